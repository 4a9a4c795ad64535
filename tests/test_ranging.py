"""Range from the image (optics/ranging, export/ply, `lathe-mirror stereo`).

Every expected number comes from somewhere else: trigonometry done here by hand, the
3-D tracer's reflected rays (optics.trace, law of reflection off the sheet's slope, not
the focal polar equation rectify uses), plane intersections written out here, trimesh's
PLY reader, and the resolution model's closed form against exact triangulation.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from lathe_mirror.config import merge
from lathe_mirror.optics.ranging.rectify import PanoramaGrid, make_grid, unwrap
from lathe_mirror.optics.ranging.resolution import angular_resolution, r10, range_error_pct
from lathe_mirror.optics.ranging.triangulate import meridian_point, stereo_centre_z, triangulate

from conftest import run_cli


# --------------------------------------------------------------------------------------
# Triangulation


def test_meridian_point_is_the_crossing_of_two_rays_by_hand():
    # Viewpoints 30 mm apart on the axis (z = 0 and z = 30); the point (40, 0) is seen
    # level from the lower one and at -atan(30 / 40) from the upper one (a 3-4-5 triangle).
    r, z = meridian_point(30.0, -math.atan2(30.0, 40.0), 0.0, 0.0)
    assert r == pytest.approx(40.0, abs=1e-12)
    assert z == pytest.approx(0.0, abs=1e-12)
    # Rays that diverge (the inner one looking lower) meet behind: no range.
    assert np.isnan(meridian_point(30.0, 0.0, 0.0, -0.01)[0])


def test_triangulate_a_panorama_pixel_by_hand(paper_mirror):
    m = paper_mirror
    grid = PanoramaGrid(band=(math.radians(-20.0), 0.0), n_elevation=200, n_azimuth=360)
    j, i = 37, 123
    phi = grid.elevations()[j]
    az = grid.azimuths()[i]
    # A point 1500 mm from the outer viewpoint along that pixel's ray.
    z_out, z_in = 2 * m.outer.e, 2 * m.inner.e
    r_w = 1500.0 * math.cos(phi)
    z_w = z_out + 1500.0 * math.sin(phi)
    phi_in = math.atan2(z_w - z_in, r_w)
    d = np.full(grid.shape, np.nan)
    d[j, i] = (phi_in - phi) / grid.step
    rm = triangulate(m, grid, d)
    assert rm.valid.sum() == 1
    x = rm.points[j, i]
    np.testing.assert_allclose(x, [r_w * math.cos(az), r_w * math.sin(az), z_w], atol=1e-9)
    z_c = 0.5 * (z_in + z_out)
    assert rm.range_mm[j, i] == pytest.approx(math.hypot(r_w, z_w - z_c), abs=1e-9)
    assert m.baseline == pytest.approx(2 * (m.outer.e - m.inner.e))
    assert stereo_centre_z(m) == pytest.approx(z_c)


# --------------------------------------------------------------------------------------
# Rectification against the tracer


@pytest.mark.parametrize("world", [(1500.0, 20.0, -150.0), (-700.0, -900.0, -420.0)])
def test_unwrap_puts_a_world_point_on_its_expected_pixel_in_both_lobes(paper_mirror, world):
    """The unwrap samples, at a world point's expected panorama pixel, the image point from
    which the tracer's reflected ray (law of reflection off the sheet) reaches that point."""
    from lathe_mirror.optics.trace import Fate, trace_pixels
    from lathe_mirror.profile import ExactProfile

    m = paper_mirror
    grid = make_grid(m)
    w, h = m.camera.sensor_px
    # Ramps of the image's own coordinates: bilinear sampling returns where it sampled.
    cols = np.tile(np.arange(w, dtype=float), (h, 1))
    rows = np.tile(np.arange(h, dtype=float)[:, None], (1, w))
    wx, wy, wz = world
    az = math.atan2(wy, wx)
    for k, lobe in enumerate(m.lobes):
        phi = math.atan2(wz - lobe.focus_z, math.hypot(wx, wy))
        row, col = grid.pixel_of(phi, az)
        j0, i0 = int(math.floor(row)), int(math.floor(col))
        fr, fc = row - j0, col - i0
        xs, ys = (unwrap(img, m, k, grid)[0].astype(float) for img in (cols, rows))

        def at(p):  # bilinear in the panorama: the map is smooth over one pixel
            return ((1 - fr) * ((1 - fc) * p[j0, i0] + fc * p[j0, i0 + 1])
                    + fr * ((1 - fc) * p[j0 + 1, i0] + fc * p[j0 + 1, i0 + 1]))

        u, v = at(xs) - (w / 2.0 - 0.5), at(ys) - (h / 2.0 - 0.5)
        hit = trace_pixels(ExactProfile(m), m.camera, np.array([[u, v]]))
        assert hit.fate[0] == (Fate.INNER if k == 0 else Fate.OUTER)
        p, o = hit.point[0], hit.direction[0]
        to_w = np.array(world) - p
        to_w /= np.linalg.norm(to_w)
        # The ray's direction against the direction to the point, in elevation and azimuth,
        # in panorama pixels.
        el_miss = (math.asin(o[2]) - math.asin(to_w[2])) / grid.step
        az_miss = (math.atan2(o[1], o[0]) - math.atan2(to_w[1], to_w[0])) / grid.azimuth_step
        assert abs(el_miss) < 0.05 and abs(az_miss) < 0.05, (k, el_miss, az_miss)


