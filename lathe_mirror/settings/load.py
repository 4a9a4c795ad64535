"""Settings from a merged configuration dict: each TOML section turned into its typed
object, every value checked (ranges, choices, the design, the costs).

`config.load()` merges the user's TOML over the embedded defaults and checks every key's
name and type; `from_config` here builds the typed Settings and checks every value. Each
section is built from its dataclass's declared fields (declared.section: a field names its
key, its unit conversion and its default), so this module knows no key by name. Each
rejection is one InputError line naming the key and what is allowed, and all of it happens
before any command does work or writes a file.
"""

from __future__ import annotations

from typing import Any

from ..declared.section import build
from ..design import LobeSpec
from .keys import check_ranges
from .model import Settings

#: The lobes, inner first.
LOBES = ("inner", "outer")


def from_config(cfg: dict[str, Any]) -> Settings:
    """Settings from a merged, key-checked configuration dict (config.load does both).

    Every key is held to its declared range first (settings.keys), then each section is
    built from its declared fields (a named choice parsed: its message lists the names),
    then Settings validates the whole (settings.validate: the cross-key rules, the
    design, the room, the costs).
    """
    check_ranges(cfg)  # every key within its declared range, before any section is built
    lobes = tuple(build(LobeSpec, cfg, star=name, name=name) for name in LOBES)
    return build(Settings, cfg, lobes=lobes)  # Settings.__post_init__ runs settings.validate
