"""A design as a configuration file every command takes with --config (TOML).

`design_toml` writes the camera and the two lobes (settings.dump.design_config: the keys
the configuration gives them, r_top, r_pixel and the lobe's one shape key, floats written
at 12 significant digits), then any other sections handed to it (the user's own
configuration, passed through), with comment lines on top. tomllib only reads TOML; the
writer here covers what a lathe-mirror configuration holds: tables, arrays of tables,
strings, booleans, integers, finite floats and arrays of those.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from ..design import Camera, LobeSpec
from ..settings.dump import design_config
from .files import toml_text, write_text


def design_toml(camera: Camera, lobes: tuple[LobeSpec, LobeSpec], *, comments: list[str] | None = None,
                extra: dict[str, Any] | None = None) -> str:
    """The TOML text: `comments` (one "# " line each), [camera], [lobes.inner],
    [lobes.outer], then the sections of `extra` (not camera or lobes)."""
    doc = design_config(camera, lobes)
    for key, value in (extra or {}).items():
        if key not in doc:
            doc[key] = value
    return toml_text(doc, comments or ())


def write_design_toml(path: str | Path, text: str) -> Path:
    """Write the TOML atomically (export.files: a temp name, then renamed)."""
    return write_text(path, text)
