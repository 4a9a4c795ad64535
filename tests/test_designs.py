"""The design matrix (issue 20) at fast settings: six designs that are not only the paper's,
each the winner `optimize` found for its camera and envelope (benchmarks/bench_designs.py
runs the whole chain at full settings), through the optimiser's tolerance check; and the
property tests: a finer lattice, a smaller nose and tighter tolerances never make a figure
worse beyond the lattice's noise; messages name only the failing criteria; no NaN or inf
reaches the JSON."""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pytest

from lathe_mirror.config import load
from lathe_mirror.enums import BEST, Program
from lathe_mirror.job import made_surface
from lathe_mirror.optics.radial import radial_figures
from lathe_mirror.optics.zones import zones, zones_for
from lathe_mirror.tolerance.montecarlo import CRITERIA, run_monte_carlo
from lathe_mirror.tolerance.runs import tolerance_context, winner_check

#: Small settings: a few trials and phases, a coarse pixel sample, a short polishing curve.
FAST = ("[tolerance]\ntrials = 24\nlattice_phases = 2\nazimuths = 4\nbin_px = 8.0\ndepth_points = 5\n"
        "[polish]\ncurve_points = 3\ngrid_step_mm = 0.01\n[tolerance.params]\npolish_time_s = 0.0\n")


def _lobes(inner, outer) -> str:
    return (f"[lobes.inner]\nr_top = {inner[0]!r}\nr_pixel = {inner[1]!r}\nalpha_deg = {inner[2]!r}\n"
            f"[lobes.outer]\nr_top = {outer[0]!r}\nr_pixel = {outer[1]!r}\nalpha_deg = {outer[2]!r}\n")


#: name -> the configuration (camera, tool, lattice, bar; the lobes optimize found with
#: maxiter = 120 under bench_designs.py's envelopes, the second set-up's grip among its
#: constraints).
DESIGNS = {
    "paper": _lobes((22.180296450480114, 336.0682794048982, 15.859295317306668),
                    (34.59840952483933, 498.06223072930203, 0.01179961352661607)),
    "deep_35mm": _lobes((19.933912090866958, 312.79920006291263, 0.17805418406952),
                        (34.87043441376087, 451.23323433504146, 0.00439676743907711))
    + "[stock]\nlength = 50.0\n[cad]\nthickness = 45.0\n",
    "lens6_px3um_nose04": "[camera]\nf = 6.0\nt_pixel = 0.003\nsensor_px = [1280, 1024]\n[tool]\nnose_radius = 0.4\n"
    "[stock]\ndiameter = 60.0\n" + _lobes((5.143250067202264, 354.34622080440613, 0.16491580636968806),
                                         (12.962773350532286, 511.82075923486775, 0.14021089596690714)),
    "lens12_px586_stock50_nose08_res01": "[camera]\nf = 12.0\nt_pixel = 0.00586\nsensor_px = [1920, 1200]\n"
    "[tool]\nnose_radius = 0.8\n[machine]\nresolution = 0.01\n[toolpath]\ngouge_tolerance = 0.01\n"
    "[stock]\ndiameter = 50.0\n" + _lobes((13.109387875739595, 378.8829160293022, 0.054743853006872456),
                                         (23.977686074024277, 552.3958066035915, 0.14920531183170951)),
    "lens4_px14_nose01_res0001": "[camera]\nf = 4.0\nt_pixel = 0.0014\nsensor_px = [2592, 1944]\n[tool]\n"
    "nose_radius = 0.1\n[machine]\nresolution = 0.001\n"
    + _lobes((3.4008462794456147, 669.2354165333072, 0.04786342068333482),
             (11.208276599404524, 971.7155733840183, 0.010759097010831909)),
    "paper_nose01_res001": "[tool]\nnose_radius = 0.1\n[machine]\nresolution = 0.01\n[toolpath]\n"
    "gouge_tolerance = 0.01\n" + _lobes((20.515328486407963, 316.6925373681863, 11.021826572768646),
                                       (34.89841492890646, 502.5542303544619, 0.01935966678973955)),
}


def load_designs(d) -> dict:
    """{name: Settings} of every matrix design at fast settings, each written to d as a file."""
    out = {}
    for name, text in DESIGNS.items():
        p = d / f"{name}.toml"
        # the resolution's tolerance below a 0.001 mm lattice (the default 0.0025 is not)
        fine = "resolution_mm = 0.0005\n" if "resolution = 0.001\n" in text else ""
        p.write_text(text + FAST + fine)
        out[name] = load(p)
    return out


