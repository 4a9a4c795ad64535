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
from lathe_mirror.declared import Key
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


def test_the_data_files_are_generated_from_the_declaration():
    """lathe_mirror/data/*.toml (what a user reads and copies) are the declaration's text,
    and read back they are the declared defaults."""
    import tomllib

    from lathe_mirror.settings.defaults_toml import default_files

    data = Path(__file__).resolve().parents[1] / "lathe_mirror" / "data"
    files = default_files()
    assert {p.name for p in data.glob("*.toml")} == set(files), "a data file not generated: run scripts/gen-keys"
    merged: dict = {}
    for name, text in files.items():
        assert (data / name).read_text(encoding="utf-8") == text, f"data/{name} differs: run scripts/gen-keys"
        for section, value in tomllib.loads(text).items():
            assert section not in merged
            merged[section] = value
    assert merged == declared_defaults()


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


def test_the_key_reference_is_the_generated_one():
    text = (README.parent / "docs" / "reference" / "keys.md").read_text(encoding="utf-8")
    assert key_table_markdown() in text, "docs/reference/keys.md differs: run scripts/gen-keys"


def test_a_dependent_limit_is_stated_in_the_table():
    table = key_table_markdown()
    for k in KEYS:
        if k.lo_depends or k.hi_depends:
            assert k.depends and k.depends in table, k.name


# --------------------------------------------------------------------------------------
# A Settings built in Python gets the same checks and messages as a configuration


def _config_message(dotted: str, value) -> str:
    cfg = copy.deepcopy(BASE)
    parts = dotted.split(".")
    node = cfg
    for p in parts[:-1]:
        node = node[p]
    if parts[0] == "lobes" and parts[-1] in ("a_over_b", "e"):
        node.pop("alpha_deg")
    node[parts[-1]] = value
    with pytest.raises(InputError) as exc:
        from_config(cfg)
    return str(exc.value)


def _replace(settings, section: str, **changes):
    import dataclasses

    return dataclasses.replace(settings, **{section: dataclasses.replace(getattr(settings, section), **changes)})


TYPED_CASES = [
    # (dotted key, value in the file, section, typed field changes)
    ("render.supersample", 9, "render", {"supersample": 9}),
    ("render.nose_radius", 5.5, "render", {"nose_radius": 5.5}),
    ("stereo.supersample", 5, "stereo", {"supersample": 5}),
    ("tolerance.bin_px", 60.0, "tolerance", {"bin_px": 60.0}),
    ("tolerance.azimuths", 2000, "tolerance", {"azimuths": 2000}),  # the sample's rays (cross-key)
    ("machine.max_points", 1_000_000, "machine", {"max_points": 1_000_000}),  # the envelope's memory (cost)
    ("polish.preston_coefficient", 1e-9, "polish", {"preston_coefficient": 1e-9}),  # the time steps (cost)
    ("optimize.bound_margin", 0.5, "optimize", {"bound_margin": 0.5}),
    ("compute.scheduler", "localhost:8786", "compute", {"scheduler": "localhost:8786"}),
    ("toolpath.max_finish_depth_mm", 0.0, "toolpath", {"max_finish_depth_mm": 0.0}),
]


@pytest.mark.parametrize("dotted, value, section, changes", TYPED_CASES, ids=[c[0] for c in TYPED_CASES])
def test_a_replaced_settings_is_refused_with_the_configs_message(dotted, value, section, changes):
    from lathe_mirror.config import load

    expected = _config_message(dotted, value)
    with pytest.raises(InputError) as exc:
        _replace(load(), section, **changes)
    assert str(exc.value) == expected


def test_a_replaced_impossible_design_raises_the_configs_message():
    """Issue 26: a_over_b = 1e-9 gave a lobe with R = 1.2e11 mm, planned without complaint."""
    import dataclasses

    from lathe_mirror.config import load
    from lathe_mirror.errors import DesignError, Error

    settings = load()
    inner = dataclasses.replace(settings.lobes[0], alpha_deg=None, a_over_b=1e-9)
    with pytest.raises(DesignError) as exc:
        dataclasses.replace(settings, lobes=(inner, settings.lobes[1]))
    assert str(exc.value) == _config_message("lobes.inner.a_over_b", 1e-9)
    assert str(exc.value).startswith("lobes.inner.a_over_b = 1e-09: allowed 0.01143 to 5.763")
    assert isinstance(exc.value, Error) and exc.value.kind == "design" and exc.value.exit_status == 2


