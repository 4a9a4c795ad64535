"""Design equations (Eqs. 3-6) against Table 1 and hand calculations."""

from __future__ import annotations

import math

import numpy as np
import pytest

from lathe_mirror.design import (
    Camera,
    design_lobe,
    design_mirror,
    single_viewpoint_error,
)
from lathe_mirror.design_table import design_figures
from lathe_mirror.errors import DesignError

# Table 1 as printed (c, h, a, b to their printed decimals; alpha in degrees).
TABLE1 = {
    "inner": {"c": (110.64, 2), "h": (115.607, 3), "a": (48.358, 3), "b": (26.866, 3), "alpha_deg": (13.948, 3)},
    "outer": {"c": (123.44, 2), "h": (123.457, 3), "a": (46.661, 3), "b": (40.399, 3), "alpha_deg": (0.028, 3)},
}


def test_paper_default_reproduces_table1(paper_mirror):
    fig = design_figures(paper_mirror)
    for lobe in fig["lobes"]:
        for key, (printed, digits) in TABLE1[lobe["name"]].items():
            assert round(lobe[key], digits) == pytest.approx(printed, abs=1e-12), (lobe["name"], key, lobe[key])


def test_table1_r_pixel_swap_is_the_consistent_reading():
    # Eq. 6 solved for R_pixel from the printed h: mirror 01 needs ~307.6 px, mirror 02 504 px.
    assert 16 * 20 / (0.009 * 115.607) == pytest.approx(307.555, abs=0.002)
    assert 16 * 35 / (0.009 * 123.457) == pytest.approx(504.0, abs=0.002)
    # Table 1's printed (unswapped) 504 for mirror 01 would give another h entirely.
    assert 16 * 20 / (0.009 * 504) == pytest.approx(70.547, abs=1e-3)


def test_paper_derived_quantities(paper_mirror):
    m = paper_mirror
    inner, outer = m.inner, m.outer
    # Hand calculation: outer sheet at r = 20: e2 + a2 sqrt(1 + 400 / b2^2).
    z_outer_20 = 61.71985 + 46.66108 * math.sqrt(1 + 400 / 40.39902**2)
    assert m.junction_z[1] == pytest.approx(z_outer_20, abs=1e-3)
    assert m.junction_z[0] == pytest.approx(inner.h, abs=1e-9)  # the inner rim
    assert m.step == pytest.approx(115.6071 - z_outer_20, abs=1e-3)
    assert m.recessed == "inner"
    assert m.baseline == pytest.approx(123.44 - 110.64, abs=0.01)  # Table 1's c's
    radii = m.image_radii_px
    # The inner rim images at its R_pixel (Eq. 6), the outer rim at its own.
    assert radii["inner_disc"][1] == pytest.approx(307.555, abs=1e-9)
    assert radii["outer_annulus"][1] == pytest.approx(504.0, abs=1e-9)
    # Ray grazing the outer sheet's edge: radius f * (20 / z_outer_20) / T_pixel.
    assert radii["lost_ring"] == pytest.approx((307.555, 16 * 20 / z_outer_20 / 0.009), abs=1e-3)
    # Field of view: each rim is seen at its alpha; the outer lobe starts at the junction.
    assert math.degrees(m.fov(outer)[1]) == pytest.approx(0.028, abs=1e-9)
    assert math.degrees(m.fov(outer)[0]) == pytest.approx(
        math.degrees(math.atan2(z_outer_20 - 123.4397, 20.0)), abs=1e-3)
    assert m.common_band == pytest.approx(m.fov(outer), abs=1e-12)


def test_exact_lobes_have_a_single_viewpoint(paper_mirror):
    for lobe in paper_mirror.lobes:
        r = np.linspace(0.0, lobe.r_top, 2001)
        assert single_viewpoint_error(lobe, r).max() < 1e-9


# --- three designs that are not the paper's, against hand calculations ----------------

def _foci_check(lobe):
    """Rim on the sheet; |P - camera| - |P - F1| = 2a along the lobe; e^2 = a^2 + b^2."""
    assert (lobe.h - lobe.e) ** 2 / lobe.a**2 - lobe.r_top**2 / lobe.b**2 == pytest.approx(1.0, abs=1e-12)
    r = np.linspace(0, lobe.r_top, 101)
    z = lobe.z(r)
    diff = np.hypot(r, z) - np.hypot(r, z - 2 * lobe.e)
    np.testing.assert_allclose(diff, 2 * lobe.a, atol=1e-10)
    assert lobe.e**2 == pytest.approx(lobe.a**2 + lobe.b**2, rel=1e-12)
    assert single_viewpoint_error(lobe, r).max() < 1e-9


