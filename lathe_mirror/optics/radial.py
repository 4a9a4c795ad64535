"""The aligned camera's figures on a 1-D set of image radii (the fast shortcut).

A lathe-turned surface is a surface of revolution; on a camera aligned with its axis the
ray through a pixel stays in that pixel's meridian plane, so every figure of a pixel
(ray deviation, image displacement, viewpoint spread) depends only on its image radius.
Evaluating each distinct radius of the sensor's pixel centres once, weighted by how many
pixel centres share it, gives exactly the per-pixel RMS and max (the tests check this
against the full per-pixel computation) at a fraction of the cost. A lobe with more
distinct radii than RADII_PER_LOBE (a sensor larger than the paper's 1 megapixel) is
sampled at that many radius bins instead, so its figures cost what the paper's do.

Camera frame (ARCHITECTURE.md): pinhole at the origin, +z up the axis; the meridian is
(r, z). Lengths in mm, angles in radians; pixels only where a name says `_px`.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

from ..design import Camera, Lobe, Mirror
from ..profile import Profile
from ..toolpath.metrics import slope_error

#: How far (px) past its lobe's designed annulus the exact lobe may image a made ray's
#: direction and the pixel still counts: half a pixel, so a direction imaged onto the
#: annulus's edge pixel is that pixel's. Beyond, the ray has left the lobe's range: the
#: lobe's model has no pixel for it (a polished rim's roll-off sends rays up to the
#: asymptote, where the exact lobe's image radius runs to infinity), so the pixel is
#: counted lost (pixels_left_range), never as a displacement larger than the annulus.
LOBE_RANGE_SLACK_PX = 0.5

#: Fixed-point iterations of the ray-surface intersection; each contracts the error by
#: |tan(theta) * slope| <= 0.22 on the paper mirror, so 60 reach machine precision for
#: any mirror whose lobes the camera sees at less than ~60 degrees off axis.
_MAX_ITER = 60
#: The most image radii a lobe is evaluated at (lobe_pixel_radii): a lobe with more
#: distinct pixel-centre radii is cut into this many equal bins (each at its pixels' mean
#: radius, weighted by their count). The paper's 1-megapixel lobes have 17,884 and 32,858
#: distinct radii, so they stay exact; a 12-megapixel sensor's (117,401 and 252,031)
#: are sampled every 0.019 and 0.013 px, about 10 samples across the ~0.2 px a 0.005 mm
#: lattice step spans in its image, and cost the paper's. Halving or doubling it moves the
#: calibration's reprojection errors by less than their printed 4 digits
#: (tests/test_calib.py).
RADII_PER_LOBE = 40_000


@dataclass(frozen=True)
class PixelRadii:
    """Distinct image radii (px) of a lobe's pixel centres and how many pixels share each."""

    radius_px: np.ndarray
    count: np.ndarray


@dataclass(frozen=True)
class MeridianRays:
    """Rays reflected by one lobe, in the meridian plane. mm; unit direction (o_r, o_z)."""

    r: np.ndarray
    z: np.ndarray
    o_r: np.ndarray
    o_z: np.ndarray
    ok: np.ndarray | None = None       # the ray lands on its lobe (not the wall, not past the rim)
    blocked: np.ndarray | None = None  # the reflected ray runs into the step wall (vignetted)

    @property
    def usable(self) -> np.ndarray:
        """Rays that land on their lobe and leave it unobstructed."""
        ok = np.ones(self.r.shape, bool) if self.ok is None else self.ok
        return ok if self.blocked is None else ok & ~self.blocked

    @property
    def elevation(self) -> np.ndarray:
        """Elevation (rad) of the reflected direction above the horizon."""
        return np.arctan2(self.o_z, self.o_r)


# --------------------------------------------------------------------------------------
# Public entry points


