"""The part-off: after the finishing contour the parting blade (PARTING_STATION) cuts the
mirror off the bar at the body's length plus the back's allowance, and the program ends.

Machine frame (r, Z), mm, the first set-up's (Z0 at the vertex, part in -Z). The blade's
controlled point is its tip's corner on the chuck side (-Z): the slot it cuts spans
[Z, Z + width]; its part side, Z + width, stands the body's length (the back face, or the
boss's end) plus toolpath.back_allowance_mm below the vertex, rounded down to the lattice.
It begins with a program stop (M0): the finished optic comes off next, and the operator
fits the parts catcher (or stands by to take it by hand once the spindle has stopped). It
comes down outside the bar, feeds in through the axis (the part is then separate,
shop.stock's accounting shows it), retracts outward along its own slot and goes home.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from ..errors import InputError
from ..lathe import parting_corner_z
from ..path import Line
from .program import (Comment, Coolant, Feed, FeedRate, Operation, ProgramEnd, ProgramStop, Rapid, SpindleOn,
                      SpindleStop, ToolCall, PARTING_STATION)

if TYPE_CHECKING:
    from ..body import BodySpec
    from ..lathe import Lathe, Stock
    from ..toolpath import ToolpathSettings


def body_length(body: BodySpec) -> float:
    """From the vertex plane to the body's lowest point, mm: the thickness, plus the
    boss's length when the mount is a boss."""
    return body.length


def parting_z(body: BodySpec, stock: Stock, options: ToolpathSettings, lathe: Lathe) -> float:
    """The blade's programmed Z (its chuck-side corner), on the lattice: the slot's part
    side at least back_allowance below the body's length. InputError (naming
    stock.length) when the slot would reach the chuck's jaws."""
    z = parting_corner_z(body_length(body), options.back_allowance_mm, options.parting_width_mm, lathe.resolution)
    if z < -stock.length:
        need = body_length(body) + options.back_allowance_mm + options.parting_width_mm
        raise InputError(f"stock.length = {stock.length:g} mm: the part-off below the body "
                         f"(cad.thickness and its mount, toolpath.back_allowance_mm and the blade's "
                         f"toolpath.parting_width_mm) needs the bar {need:g} mm out of the jaws; allowed >= {need:g} mm")
    return z


def partoff_operation(pos: tuple[float, float], home: tuple[float, float], z: float, stock: Stock,
                      options: ToolpathSettings, lathe: Lathe) -> Operation:
    """The part-off from the tool's position `pos` (home): down outside the bar, in
    through the axis at the parting feed, back out, home, M30."""
    res = lathe.resolution
    r_out = math.ceil((stock.radius + options.clearance) / res - 1e-9) * res
    w = options.parting_width_mm
    blocks: list = [Comment(f"part-off: the {w:g} mm blade through the axis at Z{z:.4f} (its chuck-side "
                            f"corner), {options.back_allowance_mm:g} mm left on the back for the second set-up"),
                    Comment("STOP: the finished optic comes off next; fit the parts catcher (or stand by to take the "
                            "part by hand once the spindle has stopped), then cycle start"),
                    ProgramStop(),
                    ToolCall(station=PARTING_STATION, role="parting"),
                    SpindleOn(surface_speed=lathe.surface_speed, max_rpm=lathe.spindle_max_rpm)]
    if options.coolant:
        blocks.append(Coolant(on=True))
    blocks.append(FeedRate(feed=options.parting_feed))
    # from wherever the tool is (a restart here): home, Z first
    blocks += [Rapid(Line(pos, (pos[0], home[1])), only="Z"), Rapid(Line((pos[0], home[1]), home), only="X"),
               Rapid(Line(home, (r_out, home[1]))), Rapid(Line((r_out, home[1]), (r_out, z)))]
    blocks.append(Feed(Line((r_out, z), (0.0, z))))
    blocks.append(Comment("the part is off: catch it (a parts catcher, or by hand with the spindle stopped)"))
    blocks.append(Rapid(Line((0.0, z), (r_out, z))))
    if options.coolant:
        blocks.append(Coolant(on=False))
    blocks.append(Rapid(Line((r_out, z), (r_out, home[1]))))
    blocks.append(Rapid(Line((r_out, home[1]), home)))
    blocks += [SpindleStop(), ProgramEnd()]
    return Operation(name="part-off", station=PARTING_STATION, feed=options.parting_feed, blocks=tuple(blocks))


def with_partoff(ops: list[Operation], home: tuple[float, float], z: float, stock: Stock,
                 options: ToolpathSettings, lathe: Lathe) -> list[Operation]:
    """The operations with the part-off before the program's end: the last operation's
    M30 moves to the part-off's end (the tool is home there)."""
    last = ops[-1]
    if not isinstance(last.blocks[-1], ProgramEnd):
        raise RuntimeError("the program's last operation does not end it")
    ended = Operation(name=last.name, station=last.station, feed=last.feed, blocks=last.blocks[:-1])
    return ops[:-1] + [ended, partoff_operation(home, home, z, stock, options, lathe)]
