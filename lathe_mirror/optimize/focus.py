"""Focus: a thin-lens defocus model of the camera looking at the mirror's virtual images.

A convex mirror shows the scene as a virtual image behind its surface; the camera's lens
focuses on one distance, so each pixel's blur grows with how far its virtual image lies
from that distance. Deep or stacked designs spread the two lobes' virtual images far
apart and win on paper while blurred in fact; this is the model the optimiser's blur
constraint uses.

For a pixel at image radius rho the camera ray meets lobe k at P = (r, z) (camera frame,
mm). A scene point at `object_range` mm from the lobe's viewpoint F1, in the direction F1
sees through P, lies s_o = object_range - |P - F1| in front of the mirror. The mirror's
local powers along the ray (Coddington's equations for a mirror, incidence angle i,
principal curvatures kappa_m in the meridian plane and kappa_s across it):

    tangential  1 / v_t = 1 / s_o + 2 kappa_m / cos(i)
    sagittal    1 / v_s = 1 / s_o + 2 kappa_s cos(i)

put its virtual image v behind P, so at d = |P| + v from the lens (the pinhole of the
design is the thin lens's centre). On a lobe whose foci are the camera and F1 the two
powers agree (the sheet images F1 onto the camera without astigmatism), and the model
keeps both anyway. With the lens focused at d_f (sensor at v_f = 1 / (1/f - 1/d_f)) a
point at d blurs into a circle of diameter

    c = (f / N) v_f |1/d - 1/d_f|                 (N the f-number; c in mm, / T_pixel in px)

linear in the vergence 1/d: the focus that minimises the largest blur over both lobes'
usable annuli sets 1/d_f midway between the smallest and largest vergence (the best
compromise between the two lobes' virtual images).

Units: mm and radians inside; blur in px, focus distance in mm.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..design import Lobe, Mirror

#: Image radii sampled per lobe over its usable annulus (the blur changes slowly along
#: it: 33 samples give the paper's largest blur to 1e-4 px of 257).
SAMPLES = 33


@dataclass(frozen=True)
class Defocus:
    """What the thin-lens model says of a design at one f-number.

    blur_px: the largest blur circle's diameter over both usable annuli (px);
    blur_lobe_px: the largest per lobe, inner first; focus_mm: the distance the lens is
    focused at (mm from the pinhole); virtual_mm: (nearest, farthest) virtual image
    distance from the pinhole over both lobes (mm).
    """

    blur_px: float
    blur_lobe_px: tuple[float, float]
    focus_mm: float
    virtual_mm: tuple[float, float]


def usable_annuli(mirror: Mirror, radii: dict | None = None) -> tuple[tuple[float, float], tuple[float, float]]:
    """Image radii (px) of each lobe's usable annulus, inner first: the inner disc less the
    band the step wall blocks, the outer annulus (Mirror.image_radii_px, or `radii` when
    the caller has them)."""
    radii = mirror.image_radii_px if radii is None else radii
    return (0.0, radii["inner_blocked_by_step"][0]), radii["outer_annulus"]


def virtual_image_distance(lobe: Lobe, mirror: Mirror, radius_px: np.ndarray,
                           object_range: float) -> tuple[np.ndarray, np.ndarray]:
    """Distance (mm) from the lens of the tangential and sagittal virtual images seen at
    these image radii (px) through this lobe, for scene points object_range mm from F1."""
    cam = mirror.camera
    t = np.asarray(radius_px, dtype=float) * cam.t_pixel / cam.f
    r = ray_meets_sheet(lobe, t)
    z = lobe.z(r)
    s = lobe.slope(r)
    w = np.sqrt(1.0 + s * s)
    q = np.sqrt(1.0 + (r / lobe.b) ** 2)
    curv_m = lobe.a / (lobe.b**2 * q**3) / w**3
    # sagittal curvature s / (r w), a / b^2 on the axis (its limit)
    curv_s = np.where(r > 0.0, s / (np.where(r > 0.0, r, 1.0) * w), lobe.a / lobe.b**2)
    p_len = np.hypot(r, z)
    cos_i = np.abs(r * s - z) / (p_len * w)
    s_obj = object_range - np.hypot(r, z - lobe.focus_z)
    v_t = 1.0 / (1.0 / s_obj + 2.0 * curv_m / cos_i)
    v_s = 1.0 / (1.0 / s_obj + 2.0 * curv_s * cos_i)
    return p_len + v_t, p_len + v_s


def defocus(mirror: Mirror, f_number: float, object_range: float, *, samples: int = SAMPLES,
            radii: dict | None = None) -> Defocus:
    """The thin-lens blur of the design (module doc): focus at the best compromise, the
    largest blur (px) over both usable annuli. object_range in mm from each lobe's F1;
    radii: Mirror.image_radii_px if the caller has them."""
    cam = mirror.camera
    verg = []
    for lobe, (lo, hi) in zip(mirror.lobes, usable_annuli(mirror, radii)):
        rho = np.linspace(lo, hi, samples) if hi > lo else np.array([lo])
        d_t, d_s = virtual_image_distance(lobe, mirror, rho, object_range)
        verg.append(np.concatenate([1.0 / d_t, 1.0 / d_s]))
    allv = np.concatenate(verg)
    v_lo, v_hi = float(np.min(allv)), float(np.max(allv))
    v_focus = 0.5 * (v_lo + v_hi)
    sensor = 1.0 / (1.0 / cam.f - v_focus)
    scale = cam.f / f_number * sensor / cam.t_pixel  # px per unit vergence (1/mm)
    per_lobe = tuple(float(np.max(np.abs(v - v_focus)) * scale) for v in verg)
    return Defocus(blur_px=max(per_lobe), blur_lobe_px=per_lobe, focus_mm=1.0 / v_focus,
                   virtual_mm=(1.0 / v_hi, 1.0 / v_lo))


def design_blur_px(mirror: Mirror, settings) -> float:
    """The largest blur circle (px) of the design with the configured lens: [camera]
    f_number, focused at the best compromise for scenes optimize.focus_range_m away (the
    blur the delivered range counts, tolerance.delivered)."""
    return defocus(mirror, settings.camera.f_number, settings.optimize.focus_range_m * 1000.0).blur_px


def ray_meets_sheet(lobe: Lobe, t: np.ndarray) -> np.ndarray:
    """Radius (mm) where the camera ray r = t z (t = tan of its angle off the axis) first
    meets the lobe's upper sheet; 0 on the axis. Vectorised form of the quadratic in r
    that design.Mirror uses for the ray grazing the inner rim."""
    t = np.asarray(t, dtype=float)
    a, b, e = lobe.a, lobe.b, lobe.e
    tt = np.where(t > 0.0, t, 1.0)
    qa = 1.0 / (tt * tt * a * a) - 1.0 / (b * b)
    qb = -2.0 * e / (tt * a * a)
    qc = e * e / (a * a) - 1.0
    disc = np.sqrt(np.maximum(qb * qb - 4.0 * qa * qc, 0.0))
    # the root with z = r / t on the upper sheet (z > e) nearest the camera; qa > 0 when
    # the ray is steeper than the asymptote, where both roots are candidates
    roots = np.stack([(-qb - disc) / (2.0 * qa), (-qb + disc) / (2.0 * qa)])
    ok = (roots > 0.0) & (roots / tt > e)
    r = np.min(np.where(ok, roots, np.inf), axis=0)
    return np.where(t > 0.0, r, 0.0)


__all__ = ["Defocus", "defocus", "design_blur_px", "ray_meets_sheet", "usable_annuli", "virtual_image_distance"]
