"""A typed section built from its declared keys: each field of a section's dataclass names
its key (`setting("machine.resolution")`), and from that one line come the field's
default, its conversion between the file's units and the field's, the configuration dict
-> section (`build`) and the section -> configuration dict (`dump`). So a section built in
Python equals the one `load()` gives, and a new key is its Key plus its field.

A field's key may also be a table of keys (`setting("tolerance.params")`: the dict of
every declared key under it) or a nested section (`nested(MatchParams)`: its own fields
name their keys). `Conv` converts between the file's value and the field's (degrees and
radians, a named choice and its enum, 0 and None); without one, a list becomes a tuple.
"""

from __future__ import annotations

import copy
import dataclasses
import math
from collections.abc import Callable
from enum import Enum
from typing import Any

from ..enums import parse
from . import KEYS, RANGES, SLACK, check

#: Metadata names on a dataclass field.
KEY, CONV, NESTED = "declared_key", "declared_conv", "declared_nested"


@dataclasses.dataclass(frozen=True)
class Conv:
    """From the file's value to the field's (`load(value, where)`: where names the key in
    a message) and back (`dump`)."""

    load: Callable[[Any, str], Any]
    dump: Callable[[Any], Any]


def _plain(v: Any) -> Any:
    if isinstance(v, Enum):
        return v.value
    if isinstance(v, tuple):
        return [_plain(x) for x in v]
    if isinstance(v, dict):
        return {k: _plain(x) for k, x in v.items()}
    return v


def _tupled(v: Any, where: str = "") -> Any:
    return tuple(v) if isinstance(v, list) else v


#: A list as a tuple (the default conversion).
PLAIN = Conv(_tupled, _plain)


def _back(v: float) -> float:
    # 15 significant digits: a value the file gave comes back as written through a unit
    # conversion and its inverse (math.degrees(math.radians(3.0)) is 3.0000000000000004).
    return float(f"{v:.15g}")


#: Degrees in the file, radians in the field (a list: each).
DEGREES = Conv(lambda v, w="": tuple(math.radians(x) for x in v) if isinstance(v, list) else math.radians(v),
               lambda v: [_back(math.degrees(x)) for x in v] if isinstance(v, tuple) else _back(math.degrees(v)))
#: Micro-units in the file (urad), units in the field (rad).
MICRO = Conv(lambda v, w="": v * 1e-6, lambda v: _back(v * 1e6))
#: Metres in the file, mm in the field.
METRES = Conv(lambda v, w="": v * 1e3, lambda v: _back(v / 1e3))
#: A table of numbers: a dict of floats.
FLOATS = Conv(lambda v, w="": {k: float(x) for k, x in v.items()}, lambda v: dict(v))


def choice(enum: type[Enum], aliases: dict[str, Enum] | None = None) -> Conv:
    """A named choice (a list of them: a tuple): its enum member, the message listing the
    names (enums.parse)."""
    def load(v: Any, where: str = "") -> Any:
        if isinstance(v, list):
            return tuple(parse(enum, x, f"{where}[{i}]", aliases=aliases) for i, x in enumerate(v))
        return parse(enum, v, where, aliases=aliases)
    return Conv(load, _plain)


def zero_none(conv: Conv = PLAIN) -> Conv:
    """0 in the file ("automatic") is None in the field."""
    return Conv(lambda v, w="": None if v == 0 else conv.load(v, w), lambda v: 0 if v is None else conv.dump(v))


def flag(true: str, false: str) -> Conv:
    """A choice of two names in the file, a bool in the field."""
    return Conv(lambda v, w="": v == true, lambda v: true if v else false)


def defaults(prefix: str = "") -> dict[str, Any]:
    """The declared defaults as a nested configuration dict (a fresh copy), the whole or
    the table at `prefix` ("tolerance.params"). Keys without a default (a lobe's a_over_b)
    and the entries of a list of tables are left out."""
    out: dict[str, Any] = {}
    for k in KEYS:
        if k.default is None or "[]" in k.name:
            continue
        name = k.name[:-2] if k.name.endswith(".*") else k.name
        node = out
        parts = name.split(".")
        for p in parts[:-1]:
            node = node.setdefault(p, {})
        node[parts[-1]] = copy.deepcopy(k.default)
    return lookup(out, prefix) if prefix else out


def lookup(cfg: dict[str, Any], dotted: str) -> Any:
    """The value at a dotted name of a nested dict (KeyError if absent)."""
    node: Any = cfg
    for p in dotted.split("."):
        node = node[p]
    return node


def setting(name: str, conv: Conv = PLAIN, *, default: Any = dataclasses.MISSING,
            required: bool = False) -> Any:
    """A dataclass field holding the declared key `name` (or the table of keys under it):
    its default is the declared one converted (`default`: a field whose declared default
    varies, e.g. by lobe; `required`: none), `conv` goes between the file and the field."""
    meta = {KEY: name, CONV: conv}
    if required:
        return dataclasses.field(metadata=meta)
    if default is dataclasses.MISSING:
        value = RANGES[name].default if name in RANGES else defaults(name)
        value = conv.load(copy.deepcopy(value), name)
        if isinstance(value, (dict, list)):
            return dataclasses.field(default_factory=lambda: copy.deepcopy(value), metadata=meta)
        default = value
    return dataclasses.field(default=default, metadata=meta)


