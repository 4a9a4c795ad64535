"""The as-machined surface: the envelope of the tool nose along the programmed path.

The programmed path is the nose centre's (toolpath.Toolpath.segments, machine frame).
A round nose of radius rho removes every point within rho of the path, so the surface
left at radius r is the lowest point any nose position reaches there (machine Z, part in
-Z): the minimum over (a) each move's offset by rho toward the part and (b) the lower
half of the nose circle at every vertex, where the moves' offsets leave gaps (only
between its two moves' offset directions: _vertex_windows). In closed form per piece,
evaluated on a dense grid of radii; a zero nose radius gives the programmed contour
itself. This includes the fillet the nose leaves in the junction's
inside corner, which it cannot reach.
"""

from __future__ import annotations

import math
import weakref
from collections import OrderedDict
from typing import TYPE_CHECKING

import numpy as np

from .path import Line
from .profile import PathProfile, Profile, TabulatedProfile, spiral_at_r
from .sheet import foot_on_sheet, signed_distance_camera

if TYPE_CHECKING:
    from .toolpath import Toolpath

#: Radial spacing (mm) of the envelope's samples; the envelope is piecewise smooth,
#: so linear interpolation between them errs by ~ spacing^2 / (8 rho) (< 2e-7 mm).
GRID = 0.0005
#: Envelopes cut in this process: (id of the toolpath, rho, include_junction) -> (a weak
#: reference to that toolpath, the envelope). The planner hands out one Toolpath per
#: program (toolpath.plan_toolpath), and `run` cuts the configured job's two programs with
#: the programmed nose about 15 times each (0.6 s of CPU); a forked worker inherits them.
_CUT: OrderedDict = OrderedDict()
#: Envelopes kept (each ~2 MB of samples).
CUT_KEPT = 8


def contour_profile(toolpath: Toolpath) -> Profile:
    """The surface the programmed contour describes, camera frame.

    For a zero nose radius: the moves themselves, exactly (a PathProfile, the same as
    as_machined). For a nose radius rho > 0: the envelope of the nose along each lobe's
    moves (the path offset back by rho, without the junction's inside-corner fillet,
    which as_machined adds).
    """
    if toolpath.nose_radius == 0.0:
        return as_machined(toolpath)
    return nose_envelope(toolpath, toolpath.nose_radius, include_junction=False)


def as_machined(toolpath: Toolpath, nose_radius: float | None = None) -> Profile:
    """The surface a nose of `nose_radius` (mm; default the tool's) cuts along the path.

    Camera frame. Zero nose radius: the programmed contour (exact lines and arcs).
    """
    rho = toolpath.nose_radius if nose_radius is None else float(nose_radius)
    if not (math.isfinite(rho) and rho >= 0):
        raise ValueError(f"nose_radius = {nose_radius!r} mm must be >= 0")
    if rho == 0.0:
        m = toolpath.mirror
        return PathProfile(toolpath.lobe_segments("inner"), toolpath.lobe_segments("outer"),
                           r_junction=m.r_junction, r_max=m.r_max, vertex_z=m.vertex_z)
    return nose_envelope(toolpath, rho, include_junction=True)


def nose_envelope(toolpath: Toolpath, rho: float, *, include_junction: bool = True) -> TabulatedProfile:
    """Envelope of a nose of radius rho (mm) along the path, as a TabulatedProfile.

    include_junction=False: only each lobe's own moves and interior vertices (the path
    offset back, without the inside-corner fillet); the lobe's ends are extended along
    their last slope where no piece covers a radius.
    """
    key = (id(toolpath), float(rho), bool(include_junction))
    held = _CUT.get(key)
    if held is not None and held[0]() is toolpath:
        _CUT.move_to_end(key)
        return held[1]
    profile = _envelope(toolpath, rho, include_junction)
    try:
        _CUT[key] = (weakref.ref(toolpath), profile)
    except TypeError:  # a stand-in for a Toolpath that takes no weak reference: not kept
        return profile
    if len(_CUT) > CUT_KEPT:
        _CUT.popitem(last=False)
    return profile


