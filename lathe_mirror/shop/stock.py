"""The stock simulation: the bar in (r, Z) minus the region the whole tool sweeps.

Machine frame (r, Z), mm. The tool is the insert seen in the (r, Z) plane: a rhombus of
the tool's included angle with its tip rounded to the nose radius (the nose centre at
the programmed point), its edges along the tool's flanks (lathe.Tool), its size from an
inscribed circle of INSERT_IC. Its cutting part is the nose and the flanks' first
CUTTING_EDGE_FRACTION of the edge length; the rest is the body. Geometry is shapely's:
the bar is kept as a grid of square tiles (each move only touches a few), a straight
move sweeps the convex insert into the convex hull of its two end positions, an arc is
cut into chords, and what the tool sweeps on the far side of the spindle axis (r < 0)
cuts the same material mirrored (the part turns).

Per operation it reports the material removed (area in the (r, Z) plane and volume), the
largest depth of cut (removed area per unit of path, over windows of at least STAT_WINDOW
mm; a drill, whose is its radius, how deep it drilled instead: tool_shapes.drill_figures)
and chip section (depth x feed), the largest removal rate, the time cutting, in the air and
at rapid, and the cycle time: feeds per revolution at the G96 surface speed, the spindle
capped (rpm(r) = min(cap, 1000 V / (2 pi r))), rapids at the rapid rate. It finds, and
`Simulation.check` refuses with one line naming the block: any stock or part touched at
rapid (a rapid is checked over the box its two ends span, so a controller's dog-leg rapid is
covered too), stock touched by the insert's body, a cut into the designed part deeper than
the gouge tolerance, the chuck touched.

The replay itself is shop.stock_sim's. A process keeps its last runs (RUNS_KEPT): the same
set-up and operations again return the run kept, and a first set-up that differs from the
last one only in the designed part goes on from that one's stock after their common
operations (the stock does not depend on the part; each shared operation's depth into it is
measured again). Either gives the figures and geometry of a run from the bar, bit for bit.
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import math
from typing import TYPE_CHECKING

import numpy as np

from .sim_results import Contact, OperationFigures, SimMove, SimOperation, Simulation  # noqa: F401
from .stock_sim import (AREA_TOL, BODY_TOL, CHORD, PIECE, PLUNGE_ANGLE, STAT_WINDOW, TILE,  # noqa: F401
                        StockSim, feed_time, rpm)
from .tool_shapes import (CUTTING_EDGE_FRACTION, INSERT_IC, cutting_zone, edge_length,  # noqa: F401
                          insert_outline, insert_shape, reach_toward_axis)
from .program import Feed, FeedRate, Rapid
from .resume import Resume, run_inputs
from .swept import snap_geometry

if TYPE_CHECKING:
    from ..design import Mirror
    from ..lathe import Lathe, Stock, Tool
    from .program import Program

#: The shoulder beyond the rim is not optical; a program read back from a file may face
#: it this far below where a nose leaving the rim along the lobe's slope would (mm).
SHOULDER_ALLOWANCE = 0.05
#: The chuck's jaws: from Z = -stock.length down, out to the bar's radius plus this (mm).
JAW_HEIGHT = 10.0


# --------------------------------------------------------------------------------------
# Public entry points


def simulate_program(program: Program, *, resume: Resume | None = None) -> Simulation:
    """Simulate a planned program (shop.program.Program) against its stock: the first
    set-up's bar, or (program.setup, a second set-up) the part it parted off, reversed.
    resume: see simulate_setup."""
    tp = program.toolpath
    if program.setup is not None:
        return simulate_setup(operations_of(program), program.setup.shapes, tp.lathe, program.setup.start,
                              program.setup.part, program.setup.chuck, rapid_rate=program.options.rapid_rate,
                              gouge_tolerance=program.options.gouge_tolerance, resume=resume)
    # the shoulder is where the finishing pass leaves it: its last point's nose bottom
    planned = tp.segments[-1].end[1] - tp.nose_radius
    return simulate(operations_of(program), tp.mirror, tp.held_tool, tp.lathe, program.stock,
                    rapid_rate=program.options.rapid_rate, gouge_tolerance=program.options.gouge_tolerance,
                    shoulder_z=min(planned, shoulder_height(tp.mirror, tp.tool)) - 1e-3,
                    shapes=program.shapes(), parting=program.parting, resume=resume)


def operations_of(program: Program) -> list[SimOperation]:
    """The program's operations as the simulation replays them."""
    out = []
    for op in program.operations:
        feed = op.feed
        moves = []
        for b in op.blocks:
            if isinstance(b, FeedRate):
                feed = b.feed
            elif isinstance(b, (Rapid, Feed)):
                moves.append(SimMove(rapid=isinstance(b, Rapid), move=b.move, feed=feed,
                                     label=program.describe(b)))
        out.append(SimOperation(name=op.name, station=op.station, moves=tuple(moves)))
    return out


