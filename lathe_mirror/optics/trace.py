"""Exact ray tracing of camera rays off a mirror surface of revolution (any Profile).

Two paths, one answer:

* Meridian (2-D), for the aligned camera. Every pixel's ray lies in the meridian plane
  through the axis and the pixel, r = t z with t = rho * t_pixel / f (rho the pixel's
  image radius, px). It meets the profile where h(r) = t Z(r) - r = 0; h is strictly
  decreasing on a lobe whenever t * Z'(r) < 1 (the ray is steeper than the surface, true
  for every lobe a camera at the outer focus can see), so each lobe has at most one root:
    - exact lobes: closed form. With r = t z in (z - e)^2 / a^2 - r^2 / b^2 = 1 and
      A = 1 - t^2 a^2 / b^2:  A z^2 - 2 e z + b^2 = 0, upper sheet z = b^2 / (e - a sqrt(1 + t^2)),
      the stable form of (e + sqrt(e^2 - A b^2)) / A;
    - polylines (the paper's 528 points): closed form per segment, z = z_j + m (r - r_j)
      gives r = t (z_j - m r_j) / (1 - t m); the segment is found by a binary search on
      the vertices' r / z (increasing along a lobe for the same reason h is monotone);
    - any other Profile (arcs, as-machined, polished): bracketed, safeguarded Newton on
      h(r), vectorised, to 1e-12 mm.
* General (3-D), for a misaligned camera: march along each ray to bracket the first point
  inside the material (z > Z(r)), then bisect to 1e-12 mm.

The step between the lobes is a vertical wall at r_junction. A camera ray that reaches
r_junction inside the material hits the wall (Fate.WALL: the lost ring of the image); a
ray past the outer rim misses the mirror (Fate.MISS). A reflected ray that leaves the
recessed inner lobe and meets the wall or the outer lobe is `blocked` (vignetted).

Frames and units: camera frame (pinhole at the origin, +z up the axis), mm.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import IntEnum

import numpy as np

from ..design import Camera, Lobe
from ..profile import ExactProfile, PolylineProfile, Profile

try:  # the toolpath issue's profiles: tool-nose envelopes and programmed moves
    from ..profile import PathProfile, TabulatedProfile
except ImportError:  # pragma: no cover
    PathProfile = TabulatedProfile = None
from .camera import ALIGNED, CameraPose, ray_directions

#: Newton / bisection stop: change of r (meridian) or ray length s (3-D) below this, mm.
ROOT_TOL_MM = 1e-12
#: A converged 3-D bracket whose ends differ in height gap by more than this straddles the
#: step wall rather than a smooth root, mm.
WALL_JUMP_MM = 1e-6


class Fate(IntEnum):
    """Where a camera ray ends on the mirror."""

    INNER = 0  # reflected by the inner lobe
    OUTER = 1  # reflected by the outer lobe
    WALL = 2   # hits the step wall between the lobes (lost ring)
    MISS = 3   # passes the outer rim: sees the mirror's mount, not the mirror


@dataclass(frozen=True)
class MeridianHits:
    """Camera rays r = t z meeting a profile in their meridian plane. mm.

    t: tan of each ray's angle off the axis. fate: Fate codes. r, z: hit point (NaN unless
    a lobe). out_r, out_z: unit reflected direction in the meridian plane (NaN unless a
    lobe). blocked: the reflected ray runs into the mirror itself.
    """

    t: np.ndarray
    fate: np.ndarray
    r: np.ndarray
    z: np.ndarray
    out_r: np.ndarray
    out_z: np.ndarray
    blocked: np.ndarray


@dataclass(frozen=True)
class RayHits:
    """Rays meeting the mirror in 3-D, mirror frame, mm.

    fate: Fate codes (...). point: hit point (..., 3). direction: unit reflected direction
    (..., 3). Both NaN unless the ray met a lobe. blocked: the reflected ray runs into the
    mirror itself (a lobe hit the camera sees but whose view is vignetted).
    """

    fate: np.ndarray
    point: np.ndarray
    direction: np.ndarray
    blocked: np.ndarray

    @property
    def lobe(self) -> np.ndarray:
        """Lobe index per ray: 0 inner, 1 outer, -1 for the wall or a miss."""
        return np.where(self.fate <= Fate.OUTER, self.fate, -1).astype(np.int8)


# --------------------------------------------------------------------------------------
# Public entry points


def trace_pixels(profile: Profile, camera: Camera, pixels_xy: np.ndarray | None = None, *,
                 radii_px: np.ndarray | None = None, pose: CameraPose | None = ALIGNED,
                 progress: bool = False) -> RayHits:
    """Trace the rays of image points (px) off the profile; exact for any Profile.

    pixels_xy: (..., 2) image coordinates (u, v) from the principal point, px (see
    camera.py; pixel centres are half-integers). radii_px: alternatively image radii
    along +u, px. pose: a misaligned camera uses the general 3-D tracer (slower, about
    60 profile evaluations per ray); the aligned one the exact meridian tracer.
    progress: a tqdm bar on stderr for the 3-D path (seconds per million rays).
    """
    pose = pose or ALIGNED
    if (pixels_xy is None) == (radii_px is None):
        raise ValueError("trace_pixels: give exactly one of pixels_xy or radii_px")
    if pixels_xy is None:
        radii = np.asarray(radii_px, float)
        pixels_xy = np.stack([radii, np.zeros_like(radii)], axis=-1)
    pixels_xy = np.asarray(pixels_xy, float)
    u, v = pixels_xy[..., 0], pixels_xy[..., 1]
    if not pose.aligned:
        origin, d = ray_directions(camera, u, v, pose)
        return trace_rays(profile, origin, d, progress=progress)
    rho = np.hypot(u, v)
    t = rho * (camera.t_pixel / camera.f)
    m = meridian_hits(profile, t)
    cos, sin = _azimuth(u, v, rho)
    point = np.stack([m.r * cos, m.r * sin, m.z], axis=-1)
    direction = np.stack([m.out_r * cos, m.out_r * sin, m.out_z], axis=-1)
    return RayHits(fate=m.fate, point=point, direction=direction, blocked=m.blocked)


def meridian_hits(profile: Profile, t: np.ndarray) -> MeridianHits:
    """Where camera rays r = t z (t >= 0) meet the profile, and how they reflect. Exact."""
    t = np.asarray(t, dtype=float)
    rj, r_max = profile.r_junction, profile.r_max
    r_out0 = np.nextafter(rj, np.inf)  # the first radius of the outer lobe
    zi_j, zo_j, z_rim = (float(profile.z(np.array(x))) for x in (rj, r_out0, r_max))
    if not (zi_j > 0 and zo_j > 0 and z_rim > 0):
        raise ValueError("meridian_hits: the profile must lie above the camera (z > 0)")

    # Classify by the ray's height where it reaches the junction and the rim (h monotone).
    fate = np.full(t.shape, Fate.MISS, dtype=np.int8)
    inner = t * zi_j <= rj
    fate[inner] = Fate.INNER
    wall = ~inner & (t * zo_j <= rj)
    fate[wall] = Fate.WALL
    outer = ~inner & ~wall & (t * z_rim <= r_max)
    fate[outer] = Fate.OUTER

    r = np.full(t.shape, np.nan)
    for k, mask in ((0, inner), (1, outer)):
        if mask.any():
            r[mask] = _meridian_root(profile, t[mask], k)
    r[outer] = np.maximum(r[outer], r_out0)  # a root at the junction belongs to the outer lobe
    hit = inner | outer
    z = np.full(t.shape, np.nan)
    with np.errstate(divide="ignore", invalid="ignore"):
        z[hit] = np.where(t[hit] > 0, r[hit] / t[hit], profile.z(np.zeros(1))[0])  # on the ray

    # Mirror reflection out = d - 2 (d.n) n in the meridian plane, n = (s, -1) / |.|.
    s = np.full(t.shape, np.nan)
    s[hit] = profile.slope(r[hit])
    norm_d = np.sqrt(1.0 + t * t)
    dr, dz = t / norm_d, 1.0 / norm_d
    norm_n = np.sqrt(1.0 + s * s)
    nr, nz = s / norm_n, -1.0 / norm_n
    dot = dr * nr + dz * nz
    out_r, out_z = dr - 2.0 * dot * nr, dz - 2.0 * dot * nz

    # Rays leaving the inner lobe cross r = r_junction (on the far side if out_r < 0); there
    # the material of the outer lobe starts at zo_j, and the outer sheet rises faster than
    # any reflected ray beyond (convex lobe), so that crossing decides.
    blocked = np.zeros(t.shape, dtype=bool)
    if inner.any():
        with np.errstate(divide="ignore", invalid="ignore"):
            ri, zi, ori, ozi = r[inner], z[inner], out_r[inner], out_z[inner]
            z_at_wall = zi + (np.sign(ori) * rj - ri) * ozi / ori
        blocked[inner] = (ori != 0) & (z_at_wall > zo_j)
    return MeridianHits(t=t, fate=fate, r=r, z=z, out_r=out_r, out_z=out_z, blocked=blocked)


def trace_rays(profile: Profile, origin: np.ndarray, directions: np.ndarray, *,
               steps: int = 16, chunk: int = 65536, progress: bool = False) -> RayHits:
    """General 3-D tracer: rays origin + s * direction (mm, unit directions (..., 3)).

    Marches each ray through the mirror's height range (about 23 mm) in `steps` steps,
    then refines the first step that enters the material to ROOT_TOL_MM (safeguarded
    Newton, bisection across the step wall: see _refine). A camera ray
    near the axis climbs faster than any lobe (dz/dr = 1/t > 3 against slopes < 1.2), so
    once inside the material it stays there and a few steps suffice; more steps guard a
    strongly tilted camera. Costs about steps + 15 profile evaluations per ray; `chunk`
    rays at a time bound the memory.
    """
    origin = np.asarray(origin, float)
    d_all = np.asarray(directions, float)
    shape = d_all.shape[:-1]
    d_all = d_all.reshape(-1, 3)
    n = d_all.shape[0]
    fate = np.full(n, Fate.MISS, dtype=np.int8)
    point = np.full((n, 3), np.nan)
    out = np.full((n, 3), np.nan)
    blocked = np.zeros(n, dtype=bool)
    z_lo, z_hi = _height_range(profile)
    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(total=n, unit="ray", unit_scale=True, desc="trace 3-D", leave=False)
    for a in range(0, n, chunk):
        sl = slice(a, min(a + chunk, n))
        f, p, o, b = _trace_chunk(profile, origin, d_all[sl], z_lo, z_hi, steps)
        fate[sl], point[sl], out[sl], blocked[sl] = f, p, o, b
        if bar is not None:
            bar.update(sl.stop - sl.start)
    if bar is not None:
        bar.close()
    return RayHits(fate=fate.reshape(shape), point=point.reshape(*shape, 3),
                   direction=out.reshape(*shape, 3), blocked=blocked.reshape(shape))


# --------------------------------------------------------------------------------------
# Meridian roots


def _azimuth(x: np.ndarray, y: np.ndarray, r: np.ndarray, *,
             on_axis: tuple[float, float] = (1.0, 0.0)) -> tuple[np.ndarray, np.ndarray]:
    """(cos, sin) of the azimuth of points (x, y) at radius r = hypot(x, y); `on_axis`
    where r = 0 (any meridian will do there)."""
    safe = np.where(r > 0, r, 1.0)
    return np.where(r > 0, x / safe, on_axis[0]), np.where(r > 0, y / safe, on_axis[1])


def _meridian_root(profile: Profile, t: np.ndarray, k: int) -> np.ndarray:
    """Radius (mm) where rays r = t z meet lobe k of the profile (the root exists)."""
    if isinstance(profile, ExactProfile):
        lobe = profile.mirror.lobes[k]
        return t * _sheet_height(lobe, t)
    vertices = polyline_vertices(profile, k)
    if vertices is not None:
        return _polyline_root(*vertices, t)
    return _newton_root(profile, t, k)


def polyline_vertices(profile: Profile, k: int) -> tuple[np.ndarray, np.ndarray] | None:
    """(r, z) vertices (mm, camera frame) of lobe k if its z is piecewise linear, else None.

    PolylineProfile: its samples. TabulatedProfile: its samples (z interpolated linearly).
    PathProfile of G1 lines only, end to end: its move ends. Beyond the end vertices the
    end segments extend, as these profiles evaluate there.
    """
    if isinstance(profile, PolylineProfile):
        s = profile.lobes[k]
        return s.r, s.z
    if TabulatedProfile is not None and isinstance(profile, TabulatedProfile):
        r, z, _ = profile.lobes[k]
        return r, z
    if PathProfile is not None and isinstance(profile, PathProfile):
        return profile.vertices(k)
    return None


def _polyline_root(rs: np.ndarray, zs: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Where rays r = t z meet the polyline through (rs, zs) (rs non-decreasing), mm.

    The segment is found by a binary search on the vertices' r / z (increasing along a
    lobe, see the module doc); the end segments extend beyond the ends.
    """
    q = np.maximum.accumulate(rs / zs)
    j = np.clip(np.searchsorted(q, t, side="right") - 1, 0, rs.size - 2)
    dr = rs[j + 1] - rs[j]
    with np.errstate(divide="ignore", invalid="ignore"):
        m = (zs[j + 1] - zs[j]) / dr
        r = t * (zs[j] - m * rs[j]) / (1.0 - t * m)
    return np.where(dr > 0, r, rs[j])  # a vertical step in the table: the ray meets it there


