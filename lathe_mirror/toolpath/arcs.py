"""Strategy ARCS (BEST): G2/G3 arcs, end points the lattice points nearest the curve,
centres the lattice points whose cut arc follows the curve's slope best.

The centre is scored on the arc the controller actually cuts (LinuxCNC's spiral when the
two radii differ). An arc follows a smooth curve's turning tangent, a chord cannot: on
the paper's machine the max slope error falls ~80x against the paper's method.
"""

from __future__ import annotations

import math

import numpy as np

from ..lathe import Lathe
from ..path import Arc, Line, Move
from ..sheet import Target, foot_on_sheet
from .layout import Layout, as_point, lattice_candidates


def arc_moves(layout: Layout, lathe: Lathe) -> tuple[list, list]:
    """G2/G3 arcs per lobe, end points and centres on the lattice (see module doc)."""
    budget = lathe.max_points - 1 - (1 + layout.junction_extra())  # start, junction
    n_arcs = _arc_counts(layout, budget)
    inner_arcs = _lobe_arcs(layout.inner, lathe, layout.inner_cols, n_arcs[0])
    outer_arcs = _lobe_arcs(layout.outer, lathe, layout.outer_cols, n_arcs[1])
    j = layout.junction_moves(np.asarray(inner_arcs[-1].end), np.asarray(outer_arcs[0].start))
    segs: list[Move] = [*inner_arcs, *j, *outer_arcs]
    lobes = ["inner"] * len(inner_arcs) + ["junction"] * len(j) + ["outer"] * len(outer_arcs)
    return segs, lobes


#: Target arc length (mm). Longer arcs tilt less for the same lattice offset of their
#: ends (~1e-5 mm for the lattice point nearest the curve in a 0.6 mm window); shorter
#: ones follow the hyperbola's changing curvature better (slope error ~ k' L^2 / 8).
#: Measured on the paper's mirror (nose 0): max slope error inner/outer 1.40e-3/9.7e-4
#: rad at 0.4 mm, 1.07e-3/9.7e-4 at 0.8, 6.9e-4/9.7e-4 at 1.0, 1.00e-3/9.7e-4 at 1.5,
#: 1.61e-3/9.7e-4 at 2.0, 2.94e-3/9.7e-4 at 3.0 (the outer figure is its fixed-column ends').
_ARC_LENGTH = 1.0

#: Lengths (mm) tried for an arc ending on a fixed column.
_END_ARC_LENGTHS = (0.4, 0.6, 0.8, 1.0, 1.3, 1.6, 2.0, 2.5, 3.0, 4.0)


def _arc_counts(layout: Layout, budget: int) -> tuple[int, int]:
    """Arcs per lobe: one per `_ARC_LENGTH` mm, fewer (shared by length) if the budget
    (2 points per arc) cannot hold that many."""
    want = [max(1, int(math.ceil(t.length / _ARC_LENGTH))) + 2 for t in layout.targets()]
    cap = budget // 2
    if sum(want) > cap:
        n0 = max(1, min(cap - 1, int(round(cap * want[0] / sum(want)))))
        return n0, cap - n0
    return want[0], want[1]


