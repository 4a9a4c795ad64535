"""A lathe program read back into the moves the stock simulation replays.

Reads the subset of G-code both of our dialects write (and a hand edit of them keeps):
N words, comments in parentheses or after ';', G0 / G1 / G2 / G3 with X, Z, I, K (I, K
relative to the arc's start: LinuxCNC's G91.1, Fanuc's default), G7 / G8 (X as diameter
or radius; Fanuc: the machine's setting), G94 / G95 / G99 (feed per minute or per
revolution), F, T (a new operation per tool call), M and S words (ignored here). Anything
else that moves the tool (G91 incremental moves, canned cycles, G28, G53, cutter
compensation) is refused with one line naming the line (but Fanuc's G28 U0 / G28 W0 before
the first move: to the reference position, from where the program's first rapids start), since the simulation could not
replay it faithfully.

Each move's label names its block as the operator finds it: "N130 G0 X0.000 Z3.000" or,
without block numbers, "line 130: G0 X0.000 Z3.000".
"""

from __future__ import annotations

import re
from typing import TYPE_CHECKING

from ..errors import InputError
from ..path import Arc, Line
from .stock import SimMove, SimOperation

if TYPE_CHECKING:
    from ..lathe import Lathe

_WORD = re.compile(r"([A-Z])\s*([-+]?(?:\d+\.?\d*|\.\d+))")
_UNSUPPORTED_G = {"30", "53", "91", "41", "42", "71", "72", "73", "70", "76", "33", "32", "92", "50.1"}


def read_program(text: str, lathe: Lathe, *, source: str = "program") -> list[SimOperation]:
    """The moves of a G-code program, one SimOperation per tool call (named by the comment
    before it, up to its first ':'). Lengths in mm; feeds in mm/rev."""
    lines = text.splitlines()
    diameter = lathe.diameter_mode
    per_rev = False
    motion = None
    feed = 0.0
    pos: list[float | None] = [None, None]
    first = _first_position(lines, diameter)
    ops: list[SimOperation] = []
    name, station, moves = "program", 0, []
    prev_comment = ""  # the comment line just before this line, if it was one
    for k, raw in enumerate(lines, start=1):
        comments = re.findall(r"\(([^)]*)\)", raw)
        code = re.sub(r"\([^)]*\)", " ", raw).split(";")[0].strip().upper()
        last_comment, prev_comment = prev_comment, (comments[-1] if comments and not code else "")
        if not code or code.startswith("%") or re.fullmatch(r"O\d+", code.split()[0] if code else ""):
            continue
        words = _WORD.findall(code)
        block_no = next((int(float(v)) for w, v in words if w == "N"), None)
        g = [_g(v) for w, v in words if w == "G"]
        if "28" in g:
            # Fanuc's return to the reference position with an incremental zero (U0 / W0: no
            # intermediate point) before the program knows where the tool is: the program's
            # first moves start from a position it cannot know anyway (their first rapid
            # writes one axis); anywhere else it would move through points we cannot know
            rest = [(w, float(v)) for w, v in words if w not in "NG"]
            if pos != [None, None] or not rest or any(w not in "UW" or v != 0.0 for w, v in rest):
                raise InputError(f"{source} line {k}: G28 is simulated only as G28 U0 / G28 W0 before the "
                                 "first move (allowed: G0-G3, G7, G8, G18, G21, G40, G49, G90, G91.1, G94-G99)")
            continue
        for gv in g:
            if gv in _UNSUPPORTED_G:
                raise InputError(f"{source} line {k}: G{gv} is not simulated (allowed: G0-G3, G7, G8, "
                                 "G18, G21, G40, G49, G90, G91.1, G94-G99)")
            if gv == "7":
                diameter = True
            elif gv == "8":
                diameter = False
            elif gv == "94":
                per_rev = False
            elif gv in ("95", "99"):
                per_rev = True
            elif gv in ("0", "00", "1", "01", "2", "02", "3", "03"):
                motion = int(gv)
            elif gv == "20":
                raise InputError(f"{source} line {k}: G20 (inches) is not simulated; the programs are in mm")
        vals = {w: float(v) for w, v in words if w in "XZIKFT"}
        if "F" in vals:
            feed = vals["F"]
        if "T" in vals:
            t = int(vals["T"])
            if moves:
                ops.append(SimOperation(name=name, station=station, moves=tuple(moves)))
            moves = []
            station = t // 100 if t >= 100 else t
            name = last_comment.split(":")[0].strip() or f"T{t}"
        if "X" not in vals and "Z" not in vals:
            continue
        if motion is None:
            raise InputError(f"{source} line {k}: a coordinate without a motion mode (G0 / G1 / G2 / G3)")
        start = (pos[0] if pos[0] is not None else first[0], pos[1] if pos[1] is not None else first[1])
        end = ((vals["X"] / 2 if diameter else vals["X"]) if "X" in vals else start[0],
               vals["Z"] if "Z" in vals else start[1])
        label = (f"N{block_no} {code.split(' ', 1)[1] if ' ' in code else code}"
                 if block_no is not None else code)
        label = f"{label} (line {k})" if block_no is not None else f"line {k}: {label}"
        if motion in (2, 3):
            if "I" not in vals and "K" not in vals:
                raise InputError(f"{source} line {k}: an arc without I / K (R arcs are not simulated)")
            centre = (start[0] + vals.get("I", 0.0), start[1] + vals.get("K", 0.0))
            mv = Arc(start=start, end=end, centre=centre, clockwise=motion == 2)
        else:
            mv = Line(start=start, end=end)
        if motion != 0 and not per_rev:
            raise InputError(f"{source} line {k}: a feed move in feed per minute (G94); the "
                             "simulation takes feed per revolution (G95 / G99)")
        moves.append(SimMove(rapid=motion == 0, move=mv, feed=feed, label=label))
        pos = [end[0], end[1]]
    if moves:
        ops.append(SimOperation(name=name, station=station, moves=tuple(moves)))
    return ops


def _g(v: str) -> str:
    """A G number as written without leading zeros ("00" -> "0", "91.1" stays)."""
    f = float(v)
    return str(int(f)) if f.is_integer() else f"{f:g}"


def _first_position(lines: list[str], diameter: bool) -> tuple[float, float]:
    """Where the tool starts: the first X and the first Z the program names (an axis the
    program moves first is taken at its first programmed value)."""
    x = z = None
    for raw in lines:
        code = re.sub(r"\([^)]*\)", " ", raw).split(";")[0].upper()
        if "G7" in code.split():
            diameter = True
        if "G8" in code.split():
            diameter = False
        for w, v in _WORD.findall(code):
            if w == "X" and x is None:
                x = float(v) / 2 if diameter else float(v)
            if w == "Z" and z is None:
                z = float(v)
        if x is not None and z is not None:
            return (x, z)
    return (x or 0.0, z or 0.0)
