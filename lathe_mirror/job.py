"""The machining job and the made mirror: plan -> machine (nose envelope) -> polish.

This is the only place that plans a finishing program and cuts it (`plan`, `machine`,
`made_surface`); the commands, the report and the tolerance analysis build their parts
through it. A part is planned on the lathe's lattice (at a lattice phase, on the design or
on a pre-compensated target), cut by a nose, and maybe polished.

    made = made_surface(mirror, settings.machine, settings.tool, Strategy.ARCS)
    made.profile                                   # the as-machined surface (camera frame)

Millimetres and radians inside (ARCHITECTURE.md).
"""

from __future__ import annotations

import dataclasses
import functools
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from .body import MAX_LENGTH, CadModel, design_meridian, programmed_parts
from .cut_surface import CompensatedMirror, CutSurface, ZeroShiftedMirror
from .design import Mirror
from .enums import BEST, Mount, Program, Strategy, Surface, member
from .errors import InputError, num
from .inputs import check_real, check_type
from .finish import Process
from .lathe import Lathe, Tool
from .machine_errors import MachineErrors, machined_with_errors
from .nose_envelope import as_machined, contour_profile, gouge_depth
from .optics.polishing_curve import PolishCurve, polish_curve
from .optics.reference import reference_surface
from .optics.scene import build_scene
from .polishing import PolishParams, compensated_mirror, polish
from .profile import ExactProfile, Profile
from .toolpath import Toolpath, check_junction, plan_toolpath

if TYPE_CHECKING:
    from .settings import Settings


def design(settings: Settings) -> Mirror:
    """Settings -> Mirror: both lobes from the camera's constants (Eqs. 3-6, Table 1)."""
    return settings.mirror()


def plan(mirror: Mirror, lathe: Lathe, tool: Tool, strategy: Strategy = BEST, *,
         max_deviation: float = 0.01, phase: float = 0.0, target: CompensatedMirror | None = None) -> Toolpath:
    """Mirror -> Toolpath on the lathe's lattice (toolpath.plan_toolpath).

    phase: where the part's Z work zero falls on the lattice, in lattice steps (0 <= phase
    < 1): the same surface cut with the zero that far off the lattice, so each phase is a
    different, equally likely realisation of the rounding (the tolerance analysis draws
    it). X stays on a lattice through the axis (its error is the tool_x tolerance).
    target: the surface the program cuts, when it is not the design: the design lowered by
    a polishing allowance (polishing.compensated_mirror; see program_target). The lattice
    phase holds the surface and moves its zero (cut_surface.ZeroShiftedMirror).
    """
    strategy = _plan_args("plan", mirror, lathe, tool, strategy, max_deviation, phase, target)
    base: Mirror | CompensatedMirror = mirror if target is None else target
    planned = base if phase == 0.0 else ZeroShiftedMirror(base, zero_shift=phase * lathe.resolution)
    return plan_toolpath(planned, lathe, tool, strategy, max_deviation=max_deviation)


def machine(toolpath: Toolpath, nose_radius: float | None = None) -> Profile:
    """Toolpath -> the as-machined surface: the envelope of a nose of nose_radius (mm;
    default the nose the path was planned for) along the programmed moves."""
    check_type(toolpath, "machine: toolpath", Toolpath, "a Toolpath (plan)")
    if nose_radius is not None:
        check_real(nose_radius, "machine: nose_radius", unit="mm", above=0.0)
    return as_machined(toolpath, nose_radius)


@dataclass(frozen=True)
class MadeSurface:
    """A made surface (camera frame) and where it came from.

    profile: the surface. toolpath: the program it was cut with. source: one line saying
    what it is (for the report). polish_time_s: how long it was polished (0: as machined).
    """

    profile: Profile
    toolpath: Toolpath
    source: str
    polish_time_s: float = 0.0

    def __repr__(self) -> str:
        return f"MadeSurface({self.source!r})"


