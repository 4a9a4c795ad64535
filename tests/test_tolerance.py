"""Tolerance analysis: the trial tracer, the calibration, the Monte Carlo, the allocation.

Checked against closed forms (a pinhole's rotation, a lever arm, Wilson's interval and
Newcombe's published values), the issue's hand figures (the matcher's floor, the spec's
disparity), independent code (optics.trace's 3-D tracer, optics.stereo's meridian
triangulation, the pipeline's own made-surface builder and polishing), physical
equivalences, and by recounting yields by hand.
"""

from __future__ import annotations

import copy
import csv
import dataclasses
import io
import json
import math

import numpy as np
import pytest

from lathe_mirror.enums import BEST, Program, Strategy
from lathe_mirror.errors import InputError
from lathe_mirror.optics.camera import CameraPose
from lathe_mirror.optics.distortion import exact_image_point
from lathe_mirror.optics.trace import Fate, trace_pixels
from lathe_mirror.job import made_surface
from lathe_mirror.tolerance.runs import tolerance_context
from lathe_mirror.polishing import polish
from lathe_mirror.profile import ExactProfile
from lathe_mirror.settings import from_config
from lathe_mirror.tolerance.allocation import allocate, inverse_sensitivity
from lathe_mirror.tolerance.montecarlo import (
    CRITERIA,
    disparity_limit_px,
    draw_trials,
    evaluate_trials,
    judge,
    run_monte_carlo,
)
from lathe_mirror.export.trials import trials_csv
from lathe_mirror.export.numbers import column_exponent
from lathe_mirror.tolerance.perturb import Trials, evaluate, poses
from lathe_mirror.tolerance.samples import matching_floor_pct, pixel_sample
from lathe_mirror.tolerance.sensitivity import responses, sensitivity_table
from lathe_mirror.tolerance.stats import wilson, yield_to_show
from lathe_mirror.tolerance.surfaces import SurfaceBank

from conftest import UNCUTTABLE, UNCUTTABLE_PHRASE, run_cli

DEG = math.pi / 180.0


@pytest.fixture(scope="module")
def small_cfg(paper_config):
    cfg = copy.deepcopy(paper_config)
    cfg["tolerance"]["lattice_phases"] = 2
    cfg["tolerance"]["trials"] = 150
    cfg["tolerance"]["nose_step_mm"] = 0.005  # 9 noses over +/- 0.02 mm: fewer parts to cut
    return cfg


@pytest.fixture(scope="module")
def ctx(small_cfg, paper_mirror):
    """The best program's part polished 5 min (its polishing curve's optimum)."""
    return tolerance_context(paper_mirror, from_config(small_cfg), Program.BEST, 300.0)


@pytest.fixture(scope="module")
def exact(paper_mirror):
    """Trials cut as the exact design (the misalignment's figures alone), and the sample."""
    bank = SurfaceBank.fixed(paper_mirror, ExactProfile(paper_mirror), 0.005)
    samples = tuple(pixel_sample(paper_mirror, k, bin_px=4.0, azimuths=12) for k in (0, 1))
    return bank, samples


# --------------------------------------------------------------------------------------
# Statistics


def test_wilson_interval_against_published_and_hand_values():
    # Newcombe (1998), Stat. Med. 17:857, Table I: 81 of 263, Wilson score 0.2553 .. 0.3662.
    lo, hi = wilson(81, 263)
    assert (round(lo, 4), round(hi, 4)) == (0.2553, 0.3662)
    # 0 of 10: [0, z^2 / (n + z^2)] = [0, 3.8415 / 13.8415].
    assert wilson(0, 10) == pytest.approx((0.0, 3.841459 / 13.841459), abs=1e-6)
    # 950 of 1000 by hand: centre (0.95 + 1.9207295e-3) / 1.003841459 = 0.9482780, half-width
    # 1.959964 sqrt(4.75e-5 + 9.603648e-7) / 1.003841459 = 0.0135918.
    assert wilson(950, 1000) == pytest.approx((0.934686, 0.961870), abs=2e-6)
    # What a 1000-trial run must show for its interval to clear 95 %: 963 gives a lower bound
    # of 0.94942 (centre 0.961227 - 0.011811), 964 gives 0.95056 (0.962223 - 0.011660).
    assert yield_to_show(0.95, 1000) == 0.964


# --------------------------------------------------------------------------------------
# Poses and the calibration


