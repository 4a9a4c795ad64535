"""`toolpath --check`: a written G-code program (any dialect, read back by shop.replay with
the dialect as its reader) simulated against the configured stock and tools, the set-up
it belongs to found from its operations: the second set-up's program (its first operation
faces the back, shop.second) against the part the configured program parts off, reversed;
any other against the bar, with the part-off's blade at the [cad] body's length.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..errors import InputError
from ..job import check_program
from ..toolpath.moves import Hand
from .partoff import parting_z
from .program import PARTING_STATION
from .programs import shop_program
from .replay import MAX_PROGRAM_BYTES, read_program
from .second import FACE_BACK
from .stock import simulate, simulate_setup
from .tool_shapes import blade_shape

__all__ = ["MAX_PROGRAM_BYTES", "check_text"]

if TYPE_CHECKING:
    from ..design import Mirror
    from ..settings import Settings
    from .replay import Reader
    from .stock import Simulation


def check_text(text: str, settings: Settings, mirror: Mirror, reader: Reader, *, source: str) -> Simulation:
    """The simulation of a program's text (shop.stock.Simulation; call .check() for the
    refusal naming the first contact). InputError (one line naming `source` and the line)
    for a program the replay cannot read or one with no moves."""
    lathe, t = settings.machine, settings.toolpath
    ops = read_program(text, lathe, reader, source=source)
    if not ops:
        raise InputError(f"{source}: no moves to simulate")
    if ops[0].name.lower() == FACE_BACK:  # its first operation's comment names it (upper case in Fanuc's)
        tp = check_program(settings, mirror, t.strategy)
        su = shop_program(tp, settings.stock, t, body=settings.body).second.setup
        return simulate_setup(ops, su.shapes, lathe, su.start, su.part, su.chuck, rapid_rate=t.rapid_rate,
                              gouge_tolerance=t.gouge_tolerance)
    parting = None
    if any(op.station == PARTING_STATION for op in ops):  # the parting blade at the body's length
        parting = (parting_z(settings.body, settings.stock, t, lathe), t.parting_width_mm)
    # the tool as the design's hand holds it (the opposite hand when the outer lobe is recessed)
    return simulate(ops, mirror, Hand.for_mirror(mirror).held(settings.tool), lathe, settings.stock,
                    rapid_rate=t.rapid_rate, gouge_tolerance=t.gouge_tolerance,
                    shapes={PARTING_STATION: blade_shape(t.parting_width_mm)}, parting=parting)