def made_surface(mirror: Mirror, lathe: Lathe, tool: Tool, strategy: Strategy = BEST, *,
                 nose_radius: float | None = None, phase: float = 0.0,
                 polish_params: PolishParams | None = None, polish_time_s: float = 0.0,
                 max_deviation: float = 0.01, toolpath: Toolpath | None = None,
                 target: CompensatedMirror | None = None, errors: MachineErrors | None = None) -> MadeSurface:
    """The one made-surface builder: plan -> machine -> (polish).

    The program is planned for `tool` (its nose offset) at lattice `phase` (steps), on
    `target` if given (a pre-compensated surface: program_target) else on the design; the
    part is cut by a nose of `nose_radius` mm (default the tool's: a worn or mis-measured
    insert differs from the programmed one); with polish_params and polish_time_s > 0 it
    is then polished for that time (s). toolpath: the program already planned with these
    arguments (a caller cutting one program with many noses plans it once). errors: the
    lathe's set-up errors ([machine.errors], machine_errors.MachineErrors; None or all zero:
    a perfect machine), cut by machine_errors.machined_with_errors.
    """
    strategy = _plan_args("made_surface", mirror, lathe, tool, strategy, max_deviation, phase, target)
    if nose_radius is not None:
        check_real(nose_radius, "made_surface: nose_radius", unit="mm", above=0.0)
    if polish_params is not None:
        check_type(polish_params, "made_surface: polish_params", PolishParams, "a PolishParams (settings.polish)")
    check_real(polish_time_s, "made_surface: polish_time_s", lo=0.0, unit="s")
    if toolpath is not None:
        check_type(toolpath, "made_surface: toolpath", Toolpath, "a Toolpath (plan)")
    if errors is not None:
        check_type(errors, "made_surface: errors", MachineErrors, "a MachineErrors")
    tp = toolpath if toolpath is not None else plan(mirror, lathe, tool, strategy, max_deviation=max_deviation,
                                                    phase=phase, target=target)
    rho = tool.nose_radius if nose_radius is None else nose_radius
    source = f"{strategy.value} program{' (pre-compensated)' if target is not None else ''}, " \
             f"as-machined with a {rho:g} mm nose"
    if errors is not None and not errors.is_zero:
        profile = machined_with_errors(tp, errors, nose_radius=rho, pip_height_mm=0.15)
        source += ", on a lathe with set-up errors " + ", ".join(
            f"{k} {v:g}" for k, v in errors.to_dict().items() if v)
    else:
        profile = machine(tp, rho)
    if polish_params is not None and polish_time_s > 0:
        profile = polish(profile, polish_params, polish_time_s)
        source += f", polished {polish_time_s / 60:g} min"
    return MadeSurface(profile, tp, source, polish_time_s if polish_params is not None else 0.0)


def _plan_args(fn: str, mirror, lathe, tool, strategy, max_deviation, phase, target) -> Strategy:
    """The arguments plan and made_surface share, checked (InputError naming `fn` and the
    argument); the strategy as a Strategy (a name such as "best" taken)."""
    check_type(mirror, f"{fn}: mirror", (Mirror, CutSurface), "a Mirror (settings.mirror())")
    check_type(lathe, f"{fn}: lathe", Lathe, "a Lathe (settings.machine)")
    check_type(tool, f"{fn}: tool", Tool, "a Tool (settings.tool)")
    check_real(max_deviation, f"{fn}: max_deviation", unit="mm", above=0.0)
    if check_real(phase, f"{fn}: phase", lo=0.0) >= 1.0:
        raise InputError(f"{fn}: phase = {phase:g}: allowed 0 <= phase < 1 (lattice steps)")
    if target is not None:
        check_type(target, f"{fn}: target", CompensatedMirror, "a CompensatedMirror (program_target)")
    return member(Strategy, strategy, f"{fn}: strategy")


def polishing_curve(profile: Profile, mirror: Mirror, params: PolishParams, *,
                    process: Process | None = None, progress: bool = False) -> PolishCurve:
    """The made surface's figures against polishing time, and the time params.objective
    chooses (optics.polishing_curve); with a resolved process (process_for) its surface
    finish too."""
    check_type(profile, "polishing_curve: profile", Profile, "a Profile (made_surface(...).profile)")
    check_type(mirror, "polishing_curve: mirror", Mirror, "a Mirror (settings.mirror())")
    check_type(params, "polishing_curve: params", PolishParams, "a PolishParams (settings.polish)")
    return polish_curve(profile, mirror, params, process=process, progress=progress)


def process_for(settings: Settings, name: str = "conventional") -> Process:
    """The process preset `name` of [polish.process], its inherited values (0) resolved
    from [tool] nose_radius, [machine] feed_finish and resolution."""
    return settings.polish.process(name).resolved(nose_radius_mm=settings.tool.nose_radius,
                                                  feed_mm=settings.machine.feed_finish,
                                                  resolution_mm=settings.machine.resolution)


