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
      gives r = t (z_j - m r_j) / (1 - t m); the segment is found by a search on the
      vertices' r / z (increasing along a lobe for the same reason h is monotone), both
      lobes in one bucketed table;
    - any other Profile (arcs, as-machined, polished): bracketed, safeguarded Newton on
      h(r), vectorised, to 1e-12 mm.
  The roots are in optics.meridian_roots; a tabulated profile (a tool-nose envelope)
  takes the fates, the segment and its slope from one table of t-intervals
  (optics.meridian_table, built once per profile), to the same bits. The rays go
  through in blocks that stay in cache.
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

from ..design import Camera
from ..profile import Profile
from .camera import ALIGNED, CameraPose, ray_directions
from .meridian_roots import fate_table, lobe_solver, per_fate
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
    merid = _Meridian(profile, min(n, _BLOCK), n)
    fate, blocked = np.empty(n, dtype=np.int8), np.empty(n, dtype=bool)
    point, direction = np.empty((n, 3)), np.empty((n, 3))
    t_over_px = camera.t_pixel / camera.f
    # numpy's loops over a strided operand (a column of xy, point, direction) are not
    # vectorised: the columns are copied once each way, the arithmetic runs contiguous
    u_buf, v_buf, rho_buf, t_buf, w_buf = np.empty((5, min(n, _BLOCK)))
    with np.errstate(divide="ignore", invalid="ignore"):
        for a in range(0, n, _BLOCK):
            b = min(a + _BLOCK, n)
            u, v, rho, t, w = (x[:b - a] for x in (u_buf, v_buf, rho_buf, t_buf, w_buf))
            np.copyto(u, xy[a:b, 0])
            np.copyto(v, xy[a:b, 1])
            np.multiply(u, u, out=rho)
            rho += np.multiply(v, v, out=t)
            np.sqrt(rho, out=rho)  # not np.hypot: 50 ns a ray, most of the tracer's time
            np.multiply(rho, t_over_px, out=t)
            fate[a:b], r, z, out_r, out_z, blocked[a:b] = merid.block(t)
            p, d = point[a:b], direction[a:b]
            if rho.min() > 0.0:  # off the principal point (always, for pixel centres): r cos = u (r / rho)
                r /= rho
                out_r /= rho
                p[:, 0] = np.multiply(r, u, out=w)
                p[:, 1] = np.multiply(r, v, out=w)
                d[:, 0] = np.multiply(out_r, u, out=w)
                d[:, 1] = np.multiply(out_r, v, out=w)
            else:  # a ray on the axis or a NaN (written as always: the sign of a NaN
                # from two NaNs follows numpy's loop)
                cos, sin = _turn(u, v, rho, r, out_r)
                np.multiply(r, cos, out=p[:, 0])
                np.multiply(r, sin, out=p[:, 1])
                np.multiply(out_r, cos, out=d[:, 0])
                np.multiply(out_r, sin, out=d[:, 1])
            p[:, 2] = z
            d[:, 2] = out_z
    return RayHits(fate=fate.reshape(shape), point=point.reshape(*shape, 3),
                   direction=direction.reshape(*shape, 3), blocked=blocked.reshape(shape))


def meridian_hits(profile: Profile, t: np.ndarray) -> MeridianHits:
    """Where camera rays r = t z (t >= 0) meet the profile, and how they reflect. Exact."""
    t = np.asarray(t, dtype=float)
    flat = t.reshape(-1)
    n = flat.size
    merid = _Meridian(profile, min(n, _BLOCK), n)
    fate, blocked = np.empty(n, dtype=np.int8), np.empty(n, dtype=bool)
    r, z, out_r, out_z = (np.empty(n) for _ in range(4))
    with np.errstate(divide="ignore", invalid="ignore"):
        for a in range(0, n, _BLOCK):
            b = min(a + _BLOCK, n)
            fate[a:b], r[a:b], z[a:b], out_r[a:b], out_z[a:b], blocked[a:b] = merid.block(flat[a:b])
    return MeridianHits(t=t, fate=fate.reshape(t.shape), r=r.reshape(t.shape), z=z.reshape(t.shape),
                        out_r=out_r.reshape(t.shape), out_z=out_z.reshape(t.shape),
                        blocked=blocked.reshape(t.shape))


# --------------------------------------------------------------------------------------
# The meridian tracer, a block of rays at a time

#: Rays per block: the block's ~20 work arrays (8 bytes a ray each) stay within a core's
#: L2 and the shared L3 caches, where a whole-sensor array (8 MB) would go to memory at
#: every step, and the ~70 numpy calls a block makes cost little beside the block's work
#: (8192 rays a block ran 10-30% slower on a loaded machine).
_BLOCK = 1 << 14


#: Rays that turn together: by r / rho times (u, v) if none of them is on the axis, else
#: by their azimuth (u, v) / rho (the two differ in the last bit); a multiple of it is a
#: block, so the bits never depend on _BLOCK.
_TURN = 1 << 13