def test_camera_tilt_moves_the_image_as_a_pinhole_rotation(paper_mirror, exact):
    """A camera tilted 0.1 deg about its pinhole on the exact mirror: each pixel's raw
    displacement is the pinhole's own rotation, q = (f / t) (R c)_xy / (R c)_z for the
    pixel's ray c (the exact mirror images the reflected ray at the point the rotated ray
    hit), and at the image centre f tan(0.1 deg) / t_pixel = 16 x 1.745e-3 / 0.009 = 3.10 px."""
    bank, samples = exact
    cam = paper_mirror.camera
    tr = Trials.nominal(1, 0.2, 0.0)
    tr.tilt_x[:] = 0.1 * DEG
    fig = evaluate(paper_mirror, bank, tr, samples, keep_displacements=True, calibrate=False)
    rot = poses(tr, 125.0)[1][0]
    for k in (0, 1):
        _, _, disp, ok = fig.extra["displacements"][k]
        u, v = samples[k].u, samples[k].v
        c = np.stack([u * cam.t_pixel, v * cam.t_pixel, np.full_like(u, cam.f)], -1) @ rot.T
        q = cam.f / cam.t_pixel * c[:, :2] / c[:, 2:3]
        expected = np.hypot(q[:, 0] - u, q[:, 1] - v)
        assert ok[0].mean() > 0.95
        assert np.max(np.abs(disp[0][ok[0]] - expected[ok[0]])) < 2e-3
    centre = 16.0 * math.tan(0.1 * DEG) / 0.009
    assert centre == pytest.approx(3.1029, abs=1e-4)
    _, _, disp, ok = fig.extra["displacements"][0]
    nearest = int(np.argmin(np.hypot(samples[0].u, samples[0].v)))
    assert disp[0][nearest] == pytest.approx(centre, rel=2e-3)  # 2 px off centre: +2e-3 relative


def test_a_pure_camera_rotation_scores_zero_once_calibrated(paper_mirror, exact):
    """Rotations of the camera about its pinhole are what a calibration removes: the fitted
    rotation is the drawn one and every calibrated figure is zero, while the raw figures
    carry the tilt (3.1 px, and tens of % of depth error at 1 m)."""
    bank, samples = exact
    tr = Trials.nominal(3, 0.2, 0.0)
    tr.tilt_x[1] = 0.1 * DEG
    tr.tilt_x[2], tr.tilt_y[2] = 0.07 * DEG, -0.05 * DEG
    fig = evaluate(paper_mirror, bank, tr, samples, ranges_m=(1.0, 3.0), depth_points=9)
    ang = fig.calibration.angles_deg()
    assert ang[1] == pytest.approx([0.1, 0.0, 0.0], abs=1e-7)
    # R_y(ty) R_x(tx) read back as (about x, about y, about z) of R_z R_y R_x.
    assert ang[2] == pytest.approx([0.07, -0.05, 0.0], abs=1e-7)
    cal, raw = fig.calibrated, fig.raw
    assert np.max(cal["image_displacement_px_rms"]) < 1e-6
    assert np.max(cal["ray_error_deg_rms"]) < 1e-6  # the 5 um grid's linear slope: 1.2e-7 deg untilted
    assert np.max(cal["disparity_px_p90"]) < 1e-5 and np.max(cal["depth_error_pct_rms"]) < 1e-3
    assert np.all(cal["within_5_pct"] == 1.0)
    assert np.min(raw["image_displacement_px_rms"][1:]) > 2.5
    assert raw["depth_error_pct_rms"][1, 0] > 20.0
    # A rotation about the pinhole (the outer focus) keeps every ray through F1.
    assert np.max(fig.raw["viewpoint_spread_mm_rms"]) < 1e-6


def test_seat_tilt_is_a_rotation_plus_its_lever_arm_of_decentre(paper_mirror, exact):
    """The mirror tilted 0.1 deg about the seat pivot 125 mm above the pinhole is, in the
    mirror's frame, the camera turned -0.1 deg and moved sideways 125 sin(0.1 deg) =
    0.2182 mm (and 125 (1 - cos) = 1.9e-4 mm along the axis). Once the calibration has
    removed the rotation, what is left is that decentre's: the calibrated figures equal a
    plain 0.2182 mm decentre's, while the raw ones differ (the rotation undoes part of
    the decentre's image shift)."""
    bank, samples = exact
    tr = Trials.nominal(2, 0.2, 0.0)
    tr.seat_x[0] = 0.1 * DEG
    origin, rot = poses(tr, 125.0)
    lever = 125.0 * math.sin(0.1 * DEG)
    assert lever == pytest.approx(0.21817, abs=1e-5)
    assert origin[0] == pytest.approx([0.0, -lever, 125.0 * (1 - math.cos(0.1 * DEG))], abs=1e-12)
    c, s = math.cos(0.1 * DEG), math.sin(0.1 * DEG)
    assert rot[0] == pytest.approx(np.array([[1, 0, 0], [0, c, s], [0, -s, c]]), abs=1e-15)  # R_x(-0.1 deg)
    tr.cam_y_mm[1], tr.cam_z_mm[1] = origin[0, 1], origin[0, 2]
    fig = evaluate(paper_mirror, bank, tr, samples, ranges_m=(1.0,), depth_points=17)
    cal, raw = fig.calibrated, fig.raw
    for key in ("image_displacement_px_rms", "viewpoint_spread_mm_rms"):
        assert cal[key][0] == pytest.approx(cal[key][1], rel=0.05), key
    assert cal["depth_error_pct_rms"][0, 0] == pytest.approx(cal["depth_error_pct_rms"][1, 0], rel=0.05)
    assert raw["image_displacement_px_rms"][1, 1] > 2 * raw["image_displacement_px_rms"][0, 1]
    # What calibration cannot remove: the decentre breaks the single viewpoint.
    assert cal["depth_error_pct_rms"][0, 0] > 5.0


