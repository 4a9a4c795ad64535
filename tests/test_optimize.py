"""The design optimiser: R10 against rays reflected off the sheet by hand, the thin-lens
focus model against two-ray tracing and the thin-lens law, the search against a dense grid,
reproducibility, the command (TOML that design and run take, rs274 on its programs), and
infeasible constraints."""

from __future__ import annotations

import dataclasses
import json
import math
import os
import subprocess
import tomllib

import numpy as np
import pytest
from scipy.optimize import brentq

from conftest import require_program, run_cli
from lathe_mirror.config import load
from lathe_mirror.design import LobeSpec, mirror_from_specs
from lathe_mirror.export.design_toml import design_toml
from lathe_mirror.lathe import Stock, Tool
from lathe_mirror.optics.ranging.resolution import r10
from lathe_mirror.optimize import OptimizeSettings, Problem, SearchSpace, search
from lathe_mirror.optimize.focus import defocus, virtual_image_distance
from lathe_mirror.optimize.pareto import pareto_front
from lathe_mirror.optimize.spec import Objective


# --------------------------------------------------------------------------------------
# R10 and the focus model against independent computations


def traced_elevation(lobe, camera, radius_px: float) -> float:
    """Elevation (rad) of the world direction a pixel sees through the lobe, by hand: the
    camera ray r = t z meets the sheet z = e + a sqrt(1 + r^2/b^2) (brentq), reflects
    about the normal (s, -1), and the reflected ray's direction is what F1 sees."""
    t = radius_px * camera.t_pixel / camera.f
    a, b, e = lobe.a, lobe.b, lobe.e
    z = lambda r: e + a * math.sqrt(1 + (r / b) ** 2)  # noqa: E731
    r = 0.0 if t == 0 else brentq(lambda r: z(r) - r / t, 0.0, 10 * lobe.r_top, xtol=1e-15)
    d = np.array([r, z(r)]) / math.hypot(r, z(r))
    s = a * r / (b * b * math.sqrt(1 + (r / b) ** 2))
    n = np.array([s, -1.0]) / math.hypot(s, 1.0)
    out = d - 2 * np.dot(d, n) * n
    return math.atan2(out[1], out[0])


def test_r10_of_the_paper_mirror_by_hand(paper_mirror):
    """Each lobe's angular resolution from finite differences of traced elevations, R10 =
    0.1 b cos(el) / sqrt(g_in^2 + g_out^2), median over 257 elevations of the common band:
    0.222 m, as the issue measured."""
    m, cam = paper_mirror, paper_mirror.camera
    lo, hi = m.common_band
    el = np.linspace(lo, hi, 257)
    g = []
    for lobe in m.lobes:
        rho = np.linspace(1.0, lobe.r_pixel, 4001)
        th = np.array([traced_elevation(lobe, cam, p) for p in rho])
        dth = np.gradient(th, rho)
        order = np.argsort(th)
        g.append(np.interp(el, th[order], np.abs(dth[order])))
    want = float(np.median(0.1 * m.baseline * np.cos(el) / np.hypot(g[0], g[1]) / 1000.0))
    assert r10(m) == pytest.approx(want, rel=2e-4)
    assert r10(m) == pytest.approx(0.222, abs=0.001)
    # over the robot's band (-20..0 deg) instead
    assert r10(m, (math.radians(-20), 0.0)) == pytest.approx(0.2344, abs=0.0005)


def test_virtual_image_at_the_vertex_is_the_mirror_equation(paper_mirror):
    """On the axis a convex mirror of vertex radius b^2/a images a point s_o in front of it
    1 / (1/s_o + 2a/b^2) behind the vertex (paraxial mirror equation)."""
    for lobe in paper_mirror.lobes:
        s_o = 2000.0 - (lobe.e - lobe.a)  # F1 is e - a behind the vertex
        want = lobe.vertex_z + 1.0 / (1.0 / s_o + 2.0 * lobe.a / lobe.b**2)
        d_t, d_s = virtual_image_distance(lobe, paper_mirror, np.array([0.0]), 2000.0)
        assert d_t[0] == pytest.approx(want, rel=1e-9) and d_s[0] == pytest.approx(want, rel=1e-9)


