"""The whole lathe program against the stock: the simulation (shapely), the planner's
shop conventions and the set-up sheet, checked against rs274's canonical moves, closed
forms and hand calculations written out here."""

from __future__ import annotations

import dataclasses
import math
import os
import re
import subprocess
from pathlib import Path

import numpy as np
import pytest

from conftest import require_program, run_cli
from lathe_mirror.errors import InputError
from lathe_mirror.export.gcode import format_program
from lathe_mirror.lathe import Lathe, Stock, Tool
from lathe_mirror.path import Arc, Line
from lathe_mirror.shop import plan_program
from lathe_mirror.shop.programs import shop_program
from lathe_mirror.toolpath import ToolpathSettings
from lathe_mirror.shop.program import Rapid
from lathe_mirror.shop.stock import SimMove, SimOperation, simulate, simulate_program
from lathe_mirror.shop.tool_shapes import blade_shape
from lathe_mirror.toolpath import Strategy, plan_toolpath

REPO = Path(__file__).resolve().parents[1]
LATHE, STOCK, TOOL = Lathe(), Stock(), Tool()
OPTIONS = ToolpathSettings()
#: The roughing feed: machine.feed_rough, at most half the nose radius per revolution.
ROUGH_FEED = min(LATHE.feed_rough, TOOL.nose_radius / 2)
#: Every station's row (rs274 reports a tool change by its row in the table), T5 the blade.
TOOLS = "".join(f"T{k} P{k} X0 Z0 D0.4 Q9\n" for k in (1, 2, 3, 4)) + "T5 P5 X0 Z0 D0\n"


def rs274(tmp_path: Path, text: str, tools: str = TOOLS) -> str:
    exe = require_program("rs274")
    (tmp_path / "prog.ngc").write_text(text)
    (tmp_path / "tools.tbl").write_text(tools)
    res = subprocess.run([exe, "-t", str(tmp_path / "tools.tbl"), "-g", str(tmp_path / "prog.ngc")],
                         capture_output=True, text=True, cwd=tmp_path, timeout=60,
                         env=dict(os.environ, HOME=str(tmp_path)))
    assert res.returncode == 0 and "PROGRAM_END" in res.stdout, res.stdout[-2000:] + res.stderr[-2000:]
    return res.stdout


def canonical(out: str) -> list[dict]:
    """rs274's canonical output as events: moves (kind, end (r, Z), centre, rotation,
    block N), feed rate (mm/rev), spindle cap and speed, tool changes, tool offsets."""
    events = []
    for ln in out.splitlines():
        m = re.match(r"\s*\d+\s+N(\S*)\s+(\w+)\((.*)\)", ln)
        if not m:
            continue
        n, name, args = m.group(1), m.group(2), m.group(3)
        nums = [float(x) for x in re.findall(r"-?\d+\.\d+|-?\d+", args)]
        if name in ("STRAIGHT_TRAVERSE", "STRAIGHT_FEED"):
            events.append({"kind": name, "end": (nums[0], nums[2]), "n": n})
        elif name == "ARC_FEED":  # XZ plane: first axis Z, second X; rotation +1 = G3
            events.append({"kind": name, "end": (nums[1], nums[0]), "centre": (nums[3], nums[2]),
                           "rotation": int(nums[4]), "n": n})
        elif name in ("SET_FEED_RATE", "CHANGE_TOOL"):
            events.append({"kind": name, "value": nums[-1]})
        elif name == "SET_SPINDLE_MODE":
            events.append({"kind": name, "value": nums[-1]})
        elif name == "SET_SPINDLE_SPEED":
            events.append({"kind": name, "value": nums[-1]})
        elif name == "USE_TOOL_LENGTH_OFFSET":
            events.append({"kind": name, "x": nums[0], "z": nums[2]})
    return events


def arc_points(start, ev, n: int) -> np.ndarray:
    """n points along an ARC_FEED as LinuxCNC cuts it (radius linear in the angle)."""
    c = np.array(ev["centre"])
    a0 = math.atan2(start[1] - c[1], start[0] - c[0])
    a1 = math.atan2(ev["end"][1] - c[1], ev["end"][0] - c[0])
    sweep = a1 - a0
    if ev["rotation"] > 0:  # clockwise in (r, Z)
        while sweep >= 0:
            sweep -= 2 * math.pi
    else:
        while sweep <= 0:
            sweep += 2 * math.pi
    r0, r1 = np.hypot(*(np.array(start) - c)), np.hypot(*(np.array(ev["end"]) - c))
    t = np.linspace(0, 1, n)
    return c + (r0 + (r1 - r0) * t)[:, None] * np.stack([np.cos(a0 + sweep * t), np.sin(a0 + sweep * t)], -1)


