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
* General (3-D), for a misaligned camera (optics.trace3d): the lobe's quadric in closed
  form on its mirror's sheet, then safeguarded Newton on a made profile, all rays at once;
  a march for the few rays near a steep feature.

The step between the lobes is a vertical wall at r_junction. A camera ray that reaches
r_junction inside the material hits the wall (Fate.WALL: the lost ring of the image); a
ray past the outer rim misses the mirror (Fate.MISS). A reflected ray that leaves the
recessed inner lobe and meets the wall or the outer lobe is `blocked` (vignetted).

Frames and units: camera frame (pinhole at the origin, +z up the axis), mm.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..design import Camera, Lobe
from ..profile import ExactProfile, Profile, TabulatedProfile
from .camera import ALIGNED, CameraPose, ray_directions
from .rays import ROOT_TOL_MM, Fate, RayHits, azimuth, polyline_vertices
from .trace3d import WALL_JUMP_MM, trace_rays

__all__ = ["ROOT_TOL_MM", "WALL_JUMP_MM", "Fate", "MeridianHits", "RayHits", "meridian_hits",
           "polyline_vertices", "trace_pixels", "trace_rays"]


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


# --------------------------------------------------------------------------------------
# Public entry points


def trace_pixels(profile: Profile, camera: Camera, pixels_xy: np.ndarray | None = None, *,
                 radii_px: np.ndarray | None = None, pose: CameraPose | None = ALIGNED,
                 progress: bool = False) -> RayHits:
    """Trace the rays of image points (px) off the profile; exact for any Profile.

    pixels_xy: (..., 2) image coordinates (u, v) from the principal point, px (see
    camera.py; pixel centres are half-integers). radii_px: alternatively image radii
    along +u, px. pose: a misaligned camera uses the general 3-D tracer (optics.trace3d); the
    aligned one the exact meridian tracer.
    progress: a tqdm bar on stderr for the 3-D path (seconds per million rays).
    """
    pose = pose or ALIGNED
    if (pixels_xy is None) == (radii_px is None):
        raise ValueError("trace_pixels: give exactly one of pixels_xy or radii_px")
    if pixels_xy is None:
        radii = np.asarray(radii_px, float)
        pixels_xy = np.stack([radii, np.zeros_like(radii)], axis=-1)
    pixels_xy = np.asarray(pixels_xy, float)
    if not pose.aligned:
        origin, d = ray_directions(camera, pixels_xy[..., 0], pixels_xy[..., 1], pose)
        return trace_rays(profile, origin, d, progress=progress)
    shape = pixels_xy.shape[:-1]
    xy = pixels_xy.reshape(-1, 2)
    n = xy.shape[0]
    merid = _Meridian(profile)
    fate, blocked = np.empty(n, dtype=np.int8), np.empty(n, dtype=bool)
    point, direction = np.empty((n, 3)), np.empty((n, 3))
    t_over_px = camera.t_pixel / camera.f
    for a in range(0, n, _BLOCK):
        b = min(a + _BLOCK, n)
        u, v = xy[a:b, 0], xy[a:b, 1]
        rho = u * u
        rho += v * v
        np.sqrt(rho, out=rho)  # not np.hypot: 50 ns a ray, most of the tracer's time
        fate[a:b], r, z, out_r, out_z, blocked[a:b] = merid.block(rho * t_over_px)
        p, d = point[a:b], direction[a:b]
        if rho.all():  # off the principal point (always, for pixel centres): r cos = u (r / rho)
            r /= rho
            out_r /= rho
            cos, sin = u, v
        else:
            cos, sin = azimuth(u, v, rho)
        np.multiply(r, cos, out=p[:, 0])
        np.multiply(r, sin, out=p[:, 1])
        p[:, 2] = z
        np.multiply(out_r, cos, out=d[:, 0])
        np.multiply(out_r, sin, out=d[:, 1])
        d[:, 2] = out_z
    return RayHits(fate=fate.reshape(shape), point=point.reshape(*shape, 3),
                   direction=direction.reshape(*shape, 3), blocked=blocked.reshape(shape))


