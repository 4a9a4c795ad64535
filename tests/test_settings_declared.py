"""The declaration builds the settings: every section's dataclass takes its defaults from
its declared keys, so a section built in Python equals the one a configuration file gives,
and load -> dump -> load gives back the same Settings.

The file side is read independently of the dataclasses: the embedded defaults as the
generated data/*.toml text, parsed by tomllib (not the declaration's dict), and each
design's own TOML.
"""

from __future__ import annotations

import dataclasses
import math
import tomllib
from importlib import resources

import pytest

import lathe_mirror as lm
from lathe_mirror.config import follow_stock, load, merge
from lathe_mirror.declared import KEYS
from lathe_mirror.declared.section import keyed
from lathe_mirror.enums import Surface
from lathe_mirror.export.design_toml import design_toml
from lathe_mirror.settings import Settings, from_config
from lathe_mirror.settings.dump import to_config
from lathe_mirror.settings.load import LOBES

from conftest import RECESSED_OUTER

#: Three designs besides the paper default: the recessed outer lobe behind a 6 mm lens;
#: a 6 mm lens with 3 um pixels; a 12 mm lens with 5.86 um pixels, a 0.8 mm nose and a
#: 0.01 mm lattice on a 50 mm bar.
DESIGNS = {
    "paper": "",
    "recessed": RECESSED_OUTER,
    "lens6_px3um": "[camera]\nf = 6.0\nt_pixel = 0.003\nsensor_px = [1280, 1024]\nf_number = 2.8\n"
                   "[lobes.inner]\nr_top = 5.143250067202264\nr_pixel = 354.34622080440613\n"
                   "alpha_deg = 0.16491580636968806\n[lobes.outer]\nr_top = 12.962773350532286\n"
                   "r_pixel = 511.82075923486775\nalpha_deg = 0.14021089596690714\n"
                   "[stock]\ndiameter = 60.0\n[camera_pose]\ntilt_deg = [0.3, -0.2]\n",
    "lens12_px586": "[camera]\nf = 12.0\nt_pixel = 0.00586\nsensor_px = [1920, 1200]\n"
                    "[tool]\nnose_radius = 0.8\nincluded_angle = 55.0\n[machine]\nresolution = 0.01\n"
                    "[machine.errors]\nsquareness_urad = 12.5\n[toolpath]\ngouge_tolerance = 0.01\n"
                    "ramp_angle = 12.5\n[stock]\ndiameter = 50.0\n[stereo]\nmin_range_m = 0.75\n"
                    "elevation_step_deg = 0.2\nply_format = \"ascii\"\n"
                    "[lobes.inner]\nr_top = 13.109387875739595\nr_pixel = 378.8829160293022\n"
                    "alpha_deg = 0.054743853006872456\n[lobes.outer]\nr_top = 23.977686074024277\n"
                    "r_pixel = 552.3958066035915\nalpha_deg = 0.14920531183170951\n",
}


def _data_toml() -> dict:
    """The embedded defaults as the shipped data/*.toml files read them."""
    cfg: dict = {}
    for entry in resources.files("lathe_mirror.data").iterdir():
        if entry.name.endswith(".toml"):
            cfg = _deep_merge(cfg, tomllib.loads(entry.read_text(encoding="utf-8")))
    return cfg


def _deep_merge(a: dict, b: dict) -> dict:
    out = dict(a)
    for k, v in b.items():
        out[k] = _deep_merge(out[k], v) if isinstance(v, dict) and isinstance(out.get(k), dict) else v
    return out


def _given(table: dict, prefix: str = "") -> set[str]:
    out: set[str] = set()
    for k, v in table.items():
        out |= _given(v, f"{prefix}{k}.") if isinstance(v, dict) else {f"{prefix}{k}"}
    return out


def _differences(a, b, path: str = "", rel: float = 0.0) -> list[str]:
    """Every field (dotted) where two sections differ, nested sections walked (floats to
    `rel` relative)."""
    if dataclasses.is_dataclass(a) and dataclasses.is_dataclass(b):
        return [d for f in dataclasses.fields(a)
                for d in _differences(getattr(a, f.name), getattr(b, f.name), f"{path}.{f.name}", rel)]
    if isinstance(a, tuple) and isinstance(b, tuple) and len(a) == len(b):
        return [d for i, (x, y) in enumerate(zip(a, b)) for d in _differences(x, y, f"{path}[{i}]", rel)]
    if isinstance(a, float) and isinstance(b, float) and rel:
        return [] if a == pytest.approx(b, rel=rel, abs=1e-300) else [f"{path}: {a!r} != {b!r}"]
    return [] if a == b else [f"{path}: {a!r} != {b!r}"]