def lobe_pixel_radii(mirror: Mirror, k: int, *, bin_px: float | None = None,
                     corner_mm: float = 0.0, zones=None, max_radii: int | None = RADII_PER_LOBE) -> PixelRadii:
    """Image radii of the pixel centres of lobe k's usable annulus, with their counts
    (read-only arrays, made once per process for equal arguments: `run` asked for the
    same radii 82 times, 0.5 s of CPU).

    The annuli are the design's (Mirror.image_radii_px): the inner disc, and the outer
    annulus up to the outer lobe's R_pixel; the ring lost on the step wall is neither.
    bin_px: None gives every distinct radius (exact; ~10^5 radii on the paper's sensor);
    a bin width (px) gives bin-centre radii (faster, approximate: for Monte Carlo).
    max_radii: at most this many radii, in equal bins when there are more (see
    RADII_PER_LOBE; None: no limit).
    corner_mm: width (mm) of the inner lobe's band next to the step that is not usable,
    e.g. the fillet a nose of that radius leaves in the inside corner; its pixels are
    counted lost like the step wall's (see corner_limit_px).
    zones: an optics.zones.Zones; the lobe's used zone only (the fillet ring the nose
    cannot reach left out).
    """
    try:
        hash((mirror, k, bin_px, corner_mm, zones, max_radii))
    except TypeError:  # an argument without a hash (a stand-in for the mirror or zones)
        return _pixel_radii(mirror, k, bin_px, corner_mm, zones, max_radii)
    return _kept_pixel_radii(mirror, k, bin_px, corner_mm, zones, max_radii)


@functools.lru_cache(maxsize=32)
def _kept_pixel_radii(mirror: Mirror, k: int, bin_px, corner_mm: float, zones, max_radii) -> PixelRadii:
    """lobe_pixel_radii's radii by their arguments (each a few thousand radii), read-only:
    every caller is handed the same arrays."""
    px = _pixel_radii(mirror, k, bin_px, corner_mm, zones, max_radii)
    px.radius_px.setflags(write=False)
    px.count.setflags(write=False)
    return px


def _pixel_radii(mirror: Mirror, k: int, bin_px, corner_mm: float, zones, max_radii) -> PixelRadii:
    radii = mirror.image_radii_px
    lo, hi = radii["inner_disc"] if k == 0 else radii["outer_annulus"]
    if k == 0 and corner_mm > 0:
        hi = corner_limit_px(mirror, corner_mm)
    if zones is not None:
        u_lo, u_hi = zones.lobes[k].used_px
        lo, hi = (lo, min(hi, u_hi)) if k == 0 else (max(lo, u_lo), hi)
    rho_all, cnt_all = sensor_radii(tuple(int(n) for n in mirror.camera.sensor_px))
    rho, cnt = rho_all, cnt_all
    if k == 0:
        m = rho < hi
    else:
        m = (rho > lo) & (rho <= hi)
    rho, cnt = rho[m], cnt[m]
    # Pixels whose exact ray the step wall blocks (vignetted) are not part of the lobe's
    # usable image on any mirror made to this design.
    keep = trace_lobe(mirror.lobes[k], mirror, k, rho).usable
    rho, cnt = rho[keep], cnt[keep]
    if bin_px is None and max_radii is not None and rho.size > max_radii:
        edges = np.linspace(lo, hi, max_radii + 1)
    elif bin_px is not None:
        edges = np.arange(lo, hi + bin_px, bin_px)
        if max_radii is not None and edges.size - 1 > max_radii:
            edges = np.linspace(lo, hi, max_radii + 1)
    else:
        edges = None
    if edges is not None:
        idx = np.clip(np.searchsorted(edges, rho, side="right") - 1, 0, edges.size - 2)
        tot = np.bincount(idx, weights=cnt, minlength=edges.size - 1)
        mean = np.bincount(idx, weights=cnt * rho, minlength=edges.size - 1)
        keep = tot > 0
        rho, cnt = mean[keep] / tot[keep], tot[keep]
    return PixelRadii(rho.astype(float), cnt.astype(float))


