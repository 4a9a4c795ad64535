"""The vectorised 3-D tracer (optics.trace3d) against an independent closed form in 50-digit
decimal arithmetic on the exact lobes, and against the march it replaced on made surfaces,
for a tilted, decentred, raised camera: the paper default and a design that is not (a 6 mm
lens with 3 um pixels, outer lobe recessed)."""

from __future__ import annotations

import math
from decimal import Decimal, getcontext

import numpy as np
import pytest

from conftest import RECESSED_OUTER
from lathe_mirror.config import load
from lathe_mirror.enums import Surface
from lathe_mirror.optics.camera import CameraPose, ray_directions
from lathe_mirror.optics.trace import Fate, trace_pixels, trace_rays
from lathe_mirror.job import named_surface
from lathe_mirror.profile import ExactProfile, LobeSamples, SampledProfile, sample_lobes

POSES = [CameraPose(decentre=(0.05, -0.03), axial_offset=0.1, tilt=(math.radians(0.1), math.radians(-0.06))),
         CameraPose(decentre=(-0.4, 0.25), axial_offset=-0.3, tilt=(math.radians(-1.0), math.radians(0.7)))]


@pytest.fixture(scope="module")
def designs(tmp_path_factory):
    cfg = tmp_path_factory.mktemp("design") / "recessed.toml"
    cfg.write_text(RECESSED_OUTER)
    return {"paper": load(), "recessed": load(cfg)}


def _sensor_sample(camera, n, seed):
    rng = np.random.default_rng(seed)
    w, h = camera.sensor_px
    return np.stack([rng.uniform(-w / 2, w / 2, n), rng.uniform(-h / 2, h / 2, n)], axis=-1)


def _decimal_hit(lobe, o, d):
    """Ray o + s d against the lobe's hyperboloid (z - e)^2 / a^2 - r^2 / b^2 = 1 in 50
    digits: (s on the mirror's sheet z > e, s on the other sheet or None), the hit, the
    reflected unit direction."""
    getcontext().prec = 50
    D = Decimal
    a, b, e = D(lobe.a), D(lobe.b), D(lobe.e)
    ox, oy, oz = (D(float(x)) for x in o)
    dx, dy, dz = (D(float(x)) for x in d)
    A = dz * dz / (a * a) - (dx * dx + dy * dy) / (b * b)
    B = (oz - e) * dz / (a * a) - (ox * dx + oy * dy) / (b * b)
    C = (oz - e) ** 2 / (a * a) - (ox * ox + oy * oy) / (b * b) - 1
    disc = B * B - A * C
    if disc < 0:
        return None
    roots = [(-B - disc.sqrt()) / A, (-B + disc.sqrt()) / A]
    upper = [s for s in roots if s > 0 and oz + s * dz > e]
    lower = [s for s in roots if s > 0 and oz + s * dz < e]
    if not upper:
        return None
    s = min(upper)
    p = (ox + s * dx, oy + s * dy, oz + s * dz)
    # the normal: the gradient of the quadric, toward the camera (-z)
    n = (p[0] / (b * b), p[1] / (b * b), -(p[2] - e) / (a * a))
    nn = (n[0] ** 2 + n[1] ** 2 + n[2] ** 2).sqrt()
    n = tuple(c / nn for c in n)
    dn = dx * n[0] + dy * n[1] + dz * n[2]
    out = (dx - 2 * dn * n[0], dy - 2 * dn * n[1], dz - 2 * dn * n[2])
    return s, (min(lower) if lower else None), np.array([float(c) for c in p]), np.array([float(c) for c in out])


def _decimal_fate(mirror, o, d, hits):
    """The ray's fate from the two hyperboloids in decimal: the inner lobe's sheet hit
    within r_junction; else the wall if the ray reaches r_junction above the outer lobe's
    start; else the outer lobe's hit within the rim; else a miss. (Each lobe is convex and
    every ray climbs faster than it, so each crossing is the only one.)"""
    if d[2] <= 0:
        return Fate.MISS
    inner = _decimal_hit(mirror.lobes[0], o, d)
    if inner is not None and math.hypot(*inner[2][:2]) <= mirror.r_junction:
        return Fate.INNER
    # where the ray leaves the cylinder r = r_junction
    a = d[0] ** 2 + d[1] ** 2
    b = o[0] * d[0] + o[1] * d[1]
    c = o[0] ** 2 + o[1] ** 2 - mirror.r_junction ** 2
    s_j = (-b + math.sqrt(b * b - a * c)) / a
    if o[2] + s_j * d[2] >= mirror.outer.z(mirror.r_junction):
        return Fate.WALL
    outer = _decimal_hit(mirror.lobes[1], o, d)
    if outer is not None and math.hypot(*outer[2][:2]) <= mirror.r_max:
        return Fate.OUTER
    return Fate.MISS


