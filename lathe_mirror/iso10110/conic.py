"""Each lobe as an ISO 10110-12 conic: vertex radius R, conic constant k, sag tables.

ISO 10110-12 (and Zemax's Even Asphere with every alpha_n = 0): the sag from the vertex,
along the axis, is

    z(r) = c r^2 / (1 + sqrt(1 - (1 + k) c^2 r^2)),   c = 1 / R (the vertex curvature),

with no r^2 polynomial term (ISO A_2n = Zemax alpha_n = 0 for every n). A lobe is the
upper sheet of (z - e)^2 / a^2 - r^2 / b^2 = 1 (design.py), so from its vertex (z = e + a)
its sag is a (sqrt(1 + r^2 / b^2) - 1), which is the conic above with R = b^2 / a and
k = -(1 + b^2 / a^2) < -1 (a hyperbola). The surface is convex toward the camera; the sag
grows into the part (machine -Z). Lengths in mm, slopes in rad.

Never a bare `c` for the paper's Table 1 figure: that `c` is the focal distance 2e (the
height of the viewpoint F1 above the camera); here c is always the curvature 1 / R.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..design import Lobe, Mirror, conic_sag
from ..errors import InputError
from ..optics.polishing_curve import clear_aperture

#: Sag-table spacing (mm of radius) unless asked for a finer one.
SAG_STEP_MM = 0.5

#: The convention, stated in the JSON and on the drawing.
CONVENTION = ("ISO 10110-12 conic: z(r) = c r^2 / (1 + sqrt(1 - (1 + k) c^2 r^2)), c = 1/R, no r^2 "
              "term, z the sag from the lobe's vertex along the axis, positive into the part (away "
              "from the camera); k < -1: hyperbola. Zemax Even Asphere: curvature = 1/R, conic = k, "
              "every alpha_n = 0 (ISO A_2n = alpha_n)")


@dataclass(frozen=True)
class Conic:
    """One lobe as the optics shop states it. Lengths in mm.

    R: vertex radius of curvature (c = 1/R). k: conic constant. vertex_z: the vertex's
    machine Z (Z = 0 at the mirror's vertex, the inner lobe's; part in -Z): 0 for the inner
    lobe, the outer lobe's (virtual) vertex behind it. clear_aperture: (r_min, r_max) the
    camera uses less the polished edge band (clear_apertures: the polishing analysis's rule). focal_distance_2e: the paper's Table 1 `c`.
    above_pinhole: the vertex's height above the camera's pinhole (camera frame).
    """

    name: str
    R: float
    k: float
    vertex_z: float
    clear_aperture: tuple[float, float]
    focal_distance_2e: float
    above_pinhole: float
    a: float
    b: float

    @property
    def curvature(self) -> float:
        """c = 1 / R (1/mm)."""
        return 1.0 / self.R

    def sag(self, r: np.ndarray | float) -> np.ndarray:
        """ISO 10110-12 sag (mm) from the vertex at radius r (mm) (design.conic_sag)."""
        return conic_sag(r, self.R, self.k)

    def slope(self, r: np.ndarray | float) -> np.ndarray:
        """Angle (rad) of the surface's tangent to the plane normal to the axis at r:
        atan(dz/dr), dz/dr = c r / sqrt(1 - (1 + k) c^2 r^2)."""
        r = np.asarray(r, dtype=float)
        c = self.curvature
        return np.arctan(c * r / np.sqrt(1.0 - (1.0 + self.k) * c * c * r * r))

    def sag_table(self, step: float = SAG_STEP_MM) -> np.ndarray:
        """(n, 3) rows [r_mm, sag_mm, slope_rad] every `step` mm of radius across the clear
        aperture, its two ends included."""
        lo, hi = self.clear_aperture
        inside = np.arange(math.ceil(lo / step - 1e-9), math.floor(hi / step + 1e-9) + 1) * step
        r = np.unique(np.concatenate([[lo], inside[(inside > lo + 1e-9) & (inside < hi - 1e-9)], [hi]]))
        return np.column_stack([r, self.sag(r), self.slope(r)])


def lobe_conic(lobe: Lobe, mirror: Mirror, clear_aperture: tuple[float, float]) -> Conic:
    """The ISO conic of one lobe (Lobe.vertex_radius, Lobe.conic_constant), its vertex's
    machine Z."""
    return Conic(name=lobe.name, R=lobe.vertex_radius, k=lobe.conic_constant,
                 vertex_z=mirror.vertex_z - lobe.vertex_z, clear_aperture=clear_aperture,
                 focal_distance_2e=lobe.focus_z, above_pinhole=lobe.vertex_z, a=lobe.a, b=lobe.b)


def mirror_conics(mirror: Mirror, edge_mm: float = 0.0) -> tuple[Conic, Conic]:
    """Both lobes' conics, inner first, each over its clear aperture (clear_apertures)."""
    return tuple(lobe_conic(lobe, mirror, ca) for lobe, ca in zip(mirror.lobes, clear_apertures(mirror, edge_mm)))


def clear_apertures(mirror: Mirror, edge_mm: float) -> tuple[tuple[float, float], tuple[float, float]]:
    """Each lobe's clear aperture (r_min, r_max), mm: the polishing analysis's
    (optics.polishing_curve.clear_aperture, one rule): the radii the image uses less edge_mm
    (polish.clear_edge_mm, mm) at each edge of the lobe, the step and the outer rim (the axis
    is no edge), the band a polish turns down. InputError when a lobe has none left."""
    try:
        return tuple((float(lo), float(hi)) for lo, hi in (clear_aperture(mirror, k, edge_mm) for k in (0, 1)))
    except ValueError as e:
        raise InputError(f"{e}; allowed a narrower polish.clear_edge_mm") from None