def meridian_hits(profile: Profile, t: np.ndarray) -> MeridianHits:
    """Where camera rays r = t z (t >= 0) meet the profile, and how they reflect. Exact."""
    t = np.asarray(t, dtype=float)
    flat = t.reshape(-1)
    n = flat.size
    merid = _Meridian(profile)
    fate, blocked = np.empty(n, dtype=np.int8), np.empty(n, dtype=bool)
    r, z, out_r, out_z = (np.empty(n) for _ in range(4))
    for a in range(0, n, _BLOCK):
        b = min(a + _BLOCK, n)
        fate[a:b], r[a:b], z[a:b], out_r[a:b], out_z[a:b], blocked[a:b] = merid.block(flat[a:b])
    return MeridianHits(t=t, fate=fate.reshape(t.shape), r=r.reshape(t.shape), z=z.reshape(t.shape),
                        out_r=out_r.reshape(t.shape), out_z=out_z.reshape(t.shape),
                        blocked=blocked.reshape(t.shape))


# --------------------------------------------------------------------------------------
# The meridian tracer, a block of rays at a time

#: Rays per block: the block's ~20 temporaries (8 bytes a ray each) stay in a core's L2
#: cache, where a whole-sensor array (8 MB) would go to memory at every step.
_BLOCK = 1 << 13


#: Fate by the number of thresholds t_in <= t_wall <= t_rim that t is below.
_FATE_BY_COUNT = np.array([Fate.MISS, Fate.OUTER, Fate.WALL, Fate.INNER], dtype=np.int8)


def _threshold(r: float, z: float) -> float:
    """The largest t with t * z <= r in floating point (z > 0)."""
    t = r / z
    while t * z > r:
        t = np.nextafter(t, -np.inf)
    while np.nextafter(t, np.inf) * z <= r:
        t = np.nextafter(t, np.inf)
    return float(t)


def _per_fate(inner: float, outer: float) -> np.ndarray:
    """A lobe constant per Fate code (INNER, OUTER, WALL, MISS): NaN off the lobes, so
    whatever is computed from it for a wall or a missed ray is NaN."""
    return np.array([inner, outer, np.nan, np.nan])


class _Meridian:
    """A profile's junction and rim, and its lobes' solver, set up once per call."""

    def __init__(self, profile: Profile):
        self.profile = profile
        self.rj, self.r_max = rj, r_max = profile.r_junction, profile.r_max
        self.r_out0 = np.nextafter(rj, np.inf)  # the first radius of the outer lobe
        self.zi_j, self.zo_j, self.z_rim = (float(profile.z(np.array(x))) for x in (rj, self.r_out0, r_max))
        if not (self.zi_j > 0 and self.zo_j > 0 and self.z_rim > 0):
            raise ValueError("meridian_hits: the profile must lie above the camera (z > 0)")
        self.z_axis = profile.z(np.zeros(1))[0]
        # t z <= r_junction and t z <= r_max as t <= a threshold: the same test to the bit
        # (t z rounds monotonically in t), one comparison a ray instead of two
        t_in = _threshold(rj, self.zi_j)
        t_wall = max(_threshold(rj, self.zo_j), t_in)
        self.t_fate = (t_in, t_wall, max(_threshold(r_max, self.z_rim), t_wall))
        # a root at the junction belongs to the outer lobe; NaN off the lobes
        self.r_min = _per_fate(-np.inf, self.r_out0)
        self.solve = _solver(profile, self.r_min, t_in)

    def block(self, t: np.ndarray) -> tuple[np.ndarray, ...]:
        """fate, r, z, out_r, out_z, blocked of the rays r = t z (t 1-D)."""
        # Classify by the ray's height where it reaches the junction and the rim (h
        # monotone): inner if t zi_j <= r_junction, else the wall if t zo_j <= r_junction,
        # else the outer lobe if t z_rim <= r_max, else a miss (and a NaN t).
        t_in, t_wall, t_rim = self.t_fate
        inner = t <= t_in
        count = inner.view(np.int8) + (t <= t_wall).view(np.int8)
        count += (t <= t_rim).view(np.int8)
        fate = _FATE_BY_COUNT.take(count)
        lobe = fate.astype(np.intp)

        norm_d = t * t
        norm_d += 1.0
        np.sqrt(norm_d, out=norm_d)
        r, s = self.solve(t, norm_d, lobe, inner)  # NaN off the lobes
        with np.errstate(divide="ignore", invalid="ignore"):
            z = r / t  # on the ray
        if not t.all():
            z[t == 0] = self.z_axis
        past = r > self.rj
        past &= inner
        if past.any():  # a root rounded past the junction: the slope profile.slope gives there
            s[past] = self.profile.slope(r[past])

        # Mirror reflection out = d - 2 (d.n) n in the meridian plane, d = (t, 1) / norm_d,
        # n = (s, -1) / sqrt(1 + s^2): out = (t - g s, 1 + g) / norm_d, g = 2 (t s - 1) / (1 + s^2).
        g = t * s
        g -= 1.0
        g += g
        h = s * s
        h += 1.0
        g /= h
        inv_d = np.divide(1.0, norm_d, out=norm_d)
        out_z = g + 1.0
        out_z *= inv_d
        out_r = np.multiply(g, s, out=g)
        np.subtract(t, out_r, out=out_r)
        out_r *= inv_d

        # Rays leaving the inner lobe cross r = r_junction (on the far side if out_r < 0);
        # there the material of the outer lobe starts at zo_j, and the outer sheet rises
        # faster than any reflected ray beyond (convex lobe), so that crossing decides.
        with np.errstate(divide="ignore", invalid="ignore"):
            z_at_wall = np.sign(out_r, out=h)
            z_at_wall *= self.rj
            z_at_wall -= r
            z_at_wall *= out_z
            z_at_wall /= out_r
            z_at_wall += z
        blocked = z_at_wall > self.zo_j
        blocked &= out_r != 0
        blocked &= inner
        return fate, r, z, out_r, out_z, blocked


