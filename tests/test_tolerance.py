"""Tolerance analysis: the radial shortcut, the 3-D trial tracer, Monte Carlo, sensitivity.

Checked against the full per-pixel computation and the 3-D tracer of lathe_mirror.optics
(independent code), against physical equivalences, and by recounting the yield by hand.
"""

from __future__ import annotations

import copy
import json
import math

import numpy as np
import pytest

from lathe_mirror.settings import from_config
from lathe_mirror.errors import InputError
from lathe_mirror.optics.camera import CameraPose
from lathe_mirror.optics.distortion import exact_image_point, image_displacement
from lathe_mirror.optics.trace import Fate, trace_pixels
from lathe_mirror.polishing import PolishParams
from lathe_mirror.profile import ExactProfile
from lathe_mirror.tolerance.montecarlo import draw_trials, evaluate_trials, judge, run_monte_carlo
from lathe_mirror.tolerance.perturb import Trials, build_nodes, evaluate, pixel_sample
from lathe_mirror.optics.radial import (
    ideal_radius_px,
    lobe_pixel_radii,
    radial_displacement,
    radial_figures,
    trace_lobe,
    used_extent,
)
from lathe_mirror.tolerance.sensitivity import sensitivity_table
from lathe_mirror.enums import Program, Strategy
from lathe_mirror.pipeline import made_surface, tolerance_context

from conftest import UNCUTTABLE, UNCUTTABLE_PHRASE, run_cli


@pytest.fixture(scope="module")
def small_cfg(paper_config):
    cfg = copy.deepcopy(paper_config)
    cfg["tolerance"]["lattice_phases"] = 2
    cfg["tolerance"]["trials"] = 150
    return cfg


@pytest.fixture(scope="module")
def ctx(small_cfg, paper_mirror):
    return tolerance_context(paper_mirror, from_config(small_cfg), Program.PAPER, 3600.0)


def test_exact_lobe_inverse_map_is_the_trace_inverse(paper_mirror):
    """The closed-form image radius of a direction undoes the forward trace on the exact lobe."""
    for k in (0, 1):
        rho = lobe_pixel_radii(paper_mirror, k, bin_px=5.0).radius_px
        rays = trace_lobe(paper_mirror.lobes[k], paper_mirror, k, rho)
        back = ideal_radius_px(paper_mirror.lobes[k], paper_mirror.camera, rays.elevation)
        assert np.max(np.abs(back - rho)) < 1e-9


def test_radial_shortcut_matches_the_full_pixel_computation(paper_mirror, paper_config):
    """1-D (each distinct radius once, weighted by its pixel count) vs optics.distortion's
    per-pixel maps (independent tracer), pixel by pixel, on the same pixel set: the lobe's
    pixels the exact design does not vignette, whose made ray lands on the lobe."""
    made = made_surface(paper_mirror, from_config(paper_config).machine, from_config(paper_config).tool, Strategy.PAPER).profile
    maps = image_displacement(made, paper_mirror)
    full = maps.figures()
    short = radial_figures(made, paper_mirror)
    for k in (0, 1):
        use = (maps.lobe == k) & maps.usable & ~maps.blocked
        px = lobe_pixel_radii(paper_mirror, k)
        mine = radial_displacement(made, paper_mirror, k, px.radius_px)
        # Map every pixel to its distinct radius (nearest: the two codes' radii differ by ~1e-13).
        hi = np.clip(np.searchsorted(px.radius_px, maps.radius_px), 1, px.radius_px.size - 1)
        nearer_lo = np.abs(px.radius_px[hi - 1] - maps.radius_px) < np.abs(px.radius_px[hi] - maps.radius_px)
        idx = np.where(nearer_lo, hi - 1, hi)
        on_radius = np.abs(px.radius_px[idx] - maps.radius_px) < 1e-9
        mine_px = np.where(on_radius & (maps.lobe == k), mine[idx], np.nan)
        assert np.array_equal(np.isfinite(mine_px), use)  # the same pixels
        assert np.max(np.abs(np.abs(mine_px[use]) - maps.image_displacement_px[use])) < 1e-6  # two root finders
        lb, ref = short["lobes"][k], full["lobes"][k]
        assert lb["pixels"] == ref["pixels"] == int(use.sum())
        for key in ("image_displacement_px", "ray_deviation_deg", "viewpoint_spread_mm"):
            assert lb[key]["rms"] == pytest.approx(ref[key]["rms"], rel=1e-8, abs=1e-12), key
            assert lb[key]["max"] == pytest.approx(ref[key]["max"], rel=1e-8, abs=1e-12), key


