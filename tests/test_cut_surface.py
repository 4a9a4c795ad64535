"""The surfaces a program cuts when it is not the design (lathe_mirror.cut_surface), built by
composition: a compensated lobe holds its design lobe and an offset spline, a zero-shifted
mirror holds its surface and the shift. A trace through either lands on its own z(r), and
the design's constants (a, b, e, the foci, the fields of view) are not reachable on them
except by name (`.design`).

The offset used here is a cubic B-spline with every coefficient c: the spline is c
everywhere (partition of unity), so the lowered sheet is the design's hyperbola moved down
by c, (z - (e - c))^2 / a^2 - r^2 / b^2 = 1, whose camera-ray hits and normals follow in
closed form, independently of the code. The design is not the
paper's (conftest.RECESSED_OUTER: 6 mm lens, 3 um pixels, the outer lobe recessed).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from conftest import RECESSED_OUTER
from lathe_mirror.config import load
from lathe_mirror.cut_surface import CompensatedLobe, CompensatedMirror, ZeroShiftedMirror
from lathe_mirror.enums import Strategy
from lathe_mirror.job import plan
from lathe_mirror.optics.trace import meridian_hits
from lathe_mirror.profile import ExactProfile

#: The allowance (mm): the 53 um a trace through the stale constants used to land off.
C = 0.053


@pytest.fixture(scope="module")
def settings(tmp_path_factory):
    cfg = tmp_path_factory.mktemp("cfg") / "recessed.toml"
    cfg.write_text(RECESSED_OUTER)
    return load(cfg)


@pytest.fixture(scope="module")
def design(settings):
    return settings.mirror()


@pytest.fixture(scope="module")
def lowered(design):
    """Each lobe lowered by C, as a cubic B-spline over the lobe's radii."""
    lobes = []
    for k, lobe in enumerate(design.lobes):
        lo, hi = (0.0, design.r_junction) if k == 0 else (design.r_junction, design.r_max)
        knots = (lo,) * 4 + tuple(np.linspace(lo, hi, 6)[1:-1]) + (hi,) * 4
        lobes.append(CompensatedLobe(lobe, offset_knots=tuple(float(v) for v in knots),
                                     offset_coef=(C,) * (len(knots) - 4)))
    return CompensatedMirror(design, lobes[0], lobes[1])


def _shifted_sheet_hit(a: float, b: float, e: float, t: np.ndarray) -> np.ndarray:
    """Height z where the camera ray r = t z meets the upper sheet of (z - e)^2 / a^2 -
    r^2 / b^2 = 1 (by hand: (1/a^2 - t^2/b^2) z^2 - 2 e z / a^2 + e^2 / a^2 - 1 = 0, the
    root above the centre)."""
    qa = 1.0 / a**2 - t**2 / b**2
    qb = -2.0 * e / a**2
    qc = e**2 / a**2 - 1.0
    disc = np.sqrt(qb * qb - 4.0 * qa * qc)
    return np.maximum((-qb + disc) / (2.0 * qa), (-qb - disc) / (2.0 * qa))


def test_the_lowered_sheet_is_the_design_moved_down_by_the_offset(design, lowered):
    for k in (0, 1):
        d, s = design.lobes[k], lowered.lobes[k]
        r = np.linspace(0.0 if k == 0 else design.r_junction + 1e-6, s.r_top, 201)
        # closed form: e + a sqrt(1 + r^2 / b^2) - C, slope and curvature unchanged
        z = d.e + d.a * np.sqrt(1.0 + (r / d.b) ** 2) - C
        np.testing.assert_allclose(s.z(r), z, rtol=0, atol=1e-12)
        np.testing.assert_allclose(s.slope(r), d.a * r / (d.b**2 * np.sqrt(1 + (r / d.b) ** 2)), atol=1e-12)
        np.testing.assert_allclose(s.offset(r), C, atol=1e-12)