def used_extent(mirror: Mirror, k: int, zones=None) -> tuple[float, float]:
    """Radial extent (mm) of lobe k that the image uses: the outer lobe from where the
    inner lobe's rim stops hiding it (Mirror.r_outer_visible) to the rim; the inner lobe up
    to where its exact reflected rays start to run into the step wall (beyond, the
    surface, including any fillet the tool leaves in the inside corner, shows no world).
    zones: an optics.zones.Zones: its used zone (the fillet ring left out) instead."""
    if zones is not None:
        return zones.lobes[k].used_mm
    if k == 1:
        return max(float(mirror.r_outer_visible), mirror.r_junction), mirror.r_max
    lo, hi = (0.0, mirror.r_junction) if k == 0 else (mirror.r_junction, mirror.r_max)
    if k == 1 or mirror.step <= 0:
        return lo, hi
    lobe = mirror.inner
    r = np.linspace(lo, hi, 20001)[1:]
    z = lobe.z(r)
    # Exact rays leave along F1 -> P; blocked if they reach r_junction above the step's top.
    z_wall = z + (hi - r) * (z - lobe.focus_z) / r
    blocked = z_wall > float(mirror.outer.z(hi))
    return lo, float(r[np.argmax(blocked)]) if blocked.any() else hi


def corner_limit_px(mirror: Mirror, corner_mm: float) -> float:
    """Image radius (px) of the exact inner lobe at r = r_junction - corner_mm (Eq. 6's map)."""
    r = max(mirror.r_junction - corner_mm, 0.0)
    return float(mirror.camera.image_radius_px(r / float(mirror.inner.z(r))))


def lobe_range_px(mirror: Mirror, k: int) -> tuple[float, float]:
    """Image radii (px) of lobe k's designed annulus (Mirror.image_radii_px: the inner
    disc, the outer annulus), the range a made ray's image may land in, give or take
    LOBE_RANGE_SLACK_PX."""
    radii = mirror.image_radii_px
    return radii["inner_disc"] if k == 0 else radii["outer_annulus"]


def in_lobe_range(mirror: Mirror, k: int, ideal_px: np.ndarray, camera: Camera | None = None) -> np.ndarray:
    """Where the exact lobe k images a made ray's direction (ideal_px, px of `camera`,
    default the design's; NaN past the asymptote) within its designed annulus, give or
    take LOBE_RANGE_SLACK_PX."""
    lo, hi = lobe_range_px(mirror, k)
    if camera is not None:  # the annulus in this camera's pixels (the same angles)
        scale = (camera.f / camera.t_pixel) / (mirror.camera.f / mirror.camera.t_pixel)
        lo, hi = lo * scale, hi * scale
    x = np.asarray(ideal_px, float)
    with np.errstate(invalid="ignore"):
        return np.isfinite(x) & (x >= lo - LOBE_RANGE_SLACK_PX) & (x <= hi + LOBE_RANGE_SLACK_PX)


def edge_mask(mirror: Mirror, k: int, r: np.ndarray, edge_mm: float) -> np.ndarray:
    """Where lobe radii r (mm) lie within edge_mm of lobe k's edges: the step (the inner
    lobe's rim, the outer lobe's inner edge) and the outer rim; the axis is no edge. The
    band a polish turns down (polish.clear_edge_mm): its own zone figure."""
    r = np.asarray(r, float)
    if edge_mm <= 0:
        return np.zeros(r.shape, bool)
    if k == 0:
        return r >= mirror.r_junction - edge_mm
    return (r <= mirror.r_junction + edge_mm) | (r >= mirror.r_max - edge_mm)


