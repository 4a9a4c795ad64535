"""`lathe-mirror run` (the README's main command) and the stage commands, end to end."""

from __future__ import annotations

import json

import pytest

from conftest import UNCUTTABLE, UNCUTTABLE_PHRASE, run_cli
from lathe_mirror.export.calib import FILE_NAMES

SMALL = """
[polish]
curve_points = 6
curve_max_s = 36000.0
[tolerance]
trials = 40
lattice_phases = 1
[stereo]
supersample = 1
"""


def test_run_writes_programs_cad_and_report(tmp_path):
    cfg = tmp_path / "small.toml"
    cfg.write_text(SMALL)
    out = tmp_path / "out"
    # the README's command, as typed, by the command line's entry point (run_cli: in this
    # process, its trials on this worker; the pool's answer is the serial one, test_compute)
    proc = run_cli("run", "--config", str(cfg), "-o", str(out))
    assert proc.returncode == 0, proc.stderr[-2000:]
    # With --config the programs and CAD go under the output directory, not the repository's.
    # each strategy's two set-ups in both dialects, one set-up sheet for both
    # two programs x two set-ups in each of three dialects, two set-up sheets, and each
    # control's tool table (LinuxCNC tools.tbl, Fanuc offsets.nc, Siemens tools.ini)
    assert sorted(p.suffix for p in (out / "gcode").iterdir()) == sorted(
        [".html"] * 2 + [".nc"] * 5 + [".ngc"] * 4 + [".mpf"] * 4 + [".tbl", ".ini"])
    assert {p.suffix for p in (out / "cad").iterdir()} == {".step", ".dxf"}
    assert {p.name for p in (out / "calib").iterdir()} == set(FILE_NAMES)  # calibration files
    report = json.loads((out / "report.json").read_text())
    # the optics shop's specification (issue 21): in the report and beside it, with the drawing
    assert report["spec"]["lobes"][0]["form_tolerance"]["iso10110_5"].startswith("3/")
    assert "ISO 10110" in (out / "report.html").read_text()
    assert (out / "mirror_drawing.pdf").read_bytes().startswith(b"%PDF")
    assert json.loads((out / "mirror_spec.json").read_text())["lobes"][1]["R_mm"] == report["spec"]["lobes"][1]["R_mm"]
    assert report["outputs"]["gcode"] and report["outputs"]["cad"]
    # the programs simulated against the stock: no contact, the operations in order
    assert [p["name"] for p in report["shop"]] == ["mirror_paper", "mirror_arcs"]
    assert all(p["contacts"] == [] for p in report["shop"])
    names = [op["name"] for op in report["shop"][0]["operations"]]
    assert names[:3] == ["face", "rough", "semi-finish"] and names[-2:] == ["finish", "part-off"]
    assert all(p["second_setup"]["contacts"] == [] for p in report["shop"])
    assert set(report["stereo"]["at_2_m"]) == {"exact", "paper", "best", "polished"}
    assert report["polishing"]["summary"]["optimum_inside_range"] is True
    html = (out / "report.html").read_text()
    assert "<img" in html and "https://" not in html
    # The progress display went to stderr, the summary to stdout.
    assert "report:" in proc.stdout and "yield" in proc.stdout
    assert "lathe-mirror" in proc.stderr


def test_run_bad_config_exit_2_writes_nothing(tmp_path):
    cfg = tmp_path / "bad.toml"
    cfg.write_text("[lobes.inner]\nr_top = -3.0\n")
    out = tmp_path / "out"
    proc = run_cli("run", "--config", str(cfg), "-o", str(out))
    assert proc.returncode == 2
    assert "r_top" in proc.stderr and "Traceback" not in proc.stderr
    assert not out.exists()


def test_run_bad_stage_setting_exit_2_writes_nothing(tmp_path):
    """A bad [tolerance] or [polish] key is caught before the programs and CAD are written."""
    for text, key in (('[tolerance]\ndistribution = "lognormal"\n', "tolerance.distribution"),
                      ("[polish]\npressure_kpa = 0.0\n", "polish.pressure_kpa"),
                      ("[cad]\nthickness = 15.0\n", "cad.thickness"),
                      ("[stock]\ndiameter = -1.0\n", "stock.diameter"),
                      # A nose too large for the step: no program cuts it.
                      (UNCUTTABLE, UNCUTTABLE_PHRASE)):
        cfg = tmp_path / "bad.toml"
        cfg.write_text(text)
        out = tmp_path / "out"
        proc = run_cli("run", "--config", str(cfg), "-o", str(out))
        assert proc.returncode == 2, proc.stderr
        assert key in proc.stderr and "Traceback" not in proc.stderr
        assert not out.exists()


def test_polish_command_json(tmp_path):
    cfg = tmp_path / "small.toml"
    cfg.write_text("[polish]\ncurve_points = 7\n")
    proc = run_cli("polish", "--config", str(cfg), "--json", "-o", str(tmp_path / "p"))
    assert proc.returncode == 0, proc.stderr[-2000:]
    data = json.loads(proc.stdout)
    assert data == json.loads((tmp_path / "p" / "polish.json").read_text())
    assert data["summary"]["optimum_time_s"] == data["curve"]["optimum"]["time_s"]
    assert len(data["curve"]["times_s"]) == 7


def test_run_unwritable_gcode_dir_leaves_no_output_dir(tmp_path):
    """-o is made before --gcode-dir; when --gcode-dir cannot be made, -o goes again."""
    blocker = tmp_path / "file"
    blocker.write_text("a file, not a directory\n")
    out = tmp_path / "out" / "report"
    proc = run_cli("run", "--config", str(_small(tmp_path)), "-o", str(out),
                   "--gcode-dir", str(blocker / "gcode"))
    assert proc.returncode == 2, proc.stderr
    assert "--gcode-dir" in proc.stderr and len(proc.stderr.strip().splitlines()) == 1
    assert not (tmp_path / "out").exists()


def _small(tmp_path):
    cfg = tmp_path / "small.toml"
    cfg.write_text(SMALL)
    return cfg




@pytest.mark.parametrize("design", ["paper", "recessed"])
def test_run_refuses_a_bar_too_short_before_any_work(tmp_path, design):
    """A bar the part-off cannot leave room in: `run` refuses at once (its programs are
    simulated in the background, but planned up front) with the line `toolpath` gives, and
    writes nothing."""
    import time

    from conftest import RECESSED_OUTER

    cfg = tmp_path / "short.toml"
    cfg.write_text((RECESSED_OUTER if design == "recessed" else "") + "\n[stock]\nlength = 12.0\n")
    t0 = time.perf_counter()
    proc = run_cli("run", "--config", str(cfg), "-o", str(tmp_path / "out"), "--no-progress")
    took = time.perf_counter() - t0
    assert proc.returncode == 2 and not (tmp_path / "out").exists()
    line = proc.stderr.strip()
    assert len(line.splitlines()) == 1 and "stock.length = 12 mm" in line
    tp = run_cli("toolpath", "--config", str(cfg), "-o", str(tmp_path / "t.ngc"))
    assert tp.returncode == 2 and tp.stderr.strip().split("error: ", 1)[1] == line.split("error: ", 1)[1]
    assert took < 30.0  # seconds, not the whole pipeline (a loaded machine: generous)
