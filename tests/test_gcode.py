"""G-code: LinuxCNC's rs274 interprets every program; its canonical moves rebuild the
finishing contour to 0.0001 mm; lattice, budget, word formats, dialects, refusals,
reproducibility, gcode/. (The stock simulation and the set-up sheet: test_shop.py.)"""

from __future__ import annotations

import math
import os
import re
import subprocess
from pathlib import Path

import numpy as np
import pytest

from committed import gcode_differs, html_differs
from conftest import require_program, run_cli
from lathe_mirror.config import load
from lathe_mirror.errors import InputError
from lathe_mirror.export.dialects import DIALECTS, dialect as find_dialect
from lathe_mirror.export.gcode import format_program, program_files
from lathe_mirror.shop.programs import shop_programs
from lathe_mirror.lathe import Lathe, Stock, Tool
from lathe_mirror.path import Arc
from lathe_mirror.shop import plan_program
from lathe_mirror.toolpath import ToolpathSettings
from lathe_mirror.toolpath import Strategy, plan_toolpath

REPO = Path(__file__).resolve().parents[1]
LATHE = Lathe()
STOCK = Stock()
#: The tool table the project writes beside its programs (gcode/tools.tbl: every station the paper
#: default calls, offsets zero until touched off, the nose centre the controlled point).
TOOLS = (REPO / "gcode" / "tools.tbl").read_text()


def program(tp, stock=STOCK, dialect="linuxcnc", *, options=None) -> str:
    """The whole program around a toolpath, as text."""
    return format_program(plan_program(tp, stock, options), dialect)


def rs274(tmp_path: Path, text: str, tools: str = TOOLS) -> str:
    """Run LinuxCNC's interpreter on a program with its tool table (the one the project
    wrote into tmp_path beside the program, else `tools`); its canonical output (fails on
    error, such as a tool the table lacks)."""
    exe = require_program("rs274")
    prog = tmp_path / "prog.ngc"
    prog.write_text(text)
    if not (tmp_path / "tools.tbl").exists():
        (tmp_path / "tools.tbl").write_text(tools)
    env = dict(os.environ, HOME=str(tmp_path))
    res = subprocess.run([exe, "-t", str(tmp_path / "tools.tbl"), "-g", str(prog)],
                         capture_output=True, text=True, cwd=tmp_path, env=env, timeout=60)
    assert res.returncode == 0, res.stdout[-2000:] + res.stderr[-2000:]
    return res.stdout


def canonical_contour(out: str) -> list[tuple]:
    """The moves between the 'finish contour begin/end' comments, as rs274 reports them,
    after the position they start from: ("line", (r, Z)) or ("arc", (r, Z), centre (r, Z),
    rotation). In G7, X is a radius."""
    lines = out.splitlines()
    i0 = next(i for i, ln in enumerate(lines) if 'COMMENT("finish contour begin")' in ln)
    i1 = next(i for i, ln in enumerate(lines) if 'COMMENT("finish contour end")' in ln)
    before = [ln for ln in lines[:i0] if re.search(r"STRAIGHT_(FEED|TRAVERSE)\(", ln)][-1]
    v = [float(x) for x in re.search(r"\(([^)]*)\)", before).group(1).split(",")]
    moves = [("line", (v[0], v[2]))]
    for ln in lines[i0 + 1:i1]:
        m = re.search(r"(STRAIGHT_FEED|ARC_FEED)\(([^)]*)\)", ln)
        if not m:
            continue
        v = [float(x) for x in m.group(2).split(",")]
        if m.group(1) == "STRAIGHT_FEED":
            moves.append(("line", (v[0], v[2])))
        else:  # XZ plane: first axis Z, second X
            moves.append(("arc", (v[1], v[0]), (v[3], v[2]), int(v[4])))
    return moves


