"""Machining the step whichever lobe is recessed: a design whose OUTER lobe is recessed
(conftest.RECESSED_OUTER) is cut with the insert in an opposite-hand holder, from the rim
in. LinuxCNC's rs274 interprets every program; the nose and the held tool's flanks are
swept along rs274's own moves against the exact part (written out here: the inner sheet,
the wall facing the rim, the outer sheet)."""

from __future__ import annotations

import math
import os
import re
import subprocess
from pathlib import Path

import numpy as np
import pytest

from conftest import RECESSED_OUTER, require_program, run_cli
from lathe_mirror.config import load
from lathe_mirror.export.dialects import DIALECTS
from lathe_mirror.export.gcode import format_program
from lathe_mirror.lathe import Stock, Tool
from lathe_mirror.path import Arc
from lathe_mirror.shop.programs import shop_program
from lathe_mirror.toolpath import ToolpathSettings
from lathe_mirror.toolpath import Strategy, check_junction, plan_toolpath
from lathe_mirror.toolpath.checks import junction_margin
from lathe_mirror.toolpath.moves import Hand

GOUGE_TOL = ToolpathSettings().gouge_tolerance
#: rs274's tool table: every station's offsets zero (the nose centre is programmed).
TOOLS = "".join(f"T{k} P{k} X0 Z0 D0.4 Q9\n" for k in (1, 2, 3, 4))


def program(tp, stock, dialect="linuxcnc") -> str:
    """The whole program around a toolpath as text, after the stock simulation passed it
    (shop.programs.shop_program refuses a rapid or the insert's body in stock)."""
    return format_program(shop_program(tp, stock).program, dialect)


@pytest.fixture(scope="module")
def settings(tmp_path_factory):
    cfg = tmp_path_factory.mktemp("cfg") / "recessed.toml"
    cfg.write_text(RECESSED_OUTER)
    return load(cfg)


@pytest.fixture(scope="module")
def mirror(settings):
    m = settings.mirror()
    assert m.recessed == "outer" and m.step < 0
    return m


@pytest.fixture(scope="module")
def plans(mirror, settings):
    return {(st, rho): plan_toolpath(mirror, settings.machine, Tool(nose_radius=rho), st)
            for st in (Strategy.PAPER, Strategy.ARCS) for rho in (0.0, 0.2)}


def rs274(tmp_path: Path, text: str) -> str:
    exe = require_program("rs274")
    prog = tmp_path / "prog.ngc"
    prog.write_text(text)
    (tmp_path / "tools.tbl").write_text(TOOLS)
    res = subprocess.run([exe, "-t", str(tmp_path / "tools.tbl"), "-g", str(prog)], capture_output=True,
                         text=True, cwd=tmp_path, env=dict(os.environ, HOME=str(tmp_path)), timeout=60)
    assert res.returncode == 0, res.stdout[-2000:] + res.stderr[-2000:]
    return res.stdout


def canonical(out: str) -> tuple[list[tuple], tuple[float, float]]:
    """Every move rs274 reports, in order: (kind, end (r, Z), centre or None, rotation,
    finishing?) with kind "rapid", "line" or "arc" (G7: X reported as a radius); and the
    position the finishing contour starts from (the end of the move before "finish
    contour begin")."""
    moves, finishing, start = [], False, None
    for ln in out.splitlines():
        if 'COMMENT("finish contour begin")' in ln:
            finishing, start = True, moves[-1][1]
        if 'COMMENT("finish contour end")' in ln:
            finishing = False
        m = re.search(r"(STRAIGHT_FEED|STRAIGHT_TRAVERSE|ARC_FEED)\(([^)]*)\)", ln)
        if not m:
            continue
        v = [float(x) for x in m.group(2).split(",")]
        if m.group(1) == "ARC_FEED":  # XZ plane: first axis Z, second X
            moves.append(("arc", (v[1], v[0]), (v[3], v[2]), int(v[4]), finishing))
        else:
            moves.append(("rapid" if m.group(1) == "STRAIGHT_TRAVERSE" else "line", (v[0], v[2]), None, 0,
                          finishing))
    return moves, start