@pytest.mark.parametrize("radius_px", [120.0, 250.0, 400.0, 480.0])
def test_tangential_virtual_image_by_two_rays(paper_mirror, radius_px):
    """A scene point 2 m from F1 seen at this pixel; two rays from it to the sheet 1e-4 mm
    either side of the chief ray's point, reflected exactly: their backward extensions
    cross at the tangential virtual image, as far from the lens as the model says."""
    m = paper_mirror
    lobe = m.inner if radius_px < 300 else m.outer
    a, b, e = lobe.a, lobe.b, lobe.e
    t = radius_px * m.camera.t_pixel / m.camera.f
    z = lambda r: e + a * math.sqrt(1 + (r / b) ** 2)  # noqa: E731
    r0 = brentq(lambda r: z(r) - r / t, 0.0, 10 * lobe.r_top, xtol=1e-15)
    p0 = np.array([r0, z(r0)])
    f1 = np.array([0.0, 2 * e])
    w = f1 + 2000.0 * (p0 - f1) / np.linalg.norm(p0 - f1)
    lines = []
    for r in (r0 - 1e-4, r0 + 1e-4):
        p = np.array([r, z(r)])
        s = a * r / (b * b * math.sqrt(1 + (r / b) ** 2))
        n = np.array([s, -1.0]) / math.hypot(s, 1.0)
        u = (p - w) / np.linalg.norm(p - w)
        lines.append((p, u - 2 * np.dot(u, n) * n))
    (p1, o1), (p2, o2) = lines
    k = np.linalg.solve(np.stack([o1, -o2], axis=1), p2 - p1)
    image = p1 + k[0] * o1
    d_t, _ = virtual_image_distance(lobe, m, np.array([radius_px]), 2000.0)
    assert np.linalg.norm(image) == pytest.approx(d_t[0], rel=2e-4)


def test_blur_is_the_thin_lens_law_at_the_best_focus(paper_mirror):
    """Thin lens 1/f = 1/d + 1/v: images of the nearest and farthest virtual images at v_n,
    v_f; the sensor that equalises their blur circles sits at the harmonic mean, and the
    blur is A (v_n - v_s) / v_n, A = f / N the aperture."""
    cam = paper_mirror.camera
    d = defocus(paper_mirror, 8.0, 2000.0)
    near, far = d.virtual_mm
    v_n, v_f = 1 / (1 / cam.f - 1 / near), 1 / (1 / cam.f - 1 / far)
    v_s = 2 * v_n * v_f / (v_n + v_f)
    want = (cam.f / 8.0) * (v_n - v_s) / v_n / cam.t_pixel
    assert d.blur_px == pytest.approx(want, rel=1e-9)
    assert 1 / (1 / cam.f - 1 / d.focus_mm) == pytest.approx(v_s, rel=1e-9)
    assert d.blur_px == pytest.approx(6.64, abs=0.01)  # the paper at f/8 (data/optimize.toml)


# --------------------------------------------------------------------------------------
# The search against a dense grid


def small_problem(workers: int = 1) -> Problem:
    """Paper's camera, rims and outer lobe fixed; free: the inner rim's image radius
    (pixel_fraction) and the inner alpha. Every constraint relaxed but the band (-20..0
    deg), the lathe's made harmless (sharp tool, narrow flanks, large bar and body)."""
    s = load()
    space = SearchSpace(outer_r_top_fraction=(1.0, 1.0), junction_fraction=(20 / 35, 20 / 35),
                        outer_r_pixel_fraction=(1.0, 1.0), pixel_fraction=(0.45, 0.8),
                        alpha_inner_deg=(0.0, 30.0), alpha_outer_deg=(0.028, 0.028))
    o = OptimizeSettings(vertex_min_mm=1.0, rim_max_mm=1000.0, usable_min=0.0, blur_max_px=1e5, blur_limit_um=0.0,
                         maxiter=200, popsize=15, tol=1e-6, search=space, workers=workers,
                         objective=Objective.R10)
    tool = Tool(nose_radius=0.0, included_angle=math.radians(10.0), approach_angle=math.radians(1.0))
    return Problem(camera=s.camera, tool=tool, stock=Stock(diameter=200.0, length=200.0),
                   body=dataclasses.replace(s.body, thickness=200.0), clearance=2.0, settings=o,
                   reference=s.lobes)