def rebuild_points(moves, n=33, *, step: float | None = None) -> list[np.ndarray]:
    """Points along the rebuilt contour (arcs as LinuxCNC's spiral), per move: n per
    move, or with `step` (mm) at least one every step along it."""
    cur = np.array(moves[0][1])
    pieces = []
    for mv in moves[1:]:
        end = np.array(mv[1])
        k = n
        if step is not None:  # an arc is at most half a circle longer than its chord
            k = max(n, int(math.ceil(np.hypot(*(end - cur)) * math.pi / 2 / step)) + 1)
        if mv[0] == "line":
            t = np.linspace(0, 1, k)[:, None]
            pieces.append((1 - t) * cur + t * end)
        else:
            c = np.array(mv[2])
            a0 = math.atan2(cur[1] - c[1], cur[0] - c[0])
            a1 = math.atan2(end[1] - c[1], end[0] - c[0])
            # rotation +1 = counterclockwise in the (Z, X) plane = clockwise in (r, Z)
            sweep = a1 - a0
            if mv[3] > 0:
                while sweep >= 0:
                    sweep -= 2 * math.pi
            else:
                while sweep <= 0:
                    sweep += 2 * math.pi
            r0, r1 = np.hypot(*(cur - c)), np.hypot(*(end - c))
            u = np.linspace(0, 1, k)
            rad = r0 + (r1 - r0) * u
            phi = a0 + sweep * u
            pieces.append(c + rad[:, None] * np.stack([np.cos(phi), np.sin(phi)], -1))
        cur = end
    return pieces


@pytest.fixture(scope="module")
def plans(paper_mirror):
    out = {}
    for rho in (0.0, 0.2):
        for st in (Strategy.PAPER, Strategy.LATTICE, Strategy.ARCS):
            out[(st, rho)] = plan_toolpath(paper_mirror, LATHE, Tool(nose_radius=rho), st)
    return out


@pytest.mark.parametrize("rho", [0.0, 0.2])
@pytest.mark.parametrize("strategy", [Strategy.PAPER, Strategy.LATTICE, Strategy.ARCS])
def test_rs274_rebuilds_the_contour(tmp_path, plans, strategy, rho):
    tp = plans[(strategy, rho)]
    out = rs274(tmp_path, program(tp, STOCK, "linuxcnc"))
    moves = canonical_contour(out)
    assert len(moves) == len(tp.segments) + 1
    # the lead-in ends at the contour's start
    assert np.allclose(moves[0][1], tp.segments[0].start, atol=1e-4)
    rebuilt = rebuild_points(moves)
    for seg, mv, pts in zip(tp.segments, moves[1:], rebuilt):
        assert mv[0] == ("arc" if isinstance(seg, Arc) else "line")
        assert np.allclose(mv[1], seg.end, atol=1e-4)
        if isinstance(seg, Arc):
            assert np.allclose(mv[2], seg.centre, atol=1e-4)
            # G2 (clockwise in G18) is reported as rotation -1
            assert (mv[3] == -1) == seg.clockwise
        want = seg.sample(len(pts))
        assert np.max(np.hypot(*(pts - want).T)) <= 1e-4


def test_rs274_reports_the_lattice_and_the_setup(tmp_path, plans):
    tp = plans[(Strategy.ARCS, 0.2)]
    out = rs274(tmp_path, program(tp, STOCK, "linuxcnc"))
    assert "SELECT_PLANE(CANON_PLANE_XZ)" in out
    assert "USE_LENGTH_UNITS(CANON_UNITS_MM)" in out
    assert "SET_SPINDLE_MODE(0 3000.0000)" in out  # G96 D: the spindle cap
    assert "SET_FEED_MODE(0, 1)" in out  # G95: feed per revolution
    # roughing tool, coolant, optional stop, a separate finishing tool, coolant off at the end
    events = [e for e in re.findall(r"(CHANGE_TOOL\(\d\)|FLOOD_ON|FLOOD_OFF|OPTIONAL_PROGRAM_STOP|PROGRAM_END)", out)]
    assert events[:1] == ["CHANGE_TOOL(1)"] and events[-1] == "PROGRAM_END"
    i_stop = events.index("OPTIONAL_PROGRAM_STOP")
    assert "FLOOD_OFF" in events[:i_stop] and events[i_stop + 1] == "CHANGE_TOOL(2)"
    assert events[-2] == "FLOOD_OFF"
    # the end position: home (X100 = r 50, Z50), Z first, before M30
    travs = re.findall(r"STRAIGHT_TRAVERSE\(([^,]+), [^,]+, ([^,]+),", out.split("OPTIONAL_PROGRAM_STOP")[1])
    assert [tuple(map(float, t)) for t in travs[-2:]] == [(40.0, 50.0), (50.0, 50.0)]
    # every canonical coordinate of the contour is a lattice value (4 decimals printed)
    for mv in canonical_contour(out):
        vals = np.array(mv[1] + (mv[2] if mv[0] == "arc" else ()))
        assert np.all(np.abs(vals / 0.005 - np.rint(vals / 0.005)) < 1e-6)


