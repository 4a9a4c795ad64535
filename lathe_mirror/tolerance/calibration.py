"""What a user's calibration removes, fitted per trial; the model it leaves the robot with.

A robot calibrates its catadioptric camera before it ranges: it fits the camera's pose
and each lobe's projection to images of a known target. What that fit can absorb is not
an error of the made camera; what it cannot is. The calibrated model here is the design's
own model made flexible in the ways a calibration is:

- the camera's rotation about its pinhole (3 angles, shared by both lobes): a camera
  tilted on its mount is a pure rotation of its rays, which any extrinsic calibration
  removes (it is also the rotation part of a tilted mirror seat);
- a smooth radial mapping per lobe: the image radius the design predicts, corrected by a
  cubic in the radius (Chebyshev terms over the lobe's annulus; 4 coefficients a lobe,
  as many radial degrees of freedom as OpenCV's omnidir model has, xi, gamma, k1, k2).
  The unified camera model's refit (optics.camera_model.refit: xi, gamma, k1,
  k2 by scipy least squares, ~0.3 s a lobe) is the same idea for one surface; this fit
  is vectorised over a thousand trials at once, and tests/test_tolerance.py checks its
  residual against refit's reprojection error on aligned made mirrors (to 1 % polished).

The model's viewpoints stay at the design's foci F1, so what a pose error does to the
single viewpoint (a decentred pinhole, a shifted pupil, a tilted seat's decentre) is
left for the figures: the calibration cannot move where the rays cross.

Model of lobe k, for a world direction w (unit, from F1 outward): the exact sheet's point
P = F1 + w b^2 / (a - e w_z) (the focal polar equation), seen by the rotated camera,
c = R^T P, at q = (f / t_pixel) (c_x, c_y) / c_z (px from the principal point), then
radially remapped, q' = q (1 + h(|q|) / |q|), h = sum_j c_j T_j(x), x the radius scaled
to [-1, 1] over the lobe's annulus. The fit minimises the image residual q'(w) - p over
each lobe's sample pixels p (w: the direction the made mirror sends p to), by
Gauss-Newton, with Huber weights (1 px) after the first iterations, so that the handful
of pixels at the step's edge, which see nothing a smooth model could map, do not drag it
(a calibration toolbox rejects such outliers); they still count in the residual figures.

Camera frame of the design (the mirror's frame), mm and radians; pixels from the
principal point.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..design import Mirror

#: Radial polynomial terms per lobe (Chebyshev T_0 .. T_3).
RADIAL_TERMS = 4
#: Gauss-Newton iterations: plain least squares, then with Huber weights (the problem is
#: nearly linear: the residual after these is converged to < 1e-6 px on a pure rotation).
PLAIN_ITERATIONS = 1
ROBUST_ITERATIONS = 2
#: The fit uses every FIT_STRIDE-th pixel of each lobe's sample (all of them are scored).
FIT_STRIDE = 3
#: Residual (px) beyond which a pixel's weight falls as 1 / residual (Huber).
HUBER_PX = 1.0


@dataclass
class Calibration:
    """Fitted per trial: rotation (trials, 3, 3) of the camera (camera -> mirror frame),
    radial coefficients (trials, 2, RADIAL_TERMS) in px, and each lobe's radius scaling
    (lo, hi) px of the Chebyshev variable."""

    rotation: np.ndarray
    coeffs: np.ndarray
    span: tuple[tuple[float, float], tuple[float, float]]

    @staticmethod
    def identity(n: int, span) -> "Calibration":
        """The design's own model (no calibration): for the raw figures."""
        return Calibration(np.broadcast_to(np.eye(3), (n, 3, 3)).copy(), np.zeros((n, 2, RADIAL_TERMS)), span)

    def take(self, idx) -> "Calibration":
        return Calibration(self.rotation[idx], self.coeffs[idx], self.span)

    def angles_deg(self) -> np.ndarray:
        """The fitted rotation as (about x, about y, about z) degrees, R = R_z R_y R_x."""
        r = self.rotation
        ay = np.arcsin(np.clip(-r[:, 2, 0], -1.0, 1.0))
        ax = np.arctan2(r[:, 2, 1], r[:, 2, 2])
        az = np.arctan2(r[:, 1, 0], r[:, 0, 0])
        return np.degrees(np.stack([ax, ay, az], axis=1))