# --------------------------------------------------------------------------------------
# Ground truth


def test_true_range_of_a_box_a_wall_and_the_floor_by_hand(paper_config, paper_mirror):
    from lathe_mirror.optics.ranging.truth import true_range
    from lathe_mirror.optics.scene import build_scene
    from lathe_mirror.settings import from_config

    m = paper_mirror
    scene = build_scene(from_config(paper_config).scene, mirror_top=m.outer.h, mirror_radius=m.r_max)
    z0, zc, zi = m.outer.focus_z, stereo_centre_z(m), m.inner.focus_z
    # The room (scene.toml): centre (150, -80), side 4000 -> x walls at -1850 and 2150;
    # floor 350 mm below the camera; box 1 centred (1100, 500), 500 mm cube: its -x face
    # x = 850 for 250 < y < 750, -350 < z < 150.
    for el_deg, n_az, col, expect in [
        (-5.0, 720, 48, "box"),     # azimuth 24.25 deg: toward box 1's -x face
        (-5.0, 720, 359, "wall"),   # azimuth 179.75 deg: the x = -1850 wall
        (-20.0, 4, 0, "floor"),     # azimuth 45 deg, 20 deg down: the floor
    ]:
        el = math.radians(el_deg)
        grid = PanoramaGrid(band=(el - 1e-3, el + 1e-3), n_elevation=1, n_azimuth=n_az)
        az = (col + 0.5) * 2 * math.pi / n_az
        ca, sa = math.cos(az), math.sin(az)
        if expect == "box":
            t = 850.0 / (math.cos(el) * ca)
            assert 250 < t * math.cos(el) * sa < 750
        elif expect == "wall":
            t = -1850.0 / (math.cos(el) * ca)
        else:
            t = (z0 + 350.0) / -math.sin(el)
            assert abs(t * math.cos(el) * ca) < 1850 and t * math.cos(el) * sa < 1920
        x, y, z = t * math.cos(el) * ca, t * math.cos(el) * sa, z0 + t * math.sin(el)
        tr = true_range(m, scene, grid)
        np.testing.assert_allclose(tr.points[0, col], [x, y, z], atol=1e-9)
        r = math.hypot(x, y)
        assert tr.range_mm[0, col] == pytest.approx(math.hypot(r, z - zc), abs=1e-9)
        assert tr.disparity[0, col] == pytest.approx((math.atan2(z - zi, r) - el) / grid.step, rel=1e-12)


# --------------------------------------------------------------------------------------
# Resolution model


def test_angular_resolution_matches_the_tracer(paper_mirror):
    """d elevation / d image radius from the closed form against reflected rays traced at
    image radii 0.01 px apart (optics.trace: reflection off the sheet's slope)."""
    from lathe_mirror.optics.radial import ideal_radius_px
    from lathe_mirror.optics.trace import meridian_hits
    from lathe_mirror.profile import ExactProfile

    m = paper_mirror
    el = np.radians([-24.0, -15.0, -5.0, -0.5])
    for lobe in m.lobes:
        rho = ideal_radius_px(lobe, m.camera, el)
        t = m.camera.tan_theta(np.stack([rho - 0.005, rho + 0.005]))
        hits = meridian_hits(ExactProfile(m), t.ravel())
        phi = np.arctan2(hits.out_z, hits.out_r).reshape(2, -1)
        np.testing.assert_allclose(angular_resolution(lobe, m.camera, el), (phi[1] - phi[0]) / 0.01, rtol=1e-6)