def test_every_written_word_is_on_the_lattice(plans):
    tp = plans[(Strategy.ARCS, 0.0)]
    for dialect in DIALECTS:
        text = program(tp, STOCK, dialect)
        for word, val in re.findall(r"\b([XZIK])(-?\d+\.\d+)", text):
            step = 0.01 if word == "X" else 0.005  # diameter mode: X = 2r
            v = float(val)
            assert abs(v / step - round(v / step)) < 1e-9, (word, val)


def test_fanuc_dialect_structure(plans):
    text = program(plans[(Strategy.ARCS, 0.2)], STOCK, "fanuc")
    lines = text.splitlines()
    assert lines[0] == "%" and lines[1].startswith("O1000")
    assert "G21" in lines  # alone in its block, for older controls
    words = [ln.split()[1:] if ln.startswith("N") else ln.split() for ln in lines]
    assert ["G50", "S3000"] in words and ["T0101"] in words and ["T0202"] in words
    assert ["M08"] in words and ["M09"] in words and ["M01"] in words
    assert ["G96", "S200", "M03"] in words
    assert "G99" in " ".join(lines)  # feed per revolution
    assert lines[-1] == "%" and words[-2] == ["M30"]
    assert not any("G7" in ln.split() or "G43" in ln.split() for ln in lines)
    # comments: upper case, in parentheses, no ';', nothing nested
    comments = [ln for ln in lines if "(" in ln]
    assert comments and all(re.fullmatch(r"(O1000 )?\([A-Z0-9 .,+\-/=:*#_]*\)", ln) for ln in comments)
    assert not any(";" in ln for ln in lines)
    # block numbers: increasing, the same blocks as the LinuxCNC program's
    n_f = [int(ln.split()[0][1:]) for ln in lines if ln.startswith("N")]
    lc = program(plans[(Strategy.ARCS, 0.2)], STOCK, "linuxcnc").splitlines()
    n_l = [int(ln.split()[0][1:]) for ln in lc if ln.startswith("N")]
    assert n_f == n_l == list(range(1, len(n_f) + 1))


def test_dialects_carry_the_same_moves(plans, tmp_path):
    """The Fanuc program read back (shop.replay) moves through the same points, arc
    centres and block numbers as rs274 reports for the LinuxCNC program."""
    from lathe_mirror.shop.replay import read_program

    tp = plans[(Strategy.PAPER, 0.2)]
    fanuc = read_program(program(tp, STOCK, "fanuc"), LATHE, DIALECTS["fanuc"])
    canon = canonical_moves(rs274(tmp_path, program(tp, STOCK, "linuxcnc")))
    mine = [mv for op in fanuc for mv in op.moves]
    assert len(mine) == len(canon)
    # the first two go home from where the machine is (rs274 starts at 0, 0): Z, then X
    assert [mv.label.split()[1:3] for mv in mine[:2]] == [["G0", "Z50.000"], ["G0", "X100.000"]]
    for mv, (kind, end, _, number) in zip(mine[2:], canon[2:]):
        assert mv.rapid == (kind == "STRAIGHT_TRAVERSE")
        assert isinstance(mv.move, Arc) == (kind == "ARC_FEED")
        assert np.allclose(mv.move.end, end, atol=1e-4)
        assert mv.label.split()[0] == f"N{number}"


def test_header_states_design_machine_tool_budget_and_figures(plans):
    tp = plans[(Strategy.ARCS, 0.0)]
    head = [ln for ln in program(tp, STOCK).splitlines() if ln.startswith("(")]
    text = "\n".join(head)
    assert "a 48.3584 b 26.8656" in text  # Table 1's a, b of mirror 01
    assert f"{tp.n_points} of 528 points used" in text
    assert "nose radius 0 mm" in text
    assert "offsets set to the NOSE CENTRE, see mirror.setup.html and tools.tbl" in text
    # per lobe: the whole lobe, and the radii the camera uses
    assert text.count("whole lobe, against the design: normal deviation rms") == 2
    assert text.count("slope error rms") == 4


