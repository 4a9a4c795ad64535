"""Blur in the image (issue 31): each pixel's thin-lens blur circle against a hand
calculation, the varying disc blur against the closed form of a disc's edge spread, and
the stereo figures that blur changes in the direction and by the size triangulation gives."""

from __future__ import annotations

import math

import numpy as np
import pytest

from lathe_mirror.optics.defocus import Lens, blur_figures, blur_map, defocus_image, lens_for


def _hand_vertex_blur(mirror, lens) -> float:
    """The blur circle (px) of the ray along the axis off the inner lobe, by hand: the
    sheet (z - e)^2 / a^2 - r^2 / b^2 = 1 has its vertex at z = e + a with radius of
    curvature R = b^2 / a; a convex mirror of focal length R / 2 images a scene point
    s_o = range - (e - a) in front of it (the range counted from F1 at z = 2e) at
    v = 1 / (1 / s_o + 2 / R) behind the vertex, d = e + a + v from the lens. The lens
    focused at d_f puts the sensor at v_f = 1 / (1/f - 1/d_f); the blur circle is
    (f / N) v_f |1/d - 1/d_f| (mm) over the pixel pitch."""
    lobe, cam = mirror.inner, mirror.camera
    a, b, e = lobe.a, lobe.b, lobe.e
    s_o = lens.object_range_mm - (e - a)
    v = 1.0 / (1.0 / s_o + 2.0 * a / b**2)
    d = e + a + v
    v_f = 1.0 / (1.0 / cam.f - 1.0 / lens.focus_mm)
    return cam.f / lens.f_number * v_f * abs(1.0 / d - 1.0 / lens.focus_mm) / cam.t_pixel


