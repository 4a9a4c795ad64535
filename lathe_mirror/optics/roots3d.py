"""Roots of the height gap g(s) = z - Z(r) along camera rays (optics.trace3d's made
surfaces), all rays at once, mirror frame, mm: on a piecewise-linear profile a Newton
step along the chord of the current segment, its landing checked without another
evaluation; on any other profile safeguarded Newton."""

from __future__ import annotations

import numpy as np

from ..profile import Profile
from .rays import ROOT_TOL_MM
from .surface_tables import LobeTable, lobe_zs

__all__ = ["NEWTON_DG_MIN", "checked_step", "newton_loop", "newton_roots"]

#: A Newton step whose g'(s) is below this (a ray grazing the surface) is checked by a
#: second evaluation (the check without it allows a residual of the grid's rounding / g').
NEWTON_DG_MIN = 0.05


def newton_roots(profile: Profile, lobe: LobeTable, o, dx, dy, dz, dxy2, s0, lo, hi, max_iter: int = 60):
    """Roots of g(s) = z - Z(r) in [lo, hi] (g(lo) < 0 <= g(hi)) from s0 (the quadric's
    hit): s, converged, and on a polyline the grid's segment of each root and its hit
    point's (x, y, r) (else None).

    On a polyline a Newton step along the chord of the current segment (the grid merges
    collinear runs) lands on the root whenever the step stays in that segment: that is
    checked without another evaluation (checked_step). A ray whose step leaves its
    segment (about one in twenty from the quadric's hit) takes another step, from there
    or, outside its bracket, from the bracket's middle (safeguarded Newton); it stops too
    where the step or the bracket falls below ROOT_TOL_MM (at a step wall or a kink)."""
    grid = lobe.grid
    x = s0
    inb = (s0 >= lo) & (s0 <= hi)
    if not inb.all():
        x = np.where(inb, s0, 0.5 * (lo + hi))  # NaN s0: the middle
    if grid is None:
        x, conv = newton_loop(profile, lobe, o, dx, dy, dz, x, lo.copy(), hi.copy(), max_iter)
        return x, conv, None, None
    ox, oy, oz = o
    nx, conv, j, hit, below = checked_step(lobe, o, dx, dy, dz, dxy2, x, lo, hi)
    if conv.all():
        return nx, conv, j, hit
    px, py, r = hit
    act = np.nonzero(~conv)[0]  # the rays still going, and their own arrays
    ax, ay, az, a2 = dx[act], dy[act], dz[act], dxy2[act]
    xa, na, la, ha, ba = x[act], nx[act], lo[act], hi[act], below[act]
    for _ in range(max_iter):
        # the bracket from g's sign at xa; a step leaving it bisects it
        la = np.where(ba, xa, la)
        ha = np.where(ba, ha, xa)
        with np.errstate(invalid="ignore"):
            na = np.where((na >= la) & (na <= ha), na, 0.5 * (la + ha))
        done = (np.abs(na - xa) <= ROOT_TOL_MM) | (ha - la <= ROOT_TOL_MM)
        if done.any():
            d_i = act[done]
            nx[d_i] = na[done]
            conv[d_i] = True
            px[d_i], py[d_i] = ox + na[done] * ax[done], oy + na[done] * ay[done]
            r[d_i] = np.sqrt(px[d_i] ** 2 + py[d_i] ** 2)
            j[d_i] = grid.segment(np.clip(r[d_i], lobe.lo, lobe.hi))
            keep = ~done
            act, ax, ay, az, a2, na, la, ha = (v[keep] for v in (act, ax, ay, az, a2, na, la, ha))
            if act.size == 0:
                break
        xa = na
        na, ok, ja, (pa, qa, ra), ba = checked_step(lobe, o, ax, ay, az, a2, xa, la, ha)
        if ok.any():
            d_i = act[ok]
            nx[d_i], conv[d_i], j[d_i], px[d_i], py[d_i], r[d_i] = na[ok], True, ja[ok], pa[ok], qa[ok], ra[ok]
            keep = ~ok
            act, ax, ay, az, a2, xa, na, la, ha, ba = (v[keep] for v in (act, ax, ay, az, a2, xa, na, la, ha, ba))
            if act.size == 0:
                break
    return nx, conv, j, (px, py, r)


