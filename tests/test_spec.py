"""`lathe-mirror spec`: each lobe as an ISO 10110-12 conic, checked against the hyperbola's
closed forms (R = b^2/a, k = -(1 + b^2/a^2), sag a (sqrt(1 + r^2/b^2) - 1)), the paper
figures of issue 21, an independent ray trace written here from the ISO sag formula alone,
and the drawing rendered by poppler's pdftoppm. On the paper default and on a design whose
outer lobe is recessed (conftest.RECESSED_OUTER)."""

from __future__ import annotations

import json
import subprocess
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from conftest import RECESSED_OUTER, require_program, run_cli
from lathe_mirror.config import load
from lathe_mirror.optics.trace import Fate, trace_pixels
from lathe_mirror.profile import ExactProfile


@pytest.fixture(scope="module", params=["paper", "recessed_outer"])
def case(request, tmp_path_factory):
    """(config path or None, settings, spec JSON from the command line)."""
    cfg = None
    if request.param == "recessed_outer":
        cfg = tmp_path_factory.mktemp("cfg") / "recessed.toml"
        cfg.write_text(RECESSED_OUTER)
    args = ["spec", "--json"] + (["--config", str(cfg)] if cfg else [])
    proc = run_cli(*args)
    assert proc.returncode == 0, proc.stderr
    return request.param, cfg, load(cfg), json.loads(proc.stdout)


def test_conic_constants_and_sag_table(case):
    name, _, settings, spec = case
    mirror = settings.mirror()
    assert (mirror.recessed == "outer") == (name == "recessed_outer")
    assert [lb["name"] for lb in spec["lobes"]] == ["inner", "outer"]
    for lobe, lb in zip(mirror.lobes, spec["lobes"]):
        a, b = lobe.a, lobe.b
        assert lb["R_mm"] == pytest.approx(b * b / a, abs=1e-9)
        assert lb["k"] == pytest.approx(-(1 + b * b / (a * a)), abs=1e-9)
        assert lb["k"] < -1  # a hyperbola
        assert lb["focal_distance_2e_mm"] == pytest.approx(2 * lobe.e, abs=1e-9)
        table = np.array(lb["sag_table"])
        lo, hi = lb["clear_aperture_mm"]
        assert table[0, 0] == pytest.approx(lo) and table[-1, 0] == pytest.approx(hi)
        inner_r = table[1:-1, 0]
        assert np.allclose(np.diff(inner_r), 0.5) and np.allclose(inner_r / 0.5, np.round(inner_r / 0.5))
        hyperbola = a * (np.sqrt(1 + (table[:, 0] / b) ** 2) - 1)
        assert np.max(np.abs(table[:, 1] - hyperbola)) < 1e-7
        slope = np.arctan(a * table[:, 0] / (b * b * np.sqrt(1 + (table[:, 0] / b) ** 2)))
        assert np.max(np.abs(table[:, 2] - slope)) < 1e-9
        ft = lb["form_tolerance"]
        assert ft["iso10110_5"].startswith("3/") and "lambda=" in ft["iso10110_5"]
        assert 0 < ft["rms_um"] <= ft["pv_um"] and ft["slope_urad"] > 0 and ft["evaluation_length_mm"] > 0
    # the outer vertex's machine Z: the difference of the two vertex heights (camera frame)
    assert spec["lobes"][1]["vertex_z_mm"] == pytest.approx(mirror.inner.vertex_z - mirror.outer.vertex_z, abs=1e-9)
    assert "ISO 10110-12" in spec["convention"] and "Zemax" in spec["convention"]


def test_paper_figures_of_the_issue(case):
    """Issue 21's figures for the paper default (hand-calculated there from Table 1's a, b)."""
    name, _, _, spec = case
    if name != "paper":
        pytest.skip("the paper's figures")
    inner, outer = spec["lobes"]
    assert inner["R_mm"] == pytest.approx(14.925, abs=5e-4) and inner["k"] == pytest.approx(-1.3086, abs=5e-5)
    assert outer["R_mm"] == pytest.approx(34.977, abs=5e-4) and outer["k"] == pytest.approx(-1.7496, abs=5e-5)
    assert outer["vertex_z_mm"] == pytest.approx(-4.70, abs=5e-3)


def _iso_trace(lb: dict, rho_px: np.ndarray, f: float, t_pixel: float):
    """Camera rays of image radii rho_px (px, along +x) off the conic stated by the spec
    alone (R, k, the vertex's height above the pinhole), from the ISO 10110-12 sag as an
    implicit quadric: F = c (x^2 + y^2) - 2 s + (1 + k) c s^2 = 0, s = z - V the sag. The
    sheet of the sag formula is the root with s >= 0 (the other sheet has s < 0 for k < -1).
    Returns hit points (n, 3) and unit reflected directions (n, 3)."""
    c, k, v = 1.0 / lb["R_mm"], lb["k"], lb["vertex_above_pinhole_mm"]
    d = np.stack([rho_px * t_pixel / f, np.zeros_like(rho_px), np.ones_like(rho_px)], axis=-1)
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    # p = t d, s = t dz - v: c t^2 dx^2 - 2 (t dz - v) + (1 + k) c (t dz - v)^2 = 0
    qa = c * d[:, 0] ** 2 + (1 + k) * c * d[:, 2] ** 2
    qb = -2 * d[:, 2] - 2 * (1 + k) * c * v * d[:, 2]
    qc = 2 * v + (1 + k) * c * v * v
    disc = np.sqrt(qb * qb - 4 * qa * qc)
    roots = np.stack([(-qb - disc) / (2 * qa), (-qb + disc) / (2 * qa)], axis=-1)
    s = roots * d[:, 2:3] - v
    roots = np.where((roots > 0) & (s >= -1e-9), roots, np.inf)
    t = roots.min(axis=-1)
    p = t[:, None] * d
    s = p[:, 2] - v
    n = np.stack([2 * c * p[:, 0], 2 * c * p[:, 1], -2 + 2 * (1 + k) * c * s], axis=-1)
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    out = d - 2 * np.sum(d * n, axis=-1, keepdims=True) * n
    return p, out


