"""Toolpath strategies: lattice, budget, the paper's rounding, the junction, the figures."""

from __future__ import annotations

import math

import numpy as np
import pytest

from lathe_mirror.errors import InputError
from lathe_mirror.lathe import Lathe, Tool
from lathe_mirror.nose_envelope import contour_profile
from lathe_mirror.profile import ExactProfile, PathProfile, Profile
from lathe_mirror.toolpath import (BEST, Arc, Line, Strategy, check_junction, check_travel,
                                   plan_toolpath, profile_errors, usable_ranges)

LATHE = Lathe()  # the paper's machine: 0.005 mm, 528 points


@pytest.fixture(scope="module")
def plans(paper_mirror):
    return {(st, rho): plan_toolpath(paper_mirror, LATHE, Tool(nose_radius=rho), st)
            for st in Strategy for rho in (0.0, 0.2)}


def test_best_is_the_shipped_default():
    """The strategy of the shipped default (data/machine.toml, read here as TOML) is the
    one test_best_slope_error_is_20x_below_the_paper_method shows best, and the typed
    settings carry it as that enum member."""
    import tomllib
    from importlib import resources

    from lathe_mirror.config import load

    shipped = tomllib.loads((resources.files("lathe_mirror") / "data" / "machine.toml").read_text())
    assert shipped["toolpath"]["strategy"] == "arcs"
    assert load().toolpath.strategy is BEST is Strategy.ARCS


@pytest.mark.parametrize("rho", [0.0, 0.2])
@pytest.mark.parametrize("strategy", list(Strategy))
def test_on_the_lattice_and_within_the_budget(plans, strategy, rho):
    tp = plans[(strategy, rho)]
    pts, centres = tp.points(), tp.centres()
    for v in (pts, centres):
        k = v / 0.005
        assert np.all(np.abs(k - np.rint(k)) < 1e-9)
    # the budget by hand: the start point, one per G1, two per G2/G3 (end and centre)
    n_lines = sum(1 for s in tp.segments if isinstance(s, Line))
    n_arcs = sum(1 for s in tp.segments if isinstance(s, Arc))
    assert tp.n_points == 1 + n_lines + 2 * n_arcs <= 528
    # moves chain, from the axis to the rim
    for a, b in zip(tp.segments[:-1], tp.segments[1:]):
        assert a.end == b.start
    assert tp.segments[0].start[0] == 0.0
    # arcs: the two radii within the machine's tolerance (LinuxCNC cuts the spiral)
    for s in tp.segments:
        if isinstance(s, Arc):
            assert abs(s.end_radius - s.radius) <= LATHE.arc_radius_tolerance + 1e-12


def test_paper_method_rounds_points_spread_along_the_profile(plans, paper_mirror):
    tp = plans[(Strategy.PAPER, 0.0)]
    assert tp.n_points == 528  # the paper's 528 points, all used
    for name, lobe in (("inner", paper_mirror.inner), ("outer", paper_mirror.outer)):
        segs = tp.lobe_segments(name)
        p = np.array([segs[0].start] + [s.end for s in segs])
        # each point is a lattice rounding of a curve point: some curve point lies within
        # half a step in r AND in Z (Z is monotone in r, so test the interval's ends)
        z_lo = paper_mirror.vertex_z - lobe.z(p[:, 0] + 0.0025)
        z_hi = paper_mirror.vertex_z - lobe.z(np.maximum(p[:, 0] - 0.0025, 0))
        assert np.all(p[:, 1] >= z_lo - 0.0025 - 1e-12) and np.all(p[:, 1] <= z_hi + 0.0025 + 1e-12)
        # spread evenly: chord lengths equal up to the rounding (+-0.007 mm)
        chords = np.hypot(*np.diff(p, axis=0).T)
        assert chords.max() - chords.min() < 0.015