def test_small_mirror_for_a_6mm_lens():
    # 12 mm / 25 mm mirror, f = 6 mm, 0.003 mm pixels, 1280 x 1024 sensor.
    cam = Camera(f=6.0, t_pixel=0.003, sensor_px=(1280, 1024))
    inner = design_lobe("inner", cam, 12.0, 300.0, a_over_b=2.0)  # the paper's text: a = 2b
    outer = design_lobe("outer", cam, 25.0, 500.0, alpha_deg=5.0)
    # Eq. 6 by hand: h = 6 * 12 / (0.003 * 300) = 80; 6 * 25 / (0.003 * 500) = 100.
    assert inner.h == pytest.approx(80.0, abs=1e-12)
    assert outer.h == pytest.approx(100.0, abs=1e-12)
    # a = 2b with e = sqrt(5) b: rim on the sheet, (80 - sqrt5 b)^2 / (4 b^2) - 144 / b^2 = 1,
    # i.e. b^2 - 2 sqrt5 * 80 b + (6400 - 4 * 144) = 0, smaller root.
    s5 = math.sqrt(5.0)
    b_hand = (2 * s5 * 80 - math.sqrt((2 * s5 * 80) ** 2 - 4 * (6400 - 576))) / 2
    assert inner.b == pytest.approx(b_hand, rel=1e-12)
    assert inner.a == pytest.approx(2 * b_hand, rel=1e-12)
    # alpha = 5 deg: 2e = h - R tan(alpha); |P - F1| = R / cos(alpha); 2a = |P| - R / cos(alpha).
    two_e = 100 - 25 * math.tan(math.radians(5))
    a_hand = (math.hypot(25, 100) - 25 / math.cos(math.radians(5))) / 2
    assert outer.c == pytest.approx(two_e, rel=1e-12)
    assert outer.a == pytest.approx(a_hand, rel=1e-12)
    assert math.degrees(outer.alpha) == pytest.approx(5.0, abs=1e-12)
    for lobe in (inner, outer):
        _foci_check(lobe)
    m = design_mirror(cam, inner, outer)
    assert m.baseline == pytest.approx(two_e - 2 * math.hypot(inner.a, inner.b), rel=1e-12)
    assert m.image_radii_px["inner_disc"][1] == pytest.approx(300.0, abs=1e-9)


def test_design_given_e():
    cam = Camera(f=8.0, t_pixel=0.0055, sensor_px=(1920, 1080))
    inner = design_lobe("inner", cam, 15.0, 250.0, e=40.0)
    outer = design_lobe("outer", cam, 30.0, 520.0, a_over_b=1.5)
    h_in = 8 * 15 / (0.0055 * 250)
    assert inner.h == pytest.approx(h_in, rel=1e-12)
    assert inner.e == 40.0 and inner.c == 80.0
    # Hand: 2a = sqrt(15^2 + h^2) - sqrt(15^2 + (h - 80)^2).
    assert inner.a == pytest.approx((math.hypot(15, h_in) - math.hypot(15, h_in - 80)) / 2, rel=1e-12)
    assert outer.a / outer.b == pytest.approx(1.5, rel=1e-12)
    for lobe in (inner, outer):
        _foci_check(lobe)
    m = design_mirror(cam, inner, outer)
    fig = design_figures(m)
    # Elevation of each rim above its F1 = atan((h - 2e) / R_top) (Table 1's alpha).
    for lobe, f in zip(m.lobes, fig["lobes"]):
        assert f["fov_deg"]["max"] == pytest.approx(math.degrees(math.atan((lobe.h - 2 * lobe.e) / lobe.r_top)))


def test_outer_lobe_recessed_hides_a_band():
    # An outer lobe whose sheet at the junction is higher than the inner rim: the inner rim
    # hides part of it; no image ring is lost, the outer annulus starts at the inner rim.
    cam = Camera()
    inner = design_lobe("inner", cam, 20.0, 400.0, alpha_deg=-20.0)
    outer = design_lobe("outer", cam, 35.0, 504.0, alpha_deg=30.0)
    m = design_mirror(cam, inner, outer)
    assert m.recessed == "outer"
    r_vis = m.r_outer_visible
    assert 20.0 < r_vis < 35.0
    # The grazing ray through the inner rim meets the outer sheet at r_vis.
    t = 20.0 / inner.h
    assert float(outer.z(r_vis)) == pytest.approx(r_vis / t, rel=1e-12)
    radii = m.image_radii_px
    assert radii["lost_ring"][0] == radii["lost_ring"][1]
    assert radii["outer_annulus"][0] == pytest.approx(400.0, abs=1e-9)


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(alpha_deg=85.0), "alpha_deg = 85 deg: no hyperbola"),
        (dict(alpha_deg=-85.0), "no hyperbola"),
        (dict(e=200.0), "0 < e < h"),
        (dict(e=-1.0), "0 < e < h"),
        (dict(a_over_b=10.0), "a_over_b"),
        (dict(a_over_b=0.0), "a_over_b"),
        (dict(alpha_deg=10.0, e=50.0), "exactly one of"),
        (dict(), "exactly one of"),
        (dict(alpha_deg=float("nan")), "finite"),
    ],
)
def test_impossible_lobes_are_rejected(kwargs, match):
    with pytest.raises(DesignError, match=match):
        design_lobe("inner", Camera(), 20.0, 307.555, **kwargs)


