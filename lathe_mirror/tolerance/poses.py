"""A tolerance trial's camera in the mirror's frame: its pinhole and rotation from the
drawn decentre, axial offset, tilt and the mirror's seat tilt (tolerance.perturb). mm, rad."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class PoseDraws:
    """What a pose is made of, one value a trial (a perturb.Trials is one, with the
    machining's draws beside): the pinhole's decentre and axial offset (mm), the camera's
    and the seat's tilts (rad)."""

    cam_x_mm: np.ndarray
    cam_y_mm: np.ndarray
    cam_z_mm: np.ndarray
    tilt_x: np.ndarray
    tilt_y: np.ndarray
    seat_x: np.ndarray
    seat_y: np.ndarray


def poses(tr: PoseDraws, seat_pivot_mm: float) -> tuple[np.ndarray, np.ndarray]:
    """The camera's pinhole (trials, 3) and rotation (camera -> mirror frame, (trials, 3, 3))
    in the mirror's frame.

    The camera is decentred (cam_x, cam_y), moved along the axis (cam_z) and turned about
    its pinhole by R_c = R_y(tilt_y) R_x(tilt_x); the mirror is turned by S = R_y(seat_y)
    R_x(seat_x) about the pivot C = (0, 0, seat_pivot_mm). In the mirror's frame the
    pinhole is S^T (o - C) + C and the rotation S^T R_c: a seat tilt t moves the pinhole
    sideways by seat_pivot_mm sin t (0.218 mm for 0.1 deg at 125 mm).
    """
    o = np.stack([tr.cam_x_mm, tr.cam_y_mm, tr.cam_z_mm], axis=1)
    rc = _rot_yx(tr.tilt_x, tr.tilt_y)
    s = _rot_yx(tr.seat_x, tr.seat_y)
    st = np.transpose(s, (0, 2, 1))
    c = np.array([0.0, 0.0, seat_pivot_mm])
    origin = np.einsum("tij,tj->ti", st, o - c) + c
    return origin, st @ rc


def _rot_yx(ax: np.ndarray, ay: np.ndarray) -> np.ndarray:
    """R_y(ay) R_x(ax) for arrays of angles (rad)."""
    cx, sx, cy, sy = np.cos(ax), np.sin(ax), np.cos(ay), np.sin(ay)
    zero, one = np.zeros_like(cx), np.ones_like(cx)
    rx = np.stack([np.stack([one, zero, zero], -1), np.stack([zero, cx, -sx], -1),
                   np.stack([zero, sx, cx], -1)], axis=1)
    ry = np.stack([np.stack([cy, zero, sy], -1), np.stack([zero, one, zero], -1),
                   np.stack([-sy, zero, cy], -1)], axis=1)
    return ry @ rx