def program_target(settings: Settings, mirror: Mirror) -> Mirror | CompensatedMirror:
    """The surface the finishing programs cut: the design, or with polish.precompensate the
    design lowered by the removal a polish of polish.time_s takes (polishing.
    compensated_mirror), so that the polished part lands on the design."""
    params = settings.polish
    if not params.precompensate or params.time_s <= 0:
        return mirror
    return compensated_mirror(mirror, params, params.time_s)


def named_surface(name: Surface, mirror: Mirror, settings: Settings, *, nose_radius: float = 0.0,
                  measured: str | None = None, job: MachiningJob | None = None) -> Profile:
    """The surface called `name` (enums.Surface), for the commands that take --surface.

      exact       the designed hyperbolic lobes (closed form)
      reference   the paper's high-resolution model: 4001 points per lobe, 1e-6 mm
      uniform528  528 points uniform in r on the 0.005 mm lattice, straight segments
      paper, lattice, arcs, best
                  the programmed contour of that strategy for the configured [tool], or with
                  nose_radius > 0 (mm) the as-machined surface of a tool of that nose radius
                  along its own program
      polished    the paper program's as-machined surface (the [tool] nose, or
                  nose_radius) polished for its polishing curve's optimum (~2 s)
      measured    the part measured in the file `measured` (--surface measured:FILE), fitted
                  against the design (measure.surface)
      made        the configured machining job's made mirror (MachiningJob.from_settings:
                  the [toolpath] strategy cut by the [tool] nose, or nose_radius)

    job: the machining job the programs come from (default MachiningJob.from_settings).
    """
    if not (nose_radius >= 0 and np.isfinite(nose_radius)):
        raise InputError(f"--nose-radius {nose_radius!r}: must be a finite number >= 0 mm")
    builtin = (Surface.EXACT, Surface.REFERENCE, Surface.UNIFORM528, Surface.MEASURED)
    if nose_radius > 0 and name in builtin:
        strategies = [s.value for s in Surface if s not in builtin]
        raise InputError(f"--nose-radius {nose_radius:g}: the as-machined surface needs a toolpath; use "
                         f"--surface with one of {', '.join(strategies)}")
    if name is Surface.EXACT:
        return ExactProfile(mirror)
    if name is Surface.MEASURED:
        if not measured:
            raise InputError("--surface measured: name the measured file, measured:FILE")
        from .measure.surface import measured_profile  # lazy: measure.surface off the CLI's start-up path

        return measured_profile(measured, mirror, nose_radius_mm=settings.tool.nose_radius)
    if name in builtin:
        return reference_surface(name.value, mirror)
    job = job if job is not None else MachiningJob.from_settings(settings, mirror)
    if nose_radius > 0:
        job = job.but(tool=dataclasses.replace(job.tool, nose_radius=nose_radius))
    if name is Surface.MADE:
        return job.made().profile
    if name is Surface.POLISHED:
        curve = polishing_curve(job.but(strategy=Strategy.PAPER).made().profile, mirror, settings.polish)
        return curve.profiles[curve.optimum_index]
    if job.errors is not None:  # the part as the configured lathe cuts it ([machine.errors])
        return job.but(strategy=name.strategy).made().profile
    tp = job.but(strategy=name.strategy).toolpath
    return machine(tp) if nose_radius > 0 else contour_profile(tp)


def scene_for(settings: Settings, mirror: Mirror, *, mirror_top: float | None = None):
    """The [scene] room as a Scene, checked against the mirror (its top, mm above the
    camera: default the outer rim)."""
    top = float(mirror.outer.z(mirror.r_max)) if mirror_top is None else mirror_top
    return build_scene(settings.scene, mirror_top=top, mirror_radius=mirror.r_max)


