"""The zones every figure covers (optics.zones): the fillet ring the nose cannot reach
against the as-machined envelope's own fillet (nose_envelope.junction_fillet), its pixels
against a count of the sensor's pixel centres, and the criteria judging the used zone on
designs whose OUTER lobe is recessed (the 6 mm lens with 3 um pixels; the paper camera
opened to 35 mm of depth), where the whole-lobe figure includes the fillet."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import RECESSED_OUTER
from lathe_mirror.config import load
from lathe_mirror.export.calib import calibration_texts
from lathe_mirror.lathe import Tool
from lathe_mirror.nose_envelope import junction_fillet
from lathe_mirror.optics.radial import radial_figures, surface_errors
from lathe_mirror.optics.zones import zones, zones_for
from lathe_mirror.job import made_surface, plan
from lathe_mirror.toolpath import Strategy, profile_errors, usable_ranges

#: The paper camera opened to 35 mm of depth (the README's deep.toml, as `optimize` found it).
DEEP = ("[lobes.inner]\nr_top = 19.83168166800536\nr_pixel = 312.96738148794424\nalpha_deg = 0.0013881710223913046\n"
        "[lobes.outer]\nr_top = 34.999054141705216\nr_pixel = 450.7939258335052\nalpha_deg = 0.00016158913340724723\n"
        "[stock]\nlength = 50.0\n[cad]\nthickness = 45.0\n")


def _settings(tmp_path_factory, text: str, name: str):
    p = tmp_path_factory.mktemp("zones") / name
    p.write_text(text)
    return load(p)


@pytest.fixture(scope="module")
def small(tmp_path_factory):
    """The 6 mm lens, 3 um pixels, outer lobe recessed 0.43 mm; cut with a 0.4 mm nose."""
    return _settings(tmp_path_factory, RECESSED_OUTER + "[tool]\nnose_radius = 0.4\n", "small.toml")


@pytest.fixture(scope="module")
def deep(tmp_path_factory):
    return _settings(tmp_path_factory, DEEP, "deep.toml")


@pytest.mark.parametrize("case, nose", [("small", 0.1), ("small", 0.4), ("paper", 0.2), ("paper", 0.4)])
def test_fillet_ring_matches_the_envelope(case, nose, small, paper_mirror):
    """The closed form (nose centre touching the wall and the sheet) against the fillet the
    as-machined envelope of the arcs program leaves: within a lattice step (5 um)."""
    if case == "small":
        m, machine = small.mirror(), small.machine
    else:
        m, machine = paper_mirror, load().machine
    tp = plan(m, machine, Tool(nose_radius=nose), Strategy.ARCS)
    env = junction_fillet(tp)
    zn = zones(m, nose)
    assert zn.recessed == env["lobe"]
    ring = zn.fillet.fillet_mm
    assert ring[0] == pytest.approx(env["r_start_mm"], abs=0.005)
    assert ring[1] == pytest.approx(env["r_end_mm"], abs=0.005)


def test_fillet_in_view_counts_its_pixels(small):
    """Outer lobe recessed 0.43 mm, 0.4 mm nose: the fillet reaches past the inner rim's
    shadow, so its ring is in view; its pixel count is the sensor's pixel centres in it."""
    m = small.mirror()
    zn = zones_for(small, m)
    f = zn.lobes[1]
    assert f.fillet_px is not None and f.fillet_width_px > 1.0
    w, h = m.camera.sensor_px
    x = np.arange(w) + 0.5 - w / 2.0
    y = np.arange(h) + 0.5 - h / 2.0
    rho = np.hypot(x[None, :], y[:, None])
    assert f.fillet_pixels == int(np.sum((rho > f.fillet_px[0]) & (rho <= f.fillet_px[1])))
    assert f.used_px[0] == pytest.approx(f.fillet_px[1])
    # the zone in the message: mm, px and pixels lost
    text = zn.describe()
    assert "in view" in text and f"{f.fillet_pixels} pixels lost" in text


