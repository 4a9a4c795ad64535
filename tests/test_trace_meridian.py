"""The meridian tracer (blocks of rays, one table search for both polylines, the reflection
in closed form) against a straightforward tracer written here: each lobe's rays by a mask,
the closed form on a design sheet, numpy's binary search and the segment's line on a
polyline, bisection on any other profile, the profile's own slope, the law of reflection
with the unit normal. Random rays (seeded) plus the hard ones: t = 0, the thresholds of
the junction and the rim to the last bit, and rays through the polylines' vertices."""

from __future__ import annotations

import numpy as np
import pytest

from lathe_mirror.enums import Surface
from lathe_mirror.job import named_surface
from lathe_mirror.optics import meridian_roots
from lathe_mirror.optics.camera import pixel_centres
from lathe_mirror.optics.meridian_roots import fate_table
from lathe_mirror.optics.meridian_table import FateTable
from lathe_mirror.optics.rays import polyline_vertices
from lathe_mirror.optics.trace import Fate, meridian_hits, trace_pixels
from lathe_mirror.profile import ExactProfile, LobeSamples, PolylineProfile, Profile, TabulatedProfile
from lathe_mirror.settings import from_config
from test_trace import Shifted


# a profile the tracer knows nothing of (Newton): another one lowered by dz (mm)
Lowered = Shifted


def reference(profile: Profile, t: np.ndarray) -> dict[str, np.ndarray]:
    """Rays r = t z off the profile, the plain way."""
    rj, r_max = profile.r_junction, profile.r_max
    r_out0 = np.nextafter(rj, np.inf)
    zi, zo, zr = (float(profile.z(np.array(x))) for x in (rj, r_out0, r_max))
    inner = t * zi <= rj
    wall = ~inner & (t * zo <= rj)
    outer = ~inner & ~wall & (t * zr <= r_max)
    fate = np.full(t.shape, Fate.MISS, dtype=np.int8)
    fate[inner], fate[wall], fate[outer] = Fate.INNER, Fate.WALL, Fate.OUTER
    r = np.full(t.shape, np.nan)
    for k, mask in ((0, inner), (1, outer)):
        r[mask] = _root(profile, t[mask], k)
    r[outer] = np.maximum(r[outer], r_out0)
    hit = inner | outer
    z = np.full(t.shape, np.nan)
    with np.errstate(divide="ignore", invalid="ignore"):
        z[hit] = np.where(t[hit] > 0, r[hit] / t[hit], profile.z(np.zeros(1))[0])
    s = np.full(t.shape, np.nan)
    s[hit] = profile.slope(r[hit])
    d = np.stack([t, np.ones_like(t)]) / np.sqrt(1 + t * t)
    n = np.stack([s, -np.ones_like(s)]) / np.sqrt(1 + s * s)
    out = d - 2 * (d * n).sum(axis=0) * n
    blocked = np.zeros(t.shape, dtype=bool)
    with np.errstate(divide="ignore", invalid="ignore"):
        z_wall = z + (np.sign(out[0]) * rj - r) * out[1] / out[0]
    blocked[inner] = (out[0][inner] != 0) & (z_wall[inner] > zo)
    return {"fate": fate, "r": r, "z": z, "out_r": out[0], "out_z": out[1], "blocked": blocked}


def _root(profile: Profile, t: np.ndarray, k: int) -> np.ndarray:
    if isinstance(profile, ExactProfile):
        lobe = profile.mirror.lobes[k]  # the upper sheet's root in its stable form
        return t * lobe.b**2 / (lobe.e - lobe.a * np.sqrt(1 + t * t))
    vertices = polyline_vertices(profile, k)
    if vertices is not None:
        rs, zs = vertices
        q = np.maximum.accumulate(rs / zs)
        j = np.clip(np.searchsorted(q, t, side="right") - 1, 0, rs.size - 2)
        m = (zs[j + 1] - zs[j]) / (rs[j + 1] - rs[j])
        return t * (zs[j] - m * rs[j]) / (1 - t * m)
    lo, hi = profile.lobe_range(k)
    lo = np.full(t.shape, lo if k == 0 else np.nextafter(lo, np.inf))
    hi = np.full(t.shape, hi)
    for _ in range(200):  # h(r) = t Z(r) - r decreases on a lobe
        mid = 0.5 * (lo + hi)
        above = t * profile.z(mid) - mid > 0
        lo, hi = np.where(above, mid, lo), np.where(above, hi, mid)
    return 0.5 * (lo + hi)


