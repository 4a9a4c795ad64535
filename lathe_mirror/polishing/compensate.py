"""Pre-compensation: the finishing program's target, the design lowered by the removal a
polish takes (compensated_mirror: a cut_surface.CompensatedMirror of CompensatedLobes)."""

from __future__ import annotations

import math

import numpy as np

from ..cut_surface import CompensatedLobe, CompensatedMirror
from ..design import Lobe, Mirror
from ..profile import ExactProfile
from .evolve import polish_series, polished_design
from .lap import LapPlan, lap_plan
from .params import COMPENSATION_ITERATIONS, COMPENSATION_KNOT_MM, PolishParams

# --------------------------------------------------------------------------------------
# Pre-compensation


def compensated_mirror(mirror: Mirror, params: PolishParams, time_s: float, *,
                       plan: LapPlan | None = None, iterations: int = COMPENSATION_ITERATIONS
                       ) -> CompensatedMirror:
    """The finishing program's target: each lobe lowered by what a polish of time_s (s)
    removes, so that the polished part lands on the design.

    The allowance is this module's own prediction: first what polishing the smooth design
    for time_s removes (the lap's roll-off and the pad's response included); then
    `iterations` times the target itself is polished and what it misses the design by is
    added (the pad presses an allowance that rolls off near the pocket's wall differently
    from the roll-off it grows itself). Each allowance is a least-squares cubic spline in r
    with knots COMPENSATION_KNOT_MM apart (smooth enough for the planner's curvature; the pad
    evens out anything finer). The bands out of the pad's reach get none.
    """


    plan = lap_plan(mirror, params) if plan is None else plan
    grids = []
    for k in (0, 1):
        lo, hi = (0.0, mirror.r_junction) if k == 0 else (mirror.r_junction, mirror.r_max)
        r = np.linspace(lo, hi, int(math.ceil((hi - lo) / params.grid_step_mm)) + 1)
        if k == 1:
            r[0] = np.nextafter(lo, hi)
        grids.append(r)
    allowance = [np.zeros_like(r) for r in grids]
    target: Mirror | CompensatedMirror = mirror
    for i in range(iterations + 1):
        polished = polished_design(mirror, params, float(time_s)) if i == 0 and plan is None else \
            polish_series(ExactProfile(target), params, [time_s], plan=plan)[0]
        lobes = []
        for k, lobe in enumerate(mirror.lobes):
            r = grids[k]
            allowance[k] = allowance[k] + (np.asarray(polished.z(r)) - lobe.z(r))
            lobes.append(_compensated_lobe(lobe, r, allowance[k]))
        target = CompensatedMirror(mirror, lobes[0], lobes[1])
    return target  # type: ignore[return-value]


def _compensated_lobe(lobe: Lobe, r: np.ndarray, allowance: np.ndarray) -> CompensatedLobe:
    from scipy.interpolate import make_lsq_spline  # scipy.interpolate: only when pre-compensating

    n_in = max(int(round((r[-1] - r[0]) / COMPENSATION_KNOT_MM)) - 1, 0)
    t = np.concatenate([[r[0]] * 4, np.linspace(r[0], r[-1], n_in + 2)[1:-1], [r[-1]] * 4])
    spline = make_lsq_spline(r, allowance, t, k=3)
    return CompensatedLobe(lobe, offset_knots=tuple(float(v) for v in spline.t),
                           offset_coef=tuple(float(v) for v in spline.c))
