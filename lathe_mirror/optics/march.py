"""The 3-D tracer's fallback: march each ray through the mirror's height range, then
refine the first step inside the material (safeguarded Newton, bisection across the step
wall). Exact to ROOT_TOL_MM but about 60 profile evaluations per ray: optics.trace3d
sends it only the rays its closed-form path cannot decide. Mirror frame, mm."""

from __future__ import annotations

import numpy as np

from ..profile import Profile
from .rays import ROOT_TOL_MM, Fate, azimuth

#: A converged march bracket whose ends differ in height gap by more than this straddles
#: the step wall rather than a smooth root, mm.
WALL_JUMP_MM = 1e-6


def gap(profile: Profile, p: np.ndarray) -> np.ndarray:
    """z - Z(r) of points (..., 3): > 0 inside the material.

    Beyond the rim the mount continues the rim's height (z_rim), as the black annulus of
    the POV-Ray scene does, so a ray leaving the rim enters the mount, not the void.
    """
    r = np.hypot(p[..., 0], p[..., 1])
    inside = r <= profile.r_max
    g = p[..., 2] - float(profile.z(np.array(profile.r_max)))
    g[inside] = p[..., 2][inside] - profile.z(r[inside])
    return g


def march(profile: Profile, origin: np.ndarray, d: np.ndarray, z_lo: float, z_hi: float, steps: int = 16):
    """March each ray through the mirror's height range (about 23 mm) in `steps` steps,
    then refine the first step that enters the material to ROOT_TOL_MM. A camera ray near
    the axis climbs faster than any lobe, so once inside the material it stays there."""
    n = d.shape[0]
    fate = np.full(n, Fate.MISS, dtype=np.int8)
    point = np.full((n, 3), np.nan)
    out = np.full((n, 3), np.nan)
    blocked = np.zeros(n, dtype=bool)
    up = d[:, 2] > 0
    idx = np.nonzero(up)[0]
    if idx.size == 0:
        return fate, point, out, blocked
    dd = d[idx]
    s0 = np.maximum((z_lo - origin[2]) / dd[:, 2], 0.0)
    s1 = np.maximum((z_hi - origin[2]) / dd[:, 2], s0)
    frac = np.linspace(0.0, 1.0, steps + 1)
    s = s0[:, None] + (s1 - s0)[:, None] * frac[None, :]
    g = gap(profile, origin + s[..., None] * dd[:, None, :])
    inside = g >= 0
    has = inside.any(axis=1)
    first = np.argmax(inside, axis=1)
    ok = has & (first > 0)
    idx, dd, first, g = idx[ok], dd[ok], first[ok], g[ok]
    rows = np.arange(idx.size)
    sh, on_wall = _refine(profile, origin, dd, s[ok][rows, first - 1], s[ok][rows, first],
                          g[rows, first - 1], g[rows, first])
    p = origin + sh[:, None] * dd
    r = np.hypot(p[:, 0], p[:, 1])
    k = profile.lobe_index(r)
    slope = profile.slope(r)
    cx, cy = azimuth(p[:, 0], p[:, 1], r, on_axis=(0.0, 0.0))  # on the axis the normal is -z
    nvec = np.stack([slope * cx, slope * cy, -np.ones_like(r)], axis=-1)
    nvec /= np.linalg.norm(nvec, axis=-1, keepdims=True)
    o = dd - 2.0 * np.sum(dd * nvec, axis=-1, keepdims=True) * nvec
    on_mount = r > profile.r_max
    fate[idx] = np.where(on_wall, Fate.WALL, np.where(on_mount, Fate.MISS, k)).astype(np.int8)
    good = ~on_wall & ~on_mount
    point[idx[good]] = p[good]
    out[idx[good]] = o[good]
    inner = good & (k == 0)
    if inner.any():
        blocked[idx[inner]] = reflected_blocked(profile, p[inner], o[inner])
    return fate, point, out, blocked