def test_header_gives_the_used_zone_beside_the_whole_lobe(plans, paper_mirror):
    """With a 0.2 mm nose the junction fillet dominates the inner lobe's whole-lobe
    figures (a slope error of radians); the header also gives the radii the camera uses,
    which the step wall cuts short of the fillet (Mirror.fov_usable)."""
    tp = plans[(Strategy.ARCS, 0.2)]
    head = "\n".join(ln for ln in program(tp, STOCK).splitlines() if ln.startswith("("))
    whole = re.search(r"as machined inner, whole lobe, against the design: .* slope error rms \S+ max (\S+) rad", head)
    used = re.search(r"as machined inner, used r 0.000\.\.(\S+) mm, against the design: .* slope error rms \S+ max "
                     r"(\S+) rad", head)
    assert float(whole.group(1)) > 1.0  # the fillet: the nose's side, nearly vertical
    assert float(used.group(2)) < 2e-3  # the turned hyperbola itself
    assert abs(float(used.group(1)) - 17.931) < 0.001  # see test_toolpath's hand calculation
    assert "the fillet lies there, out of the image" in head


def test_same_inputs_same_bytes(paper_mirror):
    a = program(plan_toolpath(paper_mirror, LATHE, Tool(), Strategy.ARCS), STOCK)
    b = program(plan_toolpath(paper_mirror, LATHE, Tool(), Strategy.ARCS), STOCK)
    assert a == b


def test_a_gouging_program_is_refused(paper_mirror):
    tp = plan_toolpath(paper_mirror, LATHE, Tool(nose_radius=0.0), Strategy.PAPER)
    # the paper's rounding lies up to ~0.003 mm inside the part: a tighter tolerance refuses it
    with pytest.raises(InputError, match="gouge"):
        plan_program(tp, STOCK, ToolpathSettings(gouge_tolerance=0.001))


def test_unknown_dialect():
    with pytest.raises(InputError, match="allowed linuxcnc, fanuc"):
        find_dialect("heidenhain")


def test_reference_programs_are_current():
    settings = load()
    files = program_files(shop_programs(settings, settings.mirror()))
    assert sorted(files) == sorted(p.name for p in (REPO / "gcode").iterdir())
    for name, text in files.items():
        path = REPO / "gcode" / name
        differs = html_differs if name.endswith(".html") else gcode_differs
        why = differs(text, path.read_text())
        assert why is None, f"gcode/{name} is stale ({why}): run `lathe-mirror run` from the repository root"


@pytest.mark.parametrize("name", ["mirror_paper.ngc", "mirror_arcs.ngc"])
def test_reference_programs_pass_rs274(tmp_path, name, paper_mirror):
    text = (REPO / "gcode" / name).read_text()
    out = rs274(tmp_path, text)
    moves = canonical_contour(out)
    pts = np.array([m[1] for m in moves] + [m[2] for m in moves if m[0] == "arc"])
    assert np.all(np.abs(pts / 0.005 - np.rint(pts / 0.005)) < 1e-6)
    n_points = 1 + sum(1 if m[0] == "line" else 2 for m in moves[1:])
    assert n_points <= 528
    # no gouge: the 0.2 mm nose swept along rs274's own moves stays out of the part
    pieces = rebuild_points(moves, 3, step=0.004)
    depth = nose_depth_into_part(pieces, 0.2, paper_mirror)
    assert depth <= ToolpathSettings().gouge_tolerance  # the stated tolerance, 0.005 mm
    # the check sees a gouge: a nose 0.05 mm larger than planned cuts 0.05 mm deeper
    assert abs(nose_depth_into_part(pieces, 0.25, paper_mirror) - (depth + 0.05)) < 1e-3
    # and the header's figure (machining.gouge_depth) agrees with this brute force
    stated = float(re.search(r"deepest point inside the part (\S+) mm", text).group(1))
    assert abs(depth - stated) < 1e-4, (depth, stated)


