"""The haze a mirror's surface finish puts into the image, per lobe.

finish.py gives the roughness of a process's surface and the scatter formulas; this module
takes them to the camera's pixels. Each pixel of a lobe's usable annulus sees the mirror at
radius r (the exact design's ray), at an angle of incidence theta_i, with an angular scale
(px of image radius per radian of the reflected ray's elevation: where a ray deflected by a
small angle lands). Per pixel, with D = exp(-removal(r) / l_c) the fraction of the turned
roughness a polish leaves (removal from polishing.LapPlan):

- roughness sigma(r) = sqrt(D^2 (sigma_feed^2 + sigma_turned^2) + (1 - D^2) sigma_polished^2);
- TIS = (4 pi sigma cos(theta_i) / lambda)^2, the small-roughness figure;
- haze = the fraction of the light scattered out of the pixel: 1 - eta_feed exp(-(4 pi
  sigma_floor cos(theta_i) / lambda)^2), eta_feed the specular fraction of the feed marks
  (their arc profile scaled by D; finish.specular_fraction) when their first diffraction
  order lands more than half a pixel away (else 1: the orders stay in the pixel), and the
  Gaussian factor the random floor's specular fraction (Debye-Waller), whose scatter spreads
  far wider than a pixel.

Figures per lobe: the pixel-weighted RMS roughness (nm) and its max, the mean and max TIS
and haze, and the feed marks' order spacing (deg; px at the lobe's angular scale).
Camera frame, mm and radians inside.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from ..design import Mirror
from ..finish import (
    Process,
    feed_mark_profile,
    order_spacing,
    roughness_rms,
    specular_fraction,
    total_integrated_scatter,
)
from .radial import lobe_pixel_radii, trace_lobe

#: Values of (feed-mark amplitude factor x cos(theta_i)) at which the feed marks' specular
#: fraction is tabulated (it is then interpolated per pixel).
_ETA_TABLE = 512


@dataclass(frozen=True)
class LobeGeometry:
    """Per distinct usable image radius of a lobe: pixel count, mirror radius r (mm), cos of
    the angle of incidence, and the angular scale (px per rad of reflected elevation)."""

    count: np.ndarray
    r: np.ndarray
    cos_incidence: np.ndarray
    px_per_rad: np.ndarray


def lobe_geometry(mirror: Mirror, k: int, *, bin_px: float | None = None) -> LobeGeometry:
    """The exact design's geometry of lobe k's usable pixels (see LobeGeometry); bin_px: on
    image-radius bins of that width (px) instead of every distinct radius."""
    px = lobe_pixel_radii(mirror, k, bin_px=bin_px)
    rays = trace_lobe(mirror.lobes[k], mirror, k, px.radius_px)
    norm = np.hypot(rays.r, rays.z)
    d_r, d_z = rays.r / norm, rays.z / norm
    # The ray turns by pi - 2 theta_i: d . o = -cos(2 theta_i).
    cos2 = np.clip(-(d_r * rays.o_r + d_z * rays.o_z), -1.0, 1.0)
    cos_i = np.cos(0.5 * np.arccos(cos2))
    elev = rays.elevation
    slope = np.abs(np.gradient(elev, px.radius_px))  # rad per px
    with np.errstate(divide="ignore"):
        scale = np.where(slope > 0, 1.0 / slope, np.inf)
    return LobeGeometry(px.count, rays.r, cos_i, scale)


def haze_figures(mirror: Mirror, process: Process, *, removal_mm, compliance_mm: float,
                 wavelength_mm: float, geometry: tuple[LobeGeometry, LobeGeometry] | None = None) -> dict:
    """Roughness, TIS and haze of each lobe's usable pixels for a resolved process (its
    nose, feed set), after a polish that removed removal_mm(k, r) (mm; a function of the
    lobe and the mirror radius, mm; None: as turned). Returns {"lobes": [...]}."""
    geo = geometry or (lobe_geometry(mirror, 0), lobe_geometry(mirror, 1))
    spacing = order_spacing(process.feed_mm, wavelength_mm)
    lobes = []
    for k, g in enumerate(geo):
        removal = np.zeros_like(g.r) if removal_mm is None else np.asarray(removal_mm(k, g.r), float)
        smooth = np.exp(-removal / compliance_mm)
        sigma = roughness_rms(process, smooth)
        floor = np.sqrt(smooth**2 * (process.turned_floor_nm * 1e-6) ** 2
                        + (1.0 - smooth**2) * (process.polished_floor_nm * 1e-6) ** 2)
        tis = total_integrated_scatter(sigma, wavelength_mm, g.cos_incidence)
        eta_feed = _feed_specular(process.feed_mm, process.nose_radius_mm, wavelength_mm, smooth * g.cos_incidence)
        order_px = spacing * g.px_per_rad
        eta_feed = np.where(order_px > 0.5, eta_feed, 1.0)
        haze = 1.0 - eta_feed * np.exp(-(4.0 * math.pi * floor * g.cos_incidence / wavelength_mm) ** 2)
        w = g.count
        lobes.append({
            "name": mirror.lobes[k].name,
            "roughness_nm": {"rms": float(np.sqrt(np.sum(w * sigma**2) / np.sum(w))) * 1e6,
                             "max": float(np.max(sigma)) * 1e6},
            "tis": {"mean": float(np.sum(w * tis) / np.sum(w)), "max": float(np.max(tis))},
            "haze": {"mean": float(np.sum(w * haze) / np.sum(w)), "max": float(np.max(haze))},
            "order_spacing_deg": math.degrees(spacing),
            "order_spacing_px": {"min": float(np.min(order_px)), "max": float(np.max(order_px[np.isfinite(order_px)]))},
        })
    return {"lobes": lobes}


def _feed_specular(feed_mm: float, nose_mm: float, wavelength_mm: float, factor: np.ndarray) -> np.ndarray:
    """Specular fraction of the feed marks scaled in height by `factor` (amplitude left x
    cos(theta_i)), interpolated from a table over factor in [0, 1]."""
    xs, eta = _eta_table(feed_mm, nose_mm, wavelength_mm)
    return np.interp(np.clip(factor, 0.0, 1.0), xs, eta)


@functools.lru_cache(maxsize=8)
def _eta_table(feed_mm: float, nose_mm: float, wavelength_mm: float) -> tuple[np.ndarray, np.ndarray]:
    h = feed_mark_profile(feed_mm, nose_mm)
    xs = np.linspace(0.0, 1.0, _ETA_TABLE)
    return xs, specular_fraction(xs[:, None] * h[None, :], wavelength_mm)
