"""Configuration: TOML files merged over the embedded defaults, validated key by key.

`load()` is the entry point: it returns the typed, frozen `settings.Settings`. The dict
functions below (load_config, merge, set_value) check names and types only; settings/
checks the values and builds the typed sections.

The defaults are the declared keys' (lathe_mirror/declared/keys_*.py; `lathe_mirror/data/*.toml` show
them, generated with each key's help and range: `paper.toml` holds the paper's design). A
user's file may override any part of them; it may not add keys the defaults do not have (except the exclusive design
choices below), change a value's type, or give a non-finite number. Every rejection is a
ConfigError whose one line names the key and what is allowed.
"""

from __future__ import annotations

import copy
import difflib
import math
import os
import tomllib
from pathlib import Path
from typing import TYPE_CHECKING, Any

from .declared.section import build
from .design import Camera, LobeSpec, mirror_from_specs
from .errors import ConfigError, InputError
from .inputs import STDIN, read_text, short
from .settings import from_config
from .settings.keys import declared_defaults
from .tolerance.shops import apply_shop

if TYPE_CHECKING:
    from .settings import Settings

#: Largest configuration file read (bytes): every input is bounded.
MAX_CONFIG_BYTES = 1 << 20

#: Keys of which a section takes exactly one; a user's section that names any of them
#: replaces the default's choice instead of adding to it.
EXCLUSIVE_KEYS: dict[str, tuple[str, ...]] = {
    "lobes.inner": ("alpha_deg", "a_over_b", "e"),
    "lobes.outer": ("alpha_deg", "a_over_b", "e"),
}


def default_config() -> dict[str, Any]:
    """The embedded defaults: every declared key's default (settings.keys, the one
    declaration; lathe_mirror/data/*.toml are generated from it, with each key's help and
    range as comments, and a test holds them equal)."""
    return declared_defaults()


def load(path: str | Path | None = None, *,
         overrides: list[tuple[str, Any, str]] | dict[str, Any] | None = None) -> Settings:
    """The Settings of a configuration: the defaults, the user's TOML file (if any) merged
    over them, then `overrides` ((dotted key, value) or (dotted key, value, source: e.g. a
    command-line flag) items, or a dict {dotted key: value}), every key and value checked
    once (one ConfigError / InputError line naming the key)."""
    if path is not None and not isinstance(path, (str, os.PathLike)):
        raise InputError(f"load: path = {short(path)} ({type(path).__name__}): expected a TOML file's path or None")
    overrides = _overrides(overrides)
    cfg, given = _load_config(path)
    for dotted, value, source in overrides:
        set_value(cfg, dotted, value, source=source)
        given.add(dotted)
    follow_stock(cfg, given)
    try:
        return from_config(cfg)
    except InputError as exc:
        # A flag's value refused under its key's name: say which flag set it.
        text = str(exc)
        for dotted, _, source in overrides or ():
            if f"{dotted} =" in text and source not in text:
                raise type(exc)(f"{source}: {text}") from None
        raise


def _overrides(overrides) -> list[tuple[str, Any, str]]:
    """load's overrides as (key, value, source) items; a source defaults to "overrides"."""
    if overrides is None:
        return []
    items = list(overrides.items()) if isinstance(overrides, dict) else overrides
    if isinstance(items, (str, bytes)) or not isinstance(items, (list, tuple)):
        raise InputError(f"load: overrides = {short(overrides)}: expected a list of (key, value) items or a dict")
    out = []
    for item in items:
        if not (isinstance(item, (tuple, list)) and len(item) in (2, 3) and isinstance(item[0], str)):
            raise InputError(f"load: overrides item {short(item)}: expected (key, value) or (key, value, source)")
        out.append((item[0], item[1], str(item[2]) if len(item) == 3 else "overrides"))
    return out


#: Environment variable naming a site configuration (e.g. the shop's machine and tools),
#: merged over the defaults and under the user's --config, with the same checks.
SITE_CONFIG_VAR = "LATHE_MIRROR_CONFIG"