def cad_model(settings: Settings, mirror: Mirror, *, programmed: bool,
              programmed_face_only: bool = False) -> CadModel:
    """The meridians behind every CAD file: the design's and, when asked, the programmed
    contour's on the [cad] body, with the tool-centre path (plans the [toolpath]).

    programmed_face_only: only the programmed contour is wanted (the design DXF's
    TOOLPATH layer), so it is closed on a body large enough for any program: the finishing
    pass runs a few lattice steps past the rim, and a blank exactly the mirror's diameter
    (a legitimate body for the design) must not stop the design's drawing.
    """
    spec = settings.body
    design_face = design_meridian(mirror, spec)
    if not programmed:
        return CadModel(mirror, design_face, None, None, None)
    prog_spec = (dataclasses.replace(spec, blank_diameter=MAX_LENGTH, thickness=MAX_LENGTH, mount=Mount.NONE)
                 if programmed_face_only else spec)
    # The same planning as `lathe-mirror toolpath`: the config's max_deviation decides
    # whether the point budget can hold the profile, so both commands accept the same configs.
    tp = MachiningJob.from_settings(settings, mirror).toolpath
    prog, centre, figures = programmed_parts(tp, mirror, prog_spec)
    return CadModel(mirror, design_face, prog, centre, figures)



def check_programs(settings: Settings, mirror: Mirror, *, tolerance: bool = True) -> None:
    """What the stages from the programs on need, checked before any file or progress
    display: a junction the toolpath can cut (an inner lobe recessed, a nose that reaches
    the wall) and polishing times the evolution can afford (tolerance=False: up to
    polishing, for `lathe-mirror polish`; True: also the Monte Carlo's longest polish, the
    curve's end plus the time tolerance)."""
    check_junction(mirror, settings.tool)
    params = settings.polish
    params.check_time(mirror.r_max, max(params.time_s, params.curve_max_s))
    if not tolerance:
        return
    tol = settings.tolerance.tolerances
    params.check_time(mirror.r_max, params.curve_max_s + tol.get("polish_time_s", 0.0))
    # The nodes span the nominal -/+ each tolerance: a nose or a controller step cannot go
    # to zero or below.
    nose0 = settings.tool.nose_radius
    if tol.get("nose_radius_mm", 0.0) > nose0:
        raise InputError(f"tolerance.params.nose_radius_mm = {tol['nose_radius_mm']:g} mm exceeds the nominal "
                         f"nose radius tool.nose_radius = {nose0:g} mm: the nose cannot be negative")
    res0 = settings.machine.resolution
    if tol.get("resolution_mm", 0.0) >= res0:
        raise InputError(f"tolerance.params.resolution_mm = {tol['resolution_mm']:g} mm must be smaller than "
                         f"machine.resolution = {res0:g} mm")


def check_cad(settings: Settings, mirror: Mirror) -> None:
    """That the [cad] body holds the designed mirror (InputError naming the key), before any
    file is written. Takes ~0.3 ms; plans no toolpath, imports no CAD kernel."""
    design_meridian(mirror, settings.body)


def check_program(settings: Settings, mirror: Mirror, strategy: Strategy | Surface | Program, *,
                  tool: Tool | None = None, target: CompensatedMirror | None = None) -> Toolpath | None:
    """The program of `strategy` checked the same way by every command that uses one
    (toolpath, cad, render, polish, tolerance, calib, stereo, report, run), before any work
    or file: MachiningJob.check on the configured job with that program (and tool: default
    [tool]). A named Surface or Program stands for the program it is cut with (polished: the
    paper's; made: the configured [toolpath] strategy; exact, reference, uniform528,
    measured: none, None returned). target: the surface the program cuts when it is not
    program_target's (a compensated re-cut: measure.compensate). Returns the toolpath;
    InputError names the setting to change."""
    job = MachiningJob.from_settings(settings, mirror)
    if isinstance(strategy, Surface) and strategy is not Surface.MADE:
        if strategy.strategy is None:
            return None
        job = job.but(strategy=strategy.strategy)
    elif isinstance(strategy, Program):
        job = job.but(strategy=strategy.strategy)
    elif isinstance(strategy, Strategy):
        job = job.but(strategy=strategy)
    if tool is not None:
        job = job.but(tool=tool)
    if target is not None:
        job = dataclasses.replace(job, target=target)
    return job.check()


def check_render_nose(settings: Settings, mirror: Mirror) -> None:
    """render.nose_radius > 0 (render --nose-radius): the render's program cut with that
    nose exists (the junction it must reach, the gouge tolerance), the refusal naming
    render.nose_radius."""
    nose = settings.render.nose_radius
    if nose <= 0:
        return
    surface = settings.render.surface
    strategy = settings.toolpath.strategy if surface is Surface.MADE else surface.strategy
    if strategy is None:
        return
    try:
        check_program(settings, mirror, strategy, tool=dataclasses.replace(settings.tool, nose_radius=nose))
    except InputError as exc:
        raise InputError(f"render.nose_radius = {num(nose)} mm: the render's program cut with that nose is "
                         f"refused: {exc}") from None


