"""The Python API misused as a notebook user would: swapped arguments, strings where numbers
go, numbers out of range, unknown names, objects of the wrong type. Each case must raise an
`lm.Error` (an InputError: wrong input, not a crash) whose message is one line and names
the argument; none may raise a raw AttributeError, TypeError, IndexError, KeyError or
ValueError from inside the code, or run the work first.

Beside the misuses: the same calls made right (a name where an enum goes, "best"), the
result types' short reprs and their round trip, `lm.measure` staying the function, the
Monte Carlo honouring `Settings.compute.scheduler`, and `help(lathe_mirror)` short.
"""

from __future__ import annotations

import dataclasses
import math
import pydoc
import time

import numpy as np
import pytest

import lathe_mirror as lm


@pytest.fixture(scope="module")
def w():
    """The paper default's objects every case draws on (planned once)."""
    s = lm.load()
    m = s.mirror()
    tp = lm.plan(m, s.machine, s.tool, "paper")
    return dict(s=s, m=m, lathe=s.machine, tool=s.tool, tp=tp, exact=lm.ExactProfile(m), cam=m.camera)


def spec(**kw):
    base = dict(name="inner", r_top=20.0, r_pixel=200.0, alpha_deg=5.0)
    base.update(kw)
    return lm.LobeSpec(**base)


