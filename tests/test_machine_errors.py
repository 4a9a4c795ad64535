"""A lathe with set-up errors (machine_errors), and `measure` naming them.

The simulated surface is checked against closed forms: with no error it is the nose
envelope nose_envelope.as_machined computes piece by piece in closed form; a nose radius
error moves the surface by dr (1 - cos t, 1 - sin t) (X radial, Z) at the normal's angle
t (the shop's rule for a tool set on its tip); an X offset moves it out in r; a centre
height leaves radii under |h| uncut. Then a part cut with a 0.21 mm nose where 0.20 was
programmed and the tool 0.05 mm above centre is traced and `measure` must name both (nose
within 0.002 mm, height within 0.01 mm), on the paper default and on a design whose outer
lobe is recessed.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from conftest import run_cli
from lathe_mirror.machine_errors import MachineErrors, machined_with_errors
from lathe_mirror.job import check_program, machine


@pytest.fixture(scope="module")
def case(design_case):
    s, mirror = design_case["settings"], design_case["mirror"]
    tp = check_program(s, mirror, s.toolpath.strategy)
    return {**design_case, "tp": tp, "nominal": machine(tp)}


def lobe_radii(m, k, n=3000, margin=0.5):
    lo, hi = (0.0, m.r_junction) if k == 0 else (m.r_junction, m.r_max)
    return np.linspace(lo + margin, hi - margin, n)


@pytest.mark.parametrize("order", ["path", "shuffled"])
def test_disc_envelope_is_the_lowest_of_all_discs(case, order):
    """Each disc is evaluated only over its window (machine_errors.disc_windows): the
    result is the minimum over every disc at every radius, computed here by brute force,
    on stretches of the program's real centre path with backlash, an X offset and a centre
    height (jumps where X reverses, a pip), in the path's order and shuffled."""
    from lathe_mirror.machine_errors import centre_path, disc_envelope

    errors = MachineErrors(centre_height_mm=0.03, x_offset_mm=0.01, backlash_mm=0.01)
    xc, zc = centre_path(case["tp"], errors)
    rho = case["tp"].nose_radius
    rng = np.random.default_rng(3)
    m = case["mirror"]
    for lo, hi in ((-0.1, 0.6), (m.r_junction - 0.5, m.r_junction + 0.5), (m.r_max - 0.6, m.r_max + 0.1)):
        sel = np.flatnonzero((xc > lo - 2 * rho) & (xc < hi + 2 * rho))
        x, z = xc[sel], zc[sel]
        if order == "shuffled":
            p = rng.permutation(x.size)
            x, z = x[p], z[p]
        r = np.sort(rng.uniform(lo, hi, 700))
        got, want = disc_envelope(x, z, rho, r), _lowest_of_all(x, z, rho, r)
        assert np.array_equal(got, want), (lo, hi, np.nanmax(np.abs(got - want)))


def _lowest_of_all(xc, zc, rho, r):
    d = r[:, None] - xc[None, :]
    h2 = rho * rho - d * d
    return np.where(h2 >= 0, zc[None, :] - np.sqrt(np.maximum(h2, 0.0)), np.inf).min(axis=1)


def test_disc_envelope_with_a_centre_an_ulp_off_and_at_the_reach_edges():
    """Rounding (a review's cases): the corner of a V-shaped centre path repeated one ulp
    away (an arc's sampled end beside the next move's start) must not hide the corner's
    disc, and a radius at a disc's reach edge (r = xc +- rho to the last bit) gets the
    disc's side point; the brute-force minimum of all discs, to the bit."""
    from lathe_mirror.machine_errors import disc_envelope

    rng = np.random.default_rng(2)
    rho = 0.2
    for c in rng.uniform(0.5, 20, (60, 2)):
        a = c + np.stack([np.linspace(-0.5, 0, 200), np.linspace(0.5, 0, 200)], 1)
        b = c + np.stack([np.linspace(0, 0.5, 200), np.linspace(0, 0.5, 200)], 1)
        a[-1] = b[0] = c
        near = [np.nextafter(c[0], np.inf), np.nextafter(c[1], -np.inf)]
        p = np.concatenate([a, [near], b])
        r = np.unique(rng.uniform(c[0] - rho, c[0] + rho, 2000))
        assert np.array_equal(disc_envelope(p[:, 0], p[:, 1], rho, r), _lowest_of_all(p[:, 0], p[:, 1], rho, r))
    for _ in range(300):
        xc, zc = rng.uniform(0, 30, 1), rng.uniform(-3, 0, 1)
        edges = [xc[0] - rho, xc[0] + rho]
        r = np.unique([np.nextafter(e, np.inf) if k else e for e in edges for k in (0, 1)]
                      + [np.nextafter(e, -np.inf) for e in edges])
        assert np.array_equal(disc_envelope(xc, zc, rho, r), _lowest_of_all(xc, zc, rho, r))


