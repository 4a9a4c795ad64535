"""The toolpath's data: the strategy that planned it, its G1 / G2 / G3 moves, the Toolpath.

Machine frame (r, Z), mm; every programmed coordinate (and every arc centre) is on the
lathe's lattice. The planners (plan.py) build these; export.gcode writes them and
nose_envelope cuts with them.
"""

from __future__ import annotations

import dataclasses
import enum
import math
from dataclasses import dataclass, fields

import numpy as np

from ..declared import SLACK, check as check_declared
from ..declared.section import DEGREES, choice, setting
from ..design import Mirror
from ..enums import BEST, Strategy
from ..lathe import Lathe, Tool
from ..path import Arc, Line, Move


class Hand(enum.Enum):
    """How the insert is held and which way the finishing contour is cut.

    AS_CONFIGURED: the [tool] as given (its body leans toward the axis: flanks at
      90 + approach .. 90 + approach + included deg from +r), cutting from the axis out
      to the rim. It climbs a step wall that faces the axis: the inner lobe recessed.
    OPPOSITE: the same insert in an opposite-hand holder (the mirror image: flanks at
      90 - approach - included .. 90 - approach deg, its body leaning toward the rim),
      cutting from the rim in to the axis. It climbs a step wall that faces the rim: the
      outer lobe recessed. The mirror image of the first cut, move for move.
    """

    AS_CONFIGURED = "as configured"
    OPPOSITE = "opposite hand"

    @staticmethod
    def for_mirror(mirror: Mirror) -> Hand:
        """The hand that cuts this mirror's step: its wall faces the axis when the inner
        lobe is recessed (AS_CONFIGURED), the rim when the outer lobe is (OPPOSITE)."""
        return Hand.AS_CONFIGURED if mirror.step > 0 else Hand.OPPOSITE

    def held(self, tool: Tool) -> Tool:
        """The tool as this hand holds it (OPPOSITE: approach -> -(approach + included),
        which mirrors its flanks about the Z axis; nose and insert unchanged)."""
        if self is Hand.AS_CONFIGURED:
            return tool
        return dataclasses.replace(tool, approach_angle=-(tool.approach_angle + tool.included_angle))

    def describe(self, tool: Tool) -> str:
        """One line for the program header: the holder, its flanks (deg), the direction."""
        lo, hi = (math.degrees(a) for a in self.held(tool).flank_directions())
        if self is Hand.AS_CONFIGURED:
            return f"held as configured, flanks at {lo:g}..{hi:g} deg from +r, cutting from the axis out"
        return (f"the same insert in an OPPOSITE-HAND holder, flanks at {lo:g}..{hi:g} deg from +r "
                "(body toward the rim), cutting from the rim in to the axis: the outer lobe is "
                "recessed and its step wall faces the rim")


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
    rapid_rate: traverse speed for the cycle-time estimate, mm/min. path_tolerance_mm:
    the controller's path blending tolerance (LinuxCNC `G64 P`). max_finish_depth_mm: the
    deepest cut one finishing pass may take. parting_width_mm, parting_feed (mm/rev):
    the parting blade's; back_allowance_mm: stock the part-off leaves on the back for the
    second set-up. min_grip_mm: the least length a set-up grips the work.
    boring_bar_min_bore_mm, boring_bar_shank_mm: the boring bar of the mount's bore (its
    smallest bore; its shank, the overhang at most 4 x it). The whole program's planner (shop.plan_program) takes this section
    as its knobs.
    """

    strategy: Strategy = setting("toolpath.strategy", choice(Strategy, {"best": BEST}))
    gouge_tolerance: float = setting("toolpath.gouge_tolerance")
    max_deviation: float = setting("toolpath.max_deviation")
    rough_depth: float = setting("toolpath.rough_depth")
    rough_allowance: float = setting("toolpath.rough_allowance")
    clearance: float = setting("toolpath.clearance")
    ramp_angle: float = setting("toolpath.ramp_angle", DEGREES)
    spring_pass: bool = setting("toolpath.spring_pass")
    coolant: bool = setting("toolpath.coolant")
    home_r: float = setting("toolpath.home_r")
    home_z: float = setting("toolpath.home_z")
    rapid_rate: float = setting("toolpath.rapid_rate")
    path_tolerance_mm: float = setting("toolpath.path_tolerance_mm")
    max_finish_depth_mm: float = setting("toolpath.max_finish_depth_mm")
    parting_width_mm: float = setting("toolpath.parting_width_mm")
    parting_feed: float = setting("toolpath.parting_feed")
    back_allowance_mm: float = setting("toolpath.back_allowance_mm")
    min_grip_mm: float = setting("toolpath.min_grip_mm")
    boring_bar_min_bore_mm: float = setting("toolpath.boring_bar_min_bore_mm")
    boring_bar_shank_mm: float = setting("toolpath.boring_bar_shank_mm")

    def __post_init__(self) -> None:
        # Each number within its key's declaration (toolpath.<field>; the ramp angle in the
        # file's degrees): the line load() gives, however the section was built.
        for f in fields(self):
            v = getattr(self, f.name)
            if f.name == "ramp_angle":
                ok = isinstance(v, (int, float)) and not isinstance(v, bool)
                check_declared("toolpath.ramp_angle", math.degrees(v) if ok else v, slack=SLACK)
            elif f.name not in ("strategy", "spring_pass", "coolant"):
                check_declared(f"toolpath.{f.name}", v)


@dataclass
class Toolpath:
    """The finishing contour of one mirror on one lathe with one tool.

    segments: the programmed moves (machine frame, cutting order) of the tool nose's
      centre, from the vertex (r = 0) out to the outer rim; every coordinate (and every
      arc centre) on the lattice.
    lobe_of: for each segment, "inner", "junction" or "outer".
    n_points: points of the controller's budget used (G1: 1 per move; G2/G3: 2, the end
      point and the centre; plus the start point).
    hand: how the insert is held and which way the contour is cut (`cutting_moves`);
      `segments` always run from the axis out, whichever way they are cut.
    """

    strategy: Strategy
    lathe: Lathe
    tool: Tool
    mirror: Mirror
    segments: tuple[Move, ...]
    lobe_of: tuple[str, ...]
    n_points: int
    hand: Hand = Hand.AS_CONFIGURED

    def __repr__(self) -> str:
        return (f"Toolpath({self.strategy.value}, {len(self.segments)} moves, {self.n_points} of "
                f"{self.lathe.max_points} points, nose {self.tool.nose_radius:g} mm, lattice "
                f"{self.lathe.resolution:g} mm, {self.hand.value})")

    @property
    def held_tool(self) -> Tool:
        """The tool as the program's hand holds it (flanks mirrored for Hand.OPPOSITE)."""
        return self.hand.held(self.tool)

    def cutting_moves(self) -> tuple[Move, ...]:
        """The moves in the order the tool cuts them: `segments` as they are for
        Hand.AS_CONFIGURED (axis -> rim); for Hand.OPPOSITE reversed, each move run
        backwards (rim -> axis). An arc run backwards is the same spiral: LinuxCNC's radius
        is linear in the swept angle, from the start radius to the end radius."""
        if self.hand is Hand.AS_CONFIGURED:
            return self.segments
        return tuple(reversed_move(s) for s in reversed(self.segments))

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



def reversed_move(move: Move) -> Move:
    """The same move run from its end to its start (machine frame, mm)."""
    if isinstance(move, Arc):
        return Arc(start=move.end, end=move.start, centre=move.centre, clockwise=not move.clockwise)
    return Line(start=move.end, end=move.start)