def test_best_slope_error_is_20x_below_the_paper_method(plans, paper_mirror):
    """The issue's 'done when': max slope error, nose radius 0, each lobe."""
    paper = profile_errors(contour_profile(plans[(Strategy.PAPER, 0.0)]), paper_mirror)
    best = profile_errors(contour_profile(plans[(BEST, 0.0)]), paper_mirror)
    for p, b in zip(paper["lobes"], best["lobes"]):
        ratio = p["slope_error_rad"]["max"] / b["slope_error_rad"]["max"]
        print(f"{p['name']}: paper max slope error {p['slope_error_rad']['max']:.3e} rad, "
              f"best {b['slope_error_rad']['max']:.3e} rad, ratio {ratio:.1f}")
        assert ratio >= 20.0
        # and it is no worse in normal deviation
        assert b["normal_deviation_mm"]["rms"] < p["normal_deviation_mm"]["rms"]


def test_paper_slope_error_matches_the_rounding_estimate(plans, paper_mirror):
    """Rounding to 0.005 mm on chords ~0.076 mm long: slope errors of order
    0.005 / 0.076 = 0.066 rad (the brief's hand estimate); the RMS of a uniform rounding
    error difference over a chord, sqrt(2 * 0.005^2 / 12) / 0.076 ~ 0.027 rad."""
    e = profile_errors(contour_profile(plans[(Strategy.PAPER, 0.0)]), paper_mirror)
    length = sum(np.hypot(*np.diff(np.array([s.start, s.end]), axis=0)[0])
                 for s in plans[(Strategy.PAPER, 0.0)].segments if isinstance(s, Line))
    chord = length / 527
    for lobe in e["lobes"]:
        assert 0.5 * 0.005 / chord < lobe["slope_error_rad"]["max"] < 2.0 * 0.005 / chord
        est = math.sqrt(2 * 0.005**2 / 12) / chord
        assert 0.6 * est < lobe["slope_error_rad"]["rms"] < 1.4 * est


def test_lattice_beats_rounding_in_rms(plans, paper_mirror):
    paper = profile_errors(contour_profile(plans[(Strategy.PAPER, 0.0)]), paper_mirror)
    lat = profile_errors(contour_profile(plans[(Strategy.LATTICE, 0.0)]), paper_mirror)
    for p, q in zip(paper["lobes"], lat["lobes"]):
        assert q["slope_error_rad"]["rms"] < 0.5 * p["slope_error_rad"]["rms"]
        assert q["slope_error_rad"]["max"] < p["slope_error_rad"]["max"]


def test_junction_sharp_tool_goes_straight_up_the_wall(plans, paper_mirror):
    tp = plans[(BEST, 0.0)]
    (wall,) = tp.lobe_segments("junction")
    # Table 1 / the design: inner sheet at r = 20 is z = 115.607, outer 113.786, vertex
    # 103.678: machine Z -11.929 and -10.108 (each to within half a step)
    assert wall.start[0] == wall.end[0] == 20.0
    assert abs(wall.start[1] - (103.678 - 115.607)) < 0.0025 + 0.001
    assert abs(wall.end[1] - (103.678 - 113.786)) < 0.0025 + 0.001
    assert wall.end[1] > wall.start[1]  # up (+Z): the inner lobe is recessed


def test_junction_with_a_nose_keeps_off_the_wall_and_corner(plans, paper_mirror):
    tp = plans[(BEST, 0.2)]
    j = tp.lobe_segments("junction")
    assert j[0].start[0] == j[0].end[0] == 19.8  # 20 - 0.2: the nose touches the wall
    corner = np.array([20.0, paper_mirror.vertex_z - float(paper_mirror.outer.z(20.0))])
    dist = min(np.hypot(*(s.sample(2001) - corner).T).min() for s in j)
    assert dist >= 0.2 - 0.005


def test_largest_nose_radius_follows_the_corner_wedge(paper_mirror):
    """Tangent-line estimate: a nose in a corner of opening theta touches the wall
    rho / tan(theta / 2) above the foot; the step is 1.821 mm, theta = 90 deg - the inner
    rim's slope angle. The exact (curved-lobe) value must be close."""
    s = float(paper_mirror.inner.slope(20.0))
    theta = math.pi / 2 - math.atan(s)
    est = abs(paper_mirror.step) * math.tan(theta / 2)
    rho_max = check_junction(paper_mirror, Tool(nose_radius=0.0))
    assert abs(rho_max - est) / est < 0.03
    with pytest.raises(InputError, match=r"tool.nose_radius = 0.8 mm is too large for the junction"):
        plan_toolpath(paper_mirror, LATHE, Tool(nose_radius=0.8))
    plan_toolpath(paper_mirror, LATHE, Tool(nose_radius=0.7))  # fits


