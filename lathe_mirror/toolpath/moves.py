"""The toolpath's data: the strategy that planned it, its G1 / G2 / G3 moves, the Toolpath.

Machine frame (r, Z), mm; every programmed coordinate (and every arc centre) is on the
lathe's lattice. The planners (plan.py) build these; export.gcode writes them and
machining cuts with them.
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass, field

import numpy as np

from ..design import Mirror
from ..machine import Lathe, Tool
from ..profile import Profile


class Strategy(enum.Enum):
    """How the exact profile becomes lattice moves. BEST (= ARCS) is the default."""

    PAPER = "paper"
    LATTICE = "lattice"
    ARCS = "arcs"


#: The strategy with the smallest slope error on the paper's machine (see the package doc).
BEST = Strategy.ARCS


@dataclass(frozen=True)
class Line:
    """A G1 move, machine frame (r, Z), mm."""

    start: tuple[float, float]
    end: tuple[float, float]
    kind: str = field(default="line", init=False)
    n_points: int = field(default=1, init=False)  # budget: its end point

    def sample(self, n: int) -> np.ndarray:
        """n points (n, 2) from start to end."""
        t = np.linspace(0.0, 1.0, n)[:, None]
        return (1 - t) * np.asarray(self.start) + t * np.asarray(self.end)


@dataclass(frozen=True)
class Arc:
    """A G2/G3 move, machine frame (r, Z), mm.

    centre: lattice centre (the block's I, K are centre - start). radius: |start -
    centre|; end_radius: |end - centre|. LinuxCNC cuts the arc with its radius linear in
    the swept angle from one to the other (a spiral when they differ). clockwise: as the
    controller cuts it in G18 (rotation in the (Z, X) plane seen from +Y): True is G2.
    """

    start: tuple[float, float]
    end: tuple[float, float]
    centre: tuple[float, float]
    clockwise: bool
    kind: str = field(default="arc", init=False)
    n_points: int = field(default=2, init=False)  # budget: end point and centre

    @property
    def radius(self) -> float:
        """|start - centre|, mm."""
        return self._distance_from_centre(self.start)

    @property
    def end_radius(self) -> float:
        """|end - centre|, mm (LinuxCNC cuts a spiral when it differs from radius)."""
        return self._distance_from_centre(self.end)

    @property
    def sweep(self) -> float:
        """Signed swept angle (rad) in the (r, Z) plane, |sweep| < pi."""
        a0 = self._angle_about_centre(self.start)
        a1 = self._angle_about_centre(self.end)
        return (a1 - a0 + math.pi) % (2 * math.pi) - math.pi

    def sample(self, n: int) -> np.ndarray:
        """n points (n, 2) along the spiral the controller cuts."""
        c = np.asarray(self.centre)
        a0 = self._angle_about_centre(self.start)
        t = np.linspace(0.0, 1.0, n)
        phi = a0 + self.sweep * t
        rad = self.radius + (self.end_radius - self.radius) * t
        return c + rad[:, None] * np.stack([np.cos(phi), np.sin(phi)], axis=-1)

    def _distance_from_centre(self, p: tuple[float, float]) -> float:
        return math.hypot(p[0] - self.centre[0], p[1] - self.centre[1])

    def _angle_about_centre(self, p: tuple[float, float]) -> float:
        """Direction (rad) of p seen from the centre, in the (r, Z) plane."""
        return math.atan2(p[1] - self.centre[1], p[0] - self.centre[0])


Move = Line | Arc


@dataclass
class Toolpath:
    """The finishing contour of one mirror on one lathe with one tool.

    segments: the programmed moves (machine frame, cutting order) of the tool nose's
      centre, from the vertex (r = 0) out to the outer rim; every coordinate (and every
      arc centre) on the lattice.
    lobe_of: for each segment, "inner", "junction" or "outer".
    n_points: points of the controller's budget used (G1: 1 per move; G2/G3: 2, the end
      point and the centre; plus the start point).
    """

    strategy: Strategy
    lathe: Lathe
    tool: Tool
    mirror: Mirror
    segments: tuple[Move, ...]
    lobe_of: tuple[str, ...]
    n_points: int

    @property
    def nose_radius(self) -> float:
        """Nose radius (mm) the path was planned for (its offset from the surface)."""
        return self.tool.nose_radius

    def lobe_segments(self, name: str) -> tuple[Move, ...]:
        """The moves of "inner", "junction" or "outer", in cutting order (machine frame, mm)."""
        return tuple(s for s, k in zip(self.segments, self.lobe_of) if k == name)

    def points(self) -> np.ndarray:
        """The programmed end points (with the start), (n, 2) machine (r, Z), mm."""
        pts = [self.segments[0].start] + [s.end for s in self.segments]
        return np.asarray(pts, dtype=float)

    def centres(self) -> np.ndarray:
        """Arc centres (m, 2) machine (r, Z), mm."""
        c = [s.centre for s in self.segments if s.kind == "arc"]
        return np.asarray(c, dtype=float).reshape(-1, 2)

    def contour_profile(self) -> Profile:
        """The surface the programmed contour describes, camera frame.

        For a zero nose radius: the moves themselves, exactly (a PathProfile, the same
        as machining.as_machined). For a nose radius rho > 0: the envelope of the nose
        along each lobe's moves (the path offset back by rho, without the junction's
        inside-corner fillet, which machining.as_machined adds).
        """
        from ..machining import as_machined, nose_envelope

        if self.nose_radius == 0.0:
            return as_machined(self)
        return nose_envelope(self, self.nose_radius, include_junction=False)