def test_range_error_model_against_exact_triangulation(paper_mirror):
    """First order: a small parallax error changes the triangulated range by
    R d(gamma) / (B cos el); checked with meridian_point (exact crossing) at 1 and 2.5 m."""
    m = paper_mirror
    z_o, z_i, zc = m.outer.focus_z, m.inner.focus_z, stereo_centre_z(m)
    for rng, el in ((1000.0, math.radians(-10.0)), (2500.0, math.radians(-3.0))):
        r, z = rng * math.cos(el), zc + rng * math.sin(el)
        phi_o, phi_i = math.atan2(z - z_o, r), math.atan2(z - z_i, r)
        dg = 1e-6
        r2, z2 = meridian_point(z_o, phi_o, z_i, phi_i - dg)
        rel = 100.0 * (math.hypot(r2, z2 - zc) - rng) / rng
        assert rel == pytest.approx(float(range_error_pct(m, rng, el, dg)), rel=2e-2)


def test_r10_of_the_paper_design(paper_mirror):
    """R10 = median over the band of 0.1 B cos(el) / sqrt(res_inner^2 + res_outer^2), here
    with the resolutions from the tracer (finite differences) on 129 band elevations."""
    from lathe_mirror.optics.radial import ideal_radius_px
    from lathe_mirror.optics.trace import meridian_hits
    from lathe_mirror.profile import ExactProfile

    m = paper_mirror
    lo, hi = m.common_band
    el = lo + (np.arange(129) + 0.5) * (hi - lo) / 129
    res = []
    for lobe in m.lobes:
        rho = ideal_radius_px(lobe, m.camera, el)
        hits = meridian_hits(ExactProfile(m), m.camera.tan_theta(np.concatenate([rho - 0.005, rho + 0.005])))
        phi = np.arctan2(hits.out_z, hits.out_r).reshape(2, -1)
        res.append((phi[1] - phi[0]) / 0.01)
    expect = np.median(0.1 * 12.799825 * np.cos(el) / np.hypot(*res)) / 1e3
    assert r10(m) == pytest.approx(expect, rel=2e-3)
    assert r10(m) == pytest.approx(0.222, abs=0.001)  # the "about 0.22 m"


# --------------------------------------------------------------------------------------
# PLY


@pytest.mark.parametrize("binary", [True, False])
def test_ply_reads_back_with_trimesh(tmp_path, binary):
    import trimesh

    from lathe_mirror.export.ply import write_ply

    rng = np.random.default_rng(7)
    pts = rng.normal(scale=2.0, size=(500, 3))
    col = rng.integers(0, 256, size=(500, 3), dtype=np.uint8)
    path = write_ply(tmp_path / "cloud.ply", pts, col, binary=binary, comments=("units m",))
    cloud = trimesh.load(path)
    assert isinstance(cloud, trimesh.PointCloud)
    np.testing.assert_array_equal(cloud.vertices, pts.astype(np.float32).astype(float))
    np.testing.assert_array_equal(cloud.colors[:, :3], col)


# --------------------------------------------------------------------------------------
# The whole chain


#: The paper's room with its 300 mm box moved to 0.57 m from the axis: its top edge lies in
#: the common band, so the 0.5-1 m bin has texture to match (in the paper's room that bin is
#: only the flat faces of boxes 1 and 3, whose edges run along the epipolar lines).
NEAR_BOX = {"scene": {"boxes": [
    {"centre": [1100.0, 500.0], "size": [500.0, 500.0, 500.0]},
    {"centre": [-600.0, 500.0], "size": [300.0, 300.0, 300.0]},
    {"centre": [-300.0, -1200.0], "size": [700.0, 450.0, 800.0]}]}}


