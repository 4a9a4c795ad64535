"""The meridian tracer's fast path on a tabulated profile (a tool-nose envelope: z and the
slope interpolated linearly): a ray's fate, its segment of either lobe's polyline and
that segment's line and slope, from one search of one table of t-intervals.

The fates (optics.trace: inner lobe, wall, outer lobe, miss) and both lobes' segments
(optics.meridian_roots' _Polylines) are each a step function of t; their breakpoints
together cut t into intervals, each with one fate and, on a lobe, one segment. A ray's
interval is found by a uniform grid of buckets over t (the same exact search as the
polylines', bucket by t * scale), and everything the ray needs comes from that interval:
- the fate (int8);
- r = t c / (1 - t m) on the segment's line (c NaN off the lobes: r, z, the slope and
  the direction are NaN there, as the tracer states);
- the slope s_lo + ds (r - r_lo), np.interp's arithmetic on the segment, which is the
  profile's own slope to the bit when r_lo <= r < r_hi.
That holds for almost every ray; the rest (a root rounded off its segment's ends, below
the outer lobe's first radius, on a vertical step, on an interval marked slow) are found
by two reductions and given to the polylines' general solver, which answers ray by ray,
so every ray gets the same bits as from the general solver. Camera frame, mm.
"""

from __future__ import annotations

import numpy as np

from .rays import Fate

__all__ = ["FateTable"]

_FATE_BY_COUNT = np.array([Fate.MISS, Fate.OUTER, Fate.WALL, Fate.INNER], dtype=np.int8)
#: Added to an interval's fate when its rays go to the general solver.
_SLOW = 4


def fate_of(t: np.ndarray, t_fate: tuple[float, float, float]) -> np.ndarray:
    """Fate codes (int8) of rays r = t z: inner if t <= t_in, else the wall if t <= t_wall,
    else the outer lobe if t <= t_rim, else (and for a NaN t) a miss."""
    count = sum((t <= x).astype(np.intp) for x in t_fate)
    return _FATE_BY_COUNT.take(count)