def sample_moves(moves, start, step=0.002):
    """Points along rs274's moves from `start` (arcs as LinuxCNC's spiral), one every
    `step` mm at least: a list of (kind, finishing, points (n, 2))."""
    cur = np.asarray(start, dtype=float)
    out = []
    for kind, end, centre, rot, fin in moves:
        end = np.asarray(end)
        n = max(3, int(math.ceil(np.hypot(*(end - cur)) * math.pi / 2 / step)) + 1)
        if kind == "arc":
            c = np.asarray(centre)
            a0, a1 = math.atan2(*(cur - c)[::-1]), math.atan2(*(end - c)[::-1])
            sweep = a1 - a0
            # rotation +1 = counterclockwise in (Z, X) = clockwise in (r, Z)
            while rot > 0 and sweep >= 0:
                sweep -= 2 * math.pi
            while rot < 0 and sweep <= 0:
                sweep += 2 * math.pi
            u = np.linspace(0, 1, n)
            rad = np.hypot(*(cur - c)) + (np.hypot(*(end - c)) - np.hypot(*(cur - c))) * u
            pts = c + rad[:, None] * np.stack([np.cos(a0 + sweep * u), np.sin(a0 + sweep * u)], -1)
        else:
            t = np.linspace(0, 1, n)[:, None]
            pts = (1 - t) * cur + t * end
        out.append((kind, fin, pts))
        cur = end
    return out


def depth_into_part(p: np.ndarray, m) -> np.ndarray:
    """How deep (mm) machine-frame points (r, Z) lie inside the exact part (< 0 outside):
    below the inner sheet z = e + a sqrt(1 + r^2/b^2) for r <= r_j, below the outer sheet
    beyond, the depth normal to the sheet to first order; under the inner lobe the wall
    facing the rim (r = r_j, from the outer sheet up to the inner rim) may be nearer."""
    r, zm = np.abs(p[:, 0]), p[:, 1]
    depth = np.full(r.shape, -np.inf)
    rj = m.r_junction
    for lobe, sel in ((m.inner, r <= rj), (m.outer, (r > rj) & (r <= m.r_max))):
        a, b, e = lobe.a, lobe.b, lobe.e
        q = np.sqrt(1 + (r[sel] / b) ** 2)
        top = m.vertex_z - (e + a * q)
        slope = a * r[sel] / (b * b * q)
        depth[sel] = (top - zm[sel]) / np.sqrt(1 + slope**2)
    z_foot = m.vertex_z - (m.outer.e + m.outer.a * math.sqrt(1 + (rj / m.outer.b) ** 2))
    under = r <= rj
    wall = np.hypot(rj - r[under], np.maximum(0.0, z_foot - zm[under]))  # to the wall segment
    depth[under] = np.minimum(depth[under], wall)
    return depth



