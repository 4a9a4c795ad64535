"""Fanuc-style lathe (Fanuc 0i-T, 16i/18i-T and their kind): `%`, `O1000 (NAME)`, upper-case
comments in parentheses (no `;`), `G21` alone in its block, `G18 G40 G97 G99 G54`, a note of
the look-ahead accuracy mode for the path tolerance, `G28 W0` and `G28 U0` (to the reference
position, Z first) before the first tool change, per operation `T0101`, `G50 S..` (the
spindle cap), `G96 S.. M03`, `M08`, `F..`; `M09`, `M05`, `M01`, `M00` before the part-off;
`M30`, `%`.

The offset list is a program in Fanuc's own form (the T series' programmable data input,
G10 P_ X_ Z_ R_ Q_): `G10 P10001 R0.2 Q0` sets geometry offset 1 (P 10000 + the offset
number; P 1..64 would be the wear offsets), its nose radius R and imaginary tool nose Q (0:
the nose centre); X and Z are written only when they are known, so running it never
overwrites what the operator touched off. The sheet shows the same numbers as the OFFSET /
GEOMETRY page's X Z R T columns.
"""

from __future__ import annotations

import re
from typing import TYPE_CHECKING

from . import register
from .base import Dialect, Measured, fixed, upper_comment

if TYPE_CHECKING:
    from ...shop.program import Program
    from ...shop.setup import ToolSheet

#: The offset list's program number.
OFFSET_PROGRAM = 9001


class Fanuc(Dialect):
    name = "fanuc"
    label = "Fanuc"
    extension = "nc"
    offsets_file = "offsets.nc"
    letters = frozenset("GMNTSFXZIKOUW")  # U, W: only G28 U0 / W0

    def owns(self, text: str) -> bool:
        return re.search(r"^O\d{4}\b", text, re.M) is not None

    def comment(self, text: str) -> str:  # older controls and DNC links
        return "(" + upper_comment(text) + ")"

    def opening(self, program: Program) -> list[str]:
        number = 1001 if program.setup is not None else 1000
        return ["%", f"O{number} (" + re.sub(r"[^A-Z0-9_]", "", program.name.upper()) + ")"]

    def preamble(self, program: Program) -> list[str]:
        tol = program.options.path_tolerance_mm
        return ["G21", "G18 G40 G97 G99 G54",
                self.comment(f"path tolerance {fixed(tol, 4)} mm: run the contour in the control's look-ahead "
                             "accuracy mode (AI contour control G05.1 Q1 or G08 P1, as the control has it)"),
                self.comment("to the reference position, Z first, before the first tool change"),
                "G28 W0", "G28 U0"]

    def tool_word(self, station: int) -> str:
        return f"T{station:02d}{station:02d}"

    def tool_call(self, station: int, role: str) -> list[str]:
        return [self.tool_word(station)]

    def spindle_on(self, surface_speed: float, max_rpm: int, clockwise: bool) -> list[str]:
        return [f"G50 S{max_rpm}", f"G96 S{int(surface_speed)} {'M03' if clockwise else 'M04'}"]

    def spindle_rpm(self, rpm: int, clockwise: bool) -> list[str]:
        return [f"G97 S{rpm} {'M03' if clockwise else 'M04'}"]

    def coolant(self, on: bool) -> str:
        return "M08" if on else "M09"

    def spindle_stop(self) -> str:
        return "M05"

    def optional_stop(self) -> str:
        return "M01"

    def program_stop(self) -> str:
        return "M00"

    def tip_code(self, tool: ToolSheet) -> str:
        return "imaginary tool nose T0"

    def offset_entry(self, tool: ToolSheet, diameter_mode: bool) -> str:
        return (f"GEOMETRY offset {tool.station:02d}: X, Z touched off, R {tool.offsets.nose_radius:.3f}, T 0"
                f" (G10 P{10000 + tool.station} R{fixed(tool.offsets.nose_radius, 3)} Q0)")

    def offsets(self, tools: list[ToolSheet], diameter_mode: bool,
                measured: dict[int, Measured] | None = None) -> str:
        measured = measured or {}
        lines = ["%", f"O{OFFSET_PROGRAM} (TOOL OFFSETS)",
                 self.comment("geometry offsets of the programs' tools: nose radius R and imaginary tool "
                              "nose Q; X and Z only where measured (touch off the others)"),
                 "G21", "G90"]
        for t in tools:
            m = measured.get(t.station)
            words = [f"G10 P{10000 + t.station}"]
            if m is not None and m.x is not None:
                words.append(f"X{m.x:.4f}")
            if m is not None and m.z is not None:
                words.append(f"Z{m.z:.4f}")
            words += [f"R{fixed(t.offsets.nose_radius, 3)}", "Q0"]
            lines += [self.comment(f"T{t.station:02d}{t.station:02d} {t.label}"), " ".join(words)]
        lines += ["M30", "%"]
        return "\n".join(lines) + "\n"


register(Fanuc())
