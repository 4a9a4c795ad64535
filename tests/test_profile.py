"""Profiles: the exact surface and the sampled ones."""

from __future__ import annotations

import numpy as np
import pytest

from lathe_mirror.profile import (
    ExactProfile,
    LobeSamples,
    PolylineProfile,
    SampledProfile,
    sample_lobes,
)


def test_exact_profile_follows_each_lobe(paper_mirror):
    p = ExactProfile(paper_mirror)
    r = np.array([0.0, 10.0, 20.0, 20.0 + 1e-9, 35.0])
    z = p.z(r)
    # Vertex e1 + a1 from Table 1; the rim heights are Table 1's h.
    assert z[0] == pytest.approx(55.32 + 48.358, abs=2e-3)
    assert z[2] == pytest.approx(115.607, abs=5e-4)
    assert z[4] == pytest.approx(123.457, abs=5e-4)
    assert z[2] - z[3] == pytest.approx(paper_mirror.step, abs=1e-6)
    assert list(p.lobe_index(r)) == [0, 0, 0, 1, 1]
    # Slope against a central difference of z.
    rr = np.linspace(0.5, 34.5, 50)
    rr = rr[np.abs(rr - 20) > 0.01]
    num = (p.z(rr + 1e-6) - p.z(rr - 1e-6)) / 2e-6
    np.testing.assert_allclose(p.slope(rr), num, atol=1e-6)
    n = p.normal(rr)
    np.testing.assert_allclose(np.linalg.norm(n, axis=1), 1.0, atol=1e-15)
    assert np.all(n[:, 1] < 0)  # toward the camera
    np.testing.assert_allclose(n[:, 0] + p.slope(rr) * n[:, 1], 0.0, atol=1e-15)


def test_machine_frame_round_trip(paper_mirror):
    p = ExactProfile(paper_mirror)
    assert p.to_machine_z(p.z(0.0)) == pytest.approx(0.0, abs=1e-12)
    assert p.to_machine_z(p.z(35.0)) == pytest.approx(-(123.457 - 103.678), abs=2e-3)
    z = p.z(np.linspace(0, 35, 7))
    np.testing.assert_allclose(p.from_machine_z(p.to_machine_z(z)), z, atol=1e-12)


def test_polyline_profile_interpolates_linearly():
    inner = LobeSamples(np.array([0.0, 1.0, 2.0]), np.array([0.0, 1.0, 3.0]))
    outer = LobeSamples(np.array([2.0, 4.0]), np.array([1.0, 2.0]))
    p = PolylineProfile(inner, outer, r_junction=2.0, r_max=4.0, vertex_z=0.0)
    np.testing.assert_allclose(p.z(np.array([0.5, 1.5, 2.0, 3.0])), [0.5, 2.0, 3.0, 1.5])
    np.testing.assert_allclose(p.slope(np.array([0.5, 1.5, 3.0])), [1.0, 2.0, 0.5])


def test_sampled_profile_reproduces_a_smooth_surface(paper_mirror):
    exact = ExactProfile(paper_mirror)
    s = SampledProfile(*sample_lobes(exact, 2001), r_junction=exact.r_junction,
                       r_max=exact.r_max, vertex_z=exact.vertex_z)
    r = np.linspace(0, 35, 3001)
    assert np.abs(s.z(r) - exact.z(r)).max() < 1e-9
    assert np.abs(s.slope(r) - exact.slope(r)).max() < 1e-6