def test_tool_flanks_must_clear_the_profile(paper_mirror):
    # inner rim normal is 90 - 47.1 = 42.9 deg from +r: a 50 deg insert at 3 deg rubs it
    with pytest.raises(InputError, match="tool.approach_angle \\+ tool.included_angle"):
        plan_toolpath(paper_mirror, LATHE, Tool(included_angle=math.radians(50)))
    # a flank leaning toward +X rubs the step wall
    with pytest.raises(InputError, match="step wall"):
        plan_toolpath(paper_mirror, LATHE, Tool(approach_angle=math.radians(-5)))


def test_budget_too_small(paper_mirror):
    with pytest.raises(InputError, match="machine.max_points = 12: too small"):
        plan_toolpath(paper_mirror, Lathe(max_points=12), Tool())
    # a budget that holds it: every strategy stays within it
    for st in Strategy:
        tp = plan_toolpath(paper_mirror, Lathe(max_points=120), Tool(nose_radius=0.0), st)
        assert tp.n_points <= 120


@pytest.mark.parametrize("max_dev", [0.0, -1.0, float("nan")])
def test_max_deviation_must_be_positive(paper_mirror, max_dev):
    with pytest.raises(InputError, match="toolpath.max_deviation"):
        plan_toolpath(paper_mirror, LATHE, Tool(), max_deviation=max_dev)


def test_travel(paper_mirror):
    with pytest.raises(InputError, match="machine.travel_x = 30"):
        plan_toolpath(paper_mirror, Lathe(travel_x=30.0), Tool())
    with pytest.raises(InputError, match="travel_z"):
        check_travel(np.array([[1.0, -90.0]]), LATHE, what="x")


def test_coarser_lattice_is_worse(paper_mirror):
    fine = profile_errors(contour_profile(plan_toolpath(paper_mirror, LATHE, Tool(nose_radius=0.0),
                                                        Strategy.PAPER)), paper_mirror)
    coarse_lathe = Lathe(resolution=0.02)
    tp = plan_toolpath(paper_mirror, coarse_lathe, Tool(nose_radius=0.0), Strategy.PAPER)
    assert coarse_lathe.on_lattice(tp.points())
    coarse = profile_errors(contour_profile(tp), paper_mirror)
    for f, c in zip(fine["lobes"], coarse["lobes"]):
        assert c["slope_error_rad"]["rms"] > 2.5 * f["slope_error_rad"]["rms"]


# --------------------------------------------------------------------------------------
# profile_errors against hand calculations


class _Shifted(Profile):
    """The exact profile moved by dz along z, its slope tilted by eps (rad)."""

    def __init__(self, mirror, dz=0.0, eps=0.0):
        self.ex = ExactProfile(mirror)
        self.r_junction, self.r_max, self.vertex_z = mirror.r_junction, mirror.r_max, mirror.vertex_z
        self.dz, self.eps = dz, eps

    def z(self, r):
        return self.ex.z(r) + self.dz

    def slope(self, r):
        return np.tan(np.arctan(self.ex.slope(r)) + self.eps)


def test_profile_errors_of_the_exact_profile_are_zero(paper_mirror):
    e = profile_errors(ExactProfile(paper_mirror), paper_mirror)
    assert [lb["name"] for lb in e["lobes"]] == ["inner", "outer"]
    for lb in e["lobes"]:
        assert lb["normal_deviation_mm"]["max"] < 1e-9
        assert lb["slope_error_rad"]["max"] < 1e-12


