"""The whole lathe program as a model: operations of blocks, planned around a toolpath.

Machine frame (ARCHITECTURE.md): Z = 0 at the mirror's vertex, part in -Z, r the radius;
every programmed coordinate is on the lathe's lattice. Every move is of the tool nose's
CENTRE (the offsets are set to it; see shop.setup for the numbers to enter).

A Program is a tuple of Operations (face, rough, semi-finish, finish, optionally a spring
pass), each a tuple of Blocks: tool calls, spindle and coolant words, feed rates, rapid
and feed moves, comments, an optional stop, the end. Every block but a comment carries a
block number (N), the same in every dialect, so a refusal names a block the operator can
find in either file, and every operation restarts at its own tool call. The dialects are
export.gcode's; this module only decides what the program does.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Iterator

import numpy as np

from ..declared import SLACK, check as check_declared
from ..errors import InputError
from ..lathe import Stock
from ..path import Arc, Line, Move
from ..toolpath.moves import Hand

if TYPE_CHECKING:
    from ..toolpath import Toolpath, ToolpathSettings

#: Tool stations: the roughing tool and a separate finishing tool with a fresh edge.
ROUGHING_STATION = 1
FINISHING_STATION = 2
#: The same two tools in opposite-hand holders (toolpath.Hand.OPPOSITE: a design whose
#: outer lobe is recessed), on stations of their own so that a turret set up for one hand
#: never runs the other's program.
OPPOSITE_ROUGHING_STATION = 3
OPPOSITE_FINISHING_STATION = 4
#: The parting blade (shop.partoff), on a station of its own.
PARTING_STATION = 5


def stations(toolpath: Toolpath) -> tuple[int, int]:
    """(roughing, finishing) stations of the toolpath's hand."""
    if toolpath.hand is Hand.OPPOSITE:
        return OPPOSITE_ROUGHING_STATION, OPPOSITE_FINISHING_STATION
    return ROUGHING_STATION, FINISHING_STATION

#: Largest block number a 5-digit N word carries (Fanuc's format).
MAX_BLOCK_NUMBER = 99999


@dataclass(frozen=True)
class ProgramOptions:
    """Knobs of the program around the finishing contour. Lengths in mm, angles in rad.

    rough_depth: depth of each roughing level (more: fewer levels, heavier cuts; the
      simulation refuses a depth the insert's cutting edge cannot take).
    rough_allowance: stock the semi-finish leaves on the profile for the finishing pass.
    clearance: distance of every rapid from the stock and of the retract above a level.
    gouge_tolerance: deepest the as-machined surface may lie inside the exact part.
    ramp_angle: slope of ramped entries (into a pocket, onto the contour's start), rad.
    spring_pass: repeat the finishing contour once more (no stock, removes deflection).
    coolant: M8 / M9 around the cutting.
    home_r, home_z: the end (and tool change) position, radius and Z of the nose centre;
      the program goes there, Z first, before M30 and before the finishing tool.
    rapid_rate: traverse speed for the cycle-time estimate, mm/min.
    path_tolerance: the controller's path blending tolerance, mm: LinuxCNC `G64 P.. Q..`
      (the Fanuc program notes its look-ahead / AI contour mode instead).
    max_finish_depth: the deepest cut one finishing pass may take, mm: the stock the
      semi-finish leaves is taken in passes of the finishing tool at offsets
      rough_allowance (n - k) / n, k = 1 .. n - 1, then the contour (shop.roughing).
    finish_passes: n (0: the fewest that keep each pass within max_finish_depth on the
      profile; pipeline.shop_program raises it when the simulation finds a deeper cut,
      as in an inside corner).
    parting_width: the parting blade's width, mm (shop.partoff). parting_feed: its feed,
      mm/rev. back_allowance: stock the part-off leaves on the back for the second
      set-up to face off, mm.
    """

    rough_depth: float = 1.0
    rough_allowance: float = 0.15
    clearance: float = 2.0
    gouge_tolerance: float = 0.005
    ramp_angle: float = math.radians(20.0)
    spring_pass: bool = False
    coolant: bool = True
    home_r: float = 50.0
    home_z: float = 50.0
    rapid_rate: float = 5000.0
    path_tolerance: float = 0.001
    max_finish_depth: float = 0.1
    finish_passes: int = 0
    parting_width: float = 3.0
    parting_feed: float = 0.05
    back_allowance: float = 0.5

    def __post_init__(self) -> None:
        # Bounds keep the planning finite (a level per rough_depth, a ramp leg per
        # ramp_angle) and the program meaningful: each within its key's declaration
        # (toolpath.<key>, the angle in the file's degrees), the line load() gives.
        for key, value in _declared_values(self):
            check_declared(f"toolpath.{key}", value, slack=SLACK if key == "ramp_angle" else 0.0)
        for key in ("spring_pass", "coolant"):
            if not isinstance(getattr(self, key), bool):
                raise InputError(f"toolpath.{key} = {getattr(self, key)!r}: must be true or false")


def options_from_settings(t: ToolpathSettings) -> ProgramOptions:
    """ProgramOptions of the [toolpath] settings (InputError naming a key out of bounds)."""
    return ProgramOptions(rough_depth=t.rough_depth, rough_allowance=t.rough_allowance, clearance=t.clearance,
                          gouge_tolerance=t.gouge_tolerance, ramp_angle=t.ramp_angle,
                          spring_pass=t.spring_pass, coolant=t.coolant, home_r=t.home_r, home_z=t.home_z,
                          rapid_rate=t.rapid_rate,
                          path_tolerance=t.path_tolerance_mm, max_finish_depth=t.max_finish_depth_mm,
                          parting_width=t.parting_width_mm, parting_feed=t.parting_feed,
                          back_allowance=t.back_allowance_mm)