class FateTable:
    """The fates and both lobes' segments as one table of t-intervals (see the module doc).
    Holds arrays only (no profile), so a profile's table can be kept while it lives.

    keys: the segments' search keys (non-decreasing, keys[0] = -inf; segment j holds the t
    with keys[j] <= t < keys[j + 1]); segments: each segment's line z = m r + c, ends r_lo,
    r_hi, slope s_lo at r_lo and its rate ds (arrays m, c, r_lo, r_hi, ds, s_lo); step: a
    vertical step (a ray meets it at r_lo). t_fate: the thresholds t_in <= t_wall <= t_rim.
    r_out0: the outer lobe's first radius (a root below it is moved to it).
    """

    def __init__(self, keys: np.ndarray, segments: dict[str, np.ndarray], step: np.ndarray,
                 t_fate: tuple[float, float, float], r_out0: float):
        self.r_out0 = r_out0
        up = [float(np.nextafter(x, np.inf)) for x in t_fate]  # where each fate ends
        starts = np.unique(np.concatenate([keys[1:], up]))
        starts = np.concatenate([[-np.inf], starts[np.isfinite(starts)]])
        fate = fate_of(starts, t_fate)
        lobe = fate <= Fate.OUTER
        seg = np.where(lobe, np.searchsorted(keys, starts, side="right") - 1, -1)
        new = np.ones(starts.size, dtype=bool)  # one interval per (fate, segment)
        new[1:] = (fate[1:] != fate[:-1]) | (seg[1:] != seg[:-1])
        starts, fate, seg, lobe = starts[new], fate[new], seg[new], lobe[new]
        j = np.where(lobe, seg, 0)
        col = {k: np.where(lobe, v.take(j), np.nan) for k, v in segments.items()}
        col["m"] = np.where(lobe, col["m"], 0.0)  # off the lobes: r = t NaN / 1
        self.step = lobe & step.take(j)
        # the general path's intervals: a vertical step, or the outer lobe's first segment
        # reaching below its first radius
        slow = self.step | ((fate == Fate.OUTER) & ~(col["r_lo"] >= r_out0))
        self.kind = (fate + np.where(slow, _SLOW, 0)).astype(np.int8)
        self.m, self.c, self.r_lo, self.r_hi, self.ds, self.s_lo = (
            np.ascontiguousarray(col[k]) for k in ("m", "c", "r_lo", "r_hi", "ds", "s_lo"))
        # the bucket search (exact, as meridian_roots' _Search): bucket(t) = int(min(t scale,
        # nb - 1)), at least 0; per bucket the first key at or after it and its first
        # interval (negative for a bucket holding two keys or more: to searchsorted)
        self.keys = starts
        finite = starts[1:]
        nb = 2 * max(finite.size, 1)
        top = float(finite[-1]) if finite.size else 0.0
        self.scale = nb / top if top > 0 else 0.0
        self.top = float(nb - 1)
        count = np.bincount(self._bucket_of(finite), minlength=nb)
        before = np.cumsum(count) - count
        self.split = np.append(finite, np.inf).take(before)
        self.first = np.where(count > 1, -starts.size - 1, before).astype(np.intp)

    def _bucket_of(self, t: np.ndarray) -> np.ndarray:
        x = np.fmin(t * self.scale, self.top)
        return np.maximum(x.astype(np.intp), 0)

    @staticmethod
    def buffers(block: int) -> tuple[np.ndarray, ...]:
        """The work arrays of one caller (`block` rays a call at most)."""
        return (np.empty((5, block)), np.empty((2, block), dtype=np.intp), np.empty(block, dtype=bool),
                np.empty(block, dtype=np.int8))

    def __call__(self, t: np.ndarray, buffers: tuple[np.ndarray, ...], profile, r_junction: float):
        """fate (int8), r and the slope dZ/dr there of the rays r = t z (t 1-D and finite),
        in `buffers` (valid until their next use). profile: the one tabulated (its own
        slope for the rays off their segment). Floating-point warnings are the caller's.
        (One take per value: numpy's take costs about as much per 32-byte record as per
        double, but the strided loops that then read a record's fields cost as much again.)"""
        n = t.size
        f, g, r, d, s = (a[:n] for a in buffers[0])
        b, j = (a[:n] for a in buffers[1])
        le, kind = buffers[2][:n], buffers[3][:n]
        # the interval: the bucket's first, plus one if the key in the bucket is <= t
        np.multiply(t, self.scale, out=f)
        np.fmin(f, self.top, out=f)
        np.copyto(b, f, casting="unsafe")  # below 0 (t < 0): clipped by take
        self.first.take(b, out=j, mode="clip")
        self.split.take(b, out=f, mode="clip")
        np.less_equal(f, t, out=le)
        j += le
        if j.min() < 0:  # a bucket holding several keys
            many = np.flatnonzero(j < 0)
            j[many] = np.searchsorted(self.keys, t[many], side="right") - 1
        self.kind.take(j, out=kind, mode="clip")
        # the root on the interval's segment (NaN off the lobes), and the slope there
        den = self.m.take(j, out=f, mode="clip")
        den *= t
        np.subtract(1.0, den, out=den)
        self.c.take(j, out=r, mode="clip")
        r *= t
        r /= den
        self.r_lo.take(j, out=d, mode="clip")
        np.subtract(r, d, out=d)  # >= 0 iff r >= r_lo
        above = self.r_hi.take(j, out=f, mode="clip")
        above -= r  # > 0 iff r < r_hi
        self.ds.take(j, out=s, mode="clip")
        s *= d
        s += self.s_lo.take(j, out=g, mode="clip")
        fits = bool(np.fmin.reduce(d) >= 0.0) and bool(np.fmin.reduce(above) > 0.0)
        if not fits or kind.max() >= _SLOW:
            self._general(t, j, kind, r, s, d, above, profile, r_junction)
        return kind, r, s

    def _general(self, t, j, kind, r, s, d, above, profile, r_junction: float) -> None:
        """The rays off their segment or on a slow interval, as the polylines' general
        solver and the tracer treat them: a step's r_lo, the outer lobe's root at least
        its first radius, the slope on the segment if the root lies in it, else the
        profile's (and the profile's for an inner root past the junction)."""
        slow = kind >= _SLOW
        off = d < 0.0
        off |= above <= 0.0  # NaN (off the lobes): False
        off |= slow
        kind[slow] -= _SLOW
        idx = np.flatnonzero(off)
        if not idx.size:
            return
        k, fate = j.take(idx), kind.take(idx)
        ri = np.where(self.step.take(k), self.r_lo.take(k), r.take(idx))
        ri = np.where(fate == Fate.OUTER, np.maximum(ri, self.r_out0), ri)
        lo = self.r_lo.take(k)
        fits = (lo <= ri) & (ri < self.r_hi.take(k))
        si = (ri - lo) * self.ds.take(k) + self.s_lo.take(k)
        redo = ~fits | ((fate == Fate.INNER) & (ri > r_junction))
        if redo.any():
            si[redo] = profile.slope(ri[redo])
        r[idx], s[idx] = ri, si