def test_calibration_residual_matches_the_unified_model_refit(paper_mirror, paper_config):
    """What the calibration leaves on an aligned made mirror against the calibration
    issue's own fit (optics.camera_model: the unified model of each lobe, xi, gamma, k1,
    k2, refitted to the exact tracer's pixel <-> direction pairs by scipy least squares):
    the paper program polished 60 min by the first polishing model, residual RMS per lobe
    ~1.2 / 0.083 px, to 3 % (1 % with the first model's Savitzky-Golay pad; the ringing-free
    pad leaves the outer lobe's residual 7 % smaller, where the two fits differ by 2 %); and
    the paper program as cut (10 / 19 px) to 5 %, where the two models' forms differ more."""
    from lathe_mirror.optics.camera_model import made_lobe_figures

    s = from_config(paper_config)
    cut = made_surface(paper_mirror, s.machine, s.tool, Strategy.PAPER).profile
    samples = tuple(pixel_sample(paper_mirror, k, bin_px=1.0, azimuths=4) for k in (0, 1))
    # Polished 60 min by the first polishing model (a lap held still: polishing.FIRST_MODEL).
    from lathe_mirror.polishing import FIRST_MODEL

    first = dataclasses.replace(s.polish, **FIRST_MODEL)
    for profile, rel in ((polish(cut, first, 3600.0), 0.03), (cut, 0.05)):
        bank = SurfaceBank.fixed(paper_mirror, profile, 0.0005)
        ours = evaluate(paper_mirror, bank, Trials.nominal(1, 0.2, 0.0), samples).calibrated
        for k in (0, 1):
            theirs = made_lobe_figures(profile, paper_mirror, k, range_mm=math.inf)["refit"]
            assert ours["image_displacement_px_rms"][0, k] == pytest.approx(
                theirs["reprojection_error_px"]["rms"], rel=rel), k


def test_misaligned_camera_matches_the_optics_3d_tracer(paper_mirror, exact):
    """The trial tracer against optics.trace (march + Newton) for a decentred, tilted,
    shifted camera on the exact mirror: the displacement is the misalignment's alone."""
    bank, _ = exact
    pose = CameraPose(decentre=(0.05, -0.03), axial_offset=0.1, tilt=(math.radians(0.08), math.radians(-0.05)))
    tr = Trials.nominal(1, 0.2, 0.0)
    tr.cam_x_mm[:], tr.cam_y_mm[:], tr.cam_z_mm[:] = 0.05, -0.03, 0.1
    tr.tilt_x[:], tr.tilt_y[:] = pose.tilt
    for k in (0, 1):
        smp = pixel_sample(paper_mirror, k, bin_px=25.0, azimuths=6)
        fig = evaluate(paper_mirror, bank, tr, (smp, smp), keep_displacements=True, calibrate=False)
        _, _, disp, ok = fig.extra["displacements"][k]
        xy = np.stack([smp.u, smp.v], axis=-1)
        hits = trace_pixels(ExactProfile(paper_mirror), paper_mirror.camera, xy, pose=pose)
        good = (hits.fate == (Fate.INNER if k == 0 else Fate.OUTER)) & ~hits.blocked & ok[0]
        assert good.sum() > 0.9 * len(smp.u)
        img = exact_image_point(paper_mirror, k, hits.direction[good], paper_mirror.camera)
        theirs = np.hypot(*(img - xy[good]).T)
        assert np.max(np.abs(disp[0][good] - theirs)) < 2e-3 * max(1.0, float(theirs.max()))
        assert theirs.max() > 0.5  # the misalignment does move the image


# --------------------------------------------------------------------------------------
# Stereo figures


def test_matching_floor_and_disparity_limit_are_the_issue_figures(paper_mirror):
    """The issue's hand figures: a 0.1 px matching noise alone gives 4.5 % at 1 m, 9 % at
    2 m, 22.5 % at 5 m; the spec's 20 % at 1 m is 2.5 mrad of parallax, or 0.44 px."""
    floor = matching_floor_pct(paper_mirror, [1.0, 2.0, 5.0], 0.1, 17)
    assert floor == pytest.approx([4.5, 9.0, 22.5], rel=0.02)
    assert disparity_limit_px(paper_mirror, 20.0, 1.0, 17) == pytest.approx(0.44, rel=0.02)
    # 2.5 mrad: 20 % of the parallax B cos(el) / R with B = 12.8 mm at 1 m.
    assert 0.2 * paper_mirror.baseline * math.cos(math.radians(-12.9)) / 1000.0 == pytest.approx(2.5e-3, rel=0.01)


