"""What the keys cost: the time and memory of the work they set, estimated and refused
above the limits with the estimate in the message.

The limits are MEMORY_LIMIT_GIB for any piece of work and TIME_LIMIT_MIN for all of them
together (estimated on the reference machine, 2 cores: benchmarks/bench_bounds.py prints
the estimates beside measured runs); LATHE_MIRROR_MAX_GIB and LATHE_MIRROR_MAX_MINUTES
change them on another machine. On a Dask cluster (compute.scheduler, or --scheduler)
the work its workers do (the Monte Carlo's trials, the tolerance analysis' surfaces) is
counted over the cluster's threads and held to its workers' memory, asked of the scheduler
only when the local estimate would refuse; the Monte Carlo counts the runs the command
makes (`planned`: plain `tolerance` one per program, `run` and `report` two more for the
best program's allocation).
"""

from __future__ import annotations

import contextlib
import os
from contextvars import ContextVar
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

from ..design import Mirror
from ..enums import Program
from ..errors import InputError, num
from ..inputs import MEMORY_LIMIT_GIB, env_number, memory_limit
from ..nose_envelope import GRID
from ..optics.ranging.rectify import make_grid
from ..tolerance.samples import DEPTH_AZIMUTHS
from .design_checks import check_assembly_tolerances, round_in
from .keys import MAX_ROUGH_LEVELS

if TYPE_CHECKING:
    from .sections import Sections as Settings


#: Limits the estimates are held to: each piece of work's peak memory (GiB), and the time
#: of all of them together (minutes, estimated for the reference machine, 2 cores: what
#: `run`, which does every piece, would take). Environment variables LATHE_MIRROR_MAX_GIB
#: and LATHE_MIRROR_MAX_MINUTES raise (or lower) them on another machine.
TIME_LIMIT_MIN = 10.0

# Cost constants, measured on the reference machine (benchmarks/bench_bounds.py prints
# each estimate beside the measured run). Bytes are peak resident memory.
_BASE_BYTES = 160 * 2**20         # the interpreter, numpy and the stage's modules
_RENDER_PX_BYTES = 190.0          # a pixel of the render (its image and distortion maps)
_RENDER_SAMPLE_BYTES = 60.0       # each further supersample of a pixel
_RENDER_PX_S = 0.66e-6            # render: per pixel, plus per sample below
_RENDER_SAMPLE_S = 0.68e-6
_REPORT_S = 8.0                   # report/run without the tolerance analysis: 8 s, plus a pixel's
_REPORT_PX_S = 3.7e-6             # four images and distortion maps
_MC_TRIAL_S = 4.5e-4              # Monte Carlo: per trial and program, plus per ray below
_MC_RAY_S = 1.6e-6                # per sample ray (both lobes)
_MC_DEPTH_RAY_S = 1.9e-6          # per depth ray (two lobes x 4 azimuths x depth_points)
_TIME_NODES = 9                   # polishing snapshots of each surface of the tolerance analysis
_MC_TRIAL_BYTES = 3000.0          # a trial's parameters, figures and JSON, per program
_POLISH_S = 3.0                   # polishing: the curves' optics, plus per grid point and time step
_POLISH_STEP_S = 1.5e-7
_POLISH_POINT_BYTES = 32.0        # a polished snapshot, per grid point
_ENVELOPE_S = 0.37e-6             # a nose-envelope sample (vertex disc), one envelope
_ENVELOPE_USES = 7                # envelopes `toolpath` computes (as machined, gouge, fillet, G-code header)
_ENVELOPE_BYTES = 62.0
_PANORAMA_CELL_S = 2.5e-6        # ranging: a panorama cell's render, match and triangulation
_PANORAMA_CELL_BYTES = 210.0
MIRRORS_RANGED = ("exact", "paper", "best", "polished")  # the report ranges each
_DESIGN_S = 1.0e-3                # the optimiser: one design's figures and constraints
_STL_TRIANGLES = 26_000.0         # triangles of the paper mirror's STL at 0.01 mm (r_max 35 mm)
_STL_TRIANGLE_S = 1.5e-5
_STL_TRIANGLE_BYTES = 1000.0      # OCC's mesh and the STL's bytes


@dataclass(frozen=True)
class Cost:
    """An estimate of one piece of work: what it is, the keys that set it (with their
    values), its time (s, reference machine) and peak memory (bytes), and the remedy."""

    work: str
    keys: str
    seconds: float
    bytes: float
    advice: str
    alone: bool = False  # a command of its own (optimize), not part of `run`: its time alone counts
    parallel: bool = False    # done by the executor's workers: a cluster's threads share its time
    on_workers: bool = False  # its memory is also held by each worker (a cluster's: held to theirs)