@pytest.mark.parametrize("section", [f.name for f in dataclasses.fields(Settings)])
def test_each_section_built_in_python_equals_the_files(section):
    """Each section's dataclass built with no argument (the lobes: their declared specs)
    equals the one the shipped data/*.toml files give, field by field; this held for none
    of render.surface (PAPER against made), stereo.surface (EXACT) and
    optimize.blur_limit_um (0 against 63) before the fields named their keys."""
    from_files = from_config(_data_toml())
    field = next(f for f in dataclasses.fields(Settings) if f.name == section)
    built = field.default_factory()
    assert _differences(built, getattr(from_files, section), section) == []


def test_settings_built_in_python_equals_load():
    """lm.Settings() is lm.load() (every section, the validation run on both)."""
    assert lm.Settings() == lm.load()
    assert lm.Settings().optimize.blur_limit_um == 63.0
    assert lm.Settings().render.surface is Surface.MADE


def test_a_documented_default_in_degrees_is_the_radians_field():
    """The unit conversions the fields declare, against the numbers the file holds: the
    tool's 35 deg and 3 deg, the ramp's 20 deg, the squareness 0 urad, the stereo's 0.5 m
    and its 0 (automatic) elevation step."""
    s = lm.Settings()
    assert s.tool.included_angle == pytest.approx(35.0 * math.pi / 180.0, rel=1e-15)
    assert s.tool.approach_angle == pytest.approx(3.0 * math.pi / 180.0, rel=1e-15)
    assert s.toolpath.ramp_angle == pytest.approx(20.0 * math.pi / 180.0, rel=1e-15)
    assert s.stereo.params.min_range == 500.0 and s.stereo.params.elevation_step is None
    assert s.stereo.params.n_azimuth is None and s.stereo.ply_binary is True


def test_every_declared_key_has_a_field():
    """Each declared key is held by a field of some section (a key with no field would be
    read by nobody): the fields' keys, the lobes' `lobes.*.` and the tables' entries."""
    held = set(keyed(Settings).values())
    from lathe_mirror.design import LobeSpec

    held |= {v.replace("*", lobe) for v in keyed(LobeSpec).values() for lobe in LOBES}
    orphans = [k.name for k in KEYS
               if k.name not in held and not any(k.name.startswith((t + ".", t + "[]")) for t in held)]
    assert orphans == []


@pytest.mark.parametrize("design", sorted(DESIGNS))
def test_load_dump_load_round_trips(design, tmp_path):
    """load -> dump (written as a design TOML, the file optimize writes) -> load gives the
    same Settings, and the dump is the configuration the files merge to. The design TOML
    writes numbers at 12 significant digits (export.numbers), so the floats agree to 1e-11
    relative; every other field exactly."""
    path = tmp_path / "in.toml"
    path.write_text(DESIGNS[design])
    first = load(path)
    cfg = to_config(first)
    user = tomllib.loads(DESIGNS[design])
    expected = merge(_data_toml(), user)
    follow_stock(expected, _given(user))  # the body follows the bar unless the file sets it
    assert cfg == expected
    out = tmp_path / "out.toml"
    out.write_text(design_toml(first.camera, first.lobes, extra=cfg))
    again = load(out)
    assert _differences(again, first, "settings", rel=1e-11) == []
    assert to_config(again).keys() == cfg.keys()


def test_round_trip_keeps_what_the_file_gave(tmp_path):
    """The 12 mm design's non-default values survive the round trip in the file's units."""
    path = tmp_path / "in.toml"
    path.write_text(DESIGNS["lens12_px586"])
    cfg = to_config(load(path))
    assert cfg["tool"]["included_angle"] == 55.0 and cfg["toolpath"]["ramp_angle"] == 12.5
    assert cfg["machine"]["errors"]["squareness_urad"] == 12.5
    assert cfg["stereo"]["min_range_m"] == 0.75 and cfg["stereo"]["elevation_step_deg"] == 0.2
    assert cfg["stereo"]["ply_format"] == "ascii" and cfg["machine"]["resolution"] == 0.01
    assert cfg["cad"]["blank_diameter"] == 50.0  # the 50 mm bar's
