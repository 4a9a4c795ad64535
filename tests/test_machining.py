"""The as-machined surface: tool-nose envelope against a brute-force sweep, the
junction's fillet against the corner-wedge hand calculation, and the gouge check."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from lathe_mirror.lathe import Lathe, Tool
from lathe_mirror.nose_envelope import as_machined, gouge_depth, nose_envelope
from lathe_mirror.path import Arc, Line
from lathe_mirror.profile import PathProfile
from lathe_mirror.toolpath import Strategy, plan_toolpath, profile_errors

LATHE = Lathe()


@pytest.fixture(scope="module")
def tp02(paper_mirror):
    return plan_toolpath(paper_mirror, LATHE, Tool(nose_radius=0.2), Strategy.ARCS)


def brute_envelope(tp, rho, r, step=0.0002):
    """Lowest point (machine Z) of any nose circle centred on densely sampled path
    points, at each radius r: the definition of the swept surface, no offsets."""
    pts = np.concatenate([s.sample(max(2, int(math.ceil(_len(s) / step)) + 1)) for s in tp.segments])
    out = np.full(r.shape, np.inf)
    for i, x in enumerate(r):
        near = pts[np.abs(pts[:, 0] - x) <= rho]
        if near.size:
            out[i] = np.min(near[:, 1] - np.sqrt(np.maximum(rho**2 - (x - near[:, 0]) ** 2, 0)))
    return out


def _len(s):
    p = s.sample(64)
    return float(np.hypot(*np.diff(p, axis=0).T).sum())


@pytest.mark.parametrize("window", [(0.0, 0.3), (9.8, 10.1), (19.6, 20.0), (20.0, 20.3), (34.7, 35.0)])
def test_envelope_matches_a_brute_force_sweep(tp02, paper_mirror, window):
    r = np.linspace(*window, 61)
    if window[0] == 20.0:
        r = r[1:]  # r = 20 belongs to the inner lobe
    am = as_machined(tp02)
    got = paper_mirror.vertex_z - am.z(r)
    want = brute_envelope(tp02, 0.2, r)
    # sampling the path every 0.2 um leaves scallops < step^2 / (8 rho) = 2.5e-8 mm
    assert np.max(np.abs(got - want)) < 2e-6


@pytest.mark.parametrize("strategy, nose", [(Strategy.PAPER, 0.4), (Strategy.ARCS, 0.4)])
def test_envelope_matches_a_brute_force_sweep_on_another_design(design_case, strategy, nose):
    """Each vertex's nose circle is taken only over its window of angles (between the two
    moves' offset directions): the paper's method (527 lines, a window at every vertex) and
    the arcs (spirals) with a 0.4 mm nose, on the paper default and the recessed design,
    against the brute-force sweep across each lobe's rims and junction."""
    m = design_case["mirror"]
    tp = plan_toolpath(m, LATHE, Tool(nose_radius=nose), strategy)
    am = as_machined(tp)
    for lo, hi in ((0.0, 0.4), (0.5 * m.r_junction - 0.2, 0.5 * m.r_junction + 0.2),
                   (m.r_junction - 0.45, m.r_junction - 0.001), (m.r_junction + 0.001, m.r_junction + 0.45),
                   (m.r_max - 0.4, m.r_max)):
        r = np.linspace(lo, hi, 81)
        got = m.vertex_z - am.z(r)
        want = brute_envelope(tp, nose, r)
        assert np.max(np.abs(got - want)) < 2e-6, (lo, hi)


def _path(segs, r_junction, r_max):
    """A made-up program (what nose_envelope reads of a Toolpath): the moves, the inner lobe's
    up to the last, which is the outer lobe's."""
    mirror = SimpleNamespace(r_junction=r_junction, r_max=r_max, step=1.0, vertex_z=0.0)
    return SimpleNamespace(mirror=mirror, segments=tuple(segs), lobe_of=("inner",) * (len(segs) - 1) + ("outer",))