@pytest.fixture(scope="session")
def design_settings(tmp_path_factory):
    return load_designs(tmp_path_factory.mktemp("designs"))


def _finite(x, path="") -> list[str]:
    """Paths of every non-finite float in a JSON-like structure."""
    if isinstance(x, dict):
        return [p for k, v in x.items() for p in _finite(v, f"{path}.{k}")]
    if isinstance(x, (list, tuple)):
        return [p for i, v in enumerate(x) for p in _finite(v, f"{path}[{i}]")]
    if isinstance(x, float) and not math.isfinite(x):
        return [path]
    return []


#: Winners whose nominal part fails at these fast settings, and the criteria it fails: the
#: 4 mm lens with 1.4 um pixels, polished for the 3-point curve's 8 h (the stereo objective
#: keeps falling; the form change raises the slope error past 0.02 rad); the paper camera on
#: a 0.01 mm lattice with a 0.1 mm nose (its facets' disparity, 0.57 > 0.46 px).
NOMINAL_FAILS = {"lens4_px14_nose01_res0001": ["slope_error_rad"], "paper_nose01_res001": ["disparity_px"]}


@pytest.mark.parametrize("name", list(DESIGNS))
def test_design_through_the_tolerance_check(name, design_settings):
    """Each winner through the optimiser's tolerance check as `optimize` runs it (the best
    program, the configured tool, the default tolerances, polished for its polishing
    curve's time, the part `tolerance` judges): nominal PASS (but NOMINAL_FAILS), and every
    message names exactly the criteria that fail (those alone): the nominal part's, or the
    criteria the failing trials break and the tolerance held perfectly that reaches the
    target (or that none does); finite figures only (strict JSON); the zone the criteria
    judge lies inside the designed annulus, the fillet's pixels counted apart."""
    s = design_settings[name]
    m = s.mirror()
    check = winner_check(m, s)
    assert _finite(check) == []
    json.dumps(check, allow_nan=False)
    failing = [c for c in CRITERIA if not check["nominal"][c]["pass"]]
    for c in CRITERIA:  # the verdict is the value against its limit
        assert check["nominal"][c]["pass"] == (check["nominal"][c]["value"] <= check["nominal"][c]["limit"])
    assert check["nominal_pass"] == (not failing)
    assert failing == NOMINAL_FAILS.get(name, []), check
    assert "polished" in check["made_mirror"] or check["polish_time_s"] == 0
    target = check["target_yield"]
    if failing:
        assert check["why"].startswith("the nominal part fails ")
        assert [c for c in CRITERIA if f"{c} (" in check["why"]] == failing
    elif check["yield"] < target:
        broken = [c for c in CRITERIA if check["pass_fraction"][c] < target] or \
            [c for c in CRITERIA if check["pass_fraction"][c] < 1.0]  # each reaches it alone
        clause = check["why"].split("; ")[0]
        assert [c for c in CRITERIA if f"{c} (pass" in clause] == broken and broken
        best = max(check["yield_without"], key=check["yield_without"].get)
        if check["yield_without"][best] >= target:
            assert f"{best} (tolerance" in check["why"] and "makes the target impossible" in check["why"]
        else:
            assert "no single tolerance" in check["why"]
    else:
        assert "why" not in check
    zn = zones_for(s, m)
    for lb in zn.lobes:
        assert lb.designed_px[0] - 1e-9 <= lb.used_px[0] <= lb.used_px[1] <= lb.designed_px[1] + 1e-9
        assert lb.used_pixels > 0


def test_finer_lattice_is_no_worse_beyond_its_noise(design_settings):
    """The 6 mm lens's best program: the image displacement over the used zone at half the
    lattice step is no worse than at the configured step by more than the spread the
    lattice's phase alone gives at the configured step (the lattice's noise)."""
    s = design_settings["lens6_px3um_nose04"]
    m = s.mirror()
    zn = zones_for(s, m)

    def disp(res, phase=0.0):
        machine = dataclasses.replace(s.machine, resolution=res)
        made = made_surface(m, machine, s.tool, BEST, phase=phase)
        return np.array([lb["image_displacement_px"]["rms"] for lb in radial_figures(made.profile, m, zones=zn)["lobes"]])

    res = s.machine.resolution
    coarse = np.array([disp(res, ph) for ph in (0.0, 0.25, 0.5, 0.75)])
    noise = coarse.max(axis=0) - coarse.min(axis=0)
    fine = disp(res / 2)
    assert np.all(fine <= coarse[0] + noise + 1e-12), (fine, coarse, noise)