def test_alpha_limit_is_the_horizon_of_the_camera():
    # 2e = h - R tan(alpha) must stay in (0, 2h): |alpha| < atan(h / R).
    h = 16 * 20 / (0.009 * 307.555)
    limit = math.degrees(math.atan(h / 20))
    design_lobe("inner", Camera(), 20.0, 307.555, alpha_deg=limit - 1e-6)
    with pytest.raises(DesignError):
        design_lobe("inner", Camera(), 20.0, 307.555, alpha_deg=limit)


def test_mirror_level_checks():
    cam = Camera()
    a = design_lobe("inner", cam, 20.0, 307.555, alpha_deg=13.948)
    with pytest.raises(DesignError, match="must exceed lobes.inner.r_top"):
        design_mirror(cam, a, design_lobe("outer", cam, 20.0, 504.0, alpha_deg=0.028))
    with pytest.raises(DesignError, match="outside the sensor"):
        design_mirror(cam, a, design_lobe("outer", cam, 35.0, 600.0, alpha_deg=0.028))
    with pytest.raises(DesignError, match="must be smaller than"):
        design_mirror(cam, design_lobe("inner", cam, 20.0, 504.0, alpha_deg=0.0),
                      design_lobe("outer", cam, 35.0, 400.0, alpha_deg=0.0))
    with pytest.raises(DesignError, match="sensor_px"):
        Camera(sensor_px=(1008, -2))


@pytest.mark.parametrize("field, value, line", [
    ("f", 0.0, "camera.f = 0 mm: allowed 0.1 to 1000 mm"),
    ("t_pixel", 0.2, "camera.t_pixel = 0.2 mm: allowed 0.0005 to 0.1 mm"),
    ("f_number", 0.1, "camera.f_number = 0.1: allowed 0.5 to 100"),
])
def test_a_camera_built_in_python_is_refused_with_the_configs_line(tmp_path, field, value, line):
    """Camera(...) and dataclasses.replace on it: the line `load()` gives for the same
    [camera] key (the declaration's range), a design error; the ends are accepted."""
    import dataclasses

    from lathe_mirror.config import load
    from lathe_mirror.declared import key
    from lathe_mirror.errors import InputError

    cfg = tmp_path / "c.toml"
    cfg.write_text(f"[camera]\n{field} = {value!r}\n")
    with pytest.raises(InputError) as from_file:
        load(cfg)
    with pytest.raises(DesignError) as built:
        dataclasses.replace(Camera(), **{field: value})
    assert str(built.value) == str(from_file.value) and line in str(built.value)
    k = key(f"camera.{field}")
    for end in (k.lo, k.hi):
        Camera(**{field: end})  # both documented ends


def test_design_figures_report_the_viewpoint_check(paper_mirror):
    for lobe in design_figures(paper_mirror)["lobes"]:
        assert 0.0 <= lobe["viewpoint_check_mm"] < 1e-9


def test_step_wall_blocks_the_top_of_the_inner_field(paper_mirror):
    m = paper_mirror
    # Hand value: a world ray bound for the inner F1 (z = 110.64) clears the top of the
    # wall (r = 20, z = outer sheet at 20) only below atan((113.786 - 110.64) / 20).
    z_top = float(m.outer.z(20.0))
    limit = math.atan((z_top - m.inner.focus_z) / 20.0)
    assert math.degrees(limit) == pytest.approx(math.degrees(math.atan((113.786 - 110.64) / 20)), abs=5e-3)
    assert m.fov_usable(m.inner) == pytest.approx((-math.pi / 2, limit), abs=1e-12)
    assert m.fov_usable(m.outer) == m.fov(m.outer)
    # The inner pixel at the start of the blocked band sees the sheet point on the line
    # from F1 through the wall's top edge.
    lo, hi = m.image_radii_px["inner_blocked_by_step"]
    assert hi == pytest.approx(307.555, abs=1e-9)
    t = lo * 0.009 / 16.0  # tan of the camera ray
    # On the sheet: the camera ray r = t z meets the inner lobe (closed-form quadratic).
    a, b, e = m.inner.a, m.inner.b, m.inner.e
    qa, qb, qc = 1 / (t * t * a * a) - 1 / (b * b), -2 * e / (t * a * a), e * e / (a * a) - 1
    r = max((-qb + s * math.sqrt(qb * qb - 4 * qa * qc)) / (2 * qa) for s in (1, -1))
    z = r / t
    assert math.atan2(z - m.inner.focus_z, r) == pytest.approx(limit, abs=1e-12)
