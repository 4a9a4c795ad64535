"""What the tool sweeps along straight pieces, for the stock simulation (shop.stock): the
convex hull of a convex shape at both ends of a piece, folded about the spindle axis, and
what does not depend on the stock, every piece of an operation at once (the regions the
whole tool and its cutting part sweep, their bounds, which may touch the chuck, how deep
the cutting part reaches into the designed part). Each figure is shapely's own, computed
as for one piece at a time: vectorised, not approximated.

Machine frame (r, Z), mm; shapely geometry.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Half-width (mm) of the boxes a hull is cut at the axis with.
_BIG = 1e4


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


def sweep(xy: np.ndarray, points: np.ndarray):
    """Convex hull of the convex shape xy (m, 2) placed at each point (n, 2), folded
    about the axis."""
    return sweep_all((points[:, None, :] + xy[None, :, :]).reshape(1, -1, 2))[0]


def sweep_pieces(xy: np.ndarray, starts: np.ndarray, ends: np.ndarray) -> np.ndarray:
    """sweep(xy, [s, e]) of every piece (starts, ends (n, 2)), as an object array (n,)."""
    return sweep_all(np.concatenate([starts[:, None, :] + xy[None, :, :], ends[:, None, :] + xy[None, :, :]], axis=1))


def sweep_all(pts: np.ndarray) -> np.ndarray:
    """The folded convex hull of each set of points pts (n, k, 2) (shapely's hull of them
    as a line string: the same as of the points, built faster)."""
    import shapely

    hulls = shapely.convex_hull(shapely.linestrings(pts))
    cross = np.flatnonzero(pts[:, :, 0].min(axis=1) < 0.0)
    if cross.size:
        hulls[cross] = fold(hulls[cross])
    return hulls


def depth_inside(geoms: np.ndarray, boundary) -> np.ndarray:
    """Largest distance (mm) from a vertex of each geometry to `boundary` (0 for an empty one)."""
    import shapely

    out = np.zeros(len(geoms))
    pts, which = shapely.get_coordinates(geoms, return_index=True)
    if pts.size:
        np.maximum.at(out, which, shapely.distance(shapely.points(pts), boundary))
    return out


@dataclass(frozen=True)
class Swept:
    """What the pieces of an operation sweep, whatever the stock: `regions` (the whole
    tool) and `zones` (its cutting part), object arrays (n,); `bounds` (n, 4) of the
    regions; `chuck` (n,) bool, the region meets the chuck; `part_depth` (n,) mm, how far
    the zone reaches into the designed part (0: not at all) and `part_inside` the part
    inside the zone where it does (None elsewhere)."""

    regions: np.ndarray
    zones: np.ndarray
    bounds: np.ndarray
    chuck: np.ndarray
    part_depth: np.ndarray
    part_inside: np.ndarray


def swept_pieces(ins_xy: np.ndarray, cut_xy: np.ndarray, starts: np.ndarray, ends: np.ndarray,
                 part, part_boundary, chuck) -> Swept:
    """Swept for the straight pieces starts -> ends (n, 2) of a tool of outline ins_xy and
    cutting part cut_xy, against the designed part (its boundary) and the chuck."""
    import shapely

    n = len(starts)
    regions = sweep_pieces(ins_xy, starts, ends)
    zones = sweep_pieces(cut_xy, starts, ends)
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
        depth[meet] = depth_inside(inside, part_boundary)
        inside_all[meet] = inside
    return Swept(regions=regions, zones=zones, bounds=bounds, chuck=on_chuck, part_depth=depth,
                 part_inside=inside_all)