def hard_rays(profile: Profile, seed: int) -> np.ndarray:
    """Random t over the sensor's range and beyond, t = 0, each fate threshold and its
    neighbours to the last bit, and the t of every polyline vertex."""
    rj, r_max = profile.r_junction, profile.r_max
    edges = [rj / float(profile.z(np.array(rj))), rj / float(profile.z(np.array(np.nextafter(rj, np.inf)))),
             r_max / float(profile.z(np.array(r_max)))]
    near = [np.nextafter(e, d) for e in edges for d in (-np.inf, np.inf)]
    t = [np.random.default_rng(seed).uniform(0, 0.4, 30_000), [0.0], edges, near]
    for k in (0, 1):
        v = polyline_vertices(profile, k)
        if v is not None:
            t.append(v[0] / v[1])
    return np.concatenate(t)


def crowded_polyline(mirror) -> PolylineProfile:
    """The design sampled at random radii with clusters of vertices 1e-12 mm apart, so
    the table search meets buckets holding several keys."""
    rng = np.random.default_rng(3)
    exact = ExactProfile(mirror)
    lobes = []
    for lo, hi in ((0.0, exact.r_junction), (np.nextafter(exact.r_junction, np.inf), exact.r_max)):
        r = np.sort(rng.uniform(lo, hi, 400))
        r = np.unique(np.concatenate([[lo, hi], r, r[::40] + 1e-12, r[::40] + 2e-12]))
        lobes.append(LobeSamples(r, exact.z(r)))
    return PolylineProfile(*lobes, r_junction=exact.r_junction, r_max=exact.r_max, vertex_z=exact.vertex_z)


def stepless_envelope(mirror) -> TabulatedProfile:
    """A tabulated profile (z and slope) whose outer lobe starts at the junction level with
    the inner one (no wall: every ray past the inner lobe meets the outer one), so the
    outer lobe's first segment reaches below its first radius r_out0 and the rays just
    past the junction take the table's general path (their root is moved up to r_out0)."""
    exact = ExactProfile(mirror)
    rj, r_max = exact.r_junction, exact.r_max
    r_in = np.linspace(0.0, rj, 3001)
    r_out = np.linspace(rj, r_max, 2001)
    lift = float(exact.z(np.array(rj))) - float(mirror.lobes[1].z(np.array(rj)))
    inner = (r_in, exact.z(r_in), exact.slope(r_in))
    outer = (r_out, mirror.lobes[1].z(r_out) + lift, mirror.lobes[1].slope(r_out))
    return TabulatedProfile(inner, outer, r_junction=rj, r_max=r_max, vertex_z=exact.vertex_z)


def test_a_stepless_envelope_matches_the_plain_tracer(paper_mirror, monkeypatch):
    """The fate table's general path (a root below the outer lobe's first radius, roots
    rounded off their segment at the vertices) against the plain tracer: fates and
    vignetting ray for ray, hits and directions within 1e-12."""
    monkeypatch.setattr(meridian_roots, "TABLE_MIN_RAYS", 0)  # the table from the first call
    profile = stepless_envelope(paper_mirror)
    t_edge = profile.r_junction / float(profile.z(np.array(profile.r_junction)))
    t = np.concatenate([hard_rays(profile, seed=11), t_edge * (1.0 + np.linspace(-1e-9, 1e-9, 2001))])
    got, want = meridian_hits(profile, t), reference(profile, t)
    assert np.array_equal(got.fate, want["fate"])
    assert not np.any(got.fate == Fate.WALL)
    assert np.array_equal(got.blocked, want["blocked"])
    clamped = (got.fate == Fate.OUTER) & (got.r == np.nextafter(profile.r_junction, np.inf))
    assert clamped.any()  # rays the general path moved up to the outer lobe's first radius
    for key in ("r", "z", "out_r", "out_z"):
        a, b = getattr(got, key), want[key]
        assert np.array_equal(np.isnan(a), np.isnan(b)), key
        assert np.nanmax(np.abs(a - b)) <= 1e-12, key