#: (id, the call given the fixture's objects, what the message must name)
CASES = [
    # enums and strategies
    ("Strategy-unknown", lambda w: lm.Strategy("fastest"), "Strategy"),
    ("Strategy-number", lambda w: lm.Strategy(3), "Strategy"),
    ("ProgramName-unknown", lambda w: lm.ProgramName("worst"), "Program"),
    ("plan-strategy-unknown", lambda w: lm.plan(w["m"], w["lathe"], w["tool"], "fastest"), "strategy"),
    ("plan-strategy-number", lambda w: lm.plan(w["m"], w["lathe"], w["tool"], 2), "strategy"),
    # the design
    ("LobeSpec-r_top-str", lambda w: spec(r_top="10"), "r_top"),
    ("LobeSpec-r_top-negative", lambda w: spec(r_top=-10.0), "r_top"),
    ("LobeSpec-r_pixel-nan", lambda w: spec(r_pixel=math.nan), "r_pixel"),
    ("LobeSpec-alpha-str", lambda w: spec(alpha_deg="5"), "alpha_deg"),
    ("LobeSpec-e-inf", lambda w: spec(alpha_deg=None, e=math.inf), "lobes.inner.e"),
    ("LobeSpec-name", lambda w: spec(name="middle"), "name"),
    ("Lobe-a-negative", lambda w: lm.Lobe("inner", 20.0, 200.0, 80.0, a=-1.0, b=0.0, e=1.0), "a"),
    ("Lobe-b-zero", lambda w: lm.Lobe("inner", 20.0, 200.0, 80.0, a=1.0, b=0.0, e=1.0), "b"),
    ("Lobe-e-not-eq3", lambda w: lm.Lobe("inner", 20.0, 200.0, 80.0, a=3.0, b=4.0, e=6.0), "e ="),
    ("Lobe-name", lambda w: lm.Lobe(None, 20.0, 200.0, 80.0, a=3.0, b=4.0, e=5.0), "name"),
    ("Camera-f-str", lambda w: lm.Camera(f="16"), "camera.f"),
    ("Camera-f-negative", lambda w: lm.Camera(f=-16.0), "camera.f"),
    ("Camera-sensor-one", lambda w: lm.Camera(sensor_px=(1008,)), "camera.sensor_px"),
    ("mirror_from_specs-swapped", lambda w: lm.mirror_from_specs(w["s"].lobes, w["cam"]), "camera"),
    ("mirror_from_specs-one-lobe", lambda w: lm.mirror_from_specs(w["cam"], (w["s"].lobes[0],)), "lobes"),
    ("mirror_from_specs-order", lambda w: lm.mirror_from_specs(w["cam"], w["s"].lobes[::-1]), "lobes"),
    ("design_mirror-outer-str", lambda w: lm.design_mirror(w["cam"], w["m"].inner, "outer"), "outer"),
    ("design_figures-str", lambda w: lm.design_figures("mirror"), "mirror"),
    # the lathe
    ("Tool-nose-negative", lambda w: lm.Tool(nose_radius=-0.1), "nose_radius"),
    ("Tool-nose-str", lambda w: lm.Tool(nose_radius="0.2"), "nose_radius"),
    ("Lathe-resolution-zero", lambda w: lm.Lathe(resolution=0.0), "resolution"),
    ("Stock-diameter-str", lambda w: lm.Stock(diameter="76"), "diameter"),
    ("plan-swapped-lathe-tool", lambda w: lm.plan(w["m"], w["tool"], w["lathe"]), "lathe"),
    ("plan-mirror-str", lambda w: lm.plan("mirror", w["lathe"], w["tool"]), "mirror"),
    ("plan-max_deviation-negative", lambda w: lm.plan(w["m"], w["lathe"], w["tool"], max_deviation=-0.01),
     "max_deviation"),
    ("plan-max_deviation-str", lambda w: lm.plan(w["m"], w["lathe"], w["tool"], max_deviation="0.01"),
     "max_deviation"),
    ("plan-phase-one", lambda w: lm.plan(w["m"], w["lathe"], w["tool"], phase=1.0), "phase"),
    ("plan-phase-nan", lambda w: lm.plan(w["m"], w["lathe"], w["tool"], phase=math.nan), "phase"),
    ("machine-nose-negative", lambda w: lm.machine(w["tp"], nose_radius=-0.1), "nose_radius"),
    ("machine-nose-str", lambda w: lm.machine(w["tp"], nose_radius="0.2"), "nose_radius"),
    ("machine-mirror", lambda w: lm.machine(w["m"]), "toolpath"),
    ("made_surface-polish-negative", lambda w: lm.made_surface(w["m"], w["lathe"], w["tool"], toolpath=w["tp"],
                                                               polish_time_s=-1.0), "polish_time_s"),
    ("made_surface-nose-zero", lambda w: lm.made_surface(w["m"], w["lathe"], w["tool"], nose_radius=0.0),
     "nose_radius"),
    ("made_surface-swapped", lambda w: lm.made_surface(w["m"], w["tool"], w["lathe"]), "lathe"),
    ("made_surface-strategy", lambda w: lm.made_surface(w["m"], w["lathe"], w["tool"], "fastest"), "strategy"),
    ("made_surface-polish_params", lambda w: lm.made_surface(w["m"], w["lathe"], w["tool"], toolpath=w["tp"],
                                                             polish_params="pitch", polish_time_s=60.0),
     "polish_params"),
    ("MachiningJob-strategy", lambda w: lm.MachiningJob(w["m"], w["lathe"], w["tool"], strategy="fastest"),
     "strategy"),
    ("MachiningJob-polish-negative", lambda w: lm.MachiningJob(w["m"], w["lathe"], w["tool"], polish_time_s=-1.0),
     "polish_time_s"),
    ("MachiningJob-mirror", lambda w: lm.MachiningJob("m", w["lathe"], w["tool"]), "mirror"),
    # polishing
    ("polish-time-negative", lambda w: lm.polish(w["exact"], w["s"].polish, -1.0), "time_s"),
    ("polish-params-str", lambda w: lm.polish(w["exact"], "pitch", 60.0), "params"),
    ("polish-profile-mirror", lambda w: lm.polish(w["m"], w["s"].polish, 60.0), "profile"),
    ("PolishParams-pressure-negative", lambda w: lm.PolishParams(pressure_kpa=-1.0), "pressure_kpa"),
    ("polishing_curve-swapped", lambda w: lm.polishing_curve(w["m"], w["exact"], w["s"].polish), "profile"),
    # optics
    ("design_model-k-2", lambda w: lm.design_model(w["m"], 2), "k"),
    ("design_model-k-name", lambda w: lm.design_model(w["m"], "middle"), "k"),
    ("design_model-mirror", lambda w: lm.design_model("m", 0), "mirror"),
    ("distortion_figures-swapped", lambda w: lm.distortion_figures(w["m"], w["exact"]), "made"),
    ("distortion_figures-camera", lambda w: lm.distortion_figures(w["exact"], w["m"], camera="cam"), "camera"),
    ("image_displacement-swapped", lambda w: lm.image_displacement(w["m"], w["exact"]), "made"),
    ("zones-nose-negative", lambda w: lm.zones(w["m"], -0.2), "nose_mm"),
    ("zones-nose-str", lambda w: lm.zones(w["m"], "0.2"), "nose_mm"),
    ("zones-guard-nan", lambda w: lm.zones(w["m"], 0.2, guard_mm=math.nan), "guard_mm"),
    ("r10-mirror", lambda w: lm.r10("m"), "mirror"),
    ("r10-band", lambda w: lm.r10(w["m"], band=(0.5,)), "band"),
    ("render_image-scene", lambda w: lm.render_image(w["exact"], w["m"], "room"), "scene"),
    ("render_image-supersample", lambda w: lm.render_image(w["exact"], w["m"], lm.build_scene(w["s"].scene),
                                                          supersample=0), "supersample"),
    ("build_scene-spec", lambda w: lm.build_scene("room"), "spec"),
    ("stereo_range-image", lambda w: lm.stereo_range(np.zeros(10), w["m"]), "image"),
    # tolerance
    ("monte_carlo-trials-str", lambda w: lm.monte_carlo(w["s"], trials="200"), "trials"),
    ("monte_carlo-trials-zero", lambda w: lm.monte_carlo(w["s"], trials=0), "trials"),
    ("monte_carlo-trials-float", lambda w: lm.monte_carlo(w["s"], trials=2.5), "trials"),
    ("monte_carlo-seed-negative", lambda w: lm.monte_carlo(w["s"], seed=-1), "seed"),
    ("monte_carlo-polish-negative", lambda w: lm.monte_carlo(w["s"], polish_time_s=-1.0), "polish_time_s"),
    ("monte_carlo-program", lambda w: lm.monte_carlo(w["s"], "worst"), "program"),
    ("monte_carlo-settings-mirror", lambda w: lm.monte_carlo(w["m"]), "settings"),
    ("nominal_polish_time_s-program", lambda w: lm.nominal_polish_time_s(w["s"], "worst"), "program"),
    # settings, files, the shop, results
    ("load-missing-file", lambda w: lm.load("/nonexistent/lathe.toml"), "/nonexistent/lathe.toml"),
    ("load-path-number", lambda w: lm.load(3), "path"),
    ("load-override-unknown-key", lambda w: lm.load(overrides=[("camera.focal", 16.0)]), "camera.focal"),
    ("load-override-bad-value", lambda w: lm.load(overrides=[("camera.f", "long")]), "camera.f"),
    ("load-override-shape", lambda w: lm.load(overrides=["camera.f=16"]), "overrides"),
    ("spec_of-mirror", lambda w: lm.spec_of(w["m"]), "settings"),
    ("spec_of-step-zero", lambda w: lm.spec_of(w["s"], step=0.0), "step"),
    ("shop_program-stock", lambda w: lm.shop_program(w["tp"], "bar"), "stock"),
    ("shop_program-toolpath", lambda w: lm.shop_program(w["m"], w["s"].stock), "toolpath"),
    ("measure-missing-file", lambda w: lm.measure("/nonexistent/trace.csv", w["m"], w["exact"], 0.2), "trace.csv"),
    ("measure-nose-negative", lambda w: lm.measure("t.csv", w["m"], w["exact"], -0.2), "programmed_nose_mm"),
    ("measured_profile-mirror", lambda w: lm.measured_profile("t.csv", "m", nose_radius_mm=0.2), "mirror"),
    ("measured_profile-nose", lambda w: lm.measured_profile("t.csv", w["m"], nose_radius_mm=-1.0), "nose_radius_mm"),
    ("MirrorFigures-from-distortion", lambda w: lm.MirrorFigures.from_dict(
        lm.distortion_figures(w["exact"], w["m"]).to_dict()), "MirrorFigures"),
    ("MirrorFigures-from-str", lambda w: lm.MirrorFigures.from_dict("lobes"), "MirrorFigures"),
    ("DesignFigures-missing", lambda w: lm.DesignFigures.from_dict({}), "DesignFigures"),
]