#: The command being loaded and whether it allocates (commands.common.load sets it;
#: None: any command, counted as `run`).
_PLAN: ContextVar[tuple[str | None, bool]] = ContextVar("lathe_mirror_cost_plan", default=(None, False))
#: Seconds of the reference machine's 2 cores: the cluster's threads divide the work of
#: its workers by threads / REFERENCE_CORES.
REFERENCE_CORES = 2


@contextlib.contextmanager
def planned(command: str | None, *, allocate: bool = False):
    """Within the block the estimates count the Monte Carlo runs `command` makes."""
    token = _PLAN.set((command, allocate))
    try:
        yield
    finally:
        _PLAN.reset(token)


def monte_carlo_runs(programs: tuple[Program, ...], command: str | None = None, allocate: bool = False) -> int:
    """Runs of tolerance.trials trials a command makes: one per program; an allocated
    program about two more (its scans and its confirming run: measured 729 s against
    339 s for `tolerance` at 55276 trials): `run` and `report` (and any command, None)
    allocate the best program, `tolerance --allocate` every program, plain `tolerance`
    none."""
    if command == "tolerance":
        return len(programs) * (3 if allocate else 1)
    return len(programs) + (2 if Program.BEST in programs else 0)


def limits() -> tuple[float, float]:
    """(memory bytes, seconds) every estimate must stay within (see MEMORY_LIMIT_GIB)."""
    return memory_limit(), env_number("LATHE_MIRROR_MAX_MINUTES", TIME_LIMIT_MIN) * 60.0


def check_costs(settings: Settings, mirror: Mirror) -> None:
    """Refuse (one InputError line with the estimate) keys whose work cannot end in the
    limits, before any command starts it: the roughing program's levels, the polishing's
    time steps, each piece of work's estimated memory and time (estimate_costs), and
    assembly tolerances under which a lobe no longer sees its pixels."""
    _check_roughing(settings, mirror)
    params = settings.polish
    tol = settings.tolerance.tolerances if settings.tolerance else {}
    params.check_time(mirror.r_max, max(params.time_s, params.curve_max_s) + tol.get("polish_time_s", 0.0))
    costs = estimate_costs(settings, mirror)
    try:
        _check_limits(costs, None)
    except InputError:
        if not settings.compute.scheduler:
            raise
        from ..compute import cluster_capacity  # lazy: the scheduler is asked only now, after the local estimate refused

        capacity = cluster_capacity(settings.compute.scheduler)
        _check_limits(on_cluster(costs, capacity.threads), capacity.worker_memory_bytes,
                      f"the cluster's {capacity.threads} threads")
    if settings.tolerance is not None:
        check_assembly_tolerances(mirror, tol)


def _check_limits(costs: list[Cost], worker_memory: float | None, cores: str = "2 cores") -> None:
    """InputError for the first estimate over its limit: memory (a worker's on a cluster,
    worker_memory, for the work on its workers), then the time of the work a command does
    (alone) or `run`, which does every piece, does (their sum)."""
    memory, seconds = limits()
    for c in costs:
        if c.on_workers and worker_memory is not None and c.bytes > worker_memory:
            raise InputError(f"{c.keys}: {c.work} needs about {_bytes(c.bytes)} of each worker's memory, "
                             f"the cluster's least worker has {_bytes(worker_memory)}; {c.advice}")
        if c.bytes > memory:
            raise InputError(f"{c.keys}: {c.work} needs about {_bytes(c.bytes)} of memory, limit "
                             f"{_bytes(memory)} (LATHE_MIRROR_MAX_GIB); {c.advice}")
    in_run = [c for c in costs if not c.alone]
    total = sum(c.seconds for c in in_run)
    for c in costs:
        if c.alone and c.seconds > seconds:
            raise InputError(f"{c.keys}: {c.work} takes about {_duration(c.seconds)} (estimate, {cores}), "
                             f"limit {_duration(seconds)} (LATHE_MIRROR_MAX_MINUTES); {c.advice}")
    if total > seconds:
        c = max(in_run, key=lambda c: c.seconds)
        more = " (or more threads: a Dask cluster, --scheduler)" if c.parallel and worker_memory is None else ""
        raise InputError(f"{c.keys}: {c.work} takes about {_duration(c.seconds)} (estimate, {cores}; "
                         f"{_duration(total)} with the other stages), limit {_duration(seconds)} "
                         f"(LATHE_MIRROR_MAX_MINUTES); {c.advice}{more}")