# --------------------------------------------------------------------------------------
# Blocks


@dataclass(frozen=True)
class Block:
    """One block of the program; `number` is its N (0 for a comment)."""

    number: int = field(default=0, kw_only=True)


@dataclass(frozen=True)
class Comment(Block):
    """A comment line (operations, markers such as "finish contour begin")."""

    text: str


@dataclass(frozen=True)
class ToolCall(Block):
    """Index the turret to `station` and take its offsets (T1 M6 G43 / T0101)."""

    station: int
    role: str  # "roughing" or "finishing"


@dataclass(frozen=True)
class SpindleOn(Block):
    """Constant surface speed (m/min) with the spindle cap (rev/min), feed per revolution."""

    surface_speed: float
    max_rpm: int


@dataclass(frozen=True)
class Coolant(Block):
    """Flood coolant on (M8) or off (M9)."""

    on: bool


@dataclass(frozen=True)
class SpindleStop(Block):
    """M5."""


@dataclass(frozen=True)
class OptionalStop(Block):
    """M1: the operator may inspect the part and the edge before finishing."""


@dataclass(frozen=True)
class FeedRate(Block):
    """Feed per revolution, mm/rev."""

    feed: float


@dataclass(frozen=True)
class Rapid(Block):
    """G0 along a straight line (machine frame, mm).

    only: "Z" or "X" to write that axis' word alone (a move from a position the program
    cannot know, at its start: the machine goes up first, then across).
    """

    move: Line
    only: str | None = None


@dataclass(frozen=True)
class Feed(Block):
    """G1 / G2 / G3 at the current feed (machine frame, mm)."""

    move: Move


@dataclass(frozen=True)
class ProgramEnd(Block):
    """M30."""


Motion = Rapid | Feed


@dataclass(frozen=True)
class Operation:
    """A named operation with one tool: its blocks from its tool call on.

    name: "face", "rough", "semi-finish", "finish", "spring pass". station: the tool.
    feed: its feed per revolution, mm/rev.
    """

    name: str
    station: int
    feed: float
    blocks: tuple[Block, ...]

    @property
    def number(self) -> int:
        """Block number of the operation's first block (where a restart begins)."""
        return next(b.number for b in self.blocks if not isinstance(b, Comment))

    def motions(self) -> Iterator[Motion]:
        """The rapid and feed blocks in order."""
        return (b for b in self.blocks if isinstance(b, (Rapid, Feed)))


@dataclass(frozen=True)
class Program:
    """The whole program of one toolpath: the operations, where it starts and ends, and
    the figures its header states.

    home: (r, Z) the nose centre starts and ends at (mm). safe_z: the plane above the
    stock every traverse uses (mm). r_out: the radius outside the bar where the tool
    goes down to a level (mm). gouge_depth: deepest point of the as-machined surface
    inside the part (mm). figures / used: nose_envelope's profile errors of the whole
    lobes and of the radii the camera uses; fillet: the junction fillet or None.
    """

    name: str
    toolpath: Toolpath
    stock: Stock
    options: ProgramOptions
    operations: tuple[Operation, ...]
    home: tuple[float, float]
    safe_z: float
    r_out: float
    gouge_depth: float
    figures: dict
    used: dict
    fillet: dict | None
    parting: tuple[float, float] | None = None
    setup: object = None

    def shapes(self) -> dict:
        """{station: tool_shapes.ToolShape} of the tools that are not the turning insert:
        the parting blade when the program parts off (the second set-up: its own)."""
        from .tool_shapes import blade_shape  # lazy: shop.tool_shapes off the CLI's start-up path

        if self.setup is not None:
            return self.setup.shapes
        return {PARTING_STATION: blade_shape(self.parting[1])} if self.parting is not None else {}

    def motions(self) -> Iterator[tuple[Operation, Motion]]:
        """Every rapid and feed block with its operation, in order."""
        for op in self.operations:
            for b in op.motions():
                yield op, b

    def points(self) -> np.ndarray:
        """Every end point of every move, (n, 2) machine (r, Z), mm."""
        return np.array([b.move.end for _, b in self.motions()], dtype=float).reshape(-1, 2)

    def describe(self, block: Block) -> str:
        """A block as the operator finds it: its N and, for a move, the words of its
        end point in the program's convention (X is 2r in diameter mode)."""
        text = f"N{block.number}"
        if isinstance(block, (Rapid, Feed)):
            lathe = self.toolpath.lathe
            x = block.move.end[0] * (2 if lathe.diameter_mode else 1)
            g = "G0" if isinstance(block, Rapid) else (
                ("G2" if block.move.clockwise else "G3") if isinstance(block.move, Arc) else "G1")
            text += f" {g} X{x:.{lathe.decimals}f} Z{block.move.end[1]:.{lathe.decimals}f}"
        return text


def _declared_values(o: ProgramOptions) -> tuple[tuple[str, object], ...]:
    """(key under [toolpath], value in the file's unit) of each declared field."""
    ramp = math.degrees(o.ramp_angle) if isinstance(o.ramp_angle, (int, float)) else o.ramp_angle
    return (("rough_depth", o.rough_depth), ("rough_allowance", o.rough_allowance), ("clearance", o.clearance),
            ("gouge_tolerance", o.gouge_tolerance), ("ramp_angle", ramp), ("home_r", o.home_r),
            ("home_z", o.home_z), ("rapid_rate", o.rapid_rate), ("path_tolerance_mm", o.path_tolerance),
            ("max_finish_depth_mm", o.max_finish_depth), ("parting_width_mm", o.parting_width),
            ("parting_feed", o.parting_feed), ("back_allowance_mm", o.back_allowance))