def test_no_error_is_the_closed_form_envelope(case):
    made = machined_with_errors(case["tp"], MachineErrors())
    for k in (0, 1):
        r = lobe_radii(case["mirror"], k)
        assert np.max(np.abs(made.z(r) - case["nominal"].z(r))) < 2e-6


def test_nose_error_moves_the_surface_by_the_shop_rule(case):
    dr = 0.01
    made = machined_with_errors(case["tp"], MachineErrors(nose_radius_error_mm=dr))
    nom = case["nominal"]
    for k in (0, 1):
        r = lobe_radii(case["mirror"], k)
        s = nom.slope(r)  # camera frame dz/dr; machine Z' = -s
        t = np.arctan2(1.0, s)  # outward normal (s, 1)/|.| in the machine frame: angle from +r
        dX, dZ = dr * (1 - np.cos(t)), dr * (1 - np.sin(t))
        expected = dZ + s * dX  # vertical change of a surface moved by (dX, dZ): dZ - Z' dX
        got = nom.z(r) - made.z(r)  # machine Z up = camera z down
        assert np.max(np.abs(got - expected)) < 0.03 * dr


def test_x_offset_and_centre_height(case):
    m, tp, nom = case["mirror"], case["tp"], case["nominal"]
    made = machined_with_errors(tp, MachineErrors(x_offset_mm=0.02))
    r = lobe_radii(m, 0, margin=0.6)
    assert np.max(np.abs(made.z(r) - nom.z(r - 0.02))) < 2e-6
    h = 0.05
    made = machined_with_errors(tp, MachineErrors(centre_height_mm=h), pip_height_mm=0.1)
    r = np.linspace(h + 0.01, 1.0, 200)
    assert np.max(np.abs(made.z(r) - nom.z(np.sqrt(r * r - h * h)))) < 2e-6
    zm = m.vertex_z - made.z(np.array([0.0, 0.5 * h]))  # machine Z of the pip (a cone)
    edge = m.vertex_z - nom.z(0.0)
    assert zm[0] == pytest.approx(edge + 0.1, abs=1e-6) and zm[1] == pytest.approx(edge + 0.05, abs=2e-4)


#: The trace's decentre (mm), tilt (rad) and lift (mm) of the part on the profilometer.
TRACE_X0, TRACE_TILT, TRACE_LIFT = -0.211, -2.0e-4, 0.5


def trace(path, case, tp, errors):
    """The part `tp` cuts on a lathe with `errors`, traced (decentred, tilted, lifted,
    0.05 um noise, every 2 um) to a CSV."""
    m = case["mirror"]
    made = machined_with_errors(tp, errors, pip_height_mm=case["settings"].toolpath.rough_allowance)
    x0, tilt, p = TRACE_X0, TRACE_TILT, TRACE_LIFT
    u = np.linspace(-m.r_max, m.r_max, 600001)
    w = m.vertex_z - made.z(np.abs(u))
    X = x0 + u * math.cos(tilt) - w * math.sin(tilt)
    Z = p + u * math.sin(tilt) + w * math.cos(tilt)
    x = np.arange(X.min() + 0.01, X.max() - 0.01, 0.002)
    z = np.interp(x, X, Z) + np.random.default_rng(3).normal(0, 5e-5, x.size)
    np.savetxt(path, np.c_[x, z], delimiter=",", header="x_mm,z_mm", comments="", fmt="%.7f")
    return path


