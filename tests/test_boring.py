"""The mount's bore (issue 32): a centre drill, a drill and a boring bar, each on its own
station in every control's tool data, rs274 running the second set-up with the tool
table the project writes, the volumes the drills remove against hand calculations, and
the refusals (a bore the bar does not fit, a bar standing out too far, a drill point
near the optic: before the stock is simulated; a short grip)."""

from __future__ import annotations

import math
import os
import re
import subprocess

import pytest

from conftest import FRESH, require_program, run_cli
from lathe_mirror.config import load
from lathe_mirror.export.gcode import format_program, offset_table, sheet_tools
from lathe_mirror.shop.programs import shop_programs
from lathe_mirror.toolpath import Strategy

#: By hand, on the paper default: the boring bar's minimum bore 8 mm (toolpath.boring_bar_
#: min_bore_mm) + 0.5 mm, a stock size -> an 8.5 mm drill with a 118 deg point; the spot
#: drill 90 deg, its spot 0.5 mm wider than the drill; the bore 20 x 6 mm; the back face
#: 0.1 mm (toolpath.max_finish_depth_mm) above Z0 while the bore is cut; lattice 0.005 mm.
DRILL_R, SPOT_R, FA, DEPTH, RES = 4.25, 4.75, 0.1, 6.0, 0.005


@pytest.fixture(scope="module")
def paper():
    settings = load()
    shop, = shop_programs(settings, settings.mirror(), strategies=(Strategy.ARCS,))
    return settings, shop


def test_the_drills_remove_what_their_cones_and_cylinders_hold(paper):
    """The spot: a 90 deg cone of radius SPOT_R (height SPOT_R): pi r^3 / 3. The drill: its
    cylinder from the face down to its full diameter and its point's cone, less what the
    spot took (the spot's cone within the drill's radius: a cylinder 0.5 mm deep, then a
    cone of radius DRILL_R)."""
    _, shop = paper
    ops = {op.name: op for op in shop.second_simulation.operations}
    spot, drill = ops["centre drill"], ops["drill"]
    assert (spot.station, drill.station) == (6, 7)
    assert spot.removed_volume_mm3 == pytest.approx(math.pi * SPOT_R**3 / 3, rel=1e-3)
    h = DRILL_R / math.tan(math.radians(59.0))
    apex = math.floor((-DEPTH + FA - h) / RES + 1e-9) * RES
    whole = math.pi * DRILL_R**2 * (FA - (apex + h)) + math.pi * DRILL_R**2 * h / 3
    overlap = math.pi * (DRILL_R**2 * (SPOT_R - DRILL_R) + DRILL_R**3 / 3)
    assert drill.removed_volume_mm3 == pytest.approx(whole - overlap, rel=1e-3)
    # the boring bar roughs and finishes (station 8), the finish at the finishing feed
    assert ops["bore"].station == ops["finish bore"].station == 8
    assert ops["finish bore"].feed_mm_rev == load().machine.feed_finish
    assert shop.second_simulation.contacts == ()