def replay(events: list[dict], start=(50.0, 50.0)) -> list[SimOperation]:
    """rs274's moves as the simulation's operations, one per tool change; the program's
    first two moves go home from where the machine is, so the replay starts at home."""
    ops, moves, station, feed, pos = [], [], 0, 0.0, start
    for ev in events:
        if ev["kind"] == "CHANGE_TOOL":
            if moves:
                ops.append(SimOperation(f"T{station}", station, tuple(moves)))
            moves, station = [], int(ev["value"])
        elif ev["kind"] == "SET_FEED_RATE":
            feed = ev["value"]
        elif ev["kind"] == "ARC_FEED":
            mv = Arc(pos, ev["end"], ev["centre"], clockwise=ev["rotation"] < 0)
            moves.append(SimMove(False, mv, feed, f"N{ev['n']}"))
            pos = ev["end"]
        elif ev["kind"] in ("STRAIGHT_TRAVERSE", "STRAIGHT_FEED"):
            if station:
                moves.append(SimMove(ev["kind"] == "STRAIGHT_TRAVERSE", Line(pos, ev["end"]), feed, f"N{ev['n']}"))
            pos = ev["end"]
    ops.append(SimOperation(f"T{station}", station, tuple(moves)))
    return ops


@pytest.fixture(scope="module")
def arcs_shop(paper_mirror):
    return shop_program(plan_toolpath(paper_mirror, LATHE, TOOL, Strategy.ARCS), STOCK, OPTIONS)


# --------------------------------------------------------------------------------------
# The committed programs, replayed from rs274's canonical moves


@pytest.mark.parametrize("name", ["mirror_paper.ngc", "mirror_arcs.ngc"])
def test_committed_programs_touch_nothing(tmp_path, paper_mirror, name):
    """rs274 interprets the committed program; its own moves, replayed against the bar
    with the whole insert (nose and body), touch no stock at rapid (nor would a dog-leg
    rapid), none with the body, never plunge, never cut the part beyond the gouge
    tolerance; each operation removes what a hand count says."""
    events = canonical(rs274(tmp_path, (REPO / "gcode" / name).read_text()))
    # the part-off: the [cad] body's 30 mm, the 0.5 mm back allowance, the 3 mm blade (T5)
    z_cut = -(30.0 + OPTIONS.back_allowance_mm + OPTIONS.parting_width_mm)
    sim = simulate(replay(events), paper_mirror, TOOL, LATHE, STOCK, rapid_rate=OPTIONS.rapid_rate,
                   gouge_tolerance=OPTIONS.gouge_tolerance, shapes={5: blade_shape(OPTIONS.parting_width_mm)},
                   parting=(z_cut, OPTIONS.parting_width_mm))
    assert sim.contacts == ()
    # the part-off cuts the blade's slot through the bar: pi R^2 w; the part is off above it
    *ops, parting = sim.operations
    assert parting.station == 5
    assert parting.removed_volume_mm3 == pytest.approx(math.pi * STOCK.radius**2 * OPTIONS.parting_width_mm, rel=1e-4)
    assert sim.parted.bounds[1] == pytest.approx(z_cut + OPTIONS.parting_width_mm, abs=1e-9)
    # face, rough, semi-finish; the finishing passes (at most max_finish_depth each) and the contour
    assert [op.station for op in ops][:3] == [1, 1, 1] and len(ops) >= 5 and {op.station for op in ops[3:]} == {2}
    assert all(op.max_depth_of_cut_mm <= OPTIONS.max_finish_depth_mm + 1e-6 for op in ops[3:])
    assert all(op.plunge_mm == 0.0 for op in ops)
    assert all(op.max_part_cut_mm <= OPTIONS.gouge_tolerance for op in ops)
    # everything from the bar's face down to the part is gone: pi R^2 (face - Z) - the part's
    # volume above Z, with the lobes written out (Z = vertex - e - a sqrt(1 + r^2 / b^2))
    m = paper_mirror
    r = np.linspace(0.0, STOCK.radius, 200001)
    zi = m.vertex_z - (m.inner.e + m.inner.a * np.sqrt(1 + (r / m.inner.b) ** 2))
    zo = m.vertex_z - (m.outer.e + m.outer.a * np.sqrt(1 + (r / m.outer.b) ** 2))
    z_rim = float(zo[np.searchsorted(r, m.r_max)])
    shoulder = float(paper_shoulder(tmp_path, events))
    top = np.where(r <= 20.0, zi, np.where(r <= m.r_max, zo, shoulder))
    removed = np.trapezoid(2 * np.pi * r * (STOCK.face_allowance - top), r)
    total = sum(op.removed_volume_mm3 for op in ops)
    # what stays: the fillet in the step's corner (0.2 mm nose), the scallops: < 0.1 %
    assert total == pytest.approx(removed, rel=1e-3), (total, removed)
    # the exit faces the shoulder where a nose leaving the rim along its slope s is:
    # rho (1 - 1 / sqrt(1 + s^2)) below the rim, 0.04 mm here; the best program ends up to
    # ~3 lattice steps past the rim (0.015 mm at slope 0.76) and rounds Z on the lattice
    s = m.outer.a * m.r_max / (m.outer.b**2 * math.sqrt(1 + (m.r_max / m.outer.b) ** 2))
    assert 0.0 <= z_rim - shoulder <= TOOL.nose_radius * (1 - 1 / math.hypot(1, s)) + 0.02