@pytest.mark.parametrize("name", ["paper", "recessed"])
@pytest.mark.parametrize("pose", POSES, ids=["trial", "gross"])
def test_exact_lobes_match_the_decimal_closed_form(designs, name, pose):
    s = designs[name]
    mirror = s.mirror()
    cam = mirror.camera
    exact = ExactProfile(mirror)
    xy = _sensor_sample(cam, 600, seed=3)
    hits = trace_pixels(exact, cam, xy, pose=pose)
    origin, d = ray_directions(cam, xy[:, 0], xy[:, 1], pose)
    assert np.sum(hits.fate == Fate.INNER) > 50 and np.sum(hits.fate == Fate.OUTER) > 50
    fates = np.array([_decimal_fate(mirror, origin, d[i], hits) for i in range(len(d))])
    assert np.array_equal(hits.fate, fates)
    other_sheet_first = 0
    for i in np.nonzero(hits.fate <= Fate.OUTER)[0]:
        s_hit, s_other, p, out = _decimal_hit(mirror.lobes[int(hits.fate[i])], origin, d[i])
        assert np.abs(hits.point[i] - p).max() < 1e-9
        # angle between the unit directions (rad)
        assert np.linalg.norm(np.cross(hits.direction[i], out)) < 1e-12
        other_sheet_first += s_other is not None and s_other < s_hit
    # the trap: the ray crosses the hyperboloid's other sheet first
    assert other_sheet_first > 0.9 * np.sum(hits.fate <= Fate.OUTER)
    # vignetting as the march decides it
    march = trace_rays(exact, origin, d, fast=False, march_steps=1024, chunk=256)
    m = hits.fate == Fate.INNER
    assert np.array_equal(hits.blocked[m], march.blocked[m])


def _made(s, which):
    mirror = s.mirror()
    if which == "spline":  # a profile known only by samples: the general (profile.z) path
        inner, outer = sample_lobes(ExactProfile(mirror), 801)
        bump = lambda lb: LobeSamples(lb.r, lb.z + 2e-4 * np.sin(lb.r * 3.0))  # noqa: E731
        return SampledProfile(bump(inner), bump(outer), r_junction=mirror.r_junction,
                              r_max=mirror.r_max, vertex_z=mirror.vertex_z)
    return named_surface(Surface(which), mirror, s)


@pytest.mark.parametrize("name,which", [("paper", "paper"), ("paper", "best"), ("paper", "uniform528"),
                                        ("recessed", "best"), ("recessed", "spline")])
def test_made_surfaces_match_the_march(designs, name, which):
    """Newton from the quadric's hit against the march and bisection it replaced (with
    fine steps): the same fates and vignetting, the same hits."""
    s = designs[name]
    mirror = s.mirror()
    made = _made(s, which)
    cam = mirror.camera
    xy = _sensor_sample(cam, 2500, seed=5)
    for pose in POSES:
        origin, d = ray_directions(cam, xy[:, 0], xy[:, 1], pose)
        fast = trace_rays(made, origin, d)
        # a fine march (steps of ~0.02 mm in height: it finds the slivers at the step)
        ref = trace_rays(made, origin, d, fast=False, march_steps=1024, chunk=256)
        assert np.array_equal(fast.fate, ref.fate)
        m = fast.fate <= Fate.OUTER
        assert m.sum() > 1200
        assert np.array_equal(fast.blocked[m], ref.blocked[m])
        assert np.abs(fast.point[m] - ref.point[m]).max() < 1e-9
        assert np.abs(fast.direction[m] - ref.direction[m]).max() < 1e-10


