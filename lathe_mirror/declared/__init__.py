"""Every configuration key, declared once (Key: type, unit, default, range, open or closed
ends, why, help), below every module that holds a setting: the settings package checks a
configuration against these declarations, and the typed sections built in Python (Lathe,
Tool, PolishParams, BodySpec, ToolpathSettings, OptimizeSettings, ...) check their fields
against the same ones on construction (`check`), so `dataclasses.replace(settings.polish,
overhang=2.0)` refuses with the line the configuration file gets.

`declared.section` (imported on its own, below this package's names): a section's field
that names its key (`setting`), from which its default, its load and its dump come.

KEYS: every key in the README table's order (`lobes.*.` stands for each lobe,
`scene.boxes[].` for each box, `polish.process.*` for each process preset). RANGES: each by
its dotted name. `key(name)`: the declaration of a concrete dotted name.
"""

from __future__ import annotations

import math
from typing import Any

from ..errors import ConfigError
from .key import Key
from .keys_design import KEYS as DESIGN_KEYS
from .keys_machine import KEYS as MACHINE_KEYS
from .keys_optics import KEYS as OPTICS_KEYS
from .keys_optimize import KEYS as OPTIMIZE_KEYS
from .keys_polish import KEYS as POLISH_KEYS
from .keys_tolerance import KEYS as TOLERANCE_KEYS

#: Every key of the configuration, in the README table's order.
KEYS: tuple[Key, ...] = (DESIGN_KEYS + MACHINE_KEYS + POLISH_KEYS + OPTICS_KEYS
                         + TOLERANCE_KEYS + OPTIMIZE_KEYS)

#: Each key by its dotted name.
RANGES: dict[str, Key] = {k.name: k for k in KEYS}

#: Relative slack of a range check on values converted back to the file's units (radians
#: to degrees and back move the last bit; a documented end must stay accepted).
SLACK = 1e-9


def key(name: str) -> Key:
    """The declared key of a dotted name (`lobes.inner.r_top` finds `lobes.*.r_top`)."""
    if name in RANGES:
        return RANGES[name]
    parts = name.split(".")
    for pattern, k in RANGES.items():
        p = pattern.split(".")
        if len(p) == len(parts) and all(a == b or a == "*" for a, b in zip(p, parts)):
            return k
    raise KeyError(name)


def check(name: str, value: Any, *, where: str | None = None, slack: float = 0.0) -> None:
    """ConfigError, the one line `load()` gives for the configuration file's key `name`,
    unless `value` (in the file's unit) fits the key's declaration: a number within its
    range (finite; a whole one for an integer key), a name among its choices. where: the
    input the line names (default the key; a flag that sets it). `slack`: Key.allows
    (values converted back to the file's units: SLACK)."""
    k = key(name)
    where = name if where is None else where
    if k.numeric and not isinstance(value, (list, tuple)):
        whole = k.type == "int"
        if (isinstance(value, bool) or not isinstance(value, (int, float))
                or (isinstance(value, float) and (not math.isfinite(value) or (whole and not value.is_integer())))):
            raise ConfigError(k.refusal(where, value))
    k.check(where, value, slack)


__all__ = ["KEYS", "RANGES", "SLACK", "Key", "check", "key"]