def test_smaller_nose_never_widens_the_ring(design_settings):
    """The fillet ring the nose cannot reach grows with the nose on every design (closed
    form), and the used zone shrinks with it."""
    for s in design_settings.values():
        m = s.mirror()
        widths, used = [], []
        for nose in (0.1, 0.2, 0.4, 0.8):
            zn = zones(m, nose)
            widths.append(zn.fillet.fillet_width_mm)
            used.append(zn.lobes[0].used_pixels + zn.lobes[1].used_pixels)
        assert widths == sorted(widths) and used == sorted(used, reverse=True)


def test_tighter_tolerances_never_lower_the_yield(design_settings):
    """Same seed, every tolerance halved: each trial's draws are the same normals scaled by
    a half, so the yield may not fall (beyond one trial of the lattice's phase draws)."""
    s = design_settings["deep_35mm"]
    m = s.mirror()
    ctx = tolerance_context(m, s, Program.BEST, 0.0)
    full = run_monte_carlo(ctx)
    half = run_monte_carlo(ctx, tolerances={k: v / 2 for k, v in s.tolerance.tolerances.items()})
    n = len(full.trials)
    assert half.yield_fraction >= full.yield_fraction - 1.0 / n
    for c in CRITERIA:
        assert np.mean(half.passed[c]) >= np.mean(full.passed[c]) - 1.0 / n


def _strict(text: str):
    """JSON text parsed, refusing NaN and Infinity (no non-finite figure reaches an output)."""
    def refuse(c):
        raise AssertionError(f"non-finite {c} in a command's JSON")

    return json.loads(text, parse_constant=refuse)


def test_one_made_mirror_one_figure_across_commands(tmp_path):
    """The 6 mm lens with 3 um pixels (outer lobe recessed, 0.4 mm nose): `calib`, `render`,
    the report and the report's tolerance analysis describe by default one made mirror (the
    configured job, as machined: the same label in each) and quote its RMS image displacement
    over the used zone per lobe within 1 % of each other; render's comes from the per-pixel
    3-D maps (optics.distortion), the others from every pixel centre of the aligned camera
    (optics.radial). The tolerance analysis states the part it judges (polished for its
    curve's time) apart. Every JSON is strict (no NaN, no inf)."""
    from conftest import run_cli

    cfg = tmp_path / "lens6.toml"
    cfg.write_text(DESIGNS["lens6_px3um_nose04"] + FAST.replace("trials = 24", "trials = 8"))
    c = run_cli("calib", "--config", str(cfg), "--json", "--no-progress", "-o", str(tmp_path / "calib"))
    assert c.returncode == 0, c.stderr
    r = run_cli("render", "--config", str(cfg), "--json", "--no-progress", "--supersample", "1")
    assert r.returncode == 0, r.stderr
    p = run_cli("report", "--config", str(cfg), "--json", "--no-progress", "--no-render", "--workers", "1",
                "-o", str(tmp_path / "out"))
    assert p.returncode == 0, p.stderr
    cal, ren, rep = _strict(c.stdout)["made"][0], _strict(r.stdout), _strict(p.stdout)
    tol = rep["tolerance"]["programs"]["best"]
    labels = {cal["made_mirror"], ren["made_mirror"], rep["mirrors"]["best"]["made_mirror"],
              tol["as_machined_over_zone"]["made_mirror"], rep["made_mirror"]["label"]}
    assert len(labels) == 1 and "as machined" in labels.pop()
    assert "polished" in tol["made_mirror"]["label"] and tol["made_mirror"]["label"] == tol["nominal_over_zone"]["made_mirror"]
    quotes = {"calib": [lb["image_displacement_px"]["rms"] for lb in cal["over_zone"]],
              "render": [lb["image_displacement_px"]["rms"] for lb in ren["lobes"]],
              "report": [lb["image_displacement_px"]["rms"] for lb in rep["mirrors"]["best"]["lobes"]],
              "tolerance": [lb["image_displacement_px"]["rms"] for lb in tol["as_machined_over_zone"]["lobes"]]}
    for k in (0, 1):
        vals = [q[k] for q in quotes.values()]
        assert min(vals) > 0 and max(vals) <= 1.01 * min(vals), quotes