def paper_shoulder(tmp_path, events) -> float:
    """The shoulder's height: the last feed move's Z before the part-off (the finishing
    exit) less the nose."""
    end = next((i for i, ev in enumerate(events) if ev["kind"] == "CHANGE_TOOL" and int(ev["value"]) == 5),
               len(events))
    feeds = [ev for ev in events[:end] if ev["kind"] == "STRAIGHT_FEED"]
    return feeds[-1]["end"][1] - TOOL.nose_radius


@pytest.mark.parametrize("rho", [0.0, 0.2])
@pytest.mark.parametrize("strategy", [Strategy.PAPER, Strategy.LATTICE, Strategy.ARCS])
def test_every_strategy_and_nose_is_simulated_clean(paper_mirror, strategy, rho):
    """Every strategy, with a sharp tool and with the paper's nose: planned, simulated
    against the bar, no contact; and the Fanuc program read back from its text replays
    to the same figures (the dialects carry the same moves)."""
    from lathe_mirror.export.dialects import DIALECTS
    from lathe_mirror.shop.replay import read_program

    tool = Tool(nose_radius=rho)
    shop = shop_program(plan_toolpath(paper_mirror, LATHE, tool, strategy), STOCK, OPTIONS, setting_costs={})
    assert shop.simulation.contacts == ()
    fanuc = read_program(format_program(shop.program, "fanuc"), LATHE, DIALECTS["fanuc"])
    sim = simulate(fanuc, paper_mirror, tool, LATHE, STOCK, rapid_rate=OPTIONS.rapid_rate,
                   gouge_tolerance=OPTIONS.gouge_tolerance)
    assert sim.contacts == ()
    assert sim.cycle_time_s == pytest.approx(shop.simulation.cycle_time_s, rel=1e-9)
    for a, b in zip(sim.operations, shop.simulation.operations):
        assert a.removed_volume_mm3 == pytest.approx(b.removed_volume_mm3, rel=1e-6)


def test_facing_removes_the_face_through_the_axis(arcs_shop):
    """The facing level: the nose bottom at the allowance above the vertex, across the
    whole bar: pi R^2 (face allowance - allowance) mm^3, depth of cut the same, chip
    section that times the feed; no stub at the centre for a later plunge."""
    face = arcs_shop.simulation.operations[0]
    depth = STOCK.face_allowance - OPTIONS.rough_allowance
    assert face.name == "face"
    assert face.removed_volume_mm3 == pytest.approx(math.pi * STOCK.radius**2 * depth, rel=2e-3)
    assert face.max_depth_of_cut_mm == pytest.approx(depth, abs=2e-3)
    assert face.max_chip_section_mm2 == pytest.approx(depth * ROUGH_FEED, abs=1e-3)
    stock = face.stock_after
    # flat through X0 (to the nose polygon's lowest vertex: 16 segments a quarter circle)
    assert stock.bounds[3] == pytest.approx(OPTIONS.rough_allowance, abs=1e-3)


def test_roughing_levels_take_the_rough_depth(arcs_shop):
    rough = arcs_shop.simulation.operations[1]
    assert rough.max_depth_of_cut_mm == pytest.approx(OPTIONS.rough_depth, abs=2e-3)
    assert rough.max_chip_section_mm2 == pytest.approx(OPTIONS.rough_depth * ROUGH_FEED, abs=1e-3)
    # 1000 V / (2 pi r) rpm at the largest radius it cuts at full depth: MRR = 2 pi r ap f n
    assert rough.max_removal_rate_cm3_min == pytest.approx(
        OPTIONS.rough_depth * ROUGH_FEED * LATHE.surface_speed, rel=1e-3)


# --------------------------------------------------------------------------------------
# Refusals: today's line 130, the body, a dog-leg


def test_todays_line_130_is_refused_at_the_cli(tmp_path):
    """The program committed before this change (gcode/mirror_arcs.ngc, kept as a test
    file): `G0 X0.000 Z3.000` right after `G0 X80.000 Z-18.000` drives the tool through
    the staircase's corners at rapid. One line, exit 2, naming line 130."""
    old = REPO / "tests" / "data" / "mirror_arcs_before_issue15.ngc"
    assert old.read_text().splitlines()[129] == "G0 X0.000 Z3.000"
    res = run_cli("toolpath", "--check", str(old))
    assert res.returncode == 2
    err = res.stderr.strip().splitlines()
    assert len(err) == 1 and "Traceback" not in res.stderr
    assert "line 130: G0 X0.000 Z3.000" in err[0] and "at rapid" in err[0], err


