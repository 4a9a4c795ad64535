"""The body's meridian: closed-form volume against numerical integration, the exact conic
form of the lobes, the programmed contour's offset, bad body sizes."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import quad

from lathe_mirror.settings import from_config
from lathe_mirror.enums import Mount
from lathe_mirror.body import (BodySpec, Role, Segment, SegmentKind,
                                   design_meridian, moves_as_segments, programmed_contour)
from lathe_mirror.errors import InputError
from lathe_mirror.path import Arc
from lathe_mirror.profile import ExactProfile


def integrated_volume(mirror, spec: BodySpec) -> float:
    """2 pi r (face Z - bottom Z) dr by scipy.integrate.quad, lobe by lobe, from the
    camera-frame ExactProfile (not the meridian's segments); shoulder, bore and boss are
    cylinders (pi r^2 h by hand)."""
    prof = ExactProfile(mirror)
    T = spec.thickness
    height = lambda r: float(prof.to_machine_z(prof.z(r))) + T  # noqa: E731
    v = 0.0
    for lo, hi in ((0.0, mirror.r_junction), (mirror.r_junction, mirror.r_max)):
        # the outer lobe's own sheet at its lower end (the junction belongs to the inner)
        f = (lambda r: 2 * math.pi * r * height(r)) if lo == 0.0 else (
            lambda r: 2 * math.pi * r * (float(prof.to_machine_z(mirror.outer.z(r))) + T))
        v += quad(f, lo, hi, epsabs=0.0, epsrel=1e-13, limit=200)[0]
    R = spec.blank_diameter / 2
    z_rim = float(prof.to_machine_z(mirror.outer.z(mirror.r_max)))
    v += math.pi * (R**2 - mirror.r_max**2) * (z_rim + T)
    rm = spec.mount_diameter / 2
    if spec.mount is Mount.BORE:
        v -= math.pi * rm**2 * spec.mount_depth
    elif spec.mount is Mount.BOSS:
        v += math.pi * rm**2 * spec.mount_depth
    return v


@pytest.mark.parametrize("spec", [
    BodySpec(),
    BodySpec(blank_diameter=70.0, thickness=25.0, mount=Mount.BOSS, mount_diameter=30.0, mount_depth=10.0),
    BodySpec(blank_diameter=90.0, thickness=40.0, mount=Mount.NONE),
])
def test_closed_form_volume_matches_numerical_integration(paper_mirror, spec):
    mer = design_meridian(paper_mirror, spec)
    assert mer.volume() == pytest.approx(integrated_volume(paper_mirror, spec), rel=1e-11)


def test_meridian_features_are_the_design(paper_mirror):
    mer = design_meridian(paper_mirror, BodySpec())
    f = mer.features
    # Brief's hand figures: inner rim z = 115.607, outer sheet at r = 20: 113.786,
    # vertex 103.678, outer rim h = 123.457 (Table 1) -> machine Z = vertex - z.
    assert f["z_rim_inner"] == pytest.approx(103.678 - 115.607, abs=2e-3)
    assert f["z_step_outer"] == pytest.approx(103.678 - 113.786, abs=2e-3)
    assert f["step"] == pytest.approx(1.821, abs=1e-3)
    assert f["z_rim_outer"] == pytest.approx(103.678 - 123.457, abs=2e-3)
    assert f["depth"] == pytest.approx(123.457 - 103.678, abs=2e-3)
    assert mer.segments[0].start == (0.0, 0.0)
    assert mer.segments[-1].end == (0.0, 0.0)  # closed loop


def test_conic_bezier_is_the_hyperbola(paper_mirror):
    """The rational quadratic form of each lobe lies on (z - e)^2/a^2 - r^2/b^2 = 1."""
    mer = design_meridian(paper_mirror, BodySpec())
    for seg, lobe in ((mer.segments[0], paper_mirror.inner), (mer.segments[2], paper_mirror.outer)):
        ctrl, w = seg.conic_bezier()
        t = np.linspace(0, 1, 2001)[:, None]
        basis = np.hstack([(1 - t) ** 2, 2 * t * (1 - t) * w, t**2])
        pts = basis @ ctrl / basis.sum(axis=1, keepdims=True)
        z_cam = paper_mirror.vertex_z - pts[:, 1]
        residual = (z_cam - lobe.e) ** 2 / lobe.a**2 - pts[:, 0] ** 2 / lobe.b**2 - 1.0
        assert np.abs(residual).max() < 1e-12
        assert pts[0] == pytest.approx(seg.start) and pts[-1] == pytest.approx(seg.end)


def test_offset_of_a_corner_by_hand():
    """Centre path: right along Z = 1, then down (a right turn), then right again (a left
    turn). Offset to the right by 0.5: the right turn is cut where the offsets cross
    (at (1.5, 0.5)), the left turn leaves a quarter circle of radius 0.5 about (2, -1)."""
    path = [Segment(SegmentKind.LINE, (0.0, 1.0), (2.0, 1.0)),
            Segment(SegmentKind.LINE, (2.0, 1.0), (2.0, -1.0)),
            Segment(SegmentKind.LINE, (2.0, -1.0), (4.0, -1.0))]
    out = programmed_contour(path, 0.5)
    assert [s.kind for s in out] == [SegmentKind.LINE, SegmentKind.LINE, SegmentKind.ARC, SegmentKind.LINE]
    assert out[0].start == pytest.approx((0.0, 0.5)) and out[0].end == pytest.approx((1.5, 0.5))
    assert out[1].start == pytest.approx((1.5, 0.5)) and out[1].end == pytest.approx((1.5, -1.0))
    arc = out[2]
    assert arc.centre == (2.0, -1.0) and arc.radius == 0.5 and not arc.clockwise
    assert arc.start == pytest.approx((1.5, -1.0)) and arc.end == pytest.approx((2.0, -1.5))
    assert out[3].start == pytest.approx((2.0, -1.5)) and out[3].end == pytest.approx((4.0, -1.5))


def test_offset_of_arcs_by_hand():
    """A clockwise arc of radius 5 offset to its right by 1 becomes radius 4 (concentric);
    counter-clockwise, radius 6."""
    cw = Segment(SegmentKind.ARC, (0.0, 5.0), (5.0, 0.0), centre=(0.0, 0.0), radius=5.0, clockwise=True)
    (o,) = programmed_contour([cw], 1.0)
    assert o.radius == 4.0 and o.start == pytest.approx((0.0, 4.0)) and o.end == pytest.approx((4.0, 0.0))
    ccw = Segment(SegmentKind.ARC, (5.0, 0.0), (0.0, 5.0), centre=(0.0, 0.0), radius=5.0, clockwise=False)
    (o,) = programmed_contour([ccw], 1.0)
    assert o.radius == 6.0 and o.end == pytest.approx((0.0, 6.0))


def test_spiral_arc_becomes_the_circle_through_its_ends_and_middle():
    # a LinuxCNC spiral: end radius 0.0002 mm larger than the start radius
    (s,) = moves_as_segments([Arc((10.0, 0.0), (0.0, 10.0002), (0.0, 0.0), clockwise=False)])
    mid = (10.0001 * math.cos(math.pi / 4), 10.0001 * math.sin(math.pi / 4))
    for p in (s.start, s.end, mid):
        assert math.dist(p, s.centre) == pytest.approx(s.radius, abs=1e-12)
    assert not s.clockwise


@pytest.mark.parametrize("spec, key", [
    (BodySpec(thickness=15.0), "cad.thickness"),          # thinner than the ~19.8 mm profile
    (BodySpec(thickness=21.0), "cad.thickness"),          # deeper than the profile, but not by min_wall
    (BodySpec(blank_diameter=60.0), "cad.blank_diameter"),
    (BodySpec(mount_depth=27.0), "cad.mount_depth"),       # the bore reaches the face (Z -3.2 at r = 10)
    (BodySpec(mount_diameter=75.0), "cad.mount_diameter"),
])
def test_bad_bodies_are_refused_naming_the_key(paper_mirror, spec, key):
    with pytest.raises(InputError, match=key):
        design_meridian(paper_mirror, spec)


def test_roles(paper_mirror):
    mer = design_meridian(paper_mirror, BodySpec())
    assert [s.role for s in mer.face] == [Role.MIRROR, Role.WALL, Role.MIRROR]
    assert all(s.role is Role.BODY for s in mer.segments[mer.n_face:])


def test_a_move_that_cuts_air_drops_out_of_the_contour():
    """Centre path: right along Z = 0, up the wall x = 1, a short move down-right that
    stays 0.5 above the wall's top, then right along Z = 0.95. With rho = 0.5 the short
    move's offset lies left of the wall's offset x = 1.5 (the nose cuts air there); the
    fillet about (1.1, 0.95) reaches x = 1.5 only at Z = 0.65, above the last move's
    offset Z = 0.45. By hand, the envelope: Z = -0.5 to x = 1, the quarter circle about
    (1, 0) to (1.5, 0), up x = 1.5 to Z = 0.45, along Z = 0.45 to x = 3."""
    L = lambda a, b: Segment(SegmentKind.LINE, a, b)  # noqa: E731
    path = [L((0.0, 0.0), (1.0, 0.0)), L((1.0, 0.0), (1.0, 1.0)),
            L((1.0, 1.0), (1.1, 0.95)), L((1.1, 0.95), (3.0, 0.95))]
    out = programmed_contour(path, 0.5)
    assert [s.kind for s in out] == [SegmentKind.LINE, SegmentKind.ARC, SegmentKind.LINE, SegmentKind.LINE]
    assert out[1].centre == (1.0, 0.0) and out[1].end == pytest.approx((1.5, 0.0))
    assert out[2].start == pytest.approx((1.5, 0.0)) and out[2].end == pytest.approx((1.5, 0.45))
    assert out[3].start == pytest.approx((1.5, 0.45)) and out[3].end == pytest.approx((3.0, 0.45))


@pytest.mark.parametrize("strategy", ["paper", "lattice", "arcs"])
def test_programmed_contour_is_the_machining_envelope(paper_config, paper_mirror, strategy):
    """The exact contour (lines and arcs) against lathe_mirror.nose_envelope's independent
    envelope (the lowest nose point over a 0.0005 mm grid of radii, linearly
    interpolated). Linear interpolation across a corner of the envelope, where the
    slope dZ/dr jumps by ds between two moves, errs by up to GRID * ds / 4: the bound."""

    from lathe_mirror.body import programmed_parts, segment_tangent
    from lathe_mirror.nose_envelope import GRID, as_machined
    from lathe_mirror.toolpath import Strategy, plan_toolpath

    settings = from_config(paper_config)
    tp = plan_toolpath(paper_mirror, settings.machine, settings.tool, Strategy(strategy))
    mer, centre, _ = programmed_parts(tp, paper_mirror, BodySpec())
    env = as_machined(tp)
    jumps = [abs(b[1] / b[0] - a[1] / a[0])  # dZ/dr after minus before, at each vertex
             for a, b in ((segment_tangent(p, end=True), segment_tangent(q, end=False))
                          for p, q, lp, lq in zip(centre, centre[1:], tp.lobe_of, tp.lobe_of[1:])
                          if lp == lq != "junction")]
    bound = GRID * max(jumps) / 4 + 1e-6
    pts = np.concatenate([s.points(1e-5) for s in mer.face])
    r, Z = pts[:, 0], pts[:, 1]
    sel = ((r > 0.01) & (r < 19.99)) | ((r > 20.01) & (r < 34.9))  # off the wall and the rim
    dz = Z[sel] - env.to_machine_z(env.z(r[sel]))
    assert np.abs(dz).max() < bound


def test_programmed_mirror_honours_the_toolpath_max_deviation(paper_config, paper_mirror):
    """The same toolpath settings as `lathe-mirror toolpath`: 528 points cannot hold lines
    within 1e-5 mm of the profile (the planner's own count says 673), so the programmed
    mirror is refused too, naming the budget."""
    import copy

    from lathe_mirror.job import cad_model

    cfg = copy.deepcopy(paper_config)
    cfg["toolpath"]["max_deviation"] = 1e-5
    with pytest.raises(InputError, match="machine.max_points"):
        cad_model(from_config(cfg), paper_mirror, programmed=True)
