"""Stereo triangulation and depth error against hand calculations and an independent closed form."""

from __future__ import annotations

import math

import numpy as np
import pytest

from lathe_mirror.design import design_lobe, design_mirror
from lathe_mirror.optics.stereo import (
    band_elevations,
    depth_error_curve,
    exact_pixels,
    stereo_centre_z,
    triangulate,
    world_points,
)
from lathe_mirror.profile import ExactProfile
from lathe_mirror.optics.radial import trace_lobe

RANGES_M = np.array([0.5, 1.0, 2.0, 3.5, 5.0])


def test_triangulate_hand_cases():
    # Two lines in a plane crossing at (3, 4).
    x = triangulate(np.array([0.0, 0.0]), np.array([3.0, 4.0]) / 5.0,
                    np.array([6.0, 0.0]), np.array([-3.0, 4.0]) / 5.0)
    assert x == pytest.approx([3.0, 4.0], abs=1e-12)
    # Skew lines: x axis, and the line through (0, 0, 2) along y; closest points (0,0,0), (0,0,2).
    x = triangulate(np.array([5.0, 0, 0]), np.array([1.0, 0, 0]), np.array([0, -7.0, 2.0]), np.array([0, 1.0, 0]))
    assert x == pytest.approx([0.0, 0.0, 1.0], abs=1e-12)


def test_exact_mirror_has_no_depth_error(paper_mirror):
    curve = depth_error_curve(ExactProfile(paper_mirror), paper_mirror, RANGES_M)
    assert curve.error_pct.shape == (RANGES_M.size, 33)
    assert np.max(np.abs(curve.error_pct)) < 1e-6
    assert curve.at(2.0)["max"] < 1e-6


def test_exact_pixels_see_the_point(paper_mirror):
    """The closed-form inverse map's pixels, traced through the exact lobes, reflect through W."""
    w_r, w_z = world_points(paper_mirror, np.array([2000.0]), band_elevations(paper_mirror, 5))
    rho = exact_pixels(paper_mirror, w_r, w_z)
    # Each lobe images the band inside its own annulus.
    radii = paper_mirror.image_radii_px
    assert np.all(rho[0] < radii["inner_disc"][1])
    assert np.all((rho[1] > radii["outer_annulus"][0]) & (rho[1] <= radii["outer_annulus"][1]))
    for k in (0, 1):
        rays = trace_lobe(paper_mirror.lobes[k], paper_mirror, k, rho[k].ravel())
        # distance of W from the reflected line |(W - P) x o|
        dist = np.abs((w_r.ravel() - rays.r) * rays.o_z - (w_z.ravel() - rays.z) * rays.o_r)
        assert np.max(dist) < 1e-8


