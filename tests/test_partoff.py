"""The complete part program of issue 21, its last part: the part-off with the parting
blade (T5) in the first set-up and the second set-up that faces the back and cuts the
mount (bore or boss, as the CAD body has it). rs274 reads every program; the stock
simulation (with the blade's own shape) finds no contact in either set-up and ends with
the part separated; the finished part, measured on the simulated stock after both
set-ups, has the CAD body's meridian (body.design_meridian, the STEP writer's) within the
lattice. On the paper default (the committed programs), the outer-recessed design
(conftest.RECESSED_OUTER) and the paper mirror with `[cad] mount = "boss"`."""

from __future__ import annotations

import math
import os
import re
import subprocess
from pathlib import Path

import pytest
import shapely

from conftest import RECESSED_OUTER, require_program
from lathe_mirror.body import BodySpec, design_meridian
from lathe_mirror.config import load
from lathe_mirror.enums import Mount
from lathe_mirror.export.dialects import DIALECTS
from lathe_mirror.errors import InputError
from lathe_mirror.export.gcode import format_program
from lathe_mirror.export.setup_sheet import setup_sheet_html
from lathe_mirror.lathe import Stock
from lathe_mirror.path import Line
from lathe_mirror.shop import plan_program
from lathe_mirror.shop.programs import shop_programs
from lathe_mirror.shop.replay import read_program
from lathe_mirror.shop.second import reverse
from lathe_mirror.shop.stock import SimMove, SimOperation, simulate, simulate_setup
from lathe_mirror.shop.tool_shapes import blade_shape
from lathe_mirror.toolpath import Strategy

REPO = Path(__file__).resolve().parents[1]
TOOLS = ("".join(f"T{k} P{k} X0 Z0 D0.4 Q9\n" for k in (1, 2, 3, 4)) + "T5 P5 X0 Z0 D0\n"
         + "T6 P6 X0 Z0 D0\nT7 P7 X0 Z0 D0\nT8 P8 X0 Z0 D0.4 Q9\n")
#: The bore's drill (shop.boring), by hand: the boring bar's minimum bore (8 mm) plus 0.5 mm,
#: a stock size; its 118 deg point's height (d / 2) / tan(59 deg).
DRILL_MM = 8.5
DRILL_CONE_MM = DRILL_MM / 2 / math.tan(math.radians(59.0))
DESIGNS = {"paper": None, "recessed": RECESSED_OUTER, "boss": '[cad]\nmount = "boss"\n'}


@pytest.fixture(scope="module", params=sorted(DESIGNS))
def made(request, tmp_path_factory):
    """(name, settings, mirror, the checked arcs program with its second set-up)."""
    text = DESIGNS[request.param]
    path = None
    if text is not None:
        path = tmp_path_factory.mktemp(request.param) / "c.toml"
        path.write_text(text)
    settings = load(path)
    mirror = settings.mirror()
    shop, = shop_programs(settings, mirror, strategies=(Strategy.ARCS,))
    return request.param, settings, mirror, shop


def rs274(tmp_path: Path, text: str) -> str:
    exe = require_program("rs274")
    (tmp_path / "tools.tbl").write_text(TOOLS)
    (tmp_path / "p.ngc").write_text(text)
    res = subprocess.run([exe, "-t", str(tmp_path / "tools.tbl"), "-g", str(tmp_path / "p.ngc")],
                         capture_output=True, text=True, cwd=tmp_path, env=dict(os.environ, HOME=str(tmp_path)),
                         timeout=120)
    assert res.returncode == 0, res.stdout[-2000:] + res.stderr[-2000:]
    return res.stdout


def feeds(out: str) -> list[tuple[float, float]]:
    """(r, Z) mm of every STRAIGHT_FEED rs274 reports (X, Y, Z in the canonical call)."""
    pts = re.findall(r"STRAIGHT_FEED\(([-\d.]+), [-\d.]+, ([-\d.]+)", out)
    return [(float(x), float(z)) for x, z in pts]