def on_cluster(costs: list[Cost], threads: int) -> list[Cost]:
    """The estimates with the work of the executor's workers spread over a cluster's
    threads (the reference machine's REFERENCE_CORES did it in the estimate)."""
    scale = REFERENCE_CORES / max(threads, 1)
    return [replace(c, seconds=c.seconds * scale) if c.parallel else c for c in costs]


def estimate_costs(settings: Settings, mirror: Mirror) -> list[Cost]:
    """The estimated time and memory of the work the keys set (see Cost; constants above)."""
    costs = []
    cam, rs, st = settings.camera, settings.render, settings.stereo
    px = float(cam.sensor_px[0]) * float(cam.sensor_px[1])
    # stereo renders the common band's pixels only (image_mask): at most about half the sensor
    n2 = max(float(rs.supersample) ** 2, 1.0 + 0.5 * (float(st.supersample) ** 2 - 1.0))
    which, n = (("render.supersample", rs.supersample) if rs.supersample ** 2 >= n2 else
                ("stereo.supersample", st.supersample))
    costs.append(Cost(
        "rendering", f"camera.sensor_px = {list(cam.sensor_px)} with {which} = {n}",
        max(5.0 + px * (_RENDER_PX_S + _RENDER_SAMPLE_S * n2), _REPORT_S + px * _REPORT_PX_S),
        _BASE_BYTES + px * (_RENDER_PX_BYTES + _RENDER_SAMPLE_BYTES * (n2 - 1.0)),
        "a smaller sensor or supersample"))

    # Ranging: each of the report's four mirrors matched on the common band's panoramas.
    grid = make_grid(mirror, elevation_step=st.params.elevation_step, n_azimuth=st.params.n_azimuth)
    cells = float(grid.n_elevation) * float(grid.n_azimuth)
    costs.append(Cost(
        "ranging", f"a panorama of {grid.n_elevation} x {grid.n_azimuth} px (stereo.elevation_step_deg, "
        f"stereo.azimuth_px)", len(MIRRORS_RANGED) * cells * _PANORAMA_CELL_S,
        _BASE_BYTES + cells * _PANORAMA_CELL_BYTES, "a coarser stereo.elevation_step_deg or fewer azimuth_px"))

    # The optimiser: popsize x 6 designs a generation, at most maxiter + 1 generations.
    op = settings.optimize
    designs = float(op.popsize) * 6.0 * (op.maxiter + 1)
    costs.append(Cost(
        "the optimiser", f"optimize.popsize = {op.popsize} x 6 parameters x (optimize.maxiter = {op.maxiter} + 1) "
        f"designs over {min(op.workers, os.cpu_count() or 1)} worker(s)",
        designs * _DESIGN_S / max(1, min(op.workers, os.cpu_count() or 1)), _BASE_BYTES,
        "a smaller popsize or maxiter (or more workers on more cores)", alone=True))

    # The made surfaces: the nose envelope samples each programmed vertex's disc.
    ts = settings.tolerance
    tol = ts.tolerances if ts else {}
    rho = max(settings.tool.nose_radius + tol.get("nose_radius_mm", 0.0), rs.nose_radius)
    vertices = float(settings.machine.max_points)
    samples = vertices * (1.0 + 2.0 * rho / GRID) + mirror.r_max / GRID
    costs.append(Cost(
        "the as-machined surface (nose envelope)",
        f"machine.max_points = {settings.machine.max_points} with a nose radius of {num(rho)} mm",
        samples * _ENVELOPE_S * _ENVELOPE_USES, _BASE_BYTES + samples * _ENVELOPE_BYTES,
        "fewer points (machine.max_points) or a smaller nose"))
    machining_s = 0.05 + samples * _ENVELOPE_S  # one made surface: plan and cut

    # Polishing: the curve of both programs (report), each of its snapshots kept.
    pp = settings.polish
    grid = mirror.r_max / pp.grid_step_mm + 2.0
    steps = pp.time_steps(mirror.r_max, max(pp.time_s, pp.curve_max_s))
    costs.append(Cost(
        "polishing", f"polish.grid_step_mm = {num(pp.grid_step_mm)} mm over r_max = {num(mirror.r_max)} mm "
        f"({grid:.3g} points) x {steps:.3g} time steps, polish.curve_points = {pp.curve_points}",
        _POLISH_S + 2.0 * steps * grid * _POLISH_STEP_S,
        _BASE_BYTES + 2.0 * pp.curve_points * grid * _POLISH_POINT_BYTES,
        "a coarser polish.grid_step_mm, fewer curve_points or a shorter curve_max_s"))

    if ts is not None:
        programs = len(ts.programs)
        command, allocate = _PLAN.get()
        runs = monte_carlo_runs(tuple(ts.programs), command, allocate)
        rays = ts.azimuths * mirror.outer.r_pixel / ts.bin_px
        depth_rays = 2.0 * DEPTH_AZIMUTHS * ts.depth_points
        per_trial = _MC_TRIAL_S + _MC_RAY_S * rays + _MC_DEPTH_RAY_S * depth_rays
        costs.append(Cost(
            "the Monte Carlo",
            f"tolerance.trials = {ts.trials} x {runs} runs ({programs} programs"
            f"{'' if runs == programs else ', the allocation'}) x "
            f"({rays:.3g} sample rays (tolerance.azimuths, bin_px) + {depth_rays:.3g} depth rays "
            f"(tolerance.depth_points))",
            runs * ts.trials * per_trial, _BASE_BYTES + runs * ts.trials * _MC_TRIAL_BYTES,
            "fewer trials, azimuths or depth_points, or wider bin_px", parallel=True))
        # Each lattice phase cut with the programmed nose, and each distinct nose the trials
        # draw (rounded to nose_step_mm; a normal draw stays within about -/+ 1.5 tolerances).
        dn = tol.get("nose_radius_mm", 0.0)
        span = 1.5 * dn + min(1.5 * dn, settings.tool.nose_radius)  # a drawn nose is at least 0
        noses = min(float(ts.trials), span / ts.nose_step_mm + 1.0)
        surfaces = ts.lattice_phases + noses
        node_steps = pp.time_steps(mirror.r_max, pp.curve_max_s + tol.get("polish_time_s", 0.0))
        per_surface = machining_s + node_steps * grid * _POLISH_STEP_S
        costs.append(Cost(
            "the tolerance analysis' machined and polished surfaces",
            f"(tolerance.lattice_phases = {ts.lattice_phases} + {noses:.3g} noses (tolerance.params.nose_radius_mm "
            f"/ tolerance.nose_step_mm)) x {programs} programs, each polished in {node_steps:.3g} time steps "
            f"(polish.preston_coefficient, pressure_kpa, spindle_rpm, lap_rpm, compliance_mm)",
            programs * surfaces * per_surface,
            _BASE_BYTES + surfaces * _TIME_NODES * grid * 16.0,
            "fewer lattice_phases, a coarser nose_step_mm or polish.grid_step_mm, or a slower removal",
            parallel=True, on_workers=True))

    tri = _STL_TRIANGLES * (0.01 / settings.cad.stl_tolerance) * (mirror.r_max / 35.0)
    costs.append(Cost(
        "the STL mesh", f"cad.stl_tolerance = {num(settings.cad.stl_tolerance)} mm on a mirror of r_max = "
        f"{num(mirror.r_max)} mm ({tri:.3g} triangles)",
        1.0 + tri * _STL_TRIANGLE_S, _BASE_BYTES + tri * _STL_TRIANGLE_BYTES, "a larger cad.stl_tolerance"))
    return costs


