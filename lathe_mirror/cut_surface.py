"""Surfaces a program cuts that are not the design itself, built by composition.

A program is planned on a two-lobe surface: the design (design.Mirror), the design's
lobes lowered by a smooth allowance (CompensatedLobe, CompensatedMirror: the polishing
pre-compensation and the measured re-cut), or either with its machine zero moved along
the axis (ZeroShiftedMirror: a lattice phase). The planner, the nose envelope, the shop
and the profiles read a surface through one protocol, which each of these provides:

    inner, outer, lobes     the sheets: name, r_top, z(r), slope(r), second_derivative(r)
    r_junction, r_max       the junction and the rim radius (mm)
    junction_z, step, recessed, lobe_index
                            from the sheets' own z(r)
    vertex_z                the height (camera frame, mm) of machine Z = 0
    design                  the designed Mirror it realises (the optics: camera, a, b, e,
                            foci, fields of view, what the camera sees)

A compensated sheet has no a, b, e, h or vertex of its own: it is not a hyperbola, and a
closed form through the design's constants lands the allowance (tens of um) off it. Its
design lobe is `.design`, named so. Millimetres, camera frame (ARCHITECTURE.md).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import Union

import numpy as np

from .design import Lobe, Mirror


class CutSurface:
    """The surface protocol's derived quantities, from `inner`, `outer` and `design`
    (subclasses provide those and vertex_z)."""

    inner: Sheet
    outer: Sheet
    design: Mirror

    @property
    def lobes(self) -> tuple[Sheet, Sheet]:
        return (self.inner, self.outer)

    @property
    def r_junction(self) -> float:
        """Radius of the step between the lobes (mm): the design's."""
        return self.design.r_junction

    @property
    def r_max(self) -> float:
        """Outer rim radius (mm): the design's."""
        return self.design.r_max

    @functools.cached_property
    def junction_z(self) -> tuple[float, float]:
        """Heights (mm) of this surface's inner and outer sheets at the junction radius."""
        r = self.r_junction
        return float(self.inner.z(r)), float(self.outer.z(r))

    @property
    def step(self) -> float:
        """Height of this surface's step at the junction, inner minus outer sheet (mm)."""
        zi, zo = self.junction_z
        return zi - zo

    @property
    def recessed(self) -> str:
        """Which lobe is recessed (farther from the camera) at the junction."""
        return "inner" if self.step > 0 else "outer"

    def lobe_index(self, r: np.ndarray) -> np.ndarray:
        """0 where r belongs to the inner lobe (r <= r_junction), 1 for the outer lobe."""
        return (np.asarray(r) > self.r_junction).astype(np.intp)


@dataclass(frozen=True)
class CompensatedLobe:
    """A design lobe's sheet lowered toward the camera by a smooth allowance:
    z(r) = design.z(r) - offset(r).

    design: the design lobe. offset: a cubic B-spline (knots offset_knots, coefficients
    offset_coef, mm) of r (mm), held at its end values beyond its knots. The surface
    protocol only (name, r_top, z, slope, second_derivative, offset): no a, b, e, h or
    vertex_z of its own, as the sheet is not a hyperbola.
    """

    design: Lobe
    offset_knots: tuple[float, ...]
    offset_coef: tuple[float, ...]

    @property
    def name(self) -> str:
        return self.design.name

    @property
    def r_top(self) -> float:
        """Rim radius (mm): the design lobe's."""
        return self.design.r_top

    @functools.cached_property
    def _spline(self):
        from scipy.interpolate import BSpline  # lazy: scipy.interpolate only when pre-compensating

        return BSpline(np.asarray(self.offset_knots), np.asarray(self.offset_coef), 3)

    def _series(self, r: np.ndarray, nu: int) -> np.ndarray:
        t = self.offset_knots
        rr = np.clip(np.asarray(r, float), t[0], t[-1])
        out = self._spline(rr, nu)
        # Beyond the knots: the end value held (no slope, no curvature).
        outside = (np.asarray(r, float) < t[0]) | (np.asarray(r, float) > t[-1])
        return np.where(outside, 0.0, out) if nu else out

    def offset(self, r: np.ndarray | float) -> np.ndarray:
        """The allowance (mm, in z) at radius r (mm)."""
        return self._series(np.asarray(r, float), 0)

    def z(self, r: np.ndarray | float) -> np.ndarray:
        """Height (mm) of the lowered sheet at radius r (mm)."""
        return self.design.z(r) - self._series(np.asarray(r, float), 0)

    def slope(self, r: np.ndarray | float) -> np.ndarray:
        """dz/dr of the lowered sheet at radius r."""
        return self.design.slope(r) - self._series(np.asarray(r, float), 1)

    def second_derivative(self, r: np.ndarray | float) -> np.ndarray:
        """d2z/dr2 of the lowered sheet at radius r (1/mm)."""
        return self.design.second_derivative(r) - self._series(np.asarray(r, float), 2)


#: A sheet of the surface protocol: a design lobe or a lowered one.
Sheet = Union[Lobe, CompensatedLobe]


@dataclass(frozen=True)
class CompensatedMirror(CutSurface):
    """The design with each lobe lowered by a smooth allowance (CompensatedLobe): the
    finishing program's target. Machine Z = 0 stays at the design's vertex (vertex_z), so
    the program leaves the allowance standing above the design where the polish (or the
    re-cut's correction) takes it off."""

    design: Mirror
    inner: CompensatedLobe
    outer: CompensatedLobe

    @property
    def vertex_z(self) -> float:
        """Height (mm) of machine Z = 0: the design's vertex (not this surface's z(0))."""
        return self.design.vertex_z


@dataclass(frozen=True)
class ZeroShiftedMirror(CutSurface):
    """A surface (the design or a compensated one) with its machine zero moved zero_shift
    (mm) along the axis: the planner puts machine Z = 0 at vertex_z, so this is the same
    surface cut with the work zero that far off the lattice."""

    surface: Mirror | CompensatedMirror
    zero_shift: float = 0.0

    @property
    def inner(self) -> Sheet:  # type: ignore[override]
        return self.surface.inner

    @property
    def outer(self) -> Sheet:  # type: ignore[override]
        return self.surface.outer

    @property
    def design(self) -> Mirror:  # type: ignore[override]
        return self.surface.design

    @property
    def vertex_z(self) -> float:
        """Height (mm) of machine Z = 0: the surface's, moved zero_shift."""
        return self.surface.vertex_z + self.zero_shift