def test_nominal_trial_depth_error_matches_the_stereo_module(ctx, paper_mirror, small_cfg):
    """A nominal (aligned) trial's raw depth error, traced in 3-D at 4 azimuths, against
    optics.stereo's meridian triangulation of the same polished surface."""
    from lathe_mirror.optics.stereo import band_elevations, depth_error_curve

    s = from_config(small_cfg)
    fig = evaluate_trials(ctx, Trials.nominal(1, ctx.nominal_nose_mm, ctx.nominal_time_s), ranges_m=(1.0, 2.0))
    polished = polish(made_surface(paper_mirror, s.machine, s.tool, BEST).profile, s.polish, ctx.nominal_time_s)
    curve = depth_error_curve(polished, paper_mirror, [1.0, 2.0],
                              elevations=band_elevations(paper_mirror, ctx.settings.depth_points))
    for i, r in enumerate((1.0, 2.0)):
        assert fig.raw["depth_error_pct_rms"][0, i] == pytest.approx(curve.at(r)["rms"], rel=0.05)


def test_mirror_piston_equals_camera_shift(ctx):
    """Tool Z error +d moves the mirror away from the camera: optically the same as the
    camera moving -d along the axis. The image is identical; the depth error differs only
    because the world point stays put while the mirror (and its stereo centre) moves by d:
    at most 100 d / R percentage points (0.001 for d = 0.01 mm at R = 1 m)."""
    a = Trials.nominal(2, ctx.nominal_nose_mm, ctx.nominal_time_s)
    a.tool_z_mm[0] = 0.01
    a.cam_z_mm[1] = -0.01
    fig = evaluate_trials(ctx, a)
    for d in (fig.raw, fig.calibrated):
        assert d["image_displacement_px_rms"][0] == pytest.approx(d["image_displacement_px_rms"][1], rel=1e-6)
        assert d["depth_error_pct_rms"][0, 0] == pytest.approx(d["depth_error_pct_rms"][1, 0], abs=100 * 0.01 / 1000)


# --------------------------------------------------------------------------------------
# Honest trials


def test_a_trials_surface_is_its_part_cut_with_its_own_nose(ctx, paper_mirror, small_cfg):
    """The trial's surface for a nose the trial drew is the pipeline's own part cut with
    that nose and polished (made_surface + polishing.polish, an independent path), away
    from the step where the junction zone is left as cut (tolerance.surfaces); phase 0."""
    s = from_config(small_cfg)
    nose = 0.21
    tr = Trials.nominal(1, nose, ctx.nominal_time_s)
    ctx.ensure(tr)
    direct = polish(made_surface(paper_mirror, s.machine, s.tool, BEST, nose_radius=nose).profile, s.polish,
                    ctx.nominal_time_s)
    for k in (0, 1):
        z, _ = ctx.bank.trial_surface(k, tr.phase, tr.nose_mm, tr.time_s, tr.tool_z_mm)
        r = ctx.bank.grid(k)
        far = (r < paper_mirror.r_junction - 3.5) if k == 0 else (r > paper_mirror.r_junction + 6.5)
        assert np.max(np.abs(z[0][far] - direct.z(r[far]))) < 1e-5
    # and it is not the programmed nose's part: the cut moved 10 um along the normal
    z0, _ = ctx.bank.trial_surface(1, tr.phase, np.array([0.2]), tr.time_s, tr.tool_z_mm)
    assert np.median(z[0] - z0[0]) == pytest.approx(0.01 * math.sqrt(1 + 0.6**2), rel=0.3)


def test_lattice_phases_are_drawn_uniformly(ctx):
    big = draw_trials(ctx, n=20000)
    counts = np.bincount(big.phase, minlength=len(ctx.bank.phases))
    assert counts == pytest.approx(np.full(len(counts), 20000 / len(counts)), rel=0.05)
    # a normal tolerance is a 3-sigma bound
    assert np.std(big.tool_x_mm) == pytest.approx(ctx.settings.tolerances["tool_x_mm"] / 3.0, rel=0.03)
    assert np.std(big.seat_x) == pytest.approx(ctx.settings.tolerances["seat_tilt_deg"] * DEG / 3.0, rel=0.03)
    # the nose is cut as drawn, on the nose step
    step = ctx.settings.nose_step_mm
    assert np.allclose((big.nose_mm - 0.2) / step, np.rint((big.nose_mm - 0.2) / step), atol=1e-9)


# --------------------------------------------------------------------------------------
# Monte Carlo, sensitivity, allocation


