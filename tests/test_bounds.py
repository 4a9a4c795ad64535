"""Issue 14: every input bounded. Each case of the issue with its exact input.

Bad input: exit status 2, one line on stderr naming the key and what is allowed, no
traceback, nothing written, in well under a second or two (the validation runs before
any work). The numbers asserted come from the issue's own observations or from hand
calculations in the test.
"""

from __future__ import annotations

import io
import math
import os
import re
import signal
import subprocess
import sys
import time
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path

import pytest

from conftest import require_program, run_cli
from lathe_mirror.cli import main

LONG = "x" * 300  # a 300-character file name


def cli(*args: str, cwd: Path) -> tuple[int, str, str, float]:
    """`lathe-mirror ARGS` in this process, in cwd: (status, stdout, stderr, seconds)."""
    out, err = io.StringIO(), io.StringIO()
    old = os.getcwd()
    os.chdir(cwd)
    t0 = time.perf_counter()
    try:
        with redirect_stdout(out), redirect_stderr(err):
            try:
                rc = main(list(args))
            except SystemExit as exc:  # argparse
                rc = exc.code
    finally:
        os.chdir(old)
    return rc, out.getvalue(), err.getvalue(), time.perf_counter() - t0


def files_under(d: Path) -> set[str]:
    return {str(p.relative_to(d)) for p in d.rglob("*")}


def refused(tmp_path: Path, toml: str | None, *args: str, within: float = 5.0) -> str:
    """Run a command that must refuse its input: exit 2, one line, nothing written (the
    directory holds only the config afterwards), fast. Returns the line."""
    if toml is not None:
        (tmp_path / "c.toml").write_text(toml)
        args = (*args, "--config", "c.toml")
    before = files_under(tmp_path)
    rc, out, err, seconds = cli(*args, cwd=tmp_path)
    assert rc == 2, (rc, out, err)
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert "Traceback" not in err and "Warning" not in err
    assert files_under(tmp_path) == before
    assert seconds < within, seconds
    return lines[0]


# --------------------------------------------------------------------------------------
# 1. Hangs


@pytest.mark.parametrize("value", ["0.00001", "0.0001"])
def test_rough_depth_of_a_hang_is_refused_at_once(tmp_path, value):
    """0.00001 mm ran past 120 s; 0.0001 mm took 10 s and wrote 20 MB of G-code."""
    line = refused(tmp_path, f"[toolpath]\nrough_depth = {value}\n", "toolpath")
    assert f"toolpath.rough_depth = {float(value):g} mm: allowed 0.05 to 10 mm" in line


def test_rough_depth_finer_than_the_lattice(tmp_path):
    """On a 0.1 mm lattice a 0.05 mm level repeats the one before it."""
    line = refused(tmp_path, "[toolpath]\nrough_depth = 0.05\n[machine]\nresolution = 0.1\n", "toolpath")
    assert "toolpath.rough_depth = 0.05 mm: allowed >= machine.resolution = 0.1 mm" in line


@pytest.mark.parametrize("value", ["1e6", "100.0", "1e308"])
def test_rough_allowance_out_of_range(tmp_path, value):
    """1e6 hung, 100 exited 1 (IndexError), 1e308 exited 1 (OverflowError)."""
    line = refused(tmp_path, f"[toolpath]\nrough_allowance = {value}\n", "toolpath")
    assert f"toolpath.rough_allowance = {float(value):g} mm: allowed 0.02 to 2 mm" in line


# --------------------------------------------------------------------------------------
# 2. Memory


def test_a_billion_trials_is_refused_with_its_estimate(tmp_path):
    line = refused(tmp_path, None, "tolerance", "--trials", "1000000000", "-o", "T")
    assert line.startswith("lathe-mirror tolerance: error: --trials: tolerance.trials = 1000000000")
    assert "of memory, limit 8 GiB" in line
    # 1e9 trials x 2 programs keep at least their ten float64 parameters each: 149 GiB
    tib = float(re.search(r"needs about ([0-9.e+]+) TiB", line).group(1))
    assert tib * 2**40 > 1e9 * 2 * 10 * 8


