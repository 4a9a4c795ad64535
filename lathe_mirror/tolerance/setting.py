"""What a tool-setting error costs: the exact mirror turned with the tool's offset off.

A touch-off error moves the whole cut: an X (radius) error dx puts every point of the
profile at r + dx, so the surface of revolution becomes z(|r - dx|), a cone point of
slope error atan(z'(dx)) ~ (a / b^2) dx at the vertex (the hyperbola's vertex curvature);
a Z error moves the mirror along the axis, which the camera sees as its own axial shift.
Both are applied to the exact design, so the figures are the setting error's alone (the
turning's own errors are the program's figures). Lengths in mm, slopes in rad, image
displacement in px (ARCHITECTURE.md's names; radial figures over each lobe's usable
annulus, surface figures over the radii the image uses).
"""

from __future__ import annotations

import numpy as np

from ..design import Mirror
from ..optics.radial import radial_figures, surface_errors
from ..profile import ExactProfile, Profile


class ShiftedProfile(Profile):
    """A profile turned with the tool's X (radius) off by dr mm: z(|r - dr|), camera frame."""

    def __init__(self, base: Profile, dr: float) -> None:
        super().__init__(r_junction=base.r_junction, r_max=base.r_max, vertex_z=base.vertex_z)
        self.base, self.dr = base, float(dr)

    def _q(self, r: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Where on the base each radius was cut (kept on its own lobe: the step wall moves
        with the tool, a ring of width dr at the junction is not judged) and the sign."""
        r = np.asarray(r, dtype=float)
        q = r - self.dr
        rj = self.r_junction
        a = np.where(r <= rj, np.minimum(np.abs(q), rj), np.maximum(np.abs(q), np.nextafter(rj, np.inf)))
        return a, np.where(q < 0, -1.0, 1.0)

    def z(self, r: np.ndarray) -> np.ndarray:
        return self.base.z(self._q(r)[0])

    def slope(self, r: np.ndarray) -> np.ndarray:
        q, sign = self._q(r)
        return self.base.slope(q) * sign


def setting_error_costs(mirror: Mirror, delta_mm: float = 0.01) -> dict:
    """Per lobe, inner first, what an X (radius) and a Z setting error of delta_mm cost:
    {"delta_mm", "x": {"lobes": [{name, slope_error_rad, image_displacement_px,
    ray_deviation_deg}]}, "z": {...}}, each figure {rms, max}."""
    exact = ExactProfile(mirror)
    out: dict = {"delta_mm": float(delta_mm)}
    for axis, profile, dz in (("x", ShiftedProfile(exact, delta_mm), 0.0), ("z", exact, delta_mm)):
        surf = surface_errors(profile, mirror, used=True)
        rad = radial_figures(profile, mirror, camera_dz=dz)
        lobes = []
        for s, r in zip(surf["lobes"], rad["lobes"]):
            # a Z error leaves the surface exact, only delta_mm off along the axis
            slope = s["slope_error_rad"] if axis == "x" else {"rms": 0.0, "max": 0.0}
            lobes.append({"name": s["name"], "slope_error_rad": slope,
                          "image_displacement_px": r["image_displacement_px"],
                          "ray_deviation_deg": r["ray_deviation_deg"]})
        out[axis] = {"lobes": lobes}
    return out