def test_profile_errors_shift_and_tilt(paper_mirror):
    d = 0.001
    e = profile_errors(_Shifted(paper_mirror, dz=d), paper_mirror)
    inner, outer = e["lobes"]
    # above the vertex the nearest sheet point is the vertex: exactly d
    assert abs(inner["normal_deviation_mm"]["max"] - d) < 1e-9
    # elsewhere to first order d cos(slope angle): RMS over r by hand (trapezoid)
    for lb, lobe, (lo, hi) in ((inner, paper_mirror.inner, (0, 20)), (outer, paper_mirror.outer, (20, 35))):
        r = np.linspace(lo, hi, 20001)
        s = lobe.slope(r)
        rms = math.sqrt(np.mean(d**2 / (1 + s**2)))
        assert abs(lb["normal_deviation_mm"]["rms"] - rms) < 1e-3 * rms
        assert lb["slope_error_rad"]["max"] < 1e-12
    e = profile_errors(_Shifted(paper_mirror, eps=1e-3), paper_mirror)
    for lb in e["lobes"]:
        assert abs(lb["slope_error_rad"]["rms"] - 1e-3) < 1e-12
        assert abs(lb["slope_error_rad"]["max"] - 1e-3) < 1e-12


def test_chord_slope_error_by_hand(paper_mirror):
    """A one-chord inner lobe from the vertex to (1, Z(1)): its slope error peaks at an
    end, |atan(chord slope) - atan(exact slope)|, computed here by hand."""
    m = paper_mirror
    Z = lambda r: m.vertex_z - float(m.inner.z(r))  # noqa: E731
    inner = [Line((0.0, 0.0), (1.0, Z(1.0))), Line((1.0, Z(1.0)), (20.0, Z(20.0)))]
    outer = [Line((20.0, m.vertex_z - float(m.outer.z(20.0))), (35.0, m.vertex_z - float(m.outer.z(35.0))))]
    prof = PathProfile(inner, outer, r_junction=20.0, r_max=35.0, vertex_z=m.vertex_z)
    e = profile_errors(prof, m)
    # camera-frame chord slope of the long inner chord vs the exact slope at its ends
    k = (float(m.inner.z(20.0)) - float(m.inner.z(1.0))) / 19.0
    want = max(abs(math.atan(k) - math.atan(float(m.inner.slope(r)))) for r in (1.0, 20.0))
    assert abs(e["lobes"][0]["slope_error_rad"]["max"] - want) < 1e-6


def test_arc_profile_is_the_circle(paper_mirror):
    """An arc about a centre on the axis: z(r) is the circle, by hand."""
    m = paper_mirror
    R = 15.0
    c = (0.0, -R)
    end = (5.0, -R + math.sqrt(R * R - 25.0))
    arc = Arc(start=(0.0, 0.0), end=end, centre=c, clockwise=True)
    tail = Line(end, (20.0, end[1] - 10.0))
    outer = [Line((20.0, -10.0), (35.0, -20.0))]
    prof = PathProfile([arc, tail], outer, r_junction=20.0, r_max=35.0, vertex_z=m.vertex_z)
    r = np.linspace(0, 4.999, 11)  # r = 5 starts the next move
    zm = -R + np.sqrt(R * R - r * r)
    assert np.allclose(prof.z(r), m.vertex_z - zm, atol=1e-12)
    assert np.allclose(prof.slope(r), r / np.sqrt(R * R - r * r), atol=1e-9)
    assert arc.sweep < 0 and arc.clockwise


def test_contour_profile_passes_through_the_points(plans, paper_mirror):
    tp = plans[(BEST, 0.0)]
    prof = contour_profile(tp)
    ends = np.array([s.end for s in tp.lobe_segments("inner") + tp.lobe_segments("outer")])
    assert np.allclose(prof.z(ends[:, 0]), paper_mirror.vertex_z - ends[:, 1], atol=1e-9)


