"""The pipeline: the house plan's arrows in order, on typed objects.

    Settings -> design -> plan toolpath -> machine (nose envelope) -> polish
             -> optics -> tolerance -> (the report lays it out; export/ writes files)

Every stage is a plain function of typed objects; this module strings them together and is
the only place that builds a made surface (`made_surface`: plan, then cut, then maybe
polish). The commands call it; `report/` only lays out what `report_figures` hands it;
`export/` only writes the models handed to it. Nothing here touches the disk.

Follow one made surface from the config to the report:

    settings = config.load("my.toml")              # typed, validated once
    mirror = design(settings)                      # Eqs. 3-6
    made = made_surface(mirror, settings.machine, settings.tool, Strategy.ARCS)
    made.profile                                   # the as-machined surface (camera frame)
    distortion_figures(made.profile, mirror)       # optics: the five figures per lobe

Millimetres and radians inside (ARCHITECTURE.md).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from .design import Mirror
from .enums import BEST, Program, Strategy, Surface
from .errors import InputError
from .finish import Process
from .lathe import Lathe, Stock, Tool
from .nose_envelope import as_machined, contour_profile
from .polishing import PolishParams, polish, polished_design
from .profile import ExactProfile, Profile
from .progress import Stages
from .toolpath import Toolpath, plan_toolpath

if TYPE_CHECKING:
    from .body import CadModel
    from .shop import ProgramOptions
    from .shop.program import Program as ShopProgramModel
    from .shop.setup import SetupSheet
    from .shop.stock import Simulation
    from .optics.polishing_curve import PolishCurve
    from .settings import Settings

#: Ranges (m) of the depth-error curve (0.5 m to 5 m).
DEPTH_RANGES_M = (0.5, 0.75, 1.0, 1.5, 2.0, 3.0, 4.0, 5.0)
#: The range (m) at which the report states the depth error of every mirror.
DEPTH_REPORT_M = 2.0
#: The mirrors compared throughout the report, in order.
MIRRORS = ("exact", "paper", "best", "polished")
#: The report's stages, in order (the progress display names them).
STAGES = ["design", "toolpaths", "polishing", "distortion", "stereo", "renders", "ranging", "tolerance"]
#: Ranges (m) and elevations (deg) of the report's resolution table.
RESOLUTION_RANGES_M = (0.5, 1.0, 1.5, 2.0, 3.0)
RESOLUTION_ELEVATIONS_DEG = (-20.0, -10.0, 0.0)


# --------------------------------------------------------------------------------------
# The arrows


def design(settings: Settings) -> Mirror:
    """Settings -> Mirror: both lobes from the camera's constants (Eqs. 3-6, Table 1)."""
    return settings.mirror()


def plan(mirror: Mirror, lathe: Lathe, tool: Tool, strategy: Strategy = BEST, *,
         max_deviation: float = 0.01, phase: float = 0.0, target: Mirror | None = None) -> Toolpath:
    """Mirror -> Toolpath on the lathe's lattice (toolpath.plan_toolpath).

    phase: where the part's Z work zero falls on the lattice, in lattice steps (0 <= phase
    < 1): the same surface cut with the zero that far off the lattice, so each phase is a
    different, equally likely realisation of the rounding (the tolerance analysis draws
    it). X stays on a lattice through the axis (its error is the tool_x tolerance).
    target: the surface the program cuts, when it is not the design: the design lowered by
    a polishing allowance (polishing.compensated_mirror; see program_target).
    """
    base = mirror if target is None else target
    planned = base if phase == 0.0 else ZeroShiftedMirror(base.camera, base.inner, base.outer,
                                                          zero_shift=phase * lathe.resolution)
    return plan_toolpath(planned, lathe, tool, strategy, max_deviation=max_deviation)


def machine(toolpath: Toolpath, nose_radius: float | None = None) -> Profile:
    """Toolpath -> the as-machined surface: the envelope of a nose of nose_radius (mm;
    default the nose the path was planned for) along the programmed moves."""
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


def made_surface(mirror: Mirror, lathe: Lathe, tool: Tool, strategy: Strategy = BEST, *,
                 nose_radius: float | None = None, phase: float = 0.0,
                 polish_params: PolishParams | None = None, polish_time_s: float = 0.0,
                 max_deviation: float = 0.01, toolpath: Toolpath | None = None,
                 target: Mirror | None = None) -> MadeSurface:
    """The one made-surface builder: plan -> machine -> (polish).

    The program is planned for `tool` (its nose offset) at lattice `phase` (steps), on
    `target` if given (a pre-compensated surface: program_target) else on the design; the
    part is cut by a nose of `nose_radius` mm (default the tool's: a worn or mis-measured
    insert differs from the programmed one); with polish_params and polish_time_s > 0 it
    is then polished for that time (s). toolpath: the program already planned with these
    arguments (a caller cutting one program with many noses plans it once).
    """
    tp = toolpath if toolpath is not None else plan(mirror, lathe, tool, strategy, max_deviation=max_deviation,
                                                    phase=phase, target=target)
    rho = tool.nose_radius if nose_radius is None else nose_radius
    profile = machine(tp, rho)
    source = f"{strategy.value} program{' (pre-compensated)' if target is not None else ''}, " \
             f"as-machined with a {rho:g} mm nose"
    if polish_params is not None and polish_time_s > 0:
        profile = polish(profile, polish_params, polish_time_s)
        source += f", polished {polish_time_s / 60:g} min"
    return MadeSurface(profile, tp, source, polish_time_s if polish_params is not None else 0.0)


def polishing_curve(profile: Profile, mirror: Mirror, params: PolishParams, *,
                    process: Process | None = None, progress: bool = False) -> PolishCurve:
    """The made surface's figures against polishing time, and the time params.objective
    chooses (optics.polishing_curve); with a resolved process (process_for) its surface
    finish too."""
    from .optics.polishing_curve import polish_curve

    return polish_curve(profile, mirror, params, process=process, progress=progress)