def test_a_program_with_that_rapid_is_refused(arcs_shop):
    """Today's lines 129-130 (`G0 X80.000 Z-18.000`, `G0 X0.000 Z3.000`) after the last
    roughing level of a planned program: the simulation names the block."""
    prog = arcs_shop.program
    rough = prog.operations[1]
    last = list(rough.motions())[-1].move.end
    bad = (Rapid(Line(last, (40.0, -18.0)), number=9998), Rapid(Line((40.0, -18.0), (0.0, 3.0)), number=9999))
    ops = list(prog.operations)
    ops[1] = dataclasses.replace(rough, blocks=rough.blocks + bad)
    sim = simulate_program(dataclasses.replace(prog, operations=tuple(ops)))
    kinds = {(c.kind, c.label) for c in sim.contacts}
    assert ("rapid", "N9999 G0 X0.000 Z3.000") in kinds
    with pytest.raises(InputError, match=r"^program refused: block N9999 G0 X0.000 Z3.000 \(rough\) "
                                         r"drives the tool through stock at rapid"):
        sim.check()


def test_a_last_bit_drift_of_the_inputs_leaves_the_stock_bit_for_bit(paper_mirror):
    """numpy's AVX-512 sin/cos differ from its AVX2 ones in the last bit, and such a drift
    once doubled a vertex of a set-up sheet's picture (issue 34). The same cuts with the
    nose radius and an arc's centre an ulp off (the tool's outline and the arc's chords
    then differ in their last bits) leave the same stock, coordinate for coordinate."""
    import shapely

    def cut(ulp: bool):
        nudge = (lambda x: float(np.nextafter(x, np.inf))) if ulp else float
        tool = dataclasses.replace(TOOL, nose_radius=nudge(TOOL.nose_radius))
        moves = (Line((40.0, 0.4), (-0.5, 0.4)), Line((-0.5, 0.4), (38.5, 0.3)),
                 Arc((38.5, 0.3), (30.5, 0.3), (34.5, nudge(4.3)), False))
        ops = [SimOperation("t", 1, tuple(SimMove(False, m, 0.15, f"N{i}") for i, m in enumerate(moves)))]
        sim = simulate(ops, paper_mirror, tool, LATHE, STOCK, rapid_rate=5000.0, gouge_tolerance=0.005)
        return sim.operations[0]

    exact, drifted = cut(False), cut(True)
    for geom in ("stock_after", "removed"):
        a, b = (shapely.get_coordinates(getattr(op, geom)) for op in (exact, drifted))
        assert a.shape == b.shape and np.array_equal(a, b), geom
    assert exact.removed_volume_mm3 == drifted.removed_volume_mm3 > 0


def test_a_dogleg_rapid_is_found(paper_mirror):
    """A diagonal rapid whose straight line clears the faced bar, but whose dog-leg (one
    axis first) would run through the bar's edge."""
    ops = [SimOperation("t", 1, (SimMove(True, Line((45.0, -5.0), (30.0, 25.0)), 0.15, "N1"),))]
    sim = simulate(ops, paper_mirror, TOOL, LATHE, STOCK, rapid_rate=5000.0, gouge_tolerance=0.005)
    assert [c.kind for c in sim.contacts] == ["dogleg"]


def test_too_deep_a_level_touches_with_the_body(tmp_path):
    """A 6 mm roughing level: the insert's cutting edge (a quarter of its 16.6 mm edge,
    from the nose) cannot take it, the body rubs; one line naming the block, exit 2."""
    cfg = tmp_path / "deep.toml"
    cfg.write_text("[toolpath]\nrough_depth = 6.0\n")
    res = run_cli("toolpath", "--config", str(cfg), "-o", str(tmp_path / "p.ngc"))
    assert res.returncode == 2
    err = res.stderr.strip().splitlines()
    assert len(err) == 1 and re.search(r"block N\d+ G1 X[\d.]+ Z-5\.650 \(rough\) touches stock with "
                                       r"the insert's body", err[0]), err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["deep.toml"]