def _lobe_arcs(t: Target, lathe: Lathe, cols, m: int) -> list[Move]:
    """Arcs along one lobe, at most m of them.

    An end point held to a fixed column (the wall, the rim) can only be the lattice
    point above or below the curve there, up to half a step off it, and an arc through
    two points cannot rotate: it tilts by about that offset over its length. So the
    arc ending there is chosen by search over its length and the column's two lattice
    rows (the longest arcs follow the slowly changing curvature at the rims well); the
    other end points are the lattice points nearest the curve at even spacing. The
    axis end is exempt: the curve crosses it level, on the vertex's own lattice row.
    """
    res = lathe.resolution
    length = t.length
    s_of = lambda p: np.interp(foot_on_sheet(t.lobe, p[..., 0], p[..., 1], zero=t.zero),  # noqa: E731
                               t.rs, t.s_tab)
    first = last = None
    s_lo, s_hi = 0.0, length
    m_left = m
    if cols[0] is not None and cols[0] > 0.0 and m >= 3:
        first = _end_arc(t, lathe, cols[0], at_start=True)
        s_lo = float(s_of(np.asarray(first.end)))
        m_left -= 1
    if cols[1] is not None and m >= 3:
        last = _end_arc(t, lathe, cols[1], at_start=False)
        s_hi = float(s_of(np.asarray(last.start)))
        m_left -= 1
    n_mid = max(1, min(m_left, int(math.ceil((s_hi - s_lo) / _ARC_LENGTH))))
    s_nom = np.linspace(s_lo, s_hi, n_mid + 1)
    end_cols = (None if first is None else first.end[0], None if last is None else last.start[0])
    if first is None:
        end_cols = (cols[0], end_cols[1])
    if last is None:
        end_cols = (end_cols[0], cols[1])
    cr, cz, _, _, _ = lattice_candidates(t, s_nom, res, end_cols, k_best=2)
    ends = np.stack([cr[:, 0], cz[:, 0]], axis=-1)
    if first is not None:
        ends[0] = first.end
    if last is not None:
        ends[-1] = last.start
    arcs, _ = _fit_arcs(t, ends, lathe)
    return ([first] if first else []) + arcs + ([last] if last else [])


def _end_arc(t: Target, lathe: Lathe, col: float, *, at_start: bool) -> Move:
    """The arc from (at_start) or to the fixed column `col`: the best of the column's two
    lattice rows against free ends at each of _END_ARC_LENGTHS."""
    res = lathe.resolution
    lens = np.asarray([x for x in _END_ARC_LENGTHS if x < 0.45 * t.length])
    s_fixed = 0.0 if at_start else t.length
    s_free = lens if at_start else t.length - lens[::-1]
    # the fixed column's two lattice rows
    if at_start:
        fr, fz, _, _, _ = lattice_candidates(t, np.array([0.0, 0.1]), res, (col, None), k_best=2)
        fixed = np.stack([fr[0], fz[0]], axis=-1)  # (2, 2)
    else:
        fr, fz, _, _, _ = lattice_candidates(t, np.array([t.length - 0.1, t.length]), res, (None, col), k_best=2)
        fixed = np.stack([fr[-1], fz[-1]], axis=-1)
    gr, gz, _, _, _ = lattice_candidates(t, np.concatenate([[s_fixed], s_free]) if at_start
                                  else np.concatenate([s_free, [s_fixed]]), res, (None, None), k_best=1)
    free = np.stack([gr[:, 0], gz[:, 0]], axis=-1)
    free = free[1:] if at_start else free[:-1]
    pairs_f = np.repeat(fixed, len(free), axis=0)
    pairs_g = np.tile(free, (2, 1))
    S, E = (pairs_f, pairs_g) if at_start else (pairs_g, pairs_f)
    arcs, err = _fit_arcs(t, None, lathe, starts=S, ends_=E)
    return arcs[int(np.argmin(err))]