def trace_lobe(profile: Profile | Lobe, mirror: Mirror, k: int, radius_px: np.ndarray, *,
               camera_dz: float = 0.0) -> MeridianRays:
    """Reflect the camera rays of image radii radius_px (px) off lobe k of a surface.

    profile: any Profile (made, polished, exact), or a Lobe (its exact sheet). Only lobe
    k's part of the surface is used (the ray is assumed to land on it). camera_dz: axial
    offset of the pinhole from its design position (mm, + toward the mirror).
    """
    z_fn, s_fn = _lobe_functions(profile, mirror, k)
    t = mirror.camera.tan_theta(np.asarray(radius_px, dtype=float))
    lobe = mirror.lobes[k]
    z = np.full_like(t, lobe.vertex_z)
    for _ in range(_MAX_ITER):
        # The ray r = t (z - dz) meets Z(r) where z = Z(t (z - dz)): a contraction.
        z_new = z_fn(t * (z - camera_dz))
        done = np.max(np.abs(z_new - z), initial=0.0) < 1e-13
        z = z_new
        if done:
            break
    r = t * (z - camera_dz)
    norm = np.hypot(t, 1.0)
    d_r, d_z = t / norm, 1.0 / norm
    s = s_fn(r)
    nn = np.hypot(s, 1.0)
    n_r, n_z = s / nn, -1.0 / nn
    dot = d_r * n_r + d_z * n_z
    # Law of reflection: o = d - 2 (d . n) n.
    o_r, o_z = d_r - 2 * dot * n_r, d_z - 2 * dot * n_z
    lo, hi = (0.0, mirror.r_junction) if k == 0 else (mirror.r_junction, mirror.r_max)
    slack = 1e-9
    ok = (r >= lo - slack) & (r <= hi + slack) & (r > lo if k == 1 else True)
    blocked = None
    if k == 0 and mirror.step > 0:
        # The recessed inner lobe: a reflected ray that reaches the junction radius above
        # the top of the step (the outer lobe's edge) runs into the wall.
        outer = mirror.outer if isinstance(profile, Lobe) else profile
        z_top = float(_lobe_functions(outer, mirror, 1)[0](np.array([mirror.r_junction]))[0])
        with np.errstate(divide="ignore", invalid="ignore"):
            z_at_wall = z + (mirror.r_junction - r) * o_z / o_r
        blocked = (o_r > 0) & (z_at_wall > z_top)
    return MeridianRays(r=r, z=z, o_r=o_r, o_z=o_z, ok=ok, blocked=blocked)


def ideal_radius_px(lobe: Lobe, camera: Camera, elevation: np.ndarray) -> np.ndarray:
    """Image radius (px) at which the exact lobe images a world direction of this elevation.

    The polar equation of the sheet about its focus F1: a point at distance s from F1 in
    the direction phi lies on the sheet when |P| - s = 2a (the focal property), which with
    |P|^2 = s^2 + 4 e s sin(phi) + 4 e^2 and e^2 = a^2 + b^2 (Eq. 3) gives
    s = b^2 / (a - e sin(phi)). NaN where the lobe cannot see that direction.
    """
    phi = np.asarray(elevation, dtype=float)
    den = lobe.a - lobe.e * np.sin(phi)
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.where(den > 0, lobe.b**2 / den, np.nan)
        r = s * np.cos(phi)
        z = lobe.focus_z + s * np.sin(phi)
        return np.asarray(camera.image_radius_px(r / z))


def radial_displacement(profile: Profile, mirror: Mirror, k: int, radius_px: np.ndarray, *,
                        camera_dz: float = 0.0) -> np.ndarray:
    """Radial image displacement (px) of lobe k at image radii radius_px (px).

    ARCHITECTURE.md: where the exact lobe would image the direction the made surface sends
    the pixel to, minus where the pixel is. NaN where the made ray misses lobe k (lost).
    """
    rays = trace_lobe(profile, mirror, k, radius_px, camera_dz=camera_dz)
    ideal = ideal_radius_px(mirror.lobes[k], mirror.camera, rays.elevation)
    d = ideal - radius_px
    # Rays that miss their lobe, or leave its range, carry no image of it: NaN. (Vignetting
    # is judged on the exact design's pixels, lobe_pixel_radii: the same pixel set for
    # every made surface.)
    return np.where(rays.ok & in_lobe_range(mirror, k, ideal), d, np.nan)


