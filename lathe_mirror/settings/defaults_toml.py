"""The embedded default configuration files (lathe_mirror/data/*.toml) as text, generated
from the declaration (settings.keys): each key with its default, its help and what it
allows as a comment. `scripts/gen-keys` writes them (and the README key table); a test fails when a file differs.
"""

from __future__ import annotations

import json
import textwrap
from typing import Any

from ..declared import Key
from .keys import KEYS

#: Each data file: its header comment and the sections it holds, in order.
FILES: dict[str, tuple[str, tuple[str, ...]]] = {
    'cad.toml': (
        (
            '# CAD of the mirror: the mounting body around the turned face, and the\n'
            '# export settings. Machine frame: the axis along Z, the vertex at Z = 0, the part in -Z.\n'
            '# Lengths in mm.\n'
        ),
        ('cad',)),
    'compute.toml': (
        (
            "# Where the heavy work runs: the Monte Carlo trials and the optimiser's evaluations.\n"
        ),
        ('compute',)),
    'machine.toml': (
        (
            '# The CNC lathe, its tool and the stock. Lengths in mm, angles in degrees.\n'
            "# The paper's lathe holds about 528 coordinates at 0.005 mm resolution (section 6).\n"
        ),
        ('machine', 'machine.errors', 'tool', 'stock', 'toolpath')),
    'optimize.toml': (
        (
            '# The design optimiser (`lathe-mirror optimize`). It keeps the [camera] fixed,\n'
            "# searches both lobes' r_top, r_pixel and alpha, and maximises the objective under the\n"
            "# constraints below. Every default keeps the paper's design feasible, so on the paper's\n"
            '# camera the winner is never worse than the paper (it starts from the [lobes] given).\n'
            '# Lengths in mm from the pinhole (the camera frame), angles in degrees, image radii in px.\n'
            "# The lathe's constraints are the other sections': [tool] (the nose reaches the step wall,\n"
            '# the flanks clear the profile, whichever lobe is recessed), [stock] diameter and length,\n'
            '# [toolpath] clearance and [cad] thickness / min_wall (the bar and the body hold it).\n'
        ),
        ('optimize', 'optimize.search')),
    'paper.toml': (
        (
            "# The paper's mirror (de Souza & Motta, Table 1): the embedded default design.\n"
            '# Lengths in mm, image radii in px, angles in degrees.\n'
            '#\n'
            "# Table 1's R_pixel column is swapped: h of mirror 01 (the inner lobe, R_top = 20 mm)\n"
            '# follows from R_pixel = 307.555 px, h of mirror 02 (the outer lobe, R_top = 35 mm) from\n'
            "# R_pixel = 504 px (the sensor's inscribed circle). We use the consistent pair.\n"
            '#\n'
            "# Each lobe takes r_top and r_pixel plus exactly one of alpha_deg (the rim's angle above\n"
            "# the lobe focus's horizon, as Table 1 prints it), a_over_b, or e (mm).\n"
        ),
        ('camera', 'lobes.inner', 'lobes.outer')),
    'polish.toml': (
        (
            '# Polishing of the turned aluminium mirror (lathe_mirror/polishing.py), the objective that\n'
            '# chooses its time (optics/polishing_curve.py) and the surface finish (finish.py,\n'
            '# optics/scatter.py). Defaults are typical for alumina polishing of aluminium on a\n'
            '# polyurethane pad; override any of them in your --config.\n'
        ),
        ('polish',)),
    'scene.toml': (
        (
            "# The paper's simulated room (section 6, Fig. 11) and how `lathe-mirror render` draws it.\n"
            '# Camera frame (ARCHITECTURE.md): pinhole at the origin, +z up the mirror axis, mm.\n'
            '# A square room with a floor of black and white squares, walls of black-and-red\n'
            '# (x walls) and black-and-green (y walls) squares, three blue boxes on the floor, and the\n'
            "# camera and mirror at a small robot's height. Colours are linear RGB in 0..1.\n"
        ),
        ('scene', 'render', 'camera_pose')),
    'stereo.toml': (
        (
            '# `lathe-mirror stereo`: range from one image, matching the two lobes along their radial\n'
            '# epipolar lines (optics/ranging). Pixels of the panoramas are px, angles degrees, ranges m.\n'
        ),
        ('stereo',)),
    'tolerance.toml': (
        (
            '# Tolerance analysis (lathe_mirror/tolerance/): the spec a mirror must meet, the\n'
            '# tolerances of the machine, the polishing and the assembly, the Monte Carlo settings and\n'
            '# what tightening each tolerance costs (for the allocation).\n'
        ),
        ('tolerance', 'tolerance.spec', 'tolerance.params', 'tolerance.machine_errors', 'tolerance.cost')),
}