def lobe_span(u: np.ndarray, v: np.ndarray) -> tuple[float, float]:
    """(lo, hi) image radius (px) of a lobe's sample: the radial polynomial's domain."""
    rho = np.hypot(u, v)
    lo, hi = float(rho.min()), float(rho.max())
    return (lo, hi if hi > lo else lo + 1.0)


def model_pixels(mirror: Mirror, k: int, w: np.ndarray, cal: Calibration,
                 points: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Where the calibrated model of lobe k images world directions w (trials, m, 3)
    (unit, from F1 outward): (u, v) px, each (trials, m); NaN where the lobe cannot see w.
    points: sheet_points(mirror, k, w), when the caller has them (they do not depend on
    the calibration: one set serves the raw and the calibrated model)."""
    q, _ = _project(mirror, k, w, cal.rotation, points)
    qr = _remap(q, cal.coeffs[:, k], cal.span[k])
    return qr[..., 0], qr[..., 1]


def model_directions(mirror: Mirror, k: int, u: np.ndarray, v: np.ndarray, cal: Calibration) -> np.ndarray:
    """The calibrated model's world direction (unit, from F1 outward) of pixels (u, v) px of
    lobe k: arrays (m,) or (trials, m); returns (trials, m, 3)."""
    lobe = mirror.lobes[k]
    cam = mirror.camera
    n = cal.rotation.shape[0]
    u = np.broadcast_to(u, (n,) + np.shape(u)[-1:])
    v = np.broadcast_to(v, u.shape)
    rho_p = np.hypot(u, v)
    # Undo the radial map: rho + h(rho) = rho_p, by fixed-point iteration (|h'| << 1); no
    # map (the design's own model: every coefficient 0, h = 0 exactly) leaves rho_p as it is.
    rho = rho_p.copy()
    for _ in range(4 if np.any(cal.coeffs[:, k]) else 0):
        rho = rho_p - _poly(rho, cal.coeffs[:, k], cal.span[k])[0]
    scale = np.where(rho_p > 0, rho / np.where(rho_p > 0, rho_p, 1.0), 1.0)
    c = np.stack([u * scale * cam.t_pixel / cam.f, v * scale * cam.t_pixel / cam.f, np.ones_like(u)], axis=-1)
    d = c @ np.transpose(cal.rotation, (0, 2, 1))
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    # The ray t d from the pinhole (the outer focus) meets the upper sheet
    # (z - e)^2 / a^2 - (x^2 + y^2) / b^2 = 1 where t d_z > e: A t^2 + B t + C = 0.
    a, b, e = lobe.a, lobe.b, lobe.e
    dz, dh2 = d[..., 2], d[..., 0] ** 2 + d[..., 1] ** 2
    A = dz**2 / a**2 - dh2 / b**2
    B = -2.0 * e * dz / a**2
    C = e**2 / a**2 - 1.0
    disc = np.sqrt(np.maximum(B * B - 4 * A * C, 0.0))
    with np.errstate(divide="ignore", invalid="ignore"):
        roots = np.stack([(-B + disc) / (2 * A), (-B - disc) / (2 * A)], axis=-1)
    upper = (roots * dz[..., None] > e) & (roots > 0)
    t = np.where(upper, roots, np.inf).min(axis=-1)
    p = t[..., None] * d
    out = p - np.array([0.0, 0.0, lobe.focus_z])
    return out / np.linalg.norm(out, axis=-1, keepdims=True)


def fit(mirror: Mirror, pixels: list[tuple[np.ndarray, np.ndarray, np.ndarray]],
        directions: list[np.ndarray], valid: list[np.ndarray]) -> Calibration:
    """The calibration of each trial: the rotation and radial maps that best image the
    made directions at their pixels.

    pixels: per lobe (u, v, weight) of its sample, (m_k,) each (px; the weight is the
    number of pixel centres a sample stands for). directions: per lobe (trials, m_k, 3),
    where the made mirror sends each pixel (unit). valid: per lobe (trials, m_k), the
    pixels whose made ray lands on the lobe.
    """
    n = directions[0].shape[0]
    span = (lobe_span(pixels[0][0], pixels[0][1]), lobe_span(pixels[1][0], pixels[1][1]))
    cal = Calibration.identity(n, span)
    npar = 3 + 2 * RADIAL_TERMS
    sub = [slice(None, None, FIT_STRIDE)] * 2
    base_w = [np.where(valid[k][:, sub[k]], pixels[k][2][None, sub[k]], 0.0) for k in (0, 1)]
    pts = [np.stack([pixels[k][0][sub[k]], pixels[k][1][sub[k]]], axis=-1) for k in (0, 1)]
    # Pixels whose made ray misses the lobe carry no weight (and a harmless direction).
    directions = [np.where(valid[k][:, sub[k], None], directions[k][:, sub[k]], np.array([1.0, 0.0, 0.0]))
                  for k in (0, 1)]
    huber = [np.ones_like(w) for w in base_w]
    points = [sheet_points(mirror, k, directions[k]) for k in (0, 1)]  # every iteration's, the same
    for it in range(PLAIN_ITERATIONS + ROBUST_ITERATIONS):
        H = np.zeros((n, npar, npar))
        g = np.zeros((n, npar))
        for k in (0, 1):
            res, jac, ok = _residual_and_jacobian(mirror, k, directions[k], cal, pts[k], points[k])
            w = np.where(ok, base_w[k] * huber[k], 0.0)
            cols = list(range(3)) + list(range(3 + k * RADIAL_TERMS, 3 + (k + 1) * RADIAL_TERMS))
            jf = jac.reshape(n, -1, jac.shape[-1])
            wf = np.repeat(w, 2, axis=1)[..., None]
            jw = np.transpose(jf * wf, (0, 2, 1))
            Hk = jw @ jf
            gk = (jw @ res.reshape(n, -1, 1))[..., 0]
            H[np.ix_(np.arange(n), cols, cols)] += Hk
            g[:, cols] += gk
        # A touch of damping keeps a lobe without valid pixels (or a flat direction) solvable.
        damp = 1e-9 * (np.trace(H, axis1=1, axis2=2)[:, None, None] / npar + 1e-30) * np.eye(npar)
        step = -np.linalg.solve(H + damp, g[..., None])[..., 0]
        cal = Calibration(cal.rotation @ _rodrigues(step[:, :3]),
                          cal.coeffs + step[:, 3:].reshape(n, 2, RADIAL_TERMS), span)
        if PLAIN_ITERATIONS <= it + 1 < PLAIN_ITERATIONS + ROBUST_ITERATIONS:  # the next iteration's weights
            for k in (0, 1):
                res = residuals(mirror, k, directions[k], cal, pts[k][..., 0], pts[k][..., 1], points[k])
                mag = np.where(np.isfinite(res), res, 0.0)
                huber[k] = np.minimum(1.0, HUBER_PX / np.maximum(mag, 1e-300))
    return cal


def residuals(mirror: Mirror, k: int, w: np.ndarray, cal: Calibration, u: np.ndarray, v: np.ndarray,
              points: np.ndarray | None = None) -> np.ndarray:
    """|q'(w) - p| (px) of each pixel p = (u, v) of lobe k whose made direction is w
    (trials, m, 3); NaN where the model cannot image w. points: as model_pixels'."""
    mu, mv = model_pixels(mirror, k, w, cal, points)
    return np.hypot(mu - u, mv - v)


# --------------------------------------------------------------------------------------


def sheet_points(mirror: Mirror, k: int, w: np.ndarray) -> np.ndarray:
    """The exact sheet's point P = F1 + w b^2 / (a - e w_z) (mm, mirror frame) of lobe k
    for directions w (..., 3); NaN where the lobe cannot see w."""
    lobe = mirror.lobes[k]
    den = lobe.a - lobe.e * w[..., 2]
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.where(den > 0, lobe.b**2 / den, np.nan)
    p = w * s[..., None]
    p[..., 2] += lobe.focus_z
    return p


def _project(mirror: Mirror, k: int, w: np.ndarray, rotation: np.ndarray,
             points: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Pixel q (trials, m, 2) of the exact sheet's point for direction w seen by the camera
    rotated by `rotation`, and that point in the camera frame c (trials, m, 3). points:
    sheet_points(mirror, k, w), if made already."""
    cam = mirror.camera
    p = sheet_points(mirror, k, w) if points is None else points
    c = p @ rotation  # R^T P, row-wise
    F = cam.f / cam.t_pixel
    with np.errstate(divide="ignore", invalid="ignore"):
        q = F * c[..., :2] / c[..., 2:3]
    return q, c


def _poly(rho: np.ndarray, coeffs: np.ndarray, span: tuple[float, float]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """h(rho) (px), dh/drho, and the basis T_j(x) (..., RADIAL_TERMS) for coefficients
    (trials, RADIAL_TERMS) and radii (trials, m)."""
    lo, hi = span
    x = 2.0 * (rho - lo) / (hi - lo) - 1.0
    dx = 2.0 / (hi - lo)
    x2 = x * x
    t2, t3 = 2 * x2 - 1, (4 * x2 - 3) * x
    c = [coeffs[:, j, None] for j in range(RADIAL_TERMS)]
    h = c[0] + c[1] * x + c[2] * t2 + c[3] * t3
    dh = (c[1] + c[2] * 4 * x + c[3] * (12 * x2 - 3)) * dx
    basis = np.stack([np.ones_like(x), x, t2, t3], axis=-1)
    return h, dh, basis


def _remap(q: np.ndarray, coeffs: np.ndarray, span) -> np.ndarray:
    rho = np.hypot(q[..., 0], q[..., 1])
    h, _, _ = _poly(rho, coeffs, span)
    with np.errstate(divide="ignore", invalid="ignore"):
        f = np.where(rho > 0, 1.0 + h / rho, 1.0)
    return q * f[..., None]


def _residual_and_jacobian(mirror, k, w, cal, pts, points=None):
    """Residual q'(w) - p (trials, m, 2), its Jacobian (trials, m, 2, 3 + RADIAL_TERMS)
    in (rotation increment, lobe k's coefficients), and where it is defined. points: the
    sheet's points of w (sheet_points), if made already."""
    F = mirror.camera.f / mirror.camera.t_pixel
    q, c = _project(mirror, k, w, cal.rotation, points)
    rho = np.hypot(q[..., 0], q[..., 1])
    coeffs = cal.coeffs[:, k]
    h, dh, basis = _poly(rho, coeffs, cal.span[k])
    ok = np.isfinite(rho) & (rho > 0) & (c[..., 2] > 0)
    rho_s = np.where(ok, rho, 1.0)
    q = np.where(ok[..., None], q, 0.0)
    c = np.where(ok[..., None], c, np.array([0.0, 0.0, 1.0]))
    h, dh = np.where(ok, h, 0.0), np.where(ok, dh, 0.0)
    fac = 1.0 + h / rho_s
    res = q * fac[..., None] - pts[None]
    # dc/d(omega_i) = c x e_i for c(omega) = (I - [omega]x) c0.
    dc = np.stack([np.cross(c, e) for e in np.eye(3)], axis=-1)  # (t, m, 3, 3): component, i
    cz = c[..., 2][..., None]
    dq = F * (dc[..., :2, :] * cz[..., None] - c[..., :2, None] * dc[..., 2:3, :]) / (cz[..., None] ** 2)
    qdq = np.einsum("tma,tmai->tmi", q, dq) / rho_s[..., None]
    coef = (dh / rho_s - h / rho_s**2)[..., None, None]
    dq_rot = dq * fac[..., None, None] + q[..., :, None] * coef * qdq[..., None, :]
    dq_c = (q / rho_s[..., None])[..., :, None] * basis[..., None, :]
    jac = np.concatenate([dq_rot, dq_c], axis=-1)
    # Directions the model cannot image (NaN basis there) must not leak into the sums.
    return np.where(ok[..., None], res, 0.0), np.where(ok[..., None, None], jac, 0.0), ok


def _rodrigues(omega: np.ndarray) -> np.ndarray:
    """Rotation matrices exp([omega]x) for rotation vectors omega (n, 3), rad."""
    th = np.linalg.norm(omega, axis=1)
    safe = np.where(th > 0, th, 1.0)
    kx, ky, kz = (omega / safe[:, None]).T
    z = np.zeros_like(kx)
    K = np.stack([np.stack([z, -kz, ky], -1), np.stack([kz, z, -kx], -1), np.stack([-ky, kx, z], -1)], axis=1)
    s, c = np.sin(th)[:, None, None], (1.0 - np.cos(th))[:, None, None]
    return np.eye(3)[None] + s * K + c * (K @ K)