# --------------------------------------------------------------------------------------
# The lobes' roots and slopes: r (NaN off the lobes) and dZ/dr there, for all rays at once


def _solver(profile: Profile, r_min: np.ndarray, t_in: float):
    """The fastest exact solver the profile allows: both lobes' hyperbolic sheets in closed
    form, both lobes' polylines by one table search, else lobe by lobe (Newton)."""
    sheets = profile.mirror.lobes if isinstance(profile, ExactProfile) else (None, None)
    if all(type(x) is Lobe for x in sheets) and type(profile).slope is ExactProfile.slope:
        return _Sheets(sheets, r_min)
    lobes = _polyline_lobes(profile, t_in)
    if lobes is not None:
        return _Polylines(profile, lobes, r_min)
    return _ByLobe(profile, r_min)


class _Sheets:
    """Rays r = t z meet the upper sheet (z - e)^2 / a^2 - r^2 / b^2 = 1 at
    z = b^2 / (e - a sqrt(1 + t^2)), the stable root of A z^2 - 2 e z + b^2 = 0. There
    dZ/dr = a r / (b^2 sqrt(1 + r^2 / b^2)) = (a / b)^2 r / (z - e) (on the sheet,
    sqrt(1 + r^2 / b^2) = (z - e) / a)."""

    def __init__(self, lobes: tuple[Lobe, Lobe], r_min: np.ndarray):
        i, o = lobes
        self.b2, self.e, self.a = (_per_fate(x, y) for x, y in ((i.b**2, o.b**2), (i.e, o.e), (i.a, o.a)))
        self.k = _per_fate((i.a / i.b) ** 2, (o.a / o.b) ** 2)
        self.r_min = r_min

    def __call__(self, t: np.ndarray, norm_d: np.ndarray, lobe: np.ndarray, inner: np.ndarray):
        e = self.e.take(lobe)
        z = self.a.take(lobe)
        z *= norm_d
        np.subtract(e, z, out=z)
        np.divide(self.b2.take(lobe), z, out=z)
        r = z * t
        np.maximum(r, self.r_min.take(lobe), out=r)
        z -= e
        s = self.k.take(lobe)
        s *= r
        s /= z
        return r, s


