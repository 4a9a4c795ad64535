"""What the tool sweeps along straight pieces, for the stock simulation (shop.stock): the
convex hull of a convex shape at both ends of a piece, folded about the spindle axis, and
what does not depend on the stock, every piece of an operation at once (the regions the
whole tool and its cutting part sweep, their bounds, which may touch the chuck, how deep
the cutting part reaches into the designed part). Each figure is shapely's own, computed
as for one piece at a time: vectorised, not approximated.

Machine frame (r, Z), mm; shapely geometry. Every coordinate the simulation hands to
shapely is first snapped to GRID (snap, snap_geometry): the tool's outline (libm's sin
and cos, GEOS's buffer), an arc's chords and the designed part (numpy's sin, cos and
sqrt, whose AVX-512 paths differ from its AVX2 ones in the last bit) reach GEOS as the
same numbers on every machine, and GEOS's own arithmetic is the same everywhere, so the
stock after each operation is too (a last-bit drift would double a vertex on one
machine and not on another).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: The grid (mm) the simulation's inputs are snapped to: a power of two, so snapping is
#: exact and sums of snapped numbers (a tool placed at a point, mirrored at the axis) stay
#: on it. 1.5e-8 mm moves a vertex far less than any tolerance of the simulation (a
#: sliver it opens along a 4 mm flank, 6e-8 mm^2, is 1/17 of shop.stock.AREA_TOL), and a
#: drift of a few 1e-15 mm crosses one of its rounding boundaries with a chance of about
#: 4e-7 a coordinate.
GRID = 2.0 ** -26
#: Half-width (mm) of the boxes a hull is cut at the axis with.
_BIG = 1e4
#: A shape's vertex at a piece's start is inside the swept hull when both its edges face
#: the move by more than this (the cosine); pieces shorter than MIN_REDUCED mm keep all.
SIDE_TOL = 1e-6
MIN_REDUCED = 1e-3
#: Points this far (mm) outside a convex zone count as in it (Swept.within_zone): a polygon
#: whose vertices are then sticks out of the zone by less than its perimeter x this in
#: area, far below shop.stock.AREA_TOL.
PLANE_TOL = 1e-9


def snap(xy) -> np.ndarray:
    """Coordinates (any shape, mm) rounded to the nearest multiple of GRID."""
    return np.round(np.asarray(xy, dtype=float) / GRID) * GRID


def snap_geometry(geom):
    """A shapely geometry with its coordinates snapped (snap); the same rings otherwise."""
    import shapely

    return shapely.transform(geom, snap)


def fold(hulls: np.ndarray) -> np.ndarray:
    """Swept hulls (object array) folded about the axis: what lies at r < 0 mirrored to
    r > 0 and united with the rest (the part turns)."""
    import shapely

    right = shapely.intersection(hulls, shapely.box(0.0, -_BIG, _BIG, _BIG))
    left = shapely.intersection(hulls, shapely.box(-_BIG, -_BIG, 0.0, _BIG))
    both = np.flatnonzero(~shapely.is_empty(left))
    if both.size:
        mirrored = shapely.transform(left[both], lambda c: c * np.array([-1.0, 1.0]))
        right[both] = shapely.union(right[both], mirrored)
    return right


def sweep_pieces(xy: np.ndarray, starts: np.ndarray, ends: np.ndarray) -> np.ndarray:
    """The folded convex hull of the convex shape xy (m, 2) placed at both ends of each
    piece (starts, ends (n, 2)), an object array (n,). Only the vertices that may lie on
    the hull are handed to shapely (its hull is the same): not those of the shape at the
    start whose two edges both face the move (nor at the end both facing back), which lie
    inside it by about the piece's length x SIDE_TOL or more."""
    import shapely

    pts = np.concatenate([starts[:, None, :] + xy[None, :, :], ends[:, None, :] + xy[None, :, :]], axis=1)
    d = ends - starts
    length = np.hypot(d[:, 0], d[:, 1])
    edges = np.roll(xy, -1, axis=0) - xy  # edge i from vertex i to i + 1
    ccw = np.sum(xy[:, 0] * np.roll(xy[:, 1], -1) - np.roll(xy[:, 0], -1) * xy[:, 1]) > 0
    normals = np.stack([edges[:, 1], -edges[:, 0]], axis=1) * (1.0 if ccw else -1.0)
    normals /= np.hypot(normals[:, 0], normals[:, 1])[:, None]
    facing = (d @ normals.T) / np.maximum(length, 1e-300)[:, None]  # (n, m): edge i along the move
    before = np.roll(facing, 1, axis=1)  # the edge ending at vertex i
    long = (length > MIN_REDUCED)[:, None]
    keep = np.concatenate([~(long & (facing > SIDE_TOL) & (before > SIDE_TOL)),
                           ~(long & (facing < -SIDE_TOL) & (before < -SIDE_TOL))], axis=1)
    lines = shapely.linestrings(pts[keep], indices=np.repeat(np.arange(len(pts)), keep.sum(axis=1)))
    return _hulls(lines, pts)