def _sheet_height(lobe: Lobe, t: np.ndarray) -> np.ndarray:
    """Height z (mm) where the ray r = t z meets the lobe's upper sheet (closed form)."""
    return lobe.b**2 / (lobe.e - lobe.a * np.sqrt(1.0 + t * t))


def _newton_root(profile: Profile, t: np.ndarray, k: int, *, table: int = 2049,
                 max_iter: int = 100) -> np.ndarray:
    """Root of h(r) = t Z(r) - r on lobe k: table bracket, then safeguarded Newton."""
    lo_r, hi_r = profile.lobe_range(k)
    if k == 1:
        lo_r = np.nextafter(lo_r, np.inf)
    rs = np.linspace(lo_r, hi_r, table)
    q = np.maximum.accumulate(rs / profile.z(rs))
    j = np.clip(np.searchsorted(q, t, side="right") - 1, 0, table - 2)
    lo, hi = rs[j], rs[j + 1]
    h_lo = t * profile.z(lo) - lo
    h_hi = t * profile.z(hi) - hi
    bad = ~((h_lo >= 0) & (h_hi <= 0))  # a non-monotone table: fall back to the whole lobe
    lo = np.where(bad, lo_r, lo)
    hi = np.where(bad, hi_r, hi)
    h_lo = np.where(bad, t * profile.z(lo) - lo, h_lo)
    h_hi = np.where(bad, t * profile.z(hi) - hi, h_hi)
    with np.errstate(divide="ignore", invalid="ignore"):
        x = np.where(h_lo == h_hi, 0.5 * (lo + hi), lo + (hi - lo) * h_lo / (h_lo - h_hi))
    x = np.clip(x, lo, hi)
    active = np.arange(t.size)
    for _ in range(max_iter):
        xa, ta = x[active], t[active]
        h = ta * profile.z(xa) - xa
        dh = ta * profile.slope(xa) - 1.0
        la, ha = lo[active], hi[active]
        la = np.where(h > 0, xa, la)
        ha = np.where(h > 0, ha, xa)
        with np.errstate(divide="ignore", invalid="ignore"):
            nx = xa - h / dh
        outside = ~((nx >= la) & (nx <= ha)) | ~np.isfinite(nx)
        nx = np.where(outside, 0.5 * (la + ha), nx)
        lo[active], hi[active], x[active] = la, ha, nx
        done = (np.abs(nx - xa) <= ROOT_TOL_MM) | (h == 0) | (ha - la <= ROOT_TOL_MM)
        active = active[~done]
        if active.size == 0:
            break
    return x