def nose_depth_into_part(pieces, rho: float, mirror) -> float:
    """Deepest (mm, normal to the surface) any point of a nose circle of radius rho on
    the path reaches inside the exact part: the lower half circle sampled every 0.75 deg
    at every path point, against each lobe's sheet z = e + a sqrt(1 + r^2 / b^2)
    (camera frame) written out here; beside the step wall the part's boundary is the
    wall, r = 20."""
    path = np.concatenate(pieces)
    phi = np.linspace(math.pi, 2 * math.pi, 241)
    p = (path[:, None, :] + rho * np.stack([np.cos(phi), np.sin(phi)], -1)[None]).reshape(-1, 2)
    p = p[(p[:, 0] >= 0.0) & (p[:, 0] <= mirror.r_max)]
    r, zm = p[:, 0], p[:, 1]
    depth = np.full(r.shape, -np.inf)
    top_inner = None
    for lobe, sel in ((mirror.inner, r <= mirror.r_junction), (mirror.outer, r > mirror.r_junction)):
        a, b, e = lobe.a, lobe.b, lobe.e
        q = np.sqrt(1 + (r[sel] / b) ** 2)
        z_part = mirror.vertex_z - (e + a * q)  # machine Z of the part's top
        slope = a * r[sel] / (b * b * q)
        depth[sel] = (z_part - zm[sel]) / np.sqrt(1 + slope**2)  # vertical -> normal depth
        if top_inner is None:
            top_inner = mirror.vertex_z - (e + a * math.sqrt(1 + (mirror.r_junction / b) ** 2))
    wall = (r > mirror.r_junction) & (zm >= top_inner)
    depth[wall] = np.minimum(depth[wall], r[wall] - mirror.r_junction)
    return max(0.0, float(depth.max()))


# --------------------------------------------------------------------------------------
# The command line: bad inputs give one line, exit 2, and no file


@pytest.mark.parametrize("args, phrase", [
    (["--points", "10"], "machine.max_points = 10: too small"),
    (["--resolution", "0"], "argument --resolution: 0 mm: allowed 0.0001 to 0.1 mm"),
    (["--nose-radius", "1.0"], "too large for the junction"),
    (["--dialect", "heidenhain"], "--dialect 'heidenhain': allowed linuxcnc, fanuc"),
    (["--strategy", "spline"], "--strategy 'spline': allowed paper, lattice, arcs, best"),
])
def test_cli_bad_inputs(tmp_path, args, phrase):
    out = tmp_path / "p.ngc"
    res = run_cli("toolpath", *args, "-o", str(out))
    assert res.returncode == 2, res.stderr
    err = res.stderr.strip().splitlines()
    assert len(err) == 1 and phrase in err[0], res.stderr
    assert "Traceback" not in res.stderr
    assert not out.exists() and list(tmp_path.iterdir()) == []


def test_cli_lattice_too_coarse_for_the_points(tmp_path):
    """0.1 mm steps under 0.076 mm chords: rounded neighbours share a column."""
    out = tmp_path / "p.ngc"
    res = run_cli("toolpath", "--strategy", "paper", "--resolution", "0.1", "-o", str(out))
    assert res.returncode == 2, res.stderr
    assert "machine.resolution = 0.1 mm: too coarse" in res.stderr
    assert len(res.stderr.strip().splitlines()) == 1 and list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("resolution", [0.003, 0.0001])
def test_other_lattices_pass_rs274(tmp_path, paper_mirror, resolution):
    """A step that does not divide the program's round figures (clearance 2 mm, r 35 mm),
    and the finest step a word can carry: every word on the lattice, rs274 rebuilds it."""
    lathe = Lathe(resolution=resolution)
    tp = plan_toolpath(paper_mirror, lathe, Tool(nose_radius=0.2), Strategy.ARCS)
    text = program(tp, STOCK)
    for word, val in re.findall(r"\b([XZIK])(-?\d+\.\d+)", text):
        step = 2 * resolution if word == "X" else resolution
        assert abs(float(val) / step - round(float(val) / step)) < 1e-6, (word, val)
    moves = canonical_contour(rs274(tmp_path, text))
    assert np.allclose([mv[1] for mv in moves[1:]], [s.end for s in tp.segments], atol=1e-4)
    assert tp.n_points <= 528


