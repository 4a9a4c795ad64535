"""Distortion figures against closed forms: zero for the exact mirror, twice the normal's
rotation for a known slope error, and the inverse map against the forward tracer."""

from __future__ import annotations

import math

import numpy as np
import pytest

from lathe_mirror.optics.distortion import (distortion_figures, exact_image_point,
                                            image_displacement)
from lathe_mirror.optics.trace import Fate, trace_pixels
from lathe_mirror.profile import ExactProfile, Profile

FIGURES = ("ray_deviation_deg", "image_displacement_px", "viewpoint_spread_mm")


class SlopeError(Profile):
    """The exact surface with its slope raised by eps everywhere (normals tilted, z exact)."""

    def __init__(self, base: Profile, eps: float):
        self.base, self.eps = base, eps
        self.r_junction, self.r_max, self.vertex_z = base.r_junction, base.r_max, base.vertex_z

    def z(self, r):
        return self.base.z(r)

    def slope(self, r):
        return self.base.slope(r) + self.eps


def test_exact_mirror_has_no_distortion(paper_mirror):
    fig = distortion_figures(ExactProfile(paper_mirror), paper_mirror)
    assert [lobe["name"] for lobe in fig["lobes"]] == ["inner", "outer"]
    for lobe in fig["lobes"]:
        assert set(FIGURES) <= set(lobe)
        assert lobe["pixels_lost"] == 0
        assert lobe["image_displacement_px"]["max"] < 1e-9
        assert lobe["viewpoint_spread_mm"]["max"] < 1e-9
        assert lobe["ray_deviation_deg"]["max"] < 1e-9
    # The usable pixels are the pixel centres inside the design's image radii (counted here).
    u = np.arange(1008) + 0.5 - 504
    v = np.arange(1018) + 0.5 - 509
    rho = np.hypot(u[None, :], v[:, None])
    radii = paper_mirror.image_radii_px
    assert fig["lobes"][0]["pixels"] == int((rho <= radii["inner_disc"][1]).sum())
    lo, hi = radii["outer_annulus"]
    assert fig["lobes"][1]["pixels"] == int(((rho > lo) & (rho <= hi)).sum())


def test_slope_error_deviates_rays_by_twice_the_normal_rotation(paper_mirror):
    """Tilting the normal by delta in the meridian plane turns the reflected ray by 2 delta."""
    eps = 1e-3
    exact = ExactProfile(paper_mirror)
    maps = image_displacement(SlopeError(exact, eps), paper_mirror)
    use = maps.usable
    # Each pixel's hit radius on the exact surface (z is unchanged), then the hand formula.
    radii = maps.radius_px[use]
    hits = trace_pixels(exact, paper_mirror.camera, radii_px=radii)
    r = hits.point[:, 0]
    s = exact.slope(r)
    expected = 2.0 * (np.arctan(s + eps) - np.arctan(s))
    assert np.abs(maps.ray_deviation_rad[use] - expected).max() < 1e-12
    fig = maps.figures()
    assert fig["lobes"][0]["ray_deviation_deg"]["max"] == pytest.approx(
        math.degrees(2 * math.atan(eps)), rel=1e-4)  # near the vertex s ~ 0: 2 atan(eps)


def test_image_displacement_inverse_map_agrees_with_forward_trace(paper_mirror):
    """Where the exact lobe images direction u, the forward tracer must send u back out."""
    exact = ExactProfile(paper_mirror)
    made = SlopeError(exact, 4e-3)
    rng = np.random.default_rng(3)
    xy = rng.uniform(-350, 350, size=(3000, 2))
    hm = trace_pixels(made, paper_mirror.camera, xy)
    for k in (0, 1):
        m = (hm.fate == k) & ~np.isnan(hm.direction[:, 0])
        img = exact_image_point(paper_mirror, k, hm.direction[m])
        back = trace_pixels(exact, paper_mirror.camera, img)
        ok = back.fate == k
        assert ok.mean() > 0.95  # a few land in the other lobe's image: not comparable
        assert np.abs(back.direction[ok] - hm.direction[m][ok]).max() < 1e-10


def test_displacement_is_radial_for_an_aligned_camera(paper_mirror):
    maps = image_displacement(SlopeError(ExactProfile(paper_mirror), 2e-3), paper_mirror)
    use = maps.usable
    assert np.allclose(np.abs(maps.radial_px[use]), maps.image_displacement_px[use], atol=1e-9)
    assert np.nanmax(maps.image_displacement_px) > 1.0  # the perturbation is visible


def test_misaligned_camera_uses_the_3d_path(paper_mirror):
    """A camera decentred by 0.1 mm: the exact mirror no longer has a single viewpoint."""
    from lathe_mirror.optics.camera import CameraPose, pixel_centres
    from lathe_mirror.design import Camera

    exact = ExactProfile(paper_mirror)
    cam = Camera(16.0, 0.009 * 8, (126, 127))  # a coarse sensor with the same field of view
    pose = CameraPose(decentre=(0.1, 0.0))
    maps = image_displacement(exact, paper_mirror, cam, pose=pose)
    fig = maps.figures()
    for lobe in fig["lobes"]:
        assert lobe["pixels"] > 1000
        assert lobe["viewpoint_spread_mm"]["max"] > 0.01  # of the order of the decentre
        assert lobe["viewpoint_spread_mm"]["max"] < 0.2
    aligned = image_displacement(exact, paper_mirror, cam).figures()
    assert aligned["lobes"][0]["viewpoint_spread_mm"]["max"] < 1e-9
