"""Geometry of a lobe's sheet in the machine frame, and of the nose centre's curve.

Machine frame: Z = zero - z (zero = the mirror's vertex_z), r the radius, mm. Used by the
planners (the nose-centre curve each strategy puts on the lattice), by the checks (the
junction's largest nose) and by the metrics and machining (foot points, signed distance).
"""

from __future__ import annotations

import math

import numpy as np

from .design import Lobe, Mirror


def foot_on_sheet(lobe: Lobe, pr, pz, *, zero: float, r0=None) -> np.ndarray:
    """Radius of the point of the sheet (machine frame) nearest to points (pr, pz).

    Radii in mm. Newton's method on d/dr of the squared distance; the points lie within
    a fraction of the radius of curvature (>= b^2 / a, about 15 mm on the paper's lobes)
    of the sheet, where it converges fast.
    """
    pr = np.asarray(pr, dtype=float)
    pz = np.asarray(pz, dtype=float)
    r = pr.copy() if r0 is None else np.asarray(r0, dtype=float).copy()
    for _ in range(8):
        zm = _zm(lobe, r, zero)
        d1 = _dzm(lobe, r)
        g = (r - pr) + (zm - pz) * d1
        dg = 1.0 + d1 * d1 + (zm - pz) * _d2zm(lobe, r)
        step = g / dg
        r = r - step
        if np.all(np.abs(step) < 1e-13):
            break
    return r


def _zm(lobe: Lobe, r, zero: float):
    return zero - lobe.z(r)


def _dzm(lobe: Lobe, r):
    return -lobe.slope(r)


def _d2zm(lobe: Lobe, r):
    # The lobe's own second derivative: a target lobe (a sheet offset by a polishing
    # allowance, cut_surface.CompensatedLobe) is not a hyperbola.
    return -lobe.second_derivative(r)


def _normal_m(lobe: Lobe, r):
    """Outward (free-side, +Z) unit normal of the sheet in the machine frame."""
    s = lobe.slope(r)
    k = 1.0 / np.sqrt(1.0 + s * s)
    return s * k, k


def signed_distance_m(lobe: Lobe, pr, pz, zero: float) -> tuple[np.ndarray, np.ndarray]:
    """Signed distance (mm, + on the free side, +Z) of machine-frame points (pr, pz) from
    the sheet, and the radius of each point's foot on it."""
    rf = foot_on_sheet(lobe, pr, pz, zero=zero)
    nr, nz = _normal_m(lobe, rf)
    d = (np.asarray(pr) - rf) * nr + (np.asarray(pz) - _zm(lobe, rf, zero)) * nz
    return d, rf


def nose_centre(lobe: Lobe, rs, zero: float, rho: float):
    """(r, Z) of the centre of a nose of radius rho touching the sheet at surface radius rs."""
    nr, nz = _normal_m(lobe, rs)
    return rs + rho * nr, _zm(lobe, rs, zero) + rho * nz


def solve_rs_for_centre_r(lobe: Lobe, rho: float, r_centre: float) -> float:
    """Surface radius whose nose centre (offset rho outward) lies at radius r_centre."""
    lo, hi = 0.0, lobe.r_top * 2 + 10.0
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        nr, _ = _normal_m(lobe, mid)
        if mid + rho * nr < r_centre:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


def normal_angles(mirror: Mirror) -> np.ndarray:
    """Directions (rad, from +r toward +Z) of the outward normals of the whole profile."""
    angles = []
    for lobe, (lo, hi) in ((mirror.inner, (0.0, mirror.r_junction)),
                           (mirror.outer, (mirror.r_junction, mirror.r_max))):
        r = np.linspace(lo, hi, 201)
        nr, nz = _normal_m(lobe, r)
        angles.append(np.arctan2(nz, nr))
    # the step wall faces the axis (-r) when the inner lobe is recessed, the rim (+r) when
    # the outer lobe is
    angles.append(np.array([math.pi if mirror.step > 0 else 0.0]))
    return np.concatenate(angles)


class Target:
    """One lobe's nose-centre curve: the sheet offset outward by rho (machine frame).

    Parametrised by the surface radius rs in [rs_lo, rs_hi]; tabulated densely for arc
    length, r -> rs and allocation; evaluated exactly (closed form) everywhere else.
    """

    def __init__(self, lobe: Lobe, zero: float, rho: float, rs_lo: float, rs_hi: float,
                 n: int = 8001) -> None:
        self.lobe, self.zero, self.rho = lobe, zero, rho
        self.rs_lo, self.rs_hi = rs_lo, rs_hi
        rs = np.linspace(rs_lo, rs_hi, n)
        p = self.point(rs)
        self.rs = rs
        self.r_tab = p[:, 0]
        self.s_tab = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(p, axis=0).T))])
        self.theta_tab = self.theta(rs)
        self.length = float(self.s_tab[-1])

    def point(self, rs) -> np.ndarray:
        """Nose centre (..., 2) machine (r, Z), mm, for surface radii rs (mm)."""
        rs = np.asarray(rs, dtype=float)
        return np.stack(nose_centre(self.lobe, rs, self.zero, self.rho), axis=-1)

    def theta(self, rs) -> np.ndarray:
        """Tangent direction (rad) of the curve (toward +r) at surface radius rs."""
        return np.arctan(_dzm(self.lobe, rs))

    def curvature(self, rs) -> np.ndarray:
        """Curvature (1/mm) of the curve at surface radius rs: the sheet's k / (1 + rho k)."""
        s = self.lobe.slope(rs)
        k = -_d2zm(self.lobe, rs) / (1.0 + s * s) ** 1.5
        return k / (1.0 + self.rho * k)

    def rs_at_s(self, s) -> np.ndarray:
        """Surface radius (mm) at arc length s (mm) along the curve from its start."""
        return np.interp(s, self.s_tab, self.rs)

    def rs_at_r(self, r) -> np.ndarray:
        """Surface radius whose nose centre lies at radius r (refined by Newton)."""
        rs = np.interp(r, self.r_tab, self.rs)
        if self.rho == 0.0:
            return np.asarray(rs, dtype=float) * 0 + np.asarray(r, dtype=float)
        for _ in range(3):
            nr, _ = _normal_m(self.lobe, rs)
            h = 1e-6
            nr2, _ = _normal_m(self.lobe, rs + h)
            f = rs + self.rho * nr - r
            df = 1.0 + self.rho * (nr2 - nr) / h
            rs = rs - f / df
        return rs

    def z_at_r(self, r) -> np.ndarray:
        """Machine Z (mm) of the curve at radius r (mm)."""
        return self.point(self.rs_at_r(r))[..., 1]

    def errors(self, pr, pz) -> tuple[np.ndarray, np.ndarray]:
        """Signed offset error (mm, + outside) and target tangent angle at the foot."""
        d, rf = signed_distance_m(self.lobe, pr, pz, self.zero)
        return d - self.rho, self.theta(rf)


def signed_distance_camera(lobe: Lobe, r: np.ndarray, z: np.ndarray) -> np.ndarray:
    """Signed distance (mm) of camera-frame points from the lobe's sheet (+ toward the camera)."""
    # In the machine frame with any vertex height the geometry is the same; use Z = -z.
    return signed_distance_m(lobe, r, -np.asarray(z), 0.0)[0]
