"""Plausible image figures (issue 31): no image figure beyond the sensor. A made ray the
exact lobe would image outside its annulus has left the lobe's range and is counted lost
(its own count), never a displacement of thousands of pixels; a polished part's edge band
has its own zone figure."""

from __future__ import annotations

import math

import numpy as np
import pytest

from lathe_mirror.enums import Strategy
from lathe_mirror.job import MachiningJob
from lathe_mirror.optics.distortion import image_displacement
from lathe_mirror.optics.radial import LOBE_RANGE_SLACK_PX, lobe_pixel_radii, radial_figures, trace_lobe
from lathe_mirror.optics.zones import zones_for
from lathe_mirror.profile import ExactProfile, Profile

from test_designs import DESIGNS, load_designs


class RolledRim(Profile):
    """The exact mirror with its outer rim turned up over the last `width` mm by a parabola
    of depth `amp` mm at the rim (a polish's rolled edge, exaggerated)."""

    def __init__(self, mirror, amp: float, width: float):
        self.exact = ExactProfile(mirror)
        super().__init__(r_junction=mirror.r_junction, r_max=mirror.r_max, vertex_z=self.exact.vertex_z)
        self.amp, self.width, self.r0 = amp, width, mirror.r_max - width

    def z(self, r):
        x = np.clip((np.asarray(r, float) - self.r0) / self.width, 0.0, None)
        return self.exact.z(r) + self.amp * x**2

    def slope(self, r):
        x = np.clip((np.asarray(r, float) - self.r0) / self.width, 0.0, None)
        return self.exact.slope(r) + 2.0 * self.amp * x / self.width


def _hand_image_radius(lobe, camera, o_r, o_z):
    """Where the exact lobe images the direction (o_r, o_z), px, written here: the point
    F1 + s (cos phi, sin phi) of the sheet with s = b^2 / (a - e sin phi) (the focal polar
    equation), seen through the pinhole (Eq. 6); inf past the asymptote."""
    phi = np.arctan2(o_z, o_r)
    den = lobe.a - lobe.e * np.sin(phi)
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.where(den > 0, lobe.b**2 / den, np.inf)
        return camera.f / camera.t_pixel * s * np.cos(phi) / (lobe.focus_z + s * np.sin(phi))


def test_a_ray_that_leaves_its_lobe_is_lost_not_displaced(paper_mirror):
    """A rim turned 0.5 mm over its last 0.3 mm: by the closed form above some outer pixels'
    rays would be imaged past the sensor's width; the figures count them lost (the same count
    per pixel and radially) and no displacement exceeds the annulus's width."""
    m = paper_mirror
    prof = RolledRim(m, 0.5, 0.3)
    px = lobe_pixel_radii(m, 1)
    rays = trace_lobe(prof, m, 1, px.radius_px)
    hand = _hand_image_radius(m.outer, m.camera, rays.o_r, rays.o_z)
    naive = np.abs(hand - px.radius_px)[rays.ok]
    assert np.nanmax(np.where(np.isinf(naive), np.nan, naive)) > max(m.camera.sensor_px) or np.isinf(naive).any()
    lo, hi = m.image_radii_px["outer_annulus"]
    outside = rays.ok & ~((hand >= lo - LOBE_RANGE_SLACK_PX) & (hand <= hi + LOBE_RANGE_SLACK_PX))
    expected = int(px.count[outside].sum())
    assert expected > 0
    rad = radial_figures(prof, m, edge_mm=0.5)["lobes"][1]
    assert rad["pixels_left_range"] == expected
    assert rad["left_range_pct"] == pytest.approx(100.0 * expected / px.count.sum(), rel=1e-12)
    assert rad["image_displacement_px"]["max"] <= hi - lo + LOBE_RANGE_SLACK_PX
    # the edge band holds every pixel that left (they all meet the rolled rim)
    assert rad["edge"]["pixels_left_range"] == expected
    assert rad["edge"]["pixels"] + rad["edge"]["pixels_left_range"] <= int(px.count.sum())
    per_pixel = image_displacement(prof, m).figures(edge_mm=0.5)["lobes"][1]
    # per pixel, a ray the rolled rim sends past the rim changes its fate first (lost, not
    # left): the lost pixels are the same set
    assert per_pixel["pixels_lost"] == rad["pixels_excluded"]
    assert 0 < per_pixel["pixels_left_range"] <= expected
    assert per_pixel["image_displacement_px"]["max"] == pytest.approx(rad["image_displacement_px"]["max"], rel=1e-9)
    # the edge band per pixel (render's) as radially: the same pixels, the same figure
    assert per_pixel["edge"]["pixels"] == rad["edge"]["pixels"]
    assert per_pixel["edge"]["image_displacement_px"]["rms"] == pytest.approx(
        rad["edge"]["image_displacement_px"]["rms"], rel=1e-9)


@pytest.fixture(scope="module")
def matrix(tmp_path_factory):
    return load_designs(tmp_path_factory.mktemp("matrix"))


@pytest.mark.parametrize("name", list(DESIGNS))
def test_no_image_figure_beyond_the_sensor(name, matrix):
    """Every matrix design (the README table's winners, fast settings): the paper and the
    best program, as machined and polished 2 h and 8 h (the polishing curve explores up to
    8 h; a long polish turns the rims down): each lobe's largest image displacement lies
    within the lobe's annulus width (plus the half-pixel slack) and so within the sensor; the
    pixels counted sum to the used zone's; the edge band's figure is its own."""
    s = matrix[name]
    m = s.mirror()
    zn = zones_for(s, m)
    job = MachiningJob.from_settings(s, m)
    sensor = min(m.camera.sensor_px)
    for strategy in (Strategy.PAPER, Strategy.ARCS):
        for hours in (0.0, 2.0, 8.0):
            made = job.but(strategy=strategy, polish_time_s=3600.0 * hours).made().profile
            lobes = radial_figures(made, m, zones=zn, edge_mm=s.polish.clear_edge_mm)["lobes"]
            for k, lb in enumerate(lobes):
                lo, hi = m.image_radii_px["inner_disc" if k == 0 else "outer_annulus"]
                biggest = lb["image_displacement_px"]["max"]
                what = f"{name} {strategy.value} {hours} h {lb['name']}"
                assert math.isfinite(biggest), what
                assert biggest <= hi - lo + LOBE_RANGE_SLACK_PX and biggest < sensor, (what, biggest)
                assert lb["edge"]["image_displacement_px"]["max"] <= biggest or lb["edge"]["pixels"] == 0
                assert lb["pixels"] + lb["pixels_excluded"] == zn.lobes[k].used_pixels, what
                assert 0 <= lb["pixels_left_range"] <= lb["pixels_excluded"]