@pytest.mark.parametrize("k", [0, 1])
def test_a_trace_through_the_composed_mirror_lands_on_its_own_surface(design, lowered, k):
    """Camera rays traced (optics.trace.meridian_hits) off the lowered surface land on its
    own z(r) to 1e-9 mm, where the moved hyperbola's closed form puts them, and reflect off
    its closed-form normal; the design's closed form lands about C off."""
    lobe = design.lobes[k]
    profile = ExactProfile(lowered)
    lo = 0.05 if k == 0 else lowered.r_junction + 0.5
    hi = lowered.r_junction - 0.05 if k == 0 else lowered.r_max - 0.05
    r_probe = np.linspace(lo, hi, 41)
    t = r_probe / lowered.lobes[k].z(r_probe)  # rays through those points of the surface
    hits = meridian_hits(profile, t)
    assert np.all(np.isfinite(hits.r))
    np.testing.assert_allclose(hits.z, lowered.lobes[k].z(hits.r), rtol=0, atol=1e-9)
    np.testing.assert_allclose(hits.z, _shifted_sheet_hit(lobe.a, lobe.b, lobe.e - C, t), rtol=0, atol=1e-9)
    # the reflection off the moved sheet's closed-form normal (its slope is the design's)
    slope = lobe.a * hits.r / (lobe.b**2 * np.sqrt(1.0 + (hits.r / lobe.b) ** 2))
    d = np.stack([t, np.ones_like(t)]) / np.sqrt(1.0 + t * t)
    n = np.stack([slope, -np.ones_like(t)]) / np.sqrt(1.0 + slope**2)
    out = d - 2.0 * np.sum(d * n, axis=0) * n
    np.testing.assert_allclose(np.stack([hits.out_r, hits.out_z]), out, rtol=0, atol=1e-9)
    # what a trace through the design's constants would give: off by about C
    stale = _shifted_sheet_hit(lobe.a, lobe.b, lobe.e, t)
    assert np.min(np.abs(stale - hits.z)) > 0.9 * C


def test_the_design_constants_are_not_reachable_on_a_cut_surface(design, lowered):
    for stale in ("a", "b", "e", "h", "c", "vertex_z", "focus_z", "alpha", "elevation", "r_pixel", "a_over_b"):
        assert not hasattr(lowered.inner, stale), stale
        assert not hasattr(lowered.outer, stale), stale
    assert {f.name for f in dataclasses.fields(CompensatedLobe)} == {"design", "offset_knots", "offset_coef"}
    # the optics belong to the design, named so
    for stale in ("camera", "fov", "fov_usable", "r_outer_visible", "common_band", "image_radii_px"):
        assert not hasattr(lowered, stale), stale
    assert lowered.inner.design is design.inner and lowered.design is design
    assert lowered.inner.design.a == design.inner.a
    # the surface protocol: the step from the lowered sheets (both moved by C: unchanged)
    assert lowered.step == pytest.approx(design.step, abs=1e-12)
    assert lowered.recessed == design.recessed == "outer"
    # machine Z = 0 stays at the design's vertex: the surface's own vertex stands C below it
    assert lowered.vertex_z == design.vertex_z
    assert float(ExactProfile(lowered).to_machine_z(lowered.inner.z(0.0))) == pytest.approx(C, abs=1e-12)


def test_the_zero_shifted_mirror_holds_its_surface_and_moves_only_the_zero(design, lowered):
    shift = 0.0021
    for surface in (design, lowered):
        moved = ZeroShiftedMirror(surface, zero_shift=shift)
        assert moved.inner is surface.inner and moved.outer is surface.outer
        assert moved.design is design
        assert moved.vertex_z == surface.vertex_z + shift
        assert moved.junction_z == surface.junction_z and moved.step == surface.step
        assert not hasattr(moved, "camera") and not hasattr(moved, "fov_usable")
        # the surface's vertex in the machine frame: shift (+ C on the lowered one) above Z = 0
        z0 = float(ExactProfile(moved).to_machine_z(moved.inner.z(0.0)))
        assert z0 == pytest.approx(shift + (C if surface is lowered else 0.0), abs=1e-12)


def test_the_planner_cuts_the_lowered_surface(settings, design, lowered):
    """Planned on the lowered target, the program's first point (the nose centre over the
    vertex) stands C higher than the design's program's (to the lattice): the planner reads
    the target's sheets, not the design's constants."""
    res = settings.machine.resolution
    on_target = plan(design, settings.machine, settings.tool, Strategy.PAPER, target=lowered)
    on_design = plan(design, settings.machine, settings.tool, Strategy.PAPER)
    assert on_target.points()[0][1] - on_design.points()[0][1] == pytest.approx(C, abs=res)
    assert on_target.mirror is lowered
    assert math.isclose(on_target.mirror.design.outer.a, design.outer.a)
