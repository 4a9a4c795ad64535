"""STL of the mirror: watertight, the expected volume, facets within the tolerance."""

from __future__ import annotations

import io

import numpy as np
import pytest
import trimesh

from lathe_mirror.body import BodySpec, design_meridian
from lathe_mirror.export.mesh import stl_bytes
from lathe_mirror.profile import ExactProfile

from test_cad_body import integrated_volume


@pytest.mark.parametrize("tol", [0.05, 0.01])
def test_stl_is_watertight_with_the_expected_volume(paper_mirror, tol):
    spec = BodySpec()
    data = stl_bytes(design_meridian(paper_mirror, spec), tol)
    mesh = trimesh.load(io.BytesIO(data), file_type="stl", validate=True)
    assert mesh.is_watertight and mesh.is_winding_consistent
    assert mesh.volume > 0  # outward normals
    exact = integrated_volume(paper_mirror, spec)
    # Facets within tol of the surface: the volume can differ by at most tol x area.
    assert abs(mesh.volume - exact) <= tol * mesh.area
    # ... and it is not exact by accident: chords cut inside the convex face
    assert mesh.volume < exact


def test_facets_lie_within_the_tolerance_of_the_exact_face(paper_mirror):
    """Triangle centroids of the reflective face (away from the step wall) lie within
    tol of the exact lobe, measured vertically (which bounds the normal distance)."""
    tol = 0.02
    data = stl_bytes(design_meridian(paper_mirror, BodySpec()), tol)
    mesh = trimesh.load(io.BytesIO(data), file_type="stl", validate=True)
    c = mesh.triangles_center
    rho = np.hypot(c[:, 0], c[:, 1])
    prof = ExactProfile(paper_mirror)
    zm = prof.to_machine_z(prof.z(rho))
    face = (rho < 34.9) & (np.abs(rho - 20.0) > 0.5) & (np.abs(c[:, 2] - zm) < 1.0)
    assert face.sum() > 1000
    dev = np.abs(c[face, 2] - zm[face])
    assert dev.max() <= tol
    assert dev.max() > tol / 20  # the tolerance is used, not wildly over-refined


def test_finer_tolerance_costs_more_triangles(paper_mirror):
    """The cost the docs state: triangles grow about as 1 / tolerance (chords of the
    meridian and of the circle each as tolerance^-1/2): a decade finer, ~10x more.
    Binary STL: 84 header bytes, then 50 bytes a triangle."""
    mer = design_meridian(paper_mirror, BodySpec())
    n = [(len(stl_bytes(mer, tol)) - 84) / 50 for tol in (0.1, 0.01)]
    assert all(k == int(k) for k in n)
    assert 5 < n[1] / n[0] < 15
