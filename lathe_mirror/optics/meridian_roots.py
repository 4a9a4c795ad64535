"""The meridian tracer's roots: where camera rays r = t z meet each lobe of a profile, and
the slope dZ/dr there, for a block of rays at once (optics.trace's module doc gives the
geometry). The fastest exact solver the profile allows: both lobes' hyperbolic sheets in
closed form; both lobes' polylines by one bucketed table search; else lobe by lobe (the
segment, or bracketed Newton to ROOT_TOL_MM on any other profile).

A solver is called with the rays' t, sqrt(1 + t^2), their Fate codes (intp) and the inner
lobe's mask, and returns r (NaN off the lobes; on the outer lobe at least r_min) and the
slope there. Camera frame, mm.
"""

from __future__ import annotations

import weakref

import numpy as np

from ..design import Lobe
from ..profile import ExactProfile, Profile, TabulatedProfile
from .meridian_table import FateTable
from .rays import ROOT_TOL_MM, Fate, polyline_vertices

__all__ = ["TABLE_MIN_RAYS", "fate_table", "lobe_solver", "per_fate"]


def per_fate(inner: float, outer: float) -> np.ndarray:
    """A lobe constant per Fate code (INNER, OUTER, WALL, MISS): NaN off the lobes, so
    whatever is computed from it for a wall or a missed ray is NaN."""
    return np.array([inner, outer, np.nan, np.nan])


def lobe_solver(profile: Profile, r_min: np.ndarray, t_in: float):
    """The fastest exact solver the profile allows: both lobes' hyperbolic sheets in closed
    form, both lobes' polylines by one table search, else lobe by lobe (Newton)."""
    sheets = profile.mirror.lobes if isinstance(profile, ExactProfile) else (None, None)
    if all(type(x) is Lobe for x in sheets) and type(profile).slope is ExactProfile.slope:
        return _Sheets(sheets, r_min)
    lobes = _polyline_lobes(profile, t_in)
    if lobes is not None:
        return _Polylines(profile, lobes, r_min)
    return _ByLobe(profile, r_min)


class _Sheets:
    """Rays r = t z meet the upper sheet (z - e)^2 / a^2 - r^2 / b^2 = 1 at
    z = b^2 / (e - a sqrt(1 + t^2)), the stable root of A z^2 - 2 e z + b^2 = 0. There
    dZ/dr = a r / (b^2 sqrt(1 + r^2 / b^2)) = (a / b)^2 r / (z - e) (on the sheet,
    sqrt(1 + r^2 / b^2) = (z - e) / a)."""

    def __init__(self, lobes: tuple[Lobe, Lobe], r_min: np.ndarray):
        i, o = lobes
        self.b2, self.e, self.a = (per_fate(x, y) for x, y in ((i.b**2, o.b**2), (i.e, o.e), (i.a, o.a)))
        self.k = per_fate((i.a / i.b) ** 2, (o.a / o.b) ** 2)
        self.r_min = r_min

    def __call__(self, t: np.ndarray, norm_d: np.ndarray, lobe: np.ndarray, inner: np.ndarray):
        e = self.e.take(lobe)
        z = self.a.take(lobe)
        z *= norm_d
        np.subtract(e, z, out=z)
        np.divide(self.b2.take(lobe), z, out=z)
        r = z * t
        np.maximum(r, self.r_min.take(lobe), out=r)
        z -= e
        s = self.k.take(lobe)
        s *= r
        s /= z
        return r, s