@pytest.fixture(scope="module")
def surfaces(paper_mirror, paper_config):
    s = from_config(paper_config)
    paper = named_surface(Surface.PAPER, paper_mirror, s)
    return {"exact": ExactProfile(paper_mirror), "uniform528": named_surface(Surface.UNIFORM528, paper_mirror, s),
            "paper": paper, "crowded": crowded_polyline(paper_mirror), "lowered": Lowered(paper, -0.01)}


@pytest.mark.parametrize("name", ["exact", "uniform528", "paper", "crowded", "lowered", "paper, table"])
def test_meridian_hits_match_the_plain_tracer(surfaces, name, monkeypatch):
    """Fates and vignetting the same ray for ray; hits and reflected directions within
    1e-12 (mm, and of a unit vector); 1e-9 mm for the bisected reference of a profile the
    tracer solves by Newton (its stop is 1e-12 mm in r, the slope of z amplifies it).
    "paper, table": the tabulated envelope by its fate table (optics.meridian_table, built
    from the first call here), which gives the polylines' solver's bits."""
    profile = surfaces[name.split(",")[0]]
    t = hard_rays(profile, seed=len(name))
    if name.endswith("table"):
        p = profile  # a new profile, traced first by the polylines' solver (a call of few rays)
        profile = TabulatedProfile(*p.lobes, r_junction=p.r_junction, r_max=p.r_max, vertex_z=p.vertex_z)
        by_polylines = meridian_hits(profile, t)
        monkeypatch.setattr(meridian_roots, "TABLE_MIN_RAYS", 0)
    got, want = meridian_hits(profile, t), reference(profile, t)
    if name.endswith("table"):
        # the table, kept with the profile, is what the second call used
        assert isinstance(fate_table(profile, (0.0, 0.0, 0.0), 0.0), FateTable)
        for key in ("fate", "r", "z", "out_r", "out_z", "blocked"):
            assert getattr(got, key).tobytes() == getattr(by_polylines, key).tobytes(), key
    assert np.array_equal(got.fate, want["fate"])
    assert set(np.unique(got.fate)) == {Fate.INNER, Fate.OUTER, Fate.WALL, Fate.MISS}
    assert np.array_equal(got.blocked, want["blocked"])
    assert got.blocked.any()
    tol = 1e-9 if name == "lowered" else 1e-12
    for key in ("r", "z", "out_r", "out_z"):
        a, b = getattr(got, key), want[key]
        assert np.array_equal(np.isnan(a), np.isnan(b)), key
        assert np.nanmax(np.abs(a - b)) <= tol, key


def test_trace_pixels_matches_the_plain_tracer_in_3d(surfaces, paper_mirror):
    """A window of the sensor around the principal point (the pixel on the axis too): the
    meridian answer turned to each pixel's azimuth, point and direction within 1e-12."""
    cam = paper_mirror.camera
    u, v = pixel_centres(cam, window=(cam.sensor_px[0] // 2 - 300, cam.sensor_px[1] // 2 - 5, 600, 11))
    xy = np.concatenate([np.stack([u[..., 0], v[..., 0]], axis=-1).reshape(-1, 2), [[0.0, 0.0]]])
    for name in ("exact", "paper"):
        hits = trace_pixels(surfaces[name], cam, xy)
        rho = np.hypot(xy[:, 0], xy[:, 1])
        want = reference(surfaces[name], rho * (cam.t_pixel / cam.f))
        safe = np.where(rho > 0, rho, 1.0)
        cos, sin = np.where(rho > 0, xy[:, 0] / safe, 1.0), np.where(rho > 0, xy[:, 1] / safe, 0.0)
        point = np.stack([want["r"] * cos, want["r"] * sin, want["z"]], axis=-1)
        direction = np.stack([want["out_r"] * cos, want["out_r"] * sin, want["out_z"]], axis=-1)
        assert np.array_equal(hits.fate, want["fate"])
        assert np.nanmax(np.abs(hits.point - point)) <= 1e-12
        assert np.nanmax(np.abs(hits.direction - direction)) <= 1e-12
        assert np.array_equal(np.isnan(hits.point), np.isnan(point))