def simulate(operations: list[SimOperation], mirror: Mirror, tool: Tool, lathe: Lathe, stock: Stock, *,
             rapid_rate: float, gouge_tolerance: float, shoulder_z: float | None = None,
             shapes: dict | None = None, parting: tuple[float, float] | None = None,
             resume: Resume | None = None) -> Simulation:
    """Replay the operations against the bar (see the module doc). rapid_rate mm/min;
    gouge_tolerance mm; shoulder_z: machine Z (mm) of the finished shoulder beyond the rim
    (default: shoulder_height(mirror, tool) - SHOULDER_ALLOWANCE). shapes: {station:
    ToolShape} (default and any other station: the insert of `tool`). parting: (Z, width)
    of a part-off (mm, the blade's chuck-side Z): the designed part ends above its slot,
    and the run ends with the part separated there (Simulation.parted) or a contact."""
    import shapely

    if shoulder_z is None:
        shoulder_z = shoulder_height(mirror, tool) - SHOULDER_ALLOWANCE
    shapes = {None: insert_shape(tool), **(shapes or {})}
    bottom = -stock.length if parting is None else parting[0] + parting[1]
    part = part_outline(mirror, stock, shoulder_z, bottom=bottom)
    r_hi = max(stock.radius, mirror.r_max) + JAW_HEIGHT
    chuck = shapely.box(0.0, -stock.length - 1000.0, r_hi, -stock.length)
    start = shapely.box(0.0, -stock.length, stock.radius, stock.face_allowance)
    return simulate_setup(operations, shapes, lathe, start, part, chuck, rapid_rate=rapid_rate,
                          gouge_tolerance=gouge_tolerance, parting=parting, resume=resume)


def simulate_setup(operations: list[SimOperation], shapes: dict, lathe: Lathe, start, part, chuck, *,
                   rapid_rate: float, gouge_tolerance: float,
                   parting: tuple[float, float] | None = None, resume: Resume | None = None) -> Simulation:
    """Replay the operations of one set-up: `start` the stock, `part` the designed part
    and `chuck` what holds it (shapely, machine (r, Z) of this set-up, mm); shapes
    {station: ToolShape}, None the default. parting: see simulate. resume (shop.resume):
    start from the state the last run it kept had before the first operation this run
    does not share with it (the same figures and contacts as from the start), and keep
    this run. A run with the same inputs and operations as one of the last RUNS_KEPT of
    this process is not replayed: its Simulation (immutable, shared) is returned."""
    inputs = run_inputs(shapes, lathe, start, part, chuck, gouge_tolerance, rapid_rate)
    kept = _kept_run(_run_key(inputs, operations, parting))
    if not kept:
        kept.append(_replay(operations, shapes, lathe, start, part, chuck, inputs, rapid_rate, gouge_tolerance,
                            parting, resume))
    sim, states, figs = kept[0]
    if resume is not None:
        resume.keep(inputs, operations, states, figs)
    return sim


#: Runs simulate_setup keeps per process (check_made, the report and the tests simulate
#: the same programs again; shop_program's re-planned run shares its first operations).
RUNS_KEPT = 16


def forget_runs() -> None:
    """Drop the runs simulate_setup keeps (a test timing or comparing fresh runs)."""
    _kept_run.cache_clear()
    _kept_stock.cache_clear()


@functools.lru_cache(maxsize=RUNS_KEPT)
def _kept_run(key: bytes) -> list:
    """The holder of the run with this key: empty until simulate_setup fills it with
    (Simulation, the states before each operation, each one's figures), none of which
    anyone mutates (frozen dataclasses, immutable geometry; a state resumes as a snapshot)."""
    return []


def _run_key(inputs: tuple, operations: list, parting) -> bytes:
    """A run's inputs and operations as bytes (repr: every float exactly, -0.0 too)."""
    return hashlib.sha256(repr((inputs, tuple(operations), parting)).encode()).digest()


@functools.lru_cache(maxsize=RUNS_KEPT)
def _kept_stock(key: bytes) -> list:
    """The holder of the last run (operations, states, figures) of these inputs but the
    designed part (_stock_key), empty before it."""
    return []


