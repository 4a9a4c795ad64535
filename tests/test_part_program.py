"""The complete part program of issue 21: the path tolerance (LinuxCNC G64 P Q, as rs274
reads it back), the Fanuc program's G54 and its return to the reference position before
the first tool change (read back by the replay), the finishing stock taken in passes no
deeper than [toolpath] max_finish_depth_mm (the stock simulation measures each pass), the
optional spring pass; on the paper default (the committed programs) and on a design whose
outer lobe is recessed (conftest.RECESSED_OUTER) with its own knobs."""

from __future__ import annotations

import os
import re
import subprocess
from pathlib import Path

import pytest

from conftest import RECESSED_OUTER, require_program, run_cli
from lathe_mirror.config import load
from lathe_mirror.export.dialects import DIALECTS
from lathe_mirror.shop.replay import read_program

REPO = Path(__file__).resolve().parents[1]


def rs274(tmp_path: Path, program: Path) -> str:
    """LinuxCNC's interpreter on a written program with the tool table written beside it
    (a program that calls a tool the table lacks stops at "Requested tool N not found")."""
    exe = require_program("rs274")
    table = program.parent / "tools.tbl"
    assert table.is_file(), f"no tools.tbl beside {program}"
    res = subprocess.run([exe, "-t", str(table), "-g", str(program)], capture_output=True,
                         text=True, cwd=tmp_path, env=dict(os.environ, HOME=str(tmp_path)), timeout=120)
    assert res.returncode == 0, res.stdout[-2000:] + res.stderr[-2000:]
    return res.stdout


@pytest.mark.parametrize("name", ["mirror_paper.ngc", "mirror_arcs.ngc"])
def test_committed_linuxcnc_programs_carry_the_path_tolerance(tmp_path, name):
    tol = load().toolpath.path_tolerance_mm
    text = (REPO / "gcode" / name).read_text()
    assert f"G64 P{tol:g} Q{tol:g}" in text
    out = rs274(tmp_path, REPO / "gcode" / name)
    # rs274's own reading: continuous mode within the tolerance, collinear merging within it
    mode = re.search(r"SET_MOTION_CONTROL_MODE\(CANON_CONTINUOUS, ([\d.]+)\)", out)
    cam = re.search(r"SET_NAIVECAM_TOLERANCE\(([\d.]+)\)", out)
    assert mode and float(mode.group(1)) == pytest.approx(tol) and cam and float(cam.group(1)) == pytest.approx(tol)
    # before the first motion
    lines = out.splitlines()
    first_move = min(i for i, ln in enumerate(lines) if "STRAIGHT_" in ln)
    assert min(i for i, ln in enumerate(lines) if "SET_MOTION_CONTROL_MODE(CANON_CONTINUOUS" in ln) < first_move


@pytest.mark.parametrize("name", ["mirror_paper.nc", "mirror_arcs.nc"])
def test_committed_fanuc_programs_set_g54_and_return_before_the_first_tool(name):
    lines = (REPO / "gcode" / name).read_text().splitlines()
    first_tool = next(i for i, ln in enumerate(lines) if re.match(r"N\d+ T\d{4}$", ln))
    head = [re.sub(r"\([^)]*\)", "", ln).strip() for ln in lines[:first_tool]]
    assert any("G54" in ln.split() for ln in head)
    assert head.index("G28 W0") < head.index("G28 U0")  # Z first, away from the face
    assert any("LOOK-AHEAD" in ln for ln in lines[:first_tool])  # the accuracy mode is noted
    # the replay (toolpath --check) takes the return and simulates the rest
    settings = load()
    ops = read_program((REPO / "gcode" / name).read_text(), settings.machine, DIALECTS["fanuc"], source=name)
    # the finishing tool, then the parting blade (the part-off)
    assert [op.station for op in ops][:3] == [1, 1, 1] and [op.station for op in ops][-2:] == [2, 5]


