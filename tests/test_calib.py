"""Calibration files (OpenCV, Kalibr, OCamCalib) against the exact tracer, and the made
mirrors' reprojection errors against closed forms.

The reference for a world point's pixel is the exact tracer (optics.trace.meridian_hits on
the exact profile): the test searches, by bisection on the image radius in the point's
meridian plane, the pixel whose traced ray reflects through the point. The files are read
the way their own tools read them: cv2.FileStorage and cv2.omnidir, PyYAML, and OCamCalib's
C reader and world2cam / cam2world written out here.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from committed import numbers_differ
from conftest import run_cli
from lathe_mirror.design import design_lobe, design_mirror
from lathe_mirror.export.calib import FILE_NAMES, calibration_texts, opencv_yaml, write_calibration
from lathe_mirror.optics.camera import CameraPose
from lathe_mirror.optics.camera_model import (design_model, made_lobe_figures, refit,
                                              trace_correspondences)
from lathe_mirror.optics.trace import meridian_hits
from lathe_mirror.profile import ExactProfile

cv2 = pytest.importorskip("cv2")

REPO = Path(__file__).resolve().parents[1]


# --------------------------------------------------------------------------------------
# The independent side: the exact tracer, inverted by bisection


def tracer_pixels(mirror, k: int, points_cam: np.ndarray) -> np.ndarray:
    """OpenCV pixels (N, 2) whose rays, traced off the exact mirror's lobe k, reflect
    through the camera-frame points (N, 3), mm."""
    prof = ExactProfile(mirror)
    cam = mirror.camera
    rw = np.hypot(points_cam[:, 0], points_cam[:, 1])
    zw = points_cam[:, 2]
    az = np.arctan2(points_cam[:, 1], points_cam[:, 0])
    zi, zo = mirror.junction_z
    if k == 0:
        t_lo, t_hi = 0.0, mirror.r_junction / zi
    else:
        t_lo = np.nextafter(mirror.r_junction / zo, 1.0)
        t_hi = mirror.r_max / float(mirror.outer.z(mirror.r_max))
    lo = np.full(rw.shape, t_lo)
    hi = np.full(rw.shape, t_hi)

    def side(t):
        h = meridian_hits(prof, t)
        assert np.all(h.fate == k)
        return (rw - h.r) * h.out_z - (zw - h.z) * h.out_r  # which side of the ray the point is

    s_lo, s_hi = side(lo), side(hi)
    assert np.all(np.sign(s_lo) != np.sign(s_hi)), "a point outside the lobe's field"
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        same = np.sign(side(mid)) == np.sign(s_lo)
        lo, hi = np.where(same, mid, lo), np.where(same, hi, mid)
    rho = 0.5 * (lo + hi) * cam.f / cam.t_pixel
    w, h = cam.sensor_px
    return np.stack([rho * np.cos(az) + (w - 1) / 2, rho * np.sin(az) + (h - 1) / 2], axis=-1)


def world_points(mirror, k: int, n: int = 60, seed: int = 11) -> np.ndarray:
    """Camera-frame points (n, 3), mm, at elevations spread over lobe k's unblocked field,
    every azimuth, 0.3 to 5 m from its viewpoint."""
    rng = np.random.default_rng(seed)
    lo, hi = mirror.fov_usable(mirror.lobes[k])
    el = np.linspace(max(lo, math.radians(-89.5)) + 1e-4, hi - 1e-4, n)
    az = rng.uniform(0, 2 * math.pi, n)
    dist = rng.uniform(300.0, 5000.0, n)
    d = np.stack([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)], axis=-1)
    return np.array([0.0, 0.0, mirror.lobes[k].focus_z]) + dist[:, None] * d


def to_lobe(points_cam, f1_z):
    """The files' documented frame: diag(1, 1, -1) (X_cam - F1)."""
    return (points_cam - [0.0, 0.0, f1_z]) * [1.0, 1.0, -1.0]


@pytest.fixture(scope="module")
def files(tmp_path_factory, paper_mirror):
    d = tmp_path_factory.mktemp("calib")
    write_calibration(d, paper_mirror)
    return d


