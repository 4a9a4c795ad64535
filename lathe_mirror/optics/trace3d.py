"""The 3-D tracer: camera rays from any pose (tilted, decentred, moved along the axis) off
a mirror surface of revolution z = Z(r) (any Profile), all rays at once. Mirror frame, mm.

Fast path (every ray, vectorised; no Python loop per ray):

* each lobe is near a quadric of revolution z^2 + p z + q r^2 + w = 0: the lobe's own
  hyperboloid for an exact profile ((z - e)^2 / a^2 - r^2 / b^2 = 1: p = -2e,
  q = -a^2 / b^2, w = e^2 - a^2), a least-squares fit to the lobe otherwise. A ray meets it
  where a quadratic in the ray length s vanishes (the stable root pair); of the two, the
  one on the mirror's sheet (sign of 2z + p, z > e for a hyperboloid) is kept, never the
  nearest hit: a ray from the pinhole crosses the other sheet first (ARCHITECTURE.md).
  On an exact profile that root is the hit, in closed form.
* on a made profile (polyline, tabulated envelope, programmed moves, spline) the hit is
  the root of the height gap g(s) = z(s) - Z(r(s)) along the ray: safeguarded Newton (a
  step leaving the bracket bisects it), all rays at once, from the quadric's hit, with
  the interpolant's own chord slope on piecewise-linear profiles, to ROOT_TOL_MM
  (optics.roots3d). On a piecewise-linear profile one step, checked without a second
  evaluation, settles about nineteen rays in twenty.
* which lobe, the wall or a miss, decided without marching: a ray from below climbs
  faster than the surface where the surface's slope stays below the ray's d_z / |d_xy|
  (dr/ds <= |d_xy|), so g rises monotonically there and has at most one root. Per lobe,
  bins of r hold the largest |slope| (cumulative from the lobe's start) and the lowest
  height (from the bin to the lobe's end); a ray's monotone zone ends at the first bin
  whose slope bound it cannot out-climb. Where the ray leaves that zone (the cylinder
  r = r_s) above the surface, the lobe's root lies inside it; below the surface and below
  every height of the steep rest, the ray never enters that lobe's material; at the
  junction then, above the outer lobe's start it meets the wall, below it the outer lobe;
  past the rim, the mount (a miss).
* blocked (inner lobe): the reflected ray's height over the outer lobe,
  h(l) = z(l) - Z_outer(r(l)), is concave on a convex lobe; h at the junction and at the
  rim, and the two tangents' meeting point, bound it. Only an undecided ray is sampled.

Fallback (the few rays the fast path cannot decide: a ray whose monotone zone ends in a
steep feature it may touch, such as the groove or the fillet a nose leaves at the step;
an origin above the surface or outside the junction radius): march each ray through the
mirror's height range and refine the first step inside the material (safeguarded Newton,
bisection across the step wall), as the meridian tracer does (optics.march).
"""

from __future__ import annotations

import contextlib
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from ..compute import active
from ..profile import Profile
from .march import WALL_JUMP_MM, march, reflected_blocked
from .rays import Fate, RayHits
from .roots3d import newton_roots
from .surface_tables import LobeTable, SurfaceTables, first_steep, normal_slope, surface_tables

__all__ = ["CHUNK", "WALL_JUMP_MM", "trace_rays", "tracing_threads"]
#: Rays per vectorised batch (its arrays stay in a core's cache: one core, 1 << 15 took
#: less CPU per ray than 1 << 16 or 1 << 17).
CHUNK = 1 << 15
#: Rays per batch when the batches run in threads (tracing_threads): larger, so that each
#: numpy call outlasts the hand-over of the interpreter's lock between the threads (2
#: threads on the full sensor, the paper program: 9.4e6 rays/s at 1 << 17 against 6.9e6
#: at 1 << 15 and 5.2e6 at 1 << 14).
THREAD_CHUNK = 1 << 17
#: A ray must out-climb a bin's slope bound by this factor to count as monotone there.
MONOTONE_MARGIN = 1.02
#: The steep bins at the inner lobe's rim walked one by one (beyond: the march).
STEEP_WALK = 32