def test_cli_bad_strategy_in_the_config(tmp_path):
    cfg = tmp_path / "c.toml"
    cfg.write_text('[toolpath]\nstrategy = "spline"\n')
    res = run_cli("toolpath", "--config", str(cfg), "-o", str(tmp_path / "p.ngc"))
    assert res.returncode == 2
    assert "toolpath.strategy = 'spline': allowed paper, lattice, arcs, best" in res.stderr
    assert not (tmp_path / "p.ngc").exists()


def test_cli_travel_exceeded(tmp_path):
    cfg = tmp_path / "small.toml"
    cfg.write_text("[machine]\ntravel_x = 30.0\n")
    out = tmp_path / "p.ngc"
    res = run_cli("toolpath", "--config", str(cfg), "-o", str(out))
    assert res.returncode == 2
    assert "machine.travel_x = 30" in res.stderr and len(res.stderr.strip().splitlines()) == 1
    assert not out.exists()


def test_cli_json_and_directory_output(tmp_path):
    import json

    res = run_cli("toolpath", "--nose-radius", "0", "--json", "-o", str(tmp_path) + "/")
    assert res.returncode == 0, res.stderr
    data = json.loads(res.stdout)
    assert [lb["name"] for lb in data["lobes"]] == ["inner", "outer"]
    for lb in data["lobes"] + data["usable_lobes"]:
        assert set(lb) >= {"name", "normal_deviation_mm", "slope_error_rad"}
        assert set(lb["slope_error_rad"]) == {"rms", "max"}
    assert [lb["name"] for lb in data["usable_lobes"]] == ["inner", "outer"]
    assert data["usable_lobes"][0]["r_range_mm"]["min"] == 0.0
    assert data["usable_lobes"][1]["r_range_mm"] == {"min": 20.0, "max": 35.0}
    assert data["n_points"] <= 528
    assert (tmp_path / "mirror_arcs.ngc").exists()
    assert (tmp_path / "mirror_arcs.setup.html").exists()  # beside the program
    assert (tmp_path / "mirror_arcs_op2.ngc").exists()  # the second set-up's program too
    names = [op["name"] for op in data["shop"]["operations"]]
    assert names[:3] == ["face", "rough", "semi-finish"] and names[-2:] == ["finish", "part-off"]
    assert data["shop"]["contacts"] == [] and data["second_setup"]["contacts"] == []
    assert [op["name"] for op in data["second_setup"]["operations"]] == ["face back", "centre drill", "drill", "bore",
                                                                         "finish bore", "finish back"]
    assert (tmp_path / "tools.tbl").read_text().splitlines()[0].startswith("T1 P1 X0 Z0 D0.000 Q0")
    # "best" names the default strategy, as in `lathe-mirror render --surface best`
    res = run_cli("toolpath", "--strategy", "best", "--nose-radius", "0", "--json")
    assert res.returncode == 0 and json.loads(res.stdout)["strategy"] == "arcs"


def canonical_moves(out: str) -> list[tuple[str, tuple[float, float], bool, int]]:
    """Every move rs274 reports: (kind, end (r, Z), with the finishing tool, block N)."""
    moves, finishing = [], False
    for ln in out.splitlines():
        if "CHANGE_TOOL(2)" in ln:
            finishing = True  # the finishing tool: its lead-in, the contour, the exit
        m = re.search(r"N(\d+)\s+(STRAIGHT_FEED|STRAIGHT_TRAVERSE|ARC_FEED)\(([^)]*)\)", ln)
        if m:
            v = [float(x) for x in m.group(3).split(",")]
            end = (v[1], v[0]) if m.group(2) == "ARC_FEED" else (v[0], v[2])
            moves.append((m.group(2), end, finishing, int(m.group(1))))
    return moves


