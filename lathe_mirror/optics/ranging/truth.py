"""The true range of every panorama pixel in the known room.

The robot's stereo geometry says the reference (outer lobe) panorama's pixel (phi, az)
looks along the ray from the outer viewpoint F1 = (0, 0, 2 e_outer) in the direction
(cos phi cos az, cos phi sin az, sin phi). The room is planes and boxes, so the ray's
first hit is closed form (optics.scene.intersect, the renderer's slab method); the true
range is that point's distance from the stereo centre, and the true disparity the
parallax under which the inner viewpoint sees it, over the grid's elevation step.

Camera frame, mm and radians.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...design import Mirror
from ..scene import Scene, intersect_columns
from .rectify import PanoramaGrid
from .resolution import range_error_pct
from .triangulate import stereo_centre_z


@dataclass(frozen=True)
class TrueRange:
    """Per reference pixel (n_el, n_az): range_mm from the stereo centre, the hit point
    (mm, (..., 3)), the surface id it lies on (optics.scene), the elevation (rad) of the
    point from the stereo centre, the true panorama disparity (px) and the resolution
    model's range error (%) at one pixel of disparity there (resolution.range_error_pct:
    the design's, the same for every made mirror ranged in this room, so computed once)."""

    range_mm: np.ndarray
    points: np.ndarray
    surface: np.ndarray
    elevation: np.ndarray
    disparity: np.ndarray
    model_1px_pct: np.ndarray


def true_range(mirror: Mirror, scene: Scene, grid: PanoramaGrid) -> TrueRange:
    """Intersect every reference pixel's ray with the room (see the module doc)."""
    el = grid.elevations()[:, None]
    az = grid.azimuths()[None, :]
    shape = grid.shape
    dx = np.broadcast_to(np.cos(el) * np.cos(az), shape).ravel()
    dy = np.broadcast_to(np.cos(el) * np.sin(az), shape).ravel()
    dz = np.broadcast_to(np.sin(el), shape).ravel()
    z0 = mirror.outer.focus_z
    origin = [np.zeros(dx.size), np.zeros(dx.size), np.full(dx.size, z0)]
    dist, surface = intersect_columns(scene, origin, [np.ascontiguousarray(x) for x in (dx, dy, dz)])
    p = np.stack([dist * dx, dist * dy, z0 + dist * dz], axis=-1).reshape(*shape, 3)
    r = np.hypot(p[..., 0], p[..., 1])
    zc = stereo_centre_z(mirror)
    phi_inner = np.arctan2(p[..., 2] - mirror.inner.focus_z, r)
    range_mm = np.hypot(r, p[..., 2] - zc)
    elevation = np.arctan2(p[..., 2] - zc, r)
    return TrueRange(range_mm=range_mm, points=p, surface=surface.reshape(shape), elevation=elevation,
                     disparity=(phi_inner - el) / grid.step,
                     model_1px_pct=range_error_pct(mirror, range_mm, elevation))
