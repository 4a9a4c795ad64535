"""The report's figures against independent computations (finite differences, the per-pixel
tracer, Table 1, closed forms) and its page and JSON against what they must hold."""

from __future__ import annotations

import copy
import html
import io
import json
import re

import numpy as np
import pytest

from lathe_mirror.settings import from_config
from lathe_mirror.nose_envelope import as_machined
from lathe_mirror.polishing import polish
from lathe_mirror.pipeline import report_figures
from lathe_mirror.report import dumps, render_html, write_report
from lathe_mirror.optics.radial import radial_figures
from lathe_mirror.toolpath import BEST, Strategy, plan_toolpath

from conftest import UNCUTTABLE, UNCUTTABLE_PHRASE, run_cli


#: The module's report: hourly to 10 h (the stereo objective's floor, ~7-8 h, inside), 60
#: trials, one lattice phase, the ranging rendered with one ray a pixel.
SMALL_TOML = ("[polish]\ncurve_points = 11\ncurve_max_s = 36000.0\n"
              "[tolerance]\ntrials = 60\nlattice_phases = 1\n[stereo]\nsupersample = 1\n")


@pytest.fixture(scope="module")
def small_cfg(paper_config):
    cfg = copy.deepcopy(paper_config)
    cfg["polish"]["curve_points"] = 11
    cfg["polish"]["curve_max_s"] = 36000.0
    cfg["tolerance"]["trials"] = 60
    cfg["tolerance"]["lattice_phases"] = 1
    cfg["stereo"]["supersample"] = 1  # the ranging's renders: one ray a pixel
    return cfg


@pytest.fixture(scope="module")
def report(small_cfg):
    return report_figures(from_config(small_cfg), renders=True)


@pytest.fixture(scope="module")
def made(small_cfg, paper_mirror):
    lathe, tool = from_config(small_cfg).machine, from_config(small_cfg).tool
    return {"paper": as_machined(plan_toolpath(paper_mirror, lathe, tool, Strategy.PAPER)),
            "best": as_machined(plan_toolpath(paper_mirror, lathe, tool, BEST))}


def test_design_and_machine_tables(report, paper_mirror, small_cfg):
    f = report.figures
    assert f["design"]["lobes"][0]["c"] == pytest.approx(110.64, abs=0.005)  # Table 1
    assert f["design"]["lobes"][1]["h"] == pytest.approx(123.457, abs=0.0005)
    assert f["machine"]["lathe"]["resolution"] == small_cfg["machine"]["resolution"]
    assert f["machine"]["tool"]["nose_radius"] == small_cfg["tool"]["nose_radius"]
    strategies = [r["strategy"] for r in f["toolpaths"]]
    assert set(strategies) == {s.value for s in Strategy}
    assert all(r["n_points"] <= small_cfg["machine"]["max_points"] for r in f["toolpaths"])


def test_made_mirror_figures_against_independent_computations(report, made, paper_mirror):
    """Each made mirror's figures against a second way of getting them: the slope error
    from finite differences of the made surface against the hyperbola's slope written out
    here (z = e + a sqrt(1 + r^2 / b^2)); the optical figures (1-D radial traces) against
    the report's own per-pixel 2-D tracer figures (optics.distortion, kept alongside)."""
    f = report.figures["mirrors"]
    for name in ("paper", "best"):
        for k, lobe in enumerate(paper_mirror.lobes):
            lb = f[name]["lobes"][k]
            lo = 0.0 if k == 0 else paper_mirror.r_junction
            r = np.linspace(lo, lobe.r_top, 200001)[1:-1]
            s_made = np.gradient(made[name].z(r), r)
            s_exact = lobe.a * r / (lobe.b**2 * np.sqrt(1.0 + (r / lobe.b) ** 2))
            rms = float(np.sqrt(np.mean((np.arctan(s_made) - np.arctan(s_exact)) ** 2)))
            assert lb["slope_error_rad"]["rms"] == pytest.approx(rms, rel=0.03)
            px = lb["optics_distortion"]
            for key in ("image_displacement_px", "ray_deviation_deg", "viewpoint_spread_mm"):
                assert lb[key]["rms"] == pytest.approx(px[key]["rms"], rel=1e-3), (name, k, key)
    for k in (0, 1):
        assert f["exact"]["lobes"][k]["image_displacement_px"]["max"] < 1e-9