def test_roughing_leaves_the_allowance_and_never_cuts_the_part(tmp_path, paper_mirror):
    """Simulate the stock column by column from rs274's own moves: every roughing feed
    move removes what a 0.2 mm nose reaches. After roughing, the stock left on the
    mirror is at least half the allowance and at most one roughing depth plus the
    allowance; rapid and roughing moves keep the nose off the finished part."""
    m = paper_mirror
    rho, allow, depth = 0.2, ToolpathSettings().rough_allowance, ToolpathSettings().rough_depth
    tp = plan_toolpath(m, LATHE, Tool(nose_radius=rho), Strategy.ARCS)
    moves = canonical_moves(rs274(tmp_path, program(tp, STOCK)))
    r = np.arange(0.0, 35.0, 0.01)
    part = m.vertex_z - np.where(r <= 20.0, m.inner.z(r), m.outer.z(r))
    top = np.full(r.shape, STOCK.face_allowance)  # the bar's face
    prev = None
    for kind, p, finishing, _ in moves:
        if prev is not None and not finishing:
            seg = np.linspace(prev, p, 400)
            if kind == "STRAIGHT_FEED":
                for c in seg:
                    near = np.abs(r - c[0]) < rho
                    bottom = c[1] - np.sqrt(rho**2 - (r[near] - c[0]) ** 2)
                    top[near] = np.minimum(top[near], bottom)
        if prev is not None and (kind == "STRAIGHT_TRAVERSE" or not finishing):
            # the nose never reaches into the finished part, rapid or roughing feed
            seg = np.linspace(prev, p, 400)
            idx = np.clip(np.searchsorted(r, seg[:, 0]), 0, r.size - 1)
            inside = seg[:, 0] <= 34.99
            assert np.all(seg[inside, 1] - part[idx[inside]] > rho * 0.99), (kind, prev, p)
        prev = p
    left = top - part
    away = np.abs(r - 20.0) > 0.6  # beside the wall the nose's column spans both lobes
    assert left[away].min() >= 0.5 * allow
    assert left[away].max() <= depth + allow + 0.05


def test_radius_mode_program(tmp_path, paper_mirror):
    """G8: X words are radii; rs274 reports the same contour."""
    lathe = Lathe(diameter_mode=False)
    tp = plan_toolpath(paper_mirror, lathe, Tool(nose_radius=0.2), Strategy.ARCS)
    text = program(tp, STOCK)
    assert "G8" in text.splitlines()[next(i for i, ln in enumerate(text.splitlines()) if ln.startswith("G18"))]
    moves = canonical_contour(rs274(tmp_path, text))
    assert np.allclose([mv[1] for mv in moves[1:]], [s.end for s in tp.segments], atol=1e-4)
    # the rim's X word is its radius, not its diameter
    assert f"X{tp.segments[-1].end[0]:.3f}" in text


# --------------------------------------------------------------------------------------
# Word formats: every number fixed-point within the controller's word format (issue 14.3)


@pytest.mark.parametrize("toml, key", [
    ("[machine]\nsurface_speed = 1000000.0\n", "machine.surface_speed = 1e+06 m/min"),
    ("[machine]\nfeed_finish = 0.00005\n", "machine.feed_finish = 5e-05 mm/rev"),
    ("[machine]\nspindle_max_rpm = 9223372036854775807\n",
     "machine.spindle_max_rpm = 9223372036854775807 rev/min"),
])
@pytest.mark.parametrize("command", ["toolpath", "run"])
def test_words_outside_their_format_are_refused(tmp_path, toml, key, command):
    """Each exact input of the fuzzing report: one line naming the key and the allowed
    range, exit 2, nothing written (the programs %g wrote as S1e+06 and F5e-05)."""
    cfg = tmp_path / "c.toml"
    cfg.write_text(toml)
    out = tmp_path / "out"
    args = (["toolpath", "--config", str(cfg), "-o", str(out) + "/"] if command == "toolpath" else
            ["run", "--config", str(cfg), "-o", str(out), "--no-render", "--no-progress"])
    res = run_cli(*args)
    assert res.returncode == 2, res.stderr[-2000:]
    err = res.stderr.strip().splitlines()
    assert len(err) == 1 and key in err[0] and "allowed" in err[0], res.stderr
    assert not out.exists() and sorted(p.name for p in tmp_path.iterdir()) == ["c.toml"]