@pytest.mark.parametrize("z", [1.0, -1.0])
def test_envelope_where_the_path_turns_back_in_r(z):
    """A path that turns back in r (a '<', as a valley and as a peak): the nose circle at
    the turn is exposed outside the angles between the two moves' offsets, so the vertex
    keeps its whole lower half; against the brute-force sweep (a review's counterexamples:
    1.5 mm off at r = 0.714 for the valley, 2 mm at r = 2.18 for the peak, before)."""
    segs = [Line((0.0, 2 * z), (2.0, z)), Line((2.0, z), (1.0, 0.0)), Line((1.0, 0.0), (2.0, -z)),
            Line((2.0, -z), (5.0, -z)), Line((5.0, -z), (10.0, -z))]
    tp = SimpleNamespace(**{**vars(_path(segs, 5.0, 10.0)), "nose_radius": 0.4})
    made = nose_envelope(tp, 0.4)
    # at the envelope's own samples (no interpolation across the circles' steep sides), none
    # at a vertex +- rho (where the sampled sweep's reach rounds)
    r, z, _ = made.lobes[0]
    pick = np.flatnonzero((r > 0.5) & (r < 2.5))[::40]
    pick = pick[np.min(np.abs(r[pick, None] - np.array([0.6, 1.4, 1.6, 2.4])), axis=1) > 1e-6]
    assert np.max(np.abs(-z[pick] - brute_envelope(tp, 0.4, r[pick]))) < 2e-6


def test_offset_contour_keeps_the_circle_next_to_a_dropped_end():
    """contour_profile's envelope (include_junction=False) leaves out the run's end points:
    the circle of the vertex beside one is then not covered by the end's, and is kept whole.
    The definition computed here for lines: each move's offset by rho toward -Z and the lower
    half circle at each interior vertex, the lowest at each radius."""
    rho = 0.1
    segs = [Line((0.0, 0.0), (0.036, 0.038)), Line((0.036, 0.038), (0.06, 0.038)), Line((0.06, 0.038), (4.0, -1.0)),
            Line((4.0, -1.0), (5.0, -1.0)), Line((5.0, -1.0), (10.0, -1.0))]
    made = nose_envelope(_path(segs, 5.0, 10.0), rho, include_junction=False)
    r = np.linspace(0.0, 0.25, 501)
    want = np.full(r.size, np.inf)
    by_move = np.zeros(r.size, bool)
    for (r0, z0), (r1, z1) in ((s.start, s.end) for s in segs[:4]):
        d = math.hypot(r1 - r0, z1 - z0)
        nr, nz = (z1 - z0) / d, -(r1 - r0) / d  # the normal toward -Z
        inside = (r >= min(r0, r1) + rho * nr) & (r <= max(r0, r1) + rho * nr)
        by_move |= inside
        want = np.where(inside, np.minimum(want, z0 + rho * nz + (z1 - z0) / (r1 - r0) * (r - r0 - rho * nr)), want)
    for vr, vz in (s.end for s in segs[:3]):
        reach = np.abs(r - vr) <= rho
        want = np.where(reach, np.minimum(want, vz - np.sqrt(np.maximum(rho**2 - (r - vr) ** 2, 0))), want)
    # from where the moves' offsets start (r = 0.0345, the third move's; before it the
    # envelope extends that offset along its slope)
    first = np.argmax(by_move)
    got = -made.z(r)
    assert np.max(np.abs(got[first:] - want[first:])) < 1e-9


def test_the_fillet_in_the_inside_corner(tp02, paper_mirror):
    """The nose cannot enter the corner at the wall's foot: at the wall (r = 20) the
    surface stands rho / tan(theta / 2) above the foot (tangent-line hand estimate with
    theta the corner's opening, 90 deg - the inner rim's slope angle)."""
    m = paper_mirror
    am = as_machined(tp02)
    theta = math.pi / 2 - math.atan(float(m.inner.slope(20.0)))
    est = 0.2 / math.tan(theta / 2)
    rise = float(m.inner.z(20.0) - am.z(np.array([20.0]))[0])  # camera z: above = smaller z
    assert abs(rise - est) / est < 0.08
    # and the fillet is the nose circle: radius 0.2 about the path's corner point
    c = np.array(tp02.lobe_segments("inner")[-1].end)
    r = np.linspace(c[0] + 0.01, 20.0, 20)
    zm = m.vertex_z - am.z(r)
    assert np.allclose(np.hypot(r - c[0], zm - c[1]), 0.2, atol=1e-6)
    # it costs the inner lobe's rim: a large local slope error, reported honestly
    e = profile_errors(am, m)
    assert e["lobes"][0]["slope_error_rad"]["max"] > 0.5