@pytest.mark.parametrize("call,names", [pytest.param(c, n, id=i) for i, c, n in CASES])
def test_a_misuse_raises_one_line_naming_the_argument(w, call, names):
    t0 = time.monotonic()
    with pytest.raises(lm.Error) as e:
        call(w)
    line = str(e.value)
    assert isinstance(e.value, lm.InputError), type(e.value)
    assert line and "\n" not in line and len(line) < 400, line
    assert names in line, line
    assert time.monotonic() - t0 < 20.0  # refused before the work, not after it


def test_the_cases_are_at_least_sixty():
    assert len(CASES) >= 60


def test_names_where_enums_go(w):
    assert lm.Strategy("best") is lm.Strategy.BEST is lm.Strategy.ARCS
    assert lm.Strategy("PAPER") is lm.Strategy.PAPER and lm.ProgramName("Best") is lm.ProgramName.BEST
    assert lm.plan(w["m"], w["lathe"], w["tool"], "paper").segments == w["tp"].segments


def test_measure_stays_the_function():
    import lathe_mirror.measure.readers  # noqa: F401 - the subpackage loaded, as a notebook cell does
    from lathe_mirror.measure import surface  # noqa: F401

    assert callable(lm.measure) and lm.measure.__name__ == "measure"
    assert lm.measure is lm.measure and lm.measure.__module__ == "lathe_mirror.measure.result"


