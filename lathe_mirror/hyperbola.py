"""Closed forms on one lobe's hyperbolic sheet, (z - e)^2 / a^2 - r^2 / b^2 = 1 (design.Lobe:
its a, b, e, focus_z, z and slope): where a camera ray meets it, the point F1 sees at an
elevation, and how far a reflected ray passes from F1. Lengths in mm, angles in rad.
design.Mirror uses them; design re-exports them for its callers."""

from __future__ import annotations

import math

import numpy as np

__all__ = ["ray_meets_sheet", "sheet_point_seen_from_focus", "single_viewpoint_error"]


def single_viewpoint_error(lobe, r: np.ndarray) -> np.ndarray:
    """Distance (mm) from F1 of the line of each camera ray reflected at radius r.

    A perfect hyperbolic lobe sends every ray from the camera focus through F1.
    """
    r = np.asarray(r, dtype=float)
    p = np.stack([r, lobe.z(r)], axis=-1)
    d = p / np.linalg.norm(p, axis=-1, keepdims=True)
    n = np.stack([lobe.slope(r), -np.ones_like(r)], axis=-1)
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    out = d - 2.0 * np.sum(d * n, axis=-1, keepdims=True) * n
    q = np.array([0.0, lobe.focus_z]) - p
    # 2-D cross product |q x out| with |out| = 1 is the distance of F1 from the line.
    return np.abs(q[..., 0] * out[..., 1] - q[..., 1] * out[..., 0])


def ray_meets_sheet(lobe, t: float) -> float:
    """Radius where the camera ray r = t z meets the lobe's upper sheet (mm).

    Substituting z = r / t in (z - e)^2 / a^2 - r^2 / b^2 = 1 gives a quadratic in r.
    """
    a, b, e = lobe.a, lobe.b, lobe.e
    qa = 1.0 / (t * t * a * a) - 1.0 / (b * b)
    qb = -2.0 * e / (t * a * a)
    qc = e * e / (a * a) - 1.0
    disc = qb * qb - 4.0 * qa * qc
    roots = [(-qb + s * math.sqrt(max(disc, 0.0))) / (2.0 * qa) for s in (1.0, -1.0)]
    # The upper sheet has z - e > 0, i.e. r / t > e.
    good = [x for x in roots if x > 0 and x / t > e]
    return min(good)


def sheet_point_seen_from_focus(lobe, elevation: float) -> tuple[float, float]:
    """Point (r, z) of the lobe's sheet seen from F1 at the given elevation (rad).

    P = F1 + t (cos el, sin el) in (z - e)^2 / a^2 - r^2 / b^2 = 1 is a quadratic in t;
    the sheet's point is its positive root.
    """
    a, b, e = lobe.a, lobe.b, lobe.e
    c, s = math.cos(elevation), math.sin(elevation)
    qa = s * s / (a * a) - c * c / (b * b)
    qb = 2.0 * e * s / (a * a)
    qc = e * e / (a * a) - 1.0
    if abs(qa) < 1e-15:
        t = -qc / qb
    else:
        disc = math.sqrt(max(qb * qb - 4.0 * qa * qc, 0.0))
        t = max((-qb + disc) / (2.0 * qa), (-qb - disc) / (2.0 * qa))
    return (t * c, lobe.focus_z + t * s)