@pytest.mark.parametrize("key, value, phrase", [
    ("rough_depth", "0.00001", "toolpath.rough_depth = 1e-05 mm: allowed 0.05 to 10 mm"),
    ("rough_allowance", "1e6", "toolpath.rough_allowance = 1e+06 mm: allowed 0.02 to 2 mm"),
    ("home_z", "1.0", "toolpath.home_z = 1 mm: the end position must be above"),
])
def test_bad_program_options(tmp_path, key, value, phrase):
    cfg = tmp_path / "c.toml"
    cfg.write_text(f"[toolpath]\n{key} = {value}\n")
    res = run_cli("toolpath", "--config", str(cfg), "-o", str(tmp_path / "p.ngc"))
    assert res.returncode == 2 and phrase in res.stderr and len(res.stderr.strip().splitlines()) == 1
    assert not (tmp_path / "p.ngc").exists()


# --------------------------------------------------------------------------------------
# Shop conventions


def test_no_rapid_crosses_the_staircase_and_every_entry_ramps(arcs_shop):
    """Every rapid moves along one axis (retract, then traverse), except none; no feed
    plunges straight down into stock (the pocket and the contour's start are ramped)."""
    prog = arcs_shop.program
    for _, b in prog.motions():
        if isinstance(b, Rapid):
            a, e = b.move.start, b.move.end
            assert a[0] == e[0] or a[1] == e[1], prog.describe(b)
    assert all(op.plunge_mm == 0.0 for op in arcs_shop.simulation.operations)
    text = format_program(prog)
    ramps = re.findall(r"\(pocket r ([\d.]+)\.\.([\d.]+) mm at Z (-?[\d.]+): ramped entry\)", text)
    assert ramps  # the paper mirror has one, under the step's top
    lead = text.split("(finish contour lead-in: ramp onto the start)")[0].splitlines()[-1]
    x, z = map(float, re.search(r"X([\d.]+) Z([\d.]+)", lead).groups())
    start = arcs_shop.program.toolpath.segments[0].start
    slope = math.degrees(math.atan2(z - start[1], x / 2 - start[0]))
    assert 19.0 < slope < 21.5  # toolpath.ramp_angle = 20 deg, rounded to the lattice


def test_semi_finish_follows_the_offset_into_the_corner(arcs_shop, paper_mirror):
    """The semi-finish's corner point: the inner lobe offset by allowance + nose meets the
    wall's offset r = 20 - 0.35. By hand: the nose centre at r_c = 19.65 sits on the
    offset of the surface point r_s with r_s + 0.35 n_r(r_s) = 19.65 (n the outward normal
    in the machine frame), at Z = Z(r_s) + 0.35 n_z(r_s)."""
    m = paper_mirror
    prog = arcs_shop.program
    semi = prog.operations[2]
    feeds = [b.move.end for b in semi.motions() if not isinstance(b, Rapid)]
    corner = next(p for p in feeds if abs(p[0] - 19.65) < 1e-9)
    a, b, e = m.inner.a, m.inner.b, m.inner.e
    lo, hi = 18.0, 19.65
    for _ in range(80):  # bisection on r_s
        rs = 0.5 * (lo + hi)
        s = a * rs / (b * b * math.sqrt(1 + rs * rs / (b * b)))  # dz/dr, camera frame
        nr, nz = s / math.hypot(1, s), 1 / math.hypot(1, s)       # machine frame: Z = -z
        lo, hi = (rs, hi) if rs + 0.35 * nr < 19.65 else (lo, rs)
    z = m.vertex_z - (e + a * math.sqrt(1 + rs * rs / (b * b))) + 0.35 * nz
    assert corner[1] == pytest.approx(z, abs=0.005 + 1e-9)  # rounded up to the lattice
    # the 0.15 mm the semi-finish leaves (about 0.4 mm deep in the step's inside corner) is
    # taken in passes of at most toolpath.max_finish_depth_mm each (issue 21)
    fin = [op for op in arcs_shop.simulation.operations if op.name.startswith("finish")]
    assert len(fin) >= 2 and fin[-1].name == "finish"
    assert all(op.max_depth_of_cut_mm <= OPTIONS.max_finish_depth_mm + 1e-6 for op in fin)


def test_spring_pass_repeats_the_contour_and_cuts_air(tmp_path, paper_mirror):
    tp = plan_toolpath(paper_mirror, LATHE, TOOL, Strategy.ARCS)
    shop = shop_program(tp, STOCK, dataclasses.replace(OPTIONS, spring_pass=True), setting_costs={})
    names = [op.name for op in shop.simulation.operations]
    assert names[:3] == ["face", "rough", "semi-finish"] and names[-2:] == ["finish", "spring pass"]
    assert all(n.startswith("finish ") for n in names[3:-2])  # the finishing passes before the contour
    spring = shop.simulation.operations[-1]
    assert spring.removed_volume_mm3 < 1.0  # the nose's polygon noise, no stock
    out = rs274(tmp_path, format_program(shop.program))
    assert out.count('COMMENT("spring pass begin")') == 1 and out.count("CHANGE_TOOL(2)") == len(names) - 3


# --------------------------------------------------------------------------------------
# The set-up sheet


