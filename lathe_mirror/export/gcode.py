"""G-code for the lathe: LinuxCNC and Fanuc-style dialects of a program it is handed.

This module only writes: the program (shop.program.Program: operations, blocks, moves on
the lattice) is planned and simulated in lathe_mirror.shop. Machine frame
(ARCHITECTURE.md): Z = 0 at the mirror's vertex, part in -Z; X is 2r in diameter mode
(LinuxCNC G7, Fanuc's default) or r (G8). The moves are the nose CENTRE's (the tool's
offsets are set to the nose centre; the set-up sheet gives the numbers).

Every number is written fixed-point within the controller's word format, never with
%g: coordinates (X, Z, I, K) are lattice values with as many decimals as the resolution
needs (at most 4) and at most 8 digits; F has 4 decimals (a multiple of 0.0001 mm/rev);
S (m/min under G96) and the spindle cap (D / G50 S) are whole numbers of at most 5
digits; N (block numbers, the same in both dialects) at most 5 digits. lathe.Lathe refuses
speeds and feeds outside their words' formats when the settings are read (one line
naming the key), the program's planner a program of more blocks; a program LinuxCNC's
rs274 (or a Fanuc) would reject is never written.

LinuxCNC: `%`, the header comments, `G18 G7 G21 G90 G40 G49 G94 G54`, `G91.1` (I, K relative
to the arc's start), `G64 P.. Q..` (the path tolerance, ProgramOptions.path_tolerance), then per operation `T1 M6 G43`, `G96 D.. S.. M3`, `G95`, `M8`, `F..`
and its moves; `M9`, the way home, `M5`, `M1` before the finishing tool; `M30`, `%`.
Fanuc: `%`, `O1000 (NAME)`, upper-case comments in parentheses (no `;`), `G21` alone in
its block, `G18 G40 G97 G99 G54`, a note of the look-ahead accuracy mode for the path
tolerance, `G28 W0` and `G28 U0` (to the reference position, Z first) before the first tool
change, per operation `T0101`, `G50 S..` (spindle cap), `G96 S..
M03`, `M08`, `F..`; `M09`, `M05`, `M01`; `M30`, `%`.
"""

from __future__ import annotations

import math
import re
import textwrap
from pathlib import Path
from typing import TYPE_CHECKING

from ..enums import Dialect
from ..errors import InputError
from ..path import Arc
from ..shop.program import (
    Comment,
    Coolant,
    Feed,
    FeedRate,
    OptionalStop,
    PARTING_STATION,
    ProgramEnd,
    Rapid,
    SpindleOn,
    SpindleStop,
    ToolCall,
    stations,
)
from .files import write_text
from .setup_sheet import setup_sheet_html

if TYPE_CHECKING:
    from ..shop.program import Program

#: Most digits of a coordinate word (sign and point aside): Fanuc's 8.
MAX_DIGITS = 8
#: Longest comment text of a header line the second set-up wraps to (rs274 reads lines of
#: at most 255 characters).
COMMENT_WIDTH = 160
#: Decimals of an F word (mm/rev).
FEED_DECIMALS = 4


def format_program(program: Program, dialect: Dialect = Dialect.LINUXCNC) -> str:
    """The program as text in `dialect`. Raises InputError if a coordinate word would
    carry more digits than the controller's format."""
    w = _Writer(program, dialect)
    w.header()
    w.preamble()
    for op in program.operations:
        w.operation(op)
    w.emit("%")
    return w.text()


def write_program(path: str | Path, program: Program, dialect: Dialect = Dialect.LINUXCNC) -> Path:
    """Write the program atomically (nothing is written if it is refused)."""
    return write_text(path, format_program(program, dialect))


def program_files(shops) -> dict[str, str]:
    """{file name: content} of checked programs (pipeline.ShopProgram): each in both
    dialects, mirror_<strategy>.ngc / .nc, its second set-up's program (the back and the
    mount), mirror_<strategy>_op2.ngc / .nc, when it parts off, and the set-up sheet of
    both, .setup.html."""
    out: dict[str, str] = {}
    for shop in shops:
        for prog in (shop.program, shop.second):
            if prog is None:
                continue
            for dialect in Dialect:
                out[f"{prog.name}.{dialect.extension}"] = format_program(prog, dialect)
        out[f"{shop.program.name}.setup.html"] = setup_sheet_html(shop.sheet)
    return out


# --------------------------------------------------------------------------------------
# Writing


