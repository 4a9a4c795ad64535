"""One declaration per key (issue 26): every declared key's documented endpoints are
accepted with the other keys at their defaults, a value just beyond each is refused with a
message naming the key; a limit that other keys move is declared (`depends`) and its
refusal names the key; the README's table is the one the declaration generates; the
embedded defaults are the declared ones.

Fast: each case validates a configuration dict in-process (settings.from_config: the
same checks `load` runs), no command, no pipeline.
"""

from __future__ import annotations

import copy
import re
from pathlib import Path

import pytest

from lathe_mirror.config import default_config
from lathe_mirror.errors import InputError
from lathe_mirror.settings import from_config
from lathe_mirror.settings.declare import Key
from lathe_mirror.settings.keys import KEYS, declared_defaults, find, key_table_markdown

BASE = default_config()
README = Path(__file__).resolve().parents[1] / "README.md"
#: Keys whose value is a name, a flag or a table: no numeric endpoints to walk.
NUMERIC = [k for k in KEYS if k.numeric and k.type != "table"]


def _target(cfg: dict, k: Key) -> tuple[dict, str, object]:
    """(the dict holding the key's first occurrence, its last name part, its value)."""
    name = k.name
    if "[]" in name:  # the first item of a list of tables
        head, tail = name.split("[].")
        node = cfg
        for p in head.split("."):
            node = node[p]
        return node[0], tail, node[0][tail]
    parts = name.split(".")
    node = cfg
    for p in parts[:-1]:
        node = node[p]
    return node, parts[-1], node.get(parts[-1])


def _with(k: Key, value) -> dict:
    """The defaults with the key (its first occurrence; for a list, the entry that holds the
    end: the first for the low end, the last for the high end) set to value."""
    cfg = copy.deepcopy(BASE)
    node, last, old = _target(cfg, k)
    if k.default is None and k.name.startswith("lobes."):  # an exclusive design choice
        for other in ("alpha_deg", "a_over_b", "e"):
            node.pop(other, None)
    if isinstance(old, list):
        new = list(old)
        new[value[0]] = value[1]
        node[last] = new
    else:
        node[last] = value
    return cfg


def _is_int(k: Key) -> bool:
    old = _target(BASE, k)[2]
    return isinstance(old[0] if isinstance(old, list) else old, int) and not isinstance(old, bool)


def _typed(k: Key, x: float):
    return int(x) if _is_int(k) else float(x)


def _beyond(k: Key, end: float, side: int) -> float:
    """Just outside an end (side -1: below lo, +1: above hi)."""
    is_open = k.lo_open if side < 0 else k.hi_open
    if is_open:
        return end
    if _is_int(k):
        return end + side
    return end + side * max(abs(end) * 1e-6, 1e-9)


def _inside(k: Key, end: float, side: int) -> float:
    """The end itself, or for an open end the nearest value inside."""
    is_open = k.lo_open if side < 0 else k.hi_open
    if not is_open:
        return end
    return end - side * max(abs(end) * 1e-9, 1e-12)


def _value(k: Key, x: float, side: int):
    v = _typed(k, x)
    if k.type == "list":
        n = len(_target(BASE, k)[2])
        return (0 if side < 0 else n - 1, v)
    return v


def _ends(k: Key):
    for side, end, depends in ((-1, k.lo, k.lo_depends), (1, k.hi, k.hi_depends)):
        if end is not None:
            yield side, end, depends


@pytest.mark.parametrize("k", NUMERIC, ids=[k.name for k in NUMERIC])
def test_every_documented_end_is_accepted_and_beyond_it_refused(k):
    for side, end, depends in _ends(k):
        inside = _value(k, _inside(k, end, side), side)
        try:
            from_config(_with(k, inside))
        except InputError as exc:
            # only an end the declaration says other keys bound may be refused, and then the
            # message names the key (or, for a design's inputs, the design it breaks)
            assert depends, f"{k.name} = {inside}: the documented end is refused: {exc}"
            named = [k.name.split("[")[0]] + re.findall(r"\b[a-z_]+\.[a-z_.\[\]]*[a-z_]\b", k.depends)
            assert any(n in str(exc) for n in named), (k.name, k.depends, str(exc))
        beyond = _value(k, _beyond(k, end, side), side)
        with pytest.raises(InputError) as exc:
            from_config(_with(k, beyond))
        assert k.name.replace("[]", "[0]").split("[")[0] in str(exc.value), (k.name, beyond, str(exc.value))


def test_every_key_of_the_defaults_is_declared_and_the_defaults_are_the_declared_ones():
    assert declared_defaults() == BASE
    declared = {k.name for k in KEYS}
    for k in KEYS:
        assert list(find(BASE, k.name.split("."), "")) or k.default is None, f"{k.name}: not in the defaults"
    for node_key in _leaves(BASE):
        generic = re.sub(r"^polish\.process\..*", "polish.process.*", re.sub(r"^scene\.boxes\[\d+\]", "scene.boxes[]",
                                                                               node_key))
        assert generic in declared or generic.split("[")[0] in declared, f"{node_key} is not declared"


def _leaves(d: dict, prefix: str = ""):
    for k, v in d.items():
        if isinstance(v, dict):
            yield from _leaves(v, f"{prefix}{k}.")
        elif isinstance(v, list) and v and isinstance(v[0], dict):
            for i, item in enumerate(v):
                yield from _leaves(item, f"{prefix}{k}[{i}].")
        else:
            yield f"{prefix}{k}"


def test_the_readme_table_is_the_generated_one():
    text = README.read_text(encoding="utf-8")
    begin = text.index("<!-- key table:")
    table = text[text.index("\n", begin) + 1:text.index("<!-- end of the key table -->")]
    assert table == key_table_markdown(), "README's key table differs: run scripts/readme-keys"


def test_a_dependent_limit_is_stated_in_the_table():
    table = key_table_markdown()
    for k in KEYS:
        if k.lo_depends or k.hi_depends:
            assert k.depends and k.depends in table, k.name