def test_words_at_their_bounds_are_fixed_point_and_pass_rs274(tmp_path, paper_mirror):
    """The largest S and spindle cap and the smallest feed a word carries are written
    fixed-point, and rs274 reads back exactly those values."""
    lathe = Lathe(surface_speed=99999.0, spindle_max_rpm=99999, feed_finish=0.0001)
    tp = plan_toolpath(paper_mirror, lathe, Tool(), Strategy.ARCS)
    text = program(tp)
    assert re.search(r"\d[eE][-+]?\d", text.split("G18", 1)[1]) is None  # no exponent in a word
    assert "G96 D99999 S99999 M3" in text and "F0.0001" in text.split()
    out = rs274(tmp_path, text)
    assert "SET_SPINDLE_MODE(0 99999.0000)" in out and "SET_SPINDLE_SPEED(0, 99999.0000)" in out
    assert "SET_FEED_RATE(0.0001)" in out


def test_no_word_of_a_reference_program_has_an_exponent():
    for path in sorted((REPO / "gcode").glob("*.n*c")):
        code = "\n".join(re.sub(r"\([^)]*\)", "", ln) for ln in path.read_text().splitlines())
        assert re.search(r"[A-Z]-?\d*\.?\d+[eE]", code) is None, path.name


# --------------------------------------------------------------------------------------
# Other designs: a second inner-recessed step; the outer-recessed step is refused


SMALL = ("[camera]\nf = 6.0\nt_pixel = 0.003\nsensor_px = [1280, 1024]\n"
         "[lobes.inner]\nr_top = 12.0\nr_pixel = 260.0\na_over_b = 2.0\n"
         "[lobes.outer]\nr_top = 25.0\nr_pixel = 500.0\nalpha_deg = 5.0\n")


@pytest.mark.parametrize("strategy", ["paper", "lattice", "arcs"])
def test_another_step_design_passes_rs274(tmp_path, strategy):
    """The README's small design (step 1.312 mm, inner lobe recessed): every strategy's
    program is written (simulated, no contact) and rs274 reads it."""
    cfg = tmp_path / "small.toml"
    cfg.write_text(SMALL)
    res = run_cli("toolpath", "--config", str(cfg), "--strategy", strategy, "-o", str(tmp_path) + "/")
    assert res.returncode == 0, res.stderr
    out = rs274(tmp_path, (tmp_path / f"mirror_{strategy}.ngc").read_text())
    text = (tmp_path / f"mirror_{strategy}.ngc").read_text()
    finishing = len(re.findall(r"^\((?:finish pass \d|finish:)", text, re.M))  # the finishing passes, each restartable
    assert "PROGRAM_END" in out and out.count("CHANGE_TOOL(1)") == 3 and out.count("CHANGE_TOOL(2)") == finishing >= 1


def test_outer_recessed_step_is_cut_by_the_opposite_hand(tmp_path):
    """A design whose outer lobe is recessed (its step wall faces the rim) is cut by the
    same insert in opposite-hand holders (T3 roughing, T4 finishing), from the rim in;
    rs274 reads the program (test_outer_step.py sweeps the nose and the flanks)."""
    from conftest import RECESSED_OUTER

    cfg = tmp_path / "outer.toml"
    cfg.write_text(RECESSED_OUTER)
    res = run_cli("toolpath", "--config", str(cfg), "-o", str(tmp_path / "p.ngc"))
    assert res.returncode == 0, res.stderr
    out = rs274(tmp_path, (tmp_path / "p.ngc").read_text())
    finishing = len(re.findall(r"^\((?:finish pass \d|finish:)", (tmp_path / "p.ngc").read_text(), re.M))
    assert out.count("CHANGE_TOOL(3)") == 3 and out.count("CHANGE_TOOL(4)") == finishing >= 1
    assert out.count("CHANGE_TOOL(5)") == 1  # the part-off
    assert "CHANGE_TOOL(1)" not in out and "PROGRAM_END" in out
    # the second set-up: the back faced with the insert as configured (T1), the bore drilled (T6, T7)
    # and bored (T8, rough and finish), the back finished (T2); rs274 names a tool by its row in the
    # table written beside the programs
    out2 = rs274(tmp_path, (tmp_path / "p_op2.ngc").read_text())
    table = [int(t) for t in re.findall(r"^T(\d+) ", (tmp_path / "tools.tbl").read_text(), re.M)]
    rows = [int(k) for k in re.findall(r"CHANGE_TOOL\((\d+)\)", out2)]
    assert [table[k - 1] for k in rows] == [1, 6, 7, 8, 8, 2] and "PROGRAM_END" in out2