def test_polishing_curve_and_polished_mirror(report, made, paper_mirror, small_cfg):
    pol = report.figures["polishing"]
    curve = pol["paper_program"]
    # The objective (the calibrated stereo residual by default) chooses the earliest time
    # within its tolerance of its least value; image displacement would choose earlier.
    assert curve["objective"] == "stereo"
    chosen = {}
    for obj, key in (("stereo", "stereo_residual_pct"), ("image_displacement", "image_displacement_px")):
        v = np.asarray(curve["combined"][key])
        chosen[obj] = int(np.flatnonzero(v <= v.min() * (1 + curve["objective_tolerance"]))[0])
        assert curve["chosen_time_s"][obj] == curve["times_s"][chosen[obj]]
    i = chosen["stereo"]
    assert curve["optimum"]["time_s"] == curve["times_s"][i]
    assert 0 < chosen["image_displacement"] < i < len(curve["times_s"]) - 1 and pol["summary"]["optimum_inside_range"]
    # The polished mirror is the paper program polished for that time, recomputed here in one
    # run (the curve's run stops at every snapshot, so its time steps differ: ~1e-3).
    polished = polish(made["paper"], from_config(small_cfg).polish, curve["optimum"]["time_s"])
    again = radial_figures(polished, paper_mirror)
    for k in (0, 1):
        assert report.figures["mirrors"]["polished"]["lobes"][k]["image_displacement_px"]["rms"] == pytest.approx(
            again["lobes"][k]["image_displacement_px"]["rms"], rel=3e-3)
    # The statement quotes the curve's own numbers (form cost in um, the chosen times in min).
    form_inner = curve["optimum"]["lobes"][0]["form_change_mm"]["rms"] * 1e3
    assert f"{form_inner:.1f} um RMS" in pol["summary"]["statement"]
    assert f"would choose {curve['chosen_time_s']['image_displacement'] / 60:.0f} min" in pol["summary"]["statement"]


def test_depth_error_at_2m_for_the_four_mirrors(report, made, paper_mirror):
    at = report.figures["stereo"]["at_2_m"]
    assert set(at) == {"exact", "paper", "best", "polished"}
    assert at["exact"]["max"] < 1e-6
    assert at["paper"]["rms"] > at["best"]["rms"]  # the 528-point program is the worse one
    # Polished until the calibrated stereo residual stops falling, the facets are gone: no point
    # fails. What depth error is left with the design assumed is the even removal's form (the
    # design carrying that form alone has as much), which calibration absorbs.
    assert at["polished"]["rms"] < 0.5 * at["paper"]["rms"] and at["polished"]["median"] < at["paper"]["median"]
    assert at["polished"]["failed"] == 0 < at["paper"]["failed"] and at["best"]["failed"] == 0
    dec = report.figures["polishing"]["decomposition"]["polished"]
    assert dec["depth_error_pct"]["made"]["rms"] == pytest.approx(at["polished"]["rms"], rel=1e-9)
    assert dec["depth_error_pct"]["form"]["rms"] == pytest.approx(at["polished"]["rms"], rel=0.5)
    assert dec["stereo_residual_pct"]["made"]["rms"] < 0.1 * at["polished"]["rms"]


def test_tolerance_section(report):
    t = report.figures["tolerance"]
    for name, prog in t["programs"].items():
        mc = prog["monte_carlo"]
        passes = mc["per_trial"]["pass"]
        assert mc["yield"] == pytest.approx(sum(passes) / len(passes), abs=1e-15)
        assert report.figures["verdict"][name]["yield"] == mc["yield"]
        # The verdict's nominal numbers are the sensitivity table's nominal case, calibrated.
        nominal = prog["sensitivity"]["nominal"]
        assert prog["verdict"]["checks"]["disparity_px"]["nominal"] == nominal["calibrated"]["disparity_px_p90"]
        lo, hi = mc["yield_wilson95"]
        assert lo <= mc["yield"] <= hi and report.figures["verdict"][name]["yield_wilson95"] == [lo, hi]
    # run and report allocate for the best program: the statement says what to tighten or
    # that nothing needs it, with the yield's interval and trial count
    alloc = t["programs"]["best"]["allocation"]
    assert "95 % CI" in alloc["statement"] and f"{alloc['trials']} trials" in alloc["statement"]
    # The paper program rounds every point to the lattice: a finer controller (0.0025 mm)
    # must give a smaller image displacement than a coarser one (0.0075 mm).
    row = t["programs"]["paper"]["sensitivity"]["rows"][0]
    assert row["parameter"] == "resolution_mm"
    assert (row["minus"]["resolution_mm"], row["plus"]["resolution_mm"]) == pytest.approx((0.0025, 0.0075))
    assert max(row["minus"]["raw"]["image_displacement_px_rms"]) < max(row["plus"]["raw"]["image_displacement_px_rms"])