def _check_roughing(settings: Settings, mirror: Mirror) -> None:
    """The roughing program's levels (shop.roughing plans them): a level finer than the
    lattice repeats the one before, and MAX_ROUGH_LEVELS bounds the program."""
    tp, res = settings.toolpath, settings.machine.resolution
    if tp.rough_depth < res:
        raise InputError(f"toolpath.rough_depth = {num(tp.rough_depth)} mm: allowed >= machine.resolution = "
                         f"{num(res)} mm (levels are on the lattice; a finer one repeats the one before)")
    depth = float(mirror.outer.z(mirror.r_max)) - mirror.vertex_z
    height = settings.stock.face_allowance + depth
    levels = height / tp.rough_depth
    if levels > MAX_ROUGH_LEVELS:
        raise InputError(
            f"toolpath.rough_depth = {num(tp.rough_depth)} mm gives {levels:.3g} roughing levels from the stock's "
            f"face ({num(settings.stock.face_allowance)} mm above the vertex) to the rim ({depth:.3f} mm below), "
            f"about {_bytes(100.0 * levels)} of G-code; allowed at most {MAX_ROUGH_LEVELS} levels "
            f"(rough_depth >= {_round_up(height / MAX_ROUGH_LEVELS)} mm here)")


def _bytes(b: float) -> str:
    for unit, scale in (("TiB", 2.0**40), ("GiB", 2.0**30), ("MiB", 2.0**20), ("KiB", 2.0**10)):
        if b >= scale:
            return f"{b / scale:.3g} {unit}"
    return f"{b:.0f} bytes"


def _duration(s: float) -> str:
    for unit, scale in (("days", 86400.0), ("h", 3600.0), ("min", 60.0)):
        if s >= scale:
            return f"{s / scale:.3g} {unit}"
    return f"{s:.3g} s"


def _round_up(x: float) -> str:
    return round_in(x, up=True)
