"""What a script calls where a command would make a choice for it.

The commands choose some things the typed functions take as arguments: the polishing
time (the objective's choice on the made mirror's polishing curve) and the trial count
and seed of a Monte Carlo (flags over `[tolerance]`). These functions make the same
choices with the same code, so a script and the command line give the same numbers.
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING

from .enums import Program
from .job import MachiningJob, polishing_curve
from .tolerance.runs import monte_carlo as run

if TYPE_CHECKING:
    from .design import Mirror
    from .settings import Settings
    from .tolerance.montecarlo import MonteCarloResult


def nominal_polish_time_s(settings: Settings, program: Program | str = Program.BEST, *,
                          mirror: Mirror | None = None, job: MachiningJob | None = None) -> float:
    """The polishing time (s) `tolerance` and `report` give a program's part: the time
    `polish.objective` chooses on the polishing curve of its as-machined mirror."""
    program = Program(program)
    job = job or MachiningJob.from_settings(settings, mirror)
    made = job.but(strategy=program.strategy).made()
    return polishing_curve(made.profile, job.mirror, settings.polish).optimum_time_s


def monte_carlo(settings: Settings, program: Program | str = Program.BEST, *, trials: int | None = None,
                seed: int | None = None, polish_time_s: float | None = None, mirror: Mirror | None = None,
                progress: bool = False) -> MonteCarloResult:
    """The seeded Monte Carlo of one program's part, as `lathe-mirror tolerance` runs it.

    trials, seed: override `[tolerance] trials` and `seed` (checked as the config's keys
    are: a value out of range raises the same InputError). polish_time_s: the nominal
    polishing time (s); None chooses it as the command does (nominal_polish_time_s).
    Returns tolerance.montecarlo.MonteCarloResult (`.yield_fraction`, `.to_dict()`).
    """
    program = Program(program)
    changes = {k: v for k, v in (("trials", trials), ("seed", seed)) if v is not None}
    if changes:
        settings = dataclasses.replace(settings, tolerance=dataclasses.replace(settings.tolerance, **changes))
    job = MachiningJob.from_settings(settings, mirror)
    if polish_time_s is None:
        polish_time_s = nominal_polish_time_s(settings, program, job=job)
    return run(job.mirror, settings, program, polish_time_s, progress=progress, job=job)