def test_help_is_short():
    text = pydoc.render_doc(lm, renderer=pydoc.plaintext)
    assert len(text.splitlines()) < 150


def test_reprs_are_short(w):
    made = lm.made_surface(w["m"], w["lathe"], w["tool"], "paper", toolpath=w["tp"])
    job = lm.MachiningJob.from_settings(w["s"], w["m"])
    df = lm.design_figures(w["m"])
    for obj in (w["tp"], made, job, df, w["m"], lm.zones(w["m"], 0.2), w["cam"], lm.spec_of(w["s"])):
        assert "\n" not in repr(obj) and len(repr(obj)) < 400, (type(obj).__name__, len(repr(obj)))
    assert repr(w["tp"]).startswith("Toolpath(paper, ")


def test_settings_programs_and_the_report_echo_in_one_short_line(w):
    """A notebook echoes what a cell returns: every field of Settings runs to kilobytes and
    a shop program's blocks and simulated moves to a hundred, which bury the cell's answer.
    Each is one line under 400 characters. A section names only the fields off their
    declared defaults (what the configuration changes), at most six and how many more."""
    from lathe_mirror.optics.camera import CameraPose

    s = w["s"]
    shop = lm.shop_program(w["tp"], s.stock, s.toolpath)
    for obj in (s, lm.Settings(), s.polish, s.scene, s.tolerance, s.optimize, lm.build_scene(s.scene),
                shop, shop.program, lm.ReportData(design=lm.design_figures(w["m"]))):
        assert "\n" not in repr(obj) and len(repr(obj)) < 400, (type(obj).__name__, len(repr(obj)))
    assert repr(lm.Settings()) == "Settings(defaults)"
    moved = dataclasses.replace(s, camera_pose=CameraPose(axial_offset=1.0),
                                tolerance=dataclasses.replace(s.tolerance, trials=200))
    assert repr(moved) == "Settings(camera_pose.axial_offset=1.0, tolerance.trials=200)"
    assert repr(lm.PolishParams(pressure_kpa=20.0)) == "PolishParams(pressure_kpa=20.0)"
    many = lm.load(overrides=[(f"tolerance.params.{k}", 0.5 * v, "test")
                              for k, v in list(s.tolerance.tolerances.items())[:8]])
    assert repr(many).endswith(", ... 2 more)") and repr(many).count("=") == 6
    assert repr(shop).startswith("ShopProgram('mirror_paper', ")


def test_typed_figures_round_trip_and_name_what_they_are(w):
    df = lm.design_figures(w["m"])
    assert isinstance(df, lm.DesignFigures)
    assert lm.DesignFigures.from_dict(df.to_dict()) == df
    # Table 1's c of mirror 01 and 02 (110.640, 123.440 mm), the paper's numbers
    assert df.to_dict()["lobes"][0]["focal_distance_2e_mm"] == pytest.approx(110.640, abs=5e-4)
    junction = df.to_dict()["junction"]
    # step_mm is the step's height, |Mirror.step|; the sign of Mirror.step (inner minus outer
    # sheet at the junction) says which lobe is recessed
    assert junction["step_mm"] == pytest.approx(abs(w["m"].step), rel=1e-12)
    assert junction["recessed"] == ("inner" if w["m"].step > 0 else "outer")