def test_monte_carlo_is_reproducible_and_the_yield_recounts(ctx):
    res = run_monte_carlo(ctx)
    a = json.dumps(res.to_dict())
    assert a == json.dumps(run_monte_carlo(ctx).to_dict())
    other = draw_trials(ctx, seed=ctx.settings.seed + 1)
    assert not np.array_equal(other.tool_x_mm, draw_trials(ctx).tool_x_mm)
    f, lim = res.figures, ctx.limits
    d = f.calibrated  # the spec judges the calibrated figures by default
    n_pass = 0
    for i in range(len(res.trials)):
        n_pass += bool(max(d["image_displacement_px_rms"][i]) <= lim["image_displacement_px"]
                       and max(d["outlier_pct"][i]) <= lim["outlier_pct"]
                       and d["disparity_px_p90"][i, 0] <= lim["disparity_px"]
                       and max(f.slope_error_rad_rms[i]) <= lim["slope_error_rad"])
    out = res.to_dict()
    assert out["passed"] == n_pass and out["yield"] == n_pass / len(res.trials)
    assert out["yield_wilson95"] == list(wilson(n_pass, len(res.trials)))
    assert set(judge(f, lim, True)) == set(CRITERIA)


def test_sensitivity_table(ctx):
    table = sensitivity_table(ctx)
    rows = {r["parameter"]: r for r in table["rows"]}
    # A decentre or a tilt along -x or +x is the same by the mirror's symmetry.
    for key in ("camera_decentre_mm", "camera_tilt_deg", "seat_tilt_deg"):
        m, p = rows[key]["minus"], rows[key]["plus"]
        assert m["raw"]["image_displacement_px_rms"] == pytest.approx(p["raw"]["image_displacement_px_rms"], rel=1e-6)
    # The camera's tilt stays a row: 3.1 px raw, nothing once calibrated.
    tilt = rows["camera_tilt_deg"]["plus"]
    assert min(tilt["raw"]["image_displacement_px_rms"]) > 3.0
    nominal = table["nominal"]["calibrated"]["image_displacement_px_rms"]
    assert tilt["calibrated"]["image_displacement_px_rms"] == pytest.approx(nominal, abs=0.02)
    assert "lattice_phase" in rows and rows["tool_x_mm"]["tolerance"] == 0.005


def test_allocation_reaches_the_target_in_a_confirming_monte_carlo(small_cfg, paper_mirror):
    """With the seat held to 0.3 deg the part misses 95 %; the allocation tightens what
    matters (never the camera's own tilt, which the calibration removes), and the Monte
    Carlo with the allocated tolerances (the configured run's seed: its trials scaled)
    reaches the target."""
    cfg = copy.deepcopy(small_cfg)
    cfg["tolerance"]["params"]["seat_tilt_deg"] = 0.3
    cfg["tolerance"]["trials"] = 200
    s = from_config(cfg)
    c = tolerance_context(paper_mirror, s, Program.BEST, 300.0)
    mc = run_monte_carlo(c)
    assert mc.yield_fraction < 0.95
    resp = responses(c)
    out, confirm = allocate(c, resp, mc)
    assert out["reached"] and confirm is not None
    assert confirm.yield_fraction >= 0.95 and out["yield"] == confirm.yield_fraction
    assert confirm.seed == mc.seed and len(confirm.trials) == 200
    tight = {r["parameter"]: r for r in out["tolerances"] if r["tighten"]}
    # common random numbers: the confirming trials are the configured ones, the seat's
    # tilts scaled by the allocated factor, the camera's own tilts untouched
    f = tight["seat_tilt_deg"]["factor"]
    assert np.allclose(confirm.trials.seat_x, f * mc.trials.seat_x, rtol=1e-12, atol=0)
    assert np.array_equal(confirm.trials.tilt_x, mc.trials.tilt_x)
    assert "seat_tilt_deg" in tight and "camera_tilt_deg" not in tight
    assert confirm.tolerances["seat_tilt_deg"] == pytest.approx(tight["seat_tilt_deg"]["allocated"])
    assert out["yield_wilson95"] == list(wilson(int(confirm.pass_all.sum()), 200))
    assert "tighten seat_tilt_deg to +/-" in out["statement"] and "200 trials" in out["statement"]
    # inverse sensitivity: the seat is the tightest lever, set by the stereo figure
    inv = {r["parameter"]: r for r in inverse_sensitivity(resp, c.limits)}
    assert inv["seat_tilt_deg"]["limited_by"] == "disparity_px"
    assert inv["seat_tilt_deg"]["largest"] < 0.3


@pytest.mark.parametrize("distribution", ["normal", "uniform"])
def test_same_seed_gives_nested_samples(small_cfg, paper_mirror, distribution):
    """Tightening one tolerance by k moves each trial's value of that parameter to k times
    the old one (numpy's normal(0, t/3) and uniform(-t, t) are linear in t on the same
    standard draws) and leaves every other parameter's value as it was."""
    cfg = copy.deepcopy(small_cfg)
    cfg["tolerance"]["distribution"] = distribution
    c = tolerance_context(paper_mirror, from_config(cfg), Program.BEST, 300.0)
    tol = c.settings.tolerances
    loose = draw_trials(c, n=400)
    for key, fields, k in (("seat_tilt_deg", ("seat_x", "seat_y"), 0.4), ("tool_x_mm", ("tool_x_mm",), 0.25),
                           ("camera_axial_mm", ("cam_z_mm",), 0.0)):
        tight = draw_trials(c, n=400, tolerances={**tol, key: k * tol[key]})
        for name, col in loose.__dict__.items():
            if name in fields:
                assert np.allclose(getattr(tight, name), k * col, rtol=1e-12, atol=1e-300)
            else:
                assert np.array_equal(getattr(tight, name), col), name
    # the uniform case draws on -t .. t, the normal one with sigma t / 3
    t = tol["tool_x_mm"]
    if distribution == "uniform":
        assert np.max(np.abs(loose.tool_x_mm)) <= t and np.max(np.abs(loose.tool_x_mm)) > 0.95 * t
    else:
        assert np.std(loose.tool_x_mm) == pytest.approx(t / 3.0, rel=0.1)


