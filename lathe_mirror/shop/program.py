"""The whole lathe program as a model: operations of blocks, planned around a toolpath.

Machine frame (ARCHITECTURE.md): Z = 0 at the mirror's vertex, part in -Z, r the radius;
every programmed coordinate is on the lathe's lattice. Every move is of the tool nose's
CENTRE (the offsets are set to it; see shop.setup for the numbers to enter).

A Program is a tuple of Operations (face, rough, semi-finish, finish, optionally a spring
pass), each a tuple of Blocks: tool calls, spindle and coolant words, feed rates, rapid
and feed moves, comments, an optional stop, the end. Every block but a comment carries a
block number (N), the same in every dialect, so a refusal names a block the operator can
find in either file, and every operation restarts at its own tool call. The dialects are
export.dialects'; this module only decides what the program does.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Iterator

import numpy as np

from ..declared import key as declared_key
from ..lathe import FEED_STEP, Stock
from ..path import Arc, Line, Move
from ..toolpath.moves import Hand

if TYPE_CHECKING:
    from ..lathe import Lathe, Tool
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
#: The mount's bore (shop.boring): the spot drill, the drill, the boring bar.
CENTRE_DRILL_STATION = 6
DRILL_STATION = 7
BORING_STATION = 8


def stations(toolpath: Toolpath) -> tuple[int, int]:
    """(roughing, finishing) stations of the toolpath's hand."""
    if toolpath.hand is Hand.OPPOSITE:
        return OPPOSITE_ROUGHING_STATION, OPPOSITE_FINISHING_STATION
    return ROUGHING_STATION, FINISHING_STATION

def rough_feed(lathe: Lathe, tool: Tool) -> float:
    """The roughing feed, mm/rev: machine.feed_rough's declared default at most half the
    nose radius (a feed per revolution above it loads the nose beyond its chip-thickness
    rating and leaves scallops the allowance may not take), on the F word's 0.0001 mm/rev;
    a feed_rough configured to another value is taken as given (a configuration that
    states the default itself gets the cap too)."""
    if tool.nose_radius <= 0.0 or lathe.feed_rough != declared_key("machine.feed_rough").default:
        return lathe.feed_rough
    return min(lathe.feed_rough, math.floor(tool.nose_radius / 2 / FEED_STEP + 1e-9) * FEED_STEP)

#: Largest block number a 5-digit N word carries (Fanuc's format).
MAX_BLOCK_NUMBER = 99999


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
    """Constant surface speed (m/min) with the spindle cap (rev/min), feed per revolution;
    clockwise: M3 (ISO 6983: clockwise looking from the headstock along +Z), else M4.
    rpm: a constant speed instead (G97, rev/min), for a drill on the axis (where G96 would
    ask for the cap anyway)."""

    surface_speed: float
    max_rpm: int
    clockwise: bool = True
    rpm: int | None = None


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
class ProgramStop(Block):
    """M0: the program waits for the operator (the spindle stopped), e.g. to fit the parts
    catcher before the part-off; the comment before it says what to do."""


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
    options: ToolpathSettings
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

    def __repr__(self) -> str:
        # one line: the blocks are the program's text (export.gcode writes it)
        return f"Program({self.name!r}, {len(self.operations)} operations, {self.toolpath!r})"

    @property
    def rough_feed(self) -> float:
        """The roughing tool's feed, mm/rev (rough_feed)."""
        return rough_feed(self.toolpath.lathe, self.toolpath.tool)

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