def test_criteria_judge_the_used_zone(small):
    """The as-machined mirror (0.4 mm nose): over the designed annulus the fillet's pixels
    dominate the image displacement; over the used zone they are out, and the ring is its
    own figure (the pixels the designed annulus has and the used zone has not)."""
    m = small.mirror()
    made = made_surface(m, small.machine, small.tool, Strategy.ARCS)
    zn = zones_for(small, m)
    whole = radial_figures(made.profile, m)["lobes"][1]
    used = radial_figures(made.profile, m, zones=zn)["lobes"][1]
    assert whole["image_displacement_px"]["max"] > 5.0 * used["image_displacement_px"]["max"]
    assert used["image_displacement_px"]["max"] < 1.0
    # the pixels left out: the sensor's pixel centres between the designed annulus's start
    # and the used zone's (the lattice's guard at the junction, then the fillet ring)
    w, h = m.camera.sensor_px
    rho = np.hypot((np.arange(w) + 0.5 - w / 2.0)[None, :], (np.arange(h) + 0.5 - h / 2.0)[:, None])
    lo, u_lo = m.image_radii_px["outer_annulus"][0], zn.lobes[1].used_px[0]
    ring = int(np.sum((rho > lo) & (rho <= u_lo)))
    assert whole["pixels"] + whole["pixels_excluded"] - used["pixels"] - used["pixels_excluded"] == ring
    assert 0.9 * ring < zn.lobes[1].fillet_pixels <= ring
    assert used["zone_px"]["min"] == pytest.approx(zn.lobes[1].used_px[0])


def test_slope_error_on_the_seen_zone_of_a_deep_mirror(deep):
    """The paper camera opened to 35 mm depth (outer lobe recessed 15.4 mm): the inner lobe's
    rim hides the outer lobe out to r 22.8 mm, where the fillet lies. The slope error over
    the used zone (optics.radial.surface_errors) agrees with the G-code header's used-zone
    figure (toolpath.profile_errors on usable_ranges, another implementation) and is far
    inside the spec's 0.02 rad, while the whole lobe's, fillet included, is not."""
    m = deep.mirror()
    assert m.recessed == "outer"
    made = made_surface(m, deep.machine, deep.tool, Strategy.ARCS)
    zn = zones_for(deep, m)
    assert zn.lobes[1].fillet_px is None  # in the shadow
    used = surface_errors(made.profile, m, used=True, n=20001)
    header = profile_errors(made.profile, m, r_ranges=usable_ranges(m))
    whole = profile_errors(made.profile, m)
    se_used, se_header = used["lobes"][1]["slope_error_rad"]["rms"], header["lobes"][1]["slope_error_rad"]["rms"]
    assert se_used == pytest.approx(se_header, rel=0.05)
    assert se_used < 0.002 < 0.02 < whole["lobes"][1]["slope_error_rad"]["rms"]


def test_calibration_files_mask_the_ring(small):
    """The OpenCV file's valid annulus of the outer lobe starts past the fillet ring."""
    m = small.mirror()
    zn = zones_for(small, m)
    text = calibration_texts(m, zn)["opencv_outer.yaml"]
    lo = float(text.split("annulus_inner_radius_px:")[1].split()[0])
    assert lo == pytest.approx(zn.lobes[1].used_px[0], abs=1e-5)
    assert lo > m.image_radii_px["outer_annulus"][0] + 1.0
    assert "fillet" in text


def test_camera_constants_print_with_their_digits(tmp_path):
    """A 3.45 um pixel (a common machine-vision sensor) prints as given in `design`, not
    rounded to 0.0034."""
    from conftest import run_cli

    cfg = tmp_path / "c.toml"
    # (a body thick enough for its 28.8 mm deep mirror: `design` refuses what `cad` would)
    cfg.write_text("[camera]\nt_pixel = 0.00345\nf = 4.5\n[lobes.inner]\nr_pixel = 110.0\n[lobes.outer]\nr_pixel = 180.0\n"
                   "[cad]\nthickness = 32.0\n")
    proc = run_cli("design", "--config", str(cfg))
    assert proc.returncode == 0, proc.stderr
    row = next(line for line in proc.stdout.splitlines() if line.startswith("T_pixel"))
    assert row.split()[-2:] == ["0.00345", "0.00345"]