def load_opencv(path: Path):
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
    assert fs.isOpened()
    out = {key: fs.getNode(key).mat() for key in ("K", "D", "xi")}
    for key in ("image_width", "image_height", "annulus_inner_radius_px", "annulus_outer_radius_px",
                "viewpoint_z_mm"):
        out[key] = fs.getNode(key).real()
    fs.release()
    return out


# --------------------------------------------------------------------------------------
# OpenCV


@pytest.mark.parametrize("k", [0, 1])
def test_opencv_yaml_projects_onto_the_tracers_pixel(files, paper_mirror, k):
    name = paper_mirror.lobes[k].name
    cal = load_opencv(files / f"opencv_{name}.yaml")
    assert (cal["image_width"], cal["image_height"]) == (1008, 1018)
    pts = world_points(paper_mirror, k)
    expected = tracer_pixels(paper_mirror, k, pts)
    obj = to_lobe(pts, cal["viewpoint_z_mm"]).reshape(1, -1, 3)
    got, _ = cv2.omnidir.projectPoints(obj, np.zeros(3), np.zeros(3), cal["K"], float(cal["xi"][0, 0]),
                                       cal["D"])
    err = np.linalg.norm(got.reshape(-1, 2) - expected, axis=-1)
    assert err.max() < 1e-6, err.max()
    # The points span the lobe's field: image radii across its valid annulus.
    rho = np.hypot(expected[:, 0] - 503.5, expected[:, 1] - 508.5)
    r0, r1 = cal["annulus_inner_radius_px"], cal["annulus_outer_radius_px"]
    assert rho.min() < r0 + 0.1 * (r1 - r0) and rho.max() > r1 - 0.1 * (r1 - r0)
    assert np.all((rho >= r0 - 1e-9) & (rho <= r1 + 1e-9))


@pytest.mark.parametrize("k", [0, 1])
def test_opencv_undistort_points_and_rectify_map_take_the_file(files, paper_mirror, k):
    name = paper_mirror.lobes[k].name
    cal = load_opencv(files / f"opencv_{name}.yaml")
    f1 = cal["viewpoint_z_mm"]
    # undistortPoints: the tracer's pixel of a point below F1's horizon goes to x/z, y/z of
    # the point in the lobe frame.
    pts = world_points(paper_mirror, k)
    pts = pts[pts[:, 2] < f1 - 1.0]
    px = tracer_pixels(paper_mirror, k, pts)
    und = cv2.omnidir.undistortPoints(px.reshape(1, -1, 2), cal["K"], cal["D"], cal["xi"], np.eye(3))
    lobe = to_lobe(pts, f1)
    # The directions agree to the file's precision: K at 1e-6 px over gamma ~ 240-480 px is
    # ~4e-9 rad (compared as angles: x/z itself grows as 1/cos^2 near the horizon).
    got_dir = np.concatenate([und.reshape(-1, 2), np.ones((len(pts), 1))], axis=1)
    ang = np.arctan2(np.linalg.norm(np.cross(got_dir, lobe), axis=1), np.sum(got_dir * lobe, axis=1))
    assert ang.max() < 1e-8
    # initUndistortRectifyMap: a perspective view (R takes the lobe frame to the view's).
    knew = np.array([[300.0, 0.0, 200.0], [0.0, 300.0, 150.0], [0.0, 0.0, 1.0]])
    el = math.radians(-60.0 if k == 0 else -13.0)  # the view's centre, inside the lobe's field
    rot, _ = cv2.Rodrigues(np.array([math.atan2(math.cos(el), -math.sin(el)), 0.0, 0.0]))
    map_x, map_y = cv2.omnidir.initUndistortRectifyMap(cal["K"], cal["D"], cal["xi"], rot, knew, (400, 300),
                                                       cv2.CV_32FC1, cv2.omnidir.RECTIFY_PERSPECTIVE)
    rows, cols = np.meshgrid(np.arange(20, 300, 40), np.arange(20, 400, 40), indexing="ij")
    rays = np.stack([cols.ravel(), rows.ravel(), np.ones(rows.size)], axis=-1) @ np.linalg.inv(knew).T
    d_lobe = rays @ rot  # R^T ray: back into the lobe frame
    d_lobe /= np.linalg.norm(d_lobe, axis=-1, keepdims=True)
    d_cam = d_lobe * [1.0, 1.0, -1.0]
    el_cam = np.degrees(np.arcsin(d_cam[:, 2]))
    lo, hi = (math.degrees(x) for x in paper_mirror.fov_usable(paper_mirror.lobes[k]))
    inside = (el_cam > lo + 0.01) & (el_cam < hi - 0.01)
    assert inside.sum() > 20
    expected = tracer_pixels(paper_mirror, k, np.array([0.0, 0.0, f1]) + 2000.0 * d_cam[inside])
    got = np.stack([map_x[rows, cols].ravel(), map_y[rows, cols].ravel()], axis=-1)[inside]
    assert np.abs(got - expected).max() < 2e-3  # float32 maps


