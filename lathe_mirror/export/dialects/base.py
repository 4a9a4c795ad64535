"""A control's dialect: one object that writes a program (shop.program.Program) in its
words, writes its tool table or offset list, and reads its programs back for the stock
simulation (shop.replay takes it as the reader).

What every dialect shares is here: the words' number formats, the header's comments, the
walk over the blocks. A dialect's module (export/dialects/<name>.py) subclasses Dialect,
fills in the words where controls differ (program start and end, preamble, tool call,
spindle, coolant, stops, comments) and the offset file, and calls `register`. Nothing else
names a dialect: the writer, the set-up sheet and the replay iterate the registry.

Machine frame (ARCHITECTURE.md): Z = 0 at the mirror's vertex, part in -Z; X is 2r in
diameter mode or r. The moves are the nose CENTRE's. Coordinates (X, Z, I, K) are lattice
values with as many decimals as the resolution needs (at most 4) and at most MAX_DIGITS
digits; I and K are the centre relative to the arc's start, I a radius in every dialect
here; F has FEED_DECIMALS decimals; S and the spindle cap are whole numbers of at most 5
digits; N (the same in every dialect) at most 5 digits.
"""

from __future__ import annotations

import math
import re
import textwrap
from dataclasses import dataclass
from typing import TYPE_CHECKING

from ...errors import InputError
from ...path import Arc
from ...shop.program import (
    PARTING_STATION,
    Comment,
    Coolant,
    Feed,
    FeedRate,
    OptionalStop,
    ProgramEnd,
    ProgramStop,
    Rapid,
    SpindleOn,
    SpindleStop,
    ToolCall,
    stations,
)

if TYPE_CHECKING:
    from ...shop.program import Program
    from ...shop.setup import ToolSheet

#: Most digits of a coordinate word (sign and point aside): Fanuc's 8.
MAX_DIGITS = 8
#: Longest comment text of a header line the second set-up wraps to (rs274 reads lines of
#: at most 255 characters).
COMMENT_WIDTH = 160
#: Decimals of an F word (mm/rev).
FEED_DECIMALS = 4


def fixed(v: float, decimals: int) -> str:
    """Fixed-point with at most `decimals` decimals and at least one (F0.15, F0.0300 -> F0.03)."""
    s = f"{v:.{decimals}f}".rstrip("0")
    return s + "0" if s.endswith(".") else s


def plain(v) -> str:
    """A number for a comment, fixed-point (no exponent) and short."""
    if isinstance(v, int) and not isinstance(v, bool):
        return str(v)
    s = f"{v:.10f}".rstrip("0").rstrip(".")
    return s if len(s) <= 24 else f"{v:.6e}"


@dataclass(frozen=True)
class Measured:
    """A tool's touched-off offsets to write into a table (mm, X in the program's X
    convention); None leaves the entry to the operator (written as 0 where a table needs a
    number, omitted where the control keeps what it has)."""

    x: float | None = None
    z: float | None = None


