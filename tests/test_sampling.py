"""Cost by samples (issue 34): the figures that go pixel by pixel take a stated density of
the sensor (optics.sampling.PIXELS_PER_LOBE, tolerance.samples.SAMPLE_LOBE_PX), and
halving or doubling it moves each sampled figure by less than its stated precision, on the
paper default and on a 12-megapixel design at fast settings.

The stated precisions: the per-pixel image figures (image displacement, ray deviation,
viewpoint spread; RMS and max per lobe) 0.5 % of themselves, their pixel counts 0.1 %; the
Monte Carlo's yield unchanged, the trials' mean RMS image displacement per lobe 1 %, the
median trial's change 2 % (a trial near the outlier cut moves more: up to 15 % at half the
paper's bins). The report's renders and range from the image on a large sensor are taken
over azimuth sectors of full-resolution pixels (optics.sampling.azimuth_sectors): a
sampled render is the full render on the counted pixels (tested to the byte), so its
figures move with the density only by which part of the room the wedges see; the bounds
below are that sampling noise, the spread of each figure across the wedges' phase at the
stated density (measured, in each test's docstring).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from lathe_mirror.config import default_config, merge
from lathe_mirror.enums import Program, Strategy
from lathe_mirror.job import MachiningJob
from lathe_mirror.optics import sampling
from lathe_mirror.optics.distortion import image_displacement
from lathe_mirror.optics.radial import ideal_radius_px
from lathe_mirror.optics.zones import zones_for
from lathe_mirror.settings import from_config
from lathe_mirror.tolerance import samples

#: A 12-megapixel camera (issue 34: f 4.4 mm, 1.55 um pixels, 4000 x 3000) with the paper's
#: lobes scaled to its short side (benchmarks/bench_large_sensor.py's design).
TWELVE_MP = {"camera": {"f": 4.4, "t_pixel": 0.00155, "sensor_px": [4000, 3000]},
             "lobes": {"inner": {"r_pixel": 915.3}, "outer": {"r_pixel": 1500.0}}}
#: Fast settings: few trials and lattice phases, one ray a pixel for the ranging render.
FAST = {"tolerance": {"trials": 24, "lattice_phases": 2}, "stereo": {"supersample": 1}}


@pytest.fixture(scope="module", params=["paper", "12mp"])
def design(request):
    """(name, settings, mirror, the paper program's part as machined, zones)."""
    cfg = merge(default_config(), FAST)
    if request.param == "12mp":
        cfg = merge(cfg, TWELVE_MP)
    settings = from_config(cfg)
    mirror = settings.mirror()
    job = MachiningJob.from_settings(settings, mirror)
    made = job.but(strategy=Strategy.PAPER).made().profile
    return request.param, settings, mirror, made, zones_for(settings, mirror), job


def _count_by_hand(w: int, h: int, mirror) -> int:
    """The larger lobe's pixel centres, every centre of the sensor tested (no radius table)."""
    x = np.arange(w) + 0.5 - w / 2.0
    y = np.arange(h) + 0.5 - h / 2.0
    rho = np.hypot(x[None, :], y[:, None])
    radii = mirror.image_radii_px
    lo, hi = radii["outer_annulus"]
    return max(int(np.count_nonzero(rho < radii["inner_disc"][1])), int(np.count_nonzero((rho > lo) & (rho <= hi))))


def test_the_stride_follows_the_lobes_pixel_count(design):
    name, settings, mirror, *_ = design
    w, h = settings.camera.sensor_px
    n = _count_by_hand(w, h, mirror)
    assert sampling.lobe_pixels(mirror) == n
    # the paper's outer lobe: ~pi (504^2 - 312.5^2) = 491,000 centres, under 640,000: exact
    # the 12-MP outer lobe: ~pi (1500^2 - 976.5^2) = 4.07 M: sqrt(4.07 M / 640,000) = 2.52 -> 3
    assert sampling.pixel_stride(mirror) == {"paper": 1, "12mp": 3}[name]
    assert abs(n - math.pi * (mirror.image_radii_px["outer_annulus"][1] ** 2
                              - mirror.image_radii_px["outer_annulus"][0] ** 2)) < 2e-3 * n


def test_the_sectors_hold_the_stated_pixels(design):
    """azimuth_sectors: none on the paper (every pixel); on the 12-MP design SECTORS wedges
    whose share of the turn is PIXELS_PER_LOBE over the larger lobe's centres, so a centred
    annulus (the outer lobe) has that many centres in them (area: to 0.5 %, counted by hand
    from each centre's angle), and the panorama columns in them are that share of the turn."""
    name, settings, mirror, *_ = design
    sec = sampling.azimuth_sectors(mirror)
    if name == "paper":
        assert sec is None
        return
    n = sampling.lobe_pixels(mirror)
    assert sec.count == sampling.SECTORS and sec.fraction == pytest.approx(sampling.PIXELS_PER_LOBE / n, rel=1e-12)
    w, h = settings.camera.sensor_px
    x = np.arange(w) + 0.5 - w / 2.0
    y = np.arange(h) + 0.5 - h / 2.0
    rho = np.hypot(x[None, :], y[:, None])
    lo, hi = mirror.image_radii_px["outer_annulus"]
    ang = np.degrees(np.arctan2(y[:, None], x[None, :])) % 45.0  # 8 wedges from 0 deg, each sec.width wide
    inside = (ang < np.degrees(sec.width)) & (rho > lo) & (rho <= hi)
    assert abs(int(inside.sum()) - sampling.PIXELS_PER_LOBE) < 5e-3 * sampling.PIXELS_PER_LOBE
    # the same centres as by hand, but for a few on a wedge's edge (rounding of the angle)
    assert np.count_nonzero(sec.pixels((w, h)) != (ang < np.degrees(sec.width))) < 1e-5 * w * h
    cols = sec.columns(7608)
    assert len(cols) == 8 and abs(sum(c.size for c in cols) - sec.fraction * 7608) <= 8
    assert all(np.all(np.diff(c) == 1) for c in cols)


def test_the_usable_annulus_is_the_designs_image_radii(design):
    """usable_annulus (the exact mirror traced once per distinct image radius, spread to the
    pixels) is the closed form of the design's radii, Mirror.image_radii_px: the inner disc
    short of the step's vignetted band, and the outer annulus, every centre tested here."""
    from lathe_mirror.optics.distortion import usable_annulus

    name, settings, mirror, *_ = design
    w, h = settings.camera.sensor_px
    rho = np.hypot((np.arange(w) + 0.5 - w / 2.0)[None, :], (np.arange(h) + 0.5 - h / 2.0)[:, None])
    radii = mirror.image_radii_px
    lo, hi = radii["outer_annulus"]
    want = (rho < radii["inner_blocked_by_step"][0]) | ((rho > lo) & (rho <= hi))
    assert np.array_equal(usable_annulus(mirror), want), name


def _densities(base: int) -> tuple[int, int, int]:
    return base // 2, base, 2 * base


def test_halving_and_doubling_the_pixel_density_keeps_the_image_figures(design):
    name, settings, mirror, made, zn, _ = design
    figs = {n: image_displacement(made, mirror, stride=sampling.pixel_stride(mirror, n)).figures(zn)["lobes"]
            for n in _densities(sampling.PIXELS_PER_LOBE)}
    stated = figs[sampling.PIXELS_PER_LOBE]
    strides = [sampling.pixel_stride(mirror, n) for n in figs]
    assert strides == {"paper": [2, 1, 1], "12mp": [4, 3, 2]}[name]
    for n, lobes in figs.items():
        for lb, ref in zip(lobes, stated):
            assert abs(lb["pixels"] - ref["pixels"]) <= 1e-3 * ref["pixels"], (name, n, lb["name"])
            for fig in ("image_displacement_px", "ray_deviation_deg", "viewpoint_spread_mm"):
                for what in ("rms", "max"):
                    got, want = lb[fig][what], ref[fig][what]
                    assert abs(got - want) <= 5e-3 * want, (name, n, lb["name"], fig, what, got, want)


def test_halving_and_doubling_the_trials_sample_keeps_the_monte_carlo(design, monkeypatch):
    from lathe_mirror.tolerance.runs import monte_carlo

    name, settings, mirror, made, zn, job = design
    base = samples.SAMPLE_LOBE_PX
    out = {}
    for n in (base / 2, base, 2 * base):
        monkeypatch.setattr(samples, "SAMPLE_LOBE_PX", n)
        mc = monte_carlo(mirror, settings, Program.BEST, 2400.0, job=job)
        out[n] = (mc.yield_fraction, np.asarray(mc.figures.calibrated["image_displacement_px_rms"]))
    y0, r0 = out[base]
    for n, (y, r) in out.items():
        assert y == y0, (name, n)
        assert np.all(np.abs(r.mean(axis=0) / r0.mean(axis=0) - 1.0) < 0.01), (name, n)
        change = np.abs(r / r0 - 1.0)
        assert np.median(change) < 0.02, (name, n, np.quantile(change, [0.5, 0.9, 1.0]))


def test_the_paper_samples_every_pixel_and_every_bin(design):
    """The paper default's figures are its exact per-pixel ones: stride 1, and its Monte
    Carlo lobes (71 and 48 bins of 4 px; 281 and 192 px wide) under SAMPLE_LOBE_PX, at the
    default bin and at 1 px; a 12-MP lobe is cut into SAMPLE_LOBE_PX / bin_px bins."""
    from lathe_mirror.optics.radial import lobe_pixel_radii

    name, settings, mirror, made, zn, _ = design
    for bin_px in (settings.tolerance.bin_px, 1.0):
        native = [lobe_pixel_radii(mirror, k, bin_px=bin_px, zones=zn, max_radii=None).radius_px.size for k in (0, 1)]
        got = [samples.pixel_sample(mirror, k, bin_px=bin_px, azimuths=1, zones=zn).u.size for k in (0, 1)]
        if name == "paper":
            assert sampling.pixel_stride(mirror) == 1
            assert got == native
        else:  # 915 and 523 px wide lobes: cut to the stated number
            assert min(native) > samples.SAMPLE_LOBE_PX / bin_px
            assert got == [math.ceil(samples.SAMPLE_LOBE_PX / bin_px)] * 2


def _made(mirror, made):
    from lathe_mirror.profile import ExactProfile

    return {"exact": ExactProfile(mirror), "paper": made}


@pytest.mark.parametrize("design", ["paper"], indirect=True)
def test_a_sampled_render_is_the_full_render_on_its_pixels(design, monkeypatch):
    """The paper's renders cut to sectors (PIXELS_PER_LOBE lowered to 120,000): on the
    counted pixels the images are the full render's byte for byte (the blur's and the SSIM
    window's neighbours traced), black beyond the traced margin, and the difference is the
    full images' over the same pixels (image_difference on the full render)."""
    from lathe_mirror.optics.distortion import usable_annulus
    from lathe_mirror.optics.render import image_difference
    from lathe_mirror.report.analysis import render_mirrors

    name, settings, mirror, made, zn, _ = design
    assert name == "paper"  # the full 12-MP render is the cost being saved
    full, full_fig = render_mirrors(_made(mirror, made), mirror, settings, zn, names=("exact", "paper"))
    monkeypatch.setattr(sampling, "PIXELS_PER_LOBE", 120_000)
    part, fig = render_mirrors(_made(mirror, made), mirror, settings, zn, names=("exact", "paper"))
    sec = sampling.azimuth_sectors(mirror)
    counted = sec.pixels(settings.camera.sensor_px) & usable_annulus(mirror)
    assert 0.2 < counted.sum() / usable_annulus(mirror).sum() < 0.3  # 120,000 of 491,000 centres
    for k in ("exact", "paper"):
        assert np.array_equal(part[k][counted], full[k][counted])
        assert not part[k][~sec.pixels(settings.camera.sensor_px, slack_px=40.0)].any()
    want = image_difference(full["exact"], full["paper"], mask=counted)
    assert fig.against_exact["paper"].rms == pytest.approx(want["rms"], rel=1e-12)
    assert fig.against_exact["paper"].ssim == pytest.approx(want["ssim"], rel=1e-12)
    assert abs(fig.against_exact["paper"].rms / full_fig.against_exact["paper"].rms - 1) < 0.2


#: The 12-MP renders' sampling noise: RMS grey-level difference and SSIM of the paper
#: program's part against the exact, the spread (max - min) over the wedges' phase 0, 1/4,
#: 1/2, 3/4 at the stated density (measured: see the test).
RENDER_RMS_SPREAD = 0.13
RENDER_SSIM_SPREAD = 0.12


@pytest.mark.parametrize("design", ["12mp"], indirect=True)
def test_the_report_renders_of_a_large_sensor_keep_their_figures(design, monkeypatch):
    """The 12-MP renders' difference at half, the stated and double density moves by less
    than its sampling noise (RENDER_*_SPREAD: measured over the wedges' phase 0, 1/4, 1/2,
    3/4 RMS 77.9 / 75.9 / 80.5 / 70.9, 12 % of the phase-0 figure, SSIM 0.333 / 0.433 /
    0.426 / 0.445; half and double density RMS 73.3 and 78.8, SSIM 0.373 and 0.339). The
    binned sensor it replaces read 86.9 / 81.6 / 77.1 and 0.29 / 0.31 / 0.34 at strides
    4 / 3 / 2: a coarser camera's figures, not a sample of this one's."""
    from lathe_mirror.optics.distortion import usable_annulus
    from lathe_mirror.report import analysis
    from lathe_mirror.report.analysis import render_mirrors

    name, settings, mirror, made, zn, _ = design
    assert name == "12mp"  # the paper's renders are per pixel (every pixel)
    # The usable annuli are the design's alone (no density in them): traced once here, not
    # at each density (a 12-MP trace, ~4 s each).
    annulus = usable_annulus(mirror)
    monkeypatch.setattr(analysis, "usable_annulus", lambda m: annulus.copy() if m is mirror else usable_annulus(m))
    base = sampling.PIXELS_PER_LOBE
    got = {}
    for n in _densities(base):
        monkeypatch.setattr(sampling, "PIXELS_PER_LOBE", n)
        images, fig = render_mirrors(_made(mirror, made), mirror, settings, zn, names=("exact", "paper"))
        got[n] = fig.against_exact["paper"]
        assert images["exact"].shape[:2] == (3000, 4000)  # the camera's own pixels
    ref = got[base]
    for n, d in got.items():
        assert abs(d.rms / ref.rms - 1.0) < RENDER_RMS_SPREAD, (n, d, ref)
        assert abs(d.ssim - ref.ssim) < RENDER_SSIM_SPREAD, (n, d, ref)


#: The 12-MP range from the image's sampling noise (exact mirror, fast settings): how far
#: the median range error (relative) and the valid fraction may move with the density, the
#: spread over the wedges' phase at the stated density (tests/test_sampled_range.py: the
#: sample against the whole panorama, -11.6 to +3.4 % over 8 phases).
RANGE_MEDIAN_SPREAD = 0.2
RANGE_VALID_SPREAD = 0.06


@pytest.mark.parametrize("design", ["12mp"], indirect=True)
def test_the_range_from_a_large_sensors_image_keeps_its_figures(design, monkeypatch):
    """The exact mirror's range from the image on the 12-MP design at half, the stated and
    double density: the median range error and the valid fraction move by less than their
    sampling noise (RANGE_*_SPREAD). Against the whole panorama: test_sampled_range.py."""
    from lathe_mirror.report.analysis import ranging_figures

    name, settings, mirror, made, zn, _ = design
    assert name == "12mp"  # the paper's range from the image is over every column
    base = sampling.PIXELS_PER_LOBE
    got = {}
    for n in _densities(base):
        monkeypatch.setattr(sampling, "PIXELS_PER_LOBE", n)
        fig, maps = ranging_figures(_made(mirror, made), mirror, settings, zn, names=("exact",))
        got[n] = fig.mirrors["exact"]
        assert "azimuth sectors" in fig.definition
    ref = got[base]
    for n, f in got.items():
        assert abs(f.range_error_pct.median / ref.range_error_pct.median - 1) < RANGE_MEDIAN_SPREAD, (n, f, ref)
        assert abs(f.valid_fraction - ref.valid_fraction) < RANGE_VALID_SPREAD, (n, f, ref)


def test_a_large_render_is_drawn_from_block_means(monkeypatch):
    """report.plots.drawn_image: an image whose shorter side holds DRAW_SHORT_PX f times is
    drawn as the mean of f x f blocks (rounded half up; the rows and columns past the last
    whole block dropped), counted by hand here; the paper's 1008 x 1018 as it is."""
    from lathe_mirror.report import plots

    paper = np.zeros((1018, 1008, 3), np.uint8)
    assert plots.drawn_image(paper) is paper
    monkeypatch.setattr(plots, "DRAW_SHORT_PX", 2)
    img = np.zeros((5, 7, 3), np.uint8)  # f = 5 // 2 = 2: blocks of rows 0-1, 2-3 and columns 0-1, 2-3, 4-5
    img[0, 0] = [255, 1, 2]  # block (0, 0): 255 / 4 = 63.75 -> 64; 1 / 4 -> 0; (2 + 1) / 4 = 0.75 -> 1
    img[1, 1, 2] = 1
    img[3, 5] = [10, 10, 10]  # block (1, 2): 2.5 -> 3 (half up)
    img[4, :] = img[:, 6] = 200  # past the last whole block: dropped
    want = np.zeros((2, 3, 3), np.uint8)
    want[0, 0] = [64, 0, 1]
    want[1, 2] = [3, 3, 3]
    assert np.array_equal(plots.drawn_image(img), want)


@pytest.mark.parametrize("design", ["paper"], indirect=True)
def test_mirrors_rendered_over_one_sample_are_each_rendered_alone(design):
    """render_images makes the samples' radii once for several profiles: each image is the
    one render_image gives that profile alone (a made mirror between two exact ones, so a
    table left over from the one before would show), at supersample 2 on a wedge."""
    from lathe_mirror.job import scene_for
    from lathe_mirror.optics.render import render_image, render_images
    from lathe_mirror.profile import ExactProfile

    name, settings, mirror, made, *_ = design
    scene = scene_for(settings, mirror)
    px = sampling.AzimuthSectors(1, 0.5, 0.2).pixels(settings.camera.sensor_px)
    profiles = [ExactProfile(mirror), made, ExactProfile(mirror)]
    together = list(render_images(profiles, mirror, scene, supersample=2, pixels=px))
    assert np.array_equal(together[0], together[2]) and not np.array_equal(together[0], together[1])
    for p, img in zip(profiles, together):
        assert np.array_equal(img, render_image(p, mirror, scene, supersample=2, pixels=px))
