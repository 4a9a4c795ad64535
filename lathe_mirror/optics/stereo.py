"""Stereo range from the two lobes, and what the made mirror does to it.

A world point W in the common band is seen by both lobes. On the exact mirror each lobe
images it at the pixel whose ray, reflected, passes through the lobe's viewpoint F1 and W
(the closed-form inverse map, `ideal_radius_px`). The made (or polished) surface sends
those same two pixels along slightly different rays; the stereo system, which assumes
the design, reports W, while the point actually seen at that pixel pair is where the two
made rays cross (traced exactly by optics.trace). Both rays lie in the pixel pair's meridian plane (the radial epipolar
line of the paper's section 4), so on an aligned camera the triangulation is the
crossing of two lines in the (r, z) plane.

depth error (ARCHITECTURE.md) = 100 * (R_made - R) / R, with R the true range of W from
the stereo centre (midway between the viewpoints) and R_made the range of the made rays'
crossing measured along the same direction (negative when the rays cross behind).

Why the band's figures cap each point at FAILED_PCT: the two viewpoints see W at the
parallax angle gamma = B cos(elevation) / R (B the baseline, 12.8 mm on the paper mirror:
0.37 deg at 2 m on the horizon). A differential ray error delta between the lobes gives R_made / R =
gamma / (gamma - delta) to first order: the error diverges as delta approaches gamma (the
rays turn parallel) and the rays cross behind beyond it. A made surface whose delta runs
through gamma somewhere in the band therefore has a depth error whose sum of squares over
the band grows without bound as the band is sampled more finely (measured on the paper
program polished 60 min, at 2 m: uncapped RMS 231 % over 9 elevations, 18 361 % over 33,
2 874 % over 2049, set by how close one sample falls to the pole; the median stays at
35-42 %). A point whose range is wrong by 100 % or more has no usable depth, just as a
point one lobe does not see; counting both at 100 % makes the band's RMS converge
(58 % at 2 m for that mirror, 59.5 / 58.7 / 58.4 % over 33 / 513 / 2049 elevations).

Camera frame, mm and radians inside; ranges in metres and errors in percent at the edges.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from ..design import Mirror
from ..errors import DesignError
from ..profile import Profile
from ..results.optics import FAILED_PCT, DepthCurve, capped_abs_error  # noqa: F401 (the cap, as the band counts it)
from .trace import meridian_hits

#: Elevations closer than this to an edge of the common band (rad) are not used: at
#: 0.5 m the two viewpoints see a point 1.5 degrees apart, so points right at the band's
#: edge would fall outside one lobe's field of view.
BAND_MARGIN = math.radians(2.0)
#: Elevations sampled across the common band by default: enough for the capped RMS to
#: settle to ~1 % of itself (9 gave 51 %, 33 gave 59.5 %, 2049 gave 58.4 % on the polished
#: paper mirror at 2 m).
BAND_POINTS = 33


def stereo_centre_z(mirror: Mirror) -> float:
    """Height (mm) of the stereo centre, midway between the two viewpoints F1."""
    return 0.5 * (mirror.inner.focus_z + mirror.outer.focus_z)


def band_elevations(mirror: Mirror, n: int = BAND_POINTS) -> np.ndarray:
    """n elevations (rad) evenly across the common band, BAND_MARGIN inside its edges."""
    lo, hi = mirror.common_band
    lo, hi = lo + BAND_MARGIN, hi - BAND_MARGIN
    if hi <= lo:
        raise DesignError(
            f"the lobes' common band ({math.degrees(mirror.common_band[0]):.4g} to "
            f"{math.degrees(mirror.common_band[1]):.4g} deg) is narrower than twice its margin "
            f"({math.degrees(BAND_MARGIN):.4g} deg): no stereo; widen it with lobes.inner / "
            "lobes.outer (r_pixel, alpha_deg)")
    return np.linspace(lo, hi, n)


def world_points(mirror: Mirror, ranges_mm: np.ndarray, elevations: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Meridian coordinates (r, z) in mm of points at range and elevation from the stereo centre."""
    rr, ee = np.meshgrid(np.asarray(ranges_mm, float), np.asarray(elevations, float), indexing="ij")
    return rr * np.cos(ee), stereo_centre_z(mirror) + rr * np.sin(ee)