@pytest.mark.parametrize("key", ["depth_points", "lattice_phases"])
def test_a_billion_depth_points_or_lattice_phases(tmp_path, key):
    line = refused(tmp_path, f"[tolerance]\n{key} = 1000000000\n", "tolerance")
    assert f"tolerance.{key} = 1000000000" in line


@pytest.mark.parametrize("command", ["design", "toolpath", "cad", "render"])
def test_a_sensor_of_ten_gigapixels_is_refused_by_every_command(tmp_path, command):
    """render needed 74.5 GiB for one float64 array of 1e10 pixels; the estimate counts
    every array of the render, so it says more."""
    line = refused(tmp_path, "[camera]\nsensor_px = [100000, 100000]\n", command)
    m = re.search(r"rendering needs about ([0-9.]+) (GiB|TiB) of memory, limit 8 GiB", line)
    assert m, line
    need = float(m.group(1)) * (2**40 if m.group(2) == "TiB" else 2**30)
    assert need >= 1e10 * 8


def test_supersample_flag_is_held_to_the_same_estimate(tmp_path):
    """8 x 8 rays a pixel on a 2000 x 2000 sensor: 2.56e8 rays of 60 bytes at least."""
    line = refused(tmp_path, "[camera]\nsensor_px = [2000, 2000]\n", "render", "--supersample", "8")
    assert line.startswith("lathe-mirror render: error: --supersample:") and "limit 8 GiB" in line


# --------------------------------------------------------------------------------------
# 3. Words a controller refuses (their formatting and bounds are issue 15's, lathe.Lathe):
#    refused with one line like every other key


@pytest.mark.parametrize("toml, key", [
    ("[machine]\nsurface_speed = 1000000.0\n", "machine.surface_speed = 1e+06 m/min: allowed 1 to 99999 m/min"),
    ("[machine]\nfeed_finish = 0.00005\n", "machine.feed_finish = 5e-05 mm/rev: allowed 0.0001 to 500 mm/rev"),
    ("[machine]\nspindle_max_rpm = 9223372036854775807\n", "machine.spindle_max_rpm = 9223372036854775807 rev/min"),
])
def test_machine_words_out_of_range(tmp_path, toml, key):
    assert key in refused(tmp_path, toml, "toolpath")


# --------------------------------------------------------------------------------------
# 4. Exit 1 instead of 2


@pytest.mark.parametrize("toml, message", [
    ("[stock]\ndiameter = 1e308\n", "stock.diameter = 1e+308 mm: allowed > 0 and <= 4000 mm"),
    ("[stock]\nface_allowance = 1e308\n", "stock.face_allowance = 1e+308 mm: allowed 0 to 100 mm"),
    ("[polish]\npad_size_mm = 1e308\n", "polish.pad_size_mm = 1e+308 mm: allowed > 0 and <= 100 mm"),
])
def test_huge_lengths(tmp_path, toml, message):
    command = "polish" if "polish" in toml else "toolpath"
    assert message in refused(tmp_path, toml, command)


@pytest.mark.parametrize("command", ["design", "toolpath", "cad"])
def test_a_flat_lobe_is_refused_with_its_range(tmp_path, command):
    """a/b = 1e-9 is a plane: vertex radius of curvature b^2/a = b/k ~ 1.2e11 mm. The
    lower end of the allowed range is where b/k = 10000 mm: with s = sqrt(1 + k^2),
    b = s h - k sqrt(h^2 + R^2) (h = 115.607 mm, R = 20 mm), b / k = 10000 gives
    k ~ h / (10000 + sqrt(h^2 + R^2)) = 0.011426."""
    line = refused(tmp_path, "[lobes.inner]\na_over_b = 1e-9\n", command)
    h, r = 16.0 * 20.0 / (0.009 * 307.555), 20.0
    k = h / (10000.0 + math.hypot(h, r))
    lo = float(re.search(r"allowed ([0-9.e-]+) to ([0-9.e+]+)", line).group(1))
    assert "lobes.inner.a_over_b = 1e-09" in line
    assert lo == pytest.approx(k, rel=2e-3)


