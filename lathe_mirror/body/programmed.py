"""The programmed mirror face: the toolpath's nose-centre moves offset back to the surface
the nose cuts, as meridian segments (lines and arcs) that body.meridian closes into a body.

Machine frame (r, Z), mm, as body.meridian. Nothing here imports cadquery.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any, Iterable

from ..design import Mirror
from ..errors import InputError
from ..path import Arc

if TYPE_CHECKING:
    from ..toolpath import Toolpath
from .meridian import (
    BodySpec,
    Meridian,
    Role,
    Segment,
    SegmentKind,
    programmed_meridian,
)


def moves_as_segments(moves: Iterable[Any], role: Role = Role.MIRROR) -> list[Segment]:
    """Toolpath moves (path.Line | path.Arc: start, end, centre; machine frame (r, Z), mm)
    as meridian segments.

    LinuxCNC cuts an arc whose end radius differs from its start radius (by at most the
    lathe's arc_radius_tolerance) as a spiral; an exact revolve needs a circle, so such an
    arc becomes the circle through its start, its spiral's midpoint and its end (within
    a quarter of the radius difference of the spiral).
    """
    out = []
    for m in moves:
        start = (float(m.start[0]), float(m.start[1]))
        end = (float(m.end[0]), float(m.end[1]))
        if math.dist(start, end) == 0.0:
            continue
        if isinstance(m, Arc):
            c = (float(m.centre[0]), float(m.centre[1]))
            r0, r1 = math.dist(start, c), math.dist(end, c)
            a0 = math.atan2(start[1] - c[1], start[0] - c[0])
            a1 = math.atan2(end[1] - c[1], end[0] - c[0])
            sweep = (a1 - a0 + math.pi) % (2.0 * math.pi) - math.pi  # |sweep| < pi
            if r0 != r1:
                am = a0 + 0.5 * sweep
                rm = 0.5 * (r0 + r1)
                mid = (c[0] + rm * math.cos(am), c[1] + rm * math.sin(am))
                c = _circumcentre(start, mid, end)
                r0 = math.dist(start, c)
            out.append(Segment(SegmentKind.ARC, start, end, role, centre=c, radius=r0,
                               clockwise=sweep < 0.0))
        else:
            out.append(Segment(SegmentKind.LINE, start, end, role))
    return out


#: Offset ends closer than this (mm) are merged at their midpoint (see programmed_contour).
SNAP = 1e-6


def programmed_contour(centre_path: list[Segment], nose_radius: float) -> list[Segment]:
    """The contour a nose of radius rho (`nose_radius`, mm) cuts when its centre follows
    `centre_path` (machine frame (r, Z), mm): the path offset by rho to its right (the
    part's side, for a path running outward from the axis), lines staying lines and
    arcs concentric arcs (radius R + rho counter-clockwise,
    R - rho clockwise). Where the path turns left (the step wall's foot) the nose leaves
    an arc of radius rho about the vertex; where it turns right the two offsets are cut
    at their intersection. This is the exact envelope of the nose, as in cutter-radius
    compensation (G41/G42) run backwards, except that offset ends closer than SNAP
    (1e-6 mm, where consecutive moves are tangent to rounding) meet at their midpoint.
    """
    rho = float(nose_radius)
    if rho == 0.0:
        return [Segment(s.kind, s.start, s.end, Role.MIRROR, s.centre, s.radius, s.clockwise)
                for s in centre_path]
    off = [_offset(s, rho) for s in centre_path]
    # Each contour piece with the direction its move ran (lines) to spot a piece that a
    # trim turned round: that move's nose never touched the part (it cut air, e.g. the
    # junction's move rounded away from the step's top corner) and it drops out.
    items: list[list[Any]] = []
    cur = off[0]
    for k in range(1, len(off)):
        nxt = off[k]
        vertex = centre_path[k].start
        t1, t2 = segment_tangent(centre_path[k - 1], end=True), segment_tangent(centre_path[k], end=False)
        turn = math.atan2(t1[0] * t2[1] - t1[1] * t2[0], t1[0] * t2[0] + t1[1] * t2[1])
        gap = math.dist(cur.end, nxt.start)
        if gap <= SNAP:
            # Offsets of (nearly) tangent moves: meet halfway rather than leave a
            # sub-micron fillet or a sliver face.
            mid = (0.5 * (cur.end[0] + nxt.start[0]), 0.5 * (cur.end[1] + nxt.start[1]))
            cur = _with_ends(cur, cur.start, mid)
            nxt = _with_ends(nxt, mid, nxt.end)
        elif turn > 0.0:  # left turn: the nose swings about the vertex
            items.append([cur, segment_tangent(centre_path[k - 1], end=False)])
            cur = Segment(SegmentKind.ARC, cur.end, nxt.start, Role.MIRROR, centre=vertex,
                          radius=rho, clockwise=False)
        else:  # right turn: the offsets overlap; cut both at their crossing
            p = _intersection(cur, nxt, near=(0.5 * (cur.end[0] + nxt.start[0]),
                                              0.5 * (cur.end[1] + nxt.start[1])))
            cur = _with_ends(cur, cur.start, p)
            nxt = _with_ends(nxt, p, nxt.end)
        items.append([cur, segment_tangent(centre_path[k - 1], end=False) if cur.kind is SegmentKind.LINE else None])
        cur = nxt
    items.append([cur, segment_tangent(centre_path[-1], end=False)])
    _drop_turned_round(items)
    out = [seg for seg, _ in items]
    # The first move leaves the axis; its offset may start a hair off it (lattice
    # rounding tilts the move): cut it at r = 0, or leave it for the body to face flat.
    first = out[0]
    if first.start[0] < 0.0:
        p = _intersection(first, Segment(SegmentKind.LINE, (0.0, first.start[1] - 1.0),
                                         (0.0, first.start[1] + 1.0)), near=first.start)
        out[0] = _with_ends(first, p, first.end)
    for seg in out:
        _check_direction(seg)
    return out


def programmed_parts(tp: Toolpath, mirror: Mirror, spec: BodySpec
                     ) -> tuple[Meridian, tuple[Segment, ...], dict[str, Any]]:
    """The programmed meridian of a planned finishing toolpath on the body `spec`, the
    tool-centre path (the programmed moves) and the toolpath's figures."""
    centre = moves_as_segments(tp.segments, role=Role.MIRROR)
    contour = programmed_contour(centre, tp.nose_radius)
    figures = {
        "strategy": tp.strategy.value,
        "moves": len(tp.segments),
        "arcs": sum(1 for s in tp.segments if isinstance(s, Arc)),
        "points": int(tp.n_points),
        "nose_radius_mm": float(tp.nose_radius),
        "contour_segments": len(contour),
    }
    return programmed_meridian(contour, mirror, spec), tuple(centre), figures


def _circumcentre(a: tuple[float, float], b: tuple[float, float],
                  c: tuple[float, float]) -> tuple[float, float]:
    """Centre of the circle through three points."""
    ax, ay = a
    bx, by = b[0] - ax, b[1] - ay
    cx, cy = c[0] - ax, c[1] - ay
    d = 2.0 * (bx * cy - by * cx)
    b2, c2 = bx * bx + by * by, cx * cx + cy * cy
    return (ax + (cy * b2 - by * c2) / d, ay + (bx * c2 - cx * b2) / d)


def segment_tangent(s: Segment, *, end: bool) -> tuple[float, float]:
    """Unit direction of travel at the start or the end of a segment."""
    if s.kind is SegmentKind.LINE:
        d = (s.end[0] - s.start[0], s.end[1] - s.start[1])
        n = math.hypot(*d)
        return (d[0] / n, d[1] / n)
    p = s.end if end else s.start
    ux, uy = (p[0] - s.centre[0]) / s.radius, (p[1] - s.centre[1]) / s.radius
    return (uy, -ux) if s.clockwise else (-uy, ux)


def _offset(s: Segment, rho: float) -> Segment:
    """The segment moved by rho to the right of its direction of travel."""
    if s.kind is SegmentKind.LINE:
        tx, ty = segment_tangent(s, end=False)
        nx, ny = ty, -tx  # right-hand normal
        return Segment(SegmentKind.LINE, (s.start[0] + rho * nx, s.start[1] + rho * ny),
                       (s.end[0] + rho * nx, s.end[1] + rho * ny), Role.MIRROR)
    radius = s.radius - rho if s.clockwise else s.radius + rho
    if radius <= 0.0:
        raise InputError(
            f"tool.nose_radius = {rho:g} mm exceeds the radius {s.radius:.4f} mm of a "
            f"concave programmed arc at {s.start}: the nose cannot cut it"
        )
    k = radius / s.radius
    cr, cz = s.centre
    move = lambda p: (cr + k * (p[0] - cr), cz + k * (p[1] - cz))  # noqa: E731
    return Segment(SegmentKind.ARC, move(s.start), move(s.end), Role.MIRROR,
                   centre=s.centre, radius=radius, clockwise=s.clockwise)


def _with_ends(s: Segment, start: tuple[float, float], end: tuple[float, float]) -> Segment:
    return Segment(s.kind, (float(start[0]), float(start[1])), (float(end[0]), float(end[1])),
                   s.role, s.centre, s.radius, s.clockwise, s.a, s.b, s.lobe)


def _intersection(s1: Segment, s2: Segment, *, near: tuple[float, float]) -> tuple[float, float]:
    """The crossing of two segments' carrier lines/circles nearest to `near`; if they
    do not cross (offsets of tangent moves, rounding), `near` itself."""
    def line_circle(p: tuple, d: tuple, c: tuple, R: float) -> list:
        fx, fy = p[0] - c[0], p[1] - c[1]
        b = fx * d[0] + fy * d[1]
        disc = b * b - (fx * fx + fy * fy - R * R)
        if disc < 0.0:
            return []
        q = math.sqrt(disc)
        return [(p[0] + t * d[0], p[1] + t * d[1]) for t in (-b - q, -b + q)]

    kinds = (s1.kind, s2.kind)
    cands: list = []
    if kinds == (SegmentKind.LINE, SegmentKind.LINE):
        d1, d2 = segment_tangent(s1, end=False), segment_tangent(s2, end=False)
        den = d1[0] * d2[1] - d1[1] * d2[0]
        if abs(den) > 1e-15:
            wx, wy = s2.start[0] - s1.start[0], s2.start[1] - s1.start[1]
            t = (wx * d2[1] - wy * d2[0]) / den
            cands = [(s1.start[0] + t * d1[0], s1.start[1] + t * d1[1])]
    elif SegmentKind.LINE in kinds:
        ln, arc = (s1, s2) if s1.kind is SegmentKind.LINE else (s2, s1)
        cands = line_circle(ln.start, segment_tangent(ln, end=False), arc.centre, arc.radius)
    else:
        (x1, y1), (x2, y2) = s1.centre, s2.centre
        R1, R2 = s1.radius, s2.radius
        d = math.hypot(x2 - x1, y2 - y1)
        if d > 0.0:
            a = (d * d + R1 * R1 - R2 * R2) / (2.0 * d)
            h2 = R1 * R1 - a * a
            if h2 >= 0.0:
                h = math.sqrt(h2)
                ex, ey = (x2 - x1) / d, (y2 - y1) / d
                mx, my = x1 + a * ex, y1 + a * ey
                cands = [(mx - h * ey, my + h * ex), (mx + h * ey, my - h * ex)]
    if not cands:
        return near
    return min(cands, key=lambda p: math.dist(p, near))


def _turned_round(s: Segment, direction: tuple[float, float] | None) -> bool:
    """True if a trimmed piece runs against its move (line) or wraps (arc: the pieces
    are all shorter than half a turn, so a sweep of pi or more means it was inverted)."""
    if s.kind is SegmentKind.LINE:
        d = (s.end[0] - s.start[0], s.end[1] - s.start[1])
        return direction is not None and d[0] * direction[0] + d[1] * direction[1] <= 0.0
    t0, t1 = s.arc_angles()
    return abs(t1 - t0) >= math.pi


def _drop_turned_round(items: list[list[Any]]) -> None:
    """Remove pieces that trimming turned round, joining their neighbours at their
    crossing, until none is left (the nose envelope's local loops)."""
    while True:
        bad = next((i for i, (seg, d) in enumerate(items) if _turned_round(seg, d)), None)
        if bad is None:
            return
        if bad == 0 or bad == len(items) - 1:
            raise RuntimeError(f"toolpath contour: the end move at {items[bad][0].start} cuts nothing")
        gone = items.pop(bad)[0]
        prev, nxt = items[bad - 1][0], items[bad][0]
        near = (0.5 * (gone.start[0] + gone.end[0]), 0.5 * (gone.start[1] + gone.end[1]))
        p = _intersection(prev, nxt, near=near)
        items[bad - 1][0] = _with_ends(prev, prev.start, p)
        items[bad][0] = _with_ends(nxt, p, nxt.end)


def _check_direction(s: Segment) -> None:
    """A trimmed offset must still run the way its move did (else the nose cannot
    follow the path: a move shorter than the nose's overlap)."""
    if s.kind is SegmentKind.LINE:
        if math.dist(s.start, s.end) == 0.0:
            raise RuntimeError(f"toolpath contour: a move vanished at {s.start}")
        return
    t0, t1 = s.arc_angles()
    if abs(t1 - t0) >= math.pi:
        raise RuntimeError(f"toolpath contour: an arc turned inside out at {s.start}")