def checked_step(lobe: LobeTable, o, dx, dy, dz, dxy2, x, lo, hi):
    """One Newton step on g(s) = z - Z(r) from x along the chord of x's grid segment: the
    new s, whether it is the root (the step inside the bracket [lo, hi] (dg > 0: g < 0
    steps up, g > 0 down) landing in the segment, g' not grazing, the neglected
    second-order term of a skew ray's curving r(s) (g'' = -m r'', r'' = (|d_xy|^2 - r'^2)
    / r) moving s by less than ROOT_TOL_MM), the segment, (x, y, r) at the new s, and
    whether g < 0 at x."""
    grid = lobe.grid
    ox, oy, oz = o
    with np.errstate(invalid="ignore", divide="ignore"):
        px = x * dx
        px += ox
        py = x * dy
        py += oy
        r = px * px
        t = py * py
        r += t
        np.sqrt(r, out=r)
        rc = np.minimum(r, lobe.hi)
        np.maximum(rc, lobe.lo, out=rc)
        j = grid.segment(rc)
        m = grid.m.take(j)
        z = grid.r0.take(j)
        np.subtract(rc, z, out=z)
        z *= m
        z += grid.z0.take(j)
        g = x * dz  # the height gap g = z_ray - Z(r)
        g += oz
        g -= z
        below = g < 0
        drds = px * dx  # dr/ds
        np.multiply(py, dy, out=t)
        drds += t
        np.maximum(r, 1e-300, out=r)  # on the axis dr/ds = 0
        drds /= r
        dg = m * drds  # g'(s) = dz - m dr/ds
        np.subtract(dz, dg, out=dg)
        step = np.divide(g, dg, out=g)
        nx = x - step
        np.multiply(drds, drds, out=t)
        np.subtract(dxy2, t, out=t)
        t *= m
        t /= r
        np.abs(t, out=t)
        t *= step
        t *= step
        conv = dg >= NEWTON_DG_MIN
        conv &= t <= np.multiply(dg, 2.0 * ROOT_TOL_MM, out=dg)
        conv &= nx >= lo
        conv &= nx <= hi
        np.multiply(nx, dx, out=px)
        px += ox
        np.multiply(nx, dy, out=py)
        py += oy
        np.multiply(px, px, out=r)
        np.multiply(py, py, out=t)
        r += t
        np.sqrt(r, out=r)
        conv &= r >= grid.seg_lo.take(j)
        conv &= r < grid.seg_hi.take(j)
    return nx, conv, j, (px, py, r), below


def newton_loop(profile: Profile, lobe: LobeTable, o, dx, dy, dz, x, lo, hi, max_iter: int = 60):
    """Safeguarded Newton on g(s) = z - Z(r) from x in the brackets [lo, hi] (updated in
    place; g(lo) < 0 <= g(hi)): a step leaving the bracket bisects it. s, converged."""
    ox, oy, oz = o
    x = x.copy()
    conv = np.zeros(x.size, dtype=bool)
    act = np.arange(x.size)
    ax, ay, az = dx, dy, dz
    for _ in range(max_iter):
        xa = x[act]
        px = ox + xa * ax
        py = oy + xa * ay
        r = np.sqrt(px * px + py * py)
        z, m = lobe_zs(profile, lobe, r)
        g = oz + xa * az - z
        with np.errstate(invalid="ignore", divide="ignore"):
            drds = np.where(r > 0, (px * ax + py * ay) / r, 0.0)
            nx = xa - g / (az - m * drds)
        below = g < 0
        la = np.where(below, xa, lo[act])
        ha = np.where(below, hi[act], xa)
        nx = np.where((nx >= la) & (nx <= ha), nx, 0.5 * (la + ha))
        lo[act], hi[act], x[act] = la, ha, nx
        done = (np.abs(nx - xa) <= ROOT_TOL_MM) | (g == 0) | (ha - la <= ROOT_TOL_MM)
        conv[act[done]] = True
        keep = ~done
        act = act[keep]
        if act.size == 0:
            break
        ax, ay, az = ax[keep], ay[keep], az[keep]
    return x, conv
