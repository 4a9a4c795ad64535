"""The calibrated stereo residual: the depth error left once calibration has absorbed what it can.

optics.stereo's depth error assumes the rig believes the design. A rig calibrated on the
made mirror (a unified model with radial distortion per lobe, or OCamCalib's polynomial)
believes instead a smooth map, per lobe, from image radius to the direction seen. Against
the design, the made mirror's error at a pixel is its radial image displacement d(rho)
(optics.radial: the exact lobe would image the made ray's direction at rho + d); what a
calibration absorbs is the smooth part of it, P_k(rho): here a least-squares cubic spline in
rho with knots CALIBRATION_KNOT_PX apart over the lobe's usable pixels inside the clear
aperture, each distinct radius weighted by its pixel count (`fit_calibration`; a spline, not
one polynomial over the lobe, because a calibration is local: the rolled band at a lobe's
edge must not bend the map in the middle of the lobe). What is left, d - P_k, no
calibration removes: a facet of ~1 px period, a lattice step.

`calibrated_depth_error`, the **calibrated stereo residual**: a world point W, which the
design images at rho_k(W) in lobe k, is where the calibrated rig reads it at the pixel
rho''_k with rho''_k + P_k(rho''_k) = rho_k(W) (the pixel the rig believes looks along the
design's ray of rho_k). The made mirror's rays through those two pixels (optics.trace,
exact, viewpoint spread included) cross at X; the error is optics.stereo's,
100 (R_X - R) / R along the true direction from the stereo centre, and the band's figures
cap each point at stereo.FAILED_PCT. With nothing absorbed (knot_px None) it is
stereo.depth_error_curve itself.

How it relates to the tolerance analysis' calibration-aware criteria (lathe_mirror/tolerance/):
both ask what depth error survives a calibration on the made part.
This one models the calibration as a per-lobe smooth radial map in the image (what a
generic radial model absorbs on an aligned camera: the smooth form a polish or a tool
offset leaves, down to a few tens of pixels); a refit of the unified camera model (xi,
gamma, principal point, two or three distortion terms) absorbs less of a mid-spatial form
(it is stiffer) and more of a misalignment (decentre, tilt). `fit_calibration` is the single
place to swap one for the other.

Camera frame, mm and radians inside; image radii in px; ranges in m and errors in % at
the edges.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..design import Mirror
from ..profile import Profile
from .radial import lobe_pixel_radii, radial_displacement, trace_lobe
from .stereo import (
    DepthCurve,
    band_elevations,
    exact_pixels,
    stereo_centre_z,
    triangulate,
    world_points,
)
from .trace import meridian_hits

#: Fixed-point iterations for rho'' + P(rho'') = rho (P' is small: each contracts by |P'|).
_PIXEL_ITER = 8
#: Knot spacing (px) of the radial spline a calibration absorbs by default: a generic
#: (spline) camera model resolves the image's smooth distortion down to a few tens of
#: pixels; a facet of ~1 px period, or a lattice step, is far below it.
CALIBRATION_KNOT_PX = 24.0


@dataclass(frozen=True)
class RadialCalibration:
    """The smooth radial image displacement a calibration absorbs, per lobe (inner first).

    knot_px: spacing (px) of the knots of the least-squares cubic spline P_k(rho) (None:
    nothing absorbed). domains: (lo, hi) image radii (px) of each lobe's fitted pixels;
    knots, coefs: the splines' (scipy BSpline), px.
    """

    knot_px: float | None
    domains: tuple[tuple[float, float], tuple[float, float]]
    knots: tuple[tuple[float, ...], tuple[float, ...]] = ((), ())
    coefs: tuple[tuple[float, ...], tuple[float, ...]] = ((), ())

    def absorbed(self, k: int, radius_px: np.ndarray) -> np.ndarray:
        """P_k (px) at image radii radius_px (px) of lobe k (held at its end values beyond
        the fitted pixels)."""
        rho = np.asarray(radius_px, dtype=float)
        if self.knot_px is None:
            return np.zeros_like(rho)
        from scipy.interpolate import BSpline

        lo, hi = self.domains[k]
        return BSpline(np.asarray(self.knots[k]), np.asarray(self.coefs[k]), 3)(np.clip(rho, lo, hi))

    def calibrated_pixel(self, k: int, radius_px: np.ndarray) -> np.ndarray:
        """The pixel radius (px) at which the calibrated rig reads the direction the design
        images at radius_px: rho'' with rho'' + P_k(rho'') = radius_px."""
        rho = np.asarray(radius_px, dtype=float)
        out = rho.copy()
        for _ in range(_PIXEL_ITER):
            out = rho - self.absorbed(k, out)
        return out

    def to_dict(self) -> dict:
        return {"knot_px": self.knot_px, "domains_px": [list(d) for d in self.domains]}


def fit_calibration(profile: Profile, mirror: Mirror, knot_px: float | None, *, clear_edge_mm: float = 0.0,
                    bin_px: float | None = None,
                    displacements: Sequence[tuple[np.ndarray, np.ndarray, np.ndarray]] | None = None
                    ) -> RadialCalibration:
    """The per-lobe smooth map (a cubic spline in rho, knots knot_px apart; None: none) a
    calibration absorbs on this surface, by least squares weighted by pixel counts.

    Fitted over the lobe's usable pixels whose exact ray meets the lobe clear_edge_mm (mm)
    or more inside its edges (the step and the rim; the clear aperture): a rolled edge
    bends the rays of a few pixels by many pixels, which no smooth map follows.
    displacements: per lobe (radius_px, count, d_px) if already computed (the polishing
    curve has them): the usable pixel radii, their pixel counts and the radial image
    displacement there (NaN where the made ray misses the lobe: left out of the fit).
    bin_px: fit on image-radius bins of that width (px; radial.lobe_pixel_radii) instead of
    every distinct radius (faster; ten bins per pixel resolve a facet).
    """
    from scipy.interpolate import make_lsq_spline

    domains, knots, coefs = [], [], []
    for k in (0, 1):
        if displacements is None:
            px = lobe_pixel_radii(mirror, k, bin_px=bin_px)
            rho, w = px.radius_px, px.count
            d = radial_displacement(profile, mirror, k, rho)
        else:
            rho, w, d = (np.asarray(a, float) for a in displacements[k])
        ok = np.isfinite(d)
        if clear_edge_mm > 0:
            r = trace_lobe(mirror.lobes[k], mirror, k, rho).r
            lo_r, hi_r = (0.0, mirror.r_junction) if k == 0 else (mirror.r_junction, mirror.r_max)
            ok &= (r <= hi_r - clear_edge_mm) & ((r >= lo_r + clear_edge_mm) if k == 1 else True)
        x, y, wt = rho[ok], d[ok], w[ok]
        lo, hi = float(x.min()), float(x.max())
        domains.append((lo, hi))
        if knot_px is None:
            knots.append(())
            coefs.append(())
            continue
        n_in = max(int(round((hi - lo) / knot_px)) - 1, 0)
        interior = np.linspace(lo, hi, n_in + 2)[1:-1]
        t = np.concatenate([[lo] * 4, interior, [hi] * 4])
        spline = make_lsq_spline(x, y, t, k=3, w=np.sqrt(wt))
        knots.append(tuple(float(v) for v in spline.t))
        coefs.append(tuple(float(v) for v in spline.c))
    return RadialCalibration(knot_px, (domains[0], domains[1]), (knots[0], knots[1]), (coefs[0], coefs[1]))


def calibrated_depth_error(profile: Profile, mirror: Mirror, ranges_m: Sequence[float] | np.ndarray, *,
                           knot_px: float | None = CALIBRATION_KNOT_PX, clear_edge_mm: float = 0.0,
                           bin_px: float | None = None, calibration: RadialCalibration | None = None,
                           elevations: Sequence[float] | np.ndarray | None = None) -> DepthCurve:
    """The calibrated stereo residual (%): depth error of a made surface against range (m)
    once the rig is calibrated on it (see the module doc). Aligned camera.

    knot_px: knot spacing (px) of the per-lobe radial spline calibration absorbs (None:
    nothing, which is stereo.depth_error_curve), fitted over the clear aperture
    (clear_edge_mm, mm; see fit_calibration, and bin_px); calibration: a fitted
    RadialCalibration (overrides these).
    elevations: rad (default stereo.band_elevations). A point whose pixel the made mirror
    sends to the other lobe, the step wall or into the mirror has no depth: NaN.
    """
    cal = calibration if calibration is not None else \
        fit_calibration(profile, mirror, knot_px, clear_edge_mm=clear_edge_mm, bin_px=bin_px)
    ranges_m = np.asarray(ranges_m, dtype=float)
    elev = band_elevations(mirror) if elevations is None else np.asarray(elevations, float)
    w_r, w_z = world_points(mirror, ranges_m * 1e3, elev)
    rho = exact_pixels(mirror, w_r, w_z)
    p, o, ok = [], [], np.ones(w_r.size, bool)
    for k in (0, 1):
        seen = cal.calibrated_pixel(k, rho[k].ravel())
        h = meridian_hits(profile, seen * (mirror.camera.t_pixel / mirror.camera.f))
        ok &= (h.fate == k) & ~h.blocked
        p.append(np.stack([h.r, h.z], -1))
        o.append(np.stack([h.out_r, h.out_z], -1))
    x = triangulate(p[0], o[0], p[1], o[1])
    x[~ok] = np.nan
    x = x.reshape(w_r.shape + (2,))
    ux, uz = np.cos(elev)[None, :], np.sin(elev)[None, :]
    ranges_mm = ranges_m * 1e3
    r_made = x[..., 0] * ux + (x[..., 1] - stereo_centre_z(mirror)) * uz
    return DepthCurve.of(ranges_m, elev, 100.0 * (r_made - ranges_mm[:, None]) / ranges_mm[:, None])


def depth_rms_pct(curve: DepthCurve, range_m: float) -> float:
    """RMS |depth error| (%, capped per point) of a curve at range_m (m)."""
    return float(curve.at(range_m)["rms"]) if math.isfinite(range_m) else math.nan