def grid_r10(s, p, alpha):
    """R10 over -20..0 deg of the design (outer lobe the paper's, inner r_pixel = p * 504,
    inner alpha), or -inf if its common band (design.Mirror) does not cover -20..0 deg."""
    try:
        m = mirror_from_specs(s.camera, (LobeSpec("inner", 20.0, p * 504.0, alpha_deg=alpha),
                                         LobeSpec("outer", 35.0, 504.0, alpha_deg=0.028)))
    except ValueError:
        return -np.inf
    lo, hi = m.common_band
    if lo > math.radians(-20.0) or hi < 0.0:
        return -np.inf
    return r10(m, (math.radians(-20.0), 0.0))


@pytest.fixture(scope="module")
def searched():
    """The small problem searched on one worker: the result the grid test checks and the
    two-worker search must repeat (one search, not one per test)."""
    return search(small_problem(1))


def test_search_lands_within_1_percent_of_a_dense_grid(searched):
    s = load()
    ps, als = np.linspace(0.45, 0.8, 71), np.linspace(0.0, 30.0, 61)
    grid = np.array([[grid_r10(s, p, a) for a in als] for p in ps])
    i, j = np.unravel_index(np.argmax(grid), grid.shape)
    # refine around the grid's best
    ps2 = np.linspace(ps[max(i - 1, 0)], ps[min(i + 1, len(ps) - 1)], 41)
    als2 = np.linspace(als[max(j - 1, 0)], als[min(j + 1, len(als) - 1)], 41)
    fine = max(grid_r10(s, p, a) for p in ps2 for a in als2)
    assert np.isfinite(fine)
    res = searched
    assert res.best_figures.r10_m == pytest.approx(fine, rel=0.01)
    # and the grid, not the search, is the check: its best lies on the same design
    best = res.best
    assert grid_r10(s, best[0].r_pixel / 504.0, best[0].alpha_deg) == pytest.approx(res.best_figures.r10_m,
                                                                                     rel=1e-12)


def test_same_seed_same_design_whatever_the_workers(searched):
    a = searched
    b = search(small_problem(2))
    assert a.best == b.best and a.evaluations == b.evaluations


def test_pareto_front_by_brute_force():
    rng = np.random.default_rng(3)
    a, b = rng.random(300), rng.random(300)
    front = set(pareto_front(a, b).tolist())
    for k in range(300):
        dominated = np.any((a >= a[k]) & (b >= b[k]) & ((a > a[k]) | (b > b[k])))
        assert (k in front) == (not dominated)


def test_design_toml_round_trips():
    s = load()
    extra = {"scene": {"boxes": [{"centre": [1.0, 2.0, 0.0], "size": [0.5, 0.5, 0.5]}], "ambient": 0.25},
             "cad": {"product_name": 'a "quoted" name'}, "optimize": {"search": {"pixel_fraction": [0.2, 0.9]}}}
    lobes = (LobeSpec("inner", 20.123456789012345, 307.1, alpha_deg=13.000000000000002),
             LobeSpec("outer", 35.0, 504.0, alpha_deg=-1e-7))
    doc = tomllib.loads(design_toml(s.camera, lobes, comments=["a", "b"], extra=extra))
    # Written at 12 significant digits (export.numbers): 20.123456789012345 -> 20.1234567890,
    # 13.000000000000002 -> 13.0; short numbers exactly.
    assert doc["lobes"]["inner"] == {"r_top": 20.123456789, "r_pixel": 307.1, "alpha_deg": 13.0}
    assert doc["lobes"]["outer"]["alpha_deg"] == -1e-7
    assert doc["scene"] == extra["scene"] and doc["cad"] == extra["cad"] and doc["optimize"] == extra["optimize"]
    assert doc["camera"]["sensor_px"] == [1008, 1018]


# --------------------------------------------------------------------------------------
# The command


def test_optimize_beats_the_paper_in_its_own_envelope(tmp_path):
    """A short search (the full one is benchmarks/bench_optimize.py): the winner is at
    least the paper's R10 and meets every constraint."""
    cfg = tmp_path / "c.toml"
    cfg.write_text("[optimize]\nmaxiter = 15\n[tolerance]\ntrials = 40\nlattice_phases = 4\n")
    # one worker: the search's answer does not depend on the workers (test_same_seed_...);
    # the command's pool of 2 is test_written_design_reproduces_through_design_and_runs'
    proc = run_cli("optimize", "--config", str(cfg), "--json", "--no-progress", "--workers", "1")
    assert proc.returncode == 0, proc.stderr
    assert proc.stderr == ""
    data = json.loads(proc.stdout)
    assert data["reference_name"] == "paper" and data["reference_feasible"]
    assert data["gain"] >= 1.0
    assert all(c["slack"] >= 0 for c in data["constraints"])
    assert data["reference"]["sharp_r10_m"] == pytest.approx(0.2344, abs=0.0005)
    # the winner through the tolerance analysis: the nominal part passes every criterion
    check = data["check"]
    assert check["nominal_pass"] and all(c["pass"] for c in check["nominal"].values())
    assert "why" not in check or not check["why"].startswith("the nominal part fails")