def test_tightening_never_lowers_the_yield(small_cfg, paper_mirror):
    """The same seed, the seat held 0.3 deg then 0.15 deg: the tight run's trials are the
    loose run's with half their seat tilt, so the yields compare trial by trial: at most 1 %
    of the trials (a seat tilt that offset another error) pass loose and fail tight, and
    the tightened yield is higher."""
    cfg = copy.deepcopy(small_cfg)
    cfg["tolerance"]["params"]["seat_tilt_deg"] = 0.3
    c = tolerance_context(paper_mirror, from_config(cfg), Program.BEST, 300.0)
    loose = run_monte_carlo(c)
    tight = run_monte_carlo(c, tolerances={**c.settings.tolerances, "seat_tilt_deg": 0.15})
    a, b = loose.pass_all, tight.pass_all
    n = len(a)
    assert loose.yield_fraction < 0.95  # the loose seat fails trials: the test can see a change
    worse = int(np.sum(a & ~b))
    assert worse <= 0.01 * n
    assert tight.yield_fraction > loose.yield_fraction


# --------------------------------------------------------------------------------------
# Command line


def test_tolerance_cli_allocate_writes_one_csv_row_per_trial(tmp_path):
    cfg = tmp_path / "quick.toml"
    cfg.write_text('[polish]\ncurve_points = 3\n[tolerance]\ntrials = 30\nlattice_phases = 1\nnose_step_mm = 0.005\n'
                   'programs = ["best"]\n[tolerance.params]\nseat_tilt_deg = 0.4\n')
    out = tmp_path / "out"
    proc = run_cli("tolerance", "--config", str(cfg), "-o", str(out), "--allocate", "--target-yield", "0.9",
                   "--csv", str(tmp_path / "trials.csv"), "--no-progress")
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert proc.stderr == ""
    data = json.loads((out / "tolerance.json").read_text())
    best = data["programs"]["best"]
    rows = list(csv.DictReader(io.StringIO((tmp_path / "trials.csv").read_text())))
    runs = {r["run"] for r in rows}
    assert "best: monte carlo" in runs
    mc_rows = [r for r in rows if r["run"] == "best: monte carlo"]
    assert len(mc_rows) == 30
    assert [r["pass"] == "True" for r in mc_rows] == best["monte_carlo"]["per_trial"]["pass"]
    assert float(mc_rows[3]["tool_x_mm"]) == pytest.approx(best["monte_carlo"]["per_trial"]["tool_x_mm"][3],
                                                           rel=1e-6, abs=1e-12)  # the JSON's stated precision
    assert len(rows) == 30 * (1 + len(best["allocation"]["rounds"]))
    assert best["allocation"]["target_yield"] == 0.9
    assert "yield" in proc.stdout and "95 % CI" in proc.stdout
    # the chart beside the JSON: a PNG of the trials against the limits
    from PIL import Image
    with Image.open(out / "monte_carlo_best.png") as chart:
        assert chart.format == "PNG" and chart.size[0] > 600
    assert sorted(p.name for p in out.iterdir()) == ["monte_carlo_best.png", "tolerance.json"]


@pytest.mark.parametrize("args, msg", [
    (["--target-yield", "0.9"], "--target-yield applies to --allocate"),
    (["--allocate", "--target-yield", "1.5"], "argument --target-yield: 1.5: allowed 0.5 to 0.999"),
    (["--csv", "nowhere/trials.csv"], "--csv nowhere/trials.csv: directory nowhere does not exist"),
])
def test_tolerance_cli_bad_flags_exit_2_writing_nothing(tmp_path, args, msg):
    out = tmp_path / "out"
    proc = run_cli("tolerance", "-o", str(out), *args, cwd=tmp_path)
    assert proc.returncode == 2, proc.stderr
    assert msg in proc.stderr and len(proc.stderr.strip().splitlines()) == 1
    assert not out.exists()


def test_spec_errors_name_the_key(paper_config):
    for path, value, key in ((("distribution",), "gaussian", "tolerance.distribution"),
                             (("params", "tool_x_mm"), -1.0, "tolerance.params.tool_x_mm"),
                             (("cost", "seat_tilt_deg"), 0.0, "tolerance.cost.seat_tilt_deg"),
                             (("target_yield",), 1.0, "tolerance.target_yield"),
                             (("spec", "outlier_pct"), 0.0, "tolerance.spec.outlier_pct")):
        cfg = copy.deepcopy(paper_config)
        node = cfg["tolerance"]
        for p in path[:-1]:
            node = node[p]
        node[path[-1]] = value
        with pytest.raises(InputError, match=key.replace(".", r"\.")):
            from_config(cfg)


