"""The Python API as a research user's script drives it (issue 26): every entry point on
a design that is not the paper's, with figures checked against closed forms and against
an independent program (OpenCV's cv2.omnidir), and the same choices the CLI makes."""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pytest

import lathe_mirror as lm
from conftest import RECESSED_OUTER, run_cli

#: A machine-vision camera: 6 mm lens, 3 um pixels, 1280 x 1024 (not the paper's).
CAMERA = lm.Camera(f=6.0, t_pixel=0.003, sensor_px=(1280, 1024), f_number=4.0)
LOBES = (lm.LobeSpec("inner", r_top=12.0, r_pixel=265.0, a_over_b=2.0),
         lm.LobeSpec("outer", r_top=25.0, r_pixel=500.0, alpha_deg=5.0))


@pytest.fixture(scope="module")
def settings(tmp_path_factory):
    path = tmp_path_factory.mktemp("cfg") / "recessed.toml"
    path.write_text(RECESSED_OUTER)
    return lm.load(path)


def test_design_for_another_camera_meets_eq6_and_its_foci():
    mirror = lm.mirror_from_specs(CAMERA, LOBES)
    for lobe, spec in zip((mirror.inner, mirror.outer), LOBES):
        h = CAMERA.f * spec.r_top / (CAMERA.t_pixel * spec.r_pixel)   # Eq. 6
        assert lobe.h == pytest.approx(h, rel=1e-12)
        # the rim lies on the hyperbola (z - e)^2 / a^2 - r^2 / b^2 = 1, foci 0 and 2e
        assert (h - lobe.e) ** 2 / lobe.a**2 - spec.r_top**2 / lobe.b**2 == pytest.approx(1.0, abs=1e-12)
        assert lobe.e == pytest.approx(math.hypot(lobe.a, lobe.b), rel=1e-14)
    assert mirror.inner.a / mirror.inner.b == pytest.approx(2.0, rel=1e-12)


def test_an_impossible_design_raises_what_the_config_says(settings, tmp_path):
    bad = dataclasses.replace(settings.lobes[0], r_pixel=900.0)   # outside a 1024 px sensor
    with pytest.raises(lm.Error) as from_api:
        dataclasses.replace(settings, lobes=(bad, settings.lobes[1]))
    cfg = tmp_path / "bad.toml"
    cfg.write_text(RECESSED_OUTER.replace("r_pixel = 265.0", "r_pixel = 900.0"))
    with pytest.raises(lm.Error) as from_config:
        lm.load(cfg)
    assert str(from_api.value) == str(from_config.value)
    assert "lobes.inner.r_pixel" in str(from_api.value)


def test_camera_model_projects_as_opencv_omnidir(settings):
    cv2 = pytest.importorskip("cv2")
    mirror = settings.mirror()
    rng = np.random.default_rng(7)
    for k in (0, 1):
        model = lm.design_model(mirror, k)
        pts = rng.normal(size=(200, 3)) * [800.0, 800.0, 300.0] + [0.0, 0.0, 400.0]
        ours = model.project(pts)
        theirs, _ = cv2.omnidir.projectPoints(pts.reshape(-1, 1, 3), np.zeros(3), np.zeros(3),
                                              model.camera_matrix, float(model.xi), model.distortion)
        ok = np.isfinite(ours).all(axis=1)
        assert ok.mean() > 0.5
        np.testing.assert_allclose(ours[ok], theirs.reshape(-1, 2)[ok], atol=1e-8)
        # the unified model's closed forms (ARCHITECTURE.md): xi and gamma from a, e
        lobe = (mirror.inner, mirror.outer)[k]
        assert model.xi == pytest.approx(2 * lobe.a * lobe.e / (lobe.a**2 + lobe.e**2), rel=1e-12)
        assert model.fu == pytest.approx(CAMERA.f / CAMERA.t_pixel * lobe.b**2 / (lobe.a**2 + lobe.e**2),
                                         rel=1e-12)