@pytest.mark.parametrize("de", [0.02, -0.1])
def test_depth_error_of_a_refocused_outer_lobe_matches_closed_form(paper_mirror, de):
    """Made mirror = the paper's, but its outer lobe a true hyperbola with e shifted by de mm.

    Independently: the exact outer lobe's pixel rho, the made sheet's hit by the design's own
    closed-form ray-sheet intersection, the reflected line through the made lobe's F1 (the
    focal property), the inner ray through the exact F1, and the crossing of the two lines.
    de = -0.1 mm lowers the outer viewpoint far enough that the rays turn parallel between
    1 and 2 m and cross behind beyond: the band's figures must cap those points at 100 %.
    """
    mirror = paper_mirror
    outer = mirror.outer
    made_outer = design_lobe("outer", mirror.camera, outer.r_top, outer.r_pixel, e=outer.e + de)
    made_mirror = design_mirror(mirror.camera, mirror.inner, made_outer)
    elev = np.radians([-20.0, -10.0, -3.0])
    curve = depth_error_curve(ExactProfile(made_mirror), mirror, RANGES_M, elevations=elev)
    zc = stereo_centre_z(mirror)
    expected = np.empty((RANGES_M.size, elev.size))
    for i, rng in enumerate(RANGES_M * 1e3):
        for j, el in enumerate(elev):
            w = np.array([rng * math.cos(el), zc + rng * math.sin(el)])
            # inner lobe: unchanged, the ray is the line F1_inner -> W
            f_in = np.array([0.0, mirror.inner.focus_z])
            # outer: exact pixel of W, then the made sheet's hit point and its line to F1'
            phi = math.atan2(w[1] - mirror.outer.focus_z, w[0])
            s = mirror.outer.b**2 / (mirror.outer.a - mirror.outer.e * math.sin(phi))
            t = (s * math.cos(phi)) / (mirror.outer.focus_z + s * math.sin(phi))
            r_hit = _camera_ray_hits_sheet(made_mirror.outer, t)
            p_hit = np.array([r_hit, r_hit / t])
            f_out = np.array([0.0, made_mirror.outer.focus_z])
            # crossing of line f_in + a (w - f_in) with line f_out + b (p_hit - f_out)
            m = np.column_stack([w - f_in, -(p_hit - f_out)])
            a, _ = np.linalg.solve(m, f_out - f_in)
            x = f_in + a * (w - f_in)
            r_made = (x[0] * math.cos(el) + (x[1] - zc) * math.sin(el))
            expected[i, j] = 100.0 * (r_made - rng) / rng
    assert curve.error_pct == pytest.approx(expected, rel=1e-6, abs=1e-7)
    # The band's figures: |error| capped at 100 % per point, by hand.
    for i, rng in enumerate(RANGES_M):
        capped = [min(abs(v), 100.0) for v in expected[i]]
        at = curve.at(float(rng))
        assert at["rms"] == pytest.approx(math.sqrt(sum(v * v for v in capped) / len(capped)), rel=1e-9)
        assert at["max"] == pytest.approx(max(capped), rel=1e-9)
        assert at["failed"] == sum(abs(v) >= 100.0 for v in expected[i]) and at["lost"] == 0
    e2 = np.abs(curve.error_pct).mean(axis=1)
    if de > 0:
        # A 0.02 mm shift of one viewpoint is a real error, and it grows with range.
        assert e2[0] > 1e-3 and np.all(np.diff(e2) > 0)
    else:
        # The rays do pass parallel: some point's error exceeds 100 % and is capped.
        assert np.max(np.abs(expected)) > 100.0 and curve.at(5.0)["failed"] > 0


def test_lost_points_count_as_failed(paper_mirror):
    """A point a lobe does not see (NaN) counts at the cap, as the Monte Carlo counts it."""
    from lathe_mirror.optics.stereo import DepthCurve

    c = DepthCurve.of(np.array([1.0]), np.radians([-10.0, -5.0, -1.0]), np.array([[3.0, np.nan, -250.0]]))
    at = c.at(1.0)
    assert at["rms"] == pytest.approx(math.sqrt((9.0 + 100.0**2 + 100.0**2) / 3.0))
    assert (at["median"], at["max"], at["failed"], at["lost"], at["points"]) == (100.0, 100.0, 2, 1, 3)


def _camera_ray_hits_sheet(lobe, t: float) -> float:
    """Radius (mm) where the camera ray r = t z first meets the lobe's upper sheet, found
    numerically here (brentq on the implicit equation along the ray), not by the design's
    closed form: f(r) = ((r / t - e) / a)^2 - (r / b)^2 - 1 changes sign at the sheet."""
    from scipy.optimize import brentq

    a, b, e = lobe.a, lobe.b, lobe.e

    def f(r):
        return ((r / t - e) / a) ** 2 - (r / b) ** 2 - 1.0

    r = np.linspace(t * (e + a), t * (e + 4 * a), 20001)  # from the axis' vertex height up
    v = f(r)
    i = int(np.flatnonzero(np.sign(v[:-1]) != np.sign(v[1:]))[0])
    return brentq(f, r[i], r[i + 1], xtol=1e-14, rtol=1e-15)

