"""shop.swept, what the stock simulation's straight pieces sweep, against closed forms: a
convex shape moved along a segment sweeps its own area plus the segment's length times
the shape's width across it (the Minkowski sum); what crosses the spindle axis is folded
onto r > 0; a point is in a convex zone when no edge's half plane excludes it."""

from __future__ import annotations

import math

import numpy as np
import pytest
import shapely

from lathe_mirror.shop.swept import PLANE_TOL, sweep_pieces, sweep_rapids, swept_pieces


def rectangle(w: float, h: float) -> np.ndarray:
    """A w x h rectangle's vertices (anticlockwise), its corner at the origin."""
    return np.array([[0.0, 0.0], [w, 0.0], [w, h], [0.0, h]])


def polygon(n: int, radius: float) -> np.ndarray:
    """A regular n-gon of circumradius `radius` about the origin (clockwise, as shapely's
    buffers are not)."""
    a = -2 * math.pi * np.arange(n) / n
    return radius * np.stack([np.cos(a), np.sin(a)], axis=1)


@pytest.mark.parametrize("d", [(3.0, 0.0), (0.0, -2.5), (1.2, 0.7), (-0.4, 1.9), (1e-4, 2e-4), (5.0, 5.0)])
def test_a_moved_rectangle_sweeps_its_area_and_the_move_times_its_width(d):
    """w x h moved by (dx, dz): w h + |dx| h + |dz| w, wherever it starts (r > 0)."""
    w, h = 0.8, 2.0
    starts = np.array([[10.0, -4.0], [20.0, 3.0]])
    ends = starts + np.array(d)
    hulls = sweep_pieces(rectangle(w, h), starts, ends)
    want = w * h + abs(d[0]) * h + abs(d[1]) * w
    assert shapely.area(hulls) == pytest.approx([want, want], rel=1e-12)


@pytest.mark.parametrize("angle", np.linspace(0.0, 2 * math.pi, 13))
def test_a_moved_polygon_sweeps_its_area_and_the_move_times_its_width(angle):
    """A regular 64-gon (many vertices inside the sweep, dropped before the hull) moved 3 mm:
    its area n R^2 sin(2 pi / n) / 2 plus 3 mm x its width across the move, the largest
    spread of its vertices along the move's normal (computed here from the vertices)."""
    n, radius, length = 64, 1.5, 3.0
    xy = polygon(n, radius)
    d = length * np.array([math.cos(angle), math.sin(angle)])
    s = np.array([[10.0, 0.0]])
    normal = np.array([-d[1], d[0]]) / length
    width = float(np.ptp(xy @ normal))
    want = n * radius**2 * math.sin(2 * math.pi / n) / 2 + length * width
    hull = sweep_pieces(xy, s, s + d)[0]
    assert hull.area == pytest.approx(want, rel=1e-12)
    # the same hull as shapely's of all the vertices at both ends
    full = shapely.convex_hull(shapely.multipoints(np.concatenate([s + xy, s + d + xy])))
    assert shapely.equals_exact(hull, full, tolerance=0.0)


def test_what_crosses_the_axis_is_folded_onto_it():
    """A 4 x 1 rectangle from r = -1 to 3: what lies at r < 0 mirrored onto r > 0, 3 x 1;
    moved 2 mm along Z, 3 x 3; moved 2 mm in +r from r = -3 to -1 (the sweep from r = -3
    to 3), its mirror the rest: 3 x 1."""
    xy = rectangle(4.0, 1.0)
    at = np.array([[-1.0, 0.0]])
    assert sweep_pieces(xy, at, at)[0].area == pytest.approx(3.0, rel=1e-12)
    hulls = sweep_pieces(xy, np.array([[-1.0, 0.0], [-3.0, 0.0]]), np.array([[-1.0, 2.0], [-1.0, 0.0]]))
    assert shapely.area(hulls) == pytest.approx([9.0, 3.0], rel=1e-12)
    assert shapely.bounds(hulls[1]) == pytest.approx([0.0, 0.0, 3.0, 1.0])


def test_within_zone_holds_points_inside_and_on_the_edge_only():
    """Piece 0's zone: a 1 x 1 square moved 2 mm in r from (10, 0), the box [10, 13] x [0, 1];
    piece 1's crosses the axis (folded, not convex): never known to hold anything."""
    sq = rectangle(1.0, 1.0)
    big = rectangle(5.0, 5.0)
    part = shapely.box(100.0, 100.0, 101.0, 101.0)
    chuck = shapely.box(0.0, -1000.0, 200.0, -500.0)
    sw = swept_pieces(big, sq, np.array([[10.0, 0.0], [-0.5, 0.0]]), np.array([[12.0, 0.0], [0.5, 0.0]]),
                      part, part.boundary, chuck)
    inside = np.array([[10.0, 0.0], [13.0, 1.0], [11.5, 0.5], [13.0 + PLANE_TOL / 2, 0.5]])
    assert sw.within_zone(0, inside)
    for out in ([13.0 + 1e-6, 0.5], [11.0, -1e-6], [9.9, 0.5], [11.0, 1.0 + 2 * PLANE_TOL]):
        assert not sw.within_zone(0, np.vstack([inside, out]))
    assert not sw.within_zone(1, np.array([[0.2, 0.5]]))
    assert not sw.chuck.any() and not sw.part_depth.any()


def test_a_rapid_sweeps_its_line_and_a_diagonal_one_its_box_too():
    """A w x h rectangle at rapid: along one axis only the line (w h + |dr| h + |dz| w);
    diagonally the line and the box its ends span, (w + |dr|) (h + |dz|); no rapid, none."""
    w, h = 0.8, 2.0
    a = np.array([[10.0, 5.0], [10.0, 5.0], [30.0, -2.0]])
    b = np.array([[10.0, 1.0], [4.0, 8.0], [22.0, 3.0]])
    out = sweep_rapids(rectangle(w, h), a, b)
    assert [[kind for kind, _ in regions] for regions in out] == [["rapid"], ["rapid", "dogleg"], ["rapid", "dogleg"]]
    for (dr, dz), regions in zip(b - a, out):
        dr, dz = abs(dr), abs(dz)
        assert regions[0][1].area == pytest.approx(w * h + dr * h + dz * w, rel=1e-12)
        if len(regions) > 1:
            assert regions[1][1].area == pytest.approx((w + dr) * (h + dz), rel=1e-12)
    assert sweep_rapids(rectangle(w, h), np.empty((0, 2)), np.empty((0, 2))) == []
