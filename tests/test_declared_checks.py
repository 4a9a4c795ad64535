"""A typed section built in Python refuses a value with the line the configuration file gets
(issue 26: the same checks and messages on construction as load() gives): both come from
the key's one declaration (lathe_mirror.declared), so `dataclasses.replace(settings.polish,
overhang=2.0)` and `[polish] overhang = 2.0` say the same, and say the declared range.

The design is not the paper's (conftest.RECESSED_OUTER: the outer lobe recessed).
"""

from __future__ import annotations

import dataclasses
import math

import pytest

from conftest import RECESSED_OUTER
from lathe_mirror.config import load
from lathe_mirror.declared import key
from lathe_mirror.errors import InputError

#: (section, field, file key, value in the file, value in the typed field) across modules:
#: polishing.PolishParams, lathe.Lathe / Tool / Stock, optimize.OptimizeSettings, body.BodySpec
#: ([cad]), toolpath.ToolpathSettings (the whole program's knobs too) below.
CASES = [
    ("polish", "overhang", "polish.overhang", 2.0, 2.0),
    ("polish", "calibration_knot_px", "polish.calibration_knot_px", 2.0, 2.0),
    ("polish", "stroke_points", "polish.stroke_points", 500, 500),
    ("polish", "lap_rpm", "polish.lap_rpm", 20000.0, 20000.0),
    ("machine", "max_points", "machine.max_points", 3, 3),
    ("machine", "travel_z_min", "machine.travel_z_min", 5.0, 5.0),
    ("tool", "nose_radius", "tool.nose_radius", 6.0, 6.0),
    ("tool", "included_angle", "tool.included_angle", 200.0, math.radians(200.0)),
    ("stock", "face_allowance", "stock.face_allowance", 150.0, 150.0),
    ("optimize", "tol", "optimize.tol", 1.5, 1.5),
    ("optimize", "workers", "optimize.workers", 65, 65),
    ("body", "thickness", "cad.thickness", -1.0, -1.0),
    ("body", "min_wall", "cad.min_wall", 0.0, 0.0),
    ("toolpath", "max_deviation", "toolpath.max_deviation", 20.0, 20.0),
    ("toolpath", "ramp_angle", "toolpath.ramp_angle", 50.0, math.radians(50.0)),
]


def _config_message(tmp_path, name: str, value) -> str:
    section, field = name.rsplit(".", 1)
    cfg = tmp_path / "bad.toml"
    cfg.write_text(RECESSED_OUTER + f"[{section}]\n{field} = {value!r}\n")
    with pytest.raises(InputError) as exc:
        load(cfg)
    return str(exc.value)


@pytest.fixture(scope="module")
def settings(tmp_path_factory):
    cfg = tmp_path_factory.mktemp("cfg") / "recessed.toml"
    cfg.write_text(RECESSED_OUTER)
    return load(cfg)


@pytest.mark.parametrize("section, field, name, file_value, typed_value", CASES,
                         ids=[c[2] for c in CASES])
def test_replace_refuses_with_the_config_files_line(tmp_path, settings, section, field, name, file_value,
                                                    typed_value):
    from_file = _config_message(tmp_path, name, file_value)
    with pytest.raises(InputError) as exc:
        dataclasses.replace(getattr(settings, section), **{field: typed_value})
    assert str(exc.value) == from_file
    declared = key(name)
    assert from_file.startswith(f"{name} = ") and f"allowed {declared.text()}" in from_file


def test_program_knobs_refuse_with_the_config_files_line(tmp_path, settings):
    """toolpath.ToolpathSettings, the whole program's knobs (shop.plan_program), says what
    the file's key gets; the ramp angle in the file's degrees."""
    base = settings.toolpath
    for field, name, file_value, typed_value in (
            ("path_tolerance_mm", "toolpath.path_tolerance_mm", 0.5, 0.5),
            ("ramp_angle", "toolpath.ramp_angle", 60.0, math.radians(60.0)),
            ("rough_depth", "toolpath.rough_depth", 0.01, 0.01)):
        from_file = _config_message(tmp_path, name, file_value)
        with pytest.raises(InputError) as exc:
            dataclasses.replace(base, **{field: typed_value})
        assert str(exc.value) == from_file
        assert f"allowed {key(name).text()}" in from_file


def test_the_declared_endpoints_are_accepted_in_python(settings):
    """Both documented ends of a closed range build (the declaration, not a second range)."""
    for field, name in (("overhang", "polish.overhang"), ("calibration_knot_px", "polish.calibration_knot_px")):
        k = key(name)
        for end in (k.lo, k.hi):
            assert getattr(dataclasses.replace(settings.polish, **{field: end}), field) == end