def radial_figures(profile: Profile, mirror: Mirror, *, camera_dz: float = 0.0,
                   bin_px: float | None = None, corner_mm: float = 0.0, zones=None,
                   edge_mm: float = 0.0) -> dict:
    """Per-lobe ray_deviation_deg, image_displacement_px, viewpoint_spread_mm ({rms, max}).

    RMS and max over the pixel centres of each lobe's usable annulus (each distinct radius
    weighted by its pixel count). Aligned camera, optionally shifted along the axis.
    Pixels count where the exact ray lands on the lobe unobstructed (lobe_pixel_radii drops
    the ones the step vignettes on the exact design) and the made ray lands on the lobe:
    the rule of optics.distortion's usable annulus. corner_mm, zones: see lobe_pixel_radii
    (zones: each lobe's used zone, its "zone_px" given).

    A made ray the exact lobe would image outside the lobe's designed annulus (in_lobe_range)
    has left the lobe's range: counted lost, "pixels_left_range" (and its share of the
    lobe's pixels, "left_range_pct"), not a displacement. edge_mm > 0: the figures of the
    pixels whose made ray meets the lobe within edge_mm of its edges (edge_mask: a polished
    part's turned-down rim and roll-off at the step) again on their own, under "edge"
    (they stay in the lobe's figures too).
    """
    lobes = []
    for k, lobe in enumerate(mirror.lobes):
        px = lobe_pixel_radii(mirror, k, bin_px=bin_px, corner_mm=corner_mm, zones=zones)
        made = trace_lobe(profile, mirror, k, px.radius_px, camera_dz=camera_dz)
        exact = trace_lobe(lobe, mirror, k, px.radius_px)
        ideal = ideal_radius_px(lobe, mirror.camera, made.elevation)
        left = made.ok & ~in_lobe_range(mirror, k, ideal)
        use = made.ok & ~left
        disp = ideal - px.radius_px
        # atan2(|cross|, dot) keeps precision for tiny angles where arccos loses it.
        dev = np.degrees(np.arctan2(np.abs(made.o_r * exact.o_z - made.o_z * exact.o_r),
                                    made.o_r * exact.o_r + made.o_z * exact.o_z))
        # |(F1 - P) x o| with |o| = 1: distance of F1 from the reflected line.
        spread = np.abs(-made.r * made.o_z - (lobe.focus_z - made.z) * made.o_r)
        w = px.count
        lobes.append({
            "name": lobe.name,
            "pixels": int(np.sum(w[use])),
            "pixels_excluded": int(np.sum(w[~use])),
            "pixels_left_range": int(np.sum(w[left])),
            "left_range_pct": float(100.0 * np.sum(w[left]) / max(float(np.sum(w)), 1.0)),
            "ray_deviation_deg": weighted_stats(dev[use], w[use], count_nan=True),
            "image_displacement_px": weighted_stats(disp[use], w[use], count_nan=True),
            "viewpoint_spread_mm": weighted_stats(spread[use], w[use], count_nan=True),
        })
        if edge_mm > 0:
            band = made.ok & edge_mask(mirror, k, made.r, edge_mm)
            lobes[-1]["edge"] = {"band_mm": float(edge_mm), "pixels": int(np.sum(w[band & use])),
                                 "pixels_left_range": int(np.sum(w[band & left])),
                                 "image_displacement_px": weighted_stats(disp[band & use], w[band & use])}
        if zones is not None:
            u = zones.lobes[k].used_px
            lobes[-1]["zone_px"] = {"min": float(u[0]), "max": float(u[1])}
    return {"lobes": lobes}