def _fit_arcs(t: Target, ends: np.ndarray | None, lathe: Lathe, *, window: int = 10,
              n_check: int = 9, starts: np.ndarray | None = None,
              ends_: np.ndarray | None = None) -> tuple[list[Move], np.ndarray]:
    """One arc per consecutive pair of end points, its centre the lattice point (within
    `window` steps of the best circle's centre) whose cut arc has the smallest max slope
    error (rad) against the curve, among those within the radius tolerance; a G1 line
    where no centre is (score inf). Returns the moves and their scores."""
    res = lathe.resolution
    if ends is not None:
        S, E = ends[:-1], ends[1:]
    else:
        S, E = starts, ends_
    m = S.shape[0]
    # the ideal centre: on the normal at the middle, at the middle's radius of curvature
    mid = 0.5 * (S + E)
    rs_mid = foot_on_sheet(t.lobe, mid[:, 0], mid[:, 1], zero=t.zero)
    kap = t.curvature(rs_mid)
    # the circle of that curvature through S and E: its centre on SE's perpendicular
    # bisector, on the part's side (below the chord, which runs toward +r)
    chord = E - S
    half = 0.5 * np.hypot(chord[:, 0], chord[:, 1])
    perp = np.stack([chord[:, 1], -chord[:, 0]], axis=-1) / (2.0 * half)[:, None]
    rad = np.maximum(1.0 / kap, half * 1.000001)
    c_ideal = mid + np.sqrt(rad**2 - half**2)[:, None] * perp
    offs = np.arange(-window, window + 1)
    gi, gj = np.meshgrid(offs, offs, indexing="ij")
    base = np.rint(c_ideal / res).astype(np.int64)
    cand = (base[:, None, :] + np.stack([gi.ravel(), gj.ravel()], axis=-1)[None]) * res  # (m, c, 2)
    r0 = np.hypot(*(S[:, None, :] - cand).transpose(2, 0, 1))
    r1 = np.hypot(*(E[:, None, :] - cand).transpose(2, 0, 1))
    ok = np.abs(r1 - r0) <= lathe.arc_radius_tolerance
    # sample each candidate's spiral and score its max slope error against the curve; only
    # the candidates within the radius tolerance (those near SE's bisector: a few of the
    # window's (2 window + 1)^2) are scored, the others cannot be cut
    ii, jj = np.nonzero(ok)
    sweep = np.zeros(ok.shape)
    c_ok, r0k, r1k = cand[ii, jj], r0[ii, jj], r1[ii, jj]
    a0 = np.arctan2(S[ii, 1] - c_ok[:, 1], S[ii, 0] - c_ok[:, 0])
    a1 = np.arctan2(E[ii, 1] - c_ok[:, 1], E[ii, 0] - c_ok[:, 0])
    sw = (a1 - a0 + np.pi) % (2 * np.pi) - np.pi
    sweep[ii, jj] = sw
    u = np.linspace(0.0, 1.0, n_check)
    phi = a0[:, None] + sw[:, None] * u
    rad = r0k[:, None] + (r1k - r0k)[:, None] * u
    pr = c_ok[:, 0, None] + rad * np.cos(phi)
    pz = c_ok[:, 1, None] + rad * np.sin(phi)
    # tangent of the spiral: d/dphi of (R cos, R sin) with dR/dphi = (r1 - r0) / sweep
    dR = ((r1k - r0k) / np.where(sw == 0, 1.0, sw))[:, None]
    tr = dR * np.cos(phi) - rad * np.sin(phi)
    tz = dR * np.sin(phi) + rad * np.cos(phi)
    sign = np.where(tr < 0, -1.0, 1.0)  # orient toward +r
    ang = np.arctan2(tz * sign, tr * sign)
    d, th = t.errors(pr, pz)
    err = np.max(np.abs(ang - th), axis=-1)
    dev = np.max(np.abs(d), axis=-1)
    # Radius tolerance: hard (the controller's spiral). Deviation within 4 steps: preferred
    # (a centre off by more would follow the slope at the cost of the surface's place),
    # but on a fine lattice a long arc at a fixed column may not get that close to the
    # hyperbola at all; then the best centre beyond it still beats a chord.
    score = np.full(ok.shape, np.inf)
    score[ii, jj] = err + 0.1 * dev + np.where(dev < 4 * res, 0.0, _FAR)
    best = np.argmin(score, axis=1)
    moves: list[Move] = []
    for i in range(m):
        if not np.isfinite(score[i, best[i]]):
            # no lattice centre cuts an arc within the radius tolerance (a coarse lattice):
            # a G1 chord between the same lattice ends; the gouge check judges it
            moves.append(Line(as_point(S[i]), as_point(E[i])))
            continue
        c = cand[i, best[i]]
        moves.append(Arc(start=as_point(S[i]), end=as_point(E[i]), centre=as_point(c),
                         clockwise=bool(sweep[i, best[i]] > 0)))
    return moves, score[np.arange(m), best]


#: Score added to a centre whose arc strays more than 4 lattice steps from the curve.
_FAR = 1.0e3