def sweep_rapids(xy: np.ndarray, a: np.ndarray, b: np.ndarray) -> list[tuple[tuple[str, object], ...]]:
    """What the shape xy sweeps along each rapid a -> b (n, 2): ("rapid", its sweep) and,
    unless it moves along one axis, ("dogleg", the sweep over the box its ends span: a
    controller moving one axis first): the folded hull of xy placed at those corners."""
    if len(a) == 0:
        return []
    straight = sweep_all((np.stack([a, b], axis=1)[:, :, None, :] + xy[None, None, :, :]).reshape(len(a), -1, 2))
    diag = np.flatnonzero((a[:, 0] != b[:, 0]) & (a[:, 1] != b[:, 1]))
    corners = np.stack([a, b, np.stack([a[:, 0], b[:, 1]], axis=1), np.stack([b[:, 0], a[:, 1]], axis=1)], axis=1)
    box = np.full(len(a), None, dtype=object)
    if diag.size:
        box[diag] = sweep_all((corners[diag][:, :, None, :] + xy[None, None, :, :]).reshape(diag.size, -1, 2))
    return [(("rapid", r),) if d is None else (("rapid", r), ("dogleg", d)) for r, d in zip(straight, box)]


def sweep_all(pts: np.ndarray) -> np.ndarray:
    """The folded convex hull of each set of points pts (n, k, 2)."""
    import shapely

    return _hulls(shapely.linestrings(pts), pts)