def process_for(settings: Settings, name: str = "conventional") -> Process:
    """The process preset `name` of [polish.process], its inherited values (0) resolved
    from [tool] nose_radius, [machine] feed_finish and resolution."""
    return settings.polish.process(name).resolved(nose_radius_mm=settings.tool.nose_radius,
                                                  feed_mm=settings.machine.feed_finish,
                                                  resolution_mm=settings.machine.resolution)


def program_target(settings: Settings, mirror: Mirror) -> Mirror:
    """The surface the finishing programs cut: the design, or with polish.precompensate the
    design lowered by the removal a polish of polish.time_s takes (polishing.
    compensated_mirror), so that the polished part lands on the design."""
    from .polishing import compensated_mirror

    params = settings.polish
    if not params.precompensate or params.time_s <= 0:
        return mirror
    return compensated_mirror(mirror, params, params.time_s)


def named_surface(name: Surface, mirror: Mirror, settings: Settings, *, nose_radius: float = 0.0) -> Profile:
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
    """
    from .optics.reference import reference_surface

    if not (nose_radius >= 0 and np.isfinite(nose_radius)):
        raise InputError(f"--nose-radius {nose_radius!r}: must be a finite number >= 0 mm")
    builtin = (Surface.EXACT, Surface.REFERENCE, Surface.UNIFORM528)
    if nose_radius > 0 and name in builtin:
        strategies = [s.value for s in Surface if s not in builtin]
        raise InputError(f"--nose-radius {nose_radius:g}: the as-machined surface needs a toolpath; use "
                         f"--surface with one of {', '.join(strategies)}")
    if name is Surface.EXACT:
        return ExactProfile(mirror)
    if name in builtin:
        return reference_surface(name.value, mirror)
    lathe, tool = settings.machine, settings.tool
    if nose_radius > 0:
        tool = dataclasses.replace(tool, nose_radius=nose_radius)
    if name is Surface.POLISHED:
        machined = made_surface(mirror, lathe, tool, Strategy.PAPER).profile
        curve = polishing_curve(machined, mirror, settings.polish)
        return curve.profiles[curve.optimum_index]
    strategy = BEST if name is Surface.BEST else Strategy(name.value)
    tp = plan(mirror, lathe, tool, strategy)
    return machine(tp) if nose_radius > 0 else contour_profile(tp)


def cad_model(settings: Settings, mirror: Mirror, *, programmed: bool,
              programmed_face_only: bool = False) -> CadModel:
    """The meridians behind every CAD file: the design's and, when asked, the programmed
    contour's on the [cad] body, with the tool-centre path (plans the [toolpath]).

    programmed_face_only: only the programmed contour is wanted (the design DXF's
    TOOLPATH layer), so it is closed on a body large enough for any program: the finishing
    pass runs a few lattice steps past the rim, and a blank exactly the mirror's diameter
    (a legitimate body for the design) must not stop the design's drawing.
    """
    from .body import MAX_LENGTH, CadModel, design_meridian, programmed_parts
    from .enums import Mount

    spec = settings.body
    design_face = design_meridian(mirror, spec)
    if not programmed:
        return CadModel(mirror, design_face, None, None, None)
    prog_spec = (dataclasses.replace(spec, blank_diameter=MAX_LENGTH, thickness=MAX_LENGTH, mount=Mount.NONE)
                 if programmed_face_only else spec)
    # The same planning as `lathe-mirror toolpath`: the config's max_deviation decides
    # whether the point budget can hold the profile, so both commands accept the same configs.
    tp = plan(mirror, settings.machine, settings.tool, settings.toolpath.strategy,
              max_deviation=settings.toolpath.max_deviation, target=program_target(settings, mirror))
    prog, centre, figures = programmed_parts(tp, mirror, prog_spec)
    return CadModel(mirror, design_face, prog, centre, figures)


def check_programs(settings: Settings, mirror: Mirror, *, tolerance: bool = True) -> None:
    """What the stages from the programs on need, checked before any file or progress
    display: a junction the toolpath can cut (an inner lobe recessed, a nose that reaches
    the wall) and polishing times the evolution can afford (tolerance=False: up to
    polishing, for `lathe-mirror polish`; True: also the Monte Carlo's longest polish, the
    curve's end plus the time tolerance)."""
    from .toolpath import check_junction

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
    from .body import design_meridian

    design_meridian(mirror, settings.body)


# --------------------------------------------------------------------------------------
# Programs a shop can run


#: Most finishing passes (the contour and the offset passes before it) a program may take.
MAX_FINISH_PASSES = 12

#: The setting error whose cost the set-up sheet states, mm.
SETTING_ERROR_MM = 0.01


@dataclass(frozen=True)
class ShopProgram:
    """A checked program (shop.program.Program), its simulation against the stock
    (shop.stock.Simulation) and its set-up sheet (shop.setup.SetupSheet)."""

    program: ShopProgramModel
    simulation: Simulation
    sheet: SetupSheet


def shop_program(toolpath: Toolpath, stock: Stock, options: ProgramOptions | None = None, *,
                 name: str | None = None, setting_costs: dict | None = None,
                 inspection: tuple = ()) -> ShopProgram:
    """The whole program around `toolpath` (shop.plan_program), simulated against the stock
    and refused (InputError, one line naming the block) if a rapid or the insert's body
    touches stock or the part, with its set-up sheet. setting_costs: what a setting error
    costs (tolerance.setting; computed if None).

    The finishing passes: as many as keep the deepest cut of each (the simulation's depth
    of cut) within options.max_finish_depth; an inside corner takes more than the offset
    step, so the count is raised from the simulated depth (at most MAX_FINISH_PASSES)."""
    import math
    from dataclasses import replace

    from .shop import ProgramOptions, plan_program
    from .shop.roughing import finish_allowances
    from .shop.setup import setup_sheet
    from .shop.stock import simulate_program
    from .tolerance.setting import setting_error_costs

    options = ProgramOptions() if options is None else options
    while True:
        program = plan_program(toolpath, stock, options, name=name or f"mirror_{toolpath.strategy.value}")
        sim = simulate_program(program)
        sim.check()
        deepest = max((op.max_depth_of_cut_mm for op in sim.operations if op.name.startswith("finish")),
                      default=0.0)
        limit = options.max_finish_depth
        if deepest <= limit + 1e-6:
            break
        n = len(finish_allowances(options)) + 1
        need = max(n + 1, math.ceil(n * deepest / limit - 1e-9))
        if need > MAX_FINISH_PASSES:
            raise InputError(f"toolpath.max_finish_depth_mm = {limit:g} mm: a finishing pass of the "
                             f"{toolpath.strategy.value} program cuts {deepest:.3f} mm deep with {n} passes; "
                             f"allowed a depth that {MAX_FINISH_PASSES} passes hold (a larger "
                             "max_finish_depth_mm or a smaller toolpath.rough_allowance)")
        options = replace(options, finish_passes=need)
    if setting_costs is None:
        setting_costs = setting_error_costs(toolpath.mirror, SETTING_ERROR_MM)
    return ShopProgram(program=program, simulation=sim,
                       sheet=setup_sheet(program, sim, setting_costs, inspection=inspection))


#: Radii the inspection table probes: every this many mm of each clear aperture, and its ends.
PROBE_STEP_MM = 2.0


def inspection_table(settings: Settings) -> tuple:
    """The set-up sheet's inspection rows (shop.setup.InspectionRow): each lobe's sag at
    every PROBE_STEP_MM of its clear aperture and at its ends, with the band its form
    tolerance allows (iso10110.spec_of)."""
    import numpy as np

    from .iso10110 import spec_of
    from .shop.setup import InspectionRow

    if settings.tolerance is None:  # no tolerance spec, no band
        return ()
    spec = spec_of(settings)
    rows = []
    for lb in spec.lobes:
        c = lb.conic
        lo, hi = c.clear_aperture
        r = np.arange(np.ceil(lo / PROBE_STEP_MM - 1e-9), np.floor(hi / PROBE_STEP_MM + 1e-9) + 1) * PROBE_STEP_MM
        r = np.unique(np.concatenate([[lo], r[(r > lo + 0.25) & (r < hi - 0.25)], [hi]]))
        for rv, s, t in zip(r, c.sag(r), c.slope(r)):
            rows.append(InspectionRow(lobe=c.name, r_mm=float(rv), z_mm=float(c.vertex_z - s), sag_mm=float(s),
                                      slope_rad=float(t), band_um=lb.form.pv_um / 2.0))
    return tuple(rows)


def shop_programs(settings: Settings, mirror: Mirror, *,
                  strategies: tuple[Strategy, ...] = (Strategy.PAPER, BEST)) -> list[ShopProgram]:
    """The checked programs of `mirror` for each strategy (default: the paper's method and
    the best), named mirror_<strategy>, with the settings' lathe, tool, stock and knobs."""
    from .shop import options_from_settings
    from .tolerance.setting import setting_error_costs

    costs = setting_error_costs(mirror, SETTING_ERROR_MM)
    options = options_from_settings(settings.toolpath)
    target = program_target(settings, mirror)  # polish.precompensate: the polish's allowance
    inspection = inspection_table(settings)
    return [shop_program(plan(mirror, settings.machine, settings.tool, strategy,
                              max_deviation=settings.toolpath.max_deviation, target=target),
                         settings.stock, options, setting_costs=costs, inspection=inspection)
            for strategy in strategies]


# --------------------------------------------------------------------------------------
# Tolerance


@dataclass
class ToleranceRuns:
    """The tolerance analysis: `figures` (JSON-ready, tolerance_analysis's dict) and every
    Monte Carlo run behind it as (run name, tolerance.montecarlo.MonteCarloResult), for the
    per-trial CSV."""

    figures: dict
    results: list


def tolerance_analysis(mirror: Mirror, settings: Settings, nominal_times_s: dict[Program, float], *,
                       progress: bool = False, allocate: tuple[Program, ...] = (),
                       target_yield: float | None = None) -> dict:
    """Monte Carlo, sensitivity and inverse sensitivity for each toleranced program
    ([tolerance] programs), each polished for its nominal time (s); the verdict of each
    against the spec; for the programs in `allocate`, the least-cost tolerances that reach
    target_yield (default tolerance.target_yield), confirmed by a fresh Monte Carlo."""
    return tolerance_runs(mirror, settings, nominal_times_s, progress=progress, allocate=allocate,
                          target_yield=target_yield).figures


def tolerance_runs(mirror: Mirror, settings: Settings, nominal_times_s: dict[Program, float], *,
                   progress: bool = False, allocate: tuple[Program, ...] = (),
                   target_yield: float | None = None) -> ToleranceRuns:
    """tolerance_analysis, keeping the Monte Carlo results (ToleranceRuns)."""
    from .tolerance.allocation import allocate as allocate_tolerances
    from .tolerance.allocation import inverse_sensitivity
    from .tolerance.montecarlo import run_monte_carlo, stereo_table
    from .tolerance.sensitivity import resolution_row, responses, sensitivity_table

    ts = settings.tolerance
    target = ts.target_yield if target_yield is None else target_yield
    out = {"spec": ts.spec_dict(), "distribution": ts.distribution.value, "tolerances": ts.tolerances,
           "cost": ts.cost, "seed": ts.seed, "trials": ts.trials, "target_yield": target,
           "seat_pivot_mm": ts.seat_pivot_mm, "lattice_phases": ts.lattice_phases,
           "nose_step_mm": ts.nose_step_mm, "programs": {}}
    results = []
    for program in ts.programs:
        ctx = tolerance_context(mirror, settings, program, nominal_times_s[program], progress=progress)
        mc = run_monte_carlo(ctx, progress=progress)
        results.append((f"{program.value}: monte carlo", mc))
        resp = responses(ctx, progress=progress)
        sens = sensitivity_table(ctx, resp)
        strategy = BEST if program is Program.BEST else Strategy.PAPER
        row = resolution_row(ctx, settings.polish, res0=settings.machine.resolution,
                             machine_at=lambda res: made_surface(
                                 mirror, dataclasses.replace(settings.machine, resolution=res), settings.tool,
                                 strategy, nose_radius=ctx.nominal_nose_mm))
        if row is not None:
            sens["rows"].insert(0, row)
        entry = {"surfaces": ctx.source, "nominal_polish_time_s": ctx.nominal_time_s, "limits": ctx.limits,
                 "monte_carlo": mc.to_dict(), "sensitivity": sens,
                 "inverse_sensitivity": inverse_sensitivity(resp, ctx.limits),
                 "stereo": stereo_table(ctx, DEPTH_RANGES_M),
                 "nose_radii_cut": len(ctx.bank.nose_mm)}
        if program in allocate:
            entry["allocation"], confirm = allocate_tolerances(ctx, resp, mc, target=target, progress=progress)
            if confirm is not None:
                results.append((f"{program.value}: allocation confirmed", confirm))
        entry["verdict"] = verdict(entry, ts.spec_dict())
        out["programs"][program.value] = entry
    return ToleranceRuns(out, results)


def monte_carlo(mirror: Mirror, settings: Settings, program: Program, nominal_time_s: float, *,
                progress: bool = False):
    """The seeded Monte Carlo of one program's part polished nominal_time_s (s): settings.
    tolerance.trials draws from its seed (tolerance.montecarlo.MonteCarloResult: the
    trials, their figures, pass flags per criterion, `.yield_fraction`)."""
    from .tolerance.montecarlo import run_monte_carlo

    return run_monte_carlo(tolerance_context(mirror, settings, program, nominal_time_s, progress=progress),
                           progress=progress)


def tolerance_context(mirror: Mirror, settings: Settings, program: Program, nominal_time_s: float, *,
                      progress: bool = False):
    """The Monte Carlo's shared context: the program's part cut at each lattice phase (and,
    as trials draw them, with each nose radius) by this module's made_surface, polished
    at the time nodes."""
    from .tolerance.montecarlo import prepare

    strategy = BEST if program is Program.BEST else Strategy.PAPER
    programs: dict[float, Toolpath] = {}

    def machine_at(phase: float, nose: float) -> MadeSurface:
        # each phase's program planned once: the noses the trials draw are all cut along
        # the program planned for the [tool] nose.
        if phase not in programs:
            programs[phase] = plan(mirror, settings.machine, settings.tool, strategy, phase=phase)
        return made_surface(mirror, settings.machine, settings.tool, strategy, nose_radius=nose,
                            toolpath=programs[phase])

    return prepare(mirror, settings.tolerance, settings.polish, nominal_time_s, program,
                   nose0=settings.tool.nose_radius, machine_at=machine_at, progress=progress)


def verdict(t: dict, spec: dict) -> dict:
    """Pass / fail of a program's nominal part against each judged limit (calibrated or raw
    figures as the spec says), its yield with the Wilson 95 % interval, and what to
    tighten when an allocation was made."""
    nominal = t["sensitivity"]["nominal"]
    fig = nominal["calibrated" if spec.get("calibrated", True) else "raw"]
    lim = t["limits"]
    checks = {
        "image_displacement_px": {"limit": lim["image_displacement_px"],
                                  "nominal": max(fig["image_displacement_px_rms"])},
        "outlier_pct": {"limit": lim["outlier_pct"], "nominal": max(fig["outlier_pct"])},
        "disparity_px": {"limit": lim["disparity_px"], "nominal": fig["disparity_px_p90"],
                         "range_m": spec["depth_range_m"], "depth_error_pct": spec["depth_error_pct"]},
        "slope_error_rad": {"limit": lim["slope_error_rad"], "nominal": max(nominal["slope_error_rad_rms"])},
    }
    for c in checks.values():
        c["pass"] = bool(c["nominal"] <= c["limit"])
    mc = t["monte_carlo"]
    out = {"checks": checks, "nominal_pass": all(c["pass"] for c in checks.values()),
           "calibrated": bool(spec.get("calibrated", True)), "yield": mc["yield"],
           "yield_wilson95": mc["yield_wilson95"], "trials": mc["trials"]}
    if "allocation" in t:
        out["allocation"] = t["allocation"]["statement"]
    return out


# --------------------------------------------------------------------------------------
# The whole report's analysis


@dataclass
class ReportData:
    """What the report shows: JSON-ready figures, the profiles compared (camera frame),
    renders (arrays) and plots (PNG bytes, filled by report.plots)."""

    figures: dict[str, Any]
    made: dict[str, Profile] = dataclasses.field(default_factory=dict)
    images: dict[str, np.ndarray] = dataclasses.field(default_factory=dict)
    curves: dict[str, Any] = dataclasses.field(default_factory=dict)
    plots: dict[str, bytes] = dataclasses.field(default_factory=dict)


def report_figures(settings: Settings, *, progress: bool = False, renders: bool = True,
                   tolerance: bool = True) -> ReportData:
    """Run every analysis stage on the settings: design, the toolpath of each strategy and
    its as-machined surface, polishing, the distortion of each made mirror, stereo depth
    error against range, renders, the tolerance analysis and the verdict. No files."""
    from .design import TABLE1_SWAP_NOTE, design_figures
    from .optics.radial import corner_limit_px, used_extent
    from .optics.stereo import depth_error_curve

    steps = Stages(STAGES, progress)
    out: dict[str, Any] = {"schema": "lathe-mirror report 1", "notes": []}
    steps.start("design")
    mirror = design(settings)
    out["design"] = design_figures(mirror)
    r_used = used_extent(mirror, 0)[1]
    facts = {"r_used": r_used, "rho_used": corner_limit_px(mirror, mirror.r_junction - r_used),
             "baseline": mirror.baseline, "angle_2m": math.degrees(mirror.baseline / 2000.0)}
    from .notes import NOTES

    out["notes"] += [TABLE1_SWAP_NOTE, *(n.format(**facts) for n in NOTES)]
    steps.done()

    steps.start("toolpaths")
    made, out["machine"], out["toolpaths"] = _strategy_table(mirror, settings)
    steps.done()

    steps.start("polishing")
    out["polishing"], polish_curves = polishing_study(settings, mirror, made, progress=progress)
    curve_paper, curve_best = polish_curves["paper"], polish_curves["best"]
    made["polished"] = curve_paper.profiles[curve_paper.optimum_index]
    steps.done()

    steps.start("distortion")
    made["exact"] = ExactProfile(mirror)
    out["mirrors"] = {name: mirror_figures(made[name], mirror) for name in MIRRORS}
    out["mirrors"]["polished"]["polish_time_s"] = curve_paper.optimum_time_s
    from .optics.camera_model import calibration_figures  # the camera models and their residuals

    out["calibration"] = calibration_figures(mirror, {n: made[n] for n in ("paper", "best", "polished")})
    steps.done()

    steps.start("stereo")
    depth = {name: depth_error_curve(made[name], mirror, DEPTH_RANGES_M) for name in MIRRORS}
    out["stereo"] = {
        "definition": "depth error = 100 (R_made - R) / R, R from the stereo centre (midway between "
                      "the viewpoints), points across the common band; RMS, median and max over the band "
                      "of |depth error| capped at 100 % per point (a point not seen by both lobes counts "
                      "100 %); failed: points at the cap",
        "baseline_mm": mirror.baseline,
        "curves": {name: c.to_dict() for name, c in depth.items()},
        f"at_{DEPTH_REPORT_M:g}_m": {name: c.at(DEPTH_REPORT_M) for name, c in depth.items()},
    }
    steps.done()

    data = ReportData(out, made=made, curves=report_curves(made, mirror))
    steps.start("renders")
    if renders:
        data.images, out["renders"] = _renders(made, mirror, settings)
    steps.done()

    steps.start("ranging")
    if renders:
        out["ranging"], data.curves["range_maps"] = ranging_figures(made, mirror, settings)
    steps.done()

    steps.start("tolerance")
    if tolerance:
        times = {Program.PAPER: curve_paper.optimum_time_s, Program.BEST: curve_best.optimum_time_s}
        out["tolerance"] = tolerance_analysis(mirror, settings, times, progress=progress,
                                              allocate=(Program.BEST,) if Program.BEST in settings.tolerance.programs
                                              else ())
        out["verdict"] = {name: t["verdict"] for name, t in out["tolerance"]["programs"].items()}
    steps.done()
    steps.close()
    return data


# --------------------------------------------------------------------------------------
# Polishing: the curve, the objective's time, form against facets, pre-compensation, processes


def polishing_study(settings: Settings, mirror: Mirror, made: dict[str, Profile], *,
                    progress: bool = False) -> tuple[dict, dict[str, PolishCurve]]:
    """The report's polishing section: both programs' polishing curves (the conventional
    process's finish on them) and the time polish.objective chooses; the form / facet
    decomposition of the polished paper mirror (and of the first model's: a fixed lap, 60
    min); pre-compensation at each program's chosen time; the process presets side by side.

    made: the as-machined "paper" and "best" parts (of the design; with polish.precompensate
    the parts cut from program_target are polished instead). Returns (JSON-ready dict,
    {"paper": curve, "best": curve}).
    """
    from .optics.polishing_curve import form_facet_decomposition, polish_summary
    from .polishing import FIRST_MODEL, lap_plan

    params = settings.polish
    process = process_for(settings)
    target = program_target(settings, mirror)
    parts = {"paper": made["paper"], "best": made["best"]}
    if target is not mirror:
        for key, strategy in (("paper", Strategy.PAPER), ("best", BEST)):
            parts[key] = made_surface(mirror, settings.machine, settings.tool, strategy, target=target).profile
    curves = {key: polishing_curve(parts[key], mirror, params, process=process, progress=progress)
              for key in ("paper", "best")}
    paper = curves["paper"]
    time_s = paper.optimum_time_s

    def decompose(surface: Profile, p: PolishParams, t: float) -> dict:
        d = form_facet_decomposition(surface, mirror, degree=p.form_degree, edge_mm=p.clear_edge_mm,
                                     range_m=p.objective_range_m, removal_only=polished_design(mirror, p, t),
                                     knot_px=p.calibration_knot_px)
        return {"time_s": t, "lap": p.lap.value, **d.to_dict()}

    first = dataclasses.replace(params, **FIRST_MODEL)
    decomposition = {
        "first_model": decompose(polish(made["paper"], first, 3600.0), first, 3600.0),
        "polished": decompose(paper.profiles[paper.optimum_index], params, time_s),
    }
    # The paper program, the one polishing rescues (the best program's figures after the
    # same study are in the README; each program costs ~1.5 s).
    precomp = {"paper": precompensation_study(mirror, settings, Strategy.PAPER, time_s,
                                              polished=paper.profiles[paper.optimum_index])}
    out = {
        "params": polish_params_dict(params),
        "model": "Preston's law dh/dt = k_p p v; the lap's kinematics give the time-averaged k_p p0 v "
                 "at each radius (polishing.LapPlan); compliant pad p = p0 max(0, 1 + d / l_c), its "
                 "surface a Gaussian-weighted local cubic fit (no ringing)",
        "lap_plan": lap_plan(mirror, params).to_dict(),
        "objective": params.objective.value,
        "paper_program": paper.to_dict(),
        "best_program": curves["best"].to_dict(),
        "summary": polish_summary(paper, "paper"),
        "summary_best": polish_summary(curves["best"], "best"),
        "decomposition": decomposition,
        "precompensation": precomp,
        "processes": process_table(settings, mirror, curves),
        "precompensated_programs": target is not mirror,
    }
    out["conclusion"] = polishing_conclusion(out)
    return out, curves


def polish_params_dict(params: PolishParams) -> dict:
    """[polish] as plain data (enums as their values, the presets as tables)."""
    d = {}
    for f in dataclasses.fields(params):
        v = getattr(params, f.name)
        if f.name == "processes":
            v = {p.name: {k: (x.value if hasattr(x, "value") else x) for k, x in p.__dict__.items() if k != "name"}
                 for p in v}
        elif hasattr(v, "value"):
            v = v.value
        d[f.name] = v
    return d


def surface_figures(profile: Profile, mirror: Mirror, params: PolishParams) -> dict:
    """What the polishing section states of a made surface: per lobe the form change and
    slope error over the clear aperture; both lobes: RMS image displacement (px), the
    calibrated stereo residual and the depth error at polish.objective_range_m (%)."""
    from .optics.calibrated_stereo import calibrated_depth_error
    from .optics.polishing_curve import CURVE_BIN_PX, clear_surface_errors, form_change
    from .optics.radial import radial_figures
    from .optics.stereo import depth_error_curve

    rng = params.objective_range_m
    form = form_change(profile, mirror, degree=params.form_degree, edge_mm=params.clear_edge_mm)
    surf = clear_surface_errors(profile, mirror, edge_mm=params.clear_edge_mm)
    rad = radial_figures(profile, mirror, bin_px=CURVE_BIN_PX)
    disp = [lb["image_displacement_px"]["rms"] for lb in rad["lobes"]]
    pix = [lb["pixels"] for lb in rad["lobes"]]
    return {
        "lobes": [{"name": f["name"], "form_change_mm": f["form_change_mm"], "form_pv_mm": f["form_pv_mm"],
                   "slope_error_rad": s_["slope_error_rad"], "normal_deviation_mm": s_["normal_deviation_mm"],
                   "image_displacement_px": r_["image_displacement_px"]}
                  for f, s_, r_ in zip(form["lobes"], surf["lobes"], rad["lobes"])],
        "image_displacement_px_rms": math.sqrt(sum(p * d * d for p, d in zip(pix, disp)) / sum(pix)),
        "stereo_residual_pct": calibrated_depth_error(profile, mirror, [rng], knot_px=params.calibration_knot_px,
                                                      clear_edge_mm=params.clear_edge_mm,
                                                      bin_px=CURVE_BIN_PX).at(rng)["rms"],
        "depth_error_pct": depth_error_curve(profile, mirror, [rng]).at(rng)["rms"],
        "range_m": rng,
    }


def precompensation_study(mirror: Mirror, settings: Settings, strategy: Strategy, time_s: float, *,
                          polished: Profile | None = None) -> dict:
    """The program's part polished time_s (s) as programmed on the design and as programmed on
    the design lowered by the allowance (polishing.compensated_mirror): the form each lands
    with (surface_figures), and the allowance itself (um, per lobe: min, max). polished: the
    program's part on the design polished time_s, if already made."""
    from .polishing import compensated_mirror

    params, lathe, tool = settings.polish, settings.machine, settings.tool
    target = compensated_mirror(mirror, params, time_s)
    plain = polished if polished is not None else \
        made_surface(mirror, lathe, tool, strategy, polish_params=params, polish_time_s=time_s).profile
    comp = made_surface(mirror, lathe, tool, strategy, polish_params=params, polish_time_s=time_s,
                        target=target).profile
    allowance = {}
    for k, lobe in enumerate(target.lobes):
        lo, hi = (0.0, mirror.r_junction) if k == 0 else (mirror.r_junction, mirror.r_max)
        off = lobe.offset(np.linspace(lo, hi, 401))
        allowance[lobe.name] = {"min_um": float(off.min() * 1e3), "max_um": float(off.max() * 1e3)}
    return {"program": strategy.value, "time_s": time_s, "allowance": allowance,
            "without": surface_figures(plain, mirror, params), "with": surface_figures(comp, mirror, params)}


def process_table(settings: Settings, mirror: Mirror, curves: dict[str, PolishCurve]) -> list[dict]:
    """The process presets side by side: turning (feed marks, roughness), the polish (the
    objective's time on the preset's program's curve) or none, and what the made surface
    gives (surface_figures; roughness, TIS and haze per lobe, optics.scatter)."""
    from .finish import feed_mark_height, feed_mark_rms
    from .optics.polishing_curve import CURVE_BIN_PX
    from .optics.scatter import haze_figures, lobe_geometry
    from .polishing import lap_plan

    params = settings.polish
    plan = lap_plan(mirror, params)
    geometry = (lobe_geometry(mirror, 0, bin_px=CURVE_BIN_PX), lobe_geometry(mirror, 1, bin_px=CURVE_BIN_PX))
    made_cache: dict[tuple, Profile] = {}
    rows = []
    for preset in params.processes:
        proc = process_for(settings, preset.name)
        strategy = BEST if proc.program is Program.BEST else Strategy.PAPER
        if proc.polish:
            curve = curves["best" if proc.program is Program.BEST else "paper"]
            t = curve.optimum_time_s
            surface = curve.profiles[curve.optimum_index]
        else:
            t = 0.0
            key = (strategy, proc.nose_radius_mm, proc.resolution_mm)
            if key not in made_cache:
                lathe = dataclasses.replace(settings.machine, resolution=proc.resolution_mm)
                tool = dataclasses.replace(settings.tool, nose_radius=proc.nose_radius_mm)
                made_cache[key] = made_surface(mirror, lathe, tool, strategy).profile
            surface = made_cache[key]
        haze = haze_figures(mirror, proc, removal_mm=(lambda k, r, t=t: plan.rate(k, r) * t) if t > 0 else None,
                            compliance_mm=params.compliance_mm, wavelength_mm=params.wavelength_mm,
                            geometry=geometry)
        turned = haze_figures(mirror, proc, removal_mm=None, compliance_mm=params.compliance_mm,
                              wavelength_mm=params.wavelength_mm, geometry=geometry)
        figs = surface_figures(surface, mirror, params)
        rows.append({
            "name": proc.name, "label": proc.label, "program": strategy.value,
            "nose_radius_mm": proc.nose_radius_mm, "feed_mm": proc.feed_mm, "resolution_mm": proc.resolution_mm,
            "feed_mark_pv_nm": feed_mark_height(proc.feed_mm, proc.nose_radius_mm) * 1e6,
            "feed_mark_rms_nm": feed_mark_rms(proc.feed_mm, proc.nose_radius_mm) * 1e6,
            "feed_mark_period_um": proc.feed_mm * 1e3,
            "polish_time_s": t,
            "as_turned": turned["lobes"],
            "finished": haze["lobes"],
            **{k: figs[k] for k in ("image_displacement_px_rms", "stereo_residual_pct", "depth_error_pct")},
            "slope_error_rad": [lb["slope_error_rad"] for lb in figs["lobes"]],
        })
    return rows


def polishing_conclusion(p: dict) -> str:
    """The polishing section's conclusion, from its figures (form against facets, the
    objective's time against image displacement's, pre-compensation)."""
    first = p["decomposition"]["first_model"]
    d1 = first["depth_error_pct"]
    rng = first["range_m"]
    s = p["summary"]
    comp = p["precompensation"]["paper"]
    chosen = s["chosen_time_s"]
    form_without = max(lb["form_change_mm"]["rms"] for lb in comp["without"]["lobes"]) * 1e3
    form_with = max(lb["form_change_mm"]["rms"] for lb in comp["with"]["lobes"]) * 1e3
    return (
        f"Facets, not form, carry the depth error. The first model's polished paper mirror (a fixed lap, "
        f"60 min) has {d1['made']['rms']:.1f} % RMS depth error at {rng:g} m; the design carrying only its "
        f"degree-{first['form_degree']} form has {d1['form']['rms']:.1f} %, the design carrying only the "
        f"facets left after the form is taken out {d1['facets']['rms']:.1f} %, the lap's removal on the "
        f"design alone {d1['removal_only']['rms']:.1f} %. The form tilts both lobes' rays alike and barely "
        f"moves the parallax; the facets survive where the removal is slow, about one pixel apart in the "
        f"image, and no calibration removes them (calibrated: facets "
        f"{first['stereo_residual_pct']['facets']['rms']:.1f} %, form {first['stereo_residual_pct']['form']['rms']:.2f} %). "
        f"So the time is chosen by {p['objective'].replace('_', ' ')} "
        f"({'the calibrated stereo residual' if p['objective'] == 'stereo' else 'as configured'}): "
        f"{chosen[p['objective']] / 60:.0f} min for the paper program, where image displacement would stop at "
        f"{chosen['image_displacement'] / 60:.0f} min (calibrated stereo residual "
        f"{s['stereo_residual_pct']['before']:.1f} -> {s['stereo_residual_pct']['at_optimum']:.2f} %). "
        f"The lap's even removal is predictable: programmed on the design lowered by it, the polished paper part "
        f"lands within {form_with:.2f} um RMS of the design's form (without: {form_without:.1f} um)."
    )


def mirror_figures(profile: Profile, mirror: Mirror) -> dict:
    """The five figures per lobe (ARCHITECTURE.md), surface and optics.

    Surface figures: toolpath.profile_errors. Optical figures: over the pixels each lobe
    images unobstructed on the exact design (optics.radial: every pixel centre, aligned
    camera; equal to optics.distortion's per-pixel figures over the usable annulus, which
    the tests check); those per-pixel figures (with the pixels the step wall vignettes
    counted too under "with_vignetted") are kept alongside under "optics_distortion".
    """
    from .optics.distortion import distortion_figures
    from .optics.radial import radial_figures
    from .toolpath import profile_errors

    surf = profile_errors(profile, mirror)
    rad = radial_figures(profile, mirror)
    full = distortion_figures(profile, mirror)
    lobes = []
    for s, o, f in zip(surf["lobes"], rad["lobes"], full["lobes"]):
        lobes.append({"name": s["name"], "slope_error_rad": s["slope_error_rad"],
                      "normal_deviation_mm": s["normal_deviation_mm"],
                      "ray_deviation_deg": o["ray_deviation_deg"],
                      "image_displacement_px": o["image_displacement_px"],
                      "viewpoint_spread_mm": o["viewpoint_spread_mm"],
                      "pixels": o["pixels"], "pixels_excluded": o["pixels_excluded"],
                      "optics_distortion": f})
    return {"lobes": lobes}


def report_curves(made: dict[str, Profile], mirror: Mirror) -> dict[str, Any]:
    """The report's curves as arrays: each made mirror's height error along the meridian
    (mm; r mm; `used` marks the radii the image uses) and its radial image displacement
    against image radius (px; NaN breaks the line where a lobe has no usable pixel)."""
    from .optics.radial import lobe_pixel_radii, radial_displacement, used_extent

    names = ("paper", "best", "polished")
    r = np.concatenate([np.linspace(0.0, mirror.r_junction, 4001),
                        np.linspace(np.nextafter(mirror.r_junction, 99.0), mirror.r_max, 3001)])
    exact_z = ExactProfile(mirror).z(r)
    used = (r <= used_extent(mirror, 0)[1]) | (r > mirror.r_junction)
    profile_error = {n: (r, made[n].z(r) - exact_z) for n in names}
    displacement = {}
    for name in names:
        rho, d = [], []
        for k in (0, 1):
            px = lobe_pixel_radii(mirror, k, bin_px=0.25)
            # NaN where radii are missing (vignetted, the lost ring): the line breaks there.
            gap = np.concatenate([[False], np.diff(px.radius_px) > 1.0])
            r_k = np.insert(px.radius_px, np.flatnonzero(gap), np.nan)
            d_k = np.insert(radial_displacement(made[name], mirror, k, px.radius_px), np.flatnonzero(gap), np.nan)
            rho += [r_k, [np.nan]]
            d += [d_k, [np.nan]]
        displacement[name] = (np.concatenate(rho), np.concatenate(d))
    return {"profile_error": profile_error, "used": used, "r_junction": mirror.r_junction,
            "displacement": displacement, "lost_ring_px": tuple(mirror.image_radii_px["lost_ring"])}


def _strategy_table(mirror: Mirror, settings: Settings):
    """As-machined profile per strategy; machine/tool table; toolpath figures per strategy."""
    from .path import Arc, Line
    from .toolpath import profile_errors

    lathe, tool = settings.machine, settings.tool
    machine_table = {"lathe": dict(lathe.__dict__),
                     "tool": {"nose_radius": tool.nose_radius,
                              "included_angle_deg": math.degrees(tool.included_angle),
                              "approach_angle_deg": math.degrees(tool.approach_angle)}}
    made, table = {}, []
    for strategy in Strategy:
        m = made_surface(mirror, lathe, tool, strategy)
        tp = m.toolpath
        table.append({"strategy": strategy.value, "best": strategy is BEST, "n_points": int(tp.n_points),
                      "moves": {"G1": sum(1 for s in tp.segments if isinstance(s, Line)),
                                "G2/G3": sum(1 for s in tp.segments if isinstance(s, Arc))},
                      "programmed": profile_errors(contour_profile(tp), mirror),
                      "as_machined": profile_errors(m.profile, mirror)})
        if strategy is Strategy.PAPER:
            made["paper"] = m.profile
        if strategy is BEST:
            made["best"] = m.profile
    return made, machine_table, table


def scene_for(settings: Settings, mirror: Mirror, *, mirror_top: float | None = None):
    """The [scene] room as a Scene, checked against the mirror (its top, mm above the
    camera: default the outer rim)."""
    from .optics.scene import build_scene

    top = float(mirror.outer.z(mirror.r_max)) if mirror_top is None else mirror_top
    return build_scene(settings.scene, mirror_top=top, mirror_radius=mirror.r_max)


def _renders(made: dict, mirror: Mirror, settings: Settings):
    """Each mirror's image of the paper's room, and each made image's difference to the exact."""
    from .optics.render import image_difference, render_image

    scene = scene_for(settings, mirror)
    images = {name: render_image(made[name], mirror, scene) for name in MIRRORS}
    stats = {name: image_difference(images[name], images["exact"]) for name in MIRRORS if name != "exact"}
    return images, {"against_exact": stats}


def ranging_figures(made: dict[str, Profile], mirror: Mirror, settings: Settings) -> tuple[dict, dict]:
    """Range from the image for each of MIRRORS (optics.ranging, the [stereo] settings,
    aligned camera): figures per mirror against the room's true range, the resolution
    table at the exact mirror's achieved disparity precision, and the range maps (m,
    arrays for the plots)."""
    from .optics.ranging.resolution import resolution_table
    from .optics.ranging.stereo import error_curve, image_mask, prepare, range_figures, stereo_range
    from .optics.ranging.truth import true_range
    from .optics.render import render_image

    st = settings.stereo
    grid, match = prepare(mirror, st.params)
    scene = scene_for(settings, mirror)
    truth = true_range(mirror, scene, grid)
    mask = image_mask(mirror, grid, match.num_disparities)
    mirrors, maps = {}, {}
    precision = math.nan
    for name in MIRRORS:  # exact first: its disparity error is the matcher's precision
        image = render_image(made[name], mirror, scene, supersample=st.supersample, pixels=mask)
        result = stereo_range(image, mirror, st.params)
        fig = range_figures(result, truth, mirror, precision_px=None if name == "exact" else precision)
        if name == "exact":
            precision = fig["disparity_error_px"]["precision"]
        fig["error_curve"] = {**error_curve(result, truth, mirror, precision), "precision_px": precision}
        mirrors[name] = fig
        maps[name] = result.range_map.range_mm / 1e3
    table = resolution_table(mirror, RESOLUTION_RANGES_M, RESOLUTION_ELEVATIONS_DEG, precision * grid.step)
    figures = {
        "definition": "range error = 100 (R - R_true) / R_true, R from the stereo centre triangulated from "
                      "StereoSGBM disparities of the two lobes' panoramas (rendered at supersample "
                      f"{st.supersample}), R_true the room along the outer lobe's pixel ray; over the common "
                      "band's pixels with a range (valid_fraction of them)",
        "supersample": st.supersample,
        "matcher_precision_px": precision,
        "resolution": table,
        "mirrors": mirrors,
    }
    maps["band_deg"] = tuple(math.degrees(x) for x in grid.band)
    return figures, maps


@dataclasses.dataclass(frozen=True)
class ZeroShiftedMirror(Mirror):
    """The design with its machine zero moved zero_shift (mm) along the axis: the planner
    puts machine Z = 0 at mirror.vertex_z, so this is the same surface cut with the work
    zero that far off the lattice."""

    zero_shift: float = 0.0

    @property
    def vertex_z(self) -> float:  # type: ignore[override]
        return self.inner.vertex_z + self.zero_shift


# --------------------------------------------------------------------------------------
# The one check of a program (issue 14, item 9)


def check_program(settings: Settings, mirror: Mirror, strategy: Strategy | Surface, *,
                  tool: Tool | None = None) -> Toolpath | None:
    """The program of `strategy` checked the same way by every command that uses one
    (toolpath, cad, render, polish, tolerance, calib, stereo, report, run), before any work
    or file: planned on the lattice within the point budget for toolpath.max_deviation
    (plan), and its as-machined surface no deeper inside the part than
    toolpath.gouge_tolerance (the check shop.plan_program makes before it writes G-code).
    A named Surface stands for the program it is cut with (polished: the paper's; exact,
    reference, uniform528: none, None returned). tool: default [tool]. Returns the
    toolpath; InputError names the setting to change."""
    from .nose_envelope import gouge_depth

    if isinstance(strategy, Surface):
        if strategy in (Surface.EXACT, Surface.REFERENCE, Surface.UNIFORM528):
            return None
        strategy = (Strategy.PAPER if strategy is Surface.POLISHED else
                    BEST if strategy is Surface.BEST else Strategy(strategy.value))
    tp = plan(mirror, settings.machine, tool or settings.tool, strategy,
              max_deviation=settings.toolpath.max_deviation,
              target=program_target(settings, mirror))  # polish.precompensate: the allowance
    depth = gouge_depth(tp)
    limit = settings.toolpath.gouge_tolerance
    if depth > limit:
        raise InputError(
            f"the {strategy.value} toolpath would gouge the part by {depth:.4f} mm "
            f"(toolpath.gouge_tolerance = {limit:g} mm); program refused "
            "(more points, a finer machine.resolution or another strategy cut closer)")
    return tp
