"""The pinhole camera's pixels and rays, and its pose against the mirror axis.

Camera frame (ARCHITECTURE.md): pinhole at the origin, +z up the optical axis toward the
mirror, millimetres. Image coordinates follow the computer-vision convention: column i
grows to the right (+x), row j grows downward (+y), so (x, y, z) is right-handed. A pixel
centre (i + 1/2, j + 1/2) lies at

    u = i + 1/2 - W / 2,   v = j + 1/2 - H / 2        (px, from the principal point)

and its ray has direction (u * t_pixel, v * t_pixel, f): the sensor is drawn in front of
the pinhole (the usual unflipped image). The principal point is the sensor centre.

A misaligned camera (tolerance analysis) is the aligned one moved by a CameraPose: its
pinhole sits at (dx, dy, dz) and its axis is tilted, rotation R = R_y(tilt_y) R_x(tilt_x).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..declared.section import DEGREES, setting
from ..design import Camera
from ..errors import InputError


@dataclass(frozen=True)
class CameraPose:
    """Position and attitude of the camera against the mirror's axis. mm and rad.

    decentre: (dx, dy) of the pinhole off the mirror axis, mm. axial_offset: dz of the
    pinhole along the axis, mm (+ toward the mirror). tilt: (tilt_x, tilt_y), rotations
    of the optical axis about the x then the y axis, rad.
    """

    decentre: tuple[float, float] = setting("camera_pose.decentre")
    axial_offset: float = setting("camera_pose.axial_offset")
    tilt: tuple[float, float] = setting("camera_pose.tilt_deg", DEGREES)

    def __post_init__(self) -> None:
        values = (*self.decentre, self.axial_offset, *self.tilt)
        if len(self.decentre) != 2 or len(self.tilt) != 2 or not all(
            isinstance(x, (int, float)) and math.isfinite(x) for x in values
        ):
            raise InputError(
                f"camera pose {self}: decentre and tilt take two finite numbers each, "
                "axial_offset one (mm, rad)"
            )

    @property
    def aligned(self) -> bool:
        """True when the pinhole is on the axis at z = 0 looking straight up it."""
        return all(x == 0.0 for x in (*self.decentre, self.axial_offset, *self.tilt))

    @property
    def origin(self) -> np.ndarray:
        """Pinhole position in the mirror frame (mm)."""
        return np.array([self.decentre[0], self.decentre[1], self.axial_offset], dtype=float)

    @property
    def rotation(self) -> np.ndarray:
        """3 x 3 rotation taking camera-frame directions to the mirror frame."""
        tx, ty = self.tilt
        cx, sx, cy, sy = math.cos(tx), math.sin(tx), math.cos(ty), math.sin(ty)
        rx = np.array([[1.0, 0.0, 0.0], [0.0, cx, -sx], [0.0, sx, cx]])
        ry = np.array([[cy, 0.0, sy], [0.0, 1.0, 0.0], [-sy, 0.0, cy]])
        return ry @ rx


ALIGNED = CameraPose()


def pixel_centres(camera: Camera, *, supersample: int = 1,
                  window: tuple[int, int, int, int] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Image coordinates (u, v) in px from the principal point of every sample, row-major.

    supersample: n gives n x n samples per pixel on a regular sub-grid (costs n^2 rays).
    window: (col0, row0, width, height) of a crop of the sensor, default the whole sensor.
    Returns arrays of shape (height, width, n * n).
    """
    w_full, h_full = camera.sensor_px
    col0, row0, w, h = window if window is not None else (0, 0, w_full, h_full)
    n = int(supersample)
    if n < 1:
        raise InputError(f"--supersample {supersample}: must be an integer >= 1")
    sub = (np.arange(n) + 0.5) / n  # sub-pixel centres within [0, 1)
    su, sv = np.meshgrid(sub, sub, indexing="xy")
    cols = np.arange(col0, col0 + w, dtype=float)
    rows = np.arange(row0, row0 + h, dtype=float)
    u = cols[None, :, None] + su.reshape(1, 1, -1) - w_full / 2.0
    v = rows[:, None, None] + sv.reshape(1, 1, -1) - h_full / 2.0
    return np.broadcast_to(u, (h, w, n * n)), np.broadcast_to(v, (h, w, n * n))


def ray_directions(camera: Camera, u: np.ndarray, v: np.ndarray,
                   pose: CameraPose = ALIGNED) -> tuple[np.ndarray, np.ndarray]:
    """Ray origin (3,) and unit directions (..., 3) in the mirror frame for image points (px).
    The directions are stored component by component (the (..., 3) array is a view of a
    (3, ...) one: the 3-D tracer reads the components as contiguous rows)."""
    u, v = np.broadcast_arrays(np.asarray(u, float), np.asarray(v, float))
    planar = np.empty((3, u.size))
    uf, vf = u.reshape(-1), v.reshape(-1)
    rot = None if pose.aligned else pose.rotation
    t, f = camera.t_pixel, camera.f
    for a in range(0, uf.size, _RAY_BLOCK):  # blocks that stay in cache
        x = uf[a:a + _RAY_BLOCK] * t
        y = vf[a:a + _RAY_BLOCK] * t
        inv = x * x
        inv += y * y
        inv += f * f
        np.sqrt(inv, out=inv)
        np.divide(1.0, inv, out=inv)
        x *= inv
        y *= inv
        inv *= f  # the z component
        blk = planar[:, a:a + _RAY_BLOCK]
        if rot is None:
            blk[0], blk[1], blk[2] = x, y, inv
        else:
            for c in range(3):
                col = np.multiply(x, rot[c, 0], out=blk[c])
                col += y * rot[c, 1]
                col += inv * rot[c, 2]
    return pose.origin, planar.T.reshape(u.shape + (3,))


#: Rays per block of ray_directions.
_RAY_BLOCK = 1 << 14