def _stock_key(inputs: tuple) -> bytes:
    """A run's inputs but the designed part (run_inputs' fourth), as bytes."""
    return hashlib.sha256(repr(inputs[:3] + inputs[4:]).encode()).digest()


def _shared_stock(inputs: tuple, operations: list, part) -> tuple | None:
    """The state from which a run of these inputs goes on from the last one of the same
    stock, tools and chuck against another designed part (the paper method's and the arc
    method's first set-ups share the face and the roughing): the stock after their common
    operations is the same whatever the part, and so are those operations' figures but the
    depth into the part (StockSim.part_cut, measured again). None: nothing in common, or a
    contact in it (a replay places it among the others). Returns (operations shared, the
    state to go on from, the states before each shared one, their figures)."""
    held = _kept_stock(_stock_key(inputs))
    if not held:
        return None
    ops, states, figs = held[0]
    k, n = 0, min(len(operations), len(ops), len(states) - 1)
    while k < n and operations[k] == ops[k]:
        k += 1
    if k == 0 or states[k].contacts:
        return None
    sim = states[k].with_part(part)
    new_figs = []
    for op, fig in zip(operations[:k], figs):
        cut = sim.part_cut(op)
        if cut is None:
            return None
        new_figs.append(dataclasses.replace(fig, max_part_cut_mm=cut))
    return k, sim, [s.with_part(part) for s in states[:k]], new_figs


def _replay(operations, shapes, lathe, start, part, chuck, inputs, rapid_rate, gouge_tolerance, parting,
            resume) -> tuple:
    """simulate_setup's run, from the state resume kept before its first operation that
    differs (from the bar when none): (Simulation, states, figures)."""
    k0 = 0 if resume is None else resume.common(inputs, operations)
    k0 = min(k0, len(resume.states) - 1) if k0 else 0  # a run the kept one ends within: its last one again
    shared = None if k0 else _shared_stock(inputs, operations, snap_geometry(part))
    if k0 > 0:
        sim = resume.states[k0].snapshot()
        figs, states = list(resume.figures[:k0]), list(resume.states[:k0])
    elif shared is not None:
        k0, sim, states, figs = shared
    else:
        figs, states = [], []
        sim = StockSim(shapes, lathe, *(snap_geometry(g) for g in (start, part, chuck)), gouge_tolerance)
    for op in operations[k0:]:
        states.append(sim.snapshot())
        figs.append(sim.operation(op, rapid_rate))
    _kept_stock(_stock_key(inputs))[:] = [(list(operations), states, figs)]
    parted = None
    if parting is not None:
        parted = sim.separate(*parting)
    return (Simulation(operations=tuple(figs), contacts=tuple(sim.contacts), stock_start=start, part=part,
                       diameter_mode=lathe.diameter_mode, parted=parted), states, figs)


def shoulder_height(mirror: Mirror, tool: Tool) -> float:
    """Machine Z (mm) of the shoulder a nose leaves leaving the rim on the lobe's offset:
    the rim's height less rho (1 - cos(slope angle))."""
    s = float(mirror.outer.slope(mirror.r_max))
    return float(mirror.vertex_z - mirror.outer.z(mirror.r_max)) - tool.nose_radius * (1 - 1 / math.hypot(1.0, s))


def part_outline(mirror: Mirror, stock: Stock, shoulder_z: float, *, spacing: float = 0.05,
                 bottom: float | None = None):
    """The designed part in (r, Z), mm: under the inner lobe, up the step wall, under
    the outer lobe to the rim, the shoulder at shoulder_z out to the bar, down to
    `bottom` (default -stock.length; a part-off's slot top). Chords every `spacing` mm lie inside the lobes (sag < 2e-5 mm on the
    paper mirror)."""
    import shapely

    rj, rm, z0 = mirror.r_junction, mirror.r_max, mirror.vertex_z
    ri = np.linspace(0.0, rj, max(2, int(math.ceil(rj / spacing)) + 1))
    ro = np.linspace(rj, rm, max(2, int(math.ceil((rm - rj) / spacing)) + 1))
    zi = z0 - mirror.inner.z(ri)
    zo = z0 - mirror.outer.z(ro)
    bottom = -stock.length if bottom is None else bottom
    z_sh = min(float(shoulder_z), float(zo[-1]))
    pts = ([(0.0, bottom)] + list(zip(ri, zi)) + list(zip(ro, zo))
           + [(rm, z_sh), (max(stock.radius, rm), z_sh), (max(stock.radius, rm), bottom)])
    return shapely.Polygon(pts).buffer(0)