def _envelope(toolpath: Toolpath, rho: float, include_junction: bool) -> TabulatedProfile:
    m = toolpath.mirror
    segs = toolpath.segments
    lobes = toolpath.lobe_of
    out = []
    for k, name in enumerate(("inner", "outer")):
        lo, hi = (0.0, m.r_junction) if k == 0 else (m.r_junction, m.r_max)
        n = int(math.ceil((hi - lo) / GRID)) + 1
        r = np.linspace(lo, hi, n)
        if k == 1:
            r[0] = np.nextafter(lo, hi)
        # the fillet at the wall's foot (on the recessed lobe) is the nose circle near its
        # side, steep: sample finer
        if k == 0 and m.step > 0:
            r = np.union1d(r, np.linspace(max(lo, hi - 2 * rho), hi, 8001))
        elif k == 1 and m.step <= 0:
            r = np.union1d(r, np.linspace(r[0], min(hi, lo + 2 * rho), 8001))
        if k == 0 and m.step <= 0:
            # the inner lobe's last sample just inside r_junction: at r_junction itself a nose
            # running down the wall (its centre exactly rho beyond, e.g. 0.21 mm on the 0.005 mm
            # lattice) reaches the wall's foot, which interpolation would smear over the rim
            r[-1] = np.nextafter(hi, lo)
        n = r.size
        keep = [i for i, lb in enumerate(lobes) if lb == name or (include_junction and lb == "junction")]
        zbest = np.full(n, np.inf)
        sbest = np.zeros(n)
        for i in keep:
            _piece_move(segs[i], rho, r, zbest, sbest)
        by_move = np.isfinite(zbest)
        verts, lo_r, hi_r = _vertex_windows(segs, keep, rho, ends=not include_junction)
        _piece_discs(verts, lo_r, hi_r, rho, r, zbest, sbest)
        ok = np.isfinite(zbest)
        if not include_junction:
            # beyond the moves' own offsets only vertex discs reach: extend the moves
            idx = np.flatnonzero(by_move)
            if idx.size:
                ok[: idx[0]] = False
                ok[idx[-1] + 1:] = False
                zbest[~ok] = np.inf
        if not np.any(ok):
            raise ValueError(f"nose envelope: no move covers the {name} lobe")
        if not np.all(ok):  # extend the ends linearly (only without the junction)
            idx = np.flatnonzero(ok)
            a, b = idx[0], idx[-1]
            zbest[:a] = zbest[a] + sbest[a] * (r[:a] - r[a])
            sbest[:a] = sbest[a]
            zbest[b + 1:] = zbest[b] + sbest[b] * (r[b + 1:] - r[b])
            sbest[b + 1:] = sbest[b]
            gaps = ~np.isfinite(zbest)
            if np.any(gaps):
                zbest[gaps] = np.interp(r[gaps], r[~gaps], zbest[~gaps])
                sbest[gaps] = np.interp(r[gaps], r[~gaps], sbest[~gaps])
        # camera frame: z = vertex_z - Z, dz/dr = -dZ/dr
        out.append((r, m.vertex_z - zbest, -sbest))
    return TabulatedProfile(out[0], out[1], r_junction=m.r_junction, r_max=m.r_max,
                            vertex_z=m.vertex_z)


def _take_lower(r_idx: np.ndarray, z: np.ndarray, s: np.ndarray, zbest, sbest) -> None:
    better = z < zbest[r_idx]
    zbest[r_idx[better]] = z[better]
    sbest[r_idx[better]] = s[better]


