"""`tolerance --surface measured:FILE`: the tolerance analysis of a part that exists.

The traces are built from the hyperbola in closed form (test_measure's design_machine_z,
smooth_residual: each lobe z = e + a sqrt(1 + r^2 / b^2), with a known decentre, tilt,
piston and noise), not from the tool's made-surface code. What the test knows without
the tool:

- the exact design images every pixel where the design's model says (no displacement), so a
  trace of the exact design must show ~0 px nominal image displacement and pass; under the
  same seed its Monte Carlo draws the same camera poses as the exact design's
  (ExactProfile, the closed form) and must give the same figures;
- to first order the image displacement of the aligned camera is linear in the surface's
  error: a residual twice as large gives twice the raw RMS image displacement; and it is
  the hand's first-order figure (hand_displacement): a slope error ds turns the normal by
  ds / (1 + z'^2) and the reflected ray by twice that, which the design's own mapping (the
  pinhole at one focus: image radius f r / z / pixel; the elevation seen from the other
  focus) puts at 2 ds / (1 + z'^2) / (d elevation / d image radius) pixels, its RMS over
  the zone's pixels (weight: image radius x d image radius);
- a part that exists has nothing of the machining left to draw: every trial's nose, tool
  setting, polishing time and lattice phase are the nominal ones, only the camera and the
  seat vary.
On the paper default and a design whose outer lobe is recessed.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from conftest import run_cli
from test_measure import DECENTRE_MM, PISTON_MM, TILT_RAD, design_machine_z, smooth_residual

TRIALS = 60


@pytest.fixture(scope="module")
def case(design_case):
    return design_case


def write_trace(path, mirror, amplitude, *, seed=1):
    """A stylus trace (CSV, mm) of the design plus `amplitude` x the smooth residual,
    decentred, tilted, lifted, with 0.05 um of noise, every 5 um."""
    u = np.linspace(-mirror.r_max, mirror.r_max, 400001)
    r = np.abs(u)
    w = design_machine_z(mirror, r) + amplitude * smooth_residual(mirror, r)
    X = DECENTRE_MM + u * math.cos(TILT_RAD) - w * math.sin(TILT_RAD)
    Z = PISTON_MM + u * math.sin(TILT_RAD) + w * math.cos(TILT_RAD)
    x = np.arange(X.min() + 0.01, X.max() - 0.01, 0.005)
    z = np.interp(x, X, Z) + np.random.default_rng(seed).normal(0.0, 5e-5, x.size)
    np.savetxt(path, np.c_[x, z], delimiter=",", header="x_mm,z_mm", comments="", fmt="%.7f")
    return path


def nominal_raw(mirror, settings, profile):
    """The aligned camera's raw RMS image displacement per lobe (px) on `profile` over the
    measured context's pixels (the Monte Carlo's tracer)."""
    from lathe_mirror.tolerance.measured import measured_context
    from lathe_mirror.tolerance.montecarlo import evaluate_trials
    from lathe_mirror.tolerance.perturb import Trials

    ctx = measured_context(mirror, settings, profile, "t")
    fig = evaluate_trials(ctx, Trials.nominal(1, ctx.nominal_nose_mm, 0.0))
    return fig.raw["image_displacement_px_rms"][0]


def hand_displacement(mirror, settings, amplitude):
    """The raw RMS image displacement per lobe (px) of `amplitude` x the smooth residual,
    to first order (module doc), over the zone's radii."""
    from lathe_mirror.optics.zones import zones_for

    cam = mirror.camera
    zn = zones_for(settings, mirror).as_dict()["lobes"]
    out = []
    for k, lobe in enumerate(mirror.lobes):
        a, b, e = lobe.a, lobe.b, lobe.e
        assert abs(e - math.hypot(a, b)) < 1e-9  # the pinhole at the hyperbola's lower focus
        r = np.linspace(max(zn[k]["used_mm"]["min"], 1e-3), zn[k]["used_mm"]["max"], 20001)
        z = e + a * np.sqrt(1 + r ** 2 / b ** 2)
        slope = a * r / (b ** 2 * np.sqrt(1 + r ** 2 / b ** 2))
        rho = cam.f * r / z / cam.t_pixel
        elevation = np.arctan2(z - 2 * e, r)  # from the upper focus, (0, e + c) = (0, 2 e)
        ds = amplitude * np.gradient(smooth_residual(mirror, r), r)
        px = 2 * ds / (1 + slope ** 2) / (np.gradient(elevation, r) / np.gradient(rho, r))
        w = rho * np.gradient(rho, r)
        out.append(float(np.sqrt(np.sum(w * px ** 2) / np.sum(w))))
    return np.array(out)


