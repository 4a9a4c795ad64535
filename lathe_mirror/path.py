"""The moves of a lathe path: G1 lines and G2/G3 arcs, machine frame (r, Z), mm.

They sit below the toolpath planners and the profiles: `profile.PathProfile` evaluates a
chain of them as a surface, `toolpath` plans them on the lattice, `export.gcode` writes
them. A move's type says what it is (`isinstance(m, Arc)`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class Line:
    """A G1 move, machine frame (r, Z), mm."""

    start: tuple[float, float]
    end: tuple[float, float]
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