@dataclass(frozen=True)
class MachiningJob:
    """One machining job: the finishing program cut on the lathe and the part it makes.

    Built once from the settings (`from_settings`) and handed to every command, the
    report and the tolerance analysis, so the configured deviation, gouge tolerance and
    pre-compensation hold everywhere; a variant (another program, nose, lattice phase,
    resolution, polish time) is `job.but(...)`.

    mirror: the design. lathe, tool: the machine and the insert the program is planned for
    (mm). strategy: the toolpath strategy. max_deviation (mm): the largest normal deviation
    a contour may have ([toolpath]). gouge_tolerance (mm): the deepest a made point may lie
    inside the exact part. target: the surface the program cuts when it is not the design
    (polish.precompensate: program_target), else None. nose_radius (mm): the nose that
    cuts (None: the tool's; a worn or mis-measured insert differs). phase: the work zero's
    lattice phase (steps, 0 <= phase < 1). polish, polish_time_s (s): the part polished
    that long after cutting (0: as machined).
    """

    mirror: Mirror
    lathe: Lathe
    tool: Tool
    strategy: Strategy = BEST
    max_deviation: float = 0.01
    gouge_tolerance: float = 0.005
    target: CompensatedMirror | None = None
    nose_radius: float | None = None
    phase: float = 0.0
    polish: PolishParams | None = None
    polish_time_s: float = 0.0
    precompensation_s: float = 0.0
    errors: MachineErrors | None = None  # the lathe's set-up errors ([machine.errors]); None: perfect

    def __post_init__(self) -> None:
        object.__setattr__(self, "strategy", _plan_args("MachiningJob", self.mirror, self.lathe, self.tool,
                                                        self.strategy, self.max_deviation, self.phase, self.target))
        check_real(self.gouge_tolerance, "MachiningJob: gouge_tolerance", lo=0.0, unit="mm")
        if self.nose_radius is not None:
            check_real(self.nose_radius, "MachiningJob: nose_radius", unit="mm", above=0.0)
        if self.polish is not None:
            check_type(self.polish, "MachiningJob: polish", PolishParams, "a PolishParams (settings.polish)")
        for k in ("polish_time_s", "precompensation_s"):
            check_real(getattr(self, k), f"MachiningJob: {k}", lo=0.0, unit="s")
        if self.errors is not None:
            check_type(self.errors, "MachiningJob: errors", MachineErrors, "a MachineErrors")

    @classmethod
    def from_settings(cls, settings: Settings, mirror: Mirror | None = None, *,
                      strategy: Strategy | None = None) -> MachiningJob:
        """The configured job: the [toolpath] strategy (or `strategy`) planned for the [tool]
        on the [machine] within toolpath.max_deviation, on the pre-compensated target when
        polish.precompensate, cut by the [tool] nose, as machined."""
        mirror = design(settings) if mirror is None else mirror
        target = program_target(settings, mirror)
        return cls(mirror=mirror, lathe=settings.machine, tool=settings.tool,
                   strategy=settings.toolpath.strategy if strategy is None else strategy,
                   max_deviation=settings.toolpath.max_deviation,
                   gouge_tolerance=settings.toolpath.gouge_tolerance,
                   target=None if target is mirror else target, polish=settings.polish,
                   precompensation_s=settings.polish.time_s if target is not mirror else 0.0,
                   errors=None if settings.machine_errors.is_zero else settings.machine_errors)

    def but(self, *, strategy: Strategy | None = None, tool: Tool | None = None,
            nose_radius: float | None = None, phase: float | None = None,
            resolution: float | None = None, polish_time_s: float | None = None) -> MachiningJob:
        """This job with the given fields changed (resolution: the lathe's, mm)."""
        changes: dict = {}
        if strategy is not None:
            changes["strategy"] = strategy
        if tool is not None:
            changes["tool"] = tool
        if nose_radius is not None:
            changes["nose_radius"] = nose_radius
        if phase is not None:
            changes["phase"] = phase
        if resolution is not None:
            changes["lathe"] = dataclasses.replace(self.lathe, resolution=resolution)
        if polish_time_s is not None:
            changes["polish_time_s"] = polish_time_s
        new = dataclasses.replace(self, **changes)
        if "toolpath" in self.__dict__ and set(changes) <= {"nose_radius", "polish_time_s"}:
            new.__dict__["toolpath"] = self.__dict__["toolpath"]  # the same program: planned once
        return new

    @functools.cached_property
    def toolpath(self) -> Toolpath:
        """The program, planned once (plan)."""
        return plan(self.mirror, self.lathe, self.tool, self.strategy, max_deviation=self.max_deviation,
                    phase=self.phase, target=self.target)

    @property
    def cutting_nose(self) -> float:
        """The nose radius that cuts the part, mm."""
        return self.tool.nose_radius if self.nose_radius is None else self.nose_radius

    def made(self) -> MadeSurface:
        """The made surface: the program cut by the cutting nose, polished polish_time_s."""
        return made_surface(self.mirror, self.lathe, self.tool, self.strategy, nose_radius=self.cutting_nose,
                            polish_params=self.polish if self.polish_time_s > 0 else None,
                            polish_time_s=self.polish_time_s, toolpath=self.toolpath, target=self.target,
                            errors=self.errors)

    def check(self) -> Toolpath:
        """The program planned within the point budget (plan raises otherwise) and its
        as-machined surface no deeper inside the part than gouge_tolerance (the check
        shop.plan_program makes before it writes G-code). InputError names the setting."""
        tp = self.toolpath
        depth = gouge_depth(tp)
        if depth > self.gouge_tolerance:
            raise InputError(
                f"the {self.strategy.value} toolpath would gouge the part by {depth:.4f} mm "
                f"(toolpath.gouge_tolerance = {self.gouge_tolerance:g} mm); program refused "
                "(more points, a finer machine.resolution or another strategy cut closer)")
        return tp

    @property
    def label(self) -> str:
        """Which part this is, in one line: 'arcs program (best), nose 0.2 mm, lattice
        0.005 mm, as machined'."""
        parts = [f"{self.strategy.value} program{' (best)' if self.strategy is BEST else ''}",
                 f"nose {self.cutting_nose:g} mm", f"lattice {self.lathe.resolution:g} mm"]
        if self.phase:
            parts.append(f"phase {self.phase:g}")
        if self.target is not None:
            parts.append(f"pre-compensated for {self.precompensation_s / 60:g} min")
        parts.append(f"polished {self.polish_time_s / 60:g} min" if self.polish_time_s > 0 else "as machined")
        return ", ".join(parts)

    def to_dict(self) -> dict:
        """The part's identity for JSON: label, program, nose, lattice, phase, polish."""
        return {"label": self.label, "program": self.strategy.value, "nose_radius_mm": self.cutting_nose,
                "resolution_mm": self.lathe.resolution, "lattice_phase": self.phase,
                "polish_time_s": self.polish_time_s, "precompensated": self.target is not None,
                "max_deviation_mm": self.max_deviation}

    def __repr__(self) -> str:
        return f"MachiningJob({self.label!r})"


def surface_label(name: Surface, job: MachiningJob, *, nose_radius: float = 0.0) -> str:
    """Which part a named surface (named_surface) is, in one line, for every output: the
    made mirror's and a program's as-machined part by their job's label, the others by
    what they are. nose_radius (mm): as named_surface's."""
    if name is Surface.EXACT:
        return "the exact design"
    if name is Surface.MEASURED:
        return "the measured part (design + the fitted residual)"
    if name in (Surface.REFERENCE, Surface.UNIFORM528):
        return f"the paper's {name.value} model"
    if nose_radius > 0:
        job = job.but(tool=dataclasses.replace(job.tool, nose_radius=nose_radius))
    if name is Surface.MADE:
        return job.label
    if name is Surface.POLISHED:
        return job.but(strategy=Strategy.PAPER).label.replace("as machined", "polished at the curve's optimum")
    strategy = name.strategy
    if nose_radius > 0:
        return job.but(strategy=strategy).label
    return (f"{strategy.value} program{' (best)' if strategy is BEST else ''}, programmed contour "
            f"(a sharp tool), lattice {job.lathe.resolution:g} mm")