# --------------------------------------------------------------------------------------
# Kalibr


def test_kalibr_camchain_loads_and_projects_with_the_axial_translation(files, paper_mirror):
    chain = yaml.safe_load((files / "kalibr_camchain.yaml").read_text())
    assert sorted(chain) == ["cam0", "cam1"]
    for cam in chain.values():
        assert cam["camera_model"] == "omni" and cam["distortion_model"] == "none"
        assert cam["distortion_coeffs"] == [] and cam["resolution"] == [1008, 1018]
        assert len(cam["intrinsics"]) == 5
    t = np.array(chain["cam1"]["T_cn_cnm1"])
    assert t.shape == (4, 4) and np.array_equal(t[:3, :3], np.eye(3)) and t[0, 3] == t[1, 3] == 0
    # Table 1: c = 2e = 110.64 (01) and 123.44 mm (02), so the viewpoints are 12.80 mm apart.
    assert t[2, 3] == pytest.approx((123.44 - 110.64) / 1000.0, abs=2e-6)

    def mei(intrinsics, x):  # Mei's projection, written out: [xi, fu, fv, pu, pv]
        xi, fu, fv, pu, pv = intrinsics
        s = x / np.linalg.norm(x, axis=-1, keepdims=True)
        return np.stack([fu * s[:, 0] / (s[:, 2] + xi) + pu, fv * s[:, 1] / (s[:, 2] + xi) + pv], axis=-1)

    # A point in the outer lobe's field: cam0 coordinates (inner lobe frame) taken into cam1
    # by T_cn_cnm1 project onto the tracer's outer-lobe pixel.
    pts = world_points(paper_mirror, 1)
    x0 = to_lobe(pts, paper_mirror.inner.focus_z) / 1000.0  # Kalibr is in metres
    x1 = x0 @ t[:3, :3].T + t[:3, 3]
    err = np.linalg.norm(mei(chain["cam1"]["intrinsics"], x1) - tracer_pixels(paper_mirror, 1, pts), axis=-1)
    assert err.max() < 1e-6
    pts = world_points(paper_mirror, 0)
    err = np.linalg.norm(mei(chain["cam0"]["intrinsics"], to_lobe(pts, paper_mirror.inner.focus_z))
                         - tracer_pixels(paper_mirror, 0, pts), axis=-1)
    assert err.max() < 1e-6


# --------------------------------------------------------------------------------------
# OCamCalib


def read_ocam(text: str) -> dict:
    """calib_results.txt read as OCamCalib's C get_ocam_model does (fgets the comment line,
    fscanf the numbers)."""
    pos = 0

    def skip_ws():
        nonlocal pos
        while pos < len(text) and text[pos].isspace():
            pos += 1

    def token():
        nonlocal pos
        skip_ws()
        end = pos
        while end < len(text) and not text[end].isspace():
            end += 1
        tok, pos = text[pos:end], end
        return tok

    def comment_line():
        nonlocal pos
        skip_ws()
        end = text.index("\n", pos) + 1
        line, pos = text[pos:end], end
        assert line.startswith("#"), line

    comment_line()
    pol = [float(token()) for _ in range(int(token()))]
    comment_line()
    invpol = [float(token()) for _ in range(int(token()))]
    comment_line()
    xc, yc = float(token()), float(token())
    comment_line()
    c, d, e = (float(token()) for _ in range(3))
    comment_line()
    height, width = int(token()), int(token())
    return dict(pol=pol, invpol=invpol, xc=xc, yc=yc, c=c, d=d, e=e, height=height, width=width)