def nested(cls: type) -> Any:
    """A dataclass field holding a section whose own fields name their keys."""
    return dataclasses.field(default_factory=cls, metadata={NESTED: cls})


def build(cls: type, cfg: dict[str, Any], *, star: str = "", **given: Any) -> Any:
    """The section `cls` from a (checked) configuration dict: each field from its key
    (`star` fills a `*`, e.g. the lobe's name), each nested section likewise; `given`
    fields as passed; a key the dict lacks keeps the field's default."""
    kwargs: dict[str, Any] = {}
    for f in dataclasses.fields(cls):
        if f.name in given or not f.init:
            continue
        if NESTED in f.metadata:
            kwargs[f.name] = build(f.metadata[NESTED], cfg, star=star)
        elif KEY in f.metadata:
            name = f.metadata[KEY].replace("*", star)
            try:
                value = lookup(cfg, name)
            except (KeyError, TypeError):
                continue
            kwargs[f.name] = f.metadata[CONV].load(value, name)
    return cls(**kwargs, **given)


def dump(obj: Any, cfg: dict[str, Any] | None = None, *, star: str = "") -> dict[str, Any]:
    """The section `obj` written into the configuration dict `cfg` (a new one if None) at
    its keys, in the file's units and names (a field that dumps to None, e.g. a lobe's
    unset a_over_b: the key left out)."""
    cfg = {} if cfg is None else cfg
    for f in dataclasses.fields(obj):
        value = getattr(obj, f.name)
        if NESTED in f.metadata:
            dump(value, cfg, star=star)
        elif KEY in f.metadata:
            value = _plain(f.metadata[CONV].dump(value))
            if value is None:
                continue
            parts = f.metadata[KEY].replace("*", star).split(".")
            node = cfg
            for p in parts[:-1]:
                node = node.setdefault(p, {})
            node[parts[-1]] = value
    return cfg


def keyed(cls: type) -> dict[str, str]:
    """{field name: declared key} of a section's fields that name one (nested ones included)."""
    out: dict[str, str] = {}
    for f in dataclasses.fields(cls):
        if NESTED in f.metadata:
            out.update({f"{f.name}.{k}": v for k, v in keyed(f.metadata[NESTED]).items()})
        elif KEY in f.metadata:
            out[f.name] = f.metadata[KEY]
    return out


def check_fields(obj: Any) -> None:
    """ConfigError, the line `load()` gives, unless each field that names a key holds a
    value its declaration allows (written back in the file's units, and read again: a
    named choice must be one of its names; nested sections are their own to check)."""
    for f in dataclasses.fields(obj):
        if KEY in f.metadata and "*" not in f.metadata[KEY]:
            value = getattr(obj, f.name)
            try:
                value = _plain(f.metadata[CONV].dump(value))
            except (TypeError, ValueError):
                pass  # not a number: declared.check names the key and what it allows
            if value is not None:
                check(f.metadata[KEY], value, slack=SLACK)
                f.metadata[CONV].load(value, f.metadata[KEY])  # a named choice: one of its names


#: The most changed fields a section's repr lists (the rest counted), so it stays one short line.
REPR_FIELDS = 6


def changed(obj: Any, prefix: str = "") -> list[tuple[str, Any]]:
    """(field path, value) of each field of a section that differs from its default: a
    nested section's fields by their dotted path, a table's (dict's) entries by theirs."""
    out: list[tuple[str, Any]] = []
    for f in dataclasses.fields(obj):
        if not (f.init and f.repr):
            continue
        name, value = prefix + f.name, getattr(obj, f.name)
        if NESTED in f.metadata and dataclasses.is_dataclass(value):
            out += changed(value, name + ".")
            continue
        if f.default is not dataclasses.MISSING:
            default = f.default
        elif f.default_factory is not dataclasses.MISSING:
            default = f.default_factory()
        else:
            out.append((name, value))  # no default: always stated
            continue
        if isinstance(value, dict) and isinstance(default, dict):
            out += [(f"{name}.{k}", v) for k, v in value.items() if not _equal(default.get(k, dataclasses.MISSING), v)]
        elif not _equal(value, default):
            out.append((name, value))
    return out


def section_repr(obj: Any) -> str:
    """A section in one short line: the fields that differ from their declared defaults
    (`PolishParams(pressure_kpa=20.0)`, `Settings(camera_pose.axial_offset=1.0)`), at most
    REPR_FIELDS of them and how many more; `Name(defaults)` when none do. The full values:
    `dump(obj)` or `dataclasses.asdict(obj)`."""
    items = changed(obj)
    shown = [f"{k}={v.value!r}" if isinstance(v, Enum) else f"{k}={v!r}" for k, v in items[:REPR_FIELDS]]
    if len(items) > REPR_FIELDS:
        shown.append(f"... {len(items) - REPR_FIELDS} more")
    return f"{type(obj).__name__}({', '.join(shown) or 'defaults'})"


def _equal(a: Any, b: Any) -> bool:
    try:
        return bool(a == b)
    except (TypeError, ValueError):  # arrays: compared element-wise, no single truth
        return False