def _refine(profile: Profile, origin: np.ndarray, d: np.ndarray, lo: np.ndarray, hi: np.ndarray,
            g_lo: np.ndarray, g_hi: np.ndarray, *, max_iter: int = 200) -> tuple[np.ndarray, np.ndarray]:
    """Ray lengths s (mm) where rays origin + s d cross the surface inside their brackets
    [lo, hi] (gap g_lo < 0 <= g_hi), and whether that crossing is the step wall.

    Safeguarded Newton on the gap g(s) = z - Z(r): dg/ds = d_z - Z'(r) dr/ds, dr/ds =
    (p_xy . d_xy) / r; a step leaving the bracket bisects it instead, so a ray whose
    crossing is the wall's jump (no smooth root) ends with a bracket narrower than
    ROOT_TOL_MM around it. The wall is where g jumps by more than WALL_JUMP_MM across
    s +- 2 ROOT_TOL_MM (a smooth root changes g by ~1e-12 mm there).
    """
    z_rim = float(profile.z(np.array(profile.r_max)))
    with np.errstate(invalid="ignore", divide="ignore"):
        x = np.clip(lo + (hi - lo) * g_lo / (g_lo - g_hi), lo, hi)  # regula falsi start
    active = np.arange(lo.size)
    for _ in range(max_iter):
        xa, da = x[active], d[active]
        p = origin + xa[:, None] * da
        r = np.hypot(p[:, 0], p[:, 1])
        on_lobe = r <= profile.r_max
        ga = p[:, 2] - z_rim  # the mount beyond the rim: flat at the rim's height
        ga[on_lobe] = p[on_lobe, 2] - profile.z(r[on_lobe])
        slope = np.zeros_like(r)
        slope[on_lobe] = profile.slope(r[on_lobe])
        dr = azimuth(p[:, 0], p[:, 1], r, on_axis=(0.0, 0.0))
        dg = da[:, 2] - slope * (dr[0] * da[:, 0] + dr[1] * da[:, 1])
        la, ha = lo[active], hi[active]
        inside = ga >= 0
        la, ha = np.where(inside, la, xa), np.where(inside, xa, ha)
        with np.errstate(invalid="ignore", divide="ignore"):
            nx = xa - ga / dg
        nx = np.where((nx > la) & (nx < ha) & np.isfinite(nx), nx, 0.5 * (la + ha))
        lo[active], hi[active], x[active] = la, ha, nx
        done = (np.abs(nx - xa) <= ROOT_TOL_MM) | (ha - la <= ROOT_TOL_MM)
        active = active[~done]
        if active.size == 0:
            break
    # A wall ray ends with a bracket of at most 2 ROOT_TOL_MM about x: look a little wider.
    step = 2 * ROOT_TOL_MM
    jump = gap(profile, origin + (x + step)[:, None] * d) - gap(profile, origin + (x - step)[:, None] * d)
    return x, jump > WALL_JUMP_MM


def reflected_blocked(profile: Profile, p: np.ndarray, o: np.ndarray, samples: int = 24) -> np.ndarray:
    """Does the reflected ray p + l o (l > 0) run into the mirror's material? (inner lobe)"""
    pxy, oxy = p[:, :2], o[:, :2]
    a = np.sum(oxy * oxy, axis=1)
    b = 2.0 * np.sum(pxy * oxy, axis=1)
    hit = np.zeros(p.shape[0], dtype=bool)
    with np.errstate(invalid="ignore", divide="ignore"):
        lams = []
        for radius in (profile.r_junction, profile.r_max):
            c = np.sum(pxy * pxy, axis=1) - radius**2
            lams.append((-b + np.sqrt(np.maximum(b * b - 4 * a * c, 0.0))) / (2 * a))
    lam_j, lam_exit = (np.where(np.isfinite(x) & (x > 0), x, 0.0) for x in lams)
    # At the junction the outer lobe's material starts at Z(r_junction+): test just past it.
    q = p + (lam_j * (1 + 1e-12) + 1e-9)[:, None] * o
    hit |= (lam_j > 0) & (gap(profile, q) > 0)
    for frac in np.arange(1, samples + 1) / samples:
        q = p + (lam_exit * frac)[:, None] * o
        hit |= (lam_exit > 0) & (gap(profile, q) > 0)
    return hit