def world2cam(m: dict, p: np.ndarray) -> np.ndarray:
    """(row, column) of points (N, 3) of OCamCalib's frame: ocam_functions.cpp's world2cam."""
    norm = np.hypot(p[:, 0], p[:, 1])
    theta = np.arctan(p[:, 2] / norm)
    rho = sum(a * theta**i for i, a in enumerate(m["invpol"]))
    x, y = p[:, 0] / norm * rho, p[:, 1] / norm * rho
    return np.stack([x * m["c"] + y * m["d"] + m["xc"], x * m["e"] + y + m["yc"]], axis=-1)


def cam2world(m: dict, rc: np.ndarray) -> np.ndarray:
    """Unit rays (N, 3) of OCamCalib's frame for (row, column) points: its cam2world."""
    inv = 1.0 / (m["c"] - m["d"] * m["e"])
    xp = inv * ((rc[:, 0] - m["xc"]) - m["d"] * (rc[:, 1] - m["yc"]))
    yp = inv * (-m["e"] * (rc[:, 0] - m["xc"]) + m["c"] * (rc[:, 1] - m["yc"]))
    r = np.hypot(xp, yp)
    zp = sum(a * r**i for i, a in enumerate(m["pol"]))
    v = np.stack([xp, yp, zp], axis=-1)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


@pytest.mark.parametrize("k", [0, 1])
def test_ocamcalib_file_reproduces_the_tracer_over_the_annulus(files, paper_mirror, k):
    lobe = paper_mirror.lobes[k]
    m = read_ocam((files / f"calib_results_{lobe.name}.txt").read_text())
    assert (m["height"], m["width"], m["c"], m["d"], m["e"]) == (1018, 1008, 1.0, 0.0, 0.0)
    f1 = np.array([0.0, 0.0, lobe.focus_z])
    # OCamCalib's frame (the file's notes): x along the rows (camera y), y along the columns
    # (camera x), z up the axis from F1.
    pts = world_points(paper_mirror, k, n=200)
    rel = pts - f1
    rc = world2cam(m, np.stack([rel[:, 1], rel[:, 0], rel[:, 2]], axis=-1))
    expected = tracer_pixels(paper_mirror, k, pts)
    err = np.linalg.norm(rc[:, ::-1] - expected, axis=-1)
    assert err.max() < 0.05, err.max()
    # cam2world: the ray of the tracer's pixel, traced back, lands on that pixel.
    ray = cam2world(m, expected[:, ::-1])
    back = tracer_pixels(paper_mirror, k, f1 + 3000.0 * np.stack([ray[:, 1], ray[:, 0], ray[:, 2]], axis=-1))
    assert np.linalg.norm(back - expected, axis=-1).max() < 0.05


# --------------------------------------------------------------------------------------
# Made mirrors


def other_design(camera):
    """The paper's rims with other hyperbolas: a central mirror the design model is not."""
    inner = design_lobe("inner", camera, 20.0, 307.555, a_over_b=1.7)
    outer = design_lobe("outer", camera, 35.0, 504.0, alpha_deg=1.0)
    return design_mirror(camera, inner, outer)