class _Polylines:
    """Both lobes' polylines (vertices rs, zs) as one table of segments, inner then outer.
    On a segment z = zs_j + m (r - rs_j), so the ray r = t z meets it at
    r = t (zs_j - m rs_j) / (1 - t m). A ray's segment is its lobe's last whose first vertex
    has r / z <= t (r / z increases along a lobe, see the module doc), the lobe's end
    segments extending beyond its ends: one search on a key per segment (the vertex's r / z;
    -inf for the first segment of the inner lobe; for the outer lobe's first, the next float
    above every inner ray's t: every outer ray's t reaches it) finds that for both lobes at
    once. A TabulatedProfile's slope is interpolated on the same segment when the root lies
    in it (the same arithmetic as np.interp, to the bit), else by the profile."""

    def __init__(self, profile: Profile, lobes: list[tuple], r_min: np.ndarray):
        self.profile, self.r_min = profile, r_min
        keys, seg, self.step = _segments(profile, lobes)
        self.search = _Search(keys)
        self.m, self.c, self.r_lo, self.r_hi = seg["m"], seg["c"], seg["r_lo"], seg["r_hi"]
        self.any_step = bool(self.step.any())
        self.ds = seg.get("ds")
        self.s_lo = seg.get("s_lo")

    def __call__(self, t: np.ndarray, norm_d: np.ndarray, lobe: np.ndarray, inner: np.ndarray):
        j = self.search(t)
        den = self.m.take(j)
        den *= t
        np.subtract(1.0, den, out=den)
        r = self.c.take(j)
        r *= t
        with np.errstate(divide="ignore", invalid="ignore"):
            r /= den
        if self.any_step:
            r = np.where(self.step.take(j), self.r_lo.take(j), r)
        np.maximum(r, self.r_min.take(lobe), out=r)
        if self.ds is None:
            return r, _slope_on_lobes(self.profile, r, lobe)
        r0 = self.r_lo.take(j)
        fits = r0 <= r
        fits &= r < self.r_hi.take(j)
        s = np.subtract(r, r0, out=r0)
        s *= self.ds.take(j)
        s += self.s_lo.take(j)
        redo = ~fits
        redo &= lobe <= Fate.OUTER
        if redo.any():  # a root on a segment's end or beyond the table: np.interp's own choice
            s[redo] = self.profile.slope(r[redo])
        return r, s


def _polyline_lobes(profile: Profile, t_in: float) -> list[tuple] | None:
    """(rs, zs, search keys) of both lobes if both are polylines whose keys, inner then
    outer, do not decrease (else None)."""
    lobes = []
    for k in (0, 1):
        vertices = polyline_vertices(profile, k)
        if vertices is None:
            return None
        rs, zs = vertices
        q = np.maximum.accumulate(rs / zs)
        first = -np.inf if k == 0 else np.nextafter(t_in, np.inf)
        lobes.append((rs, zs, np.concatenate([[first], q[1:-1]])))
    keys = np.concatenate([key for *_, key in lobes])
    return lobes if bool(np.all(keys[1:] >= keys[:-1])) else None


def _segments(profile: Profile, lobes: list[tuple]) -> tuple[np.ndarray, dict[str, np.ndarray], np.ndarray]:
    """Both lobes' polylines as one table: the search keys, each segment's line z = m r + c
    and ends r_lo, r_hi (and for a TabulatedProfile whose inner table ends by the
    junction, its slope s_lo at r_lo and rate ds), and which segments are vertical steps."""
    keys = np.concatenate([key for *_, key in lobes])
    m, c, r_lo, r_hi = [], [], [], []
    for rs, zs, _ in lobes:
        dr = rs[1:] - rs[:-1]
        with np.errstate(divide="ignore", invalid="ignore"):
            mk = (zs[1:] - zs[:-1]) / dr
        m.append(mk)
        c.append(zs[:-1] - mk * rs[:-1])
        r_lo.append(rs[:-1])
        r_hi.append(rs[1:])
    seg = {k: np.concatenate(v) for k, v in (("m", m), ("c", c), ("r_lo", r_lo), ("r_hi", r_hi))}
    if type(profile).slope is TabulatedProfile.slope and lobes[0][0][-1] <= profile.r_junction:
        ss = [profile.lobes[k][2] for k in (0, 1)]
        with np.errstate(divide="ignore", invalid="ignore"):
            seg["ds"] = np.concatenate([(x[1:] - x[:-1]) / (rs[1:] - rs[:-1]) for x, (rs, *_) in zip(ss, lobes)])
        seg["s_lo"] = np.concatenate([x[:-1] for x in ss])
    return keys, seg, seg["r_hi"] <= seg["r_lo"]


_TABLES: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
_SEEN: weakref.WeakSet = weakref.WeakSet()
#: Rays in one call from which a tabulated profile's fate table is built on its first
#: trace (else on its second): the table costs about 20 ms once (a paper envelope,
#: 77,000 intervals) and saves about 30 ns a ray and the polylines' 11 ms set-up a call.
TABLE_MIN_RAYS = 1 << 18