class _Polylines:
    """Both lobes' polylines (vertices rs, zs) as one table of segments, inner then outer.
    On a segment z = zs_j + m (r - rs_j), so the ray r = t z meets it at
    r = t (zs_j - m rs_j) / (1 - t m). A ray's segment is its lobe's last whose first vertex
    has r / z <= t (r / z increases along a lobe, see the module doc), the lobe's end
    segments extending beyond its ends: one search on a key per segment (the vertex's r / z;
    -inf for the first segment of the inner lobe; for the outer lobe's first, the next float
    above every inner ray's t: every outer ray's t reaches it) finds that for both lobes at
    once. A TabulatedProfile's slope is interpolated on the same segment when the root lies
    in it (the same arithmetic as np.interp, to the bit), else by the profile."""

    def __init__(self, profile: Profile, lobes: list[tuple], r_min: np.ndarray):
        self.profile, self.r_min = profile, r_min
        self.search = _Search(np.concatenate([key for *_, key in lobes]))
        self.m, self.c, self.r_lo, self.r_hi = [], [], [], []
        for rs, zs, _ in lobes:
            dr = rs[1:] - rs[:-1]
            with np.errstate(divide="ignore", invalid="ignore"):
                m = (zs[1:] - zs[:-1]) / dr
            self.m.append(m)
            self.c.append(zs[:-1] - m * rs[:-1])
            self.r_lo.append(rs[:-1])
            self.r_hi.append(rs[1:])
        self.m, self.c, self.r_lo, self.r_hi = (np.concatenate(x) for x in (self.m, self.c, self.r_lo, self.r_hi))
        self.step = self.r_hi <= self.r_lo  # a vertical step in the table: the ray meets it there
        self.any_step = bool(self.step.any())
        self.ds = None
        if type(profile).slope is TabulatedProfile.slope and lobes[0][0][-1] <= profile.r_junction:
            ss = [profile.lobes[k][2] for k in (0, 1)]
            with np.errstate(divide="ignore", invalid="ignore"):
                self.ds = np.concatenate([(x[1:] - x[:-1]) / (rs[1:] - rs[:-1]) for x, (rs, *_) in zip(ss, lobes)])
            self.s_lo = np.concatenate([x[:-1] for x in ss])

    def __call__(self, t: np.ndarray, norm_d: np.ndarray, lobe: np.ndarray, inner: np.ndarray):
        j = self.search(t)
        den = self.m.take(j)
        den *= t
        np.subtract(1.0, den, out=den)
        r = self.c.take(j)
        r *= t
        with np.errstate(divide="ignore", invalid="ignore"):
            r /= den
        if self.any_step:
            r = np.where(self.step.take(j), self.r_lo.take(j), r)
        np.maximum(r, self.r_min.take(lobe), out=r)
        if self.ds is None:
            return r, _slope_on_lobes(self.profile, r, lobe)
        r0 = self.r_lo.take(j)
        fits = r0 <= r
        fits &= r < self.r_hi.take(j)
        s = np.subtract(r, r0, out=r0)
        s *= self.ds.take(j)
        s += self.s_lo.take(j)
        redo = ~fits
        redo &= lobe <= Fate.OUTER
        if redo.any():  # a root on a segment's end or beyond the table: np.interp's own choice
            s[redo] = self.profile.slope(r[redo])
        return r, s


def _polyline_lobes(profile: Profile, t_in: float) -> list[tuple] | None:
    """(rs, zs, search keys) of both lobes if both are polylines whose keys, inner then
    outer, do not decrease (else None)."""
    lobes = []
    for k in (0, 1):
        vertices = polyline_vertices(profile, k)
        if vertices is None:
            return None
        rs, zs = vertices
        q = np.maximum.accumulate(rs / zs)
        first = -np.inf if k == 0 else np.nextafter(t_in, np.inf)
        lobes.append((rs, zs, np.concatenate([[first], q[1:-1]])))
    keys = np.concatenate([key for *_, key in lobes])
    return lobes if bool(np.all(keys[1:] >= keys[:-1])) else None


class _Search:
    """searchsorted(keys, t, side="right") - 1 on non-decreasing keys (keys[0] = -inf,
    the rest finite), several times faster than numpy's binary search on 10^4-10^5 keys: a
    uniform grid of buckets (twice as many as keys) over the keys' range, each key counted
    in the bucket the same arithmetic puts a ray in (monotone in t, so a ray's index is the
    keys in the buckets before its own, plus the key in its own bucket if that is <= t:
    exact, no margin at a bucket's edge); the rays of a bucket with two keys or more go to
    searchsorted. A NaN t gets some index."""

    def __init__(self, keys: np.ndarray):
        self.keys, finite = keys, keys[1:]
        self.n_buckets = nb = 2 * max(finite.size, 1)
        self.lo = float(finite[0]) if finite.size else 0.0
        span = float(finite[-1]) - self.lo if finite.size else 0.0
        self.scale = nb / span if span > 0 else 0.0
        count = np.bincount(self._bucket(finite), minlength=nb)
        before = np.cumsum(count) - count  # finite keys in the buckets below; +1 for -inf, -1
        self.split = np.append(finite, np.inf).take(before)  # the first key in or after the bucket
        self.starts = np.where(count > 1, -keys.size - 1, before)  # negative: to searchsorted

    def _bucket(self, t: np.ndarray) -> np.ndarray:
        x = t - self.lo
        x *= self.scale
        np.fmax(x, 0.0, out=x)  # fmax/fmin: a NaN t to bucket 0
        np.fmin(x, self.n_buckets - 1, out=x)
        return x.astype(np.intp)

    def __call__(self, t: np.ndarray) -> np.ndarray:
        b = self._bucket(t)
        j = self.starts.take(b)
        j += self.split.take(b) <= t
        if j.min() < 0:
            bad = np.flatnonzero(j < 0)
            j[bad] = np.searchsorted(self.keys, t[bad], side="right") - 1
        return j


