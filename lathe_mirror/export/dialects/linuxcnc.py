"""LinuxCNC (rs274ngc, checked with its `rs274` interpreter): `%`, the header comments,
`G18 G7 G21 G90 G40 G49 G94 G54`, `G91.1` (I, K relative to the arc's start), `G64 P.. Q..`
(the path tolerance, toolpath.path_tolerance_mm), then per operation `T1 M6 G43`,
`G96 D.. S.. M3`, `G95`, `M8`, `F..` and its moves; `M9`, the way home, `M5`, `M1` before
the finishing tool, `M0` before the part-off; `M30`, `%`. The tool table is tools.tbl
(`T1 P1 X0 Z0 D0.4 Q9 ;...`), which `rs274 -t tools.tbl -g PROGRAM` and LinuxCNC load.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from . import register
from .base import Dialect, Measured, fixed

if TYPE_CHECKING:
    from ...shop.program import Program
    from ...shop.setup import ToolSheet


class LinuxCNC(Dialect):
    name = "linuxcnc"
    label = "LinuxCNC"
    extension = "ngc"
    offsets_file = "tools.tbl"
    letters = frozenset("GMNTSDFXZIKHPQ")  # D: G96's spindle cap; P, Q: G64's tolerances; H: G43

    def preamble(self, program: Program) -> list[str]:
        lathe, tol = program.toolpath.lathe, program.options.path_tolerance_mm
        # path blending within the tolerance (P) and collinear merging within it (Q):
        # without it LinuxCNC blends the short arcs freely
        return ["G18 " + ("G7" if lathe.diameter_mode else "G8") + " G21 G90 G40 G49 G94 G54",
                "G91.1", f"G64 P{fixed(tol, 4)} Q{fixed(tol, 4)}"]

    def tool_call(self, station: int, role: str) -> list[str]:
        return [f"T{station} M6 G43"]

    def spindle_on(self, surface_speed: float, max_rpm: int, clockwise: bool) -> list[str]:
        return [f"G96 D{max_rpm} S{int(surface_speed)} {'M3' if clockwise else 'M4'}", "G95"]

    def spindle_rpm(self, rpm: int, clockwise: bool) -> list[str]:
        return [f"G97 S{rpm} {'M3' if clockwise else 'M4'}", "G95"]

    def tip_code(self, tool: ToolSheet) -> str:
        return f"orientation Q{9 if tool.offsets.nose_radius > 0 else 0}"

    def offset_entry(self, tool: ToolSheet, diameter_mode: bool) -> str:
        return table_line(tool, None)

    def offsets(self, tools: list[ToolSheet], diameter_mode: bool,
                measured: dict[int, Measured] | None = None) -> str:
        measured = measured or {}
        return "".join(table_line(t, measured.get(t.station)) + "\n" for t in tools)


def table_line(tool: ToolSheet, m: Measured | None) -> str:
    """A tools.tbl line: the X and Z offsets (touched off; 0 until they are), the nose's
    diameter D and orientation Q (9: the nose centre is the controlled point; 0 for a sharp
    corner such as the parting blade's)."""
    rho = tool.offsets.nose_radius
    x = "0" if m is None or m.x is None else f"{m.x:.4f}"
    z = "0" if m is None or m.z is None else f"{m.z:.4f}"
    q = 9 if rho > 0 else 0
    return f"T{tool.station} P{tool.station} X{x} Z{z} D{2 * rho:.3f} Q{q} ;{tool.label}"


register(LinuxCNC())
