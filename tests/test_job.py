"""The machining job: one object built from the settings that every command, the report
and the tolerance analysis take (issue 26 item 1; issue 20 "one made mirror")."""

from __future__ import annotations

import json

import numpy as np
import pytest

from conftest import run_cli
from lathe_mirror.config import load
from lathe_mirror.enums import BEST, Program, Strategy, Surface
from lathe_mirror.errors import InputError
from lathe_mirror.job import MachiningJob, check_program, named_surface, plan
from lathe_mirror.polishing import compensated_mirror
from lathe_mirror.report.analysis import strategy_table
from lathe_mirror.shop.programs import shop_programs
from lathe_mirror.tolerance.runs import tolerance_context

#: Issue 26's config: a 22-point controller that can hold the profile only within 0.05 mm.
SHORT_MEMORY = [("machine.max_points", 22, "test"), ("toolpath.max_deviation", 0.05, "test"),
                ("toolpath.gouge_tolerance", 0.1, "test"), ("tolerance.trials", 4, "test"),
                ("tolerance.lattice_phases", 2, "test")]


def test_a_program_name_maps_to_one_strategy():
    assert Program.BEST.strategy is BEST is Strategy.ARCS
    assert Program.PAPER.strategy is Strategy.PAPER
    assert Surface.POLISHED.strategy is Strategy.PAPER
    assert Surface.BEST.strategy is BEST
    assert Surface.LATTICE.strategy is Strategy.LATTICE
    assert Surface.EXACT.strategy is None and Surface.MADE.strategy is None


def test_the_configured_deviation_holds_in_every_stage(tmp_path):
    """Issue 26's repro: `toolpath` accepted the config while the report's and the Monte
    Carlo's plans used 0.01 mm and refused it ("need at least 25 points")."""
    toml = tmp_path / "short.toml"
    toml.write_text("[machine]\nmax_points = 22\n[toolpath]\nmax_deviation = 0.05\ngouge_tolerance = 0.1\n")
    res = run_cli("toolpath", "--config", str(toml), "--json", "-o", str(tmp_path / "tp"))
    assert res.returncode == 0, res.stderr
    n_cli = {p["strategy"]: p["n_points"] for p in _programs(json.loads(res.stdout))}

    settings = load(overrides=SHORT_MEMORY)
    mirror = settings.mirror()
    # The default plan (0.01 mm) cannot hold this profile in 22 points: the case is real.
    with pytest.raises(InputError, match="max_deviation"):
        plan(mirror, settings.machine, settings.tool, BEST)
    job = MachiningJob.from_settings(settings, mirror)
    assert job.max_deviation == 0.05 and job.gouge_tolerance == 0.1
    made, _, table = strategy_table(job)  # the report's toolpaths and made mirrors
    rows = {row.strategy: row for row in table}
    for name, n in n_cli.items():
        assert rows[name].n_points == n <= 22
    ctx = tolerance_context(mirror, settings, Program.BEST, 600.0, job=job)  # every lattice phase cut
    assert ctx.nominal_time_s == 600.0
    assert check_program(settings, mirror, Surface.BEST).n_points == n_cli["arcs"]


def _programs(out: dict) -> list[dict]:
    """The toolpath command's programs (strategy, n_points) from its JSON."""
    progs = out["programs"] if "programs" in out else [out]
    return [{"strategy": p.get("strategy", p.get("toolpath", {}).get("strategy")),
             "n_points": p.get("n_points", p.get("toolpath", {}).get("n_points"))} for p in progs]