def load_config(path: str | Path | None = None) -> dict[str, Any]:
    """Defaults, with the site file ($LATHE_MIRROR_CONFIG, if set) and the user's TOML file
    (if any) merged over them in that order and validated."""
    return _load_config(path)[0]


def _load_config(path: str | Path | None) -> tuple[dict[str, Any], set[str]]:
    """load_config's dict and the dotted keys the site and user files gave."""
    cfg = default_config()
    given: set[str] = set()
    site = os.environ.get(SITE_CONFIG_VAR, "")
    if site:
        table = _parse(site, f"{SITE_CONFIG_VAR}={site}")
        cfg = merge(cfg, table, source=site)
        given |= _dotted(table)
    if path is not None:
        table = _parse(path, f"--config {path}")
        cfg = merge(cfg, table, source=str(path))
        given |= _dotted(table)
    return cfg, given


def _dotted(table: dict[str, Any], prefix: str = "") -> set[str]:
    out: set[str] = set()
    for k, v in table.items():
        out |= _dotted(v, f"{prefix}{k}.") if isinstance(v, dict) else {f"{prefix}{k}"}
    return out


def follow_stock(cfg: dict[str, Any], given: set[str]) -> None:
    """The body follows the bar unless its keys are given: cad.blank_diameter is the [stock]
    diameter, and cad.thickness the declared one or, when the bar is shorter, what its
    length leaves below the part-off (stock.length less toolpath.parting_width_mm and
    toolpath.back_allowance_mm, and a boss's length) if that still holds the mirror's depth
    and cad.min_wall (else the declared one stays, and the part-off's check names
    stock.length)."""
    cad, stock, tp = cfg["cad"], cfg["stock"], cfg["toolpath"]
    if "cad.blank_diameter" not in given:
        cad["blank_diameter"] = stock["diameter"]
    if "cad.thickness" not in given:
        boss = cad["mount_depth"] if cad["mount"] == "boss" else 0.0
        room = stock["length"] - tp["parting_width_mm"] - tp["back_allowance_mm"] - boss
        if room < cad["thickness"] and room >= _face_depth(cfg) + cad["min_wall"]:
            cad["thickness"] = room


def _face_depth(cfg: dict[str, Any]) -> float:
    """The designed face's depth below its vertex (mm; inf when the design does not exist:
    from_config then says why)."""
    try:
        mirror = mirror_from_specs(build(Camera, cfg), tuple(build(LobeSpec, cfg, star=n, name=n)
                                                             for n in ("inner", "outer")))
    except (InputError, ValueError, ArithmeticError):
        return math.inf
    return float(mirror.depth)


def _parse(path: str | Path, name: str) -> dict[str, Any]:
    text = read_user_text(path, name.split(" ")[0].split("=")[0])
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{name}: not valid TOML ({exc})") from None
    except RecursionError:  # tomllib parses nested arrays and tables recursively
        raise ConfigError(f"{name}: arrays or tables nested too deeply (the "
                          "configuration nests at most 3 levels)") from None


def read_user_text(path: str | Path, what: str = "--config") -> str:
    """The text of the user's configuration file (stdin for "-", read once and kept):
    inputs.read_text, a regular file of at most MAX_CONFIG_BYTES."""
    if str(path) == STDIN:
        if STDIN not in _stdin_text:
            _stdin_text[STDIN] = read_text(path, what, MAX_CONFIG_BYTES)
        return _stdin_text[STDIN]
    return read_text(path, what, MAX_CONFIG_BYTES)


def read_user(path: str | Path) -> dict[str, Any]:
    """The user's configuration file as TOML (not merged, not validated)."""
    return tomllib.loads(read_user_text(path))


# Standard input read as a configuration (it can be read once a process).
_stdin_text: dict[str, str] = {}