def test_every_lattice_phase_is_polished_with_its_own_recessed_lobe(design_settings):
    """The 6 mm lens's outer lobe is recessed (the design: its junction height above the
    inner's); the lap plans every lattice phase's made part so (the fillet lowers the
    recessed lobe's edge by ~0.2 mm and the wall's sliver can end the proud lobe's samples:
    read at the junction, half the phases were polished as if the inner lobe were recessed)."""
    from lathe_mirror.job import MachiningJob
    from lathe_mirror.polishing import recessed_lobe

    s = design_settings["lens6_px3um_nose04"]
    m = s.mirror()
    zi, zo = m.inner.z(m.r_junction), m.outer.z(m.r_junction)
    assert zo - zi > 10.0  # outer recessed, by the lobes' own equations
    job = MachiningJob.from_settings(s, m, strategy=BEST)
    assert [recessed_lobe(job.but(phase=p / 8).made().profile) for p in range(8)] == [1] * 8


def test_the_seat_tilts_about_the_rim_by_default(design_settings):
    """tolerance.seat_pivot_mm = 0 (the default) puts the seat's pivot on the design's rim
    (the outer rim's height above the pinhole, from the lobe's equation), so a 0.1 deg seat
    tilt of the 6 mm lens's 13 mm mirror moves the pinhole rim x sin(0.1 deg) sideways, not
    the 0.218 mm of the paper's 125 mm; a configured pivot is kept."""
    from lathe_mirror.tolerance.poses import poses
    from lathe_mirror.tolerance.perturb import Trials

    s = design_settings["lens6_px3um_nose04"]
    m = s.mirror()
    rim = float(m.outer.z(m.r_max))
    assert s.tolerance.seat_pivot_mm == 0.0 and s.tolerance.pivot_mm(m) == pytest.approx(rim, abs=1e-12)
    assert dataclasses.replace(s.tolerance, seat_pivot_mm=125.0).pivot_mm(m) == 125.0
    ctx = tolerance_context(m, s, Program.BEST, 0.0)
    assert ctx.settings.seat_pivot_mm == pytest.approx(rim, abs=1e-12)
    tr = dataclasses.replace(Trials.nominal(1, 0.4, 0.0), seat_x=np.array([math.radians(0.1)]))
    origin = poses(tr, ctx.settings.seat_pivot_mm)[0][0]
    assert abs(origin[1]) == pytest.approx(rim * math.sin(math.radians(0.1)), rel=1e-9)


def test_optimize_writes_a_runner_up_that_passes_nominal(tmp_path):
    """The paper camera on a 0.02 mm lattice with a 0.1 mm nose: the best design the search
    finds fails the tolerance verdict nominal (its facets' disparity, NOMINAL_FAILS); the
    command tries the search's runner-up designs and writes the first that passes, saying
    what it replaced and why, with the lower objective it costs (strict JSON). The R10
    objective: the robust one's winner here passes nominal (less blur, its facets finer)."""
    from conftest import run_cli

    cfg = tmp_path / "coarse.toml"
    cfg.write_text("[tool]\nnose_radius = 0.1\n[machine]\nresolution = 0.02\n[toolpath]\ngouge_tolerance = 0.02\n"
                   "[optimize]\nmaxiter = 120\nobjective = \"r10\"\n" + FAST)
    p = run_cli("optimize", "--config", str(cfg), "--json", "--no-progress", "--workers", "1",
                "-o", str(tmp_path / "best.toml"))
    assert p.returncode == 0, p.stderr
    data = _strict(p.stdout)
    check = data["check"]
    assert check["nominal_pass"] and all(v["pass"] for v in check["nominal"].values())
    r = check["replaced"]
    assert r["why"].startswith("the nominal part fails disparity_px (")
    assert r["tried"] and r["tried"][-1]["failing"] == [] and all(t.get("failing", [1]) for t in r["tried"][:-1])
    assert data["best"]["sharp_r10_m"] <= r["objective"]
    written = load(tmp_path / "best.toml")
    assert [lb.r_top for lb in written.lobes] == pytest.approx([lb["r_top"] for lb in data["best"]["lobes"]], rel=1e-9)