#: The 35 mm envelope (vertex >= 103.6 mm, farthest point <= 138.6 mm) with a bar and body
#: that hold such a mirror, started from a design near its optimum (outer lobe recessed).
DEEP = """
[lobes.inner]
r_top = 19.84
r_pixel = 313.1
alpha_deg = 0.01
[lobes.outer]
r_top = 34.99
r_pixel = 450.8
alpha_deg = 0.01
[stock]
length = 50.0
[cad]
thickness = 45.0
[optimize]
rim_max_mm = 138.6
maxiter = 25
[tolerance]
trials = 40
lattice_phases = 4
"""


def test_written_design_reproduces_through_design_and_runs(tmp_path):
    """optimize -o: the TOML gives the same figures through `design --json`, and the shop's
    commands take it: programs rs274 accepts (opposite-hand holders: the outer lobe is
    recessed) and the programmed solid."""
    cfg = tmp_path / "deep.toml"
    cfg.write_text(DEEP)
    out = tmp_path / "best.toml"
    proc = run_cli("optimize", "--config", str(cfg), "-o", str(out), "--json", "--no-progress", "--workers", "2")
    assert proc.returncode == 0, proc.stderr
    data = json.loads(proc.stdout)
    assert out.exists() and (tmp_path / "best_pareto.png").read_bytes()[:4] == b"\x89PNG"
    best = data["best"]
    assert best["recessed"] == "outer" and best["hand"] == "opposite hand"
    # the outer-recessed winner passes its own tolerance verdict nominally (issue 20: the
    # slope criterion judged the fillet the inner rim hides)
    assert data["check"]["nominal_pass"], data["check"]
    design = run_cli("design", "--config", str(out), "--json")
    assert design.returncode == 0, design.stderr
    fig = json.loads(design.stdout)
    # The TOML holds the design at 12 significant digits (export.numbers): the figures
    # come back to ~1e-11 relative; 1e-9 leaves room for the conditioning of the rim angle.
    for k, lobe in enumerate(fig["lobes"]):
        for key in ("r_top", "r_pixel", "alpha_deg"):
            assert lobe[key] == pytest.approx(best["lobes"][k][key], rel=1e-9, abs=1e-9)
    assert fig["baseline_mm"] == pytest.approx(best["baseline_mm"], rel=1e-9)
    assert fig["common_band_deg"]["min"] == pytest.approx(best["band_deg"]["min"], rel=1e-9)
    assert fig["junction"]["step_mm"] == pytest.approx(best["step_mm"], rel=1e-9)
    # the same R10 from the design the file describes
    s = load(out)
    assert r10(s.mirror(), (math.radians(-20), 0.0)) == pytest.approx(best["sharp_r10_m"], rel=1e-9)
    # the user's sections are carried over
    assert tomllib.loads(out.read_text())["stock"]["length"] == 50.0
    # the shop's stages on the written file: both programs (each with its second set-up,
    # simulated against the stock by toolpath), which rs274 accepts, and the programmed
    # solid. (The report of such a recessed winner: test_designs and test_results; the
    # docs' your-camera tutorial runs every stage command on an optimised file.)
    shop = tmp_path / "out" / "gcode"
    for strategy in ("paper", "arcs"):
        tp = run_cli("toolpath", "--config", str(out), "--strategy", strategy, "-o", f"{shop}/")
        assert tp.returncode == 0, tp.stderr[-3000:]
    exe = require_program("rs274")
    # the tool table toolpath writes beside its programs (the second set-up's drills and bar too)
    assert (shop / "tools.tbl").exists()
    programs = sorted(shop.glob("*.ngc"))
    assert [p.name for p in programs] == ["mirror_arcs.ngc", "mirror_arcs_op2.ngc", "mirror_paper.ngc",
                                          "mirror_paper_op2.ngc"]
    for prog in programs:
        res = subprocess.run([exe, "-t", str(shop / "tools.tbl"), "-g", str(prog)], capture_output=True,
                             text=True, cwd=tmp_path, env=dict(os.environ, HOME=str(tmp_path)), timeout=120)
        assert res.returncode == 0, res.stdout[-2000:]
        if prog.name.endswith("_op2.ngc"):  # the second set-up (back face, bore) has no optical surface
            continue
        assert "CHANGE_TOOL(3)" in res.stdout and "CHANGE_TOOL(4)" in res.stdout  # opposite-hand holders
        assert "CHANGE_TOOL(1)" not in res.stdout
        assert ("ARC_FEED" in res.stdout) == (prog.name == "mirror_arcs.ngc")
    cad = run_cli("cad", "--config", str(out), "--which", "programmed", "--json", "-o",
                  str(tmp_path / "out" / "mirror_programmed.step"))
    assert cad.returncode == 0, cad.stderr[-3000:]
    check = json.loads(cad.stdout)["check"]  # the STEP read back (OCC): one valid solid
    assert check["solids"] == 1 and check["valid"] and check["volume_mm3"] > 0
    assert fig["junction"]["recessed"] == "outer"


