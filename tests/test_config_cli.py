"""Configuration and the `design` command: output, --json, and every bad input."""

from __future__ import annotations

import json
import math

import pytest

from conftest import run_cli
from lathe_mirror import __version__
from lathe_mirror.config import load_config, merge
from lathe_mirror.errors import ConfigError


def test_design_json_has_table1_and_derived_figures():
    proc = run_cli("design", "--json")
    assert proc.returncode == 0, proc.stderr
    fig = json.loads(proc.stdout)
    inner, outer = fig["lobes"]
    assert (inner["name"], outer["name"]) == ("inner", "outer")
    assert round(inner["h"], 3) == 115.607 and round(outer["h"], 3) == 123.457
    assert round(inner["c"], 2) == 110.64 and round(outer["c"], 2) == 123.44
    for key in ("r_top", "r_pixel", "f", "t_pixel", "h", "a", "b", "e", "c", "alpha_deg"):
        assert key in inner and key in outer
    assert fig["junction"]["recessed"] == "inner"
    assert fig["baseline_mm"] == pytest.approx(12.8, abs=0.01)
    assert set(fig["image_radii_px"]) == {"inner_disc", "inner_blocked_by_step", "lost_ring", "outer_annulus"}
    assert "swapped" in fig["notes"][0]


def test_design_table_is_readable_and_says_the_swap():
    proc = run_cli("design")
    assert proc.returncode == 0, proc.stderr
    assert "115.607" in proc.stdout and "123.457" in proc.stdout
    assert "swapped" in proc.stdout


def test_version_and_help():
    proc = run_cli("--version")
    assert proc.returncode == 0 and __version__ in proc.stdout
    proc = run_cli("--help")
    assert proc.returncode == 0 and "design" in proc.stdout


def test_user_config_overrides_part_of_the_default(tmp_path):
    cfg_file = tmp_path / "small.toml"
    cfg_file.write_text(
        "[camera]\nf = 6.0\nt_pixel = 0.003\nsensor_px = [1280, 1024]\n"
        "[lobes.inner]\nr_top = 12.0\nr_pixel = 300.0\na_over_b = 2.0\n"
        "[lobes.outer]\nr_top = 25\nr_pixel = 500.0\ne = 45.0\n"
    )
    cfg = load_config(cfg_file)
    assert "alpha_deg" not in cfg["lobes"]["inner"] and cfg["lobes"]["inner"]["a_over_b"] == 2.0
    assert cfg["lobes"]["outer"]["r_top"] == 25.0 and isinstance(cfg["lobes"]["outer"]["r_top"], float)
    proc = run_cli("design", "--json", "--config", str(cfg_file))
    assert proc.returncode == 0, proc.stderr
    fig = json.loads(proc.stdout)
    assert fig["lobes"][0]["h"] == pytest.approx(80.0)  # 6 * 12 / (0.003 * 300)
    assert fig["lobes"][1]["e"] == pytest.approx(45.0)
    assert "notes" not in fig


def test_output_file_is_written(tmp_path):
    out = tmp_path / "design.json"
    proc = run_cli("design", "-o", str(out))
    assert proc.returncode == 0, proc.stderr
    assert json.loads(out.read_text())["lobes"][0]["name"] == "inner"


BAD = [
    ("[lobes.inner]\nr_top = 0.0\n", "lobes.inner.r_top = 0 mm: allowed 0.1 to 1000 mm"),
    ("[lobes.inner]\nr_top = -5.0\n", "lobes.inner.r_top = -5 mm: allowed 0.1 to 1000 mm"),
    ("[camera]\nf = -16.0\n", "camera.f = -16 mm: allowed 0.1 to 1000 mm"),
    ("[lobes.outer]\nr_top = 20.0\n", "must exceed lobes.inner.r_top"),
    ("[lobes.outer]\nr_top = 15.0\n", "must exceed lobes.inner.r_top"),
    ("[lobes.inner]\nalpha_deg = 85.0\n", "no hyperbola"),
    ("[lobes.inner]\nalpha_deg = 10.0\ne = 50.0\n", "exactly one of alpha_deg, a_over_b, e"),
    ("[lobes.inner]\nrtop = 20.0\n", "unknown key 'lobes.inner.rtop'"),
    ("[camera]\nf = nan\n", "'camera.f' = nan must be a finite number"),
    ("[camera]\nf = \"sixteen\"\n", "'camera.f' must be a number"),
    ("[lobe.inner]\nr_top = 20.0\n", "unknown key 'lobe'"),
    ("[camera\n", "not valid TOML"),
]


