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
from ..profile import ExactProfile, Profile
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
    u, v = pixels_xy[..., 0], pixels_xy[..., 1]
    if not pose.aligned:
        origin, d = ray_directions(camera, u, v, pose)
        return trace_rays(profile, origin, d, progress=progress)
    rho = np.hypot(u, v)
    t = rho * (camera.t_pixel / camera.f)
    m = meridian_hits(profile, t)
    cos, sin = azimuth(u, v, rho)
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


# --------------------------------------------------------------------------------------
# Meridian roots


def _meridian_root(profile: Profile, t: np.ndarray, k: int) -> np.ndarray:
    """Radius (mm) where rays r = t z meet lobe k of the profile (the root exists)."""
    lobe = profile.mirror.lobes[k] if isinstance(profile, ExactProfile) else None
    if isinstance(lobe, Lobe):  # a design lobe: closed form (a compensated sheet is not a hyperbola)
        return t * _sheet_height(lobe, t)
    vertices = polyline_vertices(profile, k)
    if vertices is not None:
        return _polyline_root(*vertices, t)
    return _newton_root(profile, t, k)


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