#: A short search (2 generations of 5 a parameter): no design in the space meets these
#: constraints, so the least-infeasible one names the same binding key as a longer search's.
@pytest.mark.parametrize("text, key", [
    ("[optimize]\nblur_limit_um = 4.5\nmaxiter = 2\npopsize = 5\n", "optimize.blur_limit_um"),
    ("[optimize]\nblur_limit_um = 0.0\nblur_max_px = 0.5\nmaxiter = 2\npopsize = 5\n", "optimize.blur_max_px"),
    ("[optimize]\nband_deg = [-80.0, 30.0]\nmaxiter = 2\npopsize = 5\n", "optimize.band_deg"),
])
def test_infeasible_constraints_one_line_exit_2_nothing_written(tmp_path, text, key):
    cfg = tmp_path / "c.toml"
    cfg.write_text(text)
    out = tmp_path / "best.toml"
    proc = run_cli("optimize", "--config", str(cfg), "-o", str(out), "--no-progress")
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"lathe-mirror optimize: error: {key}:"), proc.stderr
    assert "binding" in lines[0] and "Traceback" not in proc.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.toml"]


def test_bad_workers_and_bad_keys(tmp_path):
    proc = run_cli("optimize", "--workers", "0", "--no-progress")
    assert proc.returncode == 2 and "argument --workers: 0: allowed 1 to 64" in proc.stderr
    cfg = tmp_path / "c.toml"
    cfg.write_text("[optimize]\nobjective = \"speed\"\n")
    proc = run_cli("optimize", "--config", str(cfg), "--no-progress")
    assert proc.returncode == 2 and "optimize.objective = 'speed': allowed delivered_r10_p5, r10, baseline" in proc.stderr


def test_the_second_set_ups_grip_is_a_constraint():
    """The winner must leave the second set-up's soft jaws their grip below the rim's
    shoulder (shop.second refuses a body whose side below the shoulder is shorter than the
    jaw gap plus the least grip, 3 + 5 mm: lathe.JAW_GAP + lathe.MIN_GRIP, the default of
    toolpath.min_grip_mm): the 6 mm lens design with its outer rim 24 mm below the vertex
    meets it 0.5 mm over (by 0) and breaks it 1 mm under by the hand-computed 1 mm."""
    from lathe_mirror.lathe import JAW_GAP, MIN_GRIP
    from lathe_mirror.optimize.evaluate import CONSTRAINTS, measure, violations

    s = load()
    cam = dataclasses.replace(s.camera, f=6.0, t_pixel=0.003, sensor_px=(1280, 1024))
    lobes = (LobeSpec("inner", r_top=5.143250067202264, r_pixel=354.34622080440613, alpha_deg=0.16491580636968806),
             LobeSpec("outer", r_top=12.962773350532286, r_pixel=511.82075923486775, alpha_deg=0.14021089596690714))
    m = mirror_from_specs(cam, lobes)
    rim_depth = float(m.outer.z(m.r_max)) - m.vertex_z  # the outer rim's depth below the vertex, by hand
    j = [i for i, c in enumerate(CONSTRAINTS) if "second set-up" in c.what]
    assert len(j) == 1 and CONSTRAINTS[j[0]].key == "cad.thickness"
    grip = JAW_GAP + MIN_GRIP
    assert grip == 8.0
    for thickness in (rim_depth + grip + 0.5, rim_depth + grip - 1.0):
        body = dataclasses.replace(s.body, thickness=thickness)
        problem = Problem(camera=cam, tool=dataclasses.replace(s.tool, nose_radius=0.4), stock=s.stock, body=body,
                          clearance=s.toolpath.clearance, settings=s.optimize, reference=s.lobes)
        v = violations(measure(m, problem, lobes, with_r10=False), problem)[j[0]]
        assert v == pytest.approx(max(0.0, rim_depth + grip - thickness), abs=1e-9)