@pytest.mark.parametrize("text, message", BAD)
def test_bad_config_gives_one_line_and_exit_2(tmp_path, text, message):
    cfg_file = tmp_path / "bad.toml"
    cfg_file.write_text(text)
    out = tmp_path / "design.json"
    proc = run_cli("design", "--config", str(cfg_file), "-o", str(out))
    assert proc.returncode == 2, (proc.stdout, proc.stderr)
    assert message in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1
    assert "Traceback" not in proc.stderr
    assert not out.exists()


def test_missing_config_file(tmp_path):
    proc = run_cli("design", "--config", str(tmp_path / "nope.toml"))
    assert proc.returncode == 2
    assert "no such file" in proc.stderr and len(proc.stderr.strip().splitlines()) == 1


def test_unwritable_output(tmp_path):
    proc = run_cli("design", "-o", str(tmp_path / "missing_dir" / "d.json"))
    assert proc.returncode == 2 and "does not exist" in proc.stderr


def test_misspelt_key_suggests_the_right_one():
    with pytest.raises(ConfigError, match="did you mean 'r_pixel'"):
        merge(load_config(), {"lobes": {"outer": {"r_pixels": 500.0}}})


def test_infinite_and_boolean_values_are_rejected():
    with pytest.raises(ConfigError, match="finite"):
        merge(load_config(), {"lobes": {"outer": {"alpha_deg": math.inf}}})
    with pytest.raises(ConfigError, match="must be a number"):
        merge(load_config(), {"camera": {"t_pixel": True}})


@pytest.mark.parametrize("args, message", [
    (("toolpath", "--points", "abc"), "invalid int value"),
    (("tolerance", "--trials", "1.5"), "invalid int value"),
    (("design", "--bogus"), "unrecognized arguments"),
    ((), "required: COMMAND"),
])
def test_bad_flag_gives_one_line_and_exit_2(args, message):
    """argparse's own errors are one line too, like every other bad input (no usage block)."""
    proc = run_cli(*args)
    assert proc.returncode == 2
    assert message in proc.stderr and len(proc.stderr.strip().splitlines()) == 1


def test_site_config_sits_between_the_defaults_and_the_users_file(tmp_path):
    """$LATHE_MIRROR_CONFIG (a shop's machine and tools) merges over the defaults; the
    user's --config merges over it; a bad site file is one line naming the variable."""
    import json
    import os

    site = tmp_path / "site.toml"
    site.write_text("[tool]\nnose_radius = 0.4\n[machine]\nresolution = 0.002\n")
    user = tmp_path / "user.toml"
    user.write_text("[tool]\nnose_radius = 0.3\n")
    env = {**os.environ, "LATHE_MIRROR_CONFIG": str(site)}
    alone = json.loads(run_cli("toolpath", "--json", env=env).stdout)
    assert alone["nose_radius_mm"] == 0.4 and alone["resolution_mm"] == 0.002
    both = json.loads(run_cli("toolpath", "--json", "--config", str(user), env=env).stdout)
    assert both["nose_radius_mm"] == 0.3 and both["resolution_mm"] == 0.002
    missing = run_cli("design", env={**env, "LATHE_MIRROR_CONFIG": str(tmp_path / "none.toml")})
    assert missing.returncode == 2 and "LATHE_MIRROR_CONFIG" in missing.stderr
    assert len(missing.stderr.strip().splitlines()) == 1
