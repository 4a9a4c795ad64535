"""Machine, tool and stock models: configuration, lattice arithmetic, validation."""

from __future__ import annotations

import math

import numpy as np
import pytest

from lathe_mirror.settings import from_config
from lathe_mirror.config import load_config
from lathe_mirror.errors import ConfigError, InputError
from lathe_mirror.lathe import (Lathe, Stock, Tool)


def test_paper_machine_from_the_default_config(paper_config):
    lathe = from_config(paper_config).machine
    assert lathe.resolution == 0.005 and lathe.max_points == 528  # section 6 of the paper
    assert lathe.diameter_mode
    tool = from_config(paper_config).tool
    assert tool.nose_radius == 0.2
    assert math.isclose(math.degrees(tool.included_angle), 35.0)
    stock = from_config(paper_config).stock
    assert stock.radius > 35.0  # holds the 70 mm mirror


def test_lattice_arithmetic():
    lathe = Lathe()
    assert lathe.to_units(11.93).item() == 2386 and lathe.to_units(-11.9274).item() == -2385
    assert lathe.snap(-11.929) == pytest.approx(-11.93)
    assert lathe.on_lattice([0.005, 20.0, -19.78])
    assert not lathe.on_lattice([0.0051])
    assert lathe.decimals == 3
    assert Lathe(resolution=0.01).decimals == 2
    assert Lathe(resolution=0.0025).decimals == 4 and Lathe(resolution=0.0001).decimals == 4
    assert np.all(lathe.from_units([1, -2]) == np.array([0.005, -0.01]))


@pytest.mark.parametrize("kwargs, phrase", [
    ({"resolution": 0.0}, "machine.resolution = 0"),
    ({"resolution": -0.005}, "machine.resolution"),
    ({"max_points": 3}, "machine.max_points = 3"),
    ({"travel_x": 0.0}, "machine.travel_x"),
    ({"travel_z_min": 1.0}, "travel_z_min"),
    ({"spindle_max_rpm": 0}, "machine.spindle_max_rpm"),
    # a G-code word carries 4 decimals: finer or odd steps cannot be written exactly
    ({"resolution": 1e-7}, "a multiple of 0.0001 mm"),
    ({"resolution": 0.00333}, "allowed a multiple of 0.0001 mm"),
    ({"resolution": 0.2}, "machine.resolution = 0.2"),
])
def test_bad_lathe(kwargs, phrase):
    with pytest.raises(InputError, match=phrase):
        Lathe(**kwargs)


def test_bad_tool_and_stock():
    with pytest.raises(InputError, match="tool.nose_radius"):
        Tool(nose_radius=-0.1)
    with pytest.raises(InputError, match="tool.included_angle"):
        Tool(included_angle=math.radians(200))
    with pytest.raises(InputError, match="stock.diameter"):
        Stock(diameter=0.0)


def test_tool_reach_by_hand():
    """Flanks at 93 and 128 deg from +r (approach 3, included 35): a surface normal
    below 128 - 90 = 38 deg or above 93 + 90 = 183 deg is rubbed."""
    tool = Tool()
    lo, hi = tool.flank_directions()
    assert math.degrees(lo) == pytest.approx(93.0) and math.degrees(hi) == pytest.approx(128.0)
    tool.check_reach(np.radians([38.5, 90.0, 180.0]))
    with pytest.raises(InputError):
        tool.check_reach(np.radians([37.5]))
    with pytest.raises(InputError):
        tool.check_reach(np.radians([184.0]))


def test_config_types_are_checked(tmp_path):
    f = tmp_path / "c.toml"
    f.write_text('[machine]\nmax_points = "many"\n')
    with pytest.raises(ConfigError, match="machine.max_points"):
        load_config(f)
    f.write_text("[tool]\nnose_radius = 0.4\n")
    assert load_config(f)["tool"]["nose_radius"] == 0.4
