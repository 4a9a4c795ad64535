"""The set-up sheet's stock pictures (export.stock_svg): the drawing puts (r, Z) where the
frame says, at equal scale, Z up; checked by hand-placed coordinates and areas."""

from __future__ import annotations

import re

from shapely.geometry import Polygon, box

from lathe_mirror.export.stock_svg import MARGIN, PX_PER_MM, nice_step, stock_svg


def _paths(svg: str, fill: str) -> list[list[tuple[float, float]]]:
    rings = []
    for d in re.findall(rf"<path d='([^']*)' fill='{fill}'", svg):
        for ring in d.split("Z"):
            if ring:
                rings.append([tuple(map(float, p.split())) for p in ring.lstrip("M").split("L")])
    return rings


def _area(ring) -> float:
    return 0.5 * abs(sum(x0 * y1 - x1 * y0 for (x0, y0), (x1, y1) in zip(ring, ring[1:] + ring[:1])))


def test_a_faced_bar_is_drawn_where_and_as_large_as_it_is():
    # A 20 mm bar (r 0..10) faced by 0.5 mm: stock r 0..10, Z -8..-0.5; removed Z -0.5..0.
    stock, removed = box(0, -8, 10, -0.5), box(0, -0.5, 10, 0)
    svg = stock_svg(stock, removed, box(0, -6, 9, -0.5), (-1.0, 12.0), (-9.0, 1.0), "after face", "t")
    left, _, top, _ = MARGIN
    (ring,) = _paths(svg, "#f39c34")
    # r = 0 at left + 1 mm, Z = 0 at top + 1 mm (the window's top is Z = +1): by hand
    xs, ys = {round(x, 3) for x, _ in ring}, {round(y, 3) for _, y in ring}
    assert xs == {left + 1 * PX_PER_MM, left + 11 * PX_PER_MM}
    assert ys == {top + 1 * PX_PER_MM, top + 1.5 * PX_PER_MM}
    assert abs(_area(ring) / PX_PER_MM**2 - 10 * 0.5) < 1e-6  # mm^2
    (grey,) = _paths(svg, "#b8b8b8")
    assert abs(_area(grey) / PX_PER_MM**2 - 10 * 7.5) < 1e-6
    # the frame is the window at 9 px/mm: 13 mm x 10 mm
    w, h = map(float, re.search(r"<rect x='[^']*' y='[^']*' width='([^']*)' height='([^']*)' fill='none'", svg).groups())
    assert (w, h) == (13 * PX_PER_MM, 10 * PX_PER_MM)
    assert "<title>after face</title>" in svg and "clip-t" in svg


def test_a_bored_part_keeps_its_hole():
    # a ring section with a hole: the hole is a second ring of the same path (even-odd fill)
    section = box(0, -10, 20, 0).difference(box(5, -6, 8, -2))
    svg = stock_svg(section, None, None, (-1.0, 22.0), (-11.0, 1.0), "x", "h")
    rings = _paths(svg, "#b8b8b8")
    assert len(rings) == 2 and "fill-rule='evenodd'" in svg
    areas = sorted(_area(r) / PX_PER_MM**2 for r in rings)
    assert abs(areas[0] - 12.0) < 1e-6 and abs(areas[1] - 200.0) < 1e-6


def test_ticks_step_1_2_5():
    assert nice_step(40.0) == 10.0 and nice_step(10.0) == 2.0 and nice_step(3.0) == 0.5


def test_a_vertex_doubled_a_few_nanometres_apart_draws_the_same_bytes():
    # issue 34: on one machine the stock's ring had a vertex twice, 1e-9 mm apart, on
    # another once, and began at another vertex; the picture must not tell them apart
    ring = [(0.0, -8.0), (10.0, -8.0), (10.0, -0.5), (4.0, -0.3), (0.0, -0.5)]
    doubled = ring[:3] + [(10.0 - 1e-9, -0.5 + 1e-9)] + ring[3:]
    turned = ring[2:] + ring[:2]
    svgs = {stock_svg(Polygon(r), None, Polygon(ring), (-1.0, 12.0), (-9.0, 1.0), "x", "d")
            for r in (ring, doubled, turned, turned[::-1])}
    assert len(svgs) == 1
    (drawn,) = _paths(svgs.pop(), "#b8b8b8")  # five vertices, the first again to close
    assert len(drawn) == 6 and abs(_area(drawn) / PX_PER_MM**2 - (10 * 7.5 + 10 * 0.2 / 2)) < 1e-6