def test_exact_trace_images_as_the_design_and_draws_only_the_assembly(case):
    """A trace of the exact design: ~0 px nominal displacement (raw), and its Monte Carlo
    is the exact design's (the closed form held fixed) trial by trial, under the same seed."""
    import dataclasses

    from lathe_mirror.measure.surface import measured_profile
    from lathe_mirror.tolerance.measured import measured_context
    from lathe_mirror.profile import ExactProfile
    from lathe_mirror.tolerance.montecarlo import run_monte_carlo

    m, s = case["mirror"], case["settings"]
    s = dataclasses.replace(s, tolerance=dataclasses.replace(s.tolerance, trials=TRIALS))
    prof = measured_profile(write_trace(case["dir"] / "exact.csv", m, 0.0), m, nose_radius_mm=s.tool.nose_radius)
    assert np.all(nominal_raw(m, s, prof) < 0.05)
    got = run_monte_carlo(measured_context(m, s, prof, "measured"))
    want = run_monte_carlo(measured_context(m, s, ExactProfile(m), "exact"))
    t = got.trials
    # nothing of the machining drawn: the nominal nose, no tool setting, no polishing time
    assert np.all(t.nose_mm == s.tool.nose_radius) and not np.any(t.tool_x_mm) and not np.any(t.tool_z_mm)
    assert not np.any(t.time_s) and not np.any(t.phase) and not np.any(t.machine_x_mm)
    assert np.std(t.cam_x_mm) > 0 and np.std(t.seat_x) > 0  # the assembly is
    assert np.array_equal(t.cam_x_mm, want.trials.cam_x_mm)
    for key in ("image_displacement_px_rms", "disparity_px_p90"):
        a, b = got.figures.calibrated[key], want.figures.calibrated[key]
        assert np.max(np.abs(a - b)) < 0.05, key
    assert np.array_equal(got.pass_all, want.pass_all)


def test_displacement_is_linear_in_the_residual(case):
    """The measured part's raw RMS image displacement: the hand's first-order figure within
    8 %; twice the residual, twice the figure; within 15 % of the closed-form part's
    through the same tracer (test_measure._ClosedForm)."""
    from test_measure import _ClosedForm

    from lathe_mirror.measure.surface import measured_profile

    m, s, d = case["mirror"], case["settings"], case["dir"]
    one = nominal_raw(m, s, measured_profile(write_trace(d / "a1.csv", m, 1.0), m, nose_radius_mm=0.2))
    two = nominal_raw(m, s, measured_profile(write_trace(d / "a2.csv", m, 2.0, seed=2), m, nose_radius_mm=0.2))
    closed = nominal_raw(m, s, _ClosedForm(m))
    assert np.all(one > 0.05)
    assert np.allclose(one, hand_displacement(m, s, 1.0), rtol=0.08), (one, hand_displacement(m, s, 1.0))
    assert np.allclose(two / one, 2.0, rtol=0.1), (one, two)
    assert np.allclose(one, closed, rtol=0.15), (one, closed)


def test_cli_names_the_measured_part(case, tmp_path):
    m = case["mirror"]
    trace = write_trace(tmp_path / "part.csv", m, 1.0)
    cfg = ["--config", str(case["cfg"])] if case["cfg"] else []
    args = ["tolerance", "--surface", f"measured:{trace}", "--trials", str(TRIALS), "--no-progress", *cfg]
    p = run_cli(*args, "--json", "-o", str(tmp_path / "out"))
    assert p.returncode == 0, p.stderr
    out = json.loads(p.stdout)
    label = f"the measured part: {trace}"
    assert out["measured_part"]["made_mirror"] == label and out["judged"] == label
    assert list(out["programs"]) == ["measured"]
    t = out["programs"]["measured"]
    assert t["made_mirror"]["label"] == label
    mc = t["monte_carlo"]
    assert mc["program"] == "measured"
    for key in ("nose_radius_mm", "polish_time_s", "tool_x_mm", "tool_z_mm"):
        assert mc["tolerances"][key] == 0.0
    assert set(mc["per_trial"]["nose_mm"]) == {case["settings"].tool.nose_radius}
    assert {r["parameter"] for r in t["sensitivity"]["rows"]} <= {
        "camera_decentre_mm", "camera_axial_mm", "camera_tilt_deg", "seat_tilt_deg"}
    # judged over the zones every command uses
    from lathe_mirror.optics.zones import zones_for

    want = zones_for(case["settings"], m).as_dict()
    for got_lobe, want_lobe in zip(mc["zones"]["lobes"], want["lobes"]):
        for key in ("used_mm", "seen_mm"):
            assert got_lobe[key] == pytest.approx(want_lobe[key], abs=1e-6)
    # the verdict: the aligned part's figures against the limits
    v = t["verdict"]["checks"]["image_displacement_px"]
    assert v["nominal"] == max(t["sensitivity"]["nominal"]["calibrated"]["image_displacement_px_rms"])
    assert v["pass"] == (v["nominal"] <= v["limit"])
    assert (tmp_path / "out" / "tolerance.json").is_file()
    assert (tmp_path / "out" / "monte_carlo_measured.png").read_bytes()[:4] == b"\x89PNG"
    p = run_cli(*args)
    assert p.returncode == 0, p.stderr
    assert f"judged: {label}" in p.stdout and f"{label}: nominal" in p.stdout


@pytest.mark.parametrize("content,phrase", [("x_mm,z_mm\n1,2\n3,abc\n", "not two numbers"),
                                            ("x_mm,z_mm\n1,2\n3,4\n", "at least 50")])
def test_bad_file_one_line(tmp_path, content, phrase):
    (tmp_path / "bad.csv").write_text(content)
    p = run_cli("tolerance", "--surface", f"measured:{tmp_path / 'bad.csv'}", "-o", str(tmp_path / "out"))
    assert p.returncode == 2
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1 and phrase in lines[0] and "Traceback" not in p.stderr
    assert not (tmp_path / "out").exists()
    p = run_cli("tolerance", "--surface", "best")
    assert p.returncode == 2 and "tolerance takes measured:FILE" in p.stderr