# --------------------------------------------------------------------------------------
# 3-D tracing


def _height_range(profile: Profile) -> tuple[float, float]:
    """Heights (mm) just below and above every point of the profile."""
    r = np.linspace(0.0, profile.r_max, 4097)
    r = np.concatenate([r, [np.nextafter(profile.r_junction, np.inf)]])
    z = profile.z(r)
    return float(z.min()) - 0.5, float(z.max()) + 0.5


def _gap(profile: Profile, p: np.ndarray) -> np.ndarray:
    """z - Z(r) of points (..., 3): > 0 inside the material.

    Beyond the rim the mount continues the rim's height (z_rim), as the black annulus of
    the POV-Ray scene does, so a ray leaving the rim enters the mount, not the void.
    """
    r = np.hypot(p[..., 0], p[..., 1])
    inside = r <= profile.r_max
    g = p[..., 2] - float(profile.z(np.array(profile.r_max)))
    g[inside] = p[..., 2][inside] - profile.z(r[inside])
    return g


def _trace_chunk(profile, origin, d, z_lo, z_hi, steps):
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
    g = _gap(profile, origin + s[..., None] * dd[:, None, :])
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
    cx, cy = _azimuth(p[:, 0], p[:, 1], r, on_axis=(0.0, 0.0))  # on the axis the normal is -z
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
        blocked[idx[inner]] = _reflected_blocked(profile, p[inner], o[inner])
    return fate, point, out, blocked