def _piece_move(seg, rho: float, r: np.ndarray, zbest, sbest) -> None:
    """Lower offset of one move (toward -Z) by rho, closed form, on the grid r."""
    if isinstance(seg, Line):
        (r0, z0), (r1, z1) = seg.start, seg.end
        dr, dz = r1 - r0, z1 - z0
        ln = math.hypot(dr, dz)
        if ln == 0 or abs(dr) < 1e-12:
            return  # a vertical move: its lower edge is its end discs
        # the normal with negative Z component
        nr, nz = -dz / ln, dr / ln
        if nz > 0:
            nr, nz = -nr, -nz
        a, b = sorted((r0 + rho * nr, r1 + rho * nr))
        i0, i1 = np.searchsorted(r, [a, b])
        if i1 <= i0:
            return
        idx = np.arange(i0, i1)
        slope = dz / dr
        z = (z0 + rho * nz) + slope * (r[idx] - (r0 + rho * nr))
        _take_lower(idx, z, np.full(idx.size, slope), zbest, sbest)
    else:
        c = np.asarray(seg.centre, dtype=float)
        R0, R1 = seg.radius - rho, seg.end_radius - rho
        if R0 <= 0 or R1 <= 0:
            return
        a0 = math.atan2(seg.start[1] - c[1], seg.start[0] - c[0])
        sweep = seg.sweep
        phis = (a0, a0 + sweep)
        ra = c[0] + R0 * math.cos(phis[0])
        rb = c[0] + R1 * math.cos(phis[1])
        a, b = sorted((ra, rb))
        i0, i1 = np.searchsorted(r, [a, b])
        if i1 <= i0:
            return
        idx = np.arange(i0, i1)
        z, s = spiral_at_r(r[idx], c[0], c[1], R0, R1, phis[0], phis[1])  # the move's numbers broadcast
        _take_lower(idx, z, s, zbest, sbest)


#: Margin (rad) added to each side of a vertex's window (_vertex_windows): rounding.
WINDOW_PAD = 0.01


#: A move's travel counts as along r at a vertex when the r part of its unit tangent there
#: is at least this (nearer a vertical tangent the vertex keeps its whole lower half).
ALONG_R = 0.05


def _lower_normal_angles(seg, rho: float):
    """For a move: the angles (rad, from -Z toward +r) of the directions from its start and
    end to its offset toward the part (_piece_move's); a margin for a spiral, whose radial
    offset crosses the nose circle at its ends at up to that angle; and the way the move
    travels in r at its start and end (+1, -1, or 0 near a vertical tangent). None where
    the lower half of the nose circle must be kept whole (a vertical move, a move with no
    offset)."""
    if isinstance(seg, Line):
        (r0, z0), (r1, z1) = seg.start, seg.end
        dr, dz = r1 - r0, z1 - z0
        ln = math.hypot(dr, dz)
        if ln == 0 or abs(dr) < 1e-12:
            return None
        nr, nz = -dz / ln, dr / ln
        if nz > 0:
            nr, nz = -nr, -nz
        a = math.atan2(nr, -nz)
        way = _way(dr / ln)
        return a, a, 0.0, way, way
    cr, cz = seg.centre
    R0, R1 = seg.radius, seg.end_radius
    if min(R0, R1) - rho <= 0 or seg.start[1] <= cz or seg.end[1] <= cz:
        return None
    a0 = math.atan2(cr - seg.start[0], seg.start[1] - cz)  # toward the centre: (cr - r, cz - Z)
    a1 = math.atan2(cr - seg.end[0], seg.end[1] - cz)
    sweep = abs(seg.sweep)
    if sweep == 0:
        return None
    crossing = math.atan(abs(R1 - R0) / (sweep * (min(R0, R1) - rho)))
    # the travel: (dR cos phi - R sin phi, dR sin phi + R cos phi) per radian, times the sweep's sign
    dR = (R1 - R0) / seg.sweep
    ways = []
    for (r, z), R in ((seg.start, R0), (seg.end, R1)):
        phi = math.atan2(z - cz, r - cr)
        vr, vz = dR * math.cos(phi) - R * math.sin(phi), dR * math.sin(phi) + R * math.cos(phi)
        ways.append(_way(math.copysign(1.0, seg.sweep) * vr / math.hypot(vr, vz)))
    return a0, a1, 3.0 * crossing, ways[0], ways[1]


def _way(tangent_r: float) -> int:
    """+1 or -1: the way a move travels in r (tangent_r: its unit tangent's r part); 0
    when it runs within ALONG_R of vertical."""
    return 0 if abs(tangent_r) < ALONG_R else (1 if tangent_r > 0 else -1)


