"""Every configuration key, declared once: KEYS (declared.Key, gathered by lathe_mirror.declared
from its keys_* modules, one per group of sections) and what comes from it.

- the check of a merged configuration dict (check_ranges: each value against its key's
  range, one ConfigError line naming the key and what is allowed),
- the README's "Ranges of every key" table (key_table_markdown; a test fails when the
  README's table differs) and the reference table with the help text
  (reference_table_markdown, for the docs),
- the `--help` text of a flag that sets a key (help_default),
- the embedded defaults (declared_defaults; config.default_config is it, and
  lathe_mirror/data/*.toml are generated from it: settings.defaults_toml).

To add or change a key: declare it (or edit it) in lathe_mirror/declared/keys_* for its
section, give it a field in the section's dataclass that names it
(`declared.section.setting("section.key", conversion)`: its default, load and dump come
from that line), then run scripts/gen-keys (README table, data/*.toml). Editing data/*.toml
by hand changes nothing: the defaults are the declaration's, and a test says so.

A key's own range is checked here; a limit that other keys move (the design, the cost
estimates, a section's cross-key rule) is declared on the key (`depends`) and checked where
the other keys are known (design_checks, costs, the typed sections), its message naming
the key.
"""

from __future__ import annotations

from typing import Any

from ..declared import KEYS, RANGES, Key, key
from ..declared.section import defaults

#: Largest rim height above the camera h (mm) a design may have, and the smallest.
H_RANGE = (0.1, 10_000.0)
#: Vertex radius of curvature b^2 / a (mm) a lobe may have: a flatter lobe is a plane,
#: whose "arcs" have centres kilometres away (coordinates no controller word holds); a
#: sharper one is a cone's tip no lattice or nose resolves (and near it the closed form
#: loses the rim to rounding: e = 1e-6 mm).
MIN_VERTEX_RADIUS = 0.01
MAX_VERTEX_RADIUS = 10_000.0
#: Most roughing levels (Z passes) one program may have: ~100 bytes of G-code each.
MAX_ROUGH_LEVELS = 20_000

#: A declared key's other name (its `text()`, `why` and `allows()` are a range's).
Range = Key

__all__ = ["H_RANGE", "KEYS", "MAX_ROUGH_LEVELS", "MAX_VERTEX_RADIUS", "MIN_VERTEX_RADIUS", "RANGES", "Range",
           "check_ranges", "declared_defaults", "find", "help_default", "key", "key_table_markdown",
           "reference_table_markdown"]


def check_ranges(cfg: dict[str, Any], slack: float = 0.0) -> None:
    """ConfigError (one line: the key, its value, the allowed range) for the first value of
    the merged configuration outside its declared range (`slack`: Key.allows)."""
    for k in KEYS:
        for where, value in find(cfg, k.name.split("."), ""):
            if isinstance(value, dict) and k.type != "table":
                continue
            k.check(where, value, slack)


def find(node: Any, parts: list[str], prefix: str):
    """(dotted key, value) of every entry of the config that a declared name matches."""
    if not parts:
        yield prefix.rstrip("."), node
        return
    head, rest = parts[0], parts[1:]
    if not isinstance(node, dict):
        return
    if head == "*":
        for k in node:
            yield from find(node[k], rest, f"{prefix}{k}.")
    elif head.endswith("[]"):
        name = head[:-2]
        for i, item in enumerate(node.get(name, []) or []):
            yield from find(item, rest, f"{prefix}{name}[{i}].")
    elif head in node:
        yield from find(node[head], rest, f"{prefix}{head}.")


def key_table_markdown() -> str:
    """The README's "Ranges of every key" table as Markdown: one row per declared key, in
    declaration order, with its default, what it allows (range, unit, open or closed ends)
    and the note (why the limit; what else bounds it). `lobes.` stands for each lobe."""
    rows = ["| key | default | allowed | note |", "|---|---|---|---|"]
    rows += [k.row() for k in KEYS]
    return "\n".join(rows) + "\n"


def reference_table_markdown() -> str:
    """Every declared key as a Markdown table with its help text: key, default, allowed,
    what it is, note. Public for the documentation's reference page."""
    rows = ["| key | default | allowed | what it is | note |", "|---|---|---|---|---|"]
    rows += [k.help_row() for k in KEYS]
    return "\n".join(rows) + "\n"


def help_default(name: str) -> str:
    """A flag's `--help` text for the key it sets: "machine.max_points, default 528"."""
    return key(name).help_default()


def declared_defaults() -> dict[str, Any]:
    """The declared defaults as a nested configuration dict (declared.section.defaults:
    keys without a default, such as a lobe's a_over_b, and the entries of a list of
    tables are left out)."""
    return defaults()