def test_exact_mirror_ranges_within_the_one_pixel_model(paper_config):
    """On the exact mirror the error is the matcher's: per range bin the median |range
    error| lies within the 1-px model, no bin is biased by more than its median error's
    share, and at least half of the band gets a range."""
    from lathe_mirror.optics.ranging.stereo import range_figures, stereo_range
    from lathe_mirror.optics.ranging.truth import true_range
    from lathe_mirror.optics.render import render_image
    from lathe_mirror.optics.scene import build_scene
    from lathe_mirror.profile import ExactProfile
    from lathe_mirror.settings import from_config

    settings = from_config(merge(paper_config, NEAR_BOX))
    m = settings.mirror()
    scene = build_scene(settings.scene, mirror_top=m.outer.h, mirror_radius=m.r_max)
    image = render_image(ExactProfile(m), m, scene, supersample=2)
    res = stereo_range(image, m, settings.stereo.params)
    fig = range_figures(res, true_range(m, scene, res.grid), m)
    assert fig["valid_fraction"] > 0.5
    for b in fig["bins"]:
        assert b["valid_fraction"] > 0.1, b
        e = b["range_error_pct"]
        assert e["median"] < b["model_1px_pct"], b
        assert abs(e["signed_median"]) < e["median"], b
    assert fig["disparity_error_px"]["median"] < 0.25


# --------------------------------------------------------------------------------------
# The command


def test_stereo_command_writes_its_files_the_same_twice(tmp_path):
    import trimesh

    outs = []
    for name in ("a", "b"):
        proc = run_cli("stereo", "--surface", "exact", "-o", str(tmp_path / name), "--json", "--no-progress")
        assert proc.returncode == 0, proc.stderr
        assert proc.stderr == ""
        outs.append(json.loads(proc.stdout))
    files = sorted(p.name for p in (tmp_path / "a").iterdir())
    assert files == ["error_range_exact.png", "points_exact.ply", "range_exact.png", "stereo_exact.json"]
    for f in files[:3]:
        assert (tmp_path / "a" / f).read_bytes() == (tmp_path / "b" / f).read_bytes(), f
    a, b = (json.loads((tmp_path / d / "stereo_exact.json").read_text()) for d in ("a", "b"))
    assert {k: v for k, v in a.items() if k != "files"} == {k: v for k, v in b.items() if k != "files"}
    fig = outs[0]
    cloud = trimesh.load(tmp_path / "a" / "points_exact.ply")
    assert len(cloud.vertices) == round(fig["valid_fraction"] * fig["pixels"])
    # The cloud is in metres, in the camera frame: the room's walls (x -1.85 / 2.15 m,
    # y -2.08 / 1.92 m) and floor (z -0.35 m), twice the median ranging error farther out
    # (12.9 % at f/8: the lens's blur, up to 6.6 px, raises it from 4.6 %), bound all but
    # the matcher's outliers (15 % of the points in the blurred image).
    v = cloud.vertices
    f = 1.0 + 2.0 * fig["range_error_pct"]["median"] / 100.0
    assert 1.2 < f < 1.3
    inside = ((v[:, 0] > -1.85 * f) & (v[:, 0] < 2.15 * f) & (v[:, 1] > -2.08 * f)
              & (v[:, 1] < 1.92 * f) & (v[:, 2] > -0.35 * f - 0.05))
    assert inside.mean() > 0.82
    assert json.loads((tmp_path / "a" / "stereo_exact.json").read_text())["valid_fraction"] == fig["valid_fraction"]


@pytest.mark.parametrize("toml, words", [
    ("[lobes.outer]\nalpha_deg = 30.0\n", "no common stereo band"),
    ("[lobes.outer]\nalpha_deg = 20.0\n", "narrower than twice the matcher's window"),
    ("[camera_pose]\ndecentre = [20.0, 0.0]\n", "the camera sees the common band"),
    ("[stereo]\nblock_size = 4\n", "stereo.block_size = 4"),
])
def test_stereo_bad_input_is_one_line_and_writes_nothing(tmp_path, toml, words):
    cfg = tmp_path / "bad.toml"
    cfg.write_text(toml)
    out = tmp_path / "out"
    proc = run_cli("stereo", "--config", str(cfg), "-o", str(out), "--no-progress")
    assert proc.returncode == 2, proc.stderr
    assert proc.stdout == ""
    assert len(proc.stderr.strip().splitlines()) == 1 and words in proc.stderr, proc.stderr
    assert not out.exists()


def test_stereo_unknown_surface_is_refused(tmp_path):
    proc = run_cli("stereo", "--surface", "glass", "-o", str(tmp_path / "out"))
    assert proc.returncode == 2 and "--surface 'glass'" in proc.stderr
    assert not (tmp_path / "out").exists()