def _plain(v) -> str:
    """A number for a message, fixed-point (no exponent) and short."""
    if isinstance(v, int) and not isinstance(v, bool):
        return str(v)
    s = f"{v:.10f}".rstrip("0").rstrip(".")
    return s if len(s) <= 24 else f"{v:.6e}"


def _fixed(v: float, decimals: int) -> str:
    """Fixed-point with at most `decimals` decimals and at least one (F0.15, F0.0300 -> F0.03)."""
    s = f"{v:.{decimals}f}".rstrip("0")
    return s + "0" if s.endswith(".") else s


_FANUC_COMMENT = re.compile(r"[^A-Z0-9 .,+\-/=:*#_]")


class _Writer:
    def __init__(self, program: Program, dialect: Dialect) -> None:
        self.p, self.dialect = program, dialect
        self.lathe = program.toolpath.lathe
        self.lines: list[str] = []
        self.res = self.lathe.resolution
        self.dec = self.lathe.decimals
        self.fanuc = dialect is Dialect.FANUC

    def text(self) -> str:
        return "\n".join(self.lines) + "\n"

    def emit(self, s: str, number: int = 0) -> None:
        self.lines.append(f"N{number} {s}" if number else s)

    def comment(self, text: str) -> None:
        if self.fanuc:  # older controls and DNC links: upper case, no ';' or nesting
            text = text.upper().replace(";", ",").replace("'", "")
            text = re.sub(" +", " ", _FANUC_COMMENT.sub(" ", text)).strip()
        else:  # neither dialect allows parentheses inside a comment
            text = text.replace("(", "[").replace(")", "]")
        self.emit("(" + text + ")")

    # -- words ------------------------------------------------------------------------

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

    # -- program ----------------------------------------------------------------------

    def header(self) -> None:
        p, lathe, tp = self.p, self.lathe, self.p.toolpath
        tool, m, stock, opts = tp.tool, tp.mirror, p.stock, p.options
        self.emit("%")
        if self.fanuc:
            number = 1001 if p.setup is not None else 1000
            self.emit(f"O{number} (" + _FANUC_COMMENT.sub("", p.name.upper()) + ")")
        if p.setup is not None:
            self.second_header()
            return
        c = self.comment
        c(f"lathe-mirror {p.name}: double-lobed hyperbolic mirror, {self.dialect.value} dialect")
        c("work zero: Z0 at the mirror's vertex, part in -Z; X0 on the spindle axis; X = "
          + ("diameter" if lathe.diameter_mode else "radius") + "; mm")
        for lobe in m.design.lobes:  # the designed constants (a cut target is not a hyperbola)
            c(f"design {lobe.name}: r_top {lobe.r_top:g} a {lobe.a:.4f} b {lobe.b:.4f} e {lobe.e:.4f} "
              f"2e (Table 1 c) {lobe.focus_z:.4f} h {lobe.h:.4f} mm alpha {math.degrees(lobe.alpha):.3f} deg")
        c(f"junction r {m.r_junction:g} mm, step {abs(m.step):.4f} mm, {m.recessed} lobe recessed")
        c(f"machine: resolution {lathe.resolution:g} mm, budget {lathe.max_points} points, "
          f"spindle cap {lathe.spindle_max_rpm} rpm, {_plain(lathe.surface_speed)} m/min, "
          f"feeds {_plain(lathe.feed_rough)}/{_plain(lathe.feed_finish)} mm/rev")

        t_r, t_f = (self.tool_word(st) for st in stations(tp))
        c(f"tools {t_r} roughing, {t_f} finishing: nose radius {tool.nose_radius:g} mm, included "
          f"{math.degrees(tool.included_angle):g} deg, approach {math.degrees(tool.approach_angle):g} deg; "
          f"offsets set to the NOSE CENTRE, see {p.name}.setup.html")
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
            c(f"tool T{PARTING_STATION}: parting blade {w:g} mm wide, controlled point its tip's corner on the "
              f"chuck side (-Z); it parts the mirror off at Z{z + w:.3f} (the slot Z{z:.3f}..{z + w:.3f})")
            c(f"the second set-up ({p.name}_op2) faces the back and cuts the mount")
        c("operations, restart at their first block: "
          + ", ".join(f"{op.name} N{op.number}" for op in p.operations))
        c(f"end position: home {self.xz(p.home)}, Z first, before the finishing tool and M30")

    def second_header(self) -> None:
        """The second set-up's header: what it is, its work zero, the holding, the tool."""
        p, lathe, su, c = self.p, self.lathe, self.p.setup, self.comment
        tool = p.toolpath.tool
        c(f"lathe-mirror {p.name}: second set-up of the double-lobed hyperbolic mirror (the back and the "
          f"mount, cad.mount {su.mount.value}), {self.dialect.value} dialect")
        for text in ("work zero: " + su.work_zero + " X = " + ("diameter" if lathe.diameter_mode else "radius")
                     + "; mm", "holding: " + su.holding):
            for line in textwrap.wrap(text, COMMENT_WIDTH):  # a controller's line is short (rs274: 255)
                c(line)
        c(f"tool {self.tool_word(su.station)}: the roughing insert, nose radius {tool.nose_radius:g} mm"
          + (", in the opposite-hand holder (it cuts from the outside in)" if su.station != 1 else
             " (it cuts from the axis out)") + f"; offsets set to the NOSE CENTRE, see {p.name.removesuffix('_op2')}.setup.html")
        c("operations, restart at their first block: "
          + ", ".join(f"{op.name} N{op.number}" for op in p.operations))
        c(f"end position: home {self.xz(p.home)}, Z first, before M30")

    def preamble(self) -> None:
        lathe, tol = self.lathe, self.p.options.path_tolerance
        if self.fanuc:
            self.emit("G21")
            self.emit("G18 G40 G97 G99 G54")
            self.comment(f"path tolerance {_fixed(tol, 4)} mm: run the contour in the control's look-ahead "
                         "accuracy mode (AI contour control G05.1 Q1 or G08 P1, as the control has it)")
            self.comment("to the reference position, Z first, before the first tool change")
            self.emit("G28 W0")
            self.emit("G28 U0")
        else:
            self.emit("G18 " + ("G7" if lathe.diameter_mode else "G8") + " G21 G90 G40 G49 G94 G54")
            self.emit("G91.1")  # I, K relative to the arc's start
            # path blending within the tolerance (P) and collinear merging within it (Q):
            # without it LinuxCNC blends the short arcs freely
            self.emit(f"G64 P{_fixed(tol, 4)} Q{_fixed(tol, 4)}")

    def tool_word(self, station: int) -> str:
        return f"T{station:02d}{station:02d}" if self.fanuc else f"T{station}"

    def operation(self, op) -> None:
        for b in op.blocks:
            n = b.number
            if isinstance(b, Comment):
                self.comment(b.text)
            elif isinstance(b, ToolCall):
                self.emit(self.tool_word(b.station) if self.fanuc else f"T{b.station} M6 G43", n)
            elif isinstance(b, SpindleOn):
                s = f"S{int(b.surface_speed)}"
                if self.fanuc:
                    self.emit(f"G50 S{int(b.max_rpm)}", n)
                    self.emit(f"G96 {s} M03")
                else:
                    self.emit(f"G96 D{int(b.max_rpm)} {s} M3", n)
                    self.emit("G95")
            elif isinstance(b, Coolant):
                self.emit(("M08" if b.on else "M09") if self.fanuc else ("M8" if b.on else "M9"), n)
            elif isinstance(b, FeedRate):
                self.emit(f"F{_fixed(b.feed, FEED_DECIMALS)}", n)
            elif isinstance(b, Rapid):
                words = self.xz(b.move.end).split()
                if b.only is not None:  # from a position the program does not know
                    words = [w for w in words if w[0] == b.only]
                self.emit("G0 " + " ".join(words), n)
            elif isinstance(b, Feed):
                mv = b.move
                if isinstance(mv, Arc):
                    g = "G2" if mv.clockwise else "G3"
                    i = mv.centre[0] - mv.start[0]  # radius in both dialects
                    k = mv.centre[1] - mv.start[1]
                    self.emit(f"{g} {self.xz(mv.end)} I{self.lattice(i, 'I')} K{self.lattice(k, 'K')}", n)
                else:
                    self.emit(f"G1 {self.xz(mv.end)}", n)
            elif isinstance(b, SpindleStop):
                self.emit("M05" if self.fanuc else "M5", n)
            elif isinstance(b, OptionalStop):
                self.emit("M01" if self.fanuc else "M1", n)
            elif isinstance(b, ProgramEnd):
                self.emit("M30", n)
            else:  # a block type this writer does not know is a bug, not bad input
                raise RuntimeError(f"cannot write block {b!r}")