class Dialect:
    """One control's G-code. Subclasses set the class attributes and override the words.

    name: the --dialect value. label: the control's name in text. extension: a program's
    file suffix. offsets_file: the tool table's or offset list's file name beside the
    programs. letters: the address letters its programs may carry (shop.replay refuses
    any other). diameter_word: how the X convention is stated (e.g. "G7")."""

    name = ""
    label = ""
    extension = ""
    offsets_file = ""
    letters = frozenset()

    # -- reading (shop.replay's reader protocol) -----------------------------------------

    def translate(self, line: str) -> str:
        """A line of this dialect's program in the common form shop.replay reads
        (parenthesised comments, G7 / G8 for the X convention, T<station>); the identity
        where the dialect writes that form already."""
        return line

    def owns(self, text: str) -> bool:
        """True if `text` (a program's first lines) is written in this dialect."""
        return False

    # -- words ---------------------------------------------------------------------------

    def comment(self, text: str) -> str:
        """A comment line (no parentheses inside one: neither LinuxCNC nor Fanuc nests them)."""
        return "(" + text.replace("(", "[").replace(")", "]") + ")"

    def opening(self, program: Program) -> list[str]:
        """Lines before the header comments."""
        return ["%"]

    def closing(self) -> list[str]:
        """Lines after the program's end."""
        return ["%"]

    def preamble(self, program: Program) -> list[str]:
        """The modal set-up before the first tool (no block numbers)."""
        raise NotImplementedError

    def tool_word(self, station: int) -> str:
        """How a tool is named in the header and on the sheet."""
        return f"T{station}"

    def tool_call(self, station: int, role: str) -> list[str]:
        """Index the turret and take the offsets (the first line takes the block number):
        the tool word alone where the word does both."""
        return [self.tool_word(station)]

    def m_code(self, number: int) -> str:
        """A miscellaneous function's word (M3; a control that writes two digits, M03,
        says so here)."""
        return f"M{number}"

    def spindle_cap(self, max_rpm: int) -> str:
        """The block that caps the spindle (rev/min) under constant surface speed."""
        raise NotImplementedError

    def spindle_on(self, surface_speed: float, max_rpm: int, clockwise: bool) -> list[str]:
        """Constant surface speed (m/min) with the cap (rev/min), feed per revolution: the
        cap's block, then G96 S.. M3 (M4 counter-clockwise)."""
        return [self.spindle_cap(max_rpm), f"G96 S{int(surface_speed)} {self.m_code(3 if clockwise else 4)}"]

    def spindle_rpm(self, rpm: int, clockwise: bool) -> list[str]:
        """A constant spindle speed (rev/min, G97), feed per revolution."""
        return [f"G97 S{rpm} {self.m_code(3 if clockwise else 4)}"]

    def coolant(self, on: bool) -> str:
        return self.m_code(8 if on else 9)

    def spindle_stop(self) -> str:
        return self.m_code(5)

    def optional_stop(self) -> str:
        return self.m_code(1)

    def program_stop(self) -> str:
        return self.m_code(0)

    def end(self) -> str:
        return self.m_code(30)

    # -- tool data -------------------------------------------------------------------------

    def tip_code(self, tool: ToolSheet) -> str:
        """The controlled point's code as this control names it (for the sheet)."""
        raise NotImplementedError

    def offset_entry(self, tool: ToolSheet, diameter_mode: bool) -> str:
        """One tool's entry as the operator types or reads it on this control (the sheet)."""
        raise NotImplementedError

    def offsets(self, tools: list[ToolSheet], diameter_mode: bool,
                measured: dict[int, Measured] | None = None) -> str:
        """The whole tool table or offset list (offsets_file's text) for these tools."""
        raise NotImplementedError

    # -- the program -------------------------------------------------------------------------

    def format(self, program: Program) -> str:
        """The program as text. InputError if a coordinate word would carry more digits than
        the controller's format."""
        w = Writer(program, self)
        for line in self.opening(program):
            w.emit(line)
        if program.setup is not None:
            w.second_header()
        else:
            w.header()
        for line in self.preamble(program):
            w.emit(line)
        for op in program.operations:
            w.operation(op)
        for line in self.closing():
            w.emit(line)
        return w.text()