def test_chunks_in_threads_match_the_march(designs):
    """A command with two workers traces its chunks in threads (tracing_threads): on a
    non-paper made surface, small chunks across the threads give the march's fates and hits."""
    from lathe_mirror import compute
    from lathe_mirror.optics.trace3d import tracing_threads

    s = designs["recessed"]
    mirror = s.mirror()
    made = _made(s, "best")
    cam = mirror.camera
    xy = _sensor_sample(cam, 2500, seed=7)
    origin, d = ray_directions(cam, xy[:, 0], xy[:, 1], POSES[0])
    ref = trace_rays(made, origin, d, fast=False, march_steps=1024, chunk=256)
    assert tracing_threads() == 1  # serial outside a command's session
    with compute.session(workers=2):
        assert tracing_threads() == 2
        fast = trace_rays(made, origin, d, chunk=64)  # 40 chunks over the threads
    assert np.array_equal(fast.fate, ref.fate)
    m = fast.fate <= Fate.OUTER
    assert m.sum() > 1200 and np.array_equal(fast.blocked[m], ref.blocked[m])
    assert np.abs(fast.point[m] - ref.point[m]).max() < 1e-9


def test_vertex_grid_merges_collinear_runs_within_its_tolerance():
    """The tracer's grid drops the interior vertices of collinear runs (G1 lines offset by
    the nose): its heights and tabulated slopes against np.interp on every original vertex
    (lines, kinks, a cluster of near-equal radii, a vertical step, a gently curved arc
    whose vertices are not collinear)."""
    from lathe_mirror.optics.surface_tables import COLLINEAR_MM, VertexGrid

    r = np.concatenate([np.linspace(0.0, 2.0, 4001), 2.0 + np.array([1e-15, 2e-15, 3e-15]),
                        np.linspace(2.0005, 3.0, 2000), [3.0], np.linspace(3.0005, 4.0, 2000)])
    z = np.where(r <= 2.0, 50.0 + 0.3 * r, 50.6 + 1.7 * (r - 2.0))
    z[-2000:] = 52.5 + 0.05 * (r[-2000:] - 3.0) ** 2  # an arc after a vertical step
    z[-2001] = 52.3  # the step's foot
    slope = np.where(r <= 2.0, 0.3, 1.7)
    slope[-2000:] = 0.1 * (r[-2000:] - 3.0)
    grid = VertexGrid(r, z, slope)
    assert grid.vr.size < 2200  # the lines merged, the arc kept
    q = np.concatenate([np.random.default_rng(1).uniform(0.0, 4.0, 20000), r])
    q = q[(q < 3.0 - 1e-9) | (q > 3.0 + 1e-9)]  # off the step itself
    zg, _ = grid.eval(q)
    assert np.abs(zg - np.interp(q, r, z)).max() <= 2 * COLLINEAR_MM
    assert np.abs(grid.slope_at(q) - np.interp(q, r, slope)).max() < 1e-12
    # a segment found by the grid's cells or its binary search: where np.searchsorted puts it
    j = grid.segment(q)
    assert np.array_equal(j, np.clip(np.searchsorted(grid.vr, q, side="right") - 1, 0, grid.vr.size - 2))


@pytest.mark.parametrize("which", ["best", "paper"])
def test_duplicated_envelope_points_leave_no_ray_to_the_march(designs, which, monkeypatch):
    """An envelope's points duplicated at one radius (heights equal to rounding) are no
    steep feature: on the recessed design's made surfaces no ray goes to the march (before,
    most did), and the fates and hits are the fine march's."""
    import lathe_mirror.optics.trace3d as trace3d

    s = designs["recessed"]
    mirror = s.mirror()
    made = _made(s, which)
    cam = mirror.camera
    xy = _sensor_sample(cam, 2500, seed=11)
    marched, counting, march = _counting_march()

    for pose in POSES:
        origin, d = ray_directions(cam, xy[:, 0], xy[:, 1], pose)
        monkeypatch.setattr(trace3d, "march", counting)
        fast = trace_rays(made, origin, d)
        monkeypatch.setattr(trace3d, "march", march)
        assert sum(marched) == 0
        ref = trace_rays(made, origin, d, fast=False, march_steps=1024, chunk=256)
        assert np.array_equal(fast.fate, ref.fate)
        m = fast.fate <= Fate.OUTER
        assert m.sum() > 1000 and np.abs(fast.point[m] - ref.point[m]).max() < 1e-9