def test_nose_sweep_keeps_the_used_zone_within_half_a_pixel(settings):
    """The programs compensate the nose: on the used zone (the designed annuli less the
    step's shadow and the ring the nose cannot reach) the as-machined image stays within
    issue 5's 0.5 px RMS for every nose the junction admits; the unreachable ring, on the
    recessed outer lobe's inner edge, widens in proportion to the nose."""
    mirror = settings.mirror()
    widths = []
    for nose in (0.1, 0.2, 0.4):
        tool = dataclasses.replace(settings.tool, nose_radius=nose)
        made = lm.made_surface(mirror, settings.machine, tool, lm.Strategy.BEST,
                               max_deviation=settings.toolpath.max_deviation)
        assert f"{nose:g} mm nose" in made.source
        maps = lm.image_displacement(made.profile, mirror)
        zones = lm.zones(mirror, nose)
        assert zones.recessed == "outer"
        for k, lobe in enumerate(zones.lobes):
            lo, hi = lobe.used_px
            used = (maps.lobe == k) & maps.usable & (maps.radius_px >= lo) & (maps.radius_px <= hi)
            rms = float(np.sqrt(np.mean(maps.image_displacement_px[used] ** 2)))
            assert used.sum() > 0.5 * lobe.used_pixels and rms < 0.5, (nose, lobe.name, rms)
        widths.append(zones.fillet.fillet_width_mm)
    assert widths[1] == pytest.approx(2 * widths[0], rel=1e-9)
    assert widths[2] == pytest.approx(4 * widths[0], rel=1e-9)


def test_render_of_another_camera_is_dark_only_off_the_mirror(settings):
    mirror = settings.mirror()
    grey = (0.9, 0.9, 0.9, 0.3, 0.3, 0.3)   # no black square: black is the colour of a miss
    room = dataclasses.replace(settings.scene, floor_colours=grey, x_wall_colours=grey, y_wall_colours=grey)
    scene = lm.build_scene(room, mirror_top=max(mirror.inner.h, mirror.outer.h),
                           mirror_radius=mirror.outer.r_top)
    img = lm.render_image(lm.ExactProfile(mirror), mirror, scene)
    w, h = CAMERA.sensor_px
    assert img.shape == (h, w, 3) and img.dtype == np.uint8
    v, u = np.mgrid[0:h, 0:w]
    rad = np.hypot(u - (w - 1) / 2, v - (h - 1) / 2)
    lit = img.max(axis=2) > 0
    # beyond the outer rim's image radius (Eq. 6's r_pixel) no ray meets the mirror
    assert not lit[rad > mirror.outer.r_pixel + 1.5].any()
    assert lit[rad < mirror.inner.r_pixel - 2].mean() > 0.99


def test_monte_carlo_from_a_script_matches_the_command(tmp_path):
    """lm.monte_carlo chooses the polishing time and reads trials= and seed= as the
    command does: the same yield as `tolerance --trials --seed` in another process."""
    cfg = tmp_path / "recessed.toml"
    cfg.write_text(RECESSED_OUTER + '[tolerance]\nprograms = ["best"]\nlattice_phases = 2\n'
                   "nose_step_mm = 0.01\n")
    settings = lm.load(cfg)
    mc = lm.monte_carlo(settings, "best", trials=100, seed=5)
    assert mc.seed == 5 and len(mc.pass_all) == 100 and 0.0 <= mc.yield_fraction <= 1.0
    proc = run_cli("tolerance", "--config", str(cfg), "--trials", "100", "--seed", "5", "--json",
                   "--no-progress")
    assert proc.returncode == 0, proc.stderr
    cli = json.loads(proc.stdout)["programs"]["best"]["monte_carlo"]
    assert cli["yield"] == pytest.approx(mc.yield_fraction, abs=1e-12)
    with pytest.raises(lm.InputError, match="tolerance.trials"):
        lm.monte_carlo(settings, trials=0)