def test_tolerance_cli_bad_program_exit_2(tmp_path):
    cfg = tmp_path / "bad.toml"
    cfg.write_text('[tolerance]\nprograms = ["paper", "perfect"]\n')
    out = tmp_path / "out"
    proc = run_cli("tolerance", "--config", str(cfg), "-o", str(out))
    assert proc.returncode == 2, proc.stderr
    assert "tolerance.programs[1]" in proc.stderr and "Traceback" not in proc.stderr
    assert not out.exists()


def test_tolerance_cli_bad_tolerances_exit_2_before_writing(tmp_path):
    """Tolerances that would put a node at a zero nose or a zero controller step, and a pixel
    sample too large for memory, are refused before the output directory is made."""
    for text, key in (("[tolerance.params]\nresolution_mm = 0.005\n", "tolerance.params.resolution_mm"),
                      ("[tolerance.params]\nnose_radius_mm = 0.25\n", "tolerance.params.nose_radius_mm"),
                      ("[tolerance]\nazimuths = 100000\n", "tolerance.azimuths")):
        cfg = tmp_path / "bad.toml"
        cfg.write_text(text)
        out = tmp_path / "out"
        proc = run_cli("tolerance", "--config", str(cfg), "-o", str(out))
        assert proc.returncode == 2, proc.stderr
        assert key in proc.stderr and "Traceback" not in proc.stderr
        assert not out.exists()


def test_tolerance_cli_uncuttable_design_leaves_no_output_dir(tmp_path):
    cfg = tmp_path / "recessed.toml"
    cfg.write_text(UNCUTTABLE)
    out = tmp_path / "out" / "tolerance"
    proc = run_cli("tolerance", "--config", str(cfg), "-o", str(out), "--trials", "2")
    assert proc.returncode == 2, proc.stderr
    assert UNCUTTABLE_PHRASE in proc.stderr and "Traceback" not in proc.stderr
    assert not (tmp_path / "out").exists()


def test_trials_csv_has_a_row_per_trial_of_each_run(ctx):
    a = run_monte_carlo(ctx)
    text = trials_csv([("x", a), ("y", a)])
    rows = list(csv.reader(io.StringIO(text)))
    assert len(rows) == 1 + 2 * len(a.trials)
    head = rows[0]
    for col in ("nose_mm", "seat_tilt_x_deg", "cal_image_displacement_px_rms_outer", "raw_disparity_px_p90",
                "cal_rotation_x_deg", "pass_disparity_px", "pass"):
        assert col in head
    i = head.index("cal_disparity_px_p90")
    got = np.array([float(r[i]) for r in rows[1:len(a.trials) + 1]])
    assert np.all(np.abs(got - a.figures.calibrated["disparity_px_p90"][:, 0]) <= 0.5e-6)  # written to 1e-6 px
    # each column at its unit's stated precision: at most that many decimals
    decimals = {"nose_mm": 9, "seat_tilt_x_deg": 10, "cal_image_displacement_px_rms_outer": 6,
                "raw_disparity_px_p90": 6, "cal_rotation_x_deg": 10, "polish_time_s": 6}
    for col, n in decimals.items():
        j = head.index(col)
        assert all(len(r[j].partition(".")[2]) <= n for r in rows[1:] if "e" not in r[j]), col


def test_a_columns_precision_comes_from_its_unit():
    # by hand from the table in export/numbers.py: mm 1e-9, px 1e-6, deg 1e-10, rad 1e-12, s 1e-6
    assert column_exponent("cal_image_displacement_px_rms_outer") == -6
    assert column_exponent("raw_disparity_px_p90") == -6
    assert column_exponent("seat_tilt_x_deg") == -10
    assert column_exponent("slope_error_rad_rms_inner") == -12
    assert column_exponent("normal_deviation_mm_rms_outer") == -9
    assert column_exponent("polish_time_s") == -6
    assert column_exponent("phase_steps") is None and column_exponent("seen_fraction") is None


# --------------------------------------------------------------------------------------
# The range the made parts deliver