def test_nan_pixels_are_left_out_and_counted(w):
    """A made mirror cut with a larger nose than programmed (0.4 mm on a 0.2 mm program):
    some outer-lobe rays leave past the exact lobe's asymptote, where the exact mirror
    images nothing; their image displacement is NaN. The figure is given over the finite
    pixels and counts the others, as the test recomputes from the per-pixel maps."""
    made = lm.made_surface(w["m"], w["lathe"], w["tool"], "best", nose_radius=0.4)
    maps = lm.image_displacement(made.profile, w["m"])
    fig = lm.distortion_figures(made.profile, w["m"])
    for k, lobe in enumerate(fig.lobes):
        clear = (maps.lobe == k) & maps.usable & ~maps.blocked
        d = maps.image_displacement_px[clear]
        n_nan = int(np.isnan(d).sum())
        st = lobe.image_displacement_px
        assert (st.nan_excluded or 0) == n_nan
        assert math.isfinite(st.rms) and st.rms == pytest.approx(float(np.sqrt(np.nanmean(d ** 2))), rel=1e-12)
    # the rays past the exact lobe's range are counted lost (pixels_left_range), never a
    # displacement (issue 31): the 0.4 mm nose's outer rim sends thousands of them there
    assert fig.lobe("outer").pixels_left_range > 1000
    table = fig.table()
    assert table["image_displacement_px_nan_excluded"][1] == (fig.lobe("outer").image_displacement_px.nan_excluded or 0)
    # the 1-D shortcut (optics.radial, the report's figures) names its dropped pixels too
    from lathe_mirror.optics.radial import radial_figures

    lobe = radial_figures(made.profile, w["m"])["lobes"][1]
    outer = lobe["image_displacement_px"]
    assert math.isfinite(outer["rms"]) and outer.get("nan_excluded", 0) + lobe["pixels_left_range"] > 1000


def test_monte_carlo_honours_the_scheduler(w):
    """A [compute] scheduler that does not answer is refused before any work (it was
    validated and then ignored)."""
    s = dataclasses.replace(w["s"], compute=dataclasses.replace(w["s"].compute, scheduler="tcp://127.0.0.1:9"))
    t0 = time.monotonic()
    with pytest.raises(lm.InputError, match="127.0.0.1:9"):
        lm.monte_carlo(s, trials=2, polish_time_s=0.0)
    assert time.monotonic() - t0 < 30.0


def test_monte_carlo_table_is_the_csv(w):
    """MonteCarloResult.table(): one row per trial, the columns of the per-trial CSV
    (export.trials, the file `tolerance --csv` writes), read back here with the csv module;
    numbers equal to the CSV's stated precision. Serial ([compute] workers = 1), 4 trials."""
    import csv
    import io

    from lathe_mirror.export.trials import trials_csv

    s = dataclasses.replace(w["s"], compute=dataclasses.replace(w["s"].compute, workers=1))
    res = lm.monte_carlo(s, trials=4, seed=3, polish_time_s=0.0)
    assert len(repr(res)) < 200 and "trials=4" in repr(res)
    table = res.table()
    rows = list(csv.DictReader(io.StringIO(trials_csv([("api", res)]))))
    assert table.shape == (4,) and list(table.dtype.names) == list(rows[0])
    assert table["pass"].mean() == pytest.approx(res.yield_fraction)
    for name in table.dtype.names:
        for got, row in zip(table[name], rows):
            want = row[name]
            if table.dtype[name].kind == "f":
                assert float(got) == pytest.approx(float(want), rel=1e-11, abs=1e-6), name  # 1e-6 px: the coarsest
            elif table.dtype[name].kind == "b":
                assert str(bool(got)).lower() == want.lower() or str(int(got)) == want, (name, got, want)
            else:
                assert str(got) == want, (name, got, want)


def test_overrides_without_a_source():
    """load's overrides as (key, value) pairs or a dict, as a script writes them; a value a
    key refuses still names the key."""
    assert lm.load(overrides=[("camera.f", 12.0)]).camera.f == 12.0
    assert lm.load(overrides={"tool.nose_radius": 0.1}).tool.nose_radius == 0.1
    with pytest.raises(lm.InputError, match="tool.nose_radius"):
        lm.load(overrides={"tool.nose_radius": -0.1})