def merge(base: dict[str, Any], user: dict[str, Any], *, source: str = "config") -> dict[str, Any]:
    """A copy of base with user's values merged in, validated against base's shape."""
    out = copy.deepcopy(base)
    apply_shop(out, user)  # a shop class under the same file's own tolerances
    _merge_table(out, user, prefix="", source=source)
    return out


def set_value(cfg: dict[str, Any], dotted: str, value: Any, *, source: str) -> None:
    """Set one key (e.g. from a command-line flag), validated like a file's key."""
    parts = dotted.split(".")
    user: dict[str, Any] = {}
    node = user
    for p in parts[:-1]:
        node = node.setdefault(p, {})
    node[parts[-1]] = value
    apply_shop(cfg, user)
    _merge_table(cfg, user, prefix="", source=source)


def _merge_table(base: dict[str, Any], user: dict[str, Any], prefix: str, source: str) -> None:
    exclusive = EXCLUSIVE_KEYS.get(prefix.rstrip("."), ())
    if exclusive and any(k in user for k in exclusive):
        for k in exclusive:
            base.pop(k, None)
    for key, value in user.items():
        dotted = f"{prefix}{key}"
        if key in exclusive:
            base[key] = _check_scalar(dotted, value, 0.0, source)
            continue
        if key not in base:
            allowed = sorted(set(base) | set(exclusive))
            hint = difflib.get_close_matches(key, allowed, n=1)
            did = f"; did you mean '{hint[0]}'?" if hint else ""
            raise ConfigError(
                f"{source}: unknown key '{dotted}' (allowed: {', '.join(allowed)}){did}"
            )
        default = base[key]
        if isinstance(default, dict):
            if not isinstance(value, dict):
                raise ConfigError(f"{source}: '{dotted}' must be a table [{dotted}], got {_tname(value)}")
            _merge_table(default, value, prefix=f"{dotted}.", source=source)
        elif isinstance(default, list):
            base[key] = _check_list(dotted, value, default, source)
        else:
            base[key] = _check_scalar(dotted, value, default, source)


def _check_list(dotted: str, value: Any, default: list, source: str) -> list:
    if not isinstance(value, list):
        raise ConfigError(f"{source}: '{dotted}' must be a list, got {_tname(value)}")
    if not default:
        return value
    proto = default[0]
    out = []
    for i, item in enumerate(value):
        where = f"{dotted}[{i}]"
        if isinstance(proto, dict):
            if not isinstance(item, dict):
                raise ConfigError(f"{source}: '{where}' must be a table, got {_tname(item)}")
            missing = sorted(set(proto) - set(item))
            if missing:
                raise ConfigError(f"{source}: '{where}' lacks {', '.join(missing)}")
            entry = copy.deepcopy(proto)
            _merge_table(entry, item, prefix=f"{where}.", source=source)
            out.append(entry)
        else:
            out.append(_check_scalar(where, item, proto, source))
    return out


def _check_scalar(dotted: str, value: Any, default: Any, source: str) -> Any:
    if isinstance(default, bool):
        if not isinstance(value, bool):
            raise ConfigError(f"{source}: '{dotted}' must be true or false, got {value!r}")
        return value
    if isinstance(default, float):
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ConfigError(f"{source}: '{dotted}' must be a number, got {_tname(value)} {value!r}")
        if not math.isfinite(value):
            raise ConfigError(f"{source}: '{dotted}' = {value!r} must be a finite number")
        return float(value)
    if isinstance(default, int):
        if isinstance(value, bool) or not isinstance(value, int):
            raise ConfigError(f"{source}: '{dotted}' must be an integer, got {_tname(value)} {value!r}")
        return value
    if isinstance(default, str):
        if not isinstance(value, str):
            raise ConfigError(f"{source}: '{dotted}' must be a string, got {_tname(value)} {value!r}")
        return value
    raise ConfigError(f"{source}: '{dotted}' has an unsupported type {_tname(value)}")


def _tname(value: Any) -> str:
    return {dict: "a table", list: "a list", str: "a string", bool: "a boolean",
            int: "an integer", float: "a number"}.get(type(value), type(value).__name__)
