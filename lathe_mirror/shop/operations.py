"""The writer of one tool's operations: the blocks of each operation (tool call, spindle,
coolant, feed, the moves) and where the tool is (machine frame, mm). The roughing and
finishing planner (shop.roughing) drives one writer per tool."""

from __future__ import annotations

from typing import TYPE_CHECKING, Protocol

from ..path import Line
from .program import (Comment, Coolant, Feed, FeedRate, Operation, OptionalStop, ProgramEnd, Rapid, SpindleOn,
                      SpindleStop, ToolCall)

if TYPE_CHECKING:
    from ..lathe import Lathe
    from ..toolpath import ToolpathSettings


class Planner(Protocol):
    """What a writer reads of its planner: the lathe, the program's options, home (r, Z)."""

    lathe: Lathe
    opts: ToolpathSettings
    home: tuple[float, float]


class OperationWriter:
    """Builds one tool's operations: blocks and the current position (machine, mm)."""

    def __init__(self, planner: Planner, station: int, role: str, feed: float,
                 pos: tuple[float, float] | None = None) -> None:
        self.p, self.station, self.role, self.feed_rate = planner, station, role, feed
        self.pos = pos if pos is not None else planner.home
        self.rpm: int | None = None  # a constant spindle speed (G97, rev/min) instead of G96
        self.ops: list[Operation] = []
        self.blocks: list = []
        self.name: str | None = None

    def start(self, name: str, note: str, *, first: bool = False) -> None:
        """Close the current operation and open `name`: tool call, spindle, coolant,
        feed (every operation restates them, so a restart at its first block works; its
        first rapid ends outside the bar or above the stock, so a restart from home is
        safe). first: begin by going home, Z first (no-ops when the tool is there)."""
        self.close()
        p, lathe = self.p, self.p.lathe
        self.name = name
        self.blocks = [Comment(note),
                       ToolCall(station=self.station, role=self.role),
                       SpindleOn(surface_speed=lathe.surface_speed, max_rpm=lathe.spindle_max_rpm, rpm=self.rpm)]
        if p.opts.coolant:
            self.blocks.append(Coolant(on=True))
        self.blocks.append(FeedRate(feed=self.feed_rate))
        if first:  # from wherever the tool is: home, Z first
            self.blocks += [Rapid(Line(self.pos, (self.pos[0], p.home[1])), only="Z"),
                            Rapid(Line((self.pos[0], p.home[1]), p.home), only="X")]
            self.pos = p.home

    def close(self) -> None:
        if self.name is not None:
            self.ops.append(Operation(name=self.name, station=self.station, feed=self.feed_rate,
                                      blocks=tuple(self.blocks)))
        self.name, self.blocks = None, []

    def comment(self, text: str) -> None:
        self.blocks.append(Comment(text))

    def rapid(self, p) -> None:
        p = (float(p[0]), float(p[1]))
        if p != self.pos:
            self.blocks.append(Rapid(Line(self.pos, p)))
            self.pos = p

    def feed(self, p) -> None:
        p = (float(p[0]), float(p[1]))
        if p != self.pos:
            self.blocks.append(Feed(Line(self.pos, p)))
            self.pos = p

    def move(self, seg) -> None:
        """A move of the finishing contour, as planned (it starts where the tool is)."""
        self.blocks.append(Feed(seg))
        self.pos = (float(seg.end[0]), float(seg.end[1]))

    def go_home(self, *, stop: bool, note: str = "check the part; the finishing tool takes a fresh edge",
                change: bool = False) -> None:
        """Coolant off, up to the home Z, across to the home radius, spindle off; then an
        optional stop (before a new tool, `note` the comment before it) or the program's end;
        change: neither (the next tool is called at home, straight on)."""
        p = self.p
        if p.opts.coolant:
            self.blocks.append(Coolant(on=False))
        self.rapid((self.pos[0], p.home[1]))
        self.rapid(p.home)
        self.blocks.append(SpindleStop())
        if change:
            pass
        elif stop:
            self.comment(note)
            self.blocks.append(OptionalStop())
        else:
            self.blocks.append(ProgramEnd())
        self.close()