def test_the_exception_family():
    import lathe_mirror as lm

    assert issubclass(lm.InputError, lm.Error) and issubclass(lm.DesignError, lm.InputError)
    assert issubclass(lm.InternalError, lm.Error) and not issubclass(lm.InternalError, lm.InputError)
    assert (lm.InputError.kind, lm.DesignError.kind, lm.InternalError.kind) == ("input", "design", "internal")
    assert (lm.InputError.exit_status, lm.InternalError.exit_status) == (2, 1)
    assert issubclass(lm.InputError, ValueError)  # a wrong argument is still a ValueError


def test_the_typed_settings_write_back_as_the_configuration():
    """settings.dump.to_config inverts from_config (degrees, m, urad back in the file's units)."""
    from lathe_mirror.config import load
    from lathe_mirror.settings.dump import to_config

    back = to_config(load())
    for key in _leaves(BASE):
        if key.startswith("stereo.") and key.split(".")[-1] in ("p1", "p2"):
            continue
        want, got = _get(BASE, key), _get(back, key)
        assert got == pytest.approx(want, rel=1e-12) if isinstance(want, float) else got == want, key


def _get(cfg: dict, dotted: str):
    node = cfg
    for p in dotted.split("."):
        m = re.fullmatch(r"(\w+)\[(\d+)\]", p)
        node = node[m.group(1)][int(m.group(2))] if m else node[p]
    return node


def test_help_shows_the_declared_default_and_range():
    """A flag that sets a key shows the key's declared default and range in --help."""
    import argparse

    from lathe_mirror.cli import build_parser
    from lathe_mirror.settings.keys import key

    sub = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    for command, flag, name in (("toolpath", "--points", "machine.max_points"),
                                ("render", "--supersample", "render.supersample"),
                                ("tolerance", "--target-yield", "tolerance.target_yield"),
                                ("cad", "--stl-tolerance", "cad.stl_tolerance")):
        action = next(a for a in sub.choices[command]._actions if flag in a.option_strings)
        k = key(name)
        assert f"{name}, default {k.help_default().split('default ')[1]}" in action.help
        assert f"[range {k.text()}]" in action.help, action.help
    assert "machine.max_points, default 528" in next(
        a for a in sub.choices["toolpath"]._actions if "--points" in a.option_strings).help


def test_a_design_from_specs_gets_the_configs_checks():
    """lm.checked_mirror(camera, specs), the API's design from a camera and lobe specs: the
    same DesignError as load() on another camera (a 6 mm lens, 3 um pixels)."""
    import dataclasses

    import lathe_mirror as lm
    from lathe_mirror.design import Camera

    settings = lm.load()
    camera = Camera(f=6.0, t_pixel=0.003, sensor_px=(1008, 1018), f_number=8.0)
    good = lm.checked_mirror(camera, settings.lobes)  # same lobes behind another lens: h = 6 R_top / (0.003 R_pixel)
    assert good.inner.r_top == 20.0
    bad = (dataclasses.replace(settings.lobes[0], alpha_deg=None, e=1e-6), settings.lobes[1])
    with pytest.raises(lm.DesignError) as exc:
        lm.checked_mirror(camera, bad)
    cfg = copy.deepcopy(BASE)
    cfg["camera"].update(f=6.0, t_pixel=0.003)
    cfg["lobes"]["inner"].pop("alpha_deg")
    cfg["lobes"]["inner"]["e"] = 1e-6
    with pytest.raises(InputError) as from_file:
        from_config(cfg)
    assert str(exc.value) == str(from_file.value) and "lobes.inner.e = 1e-06 mm: allowed" in str(exc.value)