#: A comment on a section's header line.
SECTION_NOTES = {
    "lobes.inner": "Table 1, mirror 01",
    "lobes.outer": "Table 1, mirror 02",
    "machine.errors": "the lathe's set-up errors a simulated part is cut with (0: a perfect machine)",
    "camera_pose": "misalignment of the camera against the mirror axis",
    "tolerance.spec": "a made mirror passes when every figure is within its limit",
    "tolerance.params": "tolerance of each parameter about its nominal (config) value",
    "tolerance.machine_errors": "tolerance of each [machine.errors] set-up error about its configured value "
                                "(like [tolerance.params]: a 3-sigma bound under \"normal\", +/- under \"uniform\")",
    "tolerance.cost": "relative cost of holding each tolerance at its value above; holding it k times tighter "
                      "costs k times as much (the allocation minimises the sum)",
    "optimize.search": "ranges searched [low, high]; low == high fixes that parameter",
}
#: Column of the comments, and the width they wrap at.
COMMENT_AT = 28
WIDTH = 100


def value_text(v: Any) -> str:
    """A value as TOML writes it (floats round-trip: repr)."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, float)):
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(value_text(x) for x in v) + "]"
    raise TypeError(f"no TOML text for {v!r}")


def _comment(text: str) -> list[str]:
    return textwrap.wrap(text, WIDTH - COMMENT_AT - 2, break_on_hyphens=False) or [""]


def _line(left: str, comment: str) -> list[str]:
    """`left` with the comment beside it at COMMENT_AT, wrapped onto aligned comment lines."""
    if not comment:
        return [left]
    parts = _comment(comment)
    pad = max(COMMENT_AT - len(left), 1)
    out = [f"{left}{' ' * pad}# {parts[0]}"]
    col = len(left) + pad
    out += [f"{' ' * col}#   {p}" for p in parts[1:]]
    return out


def _key_comment(k: Key) -> str:
    allowed = k.text()
    note = k.note()
    tail = f"allowed {allowed}" + (f" ({note})" if note else "") if allowed else note
    return "; ".join(p for p in (k.help, tail) if p)


def _section_of(k: Key) -> str:
    name = k.name[:-2] if k.name.endswith(".*") else k.name  # a table of tables sits in its parent
    return name.rsplit(".", 1)[0]


def default_toml(filename: str) -> str:
    """The text of data/<filename>: its header, then each of its sections' declared keys
    with their defaults and comments (tables of tables and lists of tables written out)."""
    header, sections = FILES[filename]
    lines = header.rstrip("\n").split("\n")
    for section in sections:
        keys = [k for k in KEYS if _section_of(k) == section and k.default is not None and "[]" not in k.name]
        if not keys and section not in ("tolerance.cost",):
            continue
        lines.append("")
        lines += _line(f"[{section}]", SECTION_NOTES.get(section, ""))
        tables = []
        for k in keys:
            if isinstance(k.default, dict):  # a table of tables: polish.process.*
                tables.append(k)
            elif isinstance(k.default, list) and k.default and isinstance(k.default[0], dict):
                tables.append(k)
            else:
                lines += _line(f"{k.name.rsplit('.', 1)[1]} = {value_text(k.default)}", _key_comment(k))
        for k in tables:
            lines += _table_lines(k)
    return "\n".join(lines) + "\n"


def _table_lines(k: Key) -> list[str]:
    out: list[str] = [""]
    out += [f"# {p}" for p in _comment_wide(f"{k.name}: {_key_comment(k)}")]
    if isinstance(k.default, dict):
        items = [(f"[{k.name[:-2]}.{name}]", entry) for name, entry in k.default.items()]
    else:
        items = [(f"[[{k.name}]]", entry) for entry in k.default]
    for head, entry in items:
        out.append(head)
        for name, v in entry.items():
            sub = next((x for x in KEYS if x.name in (f"{k.name}[].{name}",)), None)
            out += _line(f"{name} = {value_text(v)}", _key_comment(sub) if sub else "")
        out.append("")
    return out[:-1]


def _comment_wide(text: str) -> list[str]:
    return textwrap.wrap(text, WIDTH - 2, break_on_hyphens=False)


def default_files() -> dict[str, str]:
    """{file name: text} of every data file."""
    return {name: default_toml(name) for name in FILES}