def test_typed_tolerance_and_polishing_are_the_json(report, tmp_path):
    """The tolerance analysis and the polishing study as typed results (issue 26): their
    to_dict() is what report.json holds; the Monte Carlo's table() is its trials; the
    verdict's interval is Wilson's score interval, worked out here from its closed form."""
    import dataclasses
    import math

    from lathe_mirror.export.files import json_text
    from lathe_mirror.results import PolishingStudy, ToleranceAnalysis

    def ordered(v):  # dicts as (key, value) pairs: equal only in the same key order
        if isinstance(v, dict):
            return [(k, ordered(x)) for k, x in v.items()]
        return [ordered(x) for x in v] if isinstance(v, list) else v

    written = json.loads(write_report(report, tmp_path)["json"].read_text())
    for name, typ in (("tolerance", ToleranceAnalysis), ("polishing", PolishingStudy)):
        result = getattr(report, name)
        assert isinstance(result, typ)
        assert ordered(json.loads(json_text({"x": result.to_dict()}))["x"]) == ordered(written[name])
        assert typ.from_dict(result.to_dict()).to_dict() == result.to_dict()
    z = 1.959963984540054
    for name, prog in report.tolerance.programs.items():
        mc, v = prog.monte_carlo, prog.verdict
        table = mc.table()
        assert len(table) == mc.trials and int(table["pass"].sum()) == mc.passed
        assert table["image_displacement_px_rms_inner"].tolist() == [r[0] for r in mc.per_trial["image_displacement_px_rms"]]
        n, p = v.trials, v.yield_
        centre, half = p + z * z / (2 * n), z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n))
        assert v.yield_wilson95 == pytest.approx(((centre - half) / (1 + z * z / n),
                                                   (centre + half) / (1 + z * z / n)), abs=1e-9)
        assert written["verdict"][name] == written["tolerance"]["programs"][name]["verdict"]
        with pytest.raises(dataclasses.FrozenInstanceError):
            v.nominal_pass = not v.nominal_pass
    best = report.tolerance.programs["best"]
    alloc = best.allocation.table()
    assert list(alloc["parameter"]) == [t.parameter for t in best.allocation.tolerances]
    assert np.allclose(alloc["allocated"], alloc["tolerance"] * alloc["factor"], rtol=1e-12)
    sens = best.sensitivity.table()
    assert len(sens) == 2 * len(best.sensitivity.rows) and set(sens["side"]) == {"minus", "plus"}
    curve = report.polishing.paper_program
    assert curve.table()["time_s"].tolist() == list(curve.times_s)
    assert report.polishing.summary.optimum_time_s == curve.optimum.time_s


