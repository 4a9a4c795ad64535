"""Unwrap each lobe's annulus into a panorama on one azimuth x elevation grid.

An aligned camera images the world direction of azimuth az and elevation phi (seen from
lobe k's viewpoint F1) at the image point rho_k(phi) (cos az, sin az), rho_k the exact
lobe's closed-form inverse map (optics.radial.ideal_radius_px: the sheet's focal polar
equation). Azimuth is measured in the camera frame from +x toward +y, which is the image's
u (right) toward v (down): the reflection keeps the meridian plane, so the world azimuth
of a pixel is its image azimuth. Sampling both lobes' images on the same (phi, az) grid
through that map makes each epipolar line (a meridian plane) one column of both
panoramas; a world point's two images differ only in elevation (the parallax).

Grid: rows are elevations, top row highest, row j's centre at phi_j = hi - (j + 1/2) step
over the band (lo, hi); columns are azimuths, column i's centre at (i + 1/2) 2 pi / n_az.
Fractional panorama coordinates put row j's centre at j (as scipy.ndimage does).
Pixel centres of the image (optics.camera): (u, v) = (i + 1/2 - W/2, j + 1/2 - H/2) px from
the principal point, i.e. array index (u + W/2 - 1/2, v + H/2 - 1/2).

mm and radians; pixels where a name says so.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ...design import Mirror
from ...errors import InputError
from ..radial import ideal_radius_px
from .resolution import angular_resolution


@dataclass(frozen=True)
class PanoramaGrid:
    """An azimuth x elevation grid over an elevation band.

    band: (lowest, highest) elevation, rad. n_elevation: rows over the band. n_azimuth:
    columns over the full turn. columns: the turn's columns the grid holds, in order (a
    sample of azimuth, optics.sampling.AzimuthSectors); None: all of them.
    """

    band: tuple[float, float]
    n_elevation: int
    n_azimuth: int
    columns: tuple[int, ...] | None = None

    def __post_init__(self) -> None:
        if not (self.band[1] > self.band[0] and self.n_elevation >= 1 and self.n_azimuth >= 1
                and (self.columns is None or len(self.columns) >= 1)):
            raise InputError(f"panorama grid {self}: needs a non-empty band and at least one row and column")

    def with_columns(self, columns) -> PanoramaGrid:
        """The same grid holding only these of the turn's columns (indices, in order)."""
        return PanoramaGrid(self.band, self.n_elevation, self.n_azimuth, tuple(int(i) for i in columns))

    @property
    def step(self) -> float:
        """Elevation step between rows (rad)."""
        return (self.band[1] - self.band[0]) / self.n_elevation

    @property
    def azimuth_step(self) -> float:
        """Azimuth step between columns (rad)."""
        return 2.0 * math.pi / self.n_azimuth

    @property
    def shape(self) -> tuple[int, int]:
        """(rows, columns) of a panorama on this grid."""
        return (self.n_elevation, self.n_azimuth if self.columns is None else len(self.columns))

    def elevations(self, rows_above: int = 0, rows_below: int = 0) -> np.ndarray:
        """Row-centre elevations (rad), top row first; rows_above / rows_below extra rows
        beyond the band."""
        j = np.arange(-rows_above, self.n_elevation + rows_below)
        return self.band[1] - (j + 0.5) * self.step

    def azimuths(self) -> np.ndarray:
        """Column-centre azimuths (rad) in [0, 2 pi) of the columns held."""
        i = np.arange(self.n_azimuth) if self.columns is None else np.asarray(self.columns)
        return (i + 0.5) * self.azimuth_step

    def pixel_of(self, elevation: np.ndarray | float, azimuth: np.ndarray | float) -> tuple[np.ndarray, np.ndarray]:
        """Fractional (row, column) of directions (rad); row j's centre is j, column i's i."""
        row = (self.band[1] - np.asarray(elevation, float)) / self.step - 0.5
        col = np.mod(np.asarray(azimuth, float), 2.0 * math.pi) / self.azimuth_step - 0.5
        return row, col