def test_sheet_offsets_put_the_nose_centre_where_the_program_expects_it(tmp_path, arcs_shop):
    """A tool whose nose centre sits (3.0, 12.0) mm from the machine's reference point,
    unknown to the operator. The operator touches the bar's face with the nose's bottom
    and a 20 mm bore with the side of the nose the tool can present, enters the sheet's
    values, and the control makes the offset = reference position - entered value. Run
    through rs274 with that tool table (inches), the nose centre (canonical position +
    the offset rs274 applies - the true (3, 12)) is exactly at every programmed point."""
    sheet = arcs_shop.sheet
    rho = TOOL.nose_radius
    # which side of the nose the insert leaves free, from the tool's angles: the sharp
    # rhombus' corners (tip at the flanks' meeting point) against the nose's extremes
    a1 = math.pi / 2 + TOOL.approach_angle
    a2 = a1 + TOOL.included_angle
    u1, u2 = np.array([math.cos(a1), math.sin(a1)]), np.array([math.cos(a2), math.sin(a2)])
    tip = -(rho / math.sin(TOOL.included_angle / 2)) * (u1 + u2) / np.linalg.norm(u1 + u2)
    edge = 9.525 / math.sin(TOOL.included_angle)
    corners = np.array([tip + edge * u1, tip + edge * (u1 + u2), tip + edge * u2])
    assert corners[:, 0].max() < rho          # +r: the nose's side is the extreme -> a bore
    assert corners[:, 0].min() < -rho         # -r: the body is -> no outside diameter
    assert corners[:, 1].min() > -rho         # -Z: the nose's bottom -> the face
    true_off = np.array([3.0, 12.0])
    face_z, bore = STOCK.face_allowance, 20.0
    centre_at_touch_z = face_z + rho          # the nose's bottom on the face
    centre_at_touch_x = bore / 2 - rho        # the nose's +r side on the bore
    tools = sheet.tools
    assert [t.station for t in tools] == [1, 2]
    lines = []
    for t in tools:
        ez = t.offsets.z_entry(face_z)
        ex = t.offsets.x_entry(bore) / 2      # diameter mode: X is a diameter
        ref_z = centre_at_touch_z + true_off[1]
        ref_x = centre_at_touch_x + true_off[0]
        lines.append(f"T{t.station} P{t.station} X{(ref_x - ex) / 25.4:.9f} Z{(ref_z - ez) / 25.4:.9f} "
                     f"D{2 * rho / 25.4:.6f} Q9")
    out = rs274(tmp_path, format_program(arcs_shop.program), tools="\n".join(lines) + "\n")
    offset = None
    pts = []
    for ev in canonical(out):
        if ev["kind"] == "USE_TOOL_LENGTH_OFFSET":
            offset = np.array([ev["x"], ev["z"]])
        elif ev["kind"] in ("STRAIGHT_FEED", "ARC_FEED") and offset is not None:
            pts.append(np.array(ev["end"]) + offset - true_off)
    planned = [b.move.end for _, b in arcs_shop.program.motions() if not isinstance(b, Rapid)]
    assert len(pts) == len(planned)
    assert np.abs(np.array(pts) - np.array(planned)).max() < 2e-4  # rs274 prints 4 decimals
    # the tables the project writes say the same: orientation 9 / imaginary tool nose 0, the nose centre
    from lathe_mirror.export.gcode import offset_table

    assert all(ln.split()[5] == "Q9" for ln in offset_table(tools, "linuxcnc")[1].splitlines())
    assert [ln for ln in offset_table(tools, "fanuc")[1].splitlines() if ln.startswith("G10")] == [
        f"G10 P{10000 + t.station} R{rho:g} Q0" for t in tools]


def test_sheet_cycle_time_agrees_with_rs274(tmp_path, arcs_shop):
    """The time from rs274's canonical moves: each feed move's length over feed (mm/rev)
    x rpm(r), rpm = min(cap, 1000 V / (2 pi r)) with the cap and V rs274 reports,
    integrated along the move (arcs as LinuxCNC's spirals); each rapid at the rapid rate."""
    events = canonical(rs274(tmp_path, format_program(arcs_shop.program)))
    cap = next(ev["value"] for ev in events if ev["kind"] == "SET_SPINDLE_MODE")
    v = next(ev["value"] for ev in events if ev["kind"] == "SET_SPINDLE_SPEED")
    pos, feed, total, k = (0.0, 0.0), 0.0, 0.0, 0
    for ev in events:
        if ev["kind"] == "SET_FEED_RATE":
            feed = ev["value"]
        if ev["kind"] not in ("STRAIGHT_TRAVERSE", "STRAIGHT_FEED", "ARC_FEED"):
            continue
        k += 1
        p = arc_points(pos, ev, 2001) if ev["kind"] == "ARC_FEED" else np.linspace(pos, ev["end"], 2001)
        pos = ev["end"]
        if k <= 2:  # going home from where the machine stands (rs274: 0, 0) at the start
            continue
        seg = np.hypot(*np.diff(p, axis=0).T)
        if ev["kind"] == "STRAIGHT_TRAVERSE":
            total += seg.sum() / OPTIONS.rapid_rate * 60.0
        else:
            r_mid = np.abs(0.5 * (p[1:, 0] + p[:-1, 0]))
            n = np.minimum(cap, 1000.0 * v / (2 * math.pi * np.maximum(r_mid, 1e-12)))
            total += np.sum(seg / (feed * n)) * 60.0
    est = arcs_shop.sheet.cycle_time_s
    assert est == pytest.approx(total, rel=0.10)
    print(f"cycle time: sheet {est:.1f} s, from rs274's moves {total:.1f} s")
    assert abs(est - total) / total < 0.01  # the same law: agreement well inside the 10 %