def test_a_drill_gives_how_deep_it_drilled_not_its_radius(paper):
    """A drill's depth of cut would be its radius whatever the program does (4.25 mm on
    the sheet beside a 0.4 mm facing cut); it is n/a, and the sheet gives what a machinist
    sets a drill by, by hand from the plan: the face stands FA above Z0 when the drills go
    in, the spot drill's point goes SPOT_R below it (a 90 deg cone SPOT_R across at the
    face; its full 10 mm never enters: -), the drill's point to the apex on the lattice,
    0.1 + 8.455 = 8.555 mm, and its full diameter a cone height 4.25 / tan 59 deg less,
    6.0014 mm (6 mm less the floor's 0.1 mm left for the finish, plus the apex's rounding)."""
    from lathe_mirror.export.setup_sheet import setup_sheet_html

    _, shop = paper
    ops = {op.name: op for op in shop.second_simulation.operations}
    h = DRILL_R / math.tan(math.radians(59.0))
    apex = math.floor((-DEPTH + FA - h) / RES + 1e-9) * RES
    assert apex == pytest.approx(-8.455, abs=1e-9)
    spot, drill = ops["centre drill"], ops["drill"]
    assert spot.max_depth_of_cut_mm is None and drill.max_depth_of_cut_mm is None
    # the stock's top after the facing is FA to the simulation's 1e-4 mm
    assert spot.drilled_depth_mm == pytest.approx(SPOT_R, abs=2e-4) and spot.drilled_full_depth_mm is None
    assert drill.drilled_depth_mm == pytest.approx(FA - apex, abs=2e-4)
    assert drill.drilled_full_depth_mm == pytest.approx(FA - apex - h, abs=2e-4)
    assert all(op.drilled_depth_mm is None and op.max_depth_of_cut_mm > 0 for op in ops.values()
               if op.station not in (6, 7))
    page = setup_sheet_html(shop.sheet)
    rows = {m.group(1): m.group(0) for m in re.finditer(r"<tr><td>([a-z ]+)</td><td>T\d</td>.*?</tr>", page)}
    assert "<td class='n'>n/a</td><td class='n'>8.555 / 6.001</td>" in rows["drill"]
    assert "<td class='n'>n/a</td><td class='n'>4.750 / -</td>" in rows["centre drill"]
    assert "<td class='n'>0.400</td><td class='n'></td>" in rows["face back"]  # the facing: the 0.5 mm allowance less the 0.1 left, one level
    assert "drilled 8.56 mm deep to the point" in page and "max depth of cut 4.25" not in page


def test_the_reports_program_table_gives_both_set_ups_and_the_drilled_depth(paper):
    """The report's table of the programs (report.json's shop section as `run` writes it):
    the second set-up's operations under its own name, a drill's depth of cut n/a and its
    drilled depth as on the sheet (the hand values above, the page's 4 decimals)."""
    from lathe_mirror.report.report import programs_table

    _, shop = paper
    row = {"name": shop.program.name, "setup_sheet": f"{shop.program.name}.setup.html", **shop.simulation.figures(),
           "second_setup": {"name": shop.second.name, **shop.second_simulation.figures()}}
    page = programs_table([row])
    assert f"<td>{shop.second.name}</td><td>face back</td>" in page
    h = DRILL_R / math.tan(math.radians(59.0))
    point, full = map(float, re.search(r"<td>drill</td><td>T7</td><td>\d+</td><td>n/a</td><td>([\d.]+) / ([\d.]+)</td>",
                                       page).groups())
    assert point == pytest.approx(FA + 8.455, abs=2e-4) and full == pytest.approx(FA + 8.455 - h, abs=2e-4)
    spot = float(re.search(r"<td>centre drill</td><td>T6</td><td>\d+</td><td>n/a</td><td>([\d.]+) / -</td>", page)[1])
    assert spot == pytest.approx(SPOT_R, abs=2e-4)
    total = shop.simulation.cycle_time_s + shop.second_simulation.cycle_time_s
    assert "cycle time of both set-ups" in page and f"<th>{total:.1f}</th>" in page


def test_rs274_runs_the_second_set_up_with_the_written_tool_table(paper, tmp_path):
    """The tools.tbl the project writes beside the programs holds every station both
    set-ups call; rs274 runs the second set-up to its end with it, changing tools in the
    program's order (rs274 names a tool by its row in the table)."""
    _, shop = paper
    name, table = offset_table(sheet_tools([shop]), "linuxcnc")
    assert name == "tools.tbl"
    stations = [int(m) for m in re.findall(r"^T(\d+) ", table, re.M)]
    assert stations == [1, 2, 5, 6, 7, 8]
    (tmp_path / "tools.tbl").write_text(table)
    (tmp_path / "op2.ngc").write_text(format_program(shop.second, "linuxcnc"))
    res = subprocess.run([require_program("rs274"), "-t", str(tmp_path / "tools.tbl"), "-g",
                          str(tmp_path / "op2.ngc")], capture_output=True, text=True, cwd=tmp_path,
                         env=dict(os.environ, HOME=str(tmp_path)), timeout=120)
    assert res.returncode == 0 and "PROGRAM_END" in res.stdout, res.stderr[-2000:]
    rows = [int(k) for k in re.findall(r"CHANGE_TOOL\((\d+)\)", res.stdout)]
    assert [stations[k - 1] for k in rows] == [1, 6, 7, 8, 8, 2]
    # the drills go down the axis only; the bar's finishing pass runs down the wall at
    # X = D - 2 rho (the nose's +X side on the 20 mm wall) to the floor's nose centre
    feeds = [(float(x), float(z)) for x, z in re.findall(r"STRAIGHT_FEED\(([-\d.]+), [-\d.]+, ([-\d.]+)", res.stdout)]
    assert (19.6 / 2, -DEPTH + 0.2) in [(round(x, 4), round(z, 4)) for x, z in feeds]