def test_usable_ranges_by_hand(paper_mirror):
    """The step wall's top corner (20, z_outer(20)) cuts off the inner lobe's world rays:
    the last inner point used is where the line from the inner F1 (0, 2e) through that
    corner meets the inner sheet (z - e)^2 / a^2 - r^2 / b^2 = 1 (a quadratic in t)."""
    m = paper_mirror
    lobe = m.inner
    a, b, e = lobe.a, lobe.b, lobe.e
    zc = float(m.outer.z(20.0))  # 113.786 in the figures
    # P(t) = (20 t, 2e + t (zc - 2e)); (e + t dz)^2 / a^2 - (20 t)^2 / b^2 = 1
    dz = zc - 2 * e
    roots = np.roots([dz**2 / a**2 - 400.0 / b**2, 2 * e * dz / a**2, e**2 / a**2 - 1.0])
    t = max(x.real for x in roots if abs(x.imag) < 1e-12)
    (lo0, hi0), (lo1, hi1) = usable_ranges(m)
    assert lo0 == 0.0 and abs(hi0 - 20.0 * t) < 1e-9
    assert 17.0 < hi0 < 20.0
    assert (lo1, hi1) == (20.0, 35.0)  # the inner lobe is recessed: the outer seen from r = 20


def test_used_zone_figures_leave_out_the_fillet(plans, paper_mirror):
    """The junction fillet (nose 0.2 mm) lies beyond the used radii: there the inner
    lobe's figures are those of the turned hyperbola, the outer lobe's unchanged."""
    from lathe_mirror.nose_envelope import as_machined, junction_fillet

    tp = plans[(BEST, 0.2)]
    made = as_machined(tp)
    whole = profile_errors(made, paper_mirror)
    used = profile_errors(made, paper_mirror, r_ranges=usable_ranges(paper_mirror))
    assert junction_fillet(tp)["r_start_mm"] > used["lobes"][0]["r_range_mm"]["max"]
    assert whole["lobes"][0]["slope_error_rad"]["max"] > 1.0
    assert used["lobes"][0]["slope_error_rad"]["max"] < 2e-3
    assert used["lobes"][1]["slope_error_rad"] == whole["lobes"][1]["slope_error_rad"]
    # a sub-range by hand: the exact profile shifted by d judged on r in [0, 1] only
    e = profile_errors(_Shifted(paper_mirror, dz=0.001), paper_mirror, r_ranges=((0.0, 1.0), (20.0, 35.0)))
    r = np.linspace(0.0, 1.0, 20001)
    s = paper_mirror.inner.slope(r)
    assert abs(e["lobes"][0]["normal_deviation_mm"]["rms"] - math.sqrt(np.mean(1e-6 / (1 + s**2)))) < 1e-7
    assert e["lobes"][0]["r_range_mm"] == {"min": 0.0, "max": 1.0}


def test_contour_profile_follows_the_spirals(plans, paper_mirror):
    """Between its ends an arc whose two radii differ is LinuxCNC's spiral (radius linear
    in the swept angle): the profile's z(r), solved for r by Newton's method, meets the
    spiral's points sampled by angle; its slope is the spiral's dZ/dphi / dr/dphi."""
    tp = plans[(BEST, 0.0)]
    prof = contour_profile(tp)
    spirals = [s for s in tp.segments if isinstance(s, Arc) and s.end_radius != s.radius]
    assert spirals  # the lattice centres make most arcs spirals
    for s in spirals:
        p = s.sample(9)[1:-1]
        assert np.allclose(prof.z(p[:, 0]), paper_mirror.vertex_z - p[:, 1], atol=1e-9)
        # slope by a central difference along the spiral's own parameter
        q0, q1 = s.sample(2001)[999], s.sample(2001)[1001]
        mid = s.sample(2001)[1000]
        want = -(q1[1] - q0[1]) / (q1[0] - q0[0])  # camera frame: dz/dr = -dZ/dr
        assert abs(prof.slope(np.array([mid[0]]))[0] - want) < 1e-6


def test_arcs_fall_back_to_chords_without_a_lattice_centre(paper_mirror):
    """No lattice point is a centre equidistant (to 1e-9 mm) from two lattice ends of a
    1 mm arc of this curvature: each such move becomes a G1 chord between the same
    ends (the gouge check then judges it), not an internal error."""
    tp = plan_toolpath(paper_mirror, Lathe(arc_radius_tolerance=1e-9), Tool(nose_radius=0.0), Strategy.ARCS)
    assert any(isinstance(s, Line) for s in tp.lobe_segments("inner") + tp.lobe_segments("outer"))
    for s in tp.segments:
        if isinstance(s, Arc):
            assert abs(s.end_radius - s.radius) <= 1e-9