def test_used_extent_is_where_the_step_starts_to_vignette(paper_mirror):
    lo, hi = used_extent(paper_mirror, 0)
    inner = paper_mirror.inner
    z_top = float(paper_mirror.outer.z(paper_mirror.r_junction))
    for r, blocked in ((hi - 0.01, False), (hi + 0.01, True)):
        z = float(inner.z(r))
        # Hand calculation: the exact ray leaves along F1 -> P; height at r_junction.
        z_wall = z + (paper_mirror.r_junction - r) * (z - inner.focus_z) / r
        assert (z_wall > z_top) is blocked
    assert used_extent(paper_mirror, 1) == (paper_mirror.r_junction, paper_mirror.r_max)


def test_aligned_trial_reduces_to_the_radial_figures(ctx, paper_mirror, paper_config):
    """A nominal trial, traced in 3-D on the sparse sample, agrees with the 1-D shortcut on
    the same polished surface (differences: grid interpolation of the node surface only)."""
    from lathe_mirror.polishing import polish

    fig = evaluate_trials(ctx, Trials.nominal(1, ctx.nominal_nose_mm, ctx.nominal_time_s))
    surf = made_surface(paper_mirror, from_config(paper_config).machine, from_config(paper_config).tool, Strategy.PAPER).profile
    polished = polish(surf, from_config(paper_config).polish, ctx.nominal_time_s)
    short = radial_figures(polished, paper_mirror, bin_px=ctx.settings.bin_px)
    for k in (0, 1):
        assert fig.image_displacement_px_rms[0, k] == pytest.approx(
            short["lobes"][k]["image_displacement_px"]["rms"], rel=0.03)
    assert fig.lost_fraction[0] < 0.01


def test_misaligned_camera_matches_the_optics_3d_tracer(paper_mirror):
    """The trial tracer against optics.trace (march + bisection) for a decentred, tilted,
    shifted camera on the exact mirror: the displacement is the misalignment's alone."""
    exact = ExactProfile(paper_mirror)
    nodes = build_nodes(paper_mirror, [[exact]], np.array([0.2]), np.array([0.0]), PolishParams(), np.array([0.0]))
    pose = CameraPose(decentre=(0.05, -0.03), axial_offset=0.1, tilt=(math.radians(0.08), math.radians(-0.05)))
    tr = Trials.nominal(1, 0.2, 0.0)
    tr.cam_x_mm[:], tr.cam_y_mm[:], tr.cam_z_mm[:] = 0.05, -0.03, 0.1
    tr.tilt_x[:], tr.tilt_y[:] = pose.tilt
    for k in (0, 1):
        smp = pixel_sample(paper_mirror, k, bin_px=25.0, azimuths=6)
        fig = evaluate(paper_mirror, nodes, tr, (smp, smp), depth_range_m=1.0, keep_displacements=True)
        _, _, disp, ok = [d for d in fig.extra["displacements"] if d[0] == k][0]
        xy = np.stack([smp.u, smp.v], axis=-1)
        hits = trace_pixels(exact, paper_mirror.camera, xy, pose=pose)
        good = (hits.fate == (Fate.INNER if k == 0 else Fate.OUTER)) & ~hits.blocked & ok[0]
        assert good.sum() > 0.9 * len(smp.u)
        img = exact_image_point(paper_mirror, k, hits.direction[good], paper_mirror.camera)
        theirs = np.hypot(*(img - xy[good]).T)
        assert np.max(np.abs(disp[0][good] - theirs)) < 2e-3 * max(1.0, float(theirs.max()))
        assert theirs.max() > 0.5  # the misalignment does move the image


def test_mirror_piston_equals_camera_shift(ctx):
    """Tool Z error +d moves the mirror away from the camera: optically the same as the
    camera moving -d along the axis. The image is identical; the depth error differs only
    because the world point stays put while the mirror (and its stereo centre) moves by d:
    at most 100 d / R percentage points (0.001 for d = 0.01 mm at R = 1 m)."""
    a = Trials.nominal(2, ctx.nominal_nose_mm, ctx.nominal_time_s)
    a.tool_z_mm[0] = 0.01
    a.cam_z_mm[1] = -0.01
    fig = evaluate_trials(ctx, a)
    assert fig.image_displacement_px_rms[0] == pytest.approx(fig.image_displacement_px_rms[1], rel=1e-6)
    assert fig.depth_error_pct_rms[0] == pytest.approx(fig.depth_error_pct_rms[1], abs=100 * 0.01 / 1000.0)


