"""The controls' dialects: one module per control, each a Dialect (base.py) registered by
name. The writer (export.gcode), the set-up sheet (export.setup_sheet) and the replay
(shop.replay, handed the dialect as its reader) iterate the registry, so a control of its
own is one new module here (found and imported by the package) and nothing else.

- base.py      Dialect, Writer: the shared words, header and block walk
- linuxcnc.py  LinuxCNC (rs274ngc): .ngc, G7 / G8, G96 D.. S.., T1 M6 G43, tools.tbl
- fanuc.py     Fanuc-style lathe: .nc, O number, G50 S.., T0101, the G10 offset program
- siemens.py   Siemens SINUMERIK 840D: .mpf, DIAMON, LIMS=, T="..." D1, the $TC_DP tool data
"""

from __future__ import annotations

import importlib
import pkgutil

from ...errors import InputError
from .base import Dialect, Measured

#: Every registered dialect by name, in the order registered (linuxcnc first).
DIALECTS: dict[str, Dialect] = {}


def register(dialect: Dialect) -> Dialect:
    """Add `dialect` to the registry (by its name, which must be new) and return it."""
    if not dialect.name or dialect.name in DIALECTS:
        raise RuntimeError(f"dialect {dialect.name!r}: a new, non-empty name is needed")
    DIALECTS[dialect.name] = dialect
    return dialect


def unregister(name: str) -> None:
    """Remove a dialect (a test's own) from the registry."""
    DIALECTS.pop(name, None)


def dialect(name: str | Dialect, what: str = "--dialect") -> Dialect:
    """The registered dialect of that name; InputError naming `what` and the names allowed."""
    if isinstance(name, Dialect):
        return name
    key = str(name).strip().lower()
    if key not in DIALECTS:
        raise InputError(f"{what} {name!r}: allowed {', '.join(DIALECTS)}")
    return DIALECTS[key]


def dialects() -> tuple[Dialect, ...]:
    """The registered dialects in order."""
    return tuple(DIALECTS.values())


def for_file(path: str, text: str, default: str = "linuxcnc") -> Dialect:
    """The dialect a program is written in: the one that owns its first lines, else the one
    of its file suffix, else `default`."""
    for d in DIALECTS.values():
        if d.owns(text[:2000]):
            return d
    suffix = str(path).rsplit(".", 1)[-1].lower() if "." in str(path) else ""
    return next((d for d in DIALECTS.values() if d.extension == suffix), DIALECTS[default])


_ORDER = ("linuxcnc", "fanuc", "siemens")  # the shipped ones first, in this order
for _name in sorted((m.name for m in pkgutil.iter_modules(__path__) if m.name != "base"),
                    key=lambda n: (_ORDER.index(n) if n in _ORDER else len(_ORDER), n)):
    importlib.import_module(f"{__name__}.{_name}")

__all__ = ["DIALECTS", "Dialect", "Measured", "dialect", "dialects", "for_file", "register", "unregister"]