def test_sheet_centre_height_and_setting_costs(arcs_shop, paper_mirror):
    """Centre height: one pixel's footprint at the vertex, t_pixel x vertex height / f =
    0.009 x 103.678 / 16 mm (Table 1's mirror 01). An X setting error dx: the vertex's
    slope error atan(z'(dx)) = atan(a dx / (b^2 sqrt(1 + dx^2 / b^2)))."""
    sheet = arcs_shop.sheet
    assert sheet.centre_height_mm == pytest.approx(0.009 * 103.678 / 16.0, rel=1e-4)
    a, b = paper_mirror.inner.a, paper_mirror.inner.b
    dx = 0.01
    want = math.atan(a * dx / (b * b * math.sqrt(1 + dx * dx / (b * b))))
    x_inner = sheet.setting_costs["x"]["lobes"][0]
    assert x_inner["slope_error_rad"]["max"] == pytest.approx(want, rel=1e-3)
    assert want == pytest.approx(0.67e-3, abs=0.005e-3)  # the 0.67 mrad
    z_inner = sheet.setting_costs["z"]["lobes"][0]
    assert z_inner["slope_error_rad"]["max"] == 0.0 and 0 < z_inner["image_displacement_px"]["max"] < 0.1


def test_sheet_is_written_beside_the_program(tmp_path):
    res = run_cli("toolpath", "--dialect", "fanuc", "-o", str(tmp_path / "part.nc"))
    assert res.returncode == 0, res.stderr
    # the second set-up's program and the Fanuc offset list too
    assert sorted(p.name for p in tmp_path.iterdir()) == ["offsets.nc", "part.nc", "part.setup.html", "part_op2.nc"]
    page = (tmp_path / "part.setup.html").read_text()
    assert "Z1.200" in page and "X19.600" in page  # face + 0.2; a 20 mm bore - 0.4
    # one picture for each operation both programs list in their headers (the second set-up's too)
    n_ops = sum(len(re.search(r"^\(OPERATIONS, RESTART AT THEIR FIRST BLOCK: (.*)\)$", (tmp_path / f).read_text(),
                              re.M).group(1).split(", ")) for f in ("part.nc", "part_op2.nc"))
    assert page.count("<svg ") == n_ops and "https://" not in page


@pytest.mark.parametrize("which", ["paper", "recessed"])
def test_a_program_planned_again_is_simulated_from_its_first_finishing_pass(which, tmp_path):
    """shop_program plans a program, simulates it and, a finishing pass cutting too deep,
    plans it again with more passes (shop.resume): the second run starts from the state the
    first had before its first finishing pass (the face, the roughing and the semi-finish are
    the same operations), and its figures and contacts are those of the program simulated
    from the bar, on the paper default and a recessed-outer design."""
    from conftest import RECESSED_OUTER
    from lathe_mirror.config import load
    from lathe_mirror.shop.plan import plan_program
    from lathe_mirror.shop.programs import shop_programs
    from lathe_mirror.shop.resume import Resume
    from lathe_mirror.shop.stock import forget_runs, operations_of

    path = None
    if which == "recessed":
        path = tmp_path / "r.toml"
        path.write_text(RECESSED_OUTER)
    settings = load(path)
    mirror = settings.mirror()
    for shop in shop_programs(settings, mirror):
        forget_runs()  # each run below replayed, not the one this process kept
        fresh = simulate_program(shop.program)
        assert shop.simulation.figures() == fresh.figures()
        assert shop.simulation.contacts == fresh.contacts == ()
        assert shop.simulation.parted.equals(fresh.parted)
        # the first plan (the configured passes) and the final one share their first three operations
        first = plan_program(shop.program.toolpath, settings.stock, settings.toolpath,
                             name=shop.program.name, body=settings.body)
        resume = Resume()
        simulate_program(first, resume=resume)
        names = [op.name for op in operations_of(shop.program)]
        if len(first.operations) != len(shop.program.operations):  # planned again
            assert names[:3] == ["face", "rough", "semi-finish"] and names[3].startswith("finish 1/")
            assert len(resume.states) == len(first.operations)
            forget_runs()
            again = simulate_program(shop.program, resume=resume)
            assert again.figures() == fresh.figures()