def test_precompensated_report_mirror_is_the_programs_part():
    """With polish.precompensate the report's made mirrors are cut by the programs written
    as G-code (on the design lowered by the polish's allowance), not by the design's."""
    settings = load(overrides=[("polish.precompensate", True, "test"), ("tool.nose_radius", 0.4, "test")])
    mirror = settings.mirror()
    job = MachiningJob.from_settings(settings, mirror)
    made, _, _ = strategy_table(job)
    shops = {s.program.name: s for s in shop_programs(settings, mirror)}
    r = np.linspace(0.5, mirror.r_max - 0.5, 3001)
    for key, strategy in (("paper", Strategy.PAPER), ("best", BEST)):
        program_tp = next(s for name, s in shops.items() if name == f"mirror_{strategy.value}")
        # the G-code's finishing points are the report part's programmed points
        report_tp = job.but(strategy=strategy).toolpath
        assert np.array_equal(np.asarray(report_tp.points()), np.asarray(program_tp.program.toolpath.points()))
        # and they are not the design's program: lowered by the allowance (compensated_mirror)
        on_design = plan(mirror, settings.machine, settings.tool, strategy)
        plain = job.but(strategy=strategy)
        lowered = made[key].z(r) - MachiningJob(mirror, plain.lathe, plain.tool, strategy).made().profile.z(r)
        target = compensated_mirror(mirror, settings.polish, settings.polish.time_s)
        allowance = np.concatenate([target.lobes[0].offset(r[r <= mirror.r_junction]),
                                    target.lobes[1].offset(r[r > mirror.r_junction])])
        inside = (r > 1.0) & (np.abs(r - mirror.r_junction) > 1.0) & (r < mirror.r_max - 1.0)
        assert np.max(np.abs(allowance[inside])) > 5e-4  # the allowance is worth a test
        # the two parts differ by the allowance: each program lies within max_deviation
        # (0.01 mm) of its own target, so within twice that of each other's offset
        gap = np.abs(lowered[inside]) - np.abs(allowance[inside])
        assert np.max(np.abs(gap)) < 2 * settings.toolpath.max_deviation
        assert 0.9 < np.median(np.abs(lowered[inside]) / np.abs(allowance[inside])) < 1.1
        assert on_design.n_points > 0


def test_the_made_mirror_is_named_and_labelled():
    """The made mirror (Surface.MADE) is the configured job's part: the [toolpath]
    strategy cut by the [tool] nose; its label says which part it is."""
    settings = load(overrides=[("tool.nose_radius", 0.4, "test")])
    mirror = settings.mirror()
    job = MachiningJob.from_settings(settings, mirror)
    assert job.label == "arcs program (best), nose 0.4 mm, lattice 0.005 mm, as machined"
    assert job.but(polish_time_s=7200.0).label.endswith("polished 120 min")
    made = named_surface(Surface.MADE, mirror, settings)
    best = named_surface(Surface.BEST, mirror, settings, nose_radius=0.4)  # as machined, 0.4 mm nose
    r = np.linspace(0.1, mirror.r_max - 0.1, 2001)
    assert np.allclose(made.z(r), best.z(r), atol=1e-12, equal_nan=True)
    contour = named_surface(Surface.BEST, mirror, settings)  # the sharp programmed contour differs
    assert np.nanmax(np.abs(contour.z(r) - made.z(r))) > 1e-3


def test_calib_render_and_report_quote_one_image_displacement(tmp_path):
    """Issue 20: on the paper camera cut with a 0.4 mm nose (not the paper's tool), `calib`
    and `render` by default and the report's figures of its best mirror describe one part
    (labelled alike) and quote the same image displacement over the same zones, to 1 %:
    render from its per-pixel 2-D trace (optics.distortion), calib and the report from
    the 1-D radial trace (optics.radial)."""
    from lathe_mirror.optics.zones import zones_for
    from lathe_mirror.report.analysis import mirror_figures

    toml = tmp_path / "nose04.toml"
    toml.write_text("[tool]\nnose_radius = 0.4\n")
    calib = run_cli("calib", "--config", str(toml), "-o", str(tmp_path / "calib"), "--json", "--no-progress")
    assert calib.returncode == 0, calib.stderr
    render = run_cli("render", "--config", str(toml), "--json", "--no-progress")
    assert render.returncode == 0, render.stderr
    c = json.loads(calib.stdout)["made"][0]
    r = json.loads(render.stdout)
    settings = load(toml)
    mirror = settings.mirror()
    job = MachiningJob.from_settings(settings, mirror)
    made, _, _ = strategy_table(job)  # the report's made mirrors
    report = mirror_figures(made["best"], mirror, zones_for(settings, mirror))
    label = "arcs program (best), nose 0.4 mm, lattice 0.005 mm, as machined"
    assert c["made_mirror"] == r["made_mirror"] == label == job.but(strategy=BEST).label
    for k in (0, 1):
        rep = report.lobes[k].image_displacement_px.rms
        assert rep > 0.01
        assert c["image_displacement_px"][k]["rms"] == pytest.approx(rep, rel=0.01)
        assert r["lobes"][k]["image_displacement_px"]["rms"] == pytest.approx(rep, rel=0.01)
        for end in ("min", "max"):  # the same zone (JSON carries 1e-6 px)
            assert r["lobes"][k]["zone_px"][end] == pytest.approx(getattr(report.lobes[k].zone_px, end), abs=1e-5)