def exact_pixels(mirror: Mirror, w_r: np.ndarray, w_z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Image radii (px) at which the exact inner and outer lobes image the points (w_r, w_z).

    The direction from the lobe's viewpoint F1 to the point, through the exact lobe's
    closed-form inverse map (optics.distortion.exact_image_point: the focal polar equation
    of the sheet, P = F1 + b^2 / (a - e u_z) u).
    """
    from .distortion import exact_image_point  # lazy: optics.distortion off the CLI's start-up path

    out = []
    for k, lobe in enumerate(mirror.lobes):
        phi = np.arctan2(w_z - lobe.focus_z, w_r)
        u = np.stack([np.cos(phi), np.zeros_like(phi), np.sin(phi)], axis=-1)
        out.append(exact_image_point(mirror, k, u)[..., 0])
    return out[0], out[1]


def triangulate(p1: np.ndarray, o1: np.ndarray, p2: np.ndarray, o2: np.ndarray) -> np.ndarray:
    """Midpoint of the closest approach of lines p1 + s o1 and p2 + u o2 (any dimension).

    Vectors on the last axis. In a plane the lines cross and this is the crossing; for
    (nearly) parallel lines the result is inf/NaN.
    """
    w = p1 - p2
    a = np.sum(o1 * o1, -1)
    b = np.sum(o1 * o2, -1)
    c = np.sum(o2 * o2, -1)
    d = np.sum(o1 * w, -1)
    e = np.sum(o2 * w, -1)
    den = a * c - b * b
    with np.errstate(divide="ignore", invalid="ignore"):
        s = (b * e - c * d) / den
        u = (a * e - b * d) / den
    return 0.5 * ((p1 + s[..., None] * o1) + (p2 + u[..., None] * o2))


def depth_error_curve(profile: Profile, mirror: Mirror, ranges_m: Sequence[float] | np.ndarray, *,
                      elevations: Sequence[float] | np.ndarray | None = None) -> DepthCurve:
    """Depth error (%) of a made surface against range (m), aligned camera.

    elevations: rad (default band_elevations). The made rays are optics.trace's exact
    meridian trace; a point whose pixel the made mirror sends to the other lobe, the step
    wall, or into the mirror itself (vignetted) has no depth: NaN.
    """
    ranges_m = np.asarray(ranges_m, dtype=float)
    elev = band_elevations(mirror) if elevations is None else np.asarray(elevations, float)
    w_r, w_z = world_points(mirror, ranges_m * 1e3, elev)
    rho = exact_pixels(mirror, w_r, w_z)
    p, o, ok = [], [], np.ones(w_r.size, bool)
    for k in (0, 1):
        h = meridian_hits(profile, rho[k].ravel() * (mirror.camera.t_pixel / mirror.camera.f))
        ok &= (h.fate == k) & ~h.blocked
        p.append(np.stack([h.r, h.z], -1))
        o.append(np.stack([h.out_r, h.out_z], -1))
    x = triangulate(p[0], o[0], p[1], o[1])
    x[~ok] = np.nan
    return DepthCurve.of(ranges_m, elev, _error_pct(mirror, x.reshape(w_r.shape + (2,)), ranges_m * 1e3, elev))


def _error_pct(mirror: Mirror, x: np.ndarray, ranges_mm: np.ndarray, elev: np.ndarray) -> np.ndarray:
    """100 (R_made - R) / R with R_made the crossing's range along the true direction."""
    ux, uz = np.cos(elev)[None, :], np.sin(elev)[None, :]
    r_made = x[..., 0] * ux + (x[..., 1] - stereo_centre_z(mirror)) * uz
    return 100.0 * (r_made - ranges_mm[:, None]) / ranges_mm[:, None]