def test_both_set_ups_touch_nothing_and_the_part_comes_off(made):
    name, settings, mirror, shop = made
    body, opts = settings.body, settings.toolpath
    assert shop.simulation.contacts == () and shop.second_simulation.contacts == ()
    *_, parting = shop.simulation.operations
    assert parting.name == "part-off" and parting.station == 5
    # the blade's slot through the whole bar, by hand: pi R^2 w
    assert parting.removed_volume_mm3 == pytest.approx(math.pi * settings.stock.radius**2 * opts.parting_width_mm,
                                                       rel=1e-4)
    # the part comes off at the body's length (+ the boss) + the back's allowance
    length = body.thickness + (body.mount_depth if body.mount is Mount.BOSS else 0.0)
    assert shop.simulation.parted.bounds[1] == pytest.approx(-(length + opts.back_allowance_mm), abs=0.005)
    ops2 = [op.name for op in shop.second_simulation.operations]
    bore = ["centre drill", "drill", "bore", "finish bore", "finish back"]
    assert ops2 == ["face back", *{"paper": bore, "recessed": bore, "boss": ["boss", "finish mount"]}[name]]
    # the turning tools' depth of cut within the roughing depth (a drill has none: n/a, its drilled depth instead)
    assert all(op.max_depth_of_cut_mm <= opts.rough_depth + 0.01 for op in shop.second_simulation.operations
               if op.station not in (6, 7))
    # the mount's face finished by the finishing tool (station 2, or 4 in the opposite hand) at the
    # finishing feed, one pass of toolpath.max_finish_depth_mm
    fin = shop.second_simulation.operations[-1]
    assert fin.station == (4 if name == "boss" else 2) and fin.feed_mm_rev == settings.machine.feed_finish
    if body.mount is Mount.BORE:
        assert fin.max_depth_of_cut_mm == pytest.approx(opts.max_finish_depth_mm, abs=0.01)  # the annulus from the bore to the part's rim, that thick: pi (R^2 - rm^2) fa
        R, rm = shop.second.setup.diameter / 2, body.mount_diameter / 2
        want = math.pi * (R**2 - rm**2) * opts.max_finish_depth_mm
        assert fin.removed_volume_mm3 == pytest.approx(want, rel=0.02)
    else:  # the ring's face and the boss's wall; the roughing nose's fillet in the root corner besides
        assert opts.max_finish_depth_mm - 0.01 <= fin.max_depth_of_cut_mm <= (
            opts.max_finish_depth_mm + settings.tool.nose_radius)


def line_extent(geom, a, b) -> tuple[float, float, float, float]:
    return geom.intersection(shapely.LineString([a, b])).bounds


def test_the_finished_part_is_the_cad_body(made):
    """The stock after both set-ups against the CAD body's meridian (reversed into the
    second set-up's frame): the vertex, the back face, the mount's diameter and depth or
    length, each measured on the same line through both, agree within the lattice."""
    name, settings, mirror, shop = made
    body, res = settings.body, settings.machine.resolution
    made_part = shop.second_simulation.operations[-1].stock_after
    cad = reverse(shapely.Polygon(design_meridian(mirror, body).polyline(1e-4)).buffer(0), body.thickness)
    rm, R = body.mount_diameter / 2, body.blank_diameter / 2
    # the vertex on the axis; the bore's floor beside the drill's point (between the drilled
    # hole and the wall), the boss's end on the axis
    r_floor = 0.5 * (DRILL_MM / 2 + rm) if body.mount is Mount.BORE else 0.01
    lines = {"axis": ((0.01, -100.0), (0.01, 100.0)), "floor": ((r_floor, -100.0), (r_floor, 100.0)),
             "back": ((0.5 * (rm + R), -100.0), (0.5 * (rm + R), 100.0))}
    mid = -body.mount_depth / 2 if body.mount is Mount.BORE else body.mount_depth / 2
    lines["mount"] = ((0.0, mid), (R + 5.0, mid))
    got = {k: line_extent(made_part, *ln) for k, ln in lines.items()}
    want = {k: line_extent(cad, *ln) for k, ln in lines.items()}
    # the vertex at Z = -thickness (the first set-up's finishing, within its gouge tolerance)
    assert got["axis"][1] == pytest.approx(want["axis"][1], abs=settings.toolpath.gouge_tolerance + 1e-4)
    assert want["axis"][1] == pytest.approx(-body.thickness, abs=1e-4)  # the sag at r = 0.01 mm: 2e-5 mm
    # the mount's floor (bore) or end (boss), and the back face
    assert got["floor"][3] == pytest.approx(want["floor"][3], abs=res)
    if body.mount is Mount.BORE:  # the drill's point below the floor: its apex on the axis, by hand
        fa = settings.toolpath.max_finish_depth_mm
        apex = math.floor((-body.mount_depth + fa - DRILL_CONE_MM) / res + 1e-9) * res
        assert got["axis"][3] == pytest.approx(apex + 0.01 / math.tan(math.radians(59.0)), abs=1e-6)  # r = 0.01
    else:
        assert got["axis"][3] == pytest.approx(want["axis"][3], abs=res)
    assert got["back"][3] == pytest.approx(want["back"][3], abs=res)
    assert want["back"][3] == pytest.approx(0.0, abs=1e-9)
    # the mount's diameter at its mid depth (length): the bore's wall is where the stock
    # begins along the line, the boss's where it ends
    k = 0 if body.mount is Mount.BORE else 2
    assert got["mount"][k] == pytest.approx(want["mount"][k], abs=res)
    assert want["mount"][k] == pytest.approx(rm, abs=1e-9)
    assert want["floor"][3] == pytest.approx(-body.mount_depth if body.mount is Mount.BORE else body.mount_depth)