def test_independent_trace_matches_the_tool(case):
    _, _, settings, spec = case
    mirror = settings.mirror()
    cam = mirror.camera
    for k, lb in enumerate(spec["lobes"]):
        lo, hi = lb["clear_aperture_mm"]
        r = np.linspace(lo, hi, 401)[1:-1]
        # image radii of those mirror radii, from the spec's conic alone
        c, kk, v = 1.0 / lb["R_mm"], lb["k"], lb["vertex_above_pinhole_mm"]
        z = v + c * r * r / (1 + np.sqrt(1 - (1 + kk) * c * c * r * r))
        rho = cam.f * r / (cam.t_pixel * z)
        p, out = _iso_trace(lb, rho, cam.f, cam.t_pixel)
        hits = trace_pixels(ExactProfile(mirror), cam, radii_px=rho)
        ok = hits.fate == (Fate.INNER if k == 0 else Fate.OUTER)
        assert ok.mean() > 0.95
        dp = np.linalg.norm(hits.point[ok] - p[ok], axis=-1)
        a, b = hits.direction[ok], out[ok]
        ang = np.arctan2(np.linalg.norm(np.cross(a, b), axis=-1), np.sum(a * b, axis=-1))
        print(f"{case[0]} {lb['name']}: hit {dp.max():.2e} mm, direction {ang.max():.2e} rad over {ok.sum()} rays")
        assert dp.max() < 1e-6, dp.max()
        assert ang.max() < 1e-6, ang.max()


def test_spec_drawing_renders(case, tmp_path):
    pdftoppm = require_program("pdftoppm")
    name, cfg, _, spec = case
    out = tmp_path / "spec"
    proc = run_cli("spec", "-o", str(out), *(["--config", str(cfg)] if cfg else []))
    assert proc.returncode == 0, proc.stderr
    written = json.loads((out / "mirror_spec.json").read_text())
    assert written["lobes"][0]["R_mm"] == pytest.approx(spec["lobes"][0]["R_mm"], abs=1e-12)
    root = ET.parse(out / "mirror_drawing.svg").getroot()
    assert root.tag.endswith("svg")
    text = " ".join(t.text or "" for t in root.iter() if t.tag.endswith("title") or t.tag.endswith("text"))
    svg = (out / "mirror_drawing.svg").read_text()
    assert "3/" in svg or "3/" in text
    subprocess.run([pdftoppm, "-r", "60", "-png", "-singlefile", str(out / "mirror_drawing.pdf"),
                    str(tmp_path / "page")], check=True, capture_output=True, timeout=120)
    from PIL import Image

    img = np.asarray(Image.open(tmp_path / "page.png").convert("L"), dtype=float)
    h, w = img.shape
    assert w > h and abs(w / h - 420 / 297) < 0.02  # one A3 landscape page
    ink = img < 128
    # ink in each region: the section (top left), the asphere table (top right), the sag
    # tables (bottom left), the title block (bottom right)
    for (y0, y1, x0, x1) in ((0.1, 0.6, 0.05, 0.45), (0.05, 0.45, 0.52, 0.95), (0.7, 0.95, 0.05, 0.6),
                             (0.7, 0.95, 0.68, 0.95)):
        assert ink[int(y0 * h):int(y1 * h), int(x0 * w):int(x1 * w)].mean() > 0.002
    assert ink.mean() < 0.3  # not a black page


def test_spec_bad_step_is_one_line(tmp_path):
    proc = run_cli("spec", "--json", "--step", "0")
    assert proc.returncode == 2
    assert proc.stderr.count("\n") == 1 and "--step" in proc.stderr


def test_report_section_states_the_spec(case):
    """The report's section 12 (report.spec_section) shows the command's R, k and tolerances."""
    from lathe_mirror.iso10110 import spec_of
    from lathe_mirror.report.spec_section import spec_html

    _, _, settings, spec = case
    page = spec_html(spec_of(settings))  # the typed spec; the command's JSON to check it against
    for lb in spec["lobes"]:
        assert f"{lb['R_mm']:.6f}" in page and f"{lb['k']:.8f}" in page
        assert lb["form_tolerance"]["iso10110_5"].split(";")[0] in page
    assert "focal distance 2e" in page and page.count("<details>") == 2