def nose_depth(pieces, rho: float, m) -> float:
    """Deepest point of a whole nose circle (every 1 deg) along the points."""
    path = np.concatenate([p for _, _, p in pieces])
    phi = np.radians(np.arange(0.0, 360.0, 1.0))
    circle = rho * np.stack([np.cos(phi), np.sin(phi)], -1)
    worst = -np.inf
    for chunk in np.array_split(path, max(1, len(path) // 2000)):
        pts = (chunk[:, None, :] + circle[None]).reshape(-1, 2)
        worst = max(worst, float(depth_into_part(pts, m).max()))
    return max(0.0, worst)


def flank_depth(pieces, tool: Tool, m, length: float = 6.0) -> float:
    """Deepest point of the held tool's two flanks (tangent to the nose, `length` mm long)
    along the points: the tool's body must stay out of the part."""
    path = np.concatenate([p for _, _, p in pieces])[::5]
    rho = tool.nose_radius
    worst = -np.inf
    s = np.linspace(0.0, length, 121)
    lo, hi = tool.flank_directions()
    for phi, side in ((lo, lo - math.pi / 2), (hi, hi + math.pi / 2)):
        base = rho * np.array([math.cos(side), math.sin(side)])
        line = base + s[:, None] * np.array([math.cos(phi), math.sin(phi)])
        pts = (path[:, None, :] + line[None]).reshape(-1, 2)
        worst = max(worst, float(depth_into_part(pts, m).max()))
    return worst


# --------------------------------------------------------------------------------------


def test_the_opposite_hand_cuts_the_outer_step(plans):
    for tp in plans.values():
        assert tp.hand is Hand.OPPOSITE
        moves = tp.cutting_moves()
        # cut from the rim in: the first move starts at the rim's end, the last ends on the axis
        assert moves[0].start == tp.segments[-1].end and moves[-1].end == tp.segments[0].start
        assert moves[-1].end[0] == 0.0


@pytest.mark.parametrize("rho", [0.0, 0.2])
@pytest.mark.parametrize("strategy", [Strategy.PAPER, Strategy.ARCS])
def test_rs274_runs_the_program_and_the_nose_stays_out_of_the_part(tmp_path, plans, mirror, settings, strategy,
                                                                  rho):
    tp = plans[(strategy, rho)]
    text = program(tp, settings.stock, "linuxcnc")
    assert "T3 M6 G43" in text and "T4 M6 G43" in text and "T1 M6" not in text
    assert "OPPOSITE-HAND holder" in text and "cutting from the rim in" in text
    moves, start = canonical(rs274(tmp_path, text))
    fin = [mv for mv in moves if mv[4]]
    want = tp.cutting_moves()
    # from the contour's start (the rim), the moves themselves, rim to axis
    assert len(fin) == len(want)
    assert np.allclose(start, want[0].start, atol=1e-4)
    for seg, mv in zip(want, fin):
        assert mv[0] == ("arc" if isinstance(seg, Arc) else "line")
        assert np.allclose(mv[1], seg.end, atol=1e-4)
        if isinstance(seg, Arc):
            assert np.allclose(mv[2], seg.centre, atol=1e-4)
            assert (mv[3] == -1) == seg.clockwise
    # the nose swept along rs274's finishing moves: no gouge beyond the tolerance
    pieces = sample_moves(fin, start, step=0.002)
    if rho > 0:
        depth = nose_depth(pieces, rho, mirror)
        assert depth <= GOUGE_TOL
        stated = float(re.search(r"deepest point inside the part (\S+) mm", text).group(1))
        assert abs(depth - stated) < 2e-4, (depth, stated)
        # the sweep sees a gouge: a nose 0.05 mm larger than programmed cuts ~0.05 mm deeper
        assert nose_depth(pieces, rho + 0.05, mirror) == pytest.approx(depth + 0.05, abs=2e-3)


def test_roughing_never_cuts_the_part_and_the_held_flanks_clear_it(tmp_path, plans, mirror, settings):
    """Every rapid and roughing move keeps the nose clear of the finished part; the
    opposite-hand holder's flanks stay out of the part along the whole program, where the
    holder as configured would run its flank into the inner lobe's rim (the step wall
    faces the rim)."""
    tp = plans[(Strategy.ARCS, 0.2)]
    moves, _ = canonical(rs274(tmp_path, program(tp, settings.stock, "linuxcnc")))
    first = moves[0][1]
    pieces = sample_moves(moves[1:], first, step=0.01)
    before = [p for p in pieces if not p[1]]
    assert nose_depth(before, 0.2, mirror) <= 1e-9
    held = tp.held_tool
    assert flank_depth(pieces, held, mirror) <= GOUGE_TOL
    fin = [p for p in pieces if p[1]]
    assert flank_depth(fin, Tool(nose_radius=0.2), mirror) > 0.05  # the configured hand rubs


def test_the_largest_nose_by_brute_force(mirror):
    """check_junction's largest nose: a nose at the column r_j + rho, lowered until it
    touches the outer sheet (a dense sample of the sheet), has its centre at the height
    of the step's top (the inner rim) exactly when rho is the largest."""
    rho_max = check_junction(mirror, Tool(nose_radius=0.0))

    def centre_z(rho):
        r = np.linspace(mirror.r_junction, mirror.r_junction + 2 * rho, 200001)
        zs = mirror.vertex_z - mirror.outer.z(r)
        dx = r - (mirror.r_junction + rho)
        # the centre height at which the circle touches the sheet's highest point within reach
        return float(np.max(zs + np.sqrt(np.maximum(rho**2 - dx**2, 0.0))))

    z_top = mirror.vertex_z - mirror.inner.z(mirror.r_junction)
    assert centre_z(rho_max) == pytest.approx(float(z_top), abs=1e-6)
    assert junction_margin(mirror, 0.2) == pytest.approx(float(z_top) - centre_z(0.2), abs=1e-6)
    with pytest.raises(Exception, match="too large for the junction"):
        check_junction(mirror, Tool(nose_radius=rho_max + 0.01))


def test_toolpath_cli_cuts_it(tmp_path):
    cfg = tmp_path / "r.toml"
    cfg.write_text(RECESSED_OUTER)
    out = tmp_path / "p.ngc"
    proc = run_cli("toolpath", "--config", str(cfg), "-o", str(out), "--json")
    assert proc.returncode == 0, proc.stderr
    import json

    data = json.loads(proc.stdout)
    assert data["junction_fillet"]["lobe"] == "outer"
    assert "T4 M6 G43" in out.read_text()


def test_fanuc_calls_the_opposite_hand_stations(plans, settings):
    text = program(plans[(Strategy.ARCS, 0.2)], settings.stock, "fanuc")
    assert "T0303" in text and "T0404" in text and "T0101" not in text


def test_the_paper_is_still_cut_as_configured(paper_mirror):
    tp = plan_toolpath(paper_mirror, load().machine, Tool(nose_radius=0.2), Strategy.ARCS)
    assert tp.hand is Hand.AS_CONFIGURED and tp.cutting_moves() == tp.segments
    text = program(tp, Stock())
    assert "T1 M6 G43" in text and "T2 M6 G43" in text and "OPPOSITE" not in text