def test_page_renders_in_chromium_and_its_figures_decode(report, tmp_path):
    """The report opened by a real browser (headless Chromium): the page parses and
    renders (its DOM dump holds the answer and the tolerance tables), and every embedded
    figure is a PNG that Pillow decodes."""
    import base64
    import subprocess

    from PIL import Image

    from conftest import require_program

    chromium = require_program("chromium")
    paths = write_report(report, tmp_path / "out")
    proc = subprocess.run([chromium, "--headless=new", "--no-sandbox", "--disable-gpu",
                           "--disable-background-networking", "--disable-component-update", "--disable-sync",
                           "--no-first-run", f"--user-data-dir={tmp_path / 'profile'}", "--dump-dom",
                           paths["html"].resolve().as_uri()], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr[-2000:]
    dom = proc.stdout
    assert "<h2>The answer</h2>" in dom and "Monte Carlo yield" in dom and "95 % CI" in dom
    assert "to reach 95 %" in dom and "Inverse sensitivity" in dom and "Allocation to 95 %" in dom
    pngs = re.findall(r"data:image/png;base64,([A-Za-z0-9+/=]+)", dom)
    assert len(pngs) >= 7 and len(pngs) == paths["html"].read_text().count("data:image/png;base64,")
    for b64 in pngs:
        img = Image.open(io.BytesIO(base64.b64decode(b64)))
        img.load()
        assert img.format == "PNG" and min(img.size) > 50


def test_renders_side_by_side(report):
    imgs = report.images
    assert list(imgs) == ["exact", "paper", "best", "polished"]
    for img in imgs.values():
        assert img.shape == (1018, 1008, 3) and img.dtype == np.uint8
    # The paper program's image differs from the exact one more than the best program's.
    diff = report.figures["renders"]["against_exact"]
    key = next(k for k in diff["paper"] if "rms" in k.lower())
    assert diff["paper"][key] > diff["best"][key]


def test_calibration_section_against_the_image_displacement(report, paper_mirror):
    """The design model's reprojection error at 2 m against the image displacement (the same
    error at infinity, optics.radial): a lobe of a made mirror misses its viewpoint by at
    most about a millimetre, which at 2 m shifts a pixel by under 3 % of the error here."""
    cal = report.figures["calibration"]
    assert [lb["name"] for lb in cal["design"]["lobes"]] == ["inner", "outer"]
    for name in ("paper", "best", "polished"):
        for k, lb in enumerate(cal["made"][name]["lobes"]):
            disp = report.figures["mirrors"][name]["lobes"][k]["image_displacement_px"]["rms"]
            assert lb["design"]["reprojection_error_px"]["rms"] == pytest.approx(disp, rel=0.03)
            assert lb["refit"]["reprojection_error_px"]["rms"] <= lb["design"]["reprojection_error_px"]["rms"]
    page = render_html(report)
    outer_best = cal["made"]["best"]["lobes"][1]["refit"]["reprojection_error_px"]
    assert f"{outer_best['rms']:.4f}"[:5] in page  # the table shows the refit's residual


def test_html_is_self_contained_and_json_is_plain(report, tmp_path):
    paths = write_report(report, tmp_path)
    page = paths["html"].read_text(encoding="utf-8")
    assert not re.search(r"(src|href)\s*=\s*['\"]?(https?:|//)", page)
    assert "http://" not in page and "https://" not in page
    assert page.count("data:image/png;base64,") >= 7
    for text in ("Monte Carlo yield", html.escape(report.figures["polishing"]["summary"]["statement"])):
        assert text in page
    data = json.loads(paths["json"].read_text())
    # JSON numbers at their stated precision (export.numbers): a depth error to 12 digits.
    assert data["stereo"]["at_2_m"]["exact"]["rms"] == pytest.approx(
        report.figures["stereo"]["at_2_m"]["exact"]["rms"], rel=1e-11)
    # Same data, same bytes (no timestamps in the PNGs or the JSON).
    assert render_html(report) == page
    assert dumps(report.figures) == paths["json"].read_text()


def test_report_cli_uncuttable_design_leaves_no_output_dir(tmp_path):
    cfg = tmp_path / "recessed.toml"
    cfg.write_text(UNCUTTABLE)
    out = tmp_path / "out" / "report"
    proc = run_cli("report", "--config", str(cfg), "-o", str(out), "--no-render")
    assert proc.returncode == 2, proc.stderr
    assert UNCUTTABLE_PHRASE in proc.stderr and "Traceback" not in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1  # refused before the progress display
    assert not (tmp_path / "out").exists()


def test_report_cli_no_progress_keeps_stderr_empty_and_gives_the_same_json(tmp_path, report):
    """--no-progress (as render's): nothing on stderr on success, the figures on stdout.
    The same config in another process gives the same JSON as this module's report (the
    small config, computed here in-process), but for the stages --no-render skips."""
    cfg = tmp_path / "small.toml"
    cfg.write_text(SMALL_TOML)
    proc = run_cli("report", "--config", str(cfg), "--no-progress", "--no-render", "-o", str(tmp_path / "out"),
                   fresh=True)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert proc.stderr == "" and proc.stdout.strip()
    a = dict(report.figures)
    a.pop("renders", None)
    a.pop("ranging", None)  # ranging renders too: --no-render skips it
    assert (tmp_path / "out" / "report.json").read_text() == dumps(a)

def test_one_sentence_per_headline_and_one_definition_per_figure(report):
    """The headline names the part each answer row judges (its label: program, nose, polish
    time) and whether calibrated, with the scene range of each figure; the calibration table
    puts the image displacement at infinity (section 4's number, the same cell text) beside
    its reprojection at 2 m; report.json says what each shared figure is measured against;
    the blur the renders and the ranging carry is stated per lobe."""
    page = render_html(report)
    f = report.figures
    tol = f["tolerance"]
    calibrated = "after calibration" if tol["spec"]["calibrated"] else "uncalibrated"
    for name, t in tol["programs"].items():
        label = html.escape(t["made_mirror"]["label"])
        minutes = f"polished {t['made_mirror']['polish_time_s'] / 60:g} min"
        assert re.search(f"The answer&#x27;s {name} program row judges {re.escape(label)} .*{minutes}.*{calibrated}"
                         f": its image displacement with the scene at infinity, its disparity and depth error at "
                         f"{tol['spec']['depth_range_m']:g} m", page), name
    assert html.escape(f["made_mirror"]["label"]) in page
    from lathe_mirror.report.cells import fmt

    for name in ("paper", "best", "polished"):
        for lb in f["mirrors"][name]["lobes"]:
            cell = fmt(report.mirrors[name].lobe(lb["name"]).image_displacement_px)
            assert f"<td>{cell}</td>" in page  # in section 4 and again in section 10
            assert page.count(f"<td>{cell}</td>") >= 2
    assert "world points at 2 m</th><th>the same at infinity" in page
    d = f["definitions"]
    assert "against the DESIGN" in d["normal_deviation_mm"] and "at infinity" in d["image_displacement_px"]
    for section in ("renders", "ranging"):
        blur = f[section]["defocus"]
        assert blur["lens"]["f_number"] == 8.0 and [lb["name"] for lb in blur["lobes"]] == ["inner", "outer"]
        assert blur["lobes"][0]["blur_px"]["max"] == pytest.approx(6.64, abs=0.01)  # test_defocus's hand value
    assert "blur circle diameter inner" in page
