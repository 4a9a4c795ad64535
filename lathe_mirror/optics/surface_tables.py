"""Per-profile tables for the 3-D tracer (optics.trace3d), built once per surface: for
each lobe its quadric of revolution (the closed-form start), its piecewise-linear vertices
behind an O(1) segment lookup, and bins of r holding the largest |slope| (cumulative from
the lobe's start) and the lowest height, from which a ray's monotone zone follows.
Camera frame, mm."""

from __future__ import annotations

import weakref
from dataclasses import dataclass

import numpy as np

from ..design import Lobe
from ..profile import ExactProfile, Profile
from .rays import polyline_vertices

try:
    from ..profile import TabulatedProfile
except ImportError:  # pragma: no cover
    TabulatedProfile = None

#: Vertices of a polyline lying on the chord of their neighbours within this height (mm)
#: are dropped from the tracer's grid (the G1 lines of a program, offset by the nose,
#: give long runs of collinear vertices): the grid's polyline stays within this of the
#: profile's, far below ROOT_TOL_MM, and a Newton step lands on its segment far more often.
COLLINEAR_MM = 5e-14
#: Segments shorter than this (clustered vertices at a kink) are never merged, mm; one
#: whose ends differ in height by at most COLLINEAR_MM is no step (its chord slope is
#: rounding noise).
MERGE_MIN_DR_MM = 1e-9


@dataclass(frozen=True)
class LobeTable:
    """One lobe of a profile, tabulated for the fast path (mm)."""

    lo: float                 # first radius of the lobe (outer: just past the junction)
    hi: float                 # last radius
    quad: tuple[float, float, float, float]  # p, q, w of z^2 + p z + q r^2 + w = 0; sheet sign
    exact: Lobe | None        # the design lobe of an exact profile
    grid: VertexGrid | None  # the piecewise-linear vertices, else None
    lut: tuple[float, np.ndarray]  # climb -> first steep bin, conservative (_climb_lut)
    edges: np.ndarray         # bin edges in r (nb + 1)
    slope_cummax: np.ndarray  # largest |slope| from lo to the end of each bin (nb)
    z_edge: np.ndarray        # Z at each edge (nb + 1)
    z_sufmin: np.ndarray      # lowest Z from each bin to hi (nb + 1; last +inf)
    z_binmin: np.ndarray      # lowest Z in each bin (nb)


@dataclass(frozen=True)
class SurfaceTables:
    lobes: tuple[LobeTable, LobeTable]
    z_lo: float               # just below / above every height of the profile
    z_hi: float
    z_min: float              # the lowest point of the profile
    z_rim: float
    slope_j: float            # the outer lobe's slope at the junction and at the rim
    slope_rim: float


_CACHE: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def surface_tables(profile: Profile) -> SurfaceTables:
    try:
        return _CACHE[profile]
    except (KeyError, TypeError):
        pass
    lobes = tuple(_lobe_table(profile, k) for k in (0, 1))
    r = np.concatenate([np.linspace(0.0, profile.r_max, 4097), [lobes[1].lo]])
    z = profile.z(r)
    out = SurfaceTables(lobes=lobes, z_lo=float(z.min()) - 0.5, z_hi=float(z.max()) + 0.5,
                  z_min=float(min(z.min(), *(lb.z_edge.min() for lb in lobes))),
                  z_rim=float(profile.z(np.array(profile.r_max))),
                  slope_j=float(lobe_zs(profile, lobes[1], np.array([lobes[1].lo]))[1][0]),
                  slope_rim=float(lobe_zs(profile, lobes[1], np.array([lobes[1].hi]))[1][0]))
    try:
        _CACHE[profile] = out
    except TypeError:  # pragma: no cover - an unhashable profile: no cache
        pass
    return out


