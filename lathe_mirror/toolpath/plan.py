"""plan_toolpath: check the tool and the budget, run one strategy, check the result.

The strategies themselves are in paper.py, lattice.py and arcs.py (see the package doc).
"""

from __future__ import annotations

import functools
import math

from ..design import Mirror
from ..errors import InputError
from ..lathe import Lathe, Tool
from .arcs import arc_moves
from .checks import check_junction, check_reach, check_travel
from .lattice import lattice_points
from .layout import Layout
from .moves import BEST, Hand, Strategy, Toolpath
from .paper import paper_points

#: Programs kept per process (each a few hundred moves: ~5 kB pickled; the tolerance
#: analysis plans 18 lattice phases of each program).
PLANNED_KEPT = 64


def plan_toolpath(mirror: Mirror, lathe: Lathe, tool: Tool, strategy: Strategy = BEST, *,
                  max_deviation: float = 0.01) -> Toolpath:
    """Plan the finishing contour of `mirror` on `lathe` with `tool` (planned once per
    process for equal arguments: the same Toolpath is handed out again).

    max_deviation (mm): the largest normal deviation the budget must allow a polyline
    (decides "budget too small"; the config's toolpath.max_deviation).
    The hand (toolpath.Hand) follows the step: as configured, axis -> rim, when the inner
    lobe is recessed; the opposite-hand holder, rim -> axis, when the outer lobe is.
    Raises InputError when the budget cannot hold the profile within it, the nose
    cannot fit the junction, the held tool's flanks would rub the profile, or the contour
    leaves the lathe's travel.
    """
    try:
        hash((mirror, lathe, tool, strategy, max_deviation))
    except TypeError:  # a surface holding arrays (a compensated target) has no hash: plan it
        return _plan(mirror, lathe, tool, strategy, max_deviation)
    return _planned(mirror, lathe, tool, strategy, max_deviation)


def _plan(mirror: Mirror, lathe: Lathe, tool: Tool, strategy: Strategy, max_deviation: float) -> Toolpath:
    if not (isinstance(max_deviation, (int, float)) and math.isfinite(max_deviation) and max_deviation > 0):
        raise InputError(f"toolpath.max_deviation = {max_deviation!r} mm: must be a finite number > 0")
    if not isinstance(strategy, Strategy):
        raise InputError(f"strategy {strategy!r}: allowed {', '.join(s.value for s in Strategy)}")
    rho = tool.nose_radius
    hand = Hand.for_mirror(mirror)
    check_junction(mirror, tool)
    check_reach(mirror, tool, hand)
    layout = Layout(mirror, lathe, rho, past_rim=strategy is not Strategy.PAPER)
    need = layout.min_points(max_deviation)
    if lathe.max_points < need:
        raise InputError(
            f"machine.max_points = {lathe.max_points}: too small to hold the profile; lines "
            f"within {max_deviation:g} mm of it (toolpath.max_deviation) need at least {need} points"
        )
    if strategy is Strategy.PAPER:
        inner, outer = paper_points(layout, lathe)
        segs, lobes = layout.assemble_lines(inner, outer)
    elif strategy is Strategy.LATTICE:
        inner, outer = lattice_points(layout, lathe)
        segs, lobes = layout.assemble_lines(inner, outer)
    else:
        segs, lobes = arc_moves(layout, lathe)
    _check_advancing(segs, lobes, lathe, strategy)
    n_points = 1 + sum(s.n_points for s in segs)
    tp = Toolpath(strategy=strategy, lathe=lathe, tool=tool, mirror=mirror,
                  segments=tuple(segs), lobe_of=tuple(lobes), n_points=n_points, hand=hand)
    if n_points > lathe.max_points:  # a bug, not bad input: every strategy plans within it
        raise RuntimeError(f"{strategy.value}: {n_points} points exceed the budget {lathe.max_points}")
    check_travel(tp.points(), lathe, what="the finishing contour")
    return tp


#: Programs planned in this process, by their arguments (a Toolpath is never changed once
#: planned): `run` asks for the configured job's two programs about ten times (the checks,
#: the report's stages, the shop programs, the tolerance's phase 0 and sensitivity; 0.6 s
#: of CPU), and a forked worker inherits what its parent planned.
_planned = functools.lru_cache(maxsize=PLANNED_KEPT, typed=True)(_plan)


def _check_advancing(segs, lobes, lathe: Lathe, strategy: Strategy) -> None:
    """Raise InputError if a lobe's move does not advance in r: on a lattice too coarse
    for the points, rounded neighbours share a column and the contour is no z(r)."""
    for seg, lobe in zip(segs, lobes):
        if lobe != "junction" and not seg.end[0] > seg.start[0]:
            raise InputError(
                f"machine.resolution = {lathe.resolution:g} mm: too coarse for the {strategy.value} "
                f"strategy's points (two points of the {lobe} lobe share the column r = "
                f"{seg.start[0]:g} mm); use a finer resolution or fewer points (machine.max_points)"
            )