def test_zero_nose_is_the_programmed_contour(paper_mirror):
    """A sharp tool cuts its own path: the as-machined surface passes through every
    programmed end point and, halfway along each move, through the point the controller
    is at there (a line's midpoint; on an arc, radius linear in the swept angle about the
    programmed centre), all computed here from the program's numbers (camera z = vertex_z - Z)."""
    tp = plan_toolpath(paper_mirror, LATHE, Tool(nose_radius=0.0), Strategy.ARCS)
    made = as_machined(tp)
    assert isinstance(made, PathProfile)
    zero = paper_mirror.vertex_z
    for seg, lobe in zip(tp.segments, tp.lobe_of):
        if lobe == "junction":
            continue
        (r0, z0), (r1, z1) = seg.start, seg.end
        if isinstance(seg, Arc):
            cr, cz = seg.centre
            a0, a1 = math.atan2(z0 - cz, r0 - cr), math.atan2(z1 - cz, r1 - cr)
            sweep = (a1 - a0 + math.pi) % (2 * math.pi) - math.pi
            rad = 0.5 * (math.hypot(r0 - cr, z0 - cz) + math.hypot(r1 - cr, z1 - cz))
            mid = (cr + rad * math.cos(a0 + sweep / 2), cz + rad * math.sin(a0 + sweep / 2))
        else:
            mid = ((r0 + r1) / 2, (z0 + z1) / 2)
        for r, z in (mid, (r1, z1)):
            side = np.nextafter(r, 0.0) if abs(r - paper_mirror.r_junction) < 1e-12 else r
            assert made.z(np.array([side]))[0] == pytest.approx(zero - z, abs=1e-9)


def test_nose_compensated_path_cuts_the_surface(tp02, paper_mirror):
    """The nose-centre path sits rho off the surface; its envelope comes back to it."""
    e_path = profile_errors(as_machined(tp02, nose_radius=0.0), paper_mirror)
    e_cut = profile_errors(as_machined(tp02), paper_mirror)
    for a, b in zip(e_path["lobes"], e_cut["lobes"]):
        assert 0.19 < a["normal_deviation_mm"]["rms"] < 0.21
    # away from the junction's fillet the cut surface is within a few um of the design
    outer = e_cut["lobes"][1]
    assert outer["normal_deviation_mm"]["max"] < 0.003


def test_gouge_check(tp02, paper_mirror):
    assert 0.0 <= gouge_depth(tp02) <= 0.005  # the stated tolerance
    # a nose 0.1 mm larger than the path was planned for cuts 0.1 mm into the part
    deeper = gouge_depth(tp02, nose_radius=0.3)
    assert abs(deeper - 0.1) < 0.005


def test_junction_fillet_extent_by_hand(tp02, paper_mirror):
    """Tangent lengths of a circle in a corner of opening theta are rho / tan(theta / 2):
    up the wall, and back along the inner lobe (whose slope angle there is 90 - theta)."""
    from lathe_mirror.nose_envelope import junction_fillet

    m = paper_mirror
    phi = math.atan(float(m.inner.slope(20.0)))  # the inner rim's slope angle
    tangent = 0.2 / math.tan((math.pi / 2 - phi) / 2)
    f = junction_fillet(tp02)
    assert abs(f["height_mm"] - tangent) < 0.02 * tangent
    assert abs((20.0 - f["r_start_mm"]) - tangent * math.cos(phi)) < 0.02 * tangent
    assert junction_fillet(tp02, nose_radius=0.0) is None


def test_the_nose_cuts_the_rim_with_its_offset_not_its_side(tp02, paper_mirror):
    """The best program's last point lies past the rim's nose centre (35 + rho sin of
    the rim's slope angle, by hand), so the rim's last microns are cut by the nose's
    contact point and keep the hyperbola's slope (a point short of it would leave the
    nose's side there, 0.035 rad off on the paper's machine)."""
    m = paper_mirror
    s = float(m.outer.slope(35.0))
    centre_r = 35.0 + 0.2 * s / math.sqrt(1 + s * s)  # outward normal's r component
    assert tp02.segments[-1].end[0] >= centre_r
    r = np.linspace(34.99, 35.0, 101)
    made = as_machined(tp02)
    err = np.abs(np.arctan(made.slope(r)) - np.arctan(m.outer.slope(r)))
    assert err.max() < 2e-3