def test_rs274_reads_both_set_ups_and_the_fanuc_ones_replay_clean(made, tmp_path):
    name, settings, mirror, shop = made
    body, opts = settings.body, settings.toolpath
    one = format_program(shop.program, "linuxcnc")
    two = format_program(shop.second, "linuxcnc")
    if name == "paper":  # the committed files are these
        assert (REPO / "gcode" / "mirror_arcs_op2.ngc").read_text() == two
    out1 = rs274(tmp_path, one)
    # the part-off: rs274's last feed ends on the axis at the blade's Z (its chuck-side corner)
    length = body.thickness + (body.mount_depth if body.mount is Mount.BOSS else 0.0)
    r, z = feeds(out1)[-1]
    assert r == pytest.approx(0.0, abs=1e-6)
    assert z == pytest.approx(-(length + opts.back_allowance_mm + opts.parting_width_mm), abs=0.005)
    assert "CHANGE_TOOL(5)" in out1
    out2 = rs274(tmp_path, two)
    assert "SET_MOTION_CONTROL_MODE(CANON_CONTINUOUS" in out2  # G64 P in the second program too
    # the Fanuc second program: its own number, G54, Z then X to the reference before the tool
    nc = format_program(shop.second, "fanuc")
    lines = nc.splitlines()
    assert lines[1].startswith("O1001") and "G18 G40 G97 G99 G54" in lines
    assert lines.index("G28 W0") < lines.index("G28 U0") < min(i for i, ln in enumerate(lines) if "T0" in ln
                                                              and not ln.startswith("("))
    # read back (toolpath --check's reader) and replayed against the second set-up's stock
    ops = read_program(nc, settings.machine, DIALECTS["fanuc"], source="op2.nc")
    su = shop.second.setup
    sim = simulate_setup(ops, su.shapes, settings.machine, su.start, su.part, su.chuck,
                         rapid_rate=opts.rapid_rate, gouge_tolerance=opts.gouge_tolerance)
    assert sim.contacts == ()
    assert sum(o.removed_volume_mm3 for o in sim.operations) == pytest.approx(
        sum(o.removed_volume_mm3 for o in shop.second_simulation.operations), rel=1e-6)


def test_the_set_up_sheet_lists_both_set_ups():
    page = (REPO / "gcode" / "mirror_arcs.setup.html").read_text()
    assert "Second set-up" in page and "mirror_arcs_op2.ngc" in page and "mirror_arcs_op2.nc" in page
    for words in ("part-off", "T5 / T0505", "parting blade", "soft jaws", "Z0 on the finished back face",
                  "face back", "bore", "the parted face", "unchanged from the first set-up"):
        assert words in page, words


def test_a_part_off_short_of_the_axis_leaves_the_part_on(paper_mirror):
    """The check can fail: a blade stopping 1 mm short of the axis leaves the part joined
    ("attached"); a blade moved sideways into the bar touches it with its side ("body")."""
    settings = load()
    stock, tool, lathe = settings.stock, settings.tool, settings.machine
    z, w = -33.5, 3.0

    def sim(moves):
        op = SimOperation("part-off", 5, tuple(SimMove(False, Line(a, b), 0.05, f"N{k}")
                                               for k, (a, b) in enumerate(moves, 1)))
        return simulate([op], paper_mirror, tool, lathe, stock, rapid_rate=5000.0, gouge_tolerance=0.005,
                        shapes={5: blade_shape(w)}, parting=(z, w))

    assert sim([((40.0, z), (0.0, z))]).contacts == ()
    short = sim([((40.0, z), (1.0, z))])
    assert [c.kind for c in short.contacts] == ["attached"]
    assert "joined to the bar" in short.contacts[0].message()
    side = sim([((30.0, z - 5.0), (30.0, z))])  # the blade's tip 8 mm into the bar, moved up along Z
    assert "body" in [c.kind for c in side.contacts]


def test_a_bar_too_short_to_part_off_is_refused(paper_mirror):
    from lathe_mirror.lathe import Lathe, Tool
    from lathe_mirror.toolpath import plan_toolpath

    tp = plan_toolpath(paper_mirror, Lathe(), Tool(), Strategy.ARCS)
    with pytest.raises(InputError, match=r"stock.length = 33 mm: .* allowed >= 33.5 mm"):
        plan_program(tp, Stock(length=33.0), body=BodySpec())


def test_check_replays_the_second_set_up_against_the_parted_part(tmp_path):
    """`toolpath --check` knows a second set-up's program by its first operation and replays it
    against the part the configured program parts off (reversed): the committed one is
    clean; its bore's wall moved 0.5 mm out (X19.6 -> X20.6, past the CAD's 20 mm) cuts
    into the finished part and is refused with one line naming the block."""
    import json

    from conftest import run_cli

    res = run_cli("toolpath", "--check", str(REPO / "gcode" / "mirror_arcs_op2.nc"), "--json")
    assert res.returncode == 0, res.stderr
    data = json.loads(res.stdout)
    # face back, centre drill, drill, bore, finish bore, finish back
    assert data["contacts"] == [] and len(data["operations"]) == 6
    bad = tmp_path / "bad_op2.ngc"
    bad.write_text((REPO / "gcode" / "mirror_arcs_op2.ngc").read_text().replace("X19.600", "X20.600"))
    res = run_cli("toolpath", "--check", str(bad))
    assert res.returncode == 2 and "Traceback" not in res.stderr
    err = res.stderr.strip().splitlines()
    assert len(err) == 1 and "cuts into the finished part" in err[0] and "X20.600" in err[0]