def _refine(profile: Profile, origin: np.ndarray, d: np.ndarray, lo: np.ndarray, hi: np.ndarray,
            g_lo: np.ndarray, g_hi: np.ndarray, *, max_iter: int = 200) -> tuple[np.ndarray, np.ndarray]:
    """Ray lengths s (mm) where rays origin + s d cross the surface inside their brackets
    [lo, hi] (gap g_lo < 0 <= g_hi), and whether that crossing is the step wall.

    Safeguarded Newton on the gap g(s) = z - Z(r): dg/ds = d_z - Z'(r) dr/ds, dr/ds =
    (p_xy . d_xy) / r; a step leaving the bracket bisects it instead, so a ray whose
    crossing is the wall's jump (no smooth root) ends with a bracket narrower than
    ROOT_TOL_MM around it. A smooth root converges in a handful of steps, against ~45
    halvings of plain bisection. The wall is where g jumps by more than WALL_JUMP_MM across
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
        dr = _azimuth(p[:, 0], p[:, 1], r, on_axis=(0.0, 0.0))
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
    jump = _gap(profile, origin + (x + step)[:, None] * d) - _gap(profile, origin + (x - step)[:, None] * d)
    return x, jump > WALL_JUMP_MM


def _reflected_blocked(profile: Profile, p: np.ndarray, o: np.ndarray, samples: int = 24) -> np.ndarray:
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
    hit |= (lam_j > 0) & (_gap(profile, q) > 0)
    for frac in np.arange(1, samples + 1) / samples:
        q = p + (lam_exit * frac)[:, None] * o
        hit |= (lam_exit > 0) & (_gap(profile, q) > 0)
    return hit