def test_a_program_simulated_again_is_not_replayed(arcs_shop, monkeypatch):
    """shop.stock keeps the last runs of the process by value: the same program again is
    not replayed (its operations would raise here) and gives the run it kept; a program one
    block of which ends 0.001 mm elsewhere is replayed."""
    from lathe_mirror.shop.stock import StockSim, forget_runs

    prog = arcs_shop.program
    forget_runs()
    first = simulate_program(prog)
    assert first.figures() == arcs_shop.simulation.figures()

    def replayed(*args, **kwargs):
        raise AssertionError("replayed")

    with monkeypatch.context() as m:
        m.setattr(StockSim, "operation", replayed)
        assert simulate_program(dataclasses.replace(prog)) is first
        last = prog.operations[-1]
        k = max(i for i, b in enumerate(last.blocks) if isinstance(b, Rapid))
        end = last.blocks[k]
        moved = dataclasses.replace(end, move=dataclasses.replace(end.move, end=(end.move.end[0] + 1e-3,
                                                                                 end.move.end[1])))
        blocks = last.blocks[:k] + (moved,) + last.blocks[k + 1:]
        other = dataclasses.replace(prog, operations=prog.operations[:-1]
                                    + (dataclasses.replace(last, blocks=blocks),))
        with pytest.raises(AssertionError, match="replayed"):
            simulate_program(other)


def test_a_first_set_up_against_another_part_goes_on_from_the_shared_stock(paper_mirror, arcs_shop, monkeypatch):
    """The paper method's and the arc method's first set-ups differ only in the designed part
    (its shoulder) and share the face and the roughing: the arc program simulated after the
    paper one goes on from the stock the paper one left after them (those two operations not
    replayed; only their depth into the part measured again) and gives what it gives from the
    bar: every figure, the stock after each operation and the part it parts off bit for bit."""
    import shapely

    from lathe_mirror.shop.stock import StockSim, forget_runs

    paper = shop_program(plan_toolpath(paper_mirror, LATHE, TOOL, Strategy.PAPER), STOCK, OPTIONS).program
    arcs = arcs_shop.program
    forget_runs()
    fresh = simulate_program(arcs)
    forget_runs()
    simulate_program(paper)
    replayed = []
    real = StockSim.operation
    monkeypatch.setattr(StockSim, "operation", lambda self, op, rate: replayed.append(op.name) or real(self, op, rate))
    shared = simulate_program(arcs)
    assert "face" not in replayed and "rough" not in replayed and replayed[0] == "semi-finish"
    assert shared.figures() == fresh.figures()
    for a, b in zip(shared.operations, fresh.operations):
        assert shapely.to_wkb(a.stock_after) == shapely.to_wkb(b.stock_after)
    assert shapely.to_wkb(shared.parted) == shapely.to_wkb(fresh.parted)

def test_a_bar_held_too_far_out_is_refused(paper_mirror):
    """The first set-up's grip: a bar standing out of the jaws more than three of its
    diameters (76 mm: 228 mm) is refused before any simulation, naming stock.length; the
    sheet gives the blank's length, the stick-out and 10 mm in the jaws."""
    tp = plan_toolpath(paper_mirror, LATHE, TOOL, Strategy.ARCS)
    with pytest.raises(InputError, match=r"stock.length = 230 mm: .* more than 3 bar diameters .* allowed <= 227 mm"):
        plan_program(tp, Stock(length=230.0), OPTIONS)
    plan_program(tp, Stock(length=227.0), OPTIONS)  # 228 mm out: the limit


def test_roughing_feed_is_half_the_nose_unless_configured(paper_mirror):
    """machine.feed_rough's default 0.15 mm/rev on a 0.2 mm nose is capped at 0.1 mm/rev
    (half the nose radius per revolution); a feed_rough the configuration sets otherwise
    (0.2, or 0.05) is the program's; the finishing feed is untouched."""
    for lathe, want in ((LATHE, 0.1), (Lathe(feed_rough=0.2), 0.2), (Lathe(feed_rough=0.05), 0.05)):
        prog = plan_program(plan_toolpath(paper_mirror, lathe, TOOL, Strategy.ARCS), STOCK, OPTIONS)
        feeds = {op.name: op.feed for op in prog.operations}
        assert feeds["face"] == feeds["rough"] == feeds["semi-finish"] == want
        assert feeds["finish"] == lathe.feed_finish