@pytest.mark.parametrize("k", [0, 1])
def test_refit_of_another_hyperbola_recovers_its_closed_form(paper_mirror, k):
    """A made surface that is another pair of hyperbolic sheets is central: its directions
    are exactly the unified model of those sheets, xi' = 2 a' e' / (a'^2 + e'^2), gamma' =
    f_px b'^2 / (a'^2 + e'^2), which the refit must find; and the design model's error on
    it follows in closed form from the focal property."""
    other = other_design(paper_mirror.camera)
    made = ExactProfile(other)
    lobe, lobe2, cam = paper_mirror.lobes[k], other.lobes[k], paper_mirror.camera
    f_px = cam.f / cam.t_pixel
    corr = trace_correspondences(made, paper_mirror, k, range_mm=math.inf)
    fitted = refit(design_model(paper_mirror, k), corr)
    d2 = lobe2.a**2 + lobe2.e**2
    assert fitted.xi == pytest.approx(2 * lobe2.a * lobe2.e / d2, rel=1e-8)
    assert fitted.fu == pytest.approx(f_px * lobe2.b**2 / d2, rel=1e-8)
    assert abs(fitted.k1) < 1e-8 and abs(fitted.k2) < 1e-8
    assert (fitted.cx, fitted.cy) == (503.5, 508.5)
    # The design model's error, by hand: the pixel's ray meets sheet' at z = b'^2 / (e' -
    # a' sqrt(1 + t^2)); the world direction is F1' -> P; the design images elevation phi
    # at b^2 f_px cos(phi) / (2 a e - (a^2 + e^2) sin(phi)).
    rho = np.hypot(corr.pixels[:, 0] - 503.5, corr.pixels[:, 1] - 508.5)
    t = rho * cam.t_pixel / cam.f
    z = lobe2.b**2 / (lobe2.e - lobe2.a * np.sqrt(1 + t * t))
    phi = np.arctan2(z - 2 * lobe2.e, t * z)
    rho_design = lobe.b**2 * f_px * np.cos(phi) / (2 * lobe.a * lobe.e - (lobe.a**2 + lobe.e**2) * np.sin(phi))
    # the pixels whose direction the design images outside the lobe's annulus (by more than
    # half a pixel) have left its range: lost, not an error (optics.radial.in_lobe_range)
    lo, hi = paper_mirror.image_radii_px["inner_disc" if k == 0 else "outer_annulus"]
    inside = (rho_design >= lo - 0.5) & (rho_design <= hi + 0.5)
    err = np.abs(rho_design - rho)[inside]
    fig = made_lobe_figures(made, paper_mirror, k, range_mm=math.inf)
    w = corr.weight[inside]
    assert fig["pixels_excluded"] == corr.excluded + round(corr.weight[~inside].sum())
    assert fig["design"]["reprojection_error_px"]["rms"] == pytest.approx(np.sqrt(np.sum(w * err**2) / w.sum()), rel=1e-9)
    assert fig["design"]["reprojection_error_px"]["max"] == pytest.approx(err.max(), rel=1e-9)
    assert fig["design"]["reprojection_error_px"]["rms"] > 0.5  # a real departure
    assert fig["refit"]["reprojection_error_px"]["max"] < 1e-6


def test_design_error_at_infinity_is_the_image_displacement(paper_mirror):
    """With world points at infinity (directions) the design model's reprojection error is
    ARCHITECTURE.md's image displacement: where the exact lobe images the made ray's
    direction, minus the pixel. optics.radial computes that with its own fixed-point tracer
    and the focal-property map; both count every pixel of the best program's mirror."""
    from lathe_mirror.config import load
    from lathe_mirror.enums import Surface
    from lathe_mirror.optics.radial import radial_figures
    from lathe_mirror.job import named_surface

    made = named_surface(Surface.BEST, paper_mirror, load(), nose_radius=0.2)  # as machined
    disp = radial_figures(made, paper_mirror)["lobes"]
    for k in (0, 1):
        fig = made_lobe_figures(made, paper_mirror, k, range_mm=math.inf)
        # the same pixels lost in both: those whose made ray leaves the lobe's range
        assert fig["pixels"] == disp[k]["pixels"]
        assert fig["pixels_excluded"] == disp[k]["pixels_excluded"] == disp[k]["pixels_left_range"]
        for stat in ("rms", "max"):
            assert fig["design"]["reprojection_error_px"][stat] == pytest.approx(
                disp[k]["image_displacement_px"][stat], rel=1e-9)


def test_exact_mirror_is_its_own_calibration_at_any_range(paper_mirror):
    exact = ExactProfile(paper_mirror)
    for k in (0, 1):
        for rng in (500.0, 2000.0, math.inf):
            fig = made_lobe_figures(exact, paper_mirror, k, range_mm=rng)
            assert fig["design"]["reprojection_error_px"]["max"] < 1e-9
            assert fig["pixels_excluded"] == 0