def test_g28_elsewhere_is_refused():
    settings = load()
    text = re.sub(r"^(N\d+ M30)$", "G28 U0\n\\1", (REPO / "gcode" / "mirror_arcs.nc").read_text(), flags=re.M)
    assert "G28 U0\nN" in text
    with pytest.raises(Exception, match="G28"):
        read_program(text, settings.machine, DIALECTS["fanuc"], source="edited.nc")


def test_recessed_outer_with_its_own_path_tolerance_finish_depth_and_spring_pass(tmp_path):
    cfg = tmp_path / "outer.toml"
    cfg.write_text(RECESSED_OUTER + "[toolpath]\npath_tolerance_mm = 0.002\nmax_finish_depth_mm = 0.05\n"
                   "spring_pass = true\n")
    res = run_cli("toolpath", "--config", str(cfg), "--json", "-o", str(tmp_path) + "/")
    assert res.returncode == 0, res.stderr
    import json

    data = json.loads(res.stdout)
    ops = data["shop"]["operations"]
    assert data["shop"]["contacts"] == []
    names = [op["name"] for op in ops]
    assert names[:3] == ["face", "rough", "semi-finish"] and names[-3:] == ["finish", "spring pass", "part-off"]
    finishing = [op for op in ops if op["name"].startswith("finish")]
    # 0.15 mm of allowance at most 0.05 mm a pass: at least 3 passes, each within the limit
    assert len(finishing) >= 3
    assert all(op["max_depth_of_cut_mm"] <= 0.05 + 1e-6 for op in finishing)
    assert ops[-2]["removed_volume_mm3"] < 1.0  # the spring pass cuts (nearly) air
    ngc = tmp_path / "mirror_arcs.ngc"
    assert "G64 P0.002 Q0.002" in ngc.read_text()
    out = rs274(tmp_path, ngc)
    assert "PROGRAM_END" in out and "SET_MOTION_CONTROL_MODE(CANON_CONTINUOUS, 0.002000)" in out
    assert out.count("CHANGE_TOOL(4)") == len(finishing) + 1  # each pass restartable, the spring pass


def test_set_up_sheet_lists_every_operation_the_touch_off_and_the_inspection(tmp_path):
    page = (REPO / "gcode" / "mirror_arcs.setup.html").read_text()
    ops = re.findall(r"<tr><td>([^<]+)</td><td>T\d</td><td>N\d+</td>", page)
    nc = (REPO / "gcode" / "mirror_arcs.nc").read_text()
    # face, rough, semi-finish, the finishing passes, the part-off; the second set-up's face back, the
    # bore (centre drill, drill, the boring bar's roughing and finish) and the finishing pass on the
    # back face (the face the mirror mounts on)
    assert len(ops) == 3 + len(re.findall(r"^\((?:FINISH PASS \d|FINISH:)", nc, re.M)) + 1 + 6
    assert ops[-7:] == ["part-off", "face back", "centre drill", "drill", "bore", "finish bore", "finish back"]
    assert "test recess" in page  # the X touch-off on a surface the operator cuts first
    rows = re.findall(r"<tr><td>(inner|outer)</td><td class='n'>([\d.]+)</td><td class='n'>(-?[\d.]+)</td>"
                      r"<td class='n'>([\d.]+)</td>", page)
    assert {r[0] for r in rows} == {"inner", "outer"} and len(rows) >= 10
    m = load().mirror()
    for lobe_name, r, z, sag in rows:
        lobe = m.inner if lobe_name == "inner" else m.outer
        r = float(r)
        # the machine Z of the lobe at r from the hyperbola: Z = vertex - z(r)
        assert float(z) == pytest.approx(m.vertex_z - float(lobe.z(r)), abs=2e-6)
        assert float(sag) == pytest.approx(lobe.a * ((1 + (r / lobe.b) ** 2) ** 0.5 - 1), abs=2e-6)
