"""Disparity to range and 3-D points, from the design's two viewpoints.

Both viewpoints lie on the axis: the outer lobe's F1 at z = 2 e_outer, the inner lobe's
at z = 2 e_inner, the baseline B = 2 (e_outer - e_inner) apart (12.8 mm on the paper's
mirror). A point W = (r, z) in the meridian plane of azimuth az seen at elevation phi_o
from the outer viewpoint and phi_i from the inner one satisfies tan(phi_i) =
(z - 2 e_i) / r and tan(phi_o) = (z - 2 e_o) / r, so

    r = B / (tan(phi_i) - tan(phi_o)),   z = 2 e_o + r tan(phi_o),

and the point is (r cos az, r sin az, z). Range is measured from the stereo centre,
midway between the viewpoints (as the depth error of optics.stereo). Rays that do not
converge in front of the viewpoints (phi_i <= phi_o) have no range: NaN.

Panorama disparity d (px) on a grid of elevation step s: the inner lobe sees the outer
reference pixel's point at phi_i = phi_o + d s (rectify's rows run down in elevation).

Camera frame, mm and radians.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...design import Mirror
from .rectify import PanoramaGrid


@dataclass(frozen=True)
class RangeMap:
    """Range (mm, from the stereo centre) and 3-D points (mm, camera frame) of the
    reference (outer lobe) panorama's pixels: shapes (n_el, n_az) and (n_el, n_az, 3);
    NaN where there is no range."""

    range_mm: np.ndarray
    points: np.ndarray

    @property
    def valid(self) -> np.ndarray:
        return np.isfinite(self.range_mm)


def stereo_centre_z(mirror: Mirror) -> float:
    """Height (mm) of the stereo centre, midway between the two viewpoints F1."""
    return 0.5 * (mirror.inner.focus_z + mirror.outer.focus_z)


def meridian_point(z_outer: float, phi_outer: np.ndarray, z_inner: float,
                   phi_inner: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(r, z) in mm where the rays from (0, z_outer) at elevation phi_outer and from
    (0, z_inner) at phi_inner (rad) cross; NaN unless they cross in front (r > 0)."""
    den = np.tan(np.asarray(phi_inner, float)) - np.tan(np.asarray(phi_outer, float))
    with np.errstate(divide="ignore", invalid="ignore"):
        r = (z_outer - z_inner) / den
    r = np.where(r > 0, r, np.nan)
    return r, z_outer + r * np.tan(phi_outer)


def triangulate(mirror: Mirror, grid: PanoramaGrid, disparity: np.ndarray) -> RangeMap:
    """Range and 3-D point of every reference pixel from its panorama disparity (px,
    (n_el, n_az), NaN where unmatched)."""
    phi_o = grid.elevations()[:, None]
    r, z = meridian_point(mirror.outer.focus_z, phi_o, mirror.inner.focus_z,
                          phi_o + np.asarray(disparity, float) * grid.step)
    az = grid.azimuths()[None, :]
    points = np.stack([r * np.cos(az), r * np.sin(az), z], axis=-1)
    return RangeMap(range_mm=np.hypot(r, z - stereo_centre_z(mirror)), points=points)