def _hulls(lines: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """The folded convex hulls of line strings (shapely's hull of a line string's vertices,
    the same as of them as points, built faster); pts (n, k, 2) all their points."""
    import shapely

    hulls = shapely.convex_hull(lines)
    cross = np.flatnonzero(pts[:, :, 0].min(axis=1) < 0.0)
    if cross.size:
        hulls[cross] = fold(hulls[cross])
    return hulls


def depth_inside(geoms: np.ndarray, boundary, vertices: np.ndarray | None = None) -> np.ndarray:
    """Largest distance (mm) from a vertex of each geometry to `boundary` (0 for an empty
    one). vertices (k, 2): the boundary's own, at distance 0 from it, not measured."""
    import shapely

    out = np.zeros(len(geoms))
    pts, which = shapely.get_coordinates(geoms, return_index=True)
    if vertices is not None and pts.size:
        away = ~np.isin(_as_complex(pts), _as_complex(vertices))
        pts, which = pts[away], which[away]
    if pts.size:
        np.maximum.at(out, which, shapely.distance(shapely.points(pts), boundary))
    return out


def _as_complex(pts: np.ndarray) -> np.ndarray:
    """Points (k, 2) as complex numbers, bit for bit (to compare them)."""
    return np.ascontiguousarray(pts, dtype=float).view(np.complex128).ravel()


@dataclass(frozen=True)
class Swept:
    """What the pieces of an operation sweep, whatever the stock: `regions` (the whole
    tool) and `zones` (its cutting part), object arrays (n,); `bounds` (n, 4) of the
    regions; `chuck` (n,) bool, the region meets the chuck; `part_depth` (n,) mm, how far
    the zone reaches into the designed part (0: not at all) and `part_inside` the part
    inside the zone where it does (None elsewhere); `planes` each convex zone's edges
    (ZonePlanes). boxes and depths: bounds and part_depth as lists of floats."""

    regions: np.ndarray
    zones: np.ndarray
    bounds: np.ndarray
    chuck: np.ndarray
    part_depth: np.ndarray
    part_inside: np.ndarray
    planes: ZonePlanes
    boxes: list
    depths: list

    def within_zone(self, k: int, pts: np.ndarray) -> bool:
        """Whether the points (m, 2) all lie in piece k's zone, or outside it by at most
        PLANE_TOL mm (False: not known, the zone folded at the axis)."""
        lo, hi = self.planes.start[k], self.planes.stop[k]
        if lo < 0:
            return False
        d = pts @ self.planes.normals[lo:hi].T - self.planes.offsets[lo:hi]
        return bool(d.max() <= PLANE_TOL)


@dataclass(frozen=True)
class ZonePlanes:
    """The edges of convex zones as half planes n.p <= c: unit outward normals (M, 2) and
    offsets c (M,); piece k's are rows start[k]:stop[k] (start -1: a zone folded at the
    axis, not convex)."""

    normals: np.ndarray
    offsets: np.ndarray
    start: np.ndarray
    stop: np.ndarray


def zone_planes(zones: np.ndarray, convex: np.ndarray) -> ZonePlanes:
    """ZonePlanes of the zones (polygons, each ring either way round) marked convex."""
    import shapely

    n = len(zones)
    start, stop = np.full(n, -1), np.full(n, -1)
    ok = np.flatnonzero(convex & (shapely.get_type_id(zones) == 3))  # polygons
    pts, which = shapely.get_coordinates(zones[ok], return_index=True)
    same = which[1:] == which[:-1]  # consecutive vertices of one ring (each ring closed)
    a, b, owner = pts[:-1][same], pts[1:][same], which[:-1][same]
    twice_area = np.bincount(owner, a[:, 0] * b[:, 1] - b[:, 0] * a[:, 1], minlength=len(ok))
    turn = np.where(twice_area > 0, 1.0, -1.0)[owner]  # anticlockwise: outward is the edge's right
    normals = np.stack([(b - a)[:, 1], -(b - a)[:, 0]], axis=1) * turn[:, None]
    length = np.hypot(normals[:, 0], normals[:, 1])
    real = length > 0
    normals, a, owner = normals[real] / length[real, None], a[real], owner[real]
    start[ok] = np.searchsorted(owner, np.arange(len(ok)), side="left")
    stop[ok] = np.searchsorted(owner, np.arange(len(ok)), side="right")
    return ZonePlanes(normals=normals, offsets=np.sum(normals * a, axis=1), start=start, stop=stop)


def swept_pieces(ins_xy: np.ndarray, cut_xy: np.ndarray, starts: np.ndarray, ends: np.ndarray,
                 part, part_boundary, chuck) -> Swept:
    """Swept for the straight pieces starts -> ends (n, 2) of a tool of outline ins_xy and
    cutting part cut_xy (both convex), against the designed part (its boundary) and the
    chuck."""
    import shapely

    n = len(starts)
    regions = sweep_pieces(ins_xy, starts, ends)
    zones = sweep_pieces(cut_xy, starts, ends)
    # the zones _hulls did not fold: convex
    r = cut_xy[None, :, 0]
    unfolded = np.minimum(starts[:, None, 0] + r, ends[:, None, 0] + r).min(axis=1) >= 0.0
    bounds = shapely.bounds(regions).reshape(n, 4)
    near_chuck = np.flatnonzero(bounds[:, 1] < chuck.bounds[3])
    on_chuck = np.zeros(n, dtype=bool)
    on_chuck[near_chuck] = shapely.intersects(chuck, regions[near_chuck])
    depth = np.zeros(n)
    inside_all = np.full(n, None, dtype=object)
    meet = np.flatnonzero(shapely.intersects(part, zones))
    if meet.size:
        inside = shapely.intersection(part, zones[meet])
        real = shapely.area(inside) > 0
        meet, inside = meet[real], inside[real]
        depth[meet] = depth_inside(inside, part_boundary, shapely.get_coordinates(part_boundary))
        inside_all[meet] = inside
    return Swept(regions=regions, zones=zones, bounds=bounds, chuck=on_chuck, part_depth=depth,
                 part_inside=inside_all, planes=zone_planes(zones, unfolded), boxes=bounds.tolist(),
                 depths=depth.tolist())
