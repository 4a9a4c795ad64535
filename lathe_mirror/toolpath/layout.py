"""What every strategy shares: where each lobe's path starts and ends on the lattice, the
junction moves up the step wall, the split of the point budget between the lobes, and
the lattice points nearest the nose-centre curve.
"""

from __future__ import annotations

import math

import numpy as np

from ..design import Mirror
from ..lathe import Lathe
from ..path import Line, Move
from ..sheet import Target, solve_rs_for_centre_r


class Layout:
    """Where each lobe's path starts and ends on the lattice, and the junction moves."""

    def __init__(self, mirror: Mirror, lathe: Lathe, rho: float, *, past_rim: bool = True) -> None:
        self.mirror, self.lathe, self.rho = mirror, lathe, rho
        res = lathe.resolution
        zero = mirror.vertex_z
        rj = mirror.r_junction
        self.inner_recessed = mirror.step > 0
        # With a nose the outer path's last point floats to the lattice point nearest the
        # curve, up to ~1.5 steps short of the target: past_rim aims 2 steps past the rim
        # so that the nose's offset, not its side, cuts the rim's last microns (the side
        # left a 5 um band of 0.035 rad slope error). Beyond the rim is the shoulder,
        # faced at the last point's height by the exit move anyway. (The paper's method
        # keeps its target, the rim.)
        rs_rim = mirror.r_max + (2 * res if rho > 0.0 and past_rim else 0.0)
        if self.inner_recessed:
            # the nose centre's column on the wall: at or inside rj - rho (never into the wall)
            self.r_wall = math.floor((rj - rho) / res + 1e-9) * res
            rs_end = rj if rho == 0.0 else solve_rs_for_centre_r(mirror.inner, rho, self.r_wall)
            self.inner = Target(mirror.inner, zero, rho, 0.0, rs_end)
            self.outer = Target(mirror.outer, zero, rho, rj, rs_rim)
            # fixed columns of the end points: the axis, the wall; for a sharp tool also the
            # rim; with a nose the outer ends float (nearest lattice point to the target)
            self.inner_cols = (0.0, self.r_wall)
            self.outer_cols = (rj, mirror.r_max) if rho == 0.0 else (None, None)
        else:
            # The outer lobe recessed: the mirror image at the wall. The nose centre comes
            # down the wall at or outside rj + rho; the inner lobe's end floats to the
            # lattice point nearest its rim's offset point.
            self.r_wall = math.ceil((rj + rho) / res - 1e-9) * res
            rs_start = rj if rho == 0.0 else solve_rs_for_centre_r(mirror.outer, rho, self.r_wall)
            self.inner = Target(mirror.inner, zero, rho, 0.0, rj)
            self.outer = Target(mirror.outer, zero, rho, rs_start, rs_rim)
            self.inner_cols = (0.0, rj) if rho == 0.0 else (0.0, None)
            self.outer_cols = (self.r_wall, mirror.r_max) if rho == 0.0 else (self.r_wall, None)

    def targets(self) -> tuple[Target, Target]:
        return self.inner, self.outer

    def junction_extra(self) -> int:
        """Points the junction adds beyond the lobes' own end points."""
        return 0 if self.rho == 0.0 else 1

    def min_points(self, max_dev: float) -> int:
        """Points a polyline needs to stay within max_dev of both lobes (chord sag k L^2/8)."""
        total = 0
        for t in self.targets():
            kappa = np.abs(np.gradient(t.theta_tab, t.s_tab))
            total += int(math.ceil(np.trapezoid(np.sqrt(kappa / (8.0 * max_dev)), t.s_tab))) + 1
        return total + self.junction_extra()

    def assemble_lines(self, inner: np.ndarray, outer: np.ndarray) -> tuple[list, list]:
        """G1 moves through the inner points, the junction, the outer points."""
        segs: list[Move] = []
        lobes: list[str] = []
        for a, b in zip(inner[:-1], inner[1:]):
            segs.append(Line(as_point(a), as_point(b)))
            lobes.append("inner")
        segs_j = self.junction_moves(inner[-1], outer[0])
        segs += segs_j
        lobes += ["junction"] * len(segs_j)
        for a, b in zip(outer[:-1], outer[1:]):
            segs.append(Line(as_point(a), as_point(b)))
            lobes.append("outer")
        return segs, lobes

    def junction_moves(self, inner_end: np.ndarray, outer_start: np.ndarray) -> list[Move]:
        """From the inner lobe's last point over the step to the outer lobe's first.

        Sharp tool: one G1 along the wall (same column), up or down. With a nose and the
        inner lobe recessed: up the wall at the nose's column, then along the outer lobe's
        start tangent to its first point; with the outer lobe recessed, the mirror image:
        along the inner lobe's end tangent out to the nose's column, then down the wall.
        Either way the path passes the step's top corner at >= rho (a corner
        circumscribed by two tangents, the corner left sharp).
        """
        if self.rho == 0.0:
            return [Line(as_point(inner_end), as_point(outer_start))]
        res = self.lathe.resolution
        rj = self.mirror.r_junction
        if self.inner_recessed:
            s0 = float(self.mirror.outer.slope(rj))
            # the outer offset's tangent line at its start, back to the wall column; round
            # up (away from the part)
            z2 = outer_start[1] + (outer_start[0] - self.r_wall) * s0
            z2 = math.ceil(z2 / res - 1e-9) * res
            p2 = np.array([self.r_wall, z2])
            return [Line(as_point(inner_end), as_point(p2)), Line(as_point(p2), as_point(outer_start))]
        if inner_end[0] >= self.r_wall - 1e-12:  # the inner end already clears the wall
            return [Line(as_point(inner_end), as_point(outer_start))]
        s0 = float(self.mirror.inner.slope(rj))
        # the inner offset's tangent line at its end, out to the wall column (machine Z
        # falls with r at the sheet's slope); round up (away from the part)
        z2 = inner_end[1] - (self.r_wall - inner_end[0]) * s0
        z2 = math.ceil(z2 / res - 1e-9) * res
        p2 = np.array([self.r_wall, z2])
        return [Line(as_point(inner_end), as_point(p2)), Line(as_point(p2), as_point(outer_start))]