@pytest.mark.parametrize("command, args", [
    ("design", ["-o", LONG + ".json"]), ("toolpath", ["-o", LONG + ".ngc"]), ("cad", ["-o", LONG + ".step"]),
    ("render", ["-o", LONG]), ("polish", ["-o", LONG]),
])
def test_a_300_character_file_name(tmp_path, command, args):
    line = refused(tmp_path, None, command, *args)
    assert "a name of 30" in line and "allowed at most 255 bytes" in line


def test_toml_nested_5000_levels(tmp_path):
    toml = "a = " + "[" * 5000 + "]" * 5000 + "\n"
    assert "nested too deeply" in refused(tmp_path, toml, "design")


def test_a_huge_config_file_is_not_read(tmp_path):
    toml = "# " + "x" * (1 << 20) + "\n"
    assert "allowed at most 1048576" in refused(tmp_path, toml, "design")


# --------------------------------------------------------------------------------------
# 5. A design with no stereo band


def test_a_design_with_no_common_band_is_refused(tmp_path):
    """The issue's own figures: the outer lobe sees from -25.766 deg, the inner lobe
    (alpha -30 deg, less the step wall) up to -33.759 deg."""
    line = refused(tmp_path, "[lobes.inner]\nalpha_deg = -30.0\n", "design")
    assert "no common stereo band" in line and "lobes.inner.alpha_deg" in line
    assert "up to -33.759 deg" in line and "from -25.766 deg" in line
    line = refused(tmp_path, "[lobes.inner]\nalpha_deg = -30.0\n", "run", "-o", "OUT", "--no-progress")
    assert "no common stereo band" in line


# --------------------------------------------------------------------------------------
# 6. Leftovers after a late failure


def test_render_checks_every_output_name_first(tmp_path):
    (tmp_path / "R" / "made.png").mkdir(parents=True)   # render's default surface: the made mirror
    line = refused(tmp_path, None, "render", "-o", "R", "--no-progress", within=3.0)
    assert "R/made.png: is a directory" in line


def test_run_checks_every_output_name_first(tmp_path):
    (tmp_path / "OUT" / "report.json").mkdir(parents=True)
    line = refused(tmp_path, None, "run", "-o", "OUT", "--gcode-dir", "G", "--cad-dir", "C", "--no-progress",
                   within=3.0)
    assert "OUT/report.json: is a directory" in line