def test_fanuc_and_siemens_carry_the_bore_tools_in_their_form(paper):
    _, shop = paper
    tools = sheet_tools([shop])
    _, fanuc = offset_table(tools, "fanuc")
    for k in (6, 7, 8):
        assert f"G10 P1000{k} R" in fanuc
    assert "G10 P10008 R0.2 Q0" in fanuc and "G10 P10007 R0.0 Q0" in fanuc
    nc = format_program(shop.second, "fanuc")
    assert all(f"T0{k}0{k}" in nc for k in (6, 7, 8))
    _, ini = offset_table(tools, "siemens")
    # Siemens' tool types: 220 centre drill, 200 twist drill, 500 the boring bar (a turning tool)
    assert "$TC_DP1[6,1]=220" in ini and "$TC_DP1[7,1]=200" in ini and "$TC_DP1[8,1]=500" in ini
    mpf = format_program(shop.second, "siemens")
    assert all(f'T="T{k}" D1' in mpf for k in (6, 7, 8))


def test_the_sheet_lists_the_bore_tools_with_hand_and_spindle(paper):
    _, shop = paper
    sec = shop.sheet.second
    by = {t.station: t for t in sec.tools}
    assert set(by) >= {6, 7, 8}
    assert "min bore 8 mm" in by[8].holder and "RIGHT hand" in by[8].holder and "overhang 8 mm" in by[8].holder
    assert all(by[k].spindle.startswith("M3") for k in (6, 7, 8))
    assert any("drilled hole" in line for line in sec.touch_off)


def _no_simulation(monkeypatch):
    """The stock simulation (shop.stock.simulate_program, as shop.programs calls it) made to
    fail the test: a refusal that comes after it is not up front."""
    def simulated(*args, **kwargs):
        raise AssertionError("the stock was simulated before the refusal")

    monkeypatch.setattr("lathe_mirror.shop.programs.simulate_program", simulated)
    monkeypatch.setattr("lathe_mirror.shop.stock.simulate_program", simulated)


#: A 26 mm deep, 10 mm bore (the 7 mm shank stands 28 mm out: 4 x 7, allowed) in the 30 mm
#: body: the drill's point, its apex on the lattice, by hand, from the vertex at Z-30.
DEEP_APEX = math.floor((-26.0 + FA - DRILL_R / math.tan(math.radians(59.0))) / RES + 1e-9) * RES