ROBUST = """[optimize]
maxiter = 6
[tolerance]
trials = 100
lattice_phases = 2
nose_step_mm = 0.005
programs = ["best"]
"""


def test_robust_optimize_writes_the_allocated_tolerances_tolerance_confirms(tmp_path):
    """The robust objective (the default) on the paper camera: the winner's parts at the
    configured tolerances miss 95 % (the seat's 0.1 deg breaks the disparity criterion);
    optimize writes the least-cost tolerances that reach it into best.toml with what they
    cost, and `tolerance --config best.toml` draws the same trials at them (the seed,
    common random numbers) and counts the same yield. The winner's delivered R10 sits
    under its design R10, the nominal part's with the same blur, and the design's sits under
    the sharp R10 by the matcher's noise on that blur: n^2 = 0.1^2 + (0.03 x blur)^2, the
    blur circle the defocus and the Airy disc of f/8 on 9 um pixels (2.44 x 0.55 um x 8 /
    9 um = 1.193 px) in quadrature."""
    cfg = tmp_path / "robust.toml"
    cfg.write_text(ROBUST)
    out = tmp_path / "best.toml"
    proc = run_cli("optimize", "--config", str(cfg), "-o", str(out), "--json", "--no-progress", "--workers", "1")
    assert proc.returncode == 0, proc.stderr
    data = json.loads(proc.stdout)
    assert data["objective"] == "delivered_r10_p5"
    check = data["check"]
    d = check["delivered_r10_m"]
    blur = data["best"]["blur_px"]
    assert d["design"] == pytest.approx(data["best"]["design_r10_m"], rel=1e-12)
    assert d["sharp"] == pytest.approx(data["best"]["sharp_r10_m"], rel=1e-12)
    circle2 = blur**2 + (2.44 * 0.55e-3 * 8.0 / 0.009) ** 2
    assert d["design"] == pytest.approx(d["sharp"] / math.sqrt(1.0 + 0.01 + 0.03**2 * circle2), rel=1e-8)
    assert d["median"] <= d["design"] * (1 + 1e-12)
    assert check["yield"] < 0.95
    alloc = check["allocation"]
    assert alloc["reached"] and alloc["yield"] >= 0.95 and alloc["cost_ratio"] > 1.0
    text = out.read_text()
    assert f"their cost: {alloc['cost_ratio']:.3g} x" in text
    # the second target: the delivered R10's p5 within 90 % of the design's (the default
    # tolerance.delivered_p5_min_fraction), said in the file's comment
    dv = alloc["delivered"]
    assert dv["kept"] and dv["p5_m"] >= 0.9 * dv["design_r10_m"] and dv["min_fraction"] == 0.9
    assert f"delivered R10 p5 {dv['p5_m']:.4g} m" in text
    written = tomllib.loads(text)["tolerance"]["params"]
    for r in alloc["tolerances"]:
        if r["tighten"]:
            assert written[r["parameter"]] == pytest.approx(r["allocated"], rel=1e-5)
    tol = run_cli("tolerance", "--config", str(out), "--json", "--no-progress", "-o", str(tmp_path / "tol"))
    assert tol.returncode == 0, tol.stderr
    mc = json.loads(tol.stdout)["programs"]["best"]["monte_carlo"]
    assert mc["yield"] == pytest.approx(alloc["yield"], abs=0.011)  # one trial in 100 may flip on the rounding
    assert mc["yield"] >= 0.95
    assert mc["delivered_r10_m"]["p5"] >= 0.9 * mc["delivered_r10_m"]["design"]
    # the winner optimize checked is the design the file holds, digit for digit (its lobes
    # read back at the file's 12 digits): tolerance on the file judges the same part
    lobes = tomllib.loads(text)["lobes"]
    for lobe in data["best"]["lobes"]:
        assert {k: lobe[k] for k in ("r_top", "r_pixel", "alpha_deg")} == lobes[lobe["name"]]