def _lobe_table(profile: Profile, k: int, nb_max: int = 512) -> LobeTable:
    lo, hi = profile.lobe_range(k)
    if k == 1:
        lo = float(np.nextafter(lo, np.inf))
    # the closed form only for a design lobe (a pre-compensated target's sheet is not a hyperbola)
    sheet = profile.mirror.lobes[k] if isinstance(profile, ExactProfile) else None
    exact = sheet if isinstance(sheet, Lobe) else None
    verts = None if exact is not None else polyline_vertices(profile, k)
    vr = vz = None
    if verts is not None:
        vr, vz = (np.asarray(x, float) for x in verts)
        seg = np.diff(vr)
        nb = int(np.clip((hi - lo) / max(float(seg.max()), 1e-12), 8, nb_max))
    else:
        nb = nb_max // 2
    edges = np.linspace(lo, hi, nb + 1)
    if verts is not None:
        # Each segment's chord slope and lower end bound every bin it overlaps (the end
        # segments extend beyond the vertices, as the profile evaluates there). A cluster
        # of vertices at one radius whose heights differ by rounding (an envelope's
        # duplicated points) is no step: its chord slope is noise.
        dz = np.diff(vz)
        flat = (seg <= MERGE_MIN_DR_MM) & (np.abs(dz) <= COLLINEAR_MM)
        with np.errstate(divide="ignore", invalid="ignore"):
            m = np.abs(np.where((seg > 0) & ~flat, dz / seg, 0.0))
        r0 = vr[:-1].copy()
        r1 = vr[1:].copy()
        r0[0], r1[-1] = min(r0[0], lo), max(r1[-1], hi)
        zmin_seg = np.minimum(vz[:-1], vz[1:])
        # a vertical step inside the lobe: its two ends' heights bound the bin
        b0 = np.clip(np.searchsorted(edges, r0, side="right") - 1, 0, nb - 1)
        b1 = np.clip(np.searchsorted(edges, r1, side="left") - 1, 0, nb - 1)
        keep = (r1 >= lo) & (r0 <= hi)
        smax = np.zeros(nb)
        zmin = np.full(nb, np.inf)
        b0, b1, m, zmin_seg = b0[keep], np.maximum(b1[keep], b0[keep]), m[keep], zmin_seg[keep]
        # the extended end segments: their heights at lo / hi
        zmin[0] = min(zmin[0], float(_eval_vertices(vr, vz, np.array([lo]))[0][0]))
        zmin[-1] = min(zmin[-1], float(_eval_vertices(vr, vz, np.array([hi]))[0][0]))
        for off in range(int(np.max(b1 - b0)) + 1 if b0.size else 0):
            sel = b0 + off <= b1
            np.maximum.at(smax, b0[sel] + off, m[sel])
            np.minimum.at(zmin, b0[sel] + off, zmin_seg[sel])
        step = (seg == 0) & ~flat
        if np.any(step):  # a vertical step between equal radii: infinitely steep
            np.maximum.at(smax, np.clip(np.searchsorted(edges, vr[1:][step], "right") - 1, 0, nb - 1), np.inf)
        z_edge = _eval_vertices(vr, vz, edges)[0]
    else:
        rs = np.linspace(lo, hi, 16 * nb + 1)
        if exact is not None:
            z_s, s_s = exact.z(rs), exact.slope(rs)
        else:
            z_s, s_s = profile.z(rs), profile.slope(rs)
        s_abs = np.abs(s_s)
        # bin b holds samples 16 b .. 16 (b + 1); dilate by a neighbour (what lies between
        # samples) and a small margin
        blk = np.lib.stride_tricks.sliding_window_view(s_abs, 17)[::16]
        zblk = np.lib.stride_tricks.sliding_window_view(z_s, 17)[::16]
        smax = blk.max(axis=1)
        zmin = zblk.min(axis=1)
        if exact is None:
            smax = np.maximum(smax, np.maximum(np.r_[smax[1:], 0.0], np.r_[0.0, smax[:-1]])) * 1.05 + 1e-9
            zmin = np.minimum(zmin, np.minimum(np.r_[zmin[1:], np.inf], np.r_[np.inf, zmin[:-1]])) - 1e-6
        z_edge = z_s[::16]
    cummax = np.maximum.accumulate(smax)
    sufmin = np.concatenate([np.minimum.accumulate(zmin[::-1])[::-1], [np.inf]])
    quad = _quadric(profile, k, exact, lo, hi)
    tab = None
    if TabulatedProfile is not None and isinstance(profile, TabulatedProfile):
        tab = np.asarray(profile.lobes[k][2], float)
    lut = _climb_lut(cummax)
    return LobeTable(lo=lo, hi=hi, quad=quad, exact=exact, grid=None if vr is None else VertexGrid(vr, vz, tab, lo, hi),
                 lut=lut, edges=edges,
                 slope_cummax=cummax, z_edge=z_edge, z_sufmin=sufmin, z_binmin=zmin)


def _climb_lut(cummax: np.ndarray, cells: int = 4096) -> tuple[float, np.ndarray]:
    """A table from a ray's climb c (dz / dr) to the first bin whose slope bound c does
    not exceed: cell i covers [i h, (i + 1) h) and holds the bin of its lower end (never
    later than the exact one, so the monotone zone is never overstated); above the
    table's range every bin is monotone."""
    top = float(cummax[-1])
    if not np.isfinite(top):
        finite = cummax[np.isfinite(cummax)]
        top = float(finite[-1]) if finite.size else 1.0
    h = max(top, 1e-12) * 1.001 / cells
    b = np.searchsorted(cummax, np.arange(cells + 1) * h, side="left")
    b[-1] = np.searchsorted(cummax, np.inf, side="left") if not np.isfinite(cummax[-1]) else cummax.size
    return 1.0 / h, b.astype(np.intp)