def test_sigterm_leaves_nothing_behind(tmp_path):
    """SIGTERM after `run` made its directories, while its programs are simulated and the
    tolerance analysis runs in their background processes: status 143, no directory, no
    file, no temporary left (SIGINT's behaviour)."""
    (tmp_path / "small.toml").write_text("[tolerance]\ntrials = 20\n")
    proc = subprocess.Popen([sys.executable, "-m", "lathe_mirror", "run", "--config", "small.toml", "-o", "OUT",
                             "--no-render"], cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    seen = ""
    # the progress bar names the stage (after the directories are made; the distortion
    # stage starts once the background work has); read by character, since the progress
    # bar's carriage returns hold a line back until the run has finished
    while "distortion" not in seen:
        c = proc.stderr.read(1)
        if not c:
            break
        seen += c
    time.sleep(1.0)
    proc.send_signal(signal.SIGTERM)
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 143, seen + err
    assert "terminated" in err
    assert files_under(tmp_path) == {"small.toml"}


def test_a_failure_after_files_were_written_leaves_none(tmp_path):
    """Inside a command (files.staging) a file written before a failure never appears,
    and the file it would have replaced keeps its bytes."""
    from lathe_mirror.errors import InputError
    from lathe_mirror.export import files

    (tmp_path / "old.txt").write_text("old\n")
    with pytest.raises(InputError):
        with files.staging():
            d = files.prepare_dir(tmp_path / "new" / "deeper")
            files.write_text(d / "a.txt", "a\n")
            files.write_text(tmp_path / "old.txt", "new\n")
            raise InputError("a late failure")
    assert files_under(tmp_path) == {"old.txt"}
    assert (tmp_path / "old.txt").read_text() == "old\n"


# --------------------------------------------------------------------------------------
# 7. A malformed STEP


@pytest.mark.parametrize("toml", ["[cad]\nmount_depth = 1e-9\n", "[cad]\nmount = \"boss\"\nmount_depth = 1e-9\n",
                                  "[cad]\nmount_diameter = 1e-9\n"])
def test_a_sliver_mount_is_refused(tmp_path, toml):
    line = refused(tmp_path, toml, "cad")
    assert "allowed >= 0.01 mm" in line


@pytest.mark.parametrize("toml", ["[cad]\nmount_depth = 0.01\n", "[cad]\nmount = \"boss\"\nmount_depth = 0.01\n",
                                  "[cad]\nmount_diameter = 0.01\n"])
def test_the_smallest_mount_is_one_valid_solid_in_freecad(tmp_path, toml):
    """At the smallest feature FreeCAD reads one closed, valid solid whose volume is the
    meridian's closed form (Green's theorem on its lines and hyperbola arcs)."""
    import json

    from test_step import FREECAD_SCRIPT

    from lathe_mirror.body import design_meridian
    from lathe_mirror.config import load

    freecad = require_program("freecadcmd")
    (tmp_path / "c.toml").write_text(toml)
    rc, out, err, _ = cli("cad", "--config", "c.toml", "-o", "m.step", cwd=tmp_path)
    assert rc == 0, err
    settings = load(tmp_path / "c.toml")
    volume = design_meridian(settings.mirror(), settings.body).volume()
    (tmp_path / "check.py").write_text(FREECAD_SCRIPT)
    proc = subprocess.run([freecad, "check.py"], capture_output=True, text=True, timeout=120, cwd=tmp_path,
                          env=dict(os.environ, LATHE_MIRROR_STEP=str(tmp_path / "m.step")))
    res = json.loads([ln for ln in proc.stdout.splitlines() if ln.startswith("RESULT ")][-1][7:])
    assert res["solids"] == 1 and res["valid"] and res["closed"], res
    assert res["volume"] == pytest.approx(volume, rel=1e-6)


# --------------------------------------------------------------------------------------
# 8. Meaningless figures


@pytest.mark.parametrize("toml, message", [
    ("[tolerance.params]\ncamera_tilt_deg = 50.0\n",
     "tolerance.params.camera_tilt_deg = 50 deg: allowed >= 0 and < 45"),
    ("[tolerance.params]\ncamera_decentre_mm = 1000\n",
     "tolerance.params.camera_decentre_mm = 1000 mm: allowed 0 to 100"),
])
def test_assembly_tolerances_out_of_range(tmp_path, toml, message):
    assert message in refused(tmp_path, toml, "tolerance")


def test_a_tilt_that_blinds_a_lobe_is_refused_where_figures_stop_meaning_anything(tmp_path, paper_mirror):
    """A 30 deg tilt leaves the inner lobe's sample nothing (its RMS displacement reads
    0.000 px). The bound named is where the analysis' own sample still sees both lobes
    (its lost fraction under one half) and its figures are figures."""
    import numpy as np

    from lathe_mirror.config import load
    from lathe_mirror.enums import Program
    from lathe_mirror.tolerance.runs import tolerance_context
    from lathe_mirror.tolerance.montecarlo import evaluate_trials
    from lathe_mirror.tolerance.perturb import Trials

    line = refused(tmp_path, "[tolerance.params]\ncamera_tilt_deg = 30.0\n", "tolerance")
    bound = float(re.search(r"up to about ([0-9.]+) deg", line).group(1))
    assert 3.0 < bound < 10.0
    settings = load()
    ctx = tolerance_context(paper_mirror, settings, Program.BEST, 300.0)
    tr = Trials.nominal(2, ctx.nominal_nose_mm, ctx.nominal_time_s)
    tr.tilt_x[:] = np.radians([bound, 30.0])
    fig = evaluate_trials(ctx, tr)
    disp = fig.calibrated["image_displacement_px_rms"]
    assert np.all(disp[0] > 0.01) and fig.lost_fraction[0] < 0.5  # at the bound: seen, a figure
    assert fig.lost_fraction[1] > 0.9 and disp[1, 0] == 0.0        # 30 deg: blind, and "0 px"


# --------------------------------------------------------------------------------------
# 9. Commands disagree


@pytest.mark.parametrize("command", [["toolpath"], ["cad", "--which", "programmed"], ["polish", "--program", "best"],
                                     ["render", "--surface", "best", "--no-progress"]])
def test_every_command_checks_a_program_the_same_way(tmp_path, command):
    """resolution 0.05 mm: the arcs program gouges 0.0065 mm > 0.005 mm (the issue's figure)."""
    line = refused(tmp_path, "[machine]\nresolution = 0.05\n", *command, within=20.0)
    assert "the arcs toolpath would gouge the part by 0.0065 mm (toolpath.gouge_tolerance = 0.005 mm)" in line


# --------------------------------------------------------------------------------------
# 10. Minor


def test_a_tiny_pixel_gives_one_short_line_and_no_warning(tmp_path):
    (tmp_path / "c.toml").write_text("[camera]\nt_pixel = 1e-300\n")
    proc = run_cli("design", "--config", "c.toml", cwd=tmp_path)
    assert proc.returncode == 2
    assert proc.stderr.strip() == ("lathe-mirror design: error: camera.t_pixel = 1e-300 mm: allowed 0.0005 to "
                                   "0.1 mm (pixel pitch)")


def test_no_numpy_warning_reaches_stderr(tmp_path):
    """A design the checks refuse after numpy overflowed on the way (a flat lobe): one
    line, no RuntimeWarning (a separate process: warnings print once per process)."""
    (tmp_path / "c.toml").write_text("[lobes.inner]\na_over_b = 1e-9\n")
    proc = run_cli("toolpath", "--config", "c.toml", cwd=tmp_path)
    assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1, proc.stderr
    assert "Warning" not in proc.stderr


def test_a_degenerate_e_names_its_range(tmp_path):
    """e = 1e-6 mm (refused without a range before): a cone's tip. For small e the lobe's
    vertex radius of curvature is b^2/a ~ e R^2 / (rho h) (a ~ e h / rho, b ~ e R / rho,
    rho = |rim|), so the 0.01 mm bound puts the lower end at e ~ 0.01 rho h / R^2; the
    message's lower end is accepted, half of it refused."""
    line = refused(tmp_path, "[lobes.inner]\ne = 1e-6\n", "design")
    lo, hi = (float(x) for x in re.search(r"allowed ([0-9.e-]+) to ([0-9.e+]+) mm", line).groups())
    h, r = 16.0 * 20.0 / (0.009 * 307.555), 20.0
    assert lo == pytest.approx(0.01 * math.hypot(h, r) * h / r**2, rel=0.01)
    assert lo < hi < h
    ok = tmp_path / "ok"
    ok.mkdir()
    # (at the cone's tip a 1 mm axial pupil tolerance blinds the lobe: another key's bound)
    (ok / "c.toml").write_text(f"[lobes.inner]\ne = {lo!r}\n[tolerance.params]\ncamera_axial_mm = 0.1\n")
    # the design's own checks accept it (`design` then refuses the 123 mm deep cone on the
    # 40 mm bar, as `toolpath` does: the bar's bound, another key's)
    from lathe_mirror.config import load

    assert load(ok / "c.toml").lobes[0].e == lo
    refused(ok, f"[lobes.inner]\ne = {lo / 2!r}\n[tolerance.params]\ncamera_axial_mm = 0.1\n", "design")


def test_an_empty_output_name_is_refused(tmp_path):
    line = refused(tmp_path, None, "cad", "-o", "")
    assert "empty path" in line


def test_output_through_a_symlink_writes_its_target(tmp_path):
    """README: -o naming a symbolic link writes the file the link points to; the link stays."""
    (tmp_path / "real.json").write_text("old\n")
    (tmp_path / "link.json").symlink_to("real.json")
    rc, _, err, _ = cli("design", "-o", "link.json", cwd=tmp_path)
    assert rc == 0, err
    assert (tmp_path / "link.json").is_symlink()
    assert '"lobes"' in (tmp_path / "real.json").read_text()


# --------------------------------------------------------------------------------------
# Every key has a documented range


def test_the_default_is_inside_every_range_with_room():
    """The paper default passes every bound, and its costs are far inside the limits."""
    from lathe_mirror.config import load
    from lathe_mirror.settings import estimate_costs, limits

    settings = load()
    memory, seconds = limits()
    for cost in estimate_costs(settings, settings.mirror()):
        assert cost.bytes < memory / 4 and cost.seconds < seconds / 10, cost