def test_tilted_camera_design_error_is_the_rotation_homography(paper_mirror):
    """A camera tilted by t about its pinhole (still at the focus) keeps the mirror central:
    the world direction its pixel p sees is the aligned camera's at H(p), the homography of
    the rotation, u' = F (u cos t + F sin t) / (F cos t - u sin t), v' = F v / (F cos t -
    u sin t) (F = f / t_pixel, pixels from the centre). So the design model errs by
    |H(p) - p| exactly, about F tan(t) = 3.103 px at 0.1 deg; the refit, with the principal
    point fitted for a misaligned camera, moves the centre by about that much the other way."""
    tilt = math.radians(0.1)
    big_f = 16.0 / 0.009
    shift = big_f * math.tan(tilt)
    pose = CameraPose(tilt=(0.0, tilt))
    exact = ExactProfile(paper_mirror)
    for k in (0, 1):
        corr = trace_correspondences(exact, paper_mirror, k, pose=pose)
        u, v = corr.pixels[:, 0] - 503.5, corr.pixels[:, 1] - 508.5
        den = big_f * math.cos(tilt) - u * math.sin(tilt)
        err = np.hypot(big_f * (u * math.cos(tilt) + big_f * math.sin(tilt)) / den - u, big_f * v / den - v)
        fig = made_lobe_figures(exact, paper_mirror, k, pose=pose)
        d = fig["design"]["reprojection_error_px"]
        assert d["rms"] == pytest.approx(math.sqrt(np.mean(err**2)), rel=1e-9)
        assert d["max"] == pytest.approx(err.max(), rel=1e-9)
        assert fig["refit"]["principal_point"] == "fitted"
        assert 503.5 - 1.1 * shift < fig["refit"]["cx_px"] < 503.5 - shift
        assert fig["refit"]["cy_px"] == pytest.approx(508.5, abs=1e-3)
        assert fig["refit"]["reprojection_error_px"]["rms"] < 0.1 * d["rms"]


def test_refit_model_through_opencv_gives_the_reported_residual(tmp_path, paper_mirror):
    """The refitted model (k1, k2 != 0) written as OpenCV YAML and projected by cv2.omnidir
    reproduces the residual the library reports: its distortion is OpenCV's."""
    from lathe_mirror.config import load
    from lathe_mirror.enums import Surface
    from lathe_mirror.job import named_surface

    made = named_surface(Surface.POLISHED, paper_mirror, load())
    corr = trace_correspondences(made, paper_mirror, 1)
    fitted = refit(design_model(paper_mirror, 1), corr)
    assert abs(fitted.k1) > 1e-3
    path = tmp_path / "refit.yaml"
    path.write_text(opencv_yaml(fitted))
    cal = load_opencv(path)
    got, _ = cv2.omnidir.projectPoints(corr.points.reshape(1, -1, 3), np.zeros(3), np.zeros(3), cal["K"],
                                       float(cal["xi"][0, 0]), cal["D"])
    err = np.linalg.norm(got.reshape(-1, 2) - corr.pixels, axis=-1)
    rms = math.sqrt(np.sum(corr.weight * err**2) / corr.weight.sum())
    fig = made_lobe_figures(made, paper_mirror, 1)
    # The file holds K to 1e-6 px and D, xi to 1e-12 (export.numbers): a pixel moves by
    # ~1e-6 px at most, so the residuals agree to a few 1e-6 px.
    assert fig["refit"]["reprojection_error_px"]["rms"] == pytest.approx(rms, rel=1e-9, abs=3e-6)
    assert fig["refit"]["reprojection_error_px"]["max"] == pytest.approx(err.max(), rel=1e-9, abs=3e-6)
    # Refitting takes up the polished form's low orders: much less than the design model leaves.
    assert rms < 0.2 * fig["design"]["reprojection_error_px"]["rms"]


# --------------------------------------------------------------------------------------
# Files and the command


def test_committed_calib_files_are_current(paper_mirror):
    """calib/ holds what `lathe-mirror run` writes there: the design's files with the used
    zones of the paper default (the fillet ring masked)."""
    from lathe_mirror.config import load
    from lathe_mirror.optics.zones import zones_for

    for name, text in calibration_texts(paper_mirror, zones_for(load(), paper_mirror)).items():
        path = REPO / "calib" / name
        assert path.exists(), f"calib/{name} missing: run lathe-mirror run (or calib)"
        # Numbers to 1e-6 relative (+1e-12): the files write them at 1e-6 px, 1e-9 mm,
        # 1e-12 for ratios and each polynomial term to 1e-8 px; never bytes.
        why = numbers_differ(text, path.read_text(), rel=1e-6, abs_=1e-12)
        assert why is None, f"calib/{name} is stale ({why}): run lathe-mirror run (or calib)"


