"""What a script calls where a command would make a choice for it, and the API's typed faces.

The commands choose some things the typed functions take as arguments: the polishing
time (the objective's choice on the made mirror's polishing curve), the trial count and
seed of a Monte Carlo (flags over `[tolerance]`) and where its trials run (`[compute]`).
These functions make the same choices with the same code, so a script and the command
line give the same numbers. `design_figures` and `distortion_figures` are the stages'
figures as typed results (`to_dict()` is the JSON the report writes).

Every argument is checked where it is given: a wrong one raises an lm.InputError whose one
line names the function and the argument.
"""

from __future__ import annotations

import contextlib
import dataclasses
from typing import TYPE_CHECKING

from .compute import Executor, active, session
from .design import Camera, Mirror
from .design_table import design_figures as design_dict
from .enums import Program, member
from .inputs import check_real, check_type
from .job import MachiningJob
from .optics.distortion import distortion_figures as distortion_dict
from .profile import Profile
from .results import DesignFigures, DistortionFigures
from .tolerance.runs import monte_carlo as run

if TYPE_CHECKING:
    from .optics.camera import CameraPose
    from .settings import Settings
    from .tolerance.montecarlo import MonteCarloResult


def design_figures(mirror: Mirror) -> DesignFigures:
    """The design's figures (Table 1's and the junction's) as a typed result; the junction's
    `step_mm` is the step's height |Mirror.step|, `recessed` the lobe it lowers."""
    check_type(mirror, "design_figures: mirror", Mirror, "a Mirror (settings.mirror())")
    return DesignFigures.from_dict(design_dict(mirror))


def distortion_figures(made: Profile, mirror: Mirror, camera: Camera | None = None, *,
                       pose: CameraPose | None = None) -> DistortionFigures:
    """The per-pixel figures of the made surface `made` (optics.distortion.image_displacement)
    per lobe, inner first; a figure with NaN pixels is given over its finite ones and counts
    them (`nan_excluded`). camera: default the mirror's; pose: a misaligned camera."""
    check_type(made, "distortion_figures: made", Profile, "a Profile (made_surface(...).profile, ExactProfile)")
    check_type(mirror, "distortion_figures: mirror", Mirror, "a Mirror (settings.mirror())")
    if camera is not None:
        check_type(camera, "distortion_figures: camera", Camera, "a Camera")
    kw = {} if pose is None else {"pose": pose}
    return DistortionFigures.from_dict(distortion_dict(made, mirror, camera, **kw))


def nominal_polish_time_s(settings: Settings, program: Program | str = Program.BEST, *,
                          mirror: Mirror | None = None, job: MachiningJob | None = None) -> float:
    """The polishing time (s) `tolerance` and `report` give a program's part: the time
    `polish.objective` chooses on the polishing curve of its as-machined mirror."""
    _check_settings("nominal_polish_time_s", settings)
    program = member(Program, program, "nominal_polish_time_s: program")
    if mirror is not None:
        check_type(mirror, "nominal_polish_time_s: mirror", Mirror, "a Mirror (settings.mirror())")
    if job is not None:
        check_type(job, "nominal_polish_time_s: job", MachiningJob, "a MachiningJob")
    from .tolerance.analysis import nominal_time_s  # lazy: the command's module, measured parts and all

    job = job or MachiningJob.from_settings(settings, mirror)
    return nominal_time_s(job, program, settings.polish)


def monte_carlo(settings: Settings, program: Program | str = Program.BEST, *, trials: int | None = None,
                seed: int | None = None, polish_time_s: float | None = None, mirror: Mirror | None = None,
                progress: bool = False) -> MonteCarloResult:
    """The seeded Monte Carlo of one program's part, as `lathe-mirror tolerance` runs it.

    trials, seed: override `[tolerance] trials` and `seed` (integers; a value out of range
    raises the InputError the config's key gets). polish_time_s: the nominal polishing time
    (s, >= 0); None chooses it as the command does (nominal_polish_time_s). The trials run
    where `settings.compute` says (workers, scheduler: a Dask address that does not answer
    is refused before any work), unless the caller has a compute.session of processes or
    Dask active. The same seed gives the same trials on any of them.
    Returns tolerance.montecarlo.MonteCarloResult (`.yield_fraction`, `.to_dict()`, `.table()`).
    """
    _check_settings("monte_carlo", settings)
    program = member(Program, program, "monte_carlo: program")
    changes = {}
    if trials is not None:
        changes["trials"] = int(check_real(trials, "monte_carlo: trials", integer=True))  # range: the key's
    if seed is not None:
        changes["seed"] = int(check_real(seed, "monte_carlo: seed", integer=True))
    if polish_time_s is not None:
        polish_time_s = check_real(polish_time_s, "monte_carlo: polish_time_s", lo=0.0, unit="s")
    if mirror is not None:
        check_type(mirror, "monte_carlo: mirror", Mirror, "a Mirror (settings.mirror())")
    check_type(progress, "monte_carlo: progress", bool, "True or False")
    if changes:
        settings = dataclasses.replace(settings, tolerance=dataclasses.replace(settings.tolerance, **changes))
    with _executor(settings):
        job = MachiningJob.from_settings(settings, mirror)
        if polish_time_s is None:
            polish_time_s = nominal_polish_time_s(settings, program, job=job)
        return run(job.mirror, settings, program, polish_time_s, progress=progress, job=job)


def _executor(settings):
    """The block's executor: the caller's compute.session if one of processes or Dask is
    active, else the one settings.compute names (as a command without --workers or
    --scheduler makes it)."""
    if type(active()) is not Executor:
        return contextlib.nullcontext()
    cfg = settings.compute
    return session(cfg.workers or None, cfg.scheduler or None)


def _check_settings(fn: str, settings) -> None:
    # Settings is above this module (settings/ builds every stage's objects): its shape
    if not all(hasattr(settings, k) for k in ("tolerance", "compute", "polish", "mirror")):
        check_type(settings, f"{fn}: settings", (), "a Settings (lm.load())")
