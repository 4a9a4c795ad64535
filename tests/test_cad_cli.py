"""`lathe-mirror cad`: bad inputs give one line, exit 2 and no file; same bytes twice;
the committed reference CAD in cad/ is current (read back and measured)."""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest

from committed import dxf_differs, step_differs
from conftest import run_cli
from lathe_mirror.export.cad import REFERENCE_FILES, write_reference_cad
from lathe_mirror.job import cad_model
from lathe_mirror.settings import from_config

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


@pytest.mark.parametrize("toml, key, suffix", [
    ('mount = "flange"', "cad.mount", "step"),
    ('step_schema = "AP203"', "cad.step_schema", "step"),
    ('product_name = "Spiegel \u00fc"', "cad.product_name", "step"),
    ('product_name = ""', "cad.product_name", "stl"),        # checked whatever the format
    ("mount_depth = 27.0", "cad.mount_depth", "step"),
    ("thickness = 1e308", "cad.thickness", "stl"),           # was: an STL of inf coordinates
    ("stl_tolerance = 100.0", "cad.stl_tolerance", "stl"),   # was: a 5 kB mesh of the body
    ("stl_tolerance = 1e-6", "cad.stl_tolerance", "stl"),    # ~2e8 triangles: refused
])
def test_bad_cad_settings_are_refused(tmp_path, toml, key, suffix):
    cfg = tmp_path / "bad.toml"
    cfg.write_text(f"[cad]\n{toml}\n", encoding="utf-8")
    out = tmp_path / f"m.{suffix}"
    _assert_refused(run_cli("cad", "--config", str(cfg), "-o", str(out)), key)
    assert list(tmp_path.iterdir()) == [cfg]


def test_unwritable_path_is_refused(tmp_path):
    out = tmp_path / "no_such_dir" / "m.step"
    _assert_refused(run_cli("cad", "-o", str(out)), "does not exist")
    _assert_refused(run_cli("cad", "-o", str(tmp_path)), "is a directory")
    # os.access says yes (the tests may run as root), the write says no: still exit 2
    _assert_refused(run_cli("cad", "-o", "/proc/lathe_mirror_cad_test.step"), "cannot write")
    assert list(tmp_path.iterdir()) == []


def test_special_file_is_not_replaced(tmp_path):
    """An existing FIFO (a stand-in for /dev/null: never test on that) is refused and
    stays a FIFO: the atomic rename would otherwise put a regular file in its place."""
    import stat

    fifo = tmp_path / "m.step"
    os.mkfifo(fifo)
    _assert_refused(run_cli("cad", "-o", str(fifo)), "not a regular file")
    assert stat.S_ISFIFO(fifo.stat().st_mode)
    assert list(tmp_path.iterdir()) == [fifo]


@pytest.mark.parametrize("args, name, needle", [
    (["--format", "obj"], "m.step", "--format 'obj'"),
    (["--which", "polished"], "m.step", "--which 'polished'"),
    (["--schema", "AP203"], "m.step", "--schema"),
    (["--stl-tolerance", "0"], "m.stl", "argument --stl-tolerance: 0 mm: allowed 0.001 to 1 mm"),
    (["--stl-tolerance", "nan"], "m.stl", "--stl-tolerance"),
    (["--format", "stl"], "m.step", "a '.step' file cannot hold --format stl"),
    (["--schema", "AP242"], "m.stl", "--schema applies to --format step only"),
    (["--stl-tolerance", "0.1"], "m.dxf", "--stl-tolerance applies to --format stl only"),
])
def test_unknown_choices_are_refused(tmp_path, args, name, needle):
    _assert_refused(run_cli("cad", *args, "-o", str(tmp_path / name)), needle)
    assert list(tmp_path.iterdir()) == []


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
    `lathe-mirror run` from the repository root)."""
    from lathe_mirror.config import load
    from lathe_mirror.job import cad_model

    settings = load()
    write_reference_cad(tmp_path, cad_model(settings, settings.mirror(), programmed=True), settings.cad)
    for name in REFERENCE_FILES:
        committed = REPO / "cad" / name
        assert committed.exists(), f"cad/{name} is missing"
        # Read back and measured, never bytes (numbers are written at 1e-9 mm).
        if name.endswith(".dxf"):
            why = dxf_differs((tmp_path / name).read_bytes(), committed.read_bytes())
        else:
            why = step_differs(tmp_path / name, committed)
        assert why is None, f"cad/{name} is stale ({why}): run lathe-mirror run"


def test_check_cad_config_refuses_before_anything_is_planned(paper_config):
    """The cheap check `lathe-mirror run` can call before it writes its programs."""
    import copy

    from lathe_mirror.errors import InputError
    from lathe_mirror.job import check_cad
    from lathe_mirror.settings import from_config

    def check(cfg):
        settings = from_config(cfg)  # the [cad] values
        check_cad(settings, settings.mirror())  # the body holds the design

    check(paper_config)  # the paper default passes
    for key, value in (("thickness", 15.0), ("stl_tolerance", 5.0), ("product_name", "it's")):
        cfg = copy.deepcopy(paper_config)
        cfg["cad"][key] = value
        with pytest.raises(InputError, match=f"cad.{key}"):
            check(cfg)


def test_a_file_failing_its_read_back_check_is_removed(tmp_path, paper_config, monkeypatch):
    """If the written file does not read back as what it should be, the export fails
    (RuntimeError: exit 1) and leaves nothing behind."""
    import lathe_mirror.export.cad as cad

    real = cad.check_file

    def broken(path, fmt):
        fig = real(path, fmt)
        return dict(fig, watertight=False)

    monkeypatch.setattr(cad, "check_file", broken)
    with pytest.raises(RuntimeError, match="read-back check"):
        settings = from_config(paper_config)
        model = cad_model(settings, settings.mirror(), programmed=False)
        cad.export_cad(model, settings.cad, cad.Which.DESIGN, cad.CadFormat.STL, tmp_path / "m.stl")
    assert list(tmp_path.iterdir()) == []


def test_a_blank_exactly_the_mirrors_diameter(tmp_path, paper_config):
    """blank_diameter = 2 r_top (70 mm, no shoulder) holds the design: its DXF is drawn
    with the toolpath layers (the finishing pass runs past the rim, into air). The
    programmed solid cannot sit on it: refused naming the key and the program's reach."""
    import copy

    from lathe_mirror.enums import CadFormat, Which
    from lathe_mirror.errors import InputError
    from lathe_mirror.export.cad import export_cad

    cfg = copy.deepcopy(paper_config)
    cfg["cad"]["blank_diameter"] = 70.0
    settings = from_config(cfg)
    mirror = settings.mirror()
    model = cad_model(settings, mirror, programmed=True, programmed_face_only=True)
    fig = export_cad(model, settings.cad, Which.DESIGN, CadFormat.DXF, tmp_path / "m.dxf")
    assert fig["check"]["audit_errors"] == [] and fig["features_mm"]["blank_radius"] == 35.0
    with pytest.raises(InputError, match="cad.blank_diameter = 70 mm is smaller"):
        export_cad(cad_model(settings, mirror, programmed=True), settings.cad, Which.PROGRAMMED, CadFormat.STEP,
                   tmp_path / "p.step")
    assert [p.name for p in tmp_path.iterdir()] == ["m.dxf"]