def test_monte_carlo_is_reproducible_and_seeded(ctx):
    a = json.dumps(run_monte_carlo(ctx).to_dict())
    b = json.dumps(run_monte_carlo(ctx).to_dict())
    assert a == b
    other = draw_trials(ctx, seed=ctx.settings.seed + 1)
    assert not np.array_equal(other.tool_x_mm, draw_trials(ctx).tool_x_mm)
    # The draws follow the spec: a normal tolerance is a 3-sigma bound.
    big = draw_trials(ctx, n=20000)
    assert np.std(big.tool_x_mm) == pytest.approx(ctx.settings.tolerances["tool_x_mm"] / 3.0, rel=0.03)


def test_yield_recounted_by_hand(ctx):
    res = run_monte_carlo(ctx)
    spec = ctx.settings.spec
    f = res.figures
    n_pass = 0
    for i in range(len(res.trials)):
        ok = (max(f.image_displacement_px_rms[i]) <= spec.image_displacement_px
              and f.depth_error_pct_rms[i] <= spec.depth_error_pct
              and max(f.slope_error_rad_rms[i]) <= spec.slope_error_rad)
        n_pass += ok
    assert res.yield_fraction == n_pass / len(res.trials)
    assert set(judge(f, ctx.settings)) == {"image_displacement_px", "depth_error_pct", "slope_error_rad"}


def test_sensitivity_table(ctx):
    table = sensitivity_table(ctx)
    rows = {r["parameter"]: r for r in table["rows"]}
    # A decentre or a tilt along -x or +x is the same by the mirror's symmetry.
    for key in ("camera_decentre_mm", "camera_tilt_deg"):
        m, p = rows[key]["minus"], rows[key]["plus"]
        assert m["image_displacement_px_rms"] == pytest.approx(p["image_displacement_px_rms"], rel=1e-6)
    # A camera tilt of 0.1 deg turns the whole image by about f * tilt / pixel = 3.1 px.
    shift = 16.0 * math.radians(0.1) / 0.009
    nominal = table["nominal"]["image_displacement_px_rms"]
    tilted = rows["camera_tilt_deg"]["plus"]["image_displacement_px_rms"]
    for k in (0, 1):
        assert math.sqrt(max(tilted[k] ** 2 - nominal[k] ** 2, 0.0)) == pytest.approx(shift, rel=0.25)
    assert "lattice_phase" in rows and rows["tool_x_mm"]["tolerance"] == 0.005


def test_spec_errors_name_the_key(paper_config):
    cfg = copy.deepcopy(paper_config)
    cfg["tolerance"]["distribution"] = "gaussian"
    with pytest.raises(InputError, match="tolerance.distribution"):
        from_config(cfg).tolerance
    cfg = copy.deepcopy(paper_config)
    cfg["tolerance"]["params"]["tool_x_mm"] = -1.0
    with pytest.raises(InputError, match="tolerance.params.tool_x_mm"):
        from_config(cfg).tolerance


def test_tolerance_cli_bad_program_exit_2(tmp_path):
    cfg = tmp_path / "bad.toml"
    cfg.write_text('[tolerance]\nprograms = ["paper", "perfect"]\n')
    out = tmp_path / "out"
    proc = run_cli("tolerance", "--config", str(cfg), "-o", str(out))
    assert proc.returncode == 2, proc.stderr
    assert "tolerance.programs[1]" in proc.stderr and "Traceback" not in proc.stderr
    assert not out.exists()


def test_trial_depth_error_matches_the_stereo_module(ctx, paper_mirror, paper_config):
    """A nominal (aligned) trial's depth error, traced in 3-D at 4 azimuths, against
    optics.stereo's meridian triangulation on the same polished surface."""
    from lathe_mirror.optics.stereo import band_elevations, depth_error_curve
    from lathe_mirror.polishing import polish

    fig = evaluate_trials(ctx, Trials.nominal(1, ctx.nominal_nose_mm, ctx.nominal_time_s))
    surf = made_surface(paper_mirror, from_config(paper_config).machine, from_config(paper_config).tool, Strategy.PAPER).profile
    polished = polish(surf, from_config(paper_config).polish, ctx.nominal_time_s)
    rng = ctx.settings.spec.depth_range_m
    curve = depth_error_curve(polished, paper_mirror, [rng],
                              elevations=band_elevations(paper_mirror, ctx.settings.depth_points))
    assert fig.depth_error_pct_rms[0] == pytest.approx(curve.at(rng)["rms"], rel=0.05)


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


def test_tolerance_cli_no_progress_keeps_stderr_empty(tmp_path):
    """--no-progress (as render's): nothing on stderr on success, the figures on stdout."""
    cfg = tmp_path / "quick.toml"
    cfg.write_text("[polish]\ncurve_points = 3\n[tolerance]\ntrials = 20\nlattice_phases = 1\n")
    proc = run_cli("tolerance", "--config", str(cfg), "--no-progress")
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert proc.stderr == "" and proc.stdout.strip()
