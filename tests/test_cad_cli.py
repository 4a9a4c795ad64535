"""`lathe-mirror cad`: bad inputs give one line, exit 2 and no file; same bytes twice;
the committed reference CAD in cad/ is current."""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest

from conftest import run_cli
from lathe_mirror.export.cad import REFERENCE_FILES, write_reference_cad

REPO = Path(__file__).resolve().parents[1]


def _assert_refused(proc, *needles: str) -> None:
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1, proc.stderr
    assert "Traceback" not in proc.stderr
    for n in needles:
        assert n in lines[0], lines[0]


def test_body_thinner_than_the_profile_is_refused(tmp_path):
    cfg = tmp_path / "thin.toml"
    cfg.write_text("[cad]\nthickness = 15.0\n")
    out = tmp_path / "m.step"
    proc = run_cli("cad", "--config", str(cfg), "-o", str(out))
    _assert_refused(proc, "cad.thickness", "19.778")
    assert not out.exists() and list(tmp_path.iterdir()) == [cfg]


@pytest.mark.parametrize("toml, key", [
    ('mount = "flange"', "cad.mount"),
    ('step_schema = "AP203"', "cad.step_schema"),
    ('product_name = "Spiegel \u00fc"', "cad.product_name"),
    ("mount_depth = 27.0", "cad.mount_depth"),
])
def test_bad_cad_settings_are_refused(tmp_path, toml, key):
    cfg = tmp_path / "bad.toml"
    cfg.write_text(f"[cad]\n{toml}\n", encoding="utf-8")
    out = tmp_path / "m.step"
    _assert_refused(run_cli("cad", "--config", str(cfg), "-o", str(out)), key)
    assert not out.exists()


def test_unwritable_path_is_refused(tmp_path):
    out = tmp_path / "no_such_dir" / "m.step"
    _assert_refused(run_cli("cad", "-o", str(out)), "does not exist")
    _assert_refused(run_cli("cad", "-o", str(tmp_path)), "is a directory")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("args, needle", [
    (["--format", "obj"], "--format 'obj'"),
    (["--which", "polished"], "--which 'polished'"),
    (["--schema", "AP203"], "--schema"),
    (["--stl-tolerance", "0", "--format", "stl"], "--stl-tolerance"),
])
def test_unknown_choices_are_refused(tmp_path, args, needle):
    out = tmp_path / "m.step"
    _assert_refused(run_cli("cad", *args, "-o", str(out)), needle)
    assert not out.exists()


def test_unknown_suffix_is_refused(tmp_path):
    out = tmp_path / "m.obj"
    _assert_refused(run_cli("cad", "-o", str(out)), "'.obj'")
    assert not out.exists()


def test_json_figures_and_same_bytes_twice(tmp_path):
    """Two fresh processes with different hash seeds write identical DXF and STL; the
    --json figures report the file's own check."""
    outs = {}
    for seed in ("1", "2"):
        env = dict(os.environ, PYTHONHASHSEED=seed)
        for fmt in ("dxf", "stl"):
            path = tmp_path / f"{seed}.{fmt}"
            proc = run_cli("cad", "--format", fmt, "-o", str(path), "--json", env=env)
            assert proc.returncode == 0, proc.stderr
            fig = json.loads(proc.stdout)
            outs[(seed, fmt)] = path.read_bytes()
            if fmt == "dxf":
                assert fig["check"]["audit_errors"] == []
                assert fig["toolpath"]["nose_radius_mm"] > 0
            else:
                assert fig["check"]["watertight"]
                assert fig["check"]["volume_mm3"] == pytest.approx(fig["volume_mm3"], rel=2e-3)
    assert outs[("1", "dxf")] == outs[("2", "dxf")]
    assert outs[("1", "stl")] == outs[("2", "stl")]


def test_reference_cad_is_current(tmp_path):
    """cad/ holds what write_reference_cad writes today (regenerate with
    `python -c "from lathe_mirror.export.cad import write_reference_cad; write_reference_cad('cad')"`)."""
    write_reference_cad(tmp_path)
    for name in REFERENCE_FILES:
        committed = REPO / "cad" / name
        assert committed.exists(), f"cad/{name} is missing"
        assert (tmp_path / name).read_bytes() == committed.read_bytes(), f"cad/{name} is stale"