def test_design_model_matches_table_1(paper_mirror):
    # Table 1: a, b, e = 48.358, 26.866, 55.320 mm (01) and 46.661, 40.399, 61.720 mm (02).
    for k, (a, b, e) in enumerate(((48.358, 26.866, 55.320), (46.661, 40.399, 61.720))):
        m = design_model(paper_mirror, k)
        assert m.xi == pytest.approx(2 * a * e / (a * a + e * e), abs=2e-5)
        assert m.fu == pytest.approx(16 / 0.009 * b * b / (a * a + e * e), rel=2e-4)


def test_calib_command_json_and_files(tmp_path):
    out = tmp_path / "calib"
    proc = run_cli("calib", "-o", str(out), "--json", "--no-progress")
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert proc.stderr == ""
    data = json.loads(proc.stdout)
    assert sorted(p.name for p in out.iterdir()) == sorted(FILE_NAMES)
    # By default the made mirror every command describes: the configured job's part.
    assert [m["surface"] for m in data["made"]] == ["made"]
    assert data["made"][0]["made_mirror"] == "arcs program (best), nose 0.2 mm, lattice 0.005 mm, as machined"
    for m in data["made"]:
        assert m["range_m"] == 2.0
        assert [lb["name"] for lb in m["lobes"]] == ["inner", "outer"]
        for lb in m["lobes"]:
            d, r = lb["design"]["reprojection_error_px"], lb["refit"]["reprojection_error_px"]
            assert 0 < d["rms"] <= d["max"] and 0 < r["rms"] <= r["max"]
            assert r["rms"] <= d["rms"] * (1 + 1e-9)  # least squares from the design model
            assert lb["refit"]["principal_point"] == "fixed at the sensor centre"
    # Same inputs, same bytes (the files are the design's, whichever made mirror).
    again = tmp_path / "again"
    proc = run_cli("calib", "-o", str(again), "--surface", "paper", "--json", "--no-progress")
    assert proc.returncode == 0
    # The paper program's facets: the design's error is the README's image displacement
    # order (10.9 / 21.7 px RMS programmed; as machined here).
    paper = json.loads(proc.stdout)["made"][0]["lobes"]
    assert 5 < paper[0]["design"]["reprojection_error_px"]["rms"] < 20
    for name in FILE_NAMES:
        assert (again / name).read_bytes() == (out / name).read_bytes()


@pytest.mark.parametrize("args, text", [
    (["--surface", "nope"], "--surface 'nope': allowed exact"),
    (["--range-m", "0"], "--range-m"),
    (["--nose-radius", "-1"], "--nose-radius"),
])
def test_calib_bad_input_one_line_exit_2(tmp_path, args, text):
    out = tmp_path / "out"
    proc = run_cli("calib", "-o", str(out), *args)
    assert proc.returncode == 2
    assert text in proc.stderr and proc.stderr.count("\n") == 1 and "Traceback" not in proc.stderr
    assert not out.exists()


def test_calib_surface_no_pixel_sees_exit_2(tmp_path):
    cfg = tmp_path / "off.toml"
    cfg.write_text("[camera_pose]\ndecentre = [100.0, 0.0]\n")
    out = tmp_path / "out"
    proc = run_cli("calib", "--config", str(cfg), "--surface", "best", "-o", str(out), "--no-progress")
    assert proc.returncode == 2
    assert "--surface best: no camera pixel sees its inner lobe" in proc.stderr
    assert proc.stderr.count("\n") == 1
    assert not out.exists()