def surface_errors(profile: Profile, mirror: Mirror, *, n: int = 4001, used: bool = False) -> dict:
    """Per-lobe slope_error_rad and normal_deviation_mm ({rms, max}) on n radii per lobe.

    Uniform in r over each lobe (used=True: over the extent the image uses, used_extent).
    Slope error: angle between the made and exact normals at the same r. Normal deviation: |dz| cos(beta) with beta the exact surface's slope
    angle, the distance to the exact surface to first order in dz / (radius of curvature).
    """
    exact_lobes = mirror.lobes
    out = []
    for k, lobe in enumerate(exact_lobes):
        lo, hi = used_extent(mirror, k) if used else ((0.0, mirror.r_junction) if k == 0 else
                                                       (mirror.r_junction, mirror.r_max))
        r = np.linspace(lo, hi, n)
        if k == 1:
            r[0] = np.nextafter(lo, hi)
        s_exact = lobe.slope(r)
        slope_err = np.abs(slope_error(profile.slope(r), s_exact))
        normal_dev = np.abs(profile.z(r) - lobe.z(r)) / np.hypot(1.0, s_exact)
        w = np.ones_like(r)
        out.append({"name": lobe.name, "slope_error_rad": weighted_stats(slope_err, w),
                    "normal_deviation_mm": weighted_stats(normal_dev, w)})
    return {"lobes": out}


def pooled_rms(parts) -> float:
    """The RMS over several sets from each one's (RMS, weight): the image displacement over
    both lobes' pixels (weights: pixel counts), the slope error over both lobes' clear
    apertures (weights: their widths, mm). The polishing curve and section use it."""
    parts = [(float(r), float(n)) for r, n in parts]
    return math.sqrt(sum(r**2 * n for r, n in parts) / sum(n for _, n in parts))


def weighted_stats(values: np.ndarray, weights: np.ndarray, *, count_nan: bool = False) -> dict:
    """{"rms", "max"} of |values| with weights (NaNs, i.e. rays lost, are skipped).
    count_nan (weights that are pixel counts): the pixels skipped as "nan_excluded", when
    there are any."""
    v = np.abs(np.asarray(values, dtype=float))
    w = np.asarray(weights, dtype=float)
    ok = np.isfinite(v)
    out = ({"rms": float(np.sqrt(np.sum(w[ok] * v[ok] ** 2) / np.sum(w[ok]))), "max": float(np.max(v[ok]))}
           if ok.any() else {"rms": math.nan, "max": math.nan})
    if count_nan and not ok.all():
        out["nan_excluded"] = int(round(float(np.sum(w[~ok]))))
    return out


# --------------------------------------------------------------------------------------
# Helpers


@functools.lru_cache(maxsize=4)
def sensor_radii(sensor_px: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    """Distinct radii (px) of all pixel centres about the sensor centre, with counts."""
    w, h = sensor_px
    # the centres are symmetric about both axes: one quadrant's |x|, |y|, each with how
    # many centres share it (2, or 1 on an axis), a quarter of the work
    x, mx = np.unique(np.abs(np.arange(w) + 0.5 - w / 2.0), return_counts=True)
    y, my = np.unique(np.abs(np.arange(h) + 0.5 - h / 2.0), return_counts=True)
    # 4 (x^2 + y^2) is an integer for half-integer or integer centres: exact uniqueness.
    q = np.rint(4.0 * (x[None, :] ** 2 + y[:, None] ** 2)).astype(np.int64).ravel()
    uq, inv = np.unique(q, return_inverse=True)
    cnt = np.bincount(inv.ravel(), weights=(my[:, None] * mx[None, :]).ravel()).astype(np.int64)
    rho = np.sqrt(uq / 4.0)
    rho.setflags(write=False)
    cnt.setflags(write=False)
    return rho, cnt


def _lobe_functions(surface: Profile | Lobe, mirror: Mirror, k: int
                    ) -> tuple[Callable[[np.ndarray], np.ndarray], Callable[[np.ndarray], np.ndarray]]:
    """z(r) and slope(r) of lobe k of a surface, r clipped to the lobe's extent."""
    if isinstance(surface, Lobe):
        return surface.z, surface.slope
    lo, hi = (0.0, mirror.r_junction) if k == 0 else (np.nextafter(mirror.r_junction, np.inf), mirror.r_max)

    def z_fn(r: np.ndarray) -> np.ndarray:
        return surface.z(np.clip(np.abs(r), lo, hi))

    def s_fn(r: np.ndarray) -> np.ndarray:
        return surface.slope(np.clip(np.abs(r), lo, hi))

    return z_fn, s_fn
