"""Pre-compensation: the finishing program's target, the design lowered by the removal a
polish takes (compensated_mirror, CompensatedLobe)."""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, replace

import numpy as np

from ..design import Lobe, Mirror
from ..profile import ExactProfile
from .evolve import polish_series, polished_design
from .lap import LapPlan, lap_plan
from .params import COMPENSATION_ITERATIONS, COMPENSATION_KNOT_MM, PolishParams

# --------------------------------------------------------------------------------------
# Pre-compensation


@dataclass(frozen=True)
class CompensatedLobe(Lobe):
    """A lobe's sheet lowered toward the camera by a smooth allowance: z = sheet(r) - offset(r).

    offset: a cubic B-spline (knots offset_knots, coefficients offset_coef, mm) of r (mm),
    held at its end values beyond its knots. The sheet's own a, b, e, vertex_z stay the
    design's, so the machine frame (Z = 0 at the design's vertex) does not move: the program
    leaves the allowance standing above the design where the polish will take it off.
    """

    offset_knots: tuple[float, ...] = ()
    offset_coef: tuple[float, ...] = ()

    @functools.cached_property
    def _spline(self):
        from scipy.interpolate import BSpline

        return BSpline(np.asarray(self.offset_knots), np.asarray(self.offset_coef), 3)

    def _series(self, r: np.ndarray, nu: int) -> np.ndarray:
        t = self.offset_knots
        rr = np.clip(np.asarray(r, float), t[0], t[-1])
        out = self._spline(rr, nu)
        # Beyond the knots: the end value held (no slope, no curvature).
        outside = (np.asarray(r, float) < t[0]) | (np.asarray(r, float) > t[-1])
        return np.where(outside, 0.0, out) if nu else out

    def offset(self, r: np.ndarray | float) -> np.ndarray:
        """The allowance (mm, in z) at radius r (mm)."""
        return self._series(np.asarray(r, float), 0)

    def z(self, r: np.ndarray | float) -> np.ndarray:
        return super().z(r) - self._series(np.asarray(r, float), 0)

    def slope(self, r: np.ndarray | float) -> np.ndarray:
        return super().slope(r) - self._series(np.asarray(r, float), 1)

    def second_derivative(self, r: np.ndarray | float) -> np.ndarray:
        return super().second_derivative(r) - self._series(np.asarray(r, float), 2)


def compensated_mirror(mirror: Mirror, params: PolishParams, time_s: float, *,
                       plan: LapPlan | None = None, iterations: int = COMPENSATION_ITERATIONS) -> Mirror:
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
    target = mirror
    for i in range(iterations + 1):
        polished = polished_design(mirror, params, float(time_s)) if i == 0 and plan is None else \
            polish_series(ExactProfile(target), params, [time_s], plan=plan)[0]
        lobes = []
        for k, lobe in enumerate(mirror.lobes):
            r = grids[k]
            allowance[k] = allowance[k] + (np.asarray(polished.z(r)) - lobe.z(r))
            lobes.append(_compensated_lobe(lobe, r, allowance[k]))
        target = replace(mirror, inner=lobes[0], outer=lobes[1])
    return target


def _compensated_lobe(lobe: Lobe, r: np.ndarray, allowance: np.ndarray) -> CompensatedLobe:
    from scipy.interpolate import make_lsq_spline  # scipy.interpolate: only when pre-compensating

    n_in = max(int(round((r[-1] - r[0]) / COMPENSATION_KNOT_MM)) - 1, 0)
    t = np.concatenate([[r[0]] * 4, np.linspace(r[0], r[-1], n_in + 2)[1:-1], [r[-1]] * 4])
    spline = make_lsq_spline(r, allowance, t, k=3)
    fields = {f: getattr(lobe, f) for f in ("name", "r_top", "r_pixel", "h", "a", "b", "e")}
    return CompensatedLobe(**fields, offset_knots=tuple(float(v) for v in spline.t),
                           offset_coef=tuple(float(v) for v in spline.c))
