"""A design as a configuration file every command takes with --config (TOML).

`design_toml` writes the camera and the two lobes (settings.dump.design_config: the keys
the configuration gives them, r_top, r_pixel and the lobe's one shape key, floats written
at 12 significant digits), then any other sections handed to it (the user's own
configuration, passed through), with comment lines on top. tomllib only reads TOML; the
writer here covers what a lathe-mirror configuration holds: tables, arrays of tables,
strings, booleans, integers, finite floats and arrays of those.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

from ..design import Camera, LobeSpec
from ..settings.dump import design_config
from .files import write_text
from .numbers import fmt_sig


def design_toml(camera: Camera, lobes: tuple[LobeSpec, LobeSpec], *, comments: list[str] | None = None,
                extra: dict[str, Any] | None = None) -> str:
    """The TOML text: `comments` (one "# " line each), [camera], [lobes.inner],
    [lobes.outer], then the sections of `extra` (not camera or lobes)."""
    lines = [f"# {c}" for c in comments or ()]
    doc = design_config(camera, lobes)
    for key, value in (extra or {}).items():
        if key not in doc:
            doc[key] = value
    if lines:
        lines.append("")
    lines += _table(doc, [])
    return "\n".join(lines).rstrip("\n") + "\n"


def write_design_toml(path: str | Path, text: str) -> Path:
    """Write the TOML atomically (export.files: a temp name, then renamed)."""
    return write_text(path, text)


def _table(table: dict[str, Any], path: list[str]) -> list[str]:
    out: list[str] = []
    scalars = {k: v for k, v in table.items() if not _is_table(v) and not _is_table_array(v)}
    if scalars and path:
        out.append(f"[{'.'.join(_key(p) for p in path)}]")
    for k, v in scalars.items():
        out.append(f"{_key(k)} = {_value(v)}")
    if scalars and path:
        out.append("")
    for k, v in table.items():
        if _is_table(v):
            out += _table(v, path + [k])
        elif _is_table_array(v):
            for item in v:
                out.append(f"[[{'.'.join(_key(p) for p in path + [k])}]]")
                out += [f"{_key(ik)} = {_value(iv)}" for ik, iv in item.items()
                        if not _is_table(iv) and not _is_table_array(iv)]
                out.append("")
                out += _table({ik: iv for ik, iv in item.items() if _is_table(iv) or _is_table_array(iv)},
                              path + [k])
    return out


def _is_table(v: Any) -> bool:
    return isinstance(v, dict)


def _is_table_array(v: Any) -> bool:
    return isinstance(v, list) and bool(v) and all(isinstance(x, dict) for x in v)


def _key(k: str) -> str:
    if k and all(c.isalnum() or c in "_-" for c in k):
        return k
    return json.dumps(k)


def _value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if not math.isfinite(v):
            raise ValueError(f"a TOML configuration holds finite numbers only, got {v!r}")
        return fmt_sig(v)  # 12 significant digits (export.numbers)
    if isinstance(v, str):
        return json.dumps(v, ensure_ascii=False)
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_value(x) for x in v) + "]"
    raise TypeError(f"cannot write {type(v).__name__} {v!r} as TOML")