def make_grid(mirror: Mirror, *, elevation_step: float | None = None,
              n_azimuth: int | None = None) -> PanoramaGrid:
    """The common band's grid. elevation_step (rad): default the finer of the two lobes'
    angular resolutions at its finest over the band (so neither lobe is undersampled in
    elevation); the band is split into whole rows no coarser than that. n_azimuth: default
    the outer lobe's circumference (px) at the band's middle, rounded up to a multiple of 8.
    InputError if the band is empty."""
    lo, hi = mirror.common_band
    if not hi > lo:
        inner, outer = (mirror.fov_usable(x) for x in mirror.lobes)
        raise InputError(
            "design: the common band is empty (inner lobe sees "
            f"{math.degrees(inner[0]):.2f} to {math.degrees(inner[1]):.2f} deg, outer lobe "
            f"{math.degrees(outer[0]):.2f} to {math.degrees(outer[1]):.2f} deg elevation): no stereo"
        )
    if elevation_step is None:
        el = lo + (np.arange(257) + 0.5) * ((hi - lo) / 257)
        elevation_step = float(min(np.nanmin(angular_resolution(lobe, mirror.camera, el))
                                   for lobe in mirror.lobes))
    if not (elevation_step > 0 and math.isfinite(elevation_step)):
        raise InputError(f"stereo elevation step {elevation_step!r} rad: must be a finite number > 0")
    if n_azimuth is None:
        rho = float(ideal_radius_px(mirror.outer, mirror.camera, 0.5 * (lo + hi)))
        n_azimuth = int(math.ceil(2.0 * math.pi * rho / 8.0)) * 8
    return PanoramaGrid((lo, hi), max(1, int(math.ceil((hi - lo) / elevation_step - 1e-9))), int(n_azimuth))


def image_points(mirror: Mirror, k: int, grid: PanoramaGrid, *, rows_above: int = 0,
                 rows_below: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Image points (u, v) in px from the principal point at which the exact lobe k images
    each grid direction, and whether lobe k sees it: shapes (rows_above + n_el +
    rows_below, n_az).

    Seen: inside the lobe's unblocked field of view (Mirror.fov_usable) and on the sensor.
    """
    lobe = mirror.lobes[k]
    el = grid.elevations(rows_above, rows_below)
    rho = ideal_radius_px(lobe, mirror.camera, el)
    az = grid.azimuths()
    u = rho[:, None] * np.cos(az)[None, :]
    v = rho[:, None] * np.sin(az)[None, :]
    lo, hi = mirror.fov_usable(lobe)
    w, h = mirror.camera.sensor_px
    with np.errstate(invalid="ignore"):
        seen = ((el >= lo) & (el <= hi))[:, None] & (np.abs(u) <= w / 2.0) & (np.abs(v) <= h / 2.0)
    return u, v, seen


def unwrap(image: np.ndarray, mirror: Mirror, k: int, grid: PanoramaGrid, *,
           rows_above: int = 0, rows_below: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Lobe k's panorama of an image (H, W) or (H, W, C) on the grid, and where the lobe
    sees it: float32 (rows_above + n_el + rows_below, n_az[, C]) and a bool mask (rows,
    cols).

    cv2.remap, bilinear, samples the image at image_points (on float32 images OpenCV 5
    weights exactly, no 1/32 px table: a linear ramp comes back to 1e-4 px); outside the
    sensor it gives 0.
    """
    import cv2

    img = np.asarray(image)
    w, h = mirror.camera.sensor_px
    if img.shape[:2] != (h, w):
        raise InputError(f"image shape {img.shape[:2]} is not the camera's sensor ({h} rows x {w} columns)")
    u, v, seen = image_points(mirror, k, grid, rows_above=rows_above, rows_below=rows_below)
    # Unseen directions (NaN) sample outside the image: the constant border, 0.
    map_x = np.where(np.isfinite(u), u + (w / 2.0 - 0.5), -10.0).astype(np.float32)
    map_y = np.where(np.isfinite(v), v + (h / 2.0 - 0.5), -10.0).astype(np.float32)
    pano = cv2.remap(np.ascontiguousarray(img, dtype=np.float32), map_x, map_y, cv2.INTER_LINEAR,
                     borderMode=cv2.BORDER_CONSTANT, borderValue=0)
    return pano, seen