@pytest.mark.parametrize("name,which", [("paper", "paper"), ("paper", "best"), ("recessed", "best")])
def test_made_surface_hits_agree_with_the_march_to_the_root_tolerance(designs, name, which):
    """The made surfaces' hits to ROOT_TOL_MM's order, not just to 1e-9 mm: the one checked
    Newton step per ray neglects the curving of a skew ray's r(s) only where that moves
    the root by less than ROOT_TOL_MM (the decentred pose: without that check, hits were
    3e-10 mm off). Against the march, which refines each ray by Newton on the profile
    itself to ROOT_TOL_MM."""
    s = designs[name]
    mirror = s.mirror()
    made = _made(s, which)
    cam = mirror.camera
    xy = _sensor_sample(cam, 3000, seed=13)
    origin, d = ray_directions(cam, xy[:, 0], xy[:, 1], POSES[1])
    fast = trace_rays(made, origin, d)
    ref = trace_rays(made, origin, d, fast=False, march_steps=1024, chunk=256)
    assert np.array_equal(fast.fate, ref.fate)
    m = fast.fate <= Fate.OUTER
    assert m.sum() > 1500
    assert np.abs(fast.point[m] - ref.point[m]).max() < 1e-11


def test_a_steep_lip_at_the_inner_rim_matches_the_march(designs, monkeypatch):
    """A made surface whose inner lobe rises steeply in its last 0.2 mm (a nose's fillet at
    the step, exaggerated: slope up to 12) on the recessed design: rays near the junction
    cannot out-climb it, so the per-bin classification decides them and sends the few it
    cannot to the march. Fates, hits and vignetting against the fine march's, for pixels
    around the junction's ring."""
    from lathe_mirror.optics import trace3d
    from lathe_mirror.profile import TabulatedProfile

    mirror = designs["recessed"].mirror()
    cam = mirror.camera
    exact = ExactProfile(mirror)
    lobes = []
    for k in (0, 1):
        lo, hi = exact.lobe_range(k)
        r = np.linspace(float(np.nextafter(lo, np.inf)) if k else lo, hi, 6001)
        z, slope = exact.z(r), exact.slope(r)
        if k == 0:
            t = np.maximum(r - (hi - 0.2), 0.0)
            z, slope = z + 30.0 * t * t, slope + 60.0 * t
        lobes.append((r, z, slope))
    made = TabulatedProfile(*lobes, r_junction=exact.r_junction, r_max=exact.r_max, vertex_z=mirror.vertex_z)
    rho = np.linspace(0.0, min(cam.sensor_px) / 2, 400)
    ring = rho[np.argmax(trace_pixels(exact, cam, radii_px=rho).fate != Fate.INNER)]
    rng = np.random.default_rng(3)
    ang, rad = rng.uniform(0, 2 * np.pi, 2000), ring + rng.uniform(-25, 10, 2000)
    marched, counting, march = _counting_march()

    for pose in POSES:
        origin, d = ray_directions(cam, rad * np.cos(ang), rad * np.sin(ang), pose)
        monkeypatch.setattr(trace3d, "march", counting)
        fast = trace_rays(made, origin, d)
        monkeypatch.setattr(trace3d, "march", march)
        ref = trace_rays(made, origin, d, fast=False, march_steps=4096, chunk=256)
        assert np.array_equal(fast.fate, ref.fate)
        m = fast.fate <= Fate.OUTER
        assert np.sum(fast.fate == Fate.WALL) > 10 and m.sum() > 1500
        assert np.array_equal(fast.blocked[m], ref.blocked[m])
        assert np.abs(fast.point[m] - ref.point[m]).max() < 1e-9
    assert sum(marched) > 0  # the general classification ran, the march took its few


def test_no_rays_give_empty_hits(designs):
    mirror = designs["recessed"].mirror()
    hits = trace_rays(ExactProfile(mirror), np.zeros(3), np.zeros((2, 0, 3)))
    assert hits.fate.shape == (2, 0) and hits.point.shape == (2, 0, 3)


def _counting_march():
    """trace3d.march wrapped to record the rays each call marches: (that list, the wrapper,
    the original), for monkeypatch."""
    import lathe_mirror.optics.trace3d as trace3d

    march = trace3d.march
    marched: list[int] = []

    def counting(profile, origin, d, *args, **kw):
        marched.append(len(d))
        return march(profile, origin, d, *args, **kw)

    return marched, counting, march