def split_budget(layout: Layout, total: int, weights) -> tuple[int, int]:
    """Points per lobe: `total` shared in proportion to `weights`, at least 2 each."""
    w = np.asarray(weights, dtype=float)
    n0 = int(round(total * w[0] / w.sum()))
    n0 = min(max(n0, 2), total - 2)
    return n0, total - n0


def lattice_candidates(t: Target, s_nom: np.ndarray, res: float, cols, k_best: int):
    """Up to k_best lattice points near each nominal vertex, those nearest the curve."""
    rs = t.rs_at_s(s_nom)
    p = t.point(rs)
    gaps = np.diff(p[:, 0])
    half = np.empty(len(s_nom))
    half[:] = np.inf
    half[:-1] = np.minimum(half[:-1], gaps)
    half[1:] = np.minimum(half[1:], gaps)
    half = np.maximum(0.4 * half, res)  # windows of neighbours never overlap
    # a lobe's end points stay at its ends (the rim must be cut to the rim)
    half[0] = min(half[0], 2 * res)
    half[-1] = min(half[-1], 2 * res)
    w = int(max(1, min(60, np.max(np.floor(half / res)))))
    offs = np.arange(-w, w + 1)
    col = np.rint(p[:, 0] / res).astype(np.int64)[:, None] + offs[None, :]
    ok = np.abs(col * res - p[:, [0]]) <= half[:, None] + 1e-12
    for i, c in ((0, cols[0]), (len(s_nom) - 1, cols[1])):
        if c is not None:
            ok[i] = col[i] == int(round(c / res))
    r = col * res
    r_safe = np.where(ok, r, p[:, [0]])
    z = t.z_at_r(np.clip(r_safe, t.r_tab[0], t.r_tab[-1]))
    zl = np.floor(z / res).astype(np.int64)
    cand_r = np.concatenate([r_safe, r_safe], axis=1)
    cand_zk = np.concatenate([zl, zl + 1], axis=1)
    cand_ok = np.concatenate([ok, ok], axis=1)
    cand_z = cand_zk * res
    d, th = t.errors(cand_r, cand_z)
    score = np.where(cand_ok, np.abs(d), np.inf)
    order = np.argsort(score, axis=1, kind="stable")[:, :k_best]
    take = lambda a: np.take_along_axis(a, order, axis=1)  # noqa: E731
    return take(cand_r), take(cand_z), take(d), take(th), np.isfinite(take(score))


def as_point(p) -> tuple[float, float]:
    return (float(p[0]), float(p[1]))