def trace_rays(profile: Profile, origin: np.ndarray, directions: np.ndarray, *,
               chunk: int | None = None, progress: bool = False, fast: bool = True,
               march_steps: int = 16) -> RayHits:
    """Rays origin + s * direction (mm, unit directions (..., 3)) off the profile.

    chunk: rays per vectorised batch (default CHUNK; THREAD_CHUNK when the batches run in
    threads, tracing_threads). fast=False marches every ray (the fallback; for comparison
    and benchmarks).
    march_steps: the march's steps through the height range (it misses a sliver of
    material thinner than a step: more steps, finer). A tqdm bar on stderr when `progress`.
    """
    origin = np.asarray(origin, float)
    d_all = np.asarray(directions, float)
    shape = d_all.shape[:-1]
    d_all = d_all.reshape(-1, 3)
    n = d_all.shape[0]
    fate = np.full(n, Fate.MISS, dtype=np.int8)
    point = np.empty((n, 3))  # NaN where no lobe is hit: filled chunk by chunk (in the threads)
    out = np.empty((n, 3))
    if not fast:
        point.fill(np.nan)
        out.fill(np.nan)
    blocked = np.zeros(n, dtype=bool)
    tables = surface_tables(profile)
    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(total=n, unit="ray", unit_scale=True, desc="trace 3-D", leave=False)
    threads = tracing_threads() if fast and n > (chunk or CHUNK) else 1
    if not chunk:  # in threads: a batch for each at least
        chunk = min(THREAD_CHUNK, max(CHUNK, -(-n // threads))) if threads > 1 else CHUNK
    rest = [np.arange(n)]
    if fast:
        def one(a: int) -> np.ndarray:
            sl = slice(a, min(a + chunk, n))
            point[sl] = np.nan
            out[sl] = np.nan
            return a + _fast_chunk(profile, tables, origin, d_all[sl], fate[sl], point[sl], out[sl], blocked[sl])

        starts = range(0, n, chunk)
        # numpy releases the GIL inside its loops: in threads, the chunks (disjoint slices
        # of the outputs, each its own work) run on the command's cores, the same bytes as in turn
        with (ThreadPoolExecutor(min(threads, len(starts))) if threads > 1 else contextlib.nullcontext()) as pool:
            rest = []
            for a, r in zip(starts, pool.map(one, starts) if pool else map(one, starts)):
                rest.append(r)
                if bar is not None:
                    bar.update(min(a + chunk, n) - a)
    # the rays the fast path left, marched together (few: near a steep feature)
    rest = np.concatenate(rest) if rest else np.zeros(0, dtype=np.intp)
    for a in range(0, rest.size, chunk):
        ii = rest[a:a + chunk]
        fate[ii], point[ii], out[ii], blocked[ii] = march(profile, origin, d_all[ii], tables.z_lo, tables.z_hi,
                                                            steps=march_steps)
        if bar is not None and not fast:
            bar.update(ii.size)
    if bar is not None:
        bar.close()
    return RayHits(fate=fate.reshape(shape), point=point.reshape(*shape, 3),
                   direction=out.reshape(*shape, 3), blocked=blocked.reshape(shape))


def tracing_threads() -> int:
    """Threads for the fast path's chunks: the command's cores when it runs local worker
    processes (compute.active(): --workers, default all cores), 1 when serial (inside a
    worker, --workers 1) or on a Dask cluster."""
    ex = active()
    return ex.workers if ex.kind == "processes" else 1


# --------------------------------------------------------------------------------------
# Fast path


def _fast_chunk(profile, tb: SurfaceTables, o, d, fate, point, out, blocked) -> np.ndarray:
    """Trace the rays the fast path decides (writes into fate, point, out, blocked); the
    indices of the rest (for the march)."""
    n = d.shape[0]
    if not o[2] < tb.z_min:  # the camera must be below the mirror
        return np.arange(n)
    ox, oy, oz = (float(x) for x in o)
    r0sq = ox * ox + oy * oy
    inner_t, outer_t = tb.lobes
    dx, dy, dz = (np.ascontiguousarray(c) for c in d.T)  # no copy from ray_directions' planar rays
    # a ray heading down never reaches the mirror above (a miss); one along the axis or
    # with its origin off the inner lobe's monotone zone goes to the march
    dxy2 = dx * dx
    t = dy * dy
    dxy2 += t
    go = (dz > 0) & (dxy2 > 0)
    undecided = []
    idx = None  # the rays traced here (None: all)
    if not go.all():
        idx = np.nonzero(go)[0]
        undecided.append(np.nonzero((dz > 0) & ~go)[0])
        dx, dy, dz, dxy2, t = dx[idx], dy[idx], dz[idx], dxy2[idx], t[idx]
    bxy = dx * ox
    np.multiply(dy, oy, out=t)
    bxy += t
    inv = np.divide(1.0, dxy2)
    bb = bxy * bxy
    climb = np.sqrt(inv)  # the ray's dz / dr, at least
    climb *= dz
    climb *= 1.0 / MONOTONE_MARGIN

    def exit_s(radius, sel=None):
        """Ray length where the ray leaves the cylinder r = radius (origin inside it)."""
        if sel is None:
            e = np.multiply(dxy2, radius * radius - r0sq)
            e += bb
        else:
            e = np.multiply(dxy2.take(sel), radius * radius - r0sq)
            e += bb.take(sel)
        with np.errstate(invalid="ignore"):
            np.sqrt(e, out=e)
        e -= bxy if sel is None else bxy.take(sel)
        e *= inv if sel is None else inv.take(sel)
        return e

    def row(i):
        return i if idx is None else idx[i]

    nb0, nb1 = inner_t.slope_cummax.size, outer_t.slope_cummax.size
    b_s = first_steep(inner_t, climb)
    b1 = first_steep(outer_t, climb)
    if b_s.min(initial=nb0) == nb0 and b1.min(initial=nb1) == nb1 and r0sq < inner_t.hi ** 2:
        # No steep bin in any ray's reach (the usual case): each lobe is one monotone zone.
        # The inner lobe where the ray leaves it above its rim; else the wall where the ray
        # reaches the junction above the outer lobe's start; else the outer lobe where it
        # leaves that above the rim; else past the rim (the general case below, simplified).
        s_s = exit_s(inner_t.hi)
        z_s = s_s * dz
        z_s += oz
        inner = z_s >= inner_t.z_edge[nb0]
        wall = z_s >= outer_t.z_edge[0]
        wall &= ~inner
        s1 = exit_s(outer_t.hi)
        z1 = s1 * dz
        z1 += oz
        outer = z1 >= outer_t.z_edge[nb1]
        outer &= ~inner
        outer &= ~wall
        lost = np.isnan(z1)  # (the general case leaves these to the march)
        if lost.any():
            undecided.append(row(np.nonzero(lost & ~inner & ~wall)[0]))
        if wall.any():
            fate[row(np.nonzero(wall)[0])] = Fate.WALL
        o_in, o_out = np.nonzero(inner)[0], np.nonzero(outer)[0]
        jobs = ((0, o_in, np.zeros(o_in.size), np.minimum(s_s[o_in], (tb.z_hi - oz) / dz[o_in])),
                (1, o_out, s_s[o_out], s1[o_out]))
    else:
        # Inner lobe: each ray's monotone zone ends at r_s; above the surface there: a hit.
        if b_s.min(initial=nb0) == nb0:  # no steep bin in reach: the zone is the lobe
            s_s = exit_s(inner_t.hi)
            ok = np.full(b_s.size, r0sq < inner_t.hi * inner_t.hi)
            z_bs = inner_t.z_edge[nb0]
        else:
            r_s = inner_t.edges.take(b_s)
            s_s = exit_s(r_s)
            ok = r_s * r_s > r0sq
            z_bs = inner_t.z_edge.take(b_s)
        z_s = s_s * dz
        z_s += oz
        inner = z_s >= z_bs
        inner &= ok
        # The others: never inside the inner lobe's material, then the wall, the outer lobe
        # (its monotone zone from the junction) or past the rim.
        ok &= ~inner
        rest = np.nonzero(ok)[0]
        b_r = b_s.take(rest)
        s_c = s_s.take(rest)
        dz_r = dz.take(rest)
        steep = b_r < nb0
        if steep.any():
            s_c[steep] = exit_s(inner_t.hi, rest[steep])
        z_c = s_c * dz_r
        z_c += oz
        not_inner = z_c < inner_t.z_sufmin.take(b_r)
        # Where that does not settle it, walk the steep bins: the ray below each bin's lowest
        # point at the bin's outer edge (its highest point there) never enters it.
        walk = np.nonzero(~not_inner & (b_r >= nb0 - STEEP_WALK) & steep)[0] if steep.any() else ()
        if len(walk):
            first = nb0 - STEEP_WALK if nb0 > STEEP_WALK else 0
            bins = np.arange(first, nb0)
            sel = rest[walk]
            with np.errstate(invalid="ignore"):
                s_e = (np.sqrt(bb[sel, None] + dxy2[sel, None] * (inner_t.edges[bins + 1] ** 2 - r0sq))
                       - bxy[sel, None]) * inv[sel, None]
            under = (oz + s_e * dz[sel, None] < inner_t.z_binmin[bins]) | (bins < b_r[walk, None])
            not_inner[walk] = under.all(axis=1)
        wall = not_inner & (z_c >= outer_t.z_edge[0])
        beyond = not_inner & ~wall
        b1 = b1.take(rest)
        if b1.min(initial=nb1) == nb1:
            s1 = exit_s(outer_t.hi).take(rest)  # (dense, then picked: cheaper than four picks)
            z_b1 = outer_t.z_edge[nb1]
        else:
            s1 = exit_s(outer_t.edges.take(b1), rest)
            z_b1 = outer_t.z_edge.take(b1)
        z1 = s1 * dz_r
        z1 += oz
        outer = beyond & (b1 > 0) & (z1 >= z_b1)
        miss = beyond & (b1 == nb1) & (z1 < outer_t.z_edge[-1])
        ok = ~ok
        ok &= ~inner  # neither inner nor a candidate for the rest: the march
        if ok.any():
            undecided.append(row(np.nonzero(ok)[0]))
        settled = wall | outer | miss
        if not settled.all():
            undecided.append(row(rest[~settled]))
        fate[row(rest[wall])] = Fate.WALL

        o_in = np.nonzero(inner)[0]
        o_out = rest[outer]
        jobs = ((0, o_in, np.zeros(o_in.size), np.minimum(s_s[o_in], (tb.z_hi - oz) / dz[o_in])),
                (1, o_out, s_c[outer], s1[outer]))
    for k, sel, lo_s, hi_s in jobs:
        if sel.size == 0:
            continue
        lobe = tb.lobes[k]
        kx, ky, kz = dx[sel], dy[sel], dz[sel]
        s = _quadric_hit(lobe, oz, kz, bxy[sel], dxy2[sel], r0sq)
        rows = sel if idx is None else idx[sel]
        if lobe.exact is not None:
            conv = (s >= lo_s - 1e-9) & (s <= hi_s + 1e-9)  # False for NaN
            seg = hit = None
        else:
            s, conv, seg, hit = newton_roots(profile, lobe, (ox, oy, oz), kx, ky, kz, dxy2[sel], s, lo_s, hi_s)
        if not conv.all():
            undecided.append(rows[~conv])
            rows, kx, ky, kz, s = rows[conv], kx[conv], ky[conv], kz[conv], s[conv]
            seg = None if seg is None else seg[conv]
            hit = None if hit is None else tuple(c[conv] for c in hit)
        if hit is None:
            px, py = s * kx, s * ky
            px += ox
            py += oy
            r = px * px
            r += py * py
            np.sqrt(r, out=r)
        else:
            px, py, r = hit
        pz = s * kz
        pz += oz
        slope = normal_slope(profile, lobe, r, seg)
        ux, uy, uz = _reflect(px, py, r, kx, ky, kz, slope)
        fate[rows] = k
        for c, (pc, uc) in enumerate(((px, ux), (py, uy), (pz, uz))):
            point[rows, c] = pc
            out[rows, c] = uc
        if k == 0:
            blocked[rows] = _blocked(profile, tb, px, py, pz, ux, uy, uz)
    return np.concatenate(undecided) if undecided else np.zeros(0, dtype=np.intp)


def _reflect(px, py, r, kx, ky, kz, slope):
    """The rays k reflected at p (radius r) off a surface of revolution of the given slope:
    the unit normal toward the camera (slope px / r, slope py / r, -1) / sqrt(1 + slope^2),
    -z on the axis."""
    nn = slope * slope
    nn += 1.0
    np.sqrt(nn, out=nn)
    np.divide(1.0, nn, out=nn)
    kr = slope * nn
    if (r > 0).all():
        kr /= r
    else:
        with np.errstate(invalid="ignore", divide="ignore"):
            kr = np.where(r > 0, kr / r, 0.0)
    two_dn = px * kx
    t = py * ky
    two_dn += t
    two_dn *= kr
    np.multiply(kz, nn, out=t)
    two_dn -= t
    two_dn *= 2.0
    np.multiply(two_dn, kr, out=kr)
    ux = px * kr
    np.subtract(kx, ux, out=ux)
    uy = py * kr
    np.subtract(ky, uy, out=uy)
    uz = np.multiply(two_dn, nn, out=nn)
    uz += kz
    return ux, uy, uz


def _quadric_hit(lobe: LobeTable, oz: float, dz: np.ndarray, bxy: np.ndarray, dxy2: np.ndarray,
                 r0sq: float) -> np.ndarray:
    """Smallest s > 0 where the rays meet the lobe's quadric on the mirror's sheet (NaN
    where they do not): A s^2 + 2 B s + C = 0, the stable pair of roots. The mirror's
    sheet: 2 z + p of its sign, z = oz + s dz (dz > 0) beyond (sheet +1) or before (-1)
    the height -p / 2."""
    p, q, w, sheet = lobe.quad
    C = oz * oz + p * oz + q * r0sq + w
    with np.errstate(divide="ignore", invalid="ignore"):
        A = dz * dz
        t = dxy2 * q
        A += t
        B = dz * (oz + 0.5 * p)
        np.multiply(bxy, q, out=t)
        B += t
        sq = B * B
        np.multiply(A, C, out=t)
        sq -= t
        np.sqrt(sq, out=sq)  # NaN where the ray misses the quadric
        qq = np.copysign(sq, B, out=sq)
        qq += B
        np.negative(qq, out=qq)
        s1 = np.divide(qq, A, out=A)
        s2 = np.divide(C, qq, out=qq)
        lo = np.fmin(s1, s2)
        hi = np.fmax(s1, s2, out=s1)
        edge = np.divide(-0.5 * p - oz, dz, out=B)  # s where z = -p / 2
        if sheet > 0:
            np.maximum(edge, 0.0, out=edge)
            return np.where(lo > edge, lo, np.where(hi > edge, hi, np.nan))
        return np.where((lo > 0) & (lo < edge), lo, np.where((hi > 0) & (hi < edge), hi, np.nan))


def _blocked(profile: Profile, tb: SurfaceTables, px, py, pz, ux, uy, uz) -> np.ndarray:
    """Does the reflected ray p + l u (l > 0) leaving the inner lobe run into the outer
    lobe's material (up to the rim)? h(l) = z - Z_outer(r) is concave (convex lobe): its
    values at the junction and the rim and its tangents there decide; an undecided ray is
    sampled (march.reflected_blocked)."""
    outer = tb.lobes[1]
    with np.errstate(invalid="ignore", divide="ignore"):
        oxy2 = ux * ux
        t = uy * uy
        oxy2 += t
        bxy = px * ux
        np.multiply(py, uy, out=t)
        bxy += t
        rp2 = px * px
        np.multiply(py, py, out=t)
        rp2 += t
        inv = np.divide(1.0, oxy2)
        bb = bxy * bxy

        def leave(radius):  # l where the ray leaves the cylinder r = radius
            e = rp2 - radius * radius
            e *= oxy2
            np.subtract(bb, e, out=e)
            np.maximum(e, 0.0, out=e)
            np.sqrt(e, out=e)
            e -= bxy
            e *= inv
            return e

        lj, lm = leave(outer.lo), leave(outer.hi)
        hj = lj * uz  # h and its slope dh/dl at the junction and the rim
        hj += pz
        hj -= outer.z_edge[0]
        hm = lm * uz
        hm += pz
        hm -= tb.z_rim
        dj = lj * oxy2
        dj += bxy
        dj *= tb.slope_j
        dj /= outer.lo
        np.subtract(uz, dj, out=dj)
        dm = lm * oxy2
        dm += bxy
        dm *= tb.slope_rim
        dm /= outer.hi
        np.subtract(uz, dm, out=dm)
        valid = oxy2 > 0
        valid &= lj > 0
        res = (hj > 0) | (hm > 0)
        res &= valid
        maybe = valid & ~res & (dj > 0) & (dm < 0)
        if maybe.any():  # the tangents' meeting point bounds h
            k = np.nonzero(maybe)[0]
            cross = (hm[k] - hj[k] + dj[k] * lj[k] - dm[k] * lm[k]) / (dj[k] - dm[k])
            maybe[k] = ~(hj[k] + dj[k] * (cross - lj[k]) <= 0)
    if maybe.any():
        p = np.stack([px[maybe], py[maybe], pz[maybe]], axis=-1)
        u = np.stack([ux[maybe], uy[maybe], uz[maybe]], axis=-1)
        res[maybe] = reflected_blocked(profile, p, u)
    return res