def test_centre_pixel_blur_is_the_hand_calculation(paper_mirror):
    """The paper's f/8 lens focused for scene points 2 m away: the centre pixel's blur (the
    map), the inner lobe's largest (the figures: the vertex's virtual image lies nearest)
    and the hand calculation agree; the paper's blur is 6.64 px (the optimiser's key's help)."""
    m = paper_mirror
    lens = lens_for(m, 2000.0)
    hand = _hand_vertex_blur(m, lens)
    assert hand == pytest.approx(6.64, abs=0.005)
    bm = blur_map(m, lens)
    h, w = bm.shape
    # the four pixels around the centre lie 0.71 px off the axis: 1e-5 of the blur
    assert bm[h // 2, w // 2] == pytest.approx(hand, rel=1e-4)
    fig = blur_figures(m, lens)
    assert fig["lobes"][0]["blur_px"]["max"] == pytest.approx(hand, rel=1e-4)
    # twice the aperture, twice the blur (the focus stays where the vergences put it)
    wide = lens_for(m, 2000.0, f_number=4.0)
    assert wide.focus_mm == pytest.approx(lens.focus_mm, rel=1e-12)
    assert blur_map(m, wide)[h // 2, w // 2] == pytest.approx(2 * bm[h // 2, w // 2], rel=1e-12)


@pytest.mark.parametrize("range_m", [0.2, 0.5, 1.0, 5.0, 1e6])
def test_the_blur_at_another_scene_range_is_the_hand_calculation_and_small(paper_mirror, range_m):
    """The lens stays focused for scene points 2 m away (optimize.focus_range_m) while the
    scene point is elsewhere: the centre pixel's blur is still the hand calculation at that
    range, and it moves by what a convex mirror's focal length R / 2 gives by hand to first
    order: the virtual image moves by (R / 2)^2 (1 / s_1 - 1 / s_2) (v = 1 / (1/s + 2/R)),
    the blur by (f / N) v_f / T_pixel x that over d^2. On the paper's inner lobe (R / 2 =
    7.46 mm, d = 111 mm from the lens) that is 0.027 px between 0.5 and 2 m, 0.08 px at
    0.2 m, against 6.64 px: part of why the Monte Carlo and optimize may take the design's
    blur at the focus range for the range they judge (docs/explanation/monte-carlo.md,
    "The blur at other ranges")."""
    m = paper_mirror
    focused = lens_for(m, 2000.0)
    at = Lens(focused.f_number, focused.focus_mm, range_m * 1000.0)
    hand = _hand_vertex_blur(m, at)
    bm = blur_map(m, at)
    h, w = bm.shape
    assert bm[h // 2, w // 2] == pytest.approx(hand, rel=1e-4)
    # the first-order shift by hand, against the exact hand values at the two ranges
    lobe, cam = m.inner, m.camera
    half_r = lobe.b**2 / lobe.a / 2.0
    assert half_r == pytest.approx(7.46, abs=0.005)
    s1, s2 = range_m * 1000.0 - (lobe.e - lobe.a), 2000.0 - (lobe.e - lobe.a)
    d = lobe.e + lobe.a + 1.0 / (1.0 / s2 + 1.0 / half_r)
    v_f = 1.0 / (1.0 / cam.f - 1.0 / focused.focus_mm)
    shift = cam.f / cam.f_number * v_f / cam.t_pixel * half_r**2 * abs(1.0 / s1 - 1.0 / s2) / d**2
    exact = abs(hand - _hand_vertex_blur(m, focused))
    assert exact == pytest.approx(shift, rel=0.05)  # second order: (R / 2) / s_1, 4 % at 0.2 m
    assert exact < 0.015 * hand


def _disc_edge(x: np.ndarray, radius: float) -> np.ndarray:
    """The share of a disc of this radius lying at abscissa below x (its edge spread
    function): the circular segment R^2 acos(h / R) - h sqrt(R^2 - h^2) over pi R^2."""
    h = np.clip(np.abs(x), 0.0, radius)
    seg = (radius**2 * np.arccos(h / radius) - h * np.sqrt(radius**2 - h**2)) / (math.pi * radius**2)
    return np.where(x < 0, seg, 1.0 - seg)


@pytest.mark.parametrize("diameter", [12.0, 20.0, 15.0])
def test_a_step_edge_spreads_as_the_disc_says(diameter):
    """A vertical step 0 -> 200 grey levels blurred by a disc: across the edge the image
    follows the disc's edge spread function (closed form above) within a grey level and a
    half (the disc sampled on the pixel grid, the result rounded); 15 px lies between two
    bands (12.2 and 15.3 px) and is their blend."""
    img = np.zeros((81, 121, 3), np.uint8)
    img[:, 60:] = 200  # the edge at x = 60 (pixel centres at 0.5 + i)
    out = defocus_image(img, np.full(img.shape[:2], diameter))
    x = np.arange(121) + 0.5 - 60.0
    expected = 200.0 * _disc_edge(x, diameter / 2.0)
    row = out[40, :, 1].astype(float)
    assert np.abs(row[20:100] - expected[20:100]).max() <= 1.5 + (2.0 if diameter == 15.0 else 0.0)
    # the spread's width: 10 % to 90 % over about 0.58 of the diameter (the disc's own value)
    cross = lambda level: float(np.interp(level, row[20:100], x[20:100]))  # noqa: E731
    width = cross(180.0) - cross(20.0)
    hand = 2 * float(np.interp(0.9, _disc_edge(np.linspace(0, diameter / 2, 2001), diameter / 2),
                               np.linspace(0, diameter / 2, 2001)))
    assert width == pytest.approx(hand, abs=0.6)


def test_varying_blur_follows_each_pixels_diameter():
    """The top half 4 px, the bottom half 16 px: far from where they meet, each half's edge
    is its own disc's (the blend is per pixel, not one blur for the image); a 0 px map
    leaves the image as it was."""
    img = np.zeros((120, 121, 3), np.uint8)
    img[:, 60:] = 200
    d = np.full(img.shape[:2], 4.0)
    d[60:] = 16.0
    out = defocus_image(img, d)
    x = np.arange(121) + 0.5 - 60.0
    for r, diam in ((20, 4.0), (100, 16.0)):
        assert np.abs(out[r, 40:80, 0] - 200 * _disc_edge(x[40:80], diam / 2)).max() <= 1.5
    assert np.array_equal(defocus_image(img, np.zeros(img.shape[:2])), img)


def test_blur_raises_the_matching_error_and_the_range_error_with_it(paper_config):
    """The paper's room through the exact mirror, as the camera records it with a sharp
    lens and with the paper's f/8 (up to 6.64 px of blur): the blur raises the matcher's
    disparity error (direction), and the range error grows by the same factor (size: the
    triangulation is linear in a small disparity error, dR / R = R d_theta / B, so the
    median |range error| scales as the median |disparity error|, within 30 %)."""
    from lathe_mirror.optics.defocus import grow_mask
    from lathe_mirror.optics.ranging.stereo import image_mask, prepare, range_figures, stereo_range
    from lathe_mirror.optics.ranging.truth import true_range
    from lathe_mirror.optics.render import render_image
    from lathe_mirror.optics.scene import build_scene
    from lathe_mirror.profile import ExactProfile
    from lathe_mirror.settings import from_config

    settings = from_config(paper_config)
    m = settings.mirror()
    scene = build_scene(settings.scene, mirror_top=m.outer.h, mirror_radius=m.r_max)
    grid, match = prepare(m, settings.stereo.params)
    lens = lens_for(m, 2000.0)
    blur = blur_map(m, lens)
    mask = grow_mask(image_mask(m, grid, match.num_disparities), blur)
    sharp = render_image(ExactProfile(m), m, scene, supersample=2, pixels=mask)
    truth = true_range(m, scene, grid)
    figs = {}
    for name, image in (("sharp", sharp), ("f/8", defocus_image(sharp, blur))):
        res = stereo_range(image, m, settings.stereo.params)
        figs[name] = range_figures(res, truth, m)
    d0, d1 = (figs[n]["disparity_error_px"]["median"] for n in ("sharp", "f/8"))
    e0, e1 = (figs[n]["range_error_pct"]["median"] for n in ("sharp", "f/8"))
    assert d1 > 1.5 * d0, (d0, d1)
    assert e1 > e0
    assert e1 / e0 == pytest.approx(d1 / d0, rel=0.3), (d0, d1, e0, e1)
    assert Lens(8.0, lens.focus_mm, 2000.0) == lens