def test_measure_names_nose_and_centre_height(case):
    d = case["dir"]
    x0, tilt = TRACE_X0, TRACE_TILT
    trace(d / "part.csv", case, case["tp"], MachineErrors(centre_height_mm=0.05, nose_radius_error_mm=0.01))
    args = ["measure", str(d / "part.csv"), "--json"] + (["--config", str(case["cfg"])] if case["cfg"] else [])
    p = run_cli(*args)
    assert p.returncode == 0, p.stderr
    out = json.loads(p.stdout)
    dg = out["diagnosis"]
    assert abs(dg["nose_radius_error_mm"] - 0.01) < 0.002
    assert abs(dg["nose_radius_mm"] - 0.21) < 0.002
    assert abs(dg["centre_height_mm"] - 0.05) < 0.01
    assert any("lower the tool 0.05" in c for c in dg["corrections"])
    assert any("nose radius 0.21" in c and "tool table" in c for c in dg["corrections"])
    assert abs(out["fit"]["decentre_mm"] - x0) < 2e-3 and abs(out["fit"]["tilt_rad"] - tilt) < 2e-6


def test_compensate_recut_on_the_corrected_machine(case, tmp_path):
    """The part of the 0.21 mm nose and the tool 0.05 mm above centre, compensated: the
    re-cut program (read by LinuxCNC's rs274 with the written tool table) cut by the
    machine after the set-up corrections (the 0.21 mm insert, the tool lowered by what
    measure found) leaves no more residual than the original program on a perfect
    machine, within the lattice, in at most two iterations."""
    from test_outer_step import canonical, sample_moves

    from conftest import require_program
    from lathe_mirror.machine_errors import displaced_centres, surface_from_centres
    from lathe_mirror.optics.polishing_curve import clear_aperture

    exe = require_program("rs274")
    m, s = case["mirror"], case["settings"]
    true_h, true_nose = 0.05, 0.21
    errors = MachineErrors(centre_height_mm=true_h, nose_radius_error_mm=true_nose - 0.2)
    part = machined_with_errors(case["tp"], errors, pip_height_mm=s.toolpath.rough_allowance)

    def rms_vs_design(profile):
        """RMS (mm) of each lobe's height error over its clear aperture, off the axis by one
        lattice step (a pip narrower than the lattice is below what setting the tool's
        height to the lattice can remove)."""
        out = []
        for k in (0, 1):
            lo, hi = clear_aperture(m, k, 0.0)
            r = np.linspace(max(lo, s.machine.resolution), hi, 4000)
            if k == 1:
                r[0] = np.nextafter(r[0], hi)  # r_junction itself is the inner lobe's
            d = profile.z(r) - m.lobes[k].z(r)
            out.append(float(np.sqrt(np.mean((d - d.mean()) ** 2))))
        return np.array(out)

    perfect = rms_vs_design(case["nominal"])
    set_h, nose_in_table = 0.0, 0.2  # the machine's set-up as the operator has it
    for iteration in (1, 2):
        u = np.linspace(-m.r_max, m.r_max, 600001)
        z = (m.vertex_z - part.z(np.abs(u))) + np.random.default_rng(iteration).normal(0, 5e-5, u.size)
        np.savetxt(tmp_path / "part.csv", np.c_[u, z][::3], delimiter=",", header="x_mm,z_mm", comments="",
                   fmt="%.7f")
        out = tmp_path / f"recut{iteration}"
        args = ["compensate", str(tmp_path / "part.csv"), "-o", str(out), "--json"]
        p = run_cli(*(args + (["--config", str(case["cfg"])] if case["cfg"] else [])))
        assert p.returncode == 0, p.stderr
        res = json.loads(p.stdout)
        dg = res["measurement"]["diagnosis"]
        set_h += dg["centre_height_mm"]  # "lower the tool h": the operator does it
        nose_in_table = res["program"]["nose_radius_mm"]
        import subprocess

        run = subprocess.run([exe, "-t", str(out / "tools.tbl"), "-g", str(out / "mirror_recut.ngc")],
                             capture_output=True, text=True, cwd=out, env={"HOME": str(tmp_path), "PATH": "/usr/bin:/bin"},
                             timeout=120)
        assert run.returncode == 0, run.stdout[-1000:] + run.stderr[-1000:]
        moves, start = canonical(run.stdout)
        fin = [mv for mv in moves if mv[4]]
        pts = np.concatenate([p_[2] for p_ in sample_moves(fin, start, step=0.0005)])
        # the machine after the corrections: the real insert, the tool where the operator set it
        left = MachineErrors(centre_height_mm=true_h - set_h, nose_radius_error_mm=true_nose - nose_in_table)
        xc, zc = displaced_centres(pts[:, 0], pts[:, 1], left)
        part = surface_from_centres(m, xc, zc, true_nose, left.centre_height_mm,
                                    pip_height_mm=s.toolpath.rough_allowance)
        got = rms_vs_design(part)
        if np.all(got <= perfect + 0.1 * s.machine.resolution):
            break
    assert np.all(got <= perfect + 0.1 * s.machine.resolution), (iteration, got, perfect)
    assert abs(nose_in_table - true_nose) < 0.002 and abs(set_h - true_h) < 0.01