@pytest.mark.skipif(FRESH, reason="the simulation is monkeypatched in this process")
@pytest.mark.parametrize("text, phrase", [
    # the drill the bar enters (8.5 mm) + 2 x (0.1 finish + 0.2 nose + 0.25 clearance) = 9.6 mm
    ("[cad]\nmount_diameter = 9.0\n", "cad.mount_diameter = 9 mm: the bore is drilled 8.5 mm for the boring bar"),
    ("[toolpath]\nboring_bar_min_bore_mm = 19.0\n", "allowed >= 20.6 mm"),
    # overhang: the 6 mm depth + 2 mm clearance = 8 mm, more than 4 x a 1.5 mm shank (6 mm)
    ("[toolpath]\nboring_bar_shank_mm = 1.5\n", "cad.mount_depth = 6 mm: the boring bar would stand 8 mm out"),
    ("[toolpath]\nboring_bar_shank_mm = 7.5\n", "toolpath.boring_bar_shank_mm = 7.5 mm"),
    # the drill's point 30 + DEEP_APEX (1.545) mm from the optic, under cad.min_wall = 2 mm
    ("[cad]\nmount_depth = 26.0\nmount_diameter = 10.0\n[toolpath]\nboring_bar_shank_mm = 7.0\n",
     "cad.mount_depth = 26 mm: the 8.5 mm drill's point would come "),
])
def test_a_bore_the_shop_cannot_do_is_refused_before_the_simulation(tmp_path, monkeypatch, text, phrase):
    """`toolpath` refuses the bore's tools (shop.boring.bore_plan) from the plan, before it
    simulates the stock (shop.programs.plan_checks, as `run` does)."""
    _no_simulation(monkeypatch)
    cfg = tmp_path / "c.toml"
    cfg.write_text(text)
    res = run_cli("toolpath", "--config", str(cfg), "-o", str(tmp_path / "p.ngc"))
    err = res.stderr.strip().splitlines()
    assert res.returncode == 2 and len(err) == 1 and phrase in err[0], res.stderr
    assert "Traceback" not in res.stderr and not (tmp_path / "p.ngc").exists()
    if "drill's point" in phrase:
        wall = float(re.search(r"would come ([\d.]+) mm from the optical surface", err[0])[1])
        assert wall == pytest.approx(30.0 + DEEP_APEX, abs=0.006) and wall < 2.0
        assert "cad.min_wall = 2 mm" in err[0]


def test_a_short_grip_is_refused(tmp_path):
    """The second set-up's grip comes from the parted part (after the first simulation)."""
    cfg = tmp_path / "c.toml"
    # the paper default grips 7.22 mm (the shoulder at Z-10.222 to the jaws' end at Z-3)
    cfg.write_text("[toolpath]\nmin_grip_mm = 8.0\n")
    res = run_cli("toolpath", "--config", str(cfg), "-o", str(tmp_path / "p.ngc"))
    err = res.stderr.strip().splitlines()
    assert res.returncode == 2 and len(err) == 1, res.stderr
    assert "7.22 mm; allowed a thickness that leaves at least 8.00 mm" in err[0], res.stderr
    assert "Traceback" not in res.stderr and not (tmp_path / "p.ngc").exists()


def test_run_refuses_a_bore_the_bar_does_not_fit_before_any_work(tmp_path):
    """`run` checks the bore's tools with the programs' plan (shop.programs.plan_checks),
    before it designs, renders or writes anything."""
    cfg = tmp_path / "c.toml"
    cfg.write_text("[cad]\nmount_diameter = 9.0\n")
    res = run_cli("run", "--config", str(cfg), "-o", str(tmp_path / "out"))
    err = res.stderr.strip().splitlines()
    assert res.returncode == 2 and len(err) == 1 and "cad.mount_diameter = 9 mm" in err[0], res.stderr
    assert not (tmp_path / "out").exists()


def test_every_set_up_grips_at_least_the_configured_length(tmp_path):
    """toolpath.min_grip_mm = 12 mm: the paper default's second set-up (7.22 mm) is refused
    (test above); a 36 mm body gives its soft jaws 13.22 mm (7.22 + 6, the shoulder stays
    where the rim is) and passes, and the first set-up's jaws take 12 mm of the bar, not
    10: the blank is the 41 mm stick-out (stock.length 40 + face 1) plus 12 mm."""
    cfg = tmp_path / "c.toml"
    cfg.write_text("[toolpath]\nmin_grip_mm = 12.0\n[cad]\nthickness = 36.0\n")
    settings = load(cfg)
    shop, = shop_programs(settings, settings.mirror(), strategies=(Strategy.ARCS,))
    assert shop.sheet.stock["grip_mm"] == 12.0 and shop.sheet.stock["blank_length_mm"] == pytest.approx(53.0)
    assert shop.sheet.second.grip_mm == pytest.approx(13.2215, abs=1e-3)
    assert shop.sheet.second.min_grip_mm == 12.0
