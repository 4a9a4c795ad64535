"""The samples a trial is traced and judged on: a sparse sample of each lobe's pixels
(image-radius bins x azimuths, each ray weighted by the pixel centres it stands for) and
the world points of the common band the stereo figures cross the lobes' rays at; the
depth error a matching noise alone gives (the matcher's floor).

Mirror frame (the design's camera frame), mm and radians.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..design import Mirror
from ..optics.radial import lobe_pixel_radii
from ..optics.ranging.resolution import parallax_per_px, range_error_pct
from ..optics.stereo import band_elevations, stereo_centre_z

#: Azimuths of the stereo points.
DEPTH_AZIMUTHS = 4
#: The widest lobe (px of image radius) whose sample's bins are tolerance.bin_px wide: a
#: wider lobe is cut into SAMPLE_LOBE_PX / bin_px equal bins (80 at the default 4 px), so
#: a trial of a 12-megapixel design traces what the paper's does; the paper's lobes (281
#: and 192 px wide) keep bin_px, whatever it is. Halving and doubling it keeps the yield
#: and the trials' mean RMS image displacement within 1 % (tests/test_sampling.py).
SAMPLE_LOBE_PX = 320.0


@dataclass(frozen=True)
class PixelSample:
    """Sparse pixel sample of one lobe: (u, v) px from the principal point, and weights
    (the number of pixel centres each stands for)."""

    u: np.ndarray
    v: np.ndarray
    weight: np.ndarray




def pixel_sample(mirror: Mirror, k: int, *, bin_px: float, azimuths: int, zones=None,
                 max_radii: int | None = None) -> PixelSample:
    """Image-radius bins of lobe k's annulus x `azimuths` evenly spaced azimuths: bins
    bin_px wide, at most max_radii (default SAMPLE_LOBE_PX / bin_px, rounded up) of them
    (equal bins across a wider lobe).

    Each ray's weight is its bin's pixel count / azimuths, so weighted sums over the
    sample estimate sums over all the lobe's pixel centres (exactly, for a radial field).
    zones: optics.zones.Zones: the lobe's used zone only (the fillet ring left out).
    """
    max_radii = int(math.ceil(SAMPLE_LOBE_PX / bin_px)) if max_radii is None else max_radii
    px = lobe_pixel_radii(mirror, k, bin_px=bin_px, zones=zones, max_radii=max_radii)
    psi = (np.arange(azimuths) + 0.5) * (2.0 * math.pi / azimuths)
    rho, ang = np.meshgrid(px.radius_px, psi, indexing="ij")
    w = np.repeat(px.count[:, None] / azimuths, azimuths, axis=1)
    return PixelSample(u=(rho * np.cos(ang)).ravel(), v=(rho * np.sin(ang)).ravel(), weight=w.ravel())


@dataclass(frozen=True)
class StereoPoints:
    """World points of the common band at each range from the stereo centre (mirror frame).

    w: (ranges, m, 3) mm; unit: (m, 3) their directions from the stereo centre; range_mm
    (ranges,); elevation (m,) rad; parallax_base: B cos(elevation) (m,) mm, the baseline's
    part across the line of sight; px_scale: (m,) rad of parallax per px of image error in
    each lobe (optics.ranging.resolution.parallax_per_px: sqrt(s_inner^2 + s_outer^2), s_k
    the lobe's |d elevation / d image radius|; 5.6e-3 at -13 deg on the paper mirror).
    """

    w: np.ndarray
    unit: np.ndarray
    range_mm: np.ndarray
    elevation: np.ndarray
    centre_z: float
    parallax_base: np.ndarray
    px_scale: np.ndarray


def stereo_points(mirror: Mirror, ranges_m, n_elev: int, n_azimuth: int = DEPTH_AZIMUTHS) -> StereoPoints:
    """Points at each range (m) at n_elev elevations across the common band x n_azimuth."""
    elev = band_elevations(mirror, n_elev) if n_elev > 1 else np.array([np.mean(mirror.common_band)])
    psi = np.arange(n_azimuth) * (2.0 * math.pi / n_azimuth)
    e, a = np.meshgrid(elev, psi, indexing="ij")
    e, a = e.ravel(), a.ravel()
    unit = np.stack([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)], -1)
    rng = np.asarray(ranges_m, float) * 1e3
    zc = stereo_centre_z(mirror)
    w = rng[:, None, None] * unit[None] + np.array([0.0, 0.0, zc])
    return StereoPoints(w, unit, rng, e, zc, mirror.baseline * np.cos(e), parallax_per_px(mirror, e))


def matching_floor_pct(mirror: Mirror, ranges_m, noise_px: float, n_elev: int) -> np.ndarray:
    """The depth error (%) that a matching noise of noise_px (px, in each lobe) alone gives
    at each range (m), to first order (optics.ranging.resolution.range_error_pct), median
    over the band's elevations."""
    sp = stereo_points(mirror, [1.0], n_elev, 1)
    per_m = range_error_pct(mirror, 1.0, sp.elevation, noise_px * sp.px_scale)  # % per mm of range
    return np.asarray(ranges_m, float) * 1e3 * float(np.median(per_m))