def fate_table(profile: Profile, t_fate: tuple[float, float, float], r_out0: float,
               rays: int = TABLE_MIN_RAYS) -> FateTable | None:
    """The profile's fate-interval table (optics.meridian_table) if it is tabulated with
    its slope (a tool-nose envelope), else None; built when a call traces `rays` >=
    TABLE_MIN_RAYS or the profile was traced before, then kept while the profile lives (a
    profile is not changed once made)."""
    try:
        return _TABLES[profile]
    except (KeyError, TypeError):
        pass
    if type(profile).slope is not TabulatedProfile.slope:
        return None
    if rays < TABLE_MIN_RAYS:
        try:
            if profile not in _SEEN:
                _SEEN.add(profile)
                return None
        except TypeError:  # pragma: no cover - a profile that cannot be weakly referenced
            return None
    table = None
    lobes = _polyline_lobes(profile, t_fate[0])
    if lobes is not None:
        keys, seg, step = _segments(profile, lobes)
        if "ds" in seg:
            table = FateTable(keys, seg, step, t_fate, r_out0)
    try:
        _TABLES[profile] = table
    except TypeError:  # pragma: no cover - a profile that cannot be weakly referenced
        pass
    return table


class _Search:
    """searchsorted(keys, t, side="right") - 1 on non-decreasing keys (keys[0] = -inf,
    the rest finite), several times faster than numpy's binary search on 10^4-10^5 keys: a
    uniform grid of buckets (twice as many as keys) over the keys' range, each key counted
    in the bucket the same arithmetic puts a ray in (monotone in t, so a ray's index is the
    keys in the buckets before its own, plus the key in its own bucket if that is <= t:
    exact, no margin at a bucket's edge); the rays of a bucket with two keys or more go to
    searchsorted. A NaN t gets some index."""

    def __init__(self, keys: np.ndarray):
        self.keys, finite = keys, keys[1:]
        self.n_buckets = nb = 2 * max(finite.size, 1)
        self.lo = float(finite[0]) if finite.size else 0.0
        span = float(finite[-1]) - self.lo if finite.size else 0.0
        self.scale = nb / span if span > 0 else 0.0
        count = np.bincount(self._bucket(finite), minlength=nb)
        before = np.cumsum(count) - count  # finite keys in the buckets below; +1 for -inf, -1
        self.split = np.append(finite, np.inf).take(before)  # the first key in or after the bucket
        self.starts = np.where(count > 1, -keys.size - 1, before)  # negative: to searchsorted

    def _bucket(self, t: np.ndarray) -> np.ndarray:
        x = t - self.lo
        x *= self.scale
        np.fmax(x, 0.0, out=x)  # fmax/fmin: a NaN t to bucket 0
        np.fmin(x, self.n_buckets - 1, out=x)
        return x.astype(np.intp)

    def __call__(self, t: np.ndarray) -> np.ndarray:
        b = self._bucket(t)
        j = self.starts.take(b)
        j += self.split.take(b) <= t
        if j.min() < 0:
            bad = np.flatnonzero(j < 0)
            j[bad] = np.searchsorted(self.keys, t[bad], side="right") - 1
        return j


def _slope_on_lobes(profile: Profile, r: np.ndarray, lobe: np.ndarray) -> np.ndarray:
    """profile.slope at the hits (NaN elsewhere)."""
    s = np.full(r.shape, np.nan)
    hit = np.flatnonzero(lobe <= Fate.OUTER)
    s[hit] = profile.slope(r[hit])
    return s


class _ByLobe:
    """Lobe by lobe, for any profile: each lobe's rays to its own root (closed form on a
    design sheet, the polyline's segment, else Newton)."""

    def __init__(self, profile: Profile, r_min: np.ndarray):
        self.profile, self.r_min = profile, r_min
        self.roots = tuple(_lobe_root(profile, k) for k in (0, 1))

    def __call__(self, t: np.ndarray, norm_d: np.ndarray, lobe: np.ndarray, inner: np.ndarray):
        r = np.full(t.shape, np.nan)
        for k, root in enumerate(self.roots):
            idx = np.flatnonzero(lobe == k)
            if idx.size:
                r[idx] = np.maximum(root(t[idx], norm_d[idx]), self.r_min[k])
        return r, _slope_on_lobes(self.profile, r, lobe)


