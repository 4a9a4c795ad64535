"""The toolpath's data: the strategy that planned it, its G1 / G2 / G3 moves, the Toolpath.

Machine frame (r, Z), mm; every programmed coordinate (and every arc centre) is on the
lathe's lattice. The planners (plan.py) build these; export.gcode writes them and
nose_envelope cuts with them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..design import Mirror
from ..enums import BEST, Strategy
from ..lathe import Lathe, Tool
from ..path import Arc, Move


@dataclass(frozen=True)
class ToolpathSettings:
    """The [toolpath] section. Lengths in mm.

    strategy: how the contour is planned. gouge_tolerance: deepest a made point may lie
    inside the exact part (a program that gouges more is refused). max_deviation: largest
    normal deviation a contour may have. rough_depth: depth of each roughing level (more:
    fewer passes, heavier cuts). rough_allowance: stock left on the profile for the
    finishing pass. clearance: safe distance above the work for rapid moves. ramp_angle:
    slope of ramped entries, rad. spring_pass: the finishing contour once more. coolant:
    M8 / M9. home_r, home_z: the end and tool-change position of the nose centre.
    rapid_rate: traverse speed for the cycle-time estimate, mm/min. (The program's
    planner, shop.program.ProgramOptions, bounds them.)
    """

    strategy: Strategy = BEST
    gouge_tolerance: float = 0.005
    max_deviation: float = 0.01
    rough_depth: float = 1.0
    rough_allowance: float = 0.15
    clearance: float = 2.0
    ramp_angle: float = math.radians(20.0)
    spring_pass: bool = False
    coolant: bool = True
    home_r: float = 50.0
    home_z: float = 50.0
    rapid_rate: float = 5000.0


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
        c = [s.centre for s in self.segments if isinstance(s, Arc)]
        return np.asarray(c, dtype=float).reshape(-1, 2)