def first_steep(lobe: LobeTable, climb: np.ndarray) -> np.ndarray:
    inv_h, b = lobe.lut
    with np.errstate(invalid="ignore"):
        c = np.minimum(climb * inv_h, b.size - 1).astype(np.intp)
    return b[c]


def _quadric(profile: Profile, k: int, exact: Lobe | None, lo: float, hi: float):
    """(p, q, w, sheet) of the quadric z^2 + p z + q r^2 + w = 0 of lobe k: the lobe's own
    for an exact profile, else a least-squares fit; sheet: the sign of 2z + p on the lobe."""
    if exact is not None:
        a, b, e = exact.a, exact.b, exact.e
        return -2.0 * e, -(a * a) / (b * b), e * e - a * a, 1.0
    r = np.linspace(lo, hi, 257)
    z = profile.z(r)
    zc = float(np.mean(z))
    # fit in shifted heights for conditioning: y^2 + P y + q r^2 + W = 0, y = z - zc
    y = z - zc
    A = np.stack([y, r * r, np.ones_like(r)], axis=1)
    P, q, W = np.linalg.lstsq(A, -y * y, rcond=None)[0]
    p = P - 2.0 * zc
    w = W - P * zc + zc * zc
    sheet = float(np.sign(np.median(2.0 * z + p))) or 1.0
    return float(p), float(q), float(w), sheet