def _lobe_root(profile: Profile, k: int):
    """Lobe k's root of r = t Z(r): closed form on a design lobe (a compensated sheet is not
    a hyperbola), the segment on a polyline, else Newton."""
    sheet = profile.mirror.lobes[k] if isinstance(profile, ExactProfile) else None
    if type(sheet) is Lobe:
        b2, e, a = sheet.b**2, sheet.e, sheet.a
        return lambda t, norm_d: t * (b2 / (e - a * norm_d))
    vertices = polyline_vertices(profile, k)
    if vertices is not None:
        return _polyline_root(*vertices)
    return _NewtonRoot(profile, k)


def _polyline_root(rs: np.ndarray, zs: np.ndarray):
    """Where rays r = t z meet the polyline through (rs, zs) (rs non-decreasing), mm: the
    segment by a binary search on the vertices' r / z; the end segments extend."""
    q = np.maximum.accumulate(rs / zs)

    def root(t: np.ndarray, norm_d: np.ndarray) -> np.ndarray:
        j = np.clip(np.searchsorted(q, t, side="right") - 1, 0, rs.size - 2)
        dr = rs[j + 1] - rs[j]
        with np.errstate(divide="ignore", invalid="ignore"):
            m = (zs[j + 1] - zs[j]) / dr
            r = t * (zs[j] - m * rs[j]) / (1.0 - t * m)
        return np.where(dr > 0, r, rs[j])  # a vertical step in the table: the ray meets it there
    return root


class _NewtonRoot:
    """Root of h(r) = t Z(r) - r on lobe k of any profile: a table brackets it (built once
    per call), then safeguarded Newton, vectorised, to ROOT_TOL_MM."""

    def __init__(self, profile: Profile, k: int, *, table: int = 2049, max_iter: int = 100):
        self.profile, self.max_iter = profile, max_iter
        lo_r, hi_r = profile.lobe_range(k)
        if k == 1:
            lo_r = np.nextafter(lo_r, np.inf)
        self.lo_r, self.hi_r = lo_r, hi_r
        self.rs = np.linspace(lo_r, hi_r, table)
        self.q = np.maximum.accumulate(self.rs / profile.z(self.rs))

    def __call__(self, t: np.ndarray, norm_d: np.ndarray) -> np.ndarray:
        profile, rs = self.profile, self.rs
        j = np.clip(np.searchsorted(self.q, t, side="right") - 1, 0, rs.size - 2)
        lo, hi = rs[j], rs[j + 1]
        h_lo = t * profile.z(lo) - lo
        h_hi = t * profile.z(hi) - hi
        bad = ~((h_lo >= 0) & (h_hi <= 0))  # a non-monotone table: fall back to the whole lobe
        lo = np.where(bad, self.lo_r, lo)
        hi = np.where(bad, self.hi_r, hi)
        h_lo = np.where(bad, t * profile.z(lo) - lo, h_lo)
        h_hi = np.where(bad, t * profile.z(hi) - hi, h_hi)
        with np.errstate(divide="ignore", invalid="ignore"):
            x = np.where(h_lo == h_hi, 0.5 * (lo + hi), lo + (hi - lo) * h_lo / (h_lo - h_hi))
        x = np.clip(x, lo, hi)
        active = np.arange(t.size)
        for _ in range(self.max_iter):
            xa, ta = x[active], t[active]
            h = ta * profile.z(xa) - xa
            dh = ta * profile.slope(xa) - 1.0
            la, ha = lo[active], hi[active]
            la = np.where(h > 0, xa, la)
            ha = np.where(h > 0, ha, xa)
            with np.errstate(divide="ignore", invalid="ignore"):
                nx = xa - h / dh
            outside = ~((nx >= la) & (nx <= ha)) | ~np.isfinite(nx)
            nx = np.where(outside, 0.5 * (la + ha), nx)
            lo[active], hi[active], x[active] = la, ha, nx
            done = (np.abs(nx - xa) <= ROOT_TOL_MM) | (h == 0) | (ha - la <= ROOT_TOL_MM)
            active = active[~done]
            if active.size == 0:
                break
        return x