def test_calib_unwritable_output_exit_2(tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("not a directory\n")
    proc = run_cli("calib", "--surface", "exact", "-o", str(blocker / "calib"), "--no-progress")
    assert proc.returncode == 2
    assert "-o/--output" in proc.stderr and proc.stderr.count("\n") == 1
    assert blocker.read_text() == "not a directory\n"


def test_calibration_how_to_runs_as_written(tmp_path, paper_mirror):
    """The docs' calibration how-to (the command, then the Python that loads its file)
    runs as written, and its pixel is the exact tracer's for that point."""
    import re
    import subprocess
    import sys

    text = (REPO / "docs" / "how-to" / "calibration.md").read_text(encoding="utf-8")
    command = re.search(r"```sh\nlathe-mirror (calib .*?) >", text).group(1).split()
    assert run_cli(*command, cwd=tmp_path).returncode == 0
    code = re.search(r"python - <<'PY'\n(.*?)\nPY\n", text, re.S).group(1)
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=tmp_path, timeout=120)
    assert p.returncode == 0, p.stderr
    got = np.array([float(x) for x in p.stdout.split("\n")[0].split(":")[1].split()])
    f1 = paper_mirror.outer.focus_z
    expected = tracer_pixels(paper_mirror, 1, np.array([[1000.0, 500.0, f1 - 200.0]]))[0]
    assert np.abs(got - expected).max() < 1e-6


def test_a_refit_stops_when_it_stalls_not_while_it_gains():
    """The refit's stopping rule (camera_model.Stalled) by hand: a cost falling 1e-5 a step
    (the 6 mm lens's recessed outer lobe crawls at about that: 0.2 % over 150 evaluations)
    has fallen 1 - (1 - 1e-5)^10 ~ 1e-4 <= 1e-3 over 10 steps, so it stops at the 11th; a
    cost halving each step (a fit converging) never stops."""
    from types import SimpleNamespace

    from lathe_mirror.optics.camera_model import STALL_FRACTION, STALL_ITERATIONS, Stalled

    assert (STALL_FRACTION, STALL_ITERATIONS) == (1e-3, 10)
    crawl, calls = Stalled(), 0
    with pytest.raises(StopIteration):
        for k in range(200):
            calls += 1
            crawl(SimpleNamespace(cost=1e8 * (1 - 1e-5) ** k))
    assert calls == 11
    gaining = Stalled()
    for k in range(200):
        gaining(SimpleNamespace(cost=1e8 * 0.5 ** k))


#: A 12-megapixel camera (issue 34: f 4.4 mm, 1.55 um pixels, 4000 x 3000) with the
#: paper's lobes scaled to its short side: 117,401 and 252,031 distinct pixel radii.
TWELVE_MP = {"camera": {"f": 4.4, "t_pixel": 0.00155, "sensor_px": [4000, 3000]},
             "lobes": {"inner": {"r_pixel": 915.3}, "outer": {"r_pixel": 1500.0}}}


def test_a_large_sensor_is_sampled_densely_enough_for_the_figures():
    """A 12-megapixel lobe is traced at RADII_PER_LOBE radius bins, not at every distinct
    radius: halving or doubling that density moves its reprojection errors (printed to 4
    digits) and the pixels they stand for by under 0.1 %."""
    from lathe_mirror.enums import Surface
    from lathe_mirror.job import named_surface
    from lathe_mirror.optics.radial import RADII_PER_LOBE, sensor_radii
    from lathe_mirror.config import default_config, merge
    from lathe_mirror.settings import from_config

    settings = from_config(merge(default_config(), TWELVE_MP))
    mirror = settings.mirror()
    made = named_surface(Surface.UNIFORM528, mirror, settings)  # facets 1.4 px wide in the image
    rho, cnt = sensor_radii((4000, 3000))
    assert rho.size > 4 * RADII_PER_LOBE and cnt.sum() == 12_000_000
    for k in (0, 1):
        figs = {n: made_lobe_figures(made, mirror, k, max_radii=n)
                for n in (RADII_PER_LOBE // 2, RADII_PER_LOBE, 2 * RADII_PER_LOBE)}
        stated = figs[RADII_PER_LOBE]
        for n, f in figs.items():
            assert abs(f["pixels"] - stated["pixels"]) <= 1e-3 * stated["pixels"]
            for model in ("design", "refit"):
                for what in ("rms", "max"):
                    got, want = f[model]["reprojection_error_px"][what], stated[model]["reprojection_error_px"][what]
                    assert abs(got - want) <= 1e-3 * want, (k, n, model, what, got, want)