def _vertex_windows(segs, keep: list[int], rho: float, *, ends: bool):
    """The vertices of the kept moves (sorted, unique) and the radii (lo_r, hi_r) between
    which each one's nose circle can be the envelope.

    The lower boundary of the nose swept along a path is made of the moves' offsets and,
    at each vertex, the arc of the nose circle the two moves leave exposed: the directions
    u with u . t <= 0 for both moves' tangents t pointing away from the vertex; anywhere
    else the circle lies inside the region the nose sweeps along the move beside it (its
    offset and its far end's circle). Where the path keeps its way in r through the vertex
    that arc lies between the two moves' offset directions, so such a vertex needs only
    that window of angles (plus WINDOW_PAD, and a spiral's crossing margin). A path's end,
    a turn back in r, a tangent near vertical, a vertical move's ends and a gap keep the
    whole lower half (-rho .. +rho). ends=True: the kept run's first and last points are
    left out (contour_profile's offset without the junction), and so the vertices next to
    them keep the whole half too (the end's circle no longer covers theirs)."""
    if not keep:
        return np.empty((0, 2)), np.empty(0), np.empty(0)
    angles = [_lower_normal_angles(segs[i], rho) for i in keep]
    half = math.pi / 2
    pts, lo, hi = [], [], []
    for n, i in enumerate(keep):
        # the move's start joins the previous kept move's end, its end the next one's start
        for point, j, at_end in ((segs[i].start, n - 1, False), (segs[i].end, n + 1, True)):
            pts.append(point)
            joined = 0 <= j < len(keep) and tuple(segs[keep[j]].start if at_end else segs[keep[j]].end) == tuple(point)
            beside_end = ends and (n + (0 if at_end else -1) == 0 or n + (1 if at_end else 0) == len(keep) - 1)
            mine, theirs = angles[n], (angles[j] if joined else None)
            whole = beside_end or mine is None or theirs is None
            if not whole:
                a, way = (mine[1], mine[4]) if at_end else (mine[0], mine[3])
                b, way_j = (theirs[0], theirs[3]) if at_end else (theirs[1], theirs[4])
                whole = way == 0 or way != way_j  # a turn back in r, or a tangent near vertical
            if whole:
                lo.append(-half)
                hi.append(half)
            else:
                pad = WINDOW_PAD + max(mine[2], theirs[2])
                lo.append(max(-half, min(a, b) - pad))
                hi.append(min(half, max(a, b) + pad))
    pts = np.asarray(pts, float)
    verts, inv = np.unique(pts, axis=0, return_inverse=True)
    inv = inv.ravel()
    wlo = np.full(len(verts), np.inf)
    whi = np.full(len(verts), -np.inf)
    np.minimum.at(wlo, inv, np.asarray(lo))
    np.maximum.at(whi, inv, np.asarray(hi))
    if ends:
        drop = {tuple(segs[keep[0]].start), tuple(segs[keep[-1]].end)}
        keep_v = np.array([tuple(v) not in drop for v in verts], bool)
        verts, wlo, whi = verts[keep_v], wlo[keep_v], whi[keep_v]
    return verts, verts[:, 0] + rho * np.sin(wlo), verts[:, 0] + rho * np.sin(whi)


