"""Siemens SINUMERIK 840D (ISO dialect off, Siemens mode): the archive's first line
`%_N_<NAME>_MPF` and `;$PATH=/_N_MPF_DIR` (a main program, .mpf), comments after `;`,
`G18 G90 G71 G40 G54` (G71: metric), `DIAMON` (X a diameter) or `DIAMOF`, `G95` (feed per
revolution), `G64` (continuous path) with a note of CYCLE832 for the path tolerance; per
operation `T="T1" D1` (the tool by name, its station's; cutting edge 1), `LIMS=..` (the
spindle cap under G96), `G96 S.. M3`, `M8`, `F..`; `M9`, `M5`, `M1` before the finishing
tool, `M0` before the part-off; `M30`. Arcs: G2 / G3 with I, K the centre relative to the
arc's start (Siemens' default, incremental), I a radius; the arcs strategy's spirals are
within the arc radius tolerance the control accepts as a circle's end-point error.

The tool data are an initialisation file in the control's own form (tools.ini, loaded as
the TO_INI archive): per tool its name ($TC_TP2), type ($TC_DP1: 500 roughing, 510
finishing, 530 parting, 500 the boring bar, 200 the twist drill, 220 the centre drill),
cutting edge position ($TC_DP2: 9, the nose centre), lengths 1 and
2 (X, Z, $TC_DP3 / $TC_DP4: 0 until touched off) and the nose radius ($TC_DP6).
"""

from __future__ import annotations

import re
from typing import TYPE_CHECKING

from . import register
from .base import Dialect, Measured, fixed

if TYPE_CHECKING:
    from ...shop.program import Program
    from ...shop.setup import ToolSheet

#: $TC_DP1 of each role's tool (Siemens' turning tool types).
TOOL_TYPES = {"roughing": 500, "finishing": 510, "parting": 530, "boring": 500, "drill": 200, "centre": 220}
_TOOL = re.compile(r'T\s*=\s*"T(\d+)"')


class Siemens(Dialect):
    name = "siemens"
    label = "Siemens 840D"
    extension = "mpf"
    offsets_file = "tools.ini"
    letters = frozenset("GMNTSDFXZIK")  # D: the cutting edge

    def owns(self, text: str) -> bool:
        return re.search(r"^%_N_\w+_MPF\b|^\s*(N\d+\s+)?DIAMO[NF]\b", text, re.M) is not None

    def translate(self, line: str) -> str:
        code, _, note = line.partition(";")
        if code.lstrip().startswith("%_N_") or note.startswith("$PATH"):
            return ""
        code = _TOOL.sub(r"T\1", code.upper())
        code = re.sub(r"\bDIAMON\b", "G7", code)
        code = re.sub(r"\bDIAMOF\b", "G8", code)
        code = re.sub(r"\bLIMS\s*=\s*\d+(\.\d*)?", " ", code)  # the spindle cap: not a move
        code = re.sub(r"\bG71\b", "G21", code)  # metric
        code = re.sub(r"\bG64\b", " ", code)   # continuous path: the moves are the same
        note = note.strip().replace("(", "[").replace(")", "]")
        return code.rstrip() + (f" ({note})" if note else "")

    def comment(self, text: str) -> str:
        return "; " + text.replace(";", ",")

    def opening(self, program: Program) -> list[str]:
        name = re.sub(r"[^A-Z0-9_]", "_", program.name.upper())
        return [f"%_N_{name}_MPF", ";$PATH=/_N_MPF_DIR"]

    def closing(self) -> list[str]:
        return []

    def preamble(self, program: Program) -> list[str]:
        lathe, tol = program.toolpath.lathe, program.options.path_tolerance_mm
        return ["G18 G90 G71 G40 G54", "DIAMON" if lathe.diameter_mode else "DIAMOF", "G95 G64",
                self.comment(f"path tolerance {fixed(tol, 4)} mm: CYCLE832({fixed(tol, 4)}, _FINISH) where the "
                             "control has it (high speed settings)")]

    def tool_word(self, station: int) -> str:
        return f'T="T{station}" D1'

    def spindle_cap(self, max_rpm: int) -> str:
        return f"LIMS={max_rpm}"

    def tip_code(self, tool: ToolSheet) -> str:
        return "cutting edge position 9 ($TC_DP2)"

    def offset_entry(self, tool: ToolSheet, diameter_mode: bool) -> str:
        return (f'T="{tool_name(tool)}" D1: type {TOOL_TYPES.get(role_word(tool.role).lower(), 500)}, '
                f"edge position 9, lengths 1 / 2 touched off, radius {tool.offsets.nose_radius:.3f}")

    def offsets(self, tools: list[ToolSheet], diameter_mode: bool,
                measured: dict[int, Measured] | None = None) -> str:
        measured = measured or {}
        lines = ["%_N_TO_INI", "; lathe-mirror tool data: per tool its name, type, cutting edge position 9 "
                 "(the nose centre), lengths 1 (X) and 2 (Z) to touch off, nose radius"]
        for t in tools:
            m = measured.get(t.station) or Measured()
            s = t.station
            lines += [f"; {t.label}", f'$TC_TP2[{s}]="{tool_name(t)}"',
                      f"$TC_DP1[{s},1]={TOOL_TYPES.get(role_word(t.role).lower(), 500)}",
                      f"$TC_DP2[{s},1]=9",
                      f"$TC_DP3[{s},1]={0 if m.x is None else fixed(m.x, 4)}",
                      f"$TC_DP4[{s},1]={0 if m.z is None else fixed(m.z, 4)}",
                      f"$TC_DP6[{s},1]={fixed(t.offsets.nose_radius, 4)}"]
        lines.append("M17")
        return "\n".join(lines) + "\n"


def tool_name(tool: ToolSheet) -> str:
    """The name the program calls the tool by (T="..."): its station's, T<station>."""
    return f"T{tool.station}"


def role_word(role: str) -> str:
    """A role's first word, upper case ("finishing, a fresh edge" -> FINISHING)."""
    m = re.match(r"[A-Za-z]+", role)
    return m.group(0).upper() if m else "TOOL"


register(Siemens())