def test_delivered_r10_of_a_perfect_sharp_part_is_the_papers(paper_mirror):
    """Hand calculation. No part error, no blur, no matcher noise: the paper's sharp R10
    (0.222 m over the common band, optics.ranging.resolution) is the design's. A 10 px
    blur circle with 0.1 px of sharp matcher noise: n^2 = 0.1^2 + (0.03 x 10)^2 = 0.1, so
    the design (the nominal part) delivers 0.222 / sqrt(1.1) and a part with 1 px of its
    own disparity error 0.222 / sqrt(2.1); the robot reads at 1 m 10 % x (1 / 0.222) x
    sqrt(1 + 0.1) = 47.2 % (first order in the disparity error)."""
    from lathe_mirror.tolerance.delivered import delivered_range

    d = delivered_range(paper_mirror, np.array([0.0, 1.0]), blur_px=0.0, matching_noise_px=0.0, range_m=1.0)
    assert d.design_r10_m == pytest.approx(0.222, abs=5e-4) and d.sharp_r10_m == d.design_r10_m
    assert d.r10_m[0] == pytest.approx(0.222, abs=5e-4)
    assert d.r10_m[1] == pytest.approx(0.222 / math.sqrt(2.0), abs=5e-4)
    d = delivered_range(paper_mirror, np.array([0.0, 1.0]), blur_px=10.0, matching_noise_px=0.1, range_m=1.0)
    assert d.sharp_r10_m == pytest.approx(0.222, abs=5e-4)
    assert d.design_r10_m == pytest.approx(0.222 / math.sqrt(1.1), abs=5e-4)
    assert d.r10_m[0] == pytest.approx(d.design_r10_m, rel=1e-12)  # the nominal part delivers the design
    assert d.r10_m[1] == pytest.approx(0.222 / math.sqrt(2.1), abs=5e-4)
    assert d.depth_error_pct[1] == pytest.approx(10.0 / 0.222 * math.sqrt(1.1), rel=3e-3)
    assert d.summary()["sharp"] == d.sharp_r10_m and d.summary()["design"] == d.design_r10_m


def test_monte_carlo_quotes_the_delivered_range_per_trial(ctx):
    """Every trial's delivered R10 is the sharp R10 over sqrt(1 + d^2 + n^2), with d its own
    calibrated disparity (the band's median) and n^2 = 0.1^2 + (0.03 x 6)^2 the matcher's
    noise on a 6 px blur: recomputed by hand from the trial table; the design's is the
    same with d = 0; the summary's p5 and median are the table's."""
    c = dataclasses.replace(ctx, blur_px=6.0)
    res = run_monte_carlo(c)
    out = res.to_dict()
    per = out["per_trial"]
    d = res.figures.calibrated["disparity_px_median"][:, 0]
    design, sharp = out["delivered_r10_m"]["design"], out["delivered_r10_m"]["sharp"]
    assert design == pytest.approx(sharp / math.sqrt(1.0 + 0.01 + 0.0324), rel=1e-12)
    want = sharp / np.sqrt(1.0 + d**2 + 0.01 + 0.0324)
    assert np.allclose(per["delivered_r10_m"], want, rtol=1e-12)
    assert out["delivered_r10_m"]["p5"] == pytest.approx(np.quantile(want, 0.05, method="inverted_cdf"))
    assert out["delivered_r10_m"]["median"] <= design
    header, rows = res.csv_rows("mc")
    assert "delivered_r10_m" in header and len(rows) == len(res.trials)


# --------------------------------------------------------------------------------------
# Shop classes


def test_a_shop_class_sets_every_tolerance_and_the_files_own_values_override(tmp_path):
    """shop = "hobby" gives the hobby column of the shop-class table (its values typed here
    from docs/reference/shop-classes.md), the file's own seat tilt wins over it, and
    precision is tighter than job, job than hobby, on every parameter."""
    from lathe_mirror.config import load
    from lathe_mirror.tolerance.shops import SHOPS, TABLE, shop_table_markdown

    path = tmp_path / "shop.toml"
    path.write_text('[tolerance]\nshop = "hobby"\n[tolerance.params]\nseat_tilt_deg = 0.07\n')
    t = load(path).tolerance
    assert t.shop == "hobby"
    assert t.tolerances["seat_tilt_deg"] == 0.07  # the file's own value
    assert t.tolerances["camera_decentre_mm"] == 0.2 and t.tolerances["nose_radius_mm"] == 0.05
    assert t.tolerances["tool_x_mm"] == 0.02 and t.machine_errors["backlash_mm"] == 0.05
    assert t.machine_errors["centre_height_mm"] == 0.1
    # the other keys of [tolerance.params] (the resolution) keep their defaults
    assert t.tolerances["resolution_mm"] == load().tolerance.tolerances["resolution_mm"]
    for section in TABLE.values():
        for vals, _ in section.values():
            assert vals[0] > vals[1] > vals[2] > 0
    for name in SHOPS:  # every class loads, and sets every drawn tolerance
        path.write_text(f'[tolerance]\nshop = "{name}"\n')
        assert load(path).tolerance.tolerances["seat_tilt_deg"] == TABLE["params"]["seat_tilt_deg"][0][SHOPS.index(name)]
    path.write_text('[tolerance]\nshop = "garage"\n')
    with pytest.raises(Exception, match="tolerance.shop"):
        load(path)
    from pathlib import Path

    doc = (Path(__file__).resolve().parents[1] / "docs" / "reference" / "shop-classes.md").read_text()
    assert shop_table_markdown() in doc