class Writer:
    """One program being written in one dialect: the lines and the word formats."""

    def __init__(self, program: Program, dialect: Dialect) -> None:
        self.p, self.d = program, dialect
        self.lathe = program.toolpath.lathe
        self.lines: list[str] = []
        self.res = self.lathe.resolution
        self.dec = self.lathe.decimals

    def text(self) -> str:
        return "\n".join(self.lines) + "\n"

    def emit(self, s: str, number: int = 0) -> None:
        self.lines.append(f"N{number} {s}" if number else s)

    def comment(self, text: str) -> None:
        self.emit(self.d.comment(text))

    def lattice(self, v: float, what: str, scale: int = 1) -> str:
        k = int(round(v / self.res))
        if abs(k * self.res - v) > 1e-7:
            raise RuntimeError(f"{what} {v!r} is not on the lattice")
        s = f"{k * self.res * scale:.{self.dec}f}"
        if float(s) == 0.0:
            s = s.lstrip("-")
        if len(s.lstrip("-").replace(".", "")) > MAX_DIGITS:
            raise InputError(f"a coordinate word {what}{s} has more than {MAX_DIGITS} digits "
                             "(machine travel and stock too large for the controller's word format)")
        return s

    def xz(self, p) -> str:
        return (f"X{self.lattice(p[0], 'X', 2 if self.lathe.diameter_mode else 1)} "
                f"Z{self.lattice(p[1], 'Z')}")

    # -- header ----------------------------------------------------------------------------

    def header(self) -> None:
        p, lathe, tp, d = self.p, self.lathe, self.p.toolpath, self.d
        tool, m, stock, opts = tp.tool, tp.mirror, p.stock, p.options
        c = self.comment
        c(f"lathe-mirror {p.name}: double-lobed hyperbolic mirror, {d.name} dialect")
        c("work zero: Z0 at the mirror's vertex, part in -Z; X0 on the spindle axis; X = "
          + ("diameter" if lathe.diameter_mode else "radius") + "; mm")
        for lobe in m.design.lobes:  # the designed constants (a cut target is not a hyperbola)
            c(f"design {lobe.name}: r_top {lobe.r_top:g} a {lobe.a:.4f} b {lobe.b:.4f} e {lobe.e:.4f} "
              f"2e (Table 1 c) {lobe.focus_z:.4f} h {lobe.h:.4f} mm alpha {math.degrees(lobe.alpha):.3f} deg")
        c(f"junction r {m.r_junction:g} mm, step {abs(m.step):.4f} mm, {m.recessed} lobe recessed")
        c(f"machine: resolution {lathe.resolution:g} mm, budget {lathe.max_points} points, "
          f"spindle cap {lathe.spindle_max_rpm} rpm, {plain(lathe.surface_speed)} m/min, "
          f"feeds {plain(p.rough_feed)}/{plain(lathe.feed_finish)} mm/rev")
        t_r, t_f = (d.tool_word(st) for st in stations(tp))
        c(f"tools {t_r} roughing, {t_f} finishing: nose radius {tool.nose_radius:g} mm, included "
          f"{math.degrees(tool.included_angle):g} deg, approach {math.degrees(tool.approach_angle):g} deg; "
          f"offsets set to the NOSE CENTRE, see {p.name}.setup.html and {d.offsets_file}")
        if tp.held_tool is not tool:
            c(f"tools {t_r} and {t_f}: {tp.hand.describe(tool)}")
        c(f"stock: diameter {stock.diameter:g} mm, face allowance {stock.face_allowance:g} mm, "
          f"length {stock.length:g} mm")
        n_arcs = sum(1 for s in tp.segments if isinstance(s, Arc))
        c(f"strategy {tp.strategy.value}: {len(tp.segments)} moves, {n_arcs} arcs, "
          f"{tp.n_points} of {lathe.max_points} points used")
        c(f"gouge check: deepest point inside the part {p.gouge_depth:.4f} mm, tolerance "
          f"{opts.gouge_tolerance:g} mm")
        fillet = p.fillet
        if fillet is not None:
            c(f"junction fillet: the nose cannot reach the inside corner; the {fillet['lobe']} lobe is "
              f"filleted from r {fillet['r_start_mm']:.3f} to {fillet['r_end_mm']:g} mm, "
              f"{fillet['height_mm']:.3f} mm up the wall; the whole-lobe figures include it")
        for lobe in p.figures["lobes"]:
            nd, se = lobe["normal_deviation_mm"], lobe["slope_error_rad"]
            c(f"as machined {lobe['name']}, whole lobe, against the design: normal deviation rms {nd['rms']:.2e} max "
              f"{nd['max']:.2e} mm, slope error rms {se['rms']:.2e} max {se['max']:.2e} rad")
        for lobe in p.figures.get("against_target", ()):
            nd = lobe["normal_deviation_mm"]
            c(f"as machined {lobe['name']}, whole lobe, against this program's target [the design lowered by the "
              f"polish's planned removal]: normal deviation rms {nd['rms']:.2e} max {nd['max']:.2e} mm")
        if m.step > 0:
            inner_hi = p.used["lobes"][0]["r_range_mm"]["max"]
            hidden = fillet is not None and fillet["r_start_mm"] >= inner_hi
            c(f"used zone: the step wall blocks the camera's view of the inner lobe beyond r {inner_hi:.3f} mm"
              + ("; the fillet lies there, out of the image" if hidden else ""))
        else:
            outer_lo = p.used["lobes"][1]["r_range_mm"]["min"]
            hidden = fillet is not None and fillet["r_end_mm"] <= outer_lo
            c(f"used zone: the inner lobe's rim hides the outer lobe from the camera below r {outer_lo:.3f} mm"
              + ("; the fillet lies there, out of the image" if hidden else ""))
        for lobe in p.used["lobes"]:
            nd, se, rr = lobe["normal_deviation_mm"], lobe["slope_error_rad"], lobe["r_range_mm"]
            c(f"as machined {lobe['name']}, used r {rr['min']:.3f}..{rr['max']:.3f} mm, against the design: normal deviation "
              f"rms {nd['rms']:.2e} max {nd['max']:.2e} mm, slope error rms {se['rms']:.2e} max {se['max']:.2e} rad")
        if p.parting is not None:
            z, w = p.parting
            c(f"tool {d.tool_word(PARTING_STATION)}: parting blade {w:g} mm wide, controlled point its tip's "
              f"corner on the chuck side (-Z); it parts the mirror off at Z{z + w:.3f} (the slot "
              f"Z{z:.3f}..{z + w:.3f}) after a stop to fit the parts catcher")
            c(f"the second set-up ({p.name}_op2) faces the back and cuts the mount")
        c("operations, restart at their first block: "
          + ", ".join(f"{op.name} N{op.number}" for op in p.operations))
        c(f"end position: home {self.xz(p.home)}, Z first, before the finishing tool and M30")

    def second_header(self) -> None:
        """The second set-up's header: what it is, its work zero, the holding, the tools."""
        p, lathe, su, c, d = self.p, self.lathe, self.p.setup, self.comment, self.d
        tool = p.toolpath.tool
        c(f"lathe-mirror {p.name}: second set-up of the double-lobed hyperbolic mirror (the back and the "
          f"mount, cad.mount {su.mount.value}), {d.name} dialect")
        for text in ("work zero: " + su.work_zero + " X = " + ("diameter" if lathe.diameter_mode else "radius")
                     + "; mm", "holding: " + su.holding):
            for line in textwrap.wrap(text, COMMENT_WIDTH):  # a controller's line is short (rs274: 255)
                c(line)
        for station, what in su.tools:
            c(f"tool {d.tool_word(station)}: {what}")
        c(f"nose radius {tool.nose_radius:g} mm; offsets set to the NOSE CENTRE, see "
          f"{p.name.removesuffix('_op2')}.setup.html and {d.offsets_file}")
        c("operations, restart at their first block: "
          + ", ".join(f"{op.name} N{op.number}" for op in p.operations))
        c(f"end position: home {self.xz(p.home)}, Z first, before M30")

    # -- blocks ------------------------------------------------------------------------------

    def operation(self, op) -> None:
        d = self.d
        for b in op.blocks:
            n = b.number
            if isinstance(b, Comment):
                self.comment(b.text)
            elif isinstance(b, ToolCall):
                self.lines_numbered(d.tool_call(b.station, b.role), n)
            elif isinstance(b, SpindleOn) and b.rpm is not None:
                self.lines_numbered(d.spindle_rpm(int(b.rpm), b.clockwise), n)
            elif isinstance(b, SpindleOn):
                self.lines_numbered(d.spindle_on(b.surface_speed, int(b.max_rpm), b.clockwise), n)
            elif isinstance(b, Coolant):
                self.emit(d.coolant(b.on), n)
            elif isinstance(b, FeedRate):
                self.emit(f"F{fixed(b.feed, FEED_DECIMALS)}", n)
            elif isinstance(b, Rapid):
                words = self.xz(b.move.end).split()
                if b.only is not None:  # from a position the program does not know
                    words = [w for w in words if w[0] == b.only]
                self.emit("G0 " + " ".join(words), n)
            elif isinstance(b, Feed):
                mv = b.move
                if isinstance(mv, Arc):
                    g = "G2" if mv.clockwise else "G3"
                    i = mv.centre[0] - mv.start[0]  # a radius
                    k = mv.centre[1] - mv.start[1]
                    self.emit(f"{g} {self.xz(mv.end)} I{self.lattice(i, 'I')} K{self.lattice(k, 'K')}", n)
                else:
                    self.emit(f"G1 {self.xz(mv.end)}", n)
            elif isinstance(b, SpindleStop):
                self.emit(d.spindle_stop(), n)
            elif isinstance(b, OptionalStop):
                self.emit(d.optional_stop(), n)
            elif isinstance(b, ProgramStop):
                self.emit(d.program_stop(), n)
            elif isinstance(b, ProgramEnd):
                self.emit(d.end(), n)
            else:  # a block type this writer does not know is a bug, not bad input
                raise RuntimeError(f"cannot write block {b!r}")

    def lines_numbered(self, lines: list[str], number: int) -> None:
        for k, line in enumerate(lines):
            self.emit(line, number if k == 0 else 0)


def upper_comment(text: str) -> str:
    """A comment's text as older controls and DNC links take it: upper case, none of
    ';', quotes or parentheses, single spaces."""
    text = text.upper().replace(";", ",").replace("'", "")
    return re.sub(" +", " ", re.sub(r"[^A-Z0-9 .,+\-/=:*#_]", " ", text)).strip()