def _eval_vertices(vr: np.ndarray, vz: np.ndarray, r: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """z and the chord slope of the polyline (vr, vz) at r (end segments extended)."""
    j = np.clip(np.searchsorted(vr, r, side="right") - 1, 0, vr.size - 2)
    r0, r1 = vr[j], vr[j + 1]
    z0 = vz[j]
    dr = r1 - r0
    m = np.where(dr > 0, (vz[j + 1] - z0) / np.where(dr > 0, dr, 1.0), 0.0)
    return z0 + m * (r - r0), m


def collinear_keep(vr: np.ndarray, vz: np.ndarray, slope: np.ndarray | None = None) -> np.ndarray:
    """Which vertices of the polyline (vr, vz) to keep: an interior vertex of a run of
    collinear vertices (each on its neighbours' chord within COLLINEAR_MM, with a constant
    slope column if given) is dropped when every vertex of the run lies within
    COLLINEAR_MM of the run's end-to-end chord (checked; a run that drifts is kept whole)."""
    n = vr.size
    keep = np.ones(n, dtype=bool)
    if n < 3:
        return keep
    dr = np.diff(vr)
    long = dr > MERGE_MIN_DR_MM
    with np.errstate(divide="ignore", invalid="ignore"):
        dev = vz[1:-1] - (vz[:-2] + (vz[2:] - vz[:-2]) * ((vr[1:-1] - vr[:-2]) / (vr[2:] - vr[:-2])))
    mid = long[:-1] & long[1:] & (np.abs(dev) <= COLLINEAR_MM)
    if slope is not None:
        mid &= (slope[1:-1] == slope[:-2]) & (slope[1:-1] == slope[2:])
    keep[1:-1] = ~mid
    kept = np.nonzero(keep)[0]
    # each vertex against the chord of the kept vertices around it
    i = np.clip(np.searchsorted(kept, np.arange(n), side="right") - 1, 0, kept.size - 2)
    a, b = kept[i], kept[i + 1]
    with np.errstate(divide="ignore", invalid="ignore"):
        chord = vz[a] + (vz[b] - vz[a]) * ((vr - vr[a]) / (vr[b] - vr[a]))
    bad = ~(np.abs(vz - chord) <= COLLINEAR_MM)
    if bad.any():  # a drifting run: keep all its vertices
        keep |= np.isin(i, i[bad])
    return keep


class VertexGrid:
    """O(1) segment lookup on a polyline: a uniform grid of cells over its radii, each
    holding the segment at its start and the next boundary; one step forward finds the
    segment (the one np.searchsorted(vr, r, "right") - 1 finds, clipped to the end
    segments; a binary search for the rare r in a cell holding a cluster of vertices).
    Collinear runs are merged first (collinear_keep). slope: a TabulatedProfile's slope
    column at the vertices (interpolated linearly, as the profile does), else None.
    seg_lo, seg_hi: the radii where segment j is the one evaluated (the end segments
    extended), within the lobe [lo, hi]."""

    def __init__(self, vr: np.ndarray, vz: np.ndarray, slope: np.ndarray | None = None,
                 lo: float = -np.inf, hi: float = np.inf):
        keep = collinear_keep(vr, vz, slope)
        vr, vz = vr[keep], vz[keep]
        slope = None if slope is None else slope[keep]
        n = vr.size
        dr = np.diff(vr)
        pos = dr > 0
        safe = np.where(pos, dr, 1.0)
        self.m = np.where(pos, np.diff(vz) / safe, 0.0)
        self.r0, self.z0 = vr[:-1].copy(), vz[:-1].copy()
        self.nxt = np.concatenate([vr[1:-1], [np.inf]])  # the next segment's start
        self.seg_lo = np.maximum(np.concatenate([[-np.inf], vr[1:-1]]), lo)
        self.seg_hi = np.minimum(self.nxt, hi)
        # cells over the vertices and the lobe: a cell holds the segment of its start and
        # the next boundary; one holding more boundaries (a cluster) is flagged -2
        g0, g1 = float(vr[0]), float(vr[-1])
        g0, g1 = (min(g0, lo) if np.isfinite(lo) else g0), (max(g1, hi) if np.isfinite(hi) else g1)
        self.g0 = g0
        for per in (4, 16, 64):  # finer until few cells hold a cluster
            self.cells = per * n
            self.inv_h = self.cells / ((g1 - g0) or 1.0)
            c = np.arange(self.cells + 1)
            a = g0 + (c - 0.01) / self.inv_h  # a little wider than the cell: rounding in r -> cell
            b = g0 + (c + 1.01) / self.inv_h
            start = np.clip(np.searchsorted(vr, a, side="right") - 1, 0, n - 2)
            more = np.searchsorted(self.nxt, b, side="right") - np.searchsorted(self.nxt, a, side="right") > 1
            if more.mean() <= 0.005 or self.cells >= 1 << 18:
                break
        self.start = np.where(more, -2, start).astype(np.intp)
        self.cell_nxt = self.nxt[start]
        self.vr = vr
        self.r_ends = (float(vr[0]), float(vr[-1]))
        self.s0 = self.sm = None
        if slope is not None:
            self.s0 = slope[:-1].copy()
            self.sm = np.where(pos, np.diff(slope) / safe, 0.0)

    def segment(self, r: np.ndarray) -> np.ndarray:
        """The segment of each r (in the lobe or the vertices' range; NaN: any)."""
        c = r - self.g0
        c *= self.inv_h
        c = c.astype(np.intp)
        j = self.start.take(c, mode="clip")
        j += self.cell_nxt.take(c, mode="clip") <= r
        if (j < 0).any():  # a cluster of vertices in the cell: search
            k = np.nonzero(j < 0)[0]
            j[k] = np.clip(np.searchsorted(self.vr, r[k], side="right") - 1, 0, self.vr.size - 2)
        return j

    def eval(self, r: np.ndarray, j: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        if j is None:
            j = self.segment(r)
        m = self.m[j]
        return self.z0[j] + m * (r - self.r0[j]), m

    def slope_at(self, r: np.ndarray, j: np.ndarray | None = None) -> np.ndarray:
        """The tabulated slope at r (np.interp's: held at the ends); j: r's segment if known."""
        r = np.clip(r, *self.r_ends)
        if j is None:
            j = self.segment(r)
        return self.s0[j] + self.sm[j] * (r - self.r0[j])


def lobe_zs(profile: Profile, lobe: LobeTable, r: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Z and dZ/dr of one lobe at r (clamped into the lobe): the lobe's closed form, the
    polyline's chord, or the profile's own."""
    r = np.clip(r, lobe.lo, lobe.hi)
    if lobe.exact is not None:
        lb = lobe.exact
        root = np.sqrt(1.0 + (r / lb.b) ** 2)
        return lb.e + lb.a * root, lb.a * r / (lb.b * lb.b * root)
    if lobe.grid is not None:
        return lobe.grid.eval(r)
    return profile.z(r), profile.slope(r)


def normal_slope(profile: Profile, lobe: LobeTable, r: np.ndarray, j: np.ndarray | None = None) -> np.ndarray:
    """The slope the reflection uses (the profile's own, as the meridian tracer's); j: the
    grid's segment of each r (clipped into the lobe) if known."""
    r = np.clip(r, lobe.lo, lobe.hi)
    if lobe.exact is not None:
        return lobe.exact.slope(r)
    if lobe.grid is not None and lobe.grid.s0 is not None:  # TabulatedProfile.slope on this lobe
        return lobe.grid.slope_at(r, j)
    return profile.slope(r)