def grid_spans(i0: np.ndarray, i1: np.ndarray, first: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Piece k's grid indices i0[k] .. i1[k] - 1 (none where i1 <= i0), all flattened:
    (the piece's number, counted from `first`; the grid index)."""
    counts = np.maximum(i1 - i0, 0)
    total = int(counts.sum())
    owner = np.repeat(np.arange(first, first + counts.size), counts)
    idx = np.repeat(i0, counts) + np.arange(total) - np.repeat(np.cumsum(counts) - counts, counts)
    return owner, idx


def _piece_discs(verts: np.ndarray, lo_r: np.ndarray, hi_r: np.ndarray, rho: float, r: np.ndarray,
                 zbest, sbest) -> None:
    """Lower half of the nose circle at each vertex, on the grid r between lo_r and hi_r
    (its window, _vertex_windows; vectorised)."""
    if verts.size == 0:
        return
    owner, idx = grid_spans(np.searchsorted(r, lo_r), np.searchsorted(r, hi_r, side="right"))
    if idx.size == 0:
        return
    dx = r[idx] - verts[owner, 0]
    h = np.sqrt(np.maximum(rho * rho - dx * dx, 0.0))
    z = verts[owner, 1] - h
    s = np.where(h > 0, dx / np.where(h > 0, h, 1.0), np.sign(dx) * 1e6)
    # the lowest disc at each grid radius (the first such vertex on a tie): grouped by the
    # radius (a stable integer sort, linear), each group's minimum, its first entry at it
    order = np.argsort(idx, kind="stable")
    idx, z, s = idx[order], z[order], s[order]
    starts = np.flatnonzero(np.concatenate([[True], idx[1:] != idx[:-1]]))
    group = np.repeat(np.arange(starts.size), np.diff(np.append(starts, idx.size)))
    at_min = np.flatnonzero(z == np.minimum.reduceat(z, starts)[group])
    pick = at_min[np.concatenate([[True], group[at_min[1:]] != group[at_min[:-1]]])]
    _take_lower(idx[pick], z[pick], s[pick], zbest, sbest)


def gouge_depth(toolpath: Toolpath, nose_radius: float | None = None) -> float:
    """Deepest point (mm) of the as-machined surface inside the exact part (0 if none).

    Measured from each lobe's sheet (foot point by Newton) over the envelope's samples,
    and from the step's top corner to the nose along the junction moves (the one place
    the part's boundary is not a lobe sheet that the nose passes).
    """
    rho = toolpath.nose_radius if nose_radius is None else float(nose_radius)
    m = toolpath.mirror
    prof = as_machined(toolpath, rho)
    depth = 0.0
    for k, lobe in enumerate(m.lobes):
        lo, hi = prof.lobe_range(k)
        r = np.linspace(lo, hi, 40001)
        if k == 1:
            r[0] = np.nextafter(lo, hi)
        if hasattr(prof, "breakpoints"):
            bp = prof.breakpoints(k)
            r = np.concatenate([r, bp[(bp > lo) & (bp <= hi)]])
        z = prof.z(r)
        inside = -signed_distance_camera(lobe, r, z)  # > 0: inside the part, below the sheet
        if k == 1:
            # beside the step wall the part's nearest boundary may be the wall itself
            zi, zo = m.junction_z
            beside = (z <= zi) & (z >= zo)
            inside = np.where(beside, np.minimum(inside, r - m.r_junction), inside)
        depth = max(depth, float(inside.max()))
    # the step's top corner (machine frame: the higher sheet at the junction) against the
    # nose along the junction moves
    corner = np.array([m.r_junction, m.vertex_z - min(m.junction_z)])
    for seg, lb in zip(toolpath.segments, toolpath.lobe_of):
        if lb != "junction":
            continue
        p = seg.sample(2001)
        dist = np.hypot(*(p - corner).T).min()
        depth = max(depth, rho - float(dist))
    return depth


def junction_fillet(toolpath: Toolpath, nose_radius: float | None = None) -> dict | None:
    """What the nose leaves in the junction's inside corner, or None for a sharp tool.

    The corner is at the foot of the step wall, on the recessed lobe's rim (the inner
    lobe's outer edge, or the outer lobe's inner edge). lobe: which lobe carries the
    fillet. r_start_mm .. r_end_mm: the radii it spans, from where it leaves the lobe's
    sheet (the nose's contact point when its centre is at the corner) to the wall (r =
    r_junction), or from the wall out; height_mm: how far above the wall's foot the
    fillet meets the wall. The camera sees this band through a fillet, not the designed
    sheet.
    """
    rho = toolpath.nose_radius if nose_radius is None else float(nose_radius)
    if rho == 0.0:
        return None
    m = toolpath.mirror
    rj = np.array([m.r_junction])
    if m.step > 0:
        c = toolpath.lobe_segments("inner")[-1].end
        r_start = float(foot_on_sheet(m.inner, np.array([c[0]]), np.array([c[1]]), zero=m.vertex_z)[0])
        height = float(m.inner.z(rj)[0] - as_machined(toolpath, rho).z(rj)[0])
        return {"lobe": "inner", "r_start_mm": r_start, "r_end_mm": m.r_junction, "height_mm": height}
    # the nose centre at the wall's foot; the fillet meets the wall at its height
    c = toolpath.lobe_segments("outer")[0].start
    r_end = float(foot_on_sheet(m.outer, np.array([c[0]]), np.array([c[1]]), zero=m.vertex_z)[0])
    height = float(c[1] - (m.vertex_z - m.outer.z(rj)[0]))
    return {"lobe": "outer", "r_start_mm": m.r_junction, "r_end_mm": r_end, "height_mm": height}