def _turn(u: np.ndarray, v: np.ndarray, rho: np.ndarray, r: np.ndarray, out_r: np.ndarray):
    """(cos, sin) that turn r and out_r (divided by rho in place where that is the way)
    into the pixels' azimuths, _TURN rays at a time (a block holding a ray on the axis)."""
    cos, sin = np.empty_like(u), np.empty_like(v)
    for a in range(0, u.size, _TURN):
        s = slice(a, a + _TURN)
        if rho[s].all():
            r[s] /= rho[s]
            out_r[s] /= rho[s]
            cos[s], sin[s] = u[s], v[s]
        else:
            cos[s], sin[s] = azimuth(u[s], v[s], rho[s])
    return cos, sin


#: Fate by the number of thresholds t_in <= t_wall <= t_rim that t is below.
_FATE_BY_COUNT = np.array([Fate.MISS, Fate.OUTER, Fate.WALL, Fate.INNER], dtype=np.int8)
_INNER = np.int8(Fate.INNER)  # (an IntEnum would make numpy cast the int8 fates to int64)


def _threshold(r: float, z: float) -> float:
    """The largest t with t * z <= r in floating point (z > 0)."""
    t = r / z
    while t * z > r:
        t = np.nextafter(t, -np.inf)
    while np.nextafter(t, np.inf) * z <= r:
        t = np.nextafter(t, np.inf)
    return float(t)


class _Meridian:
    """A profile's junction and rim, and its lobes' solver (a tabulated profile's fate
    table, kept with the profile, else lobe_solver's), set up once per call of `rays`
    rays, with the work arrays of one block. Its block's arrays are valid until the next
    block."""

    def __init__(self, profile: Profile, block: int = _BLOCK, rays: int = _BLOCK):
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
        self.table = fate_table(profile, self.t_fate, float(self.r_out0), rays)
        self.solve = None  # lobe_solver's, when needed (no table, or a t not finite)
        if self.table is not None:
            self.table_buffers = self.table.buffers(block)
        self.f64 = np.empty((5, block))
        self.bools = np.empty((3, block), dtype=bool)

    def block(self, t: np.ndarray) -> tuple[np.ndarray, ...]:
        """fate, r, z, out_r, out_z, blocked of the rays r = t z (t 1-D, at most `block`).
        Floating-point warnings are the caller's (divisions by 0 for the rays on the axis
        and off the lobes)."""
        n = t.size
        z, g, h, norm_d, out_z = (a[:n] for a in self.f64)
        inner, blocked, other = (a[:n] for a in self.bools)
        np.multiply(t, t, out=norm_d)
        norm_d += 1.0
        np.sqrt(norm_d, out=norm_d)
        t_min = t.min()
        if self.table is not None and -np.inf < t_min and t.max() < np.inf:
            fate, r, s = self.table(t, self.table_buffers, self.profile, self.rj)
            np.equal(fate, _INNER, out=inner)
        else:
            if self.solve is None:  # a root at the junction belongs to the outer lobe; NaN off the lobes
                self.solve = lobe_solver(self.profile, per_fate(-np.inf, self.r_out0), self.t_fate[0])
            # Classify by the ray's height where it reaches the junction and the rim (h
            # monotone): inner if t zi_j <= r_junction, else the wall if t zo_j <= r_junction,
            # else the outer lobe if t z_rim <= r_max, else a miss (and a NaN t).
            t_in, t_wall, t_rim = self.t_fate
            np.less_equal(t, t_in, out=inner)
            count = inner.view(np.int8) + np.less_equal(t, t_wall, out=other).view(np.int8)
            count += np.less_equal(t, t_rim, out=other).view(np.int8)
            fate = _FATE_BY_COUNT.take(count)
            r, s = self.solve(t, norm_d, fate.astype(np.intp), inner)  # NaN off the lobes
            past = r > self.rj
            past &= inner
            if past.any():  # a root rounded past the junction: the slope profile.slope gives there
                s[past] = self.profile.slope(r[past])
        np.divide(r, t, out=z)  # on the ray
        if not t_min > 0.0:  # (or NaN)
            z[t == 0] = self.z_axis

        # Mirror reflection out = d - 2 (d.n) n in the meridian plane, d = (t, 1) / norm_d,
        # n = (s, -1) / sqrt(1 + s^2): out = (t - g s, 1 + g) / norm_d, g = 2 (t s - 1) / (1 + s^2).
        np.multiply(t, s, out=g)
        g -= 1.0
        g += g
        np.multiply(s, s, out=h)
        h += 1.0
        g /= h
        inv_d = np.divide(1.0, norm_d, out=norm_d)
        np.add(g, 1.0, out=out_z)
        out_z *= inv_d
        out_r = np.multiply(g, s, out=g)
        np.subtract(t, out_r, out=out_r)
        out_r *= inv_d

        # Rays leaving the inner lobe cross r = r_junction (on the far side if out_r < 0);
        # there the material of the outer lobe starts at zo_j, and the outer sheet rises
        # faster than any reflected ray beyond (convex lobe), so that crossing decides.
        if inner.any():
            # (+-r_junction by out_r's sign: at out_r = 0, never blocked, and a NaN stays NaN)
            z_at_wall = np.copysign(self.rj, out_r, out=h)
            z_at_wall -= r
            z_at_wall *= out_z
            z_at_wall /= out_r
            z_at_wall += z
            np.greater(z_at_wall, self.zo_j, out=blocked)
            blocked &= np.not_equal(out_r, 0.0, out=other)
            blocked &= inner
        else:
            blocked[...] = False
        return fate, r, z, out_r, out_z, blocked
