"""A lathe program read back into the moves the stock simulation replays.

Reads the subset of G-code the dialects write (and a hand edit of them keeps), each
line first put in the common form by the program's dialect (export.dialects, handed in as
the `reader`: its `translate` and its `letters`, the address letters it allows):
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

A program a user may have edited by hand is held to what the simulation can replay
faithfully, each refusal one line naming the line (and the N number): every word a letter
of the reader's letters and a finite decimal number (`Xnan`, `X1e5`, `Y2` are refused), X and Z
within the machine's travel (machine.travel_x, travel_z_min / travel_z_max), I and K
within MAX_ARC_OFFSET_MM, feeds F above 0 and at most MAX_FEED_MM_REV (a feed move before
any F is refused), T from 0 to 9999, and at most MAX_MOVES moves (the simulation's time
grows with them: README "Toolpath and G-code").
"""

from __future__ import annotations

import math
import re
from typing import TYPE_CHECKING, Protocol

from ..errors import InputError, num
from ..path import Arc, Line
from .stock import SimMove, SimOperation

if TYPE_CHECKING:
    from ..lathe import Lathe

_WORD = re.compile(r"([A-Z])\s*([-+]?(?:\d+\.?\d*|\.\d+))")


class Reader(Protocol):
    """What the replay needs of a dialect (export.dialects.Dialect): the address letters its
    programs may carry (anything else is refused rather than ignored) and the translation
    of one of its lines into the common form read here."""

    name: str
    letters: frozenset

    def translate(self, line: str) -> str: ...

#: Largest feed per revolution a program may give (mm/rev; machine.feed_* allow as much).
MAX_FEED_MM_REV = 500.0
#: Largest arc centre offset I / K (mm): a lobe's vertex radius is at most 10 000 mm.
MAX_ARC_OFFSET_MM = 100_000.0
#: Most moves a program checked by `toolpath --check` may have (the simulation took 3.4 ms
#: a move on the 2-core reference machine under load 8, 11 ms under load 18;
#: benchmarks/bench_check.py).
MAX_MOVES = 10_000
#: Largest program file `toolpath --check` reads (bytes).
MAX_PROGRAM_BYTES = 2 << 20
_N = re.compile(r"N\s*(\d{1,9})\b")
_UNSUPPORTED_G = {"30", "53", "91", "41", "42", "71", "72", "73", "70", "76", "33", "32", "92", "50.1"}


def read_program(text: str, lathe: Lathe, reader: Reader, *, source: str = "program") -> list[SimOperation]:
    """The moves of a G-code program in the reader's dialect, one SimOperation per tool call
    (named by the comment before it, up to its first ':'). Lengths in mm; feeds in mm/rev."""
    lines = [reader.translate(ln) for ln in text.splitlines()]
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
        n_word = _N.match(code)
        where = f"{source} line {k}" + (f" (N{n_word.group(1)})" if n_word else "")
        words = _words(code, where, reader)
        block_no = next((int(float(v)) for w, v in words if w == "N"), None)
        _check_words(words, where, lathe, diameter)
        g = [_g(v) for w, v in words if w == "G"]
        if "28" in g:
            # Fanuc's return to the reference position with an incremental zero (U0 / W0: no
            # intermediate point) before the program knows where the tool is: the program's
            # first moves start from a position it cannot know anyway (their first rapid
            # writes one axis); anywhere else it would move through points we cannot know
            rest = [(w, float(v)) for w, v in words if w not in "NG"]
            if pos != [None, None] or not rest or any(w not in "UW" or v != 0.0 for w, v in rest):
                raise InputError(f"{where}: G28 is simulated only as G28 U0 / G28 W0 before the first move "
                                 "(allowed: G0-G3, G7, G8, G18, G21, G40, G49, G54, G64, G90, G91.1, G94-G99)")
            continue
        if any(w in "UW" for w, _ in words):
            raise InputError(f"{where}: incremental U / W words are not simulated (only G28 U0 / G28 W0 "
                             "before the first move)")
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
            if not 0.0 < feed <= MAX_FEED_MM_REV:
                raise InputError(f"{where}: F{num(feed)}: a feed must be above 0 and at most "
                                 f"{num(MAX_FEED_MM_REV)} mm/rev")
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
        if motion != 0 and feed <= 0.0:
            raise InputError(f"{where}: a feed move before any F word (the feed, mm/rev)")
        if sum(len(op.moves) for op in ops) + len(moves) >= MAX_MOVES:
            raise InputError(f"{source}: more than {MAX_MOVES} moves (at line {k}); --check simulates "
                             f"at most {MAX_MOVES}")
        moves.append(SimMove(rapid=motion == 0, move=mv, feed=feed, label=label))
        pos = [end[0], end[1]]
    if moves:
        ops.append(SimOperation(name=name, station=station, moves=tuple(moves)))
    return ops


def _words(code: str, where: str, reader: Reader) -> list[tuple[str, str]]:
    """The (letter, number) words of a block (comments removed, upper case): InputError
    naming the first piece that is not a letter of the reader's and a finite decimal."""
    allowed = "".join(sorted(reader.letters))
    words = _WORD.findall(code)
    rest = _WORD.sub(" ", code).split()
    if rest:
        token = rest[0][:20]
        raise InputError(f"{where}: '{token}' is not a word of this {reader.name} program (a letter of "
                         f"{allowed} and a finite decimal number)")
    for w, v in words:
        if w not in reader.letters:
            raise InputError(f"{where}: word {w}{v[:20]} is not simulated in the {reader.name} dialect "
                             f"(allowed letters: {allowed})")
        if len(v) > 40 or not math.isfinite(float(v)):
            raise InputError(f"{where}: {w}{v[:20]}...: a number of {len(v)} characters")
    return words


def _check_words(words: list[tuple[str, str]], where: str, lathe: Lathe, diameter: bool) -> None:
    """Coordinates within the machine's travel, arc offsets and tool numbers bounded."""
    for w, v in words:
        f = float(v)
        if w == "X":
            r = f / 2 if diameter else f
            if abs(r) > lathe.travel_x:
                raise InputError(f"{where}: X{v} is outside the machine's travel (radius at most "
                                 f"{num(lathe.travel_x)} mm, machine.travel_x{'; X is a diameter' if diameter else ''})")
        elif w == "Z":
            if not lathe.travel_z_min <= f <= lathe.travel_z_max:
                raise InputError(f"{where}: Z{v} is outside the machine's travel ({num(lathe.travel_z_min)} "
                                 f"to {num(lathe.travel_z_max)} mm, machine.travel_z_min / travel_z_max)")
        elif w in "IK":
            if abs(f) > MAX_ARC_OFFSET_MM:
                raise InputError(f"{where}: {w}{v}: an arc centre offset of at most {num(MAX_ARC_OFFSET_MM)} mm")
        elif w == "T":
            if not 0 <= f <= 9999:
                raise InputError(f"{where}: T{v}: a tool number 0 to 9999")


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