def _slope_on_lobes(profile: Profile, r: np.ndarray, lobe: np.ndarray) -> np.ndarray:
    """profile.slope at the hits (NaN elsewhere)."""
    s = np.full(r.shape, np.nan)
    hit = np.flatnonzero(lobe <= Fate.OUTER)
    s[hit] = profile.slope(r[hit])
    return s


class _ByLobe:
    """Lobe by lobe, for any profile: each lobe's rays to its own root (closed form on a
    design sheet, the polyline's segment, else Newton)."""

    def __init__(self, profile: Profile, r_min: np.ndarray):
        self.profile, self.r_min = profile, r_min
        self.roots = tuple(_lobe_root(profile, k) for k in (0, 1))

    def __call__(self, t: np.ndarray, norm_d: np.ndarray, lobe: np.ndarray, inner: np.ndarray):
        r = np.full(t.shape, np.nan)
        for k, root in enumerate(self.roots):
            idx = np.flatnonzero(lobe == k)
            if idx.size:
                r[idx] = np.maximum(root(t[idx], norm_d[idx]), self.r_min[k])
        return r, _slope_on_lobes(self.profile, r, lobe)


def _lobe_root(profile: Profile, k: int):
    """Lobe k's root of r = t Z(r): closed form on a design lobe (a compensated sheet is not
    a hyperbola), the segment on a polyline, else Newton."""
    sheet = profile.mirror.lobes[k] if isinstance(profile, ExactProfile) else None
    if type(sheet) is Lobe:
        b2, e, a = sheet.b**2, sheet.e, sheet.a
        return lambda t, norm_d: t * (b2 / (e - a * norm_d))
    vertices = polyline_vertices(profile, k)
    if vertices is not None:
        return _polyline_root(*vertices)
    return _NewtonRoot(profile, k)


def _polyline_root(rs: np.ndarray, zs: np.ndarray):
    """Where rays r = t z meet the polyline through (rs, zs) (rs non-decreasing), mm: the
    segment by a binary search on the vertices' r / z; the end segments extend."""
    q = np.maximum.accumulate(rs / zs)

    def root(t: np.ndarray, norm_d: np.ndarray) -> np.ndarray:
        j = np.clip(np.searchsorted(q, t, side="right") - 1, 0, rs.size - 2)
        dr = rs[j + 1] - rs[j]
        with np.errstate(divide="ignore", invalid="ignore"):
            m = (zs[j + 1] - zs[j]) / dr
            r = t * (zs[j] - m * rs[j]) / (1.0 - t * m)
        return np.where(dr > 0, r, rs[j])  # a vertical step in the table: the ray meets it there
    return root


class _NewtonRoot:
    """Root of h(r) = t Z(r) - r on lobe k of any profile: a table brackets it (built once
    per call), then safeguarded Newton, vectorised, to ROOT_TOL_MM."""

    def __init__(self, profile: Profile, k: int, *, table: int = 2049, max_iter: int = 100):
        self.profile, self.max_iter = profile, max_iter
        lo_r, hi_r = profile.lobe_range(k)
        if k == 1:
            lo_r = np.nextafter(lo_r, np.inf)
        self.lo_r, self.hi_r = lo_r, hi_r
        self.rs = np.linspace(lo_r, hi_r, table)
        self.q = np.maximum.accumulate(self.rs / profile.z(self.rs))

    def __call__(self, t: np.ndarray, norm_d: np.ndarray) -> np.ndarray:
        profile, rs = self.profile, self.rs
        j = np.clip(np.searchsorted(self.q, t, side="right") - 1, 0, rs.size - 2)
        lo, hi = rs[j], rs[j + 1]
        h_lo = t * profile.z(lo) - lo
        h_hi = t * profile.z(hi) - hi
        bad = ~((h_lo >= 0) & (h_hi <= 0))  # a non-monotone table: fall back to the whole lobe
        lo = np.where(bad, self.lo_r, lo)
        hi = np.where(bad, self.hi_r, hi)
        h_lo = np.where(bad, t * profile.z(lo) - lo, h_lo)
        h_hi = np.where(bad, t * profile.z(hi) - hi, h_hi)
        with np.errstate(divide="ignore", invalid="ignore"):
            x = np.where(h_lo == h_hi, 0.5 * (lo + hi), lo + (hi - lo) * h_lo / (h_lo - h_hi))
        x = np.clip(x, lo, hi)
        active = np.arange(t.size)
        for _ in range(self.max_iter):
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
