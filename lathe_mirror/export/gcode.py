"""G-code for the lathe: a program (shop.program.Program) written in a control's dialect,
and the tool table or offset list beside it.

This module only writes: the program is planned and simulated in lathe_mirror.shop, and
each control's words are its dialect's (export/dialects: LinuxCNC, Fanuc, Siemens 840D; a
dialect is one module there). Every number is written fixed-point within the controller's
word format (export.dialects.base); a program a control would reject is never written:
lathe.Lathe refuses speeds and feeds outside their words' formats when the settings are
read, the planner a program of more blocks than an N word carries, the writer a coordinate
of more digits.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from .dialects import Dialect, Measured, dialect, dialects
from .files import write_text
from .setup_sheet import setup_sheet_html

if TYPE_CHECKING:
    from ..shop.program import Program
    from ..shop.setup import ToolSheet


def format_program(program: Program, dialect_: Dialect | str = "linuxcnc") -> str:
    """The program as text in a dialect (an export.dialects.Dialect or its name). Raises
    InputError if a coordinate word would carry more digits than the controller's format."""
    return dialect(dialect_).format(program)


def write_program(path: str | Path, program: Program, dialect_: Dialect | str = "linuxcnc") -> Path:
    """Write the program atomically (nothing is written if it is refused)."""
    return write_text(path, format_program(program, dialect_))


def offset_table(tools: list[ToolSheet], dialect_: Dialect | str = "linuxcnc", *, diameter_mode: bool = True,
                 measured: dict[int, Measured] | None = None) -> tuple[str, str]:
    """(file name, text) of the tool table (LinuxCNC tools.tbl), offset list (Fanuc's G10
    program) or tool data (Siemens' tools.ini) of these tools (shop.setup.ToolSheet: the
    set-up sheet's `tools`, one per station), in the dialect's own form. measured: {station:
    export.dialects.Measured(x, z)} the touched-off offsets to write (mm; the program's X
    convention), where known; the nose radius is each ToolSheet's offsets.nose_radius."""
    d = dialect(dialect_)
    return d.offsets_file, d.offsets(list(tools), diameter_mode, measured)


def write_offset_table(directory: str | Path, tools: list[ToolSheet], dialect_: Dialect | str = "linuxcnc", *,
                       diameter_mode: bool = True, measured: dict[int, Measured] | None = None) -> Path:
    """Write offset_table(...) into `directory` under the dialect's file name (atomically)."""
    name, text = offset_table(tools, dialect_, diameter_mode=diameter_mode, measured=measured)
    return write_text(Path(directory) / name, text)


def sheet_tools(shops) -> list[ToolSheet]:
    """Every tool of the programs' set-up sheets (both set-ups), one per station in station
    order; RuntimeError if two programs put different tools on one station."""
    by_station: dict[int, ToolSheet] = {}
    for shop in shops:
        sheet = shop.sheet
        tools = list(sheet.tools) + (list(sheet.second.tools) if sheet.second is not None else [])
        for t in tools:
            known = by_station.setdefault(t.station, t)
            if known.offsets.nose_radius != t.offsets.nose_radius:
                raise RuntimeError(f"station {t.station} holds two different tools in one directory")
    return [by_station[k] for k in sorted(by_station)]


def program_files(shops, which: tuple[Dialect | str, ...] | None = None) -> dict[str, str]:
    """{file name: content} of checked programs (shop.programs.ShopProgram): each in every
    dialect (default: every registered one), mirror_<strategy>.<extension>, its second
    set-up's program (the back and the mount), mirror_<strategy>_op2.<extension>, when it
    parts off, the set-up sheet of both, .setup.html, and each dialect's tool table or
    offset list of every program's tools (tools.tbl beside the LinuxCNC programs)."""
    out: dict[str, str] = {}
    chosen = dialects() if which is None else tuple(dialect(d) for d in which)
    shops = list(shops)
    for shop in shops:
        for prog in (shop.program, shop.second):
            if prog is None:
                continue
            for d in chosen:
                out[f"{prog.name}.{d.extension}"] = d.format(prog)
        out[f"{shop.program.name}.setup.html"] = setup_sheet_html(shop.sheet)
    if shops:
        tools = sheet_tools(shops)
        diameter_mode = shops[0].program.toolpath.lathe.diameter_mode
        for d in chosen:
            out[d.offsets_file] = d.offsets(tools, diameter_mode)
    return out