def test_monte_carlo_draws_machine_errors(paper_config, paper_mirror):
    """The Monte Carlo's first-order model of the set-up errors (tolerance.perturb.
    machine_error_surface) against the full simulation (machined_with_errors) on the same
    part, and the errors drawn and tabled as every toleranced parameter."""
    import copy

    from lathe_mirror.enums import Program
    from lathe_mirror.job import plan
    from lathe_mirror.settings import from_config
    from lathe_mirror.tolerance.montecarlo import draw_trials
    from lathe_mirror.tolerance.perturb import Trials, machine_error_surface
    from lathe_mirror.tolerance.runs import tolerance_context
    from lathe_mirror.tolerance.sensitivity import sensitivity_table

    cfg = copy.deepcopy(paper_config)
    cfg["tolerance"].update(lattice_phases=1, trials=20, nose_step_mm=0.005, programs=["best"])
    cfg["tolerance"]["machine_errors"].update(centre_height_mm=0.05, nose_radius_error_mm=0.02, squareness_urad=50.0)
    settings = from_config(cfg)
    m = paper_mirror
    ctx = tolerance_context(m, settings, Program.BEST, 0.0)
    tr = Trials.nominal(1, ctx.nominal_nose_mm, 0.0)
    tr.nose_error_mm[0], tr.squareness_rad[0] = 0.01, 20e-6
    tp = plan(m, settings.machine, settings.tool, settings.toolpath.strategy)
    full = machined_with_errors(tp, MachineErrors(nose_radius_error_mm=0.01, squareness_rad=20e-6))
    for k in (0, 1):
        z0, s0 = ctx.bank.trial_surface(k, tr.phase, tr.nose_mm, tr.time_s, tr.tool_z_mm)
        z, _ = machine_error_surface(ctx.bank, k, (z0, s0), tr)
        r = ctx.bank.grid(k)
        lo, hi = (0.5, m.r_junction - 0.5) if k == 0 else (m.r_junction + 0.5, m.r_max - 0.5)
        sel = (r > lo) & (r < hi)
        effect = np.abs(full.z(r[sel]) - z0[0, sel])
        assert effect.max() > 1e-3  # micrometres of change
        assert np.max(np.abs(z[0, sel] - full.z(r[sel]))) < 0.05 * effect.max()
    trials = draw_trials(ctx)
    assert np.std(trials.centre_height_mm) > 0.005 and np.std(trials.nose_error_mm) > 0.002
    rows = {row["parameter"] for row in sensitivity_table(ctx)["rows"]}
    assert {"centre_height_mm", "nose_radius_error_mm", "squareness_urad"} <= rows
