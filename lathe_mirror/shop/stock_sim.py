"""The stock simulation's state and replay (shop.stock's module doc says what it does):
the bar kept as a grid of square tiles (each move only touches a few), each operation's
feed moves cut into straight pieces swept at once (shop.swept), then cut from the tiles in
order, with the figures and contacts each piece gives.
"""

from __future__ import annotations

import copy
import math

import numpy as np

from ..path import Arc
from .sim_results import Contact, OperationFigures, SimMove, SimOperation
from .swept import Swept, depth_inside, snap, sweep_pieces, sweep_rapids, swept_pieces
from .tool_shapes import drill_figures

#: Tile size of the bar's grid, mm.
TILE = 2.0
#: Longest straight piece a move is cut into for the statistics, mm; arcs' chords, mm.
PIECE = 1.0
CHORD = 0.5
#: Path length over which depth of cut is averaged, mm.
STAT_WINDOW = 0.5
#: Contact below this area (mm^2) is float noise, not contact.
AREA_TOL = 1e-6
#: Depth (mm) of stock touched by the body that counts (below it: the stock's own
#: polygon noise at the cutting edge's end).
BODY_TOL = 1e-3
#: A feed within this angle (rad) of -Z that removes stock is a plunge.
PLUNGE_ANGLE = math.radians(15.0)

def rpm(r: np.ndarray, lathe: Lathe) -> np.ndarray:
    """Spindle speed (rev/min) at radius r (mm) under G96: min(cap, 1000 V / (2 pi r))."""
    r = np.abs(np.asarray(r, dtype=float))
    with np.errstate(divide="ignore"):
        n = np.where(r > 0, 1000.0 * lathe.surface_speed / (2 * math.pi * np.maximum(r, 1e-300)), np.inf)
    return np.minimum(n, float(lathe.spindle_max_rpm))


def feed_time(starts: np.ndarray, ends: np.ndarray, feed: np.ndarray, lathe: Lathe) -> np.ndarray:
    """Time (s) of straight feed pieces (n, 2) -> (n, 2) at feed mm/rev under G96 with the
    spindle cap: the length over feed x rpm(r), r linear along the piece (9-point
    midpoint rule; the integrand is piecewise linear in r)."""
    t = (np.arange(9) + 0.5) / 9
    r = starts[:, None, 0] + (ends[:, None, 0] - starts[:, None, 0]) * t[None, :]
    inv = np.mean(1.0 / rpm(r, lathe), axis=1)  # min per rev
    length = np.hypot(*(ends - starts).T)
    return 60.0 * length * inv / feed


class StockSim:
    """The bar as tiles, replayed operation by operation (shop.stock's module doc)."""

    def __init__(self, shapes: dict, lathe, start, part, chuck, gouge_tolerance: float) -> None:
        import shapely

        self.lathe, self.gouge, self.shapes = lathe, gouge_tolerance, shapes
        self.use(None)
        self.part = part
        self.part_boundary = self.part.boundary
        shapely.prepare(self.part)
        self.chuck = chuck
        shapely.prepare(self.chuck)
        # the stock, as tiles of its bounding box
        r0, self.z_lo, r1, self.z_hi = start.bounds
        self.nr = max(1, int(math.ceil(r1 / TILE)))
        self.nz = max(1, int(math.ceil((self.z_hi - self.z_lo) / TILE)))
        i, j = np.meshgrid(np.arange(self.nr, dtype=float), np.arange(self.nz, dtype=float), indexing="ij")
        i, j = i.ravel(), j.ravel()
        tiles = shapely.box(i * TILE, self.z_lo + j * TILE, np.minimum((i + 1) * TILE, r1),
                            np.minimum(self.z_lo + (j + 1) * TILE, self.z_hi))
        self.tiles = shapely.intersection(tiles, start)
        self.alive = shapely.area(self.tiles) > 0
        self.tile_bounds = shapely.bounds(self.tiles)
        self.grid = np.arange(self.nr * self.nz).reshape(self.nr, self.nz)  # tile (i, j)'s index
        self._stock = None
        self.contacts: list[Contact] = []
        self.pos: tuple[float, float] | None = None

    def snapshot(self) -> StockSim:
        """A copy to go on from (the stock's tiles copied; the geometry itself is immutable)."""
        other = copy.copy(self)
        other.tiles, other.alive, other.tile_bounds = self.tiles.copy(), self.alive.copy(), self.tile_bounds.copy()
        other.contacts = list(self.contacts)
        return other

    def with_part(self, part) -> StockSim:
        """A snapshot held against another designed part (snapped, as the run's inputs are)."""
        import shapely

        other = self.snapshot()
        other.part, other.part_boundary = part, part.boundary
        shapely.prepare(part)
        return other

    def part_cut(self, op: SimOperation) -> float | None:
        """How deep (mm) op's cutting zone reaches into the designed part
        (OperationFigures.max_part_cut_mm: the same figure operation gives, which the stock
        does not change); None when op touches the part beyond the gouge tolerance or at
        rapid (a contact, which only a replay places among the others)."""
        import shapely

        self.use(op.station)
        p_s, p_e, _ = _piece_ends([mv for mv in op.moves if not mv.rapid])
        zones = sweep_pieces(self.cut_xy, p_s, p_e)
        depth = np.zeros(len(zones))
        meet = np.flatnonzero(shapely.intersects(self.part, zones))  # as swept_pieces
        if meet.size:
            inside = shapely.intersection(self.part, zones[meet])
            real = shapely.area(inside) > 0
            depth[meet[real]] = depth_inside(inside[real], self.part_boundary,
                                             shapely.get_coordinates(self.part_boundary))
        if depth.size and float(depth.max()) > self.gouge:
            return None
        rapids = snap(np.array([[mv.move.start, mv.move.end] for mv in op.moves if mv.rapid], float).reshape(-1, 2, 2))
        for regions in sweep_rapids(self.ins_xy, rapids[:, 0], rapids[:, 1]):
            for _, region in regions:
                if shapely.intersects(self.part, region) and shapely.intersection(self.part, region).area > AREA_TOL:
                    return None
        return max(0.0, float(depth.max())) if depth.size else 0.0

    def use(self, station) -> None:
        """Take the tool of `station` (the default shape when it has none of its own)."""
        shape = self.shapes.get(station, self.shapes[None])
        self.ins_xy, self.cut_xy = snap(shape.outline_xy), snap(shape.cutting_xy)  # swept's module doc

    def separate(self, z: float, width: float):
        """The part above a part-off's slot [z, z + width] (shapely), a contact if stock
        still joins it to the bar across the slot."""
        import shapely

        left = self.stock_geometry()
        r_hi = self.nr * TILE
        bridge = shapely.intersection(left, shapely.box(0.0, z, r_hi, z + width))
        if bridge.area > AREA_TOL:
            mv = SimMove(rapid=False, move=None, feed=0.0, label="part-off")
            self.add("attached", "part-off", mv, bridge, None, depth=float(bridge.bounds[2]))
        return shapely.intersection(left, shapely.box(0.0, z + width, r_hi, self.z_hi + 1.0))

    # -- geometry ---------------------------------------------------------------------

    def tiles_near(self, bounds) -> np.ndarray:
        """The live tiles whose bounding boxes meet the box `bounds` (x0, y0, x1, y1)."""
        x0, y0, x1, y1 = bounds
        i0, i1 = max(0, int(x0 // TILE)), min(self.nr - 1, int(x1 // TILE))
        j0 = max(0, int((y0 - self.z_lo) // TILE))
        j1 = min(self.nz - 1, int((y1 - self.z_lo) // TILE))
        if i1 < i0 or j1 < j0:
            return np.empty(0, dtype=np.intp)
        idx = self.grid[i0:i1 + 1, j0:j1 + 1].ravel()
        idx = idx[self.alive[idx]]
        tb = self.tile_bounds[idx]
        return idx[(tb[:, 0] <= x1) & (tb[:, 2] >= x0) & (tb[:, 1] <= y1) & (tb[:, 3] >= y0)]

    def stock_geometry(self):
        """The stock left (one shapely geometry; kept until a tile changes)."""
        import shapely

        if self._stock is None:
            self._stock = shapely.union_all(self.tiles[self.alive])
        return self._stock

    def set_tiles(self, idx: np.ndarray, left: np.ndarray) -> None:
        import shapely

        self.tiles[idx] = left
        self.alive[idx] = shapely.area(left) > 0
        self.tile_bounds[idx] = shapely.bounds(left)
        self._stock = None

    # -- replay -----------------------------------------------------------------------

    def operation(self, op: SimOperation, rapid_rate: float) -> OperationFigures:
        import shapely

        before = self.stock_geometry()
        self.use(op.station)
        lathe = self.lathe
        rapid_time = 0.0
        area = volume = 0.0
        part_cut = 0.0
        # the feed pieces, all swept first (what does not depend on the stock)
        feeds = [mv for mv in op.moves if not mv.rapid]
        p_s, p_e, pts = _piece_ends(feeds)
        p_f = np.concatenate([np.full(len(p) - 1, mv.feed) for mv, p in zip(feeds, pts)]) if pts else np.empty(0)
        p_a = np.zeros(len(p_s))
        swept = swept_pieces(self.ins_xy, self.cut_xy, p_s, p_e, self.part, self.part_boundary, self.chuck)
        shapely.prepare(swept.regions)  # all at once, for feed_piece's intersects
        rapids = snap(np.array([[mv.move.start, mv.move.end] for mv in op.moves if mv.rapid], float).reshape(-1, 2, 2))
        rapid_regions = iter(sweep_rapids(self.ins_xy, rapids[:, 0], rapids[:, 1]))
        first = i_feed = 0  # the feed move's first piece, its index in feeds
        for mv in op.moves:
            if self.pos is None:
                self.pos = tuple(mv.move.start)
            if mv.rapid:
                a, b = np.asarray(mv.move.start, float), np.asarray(mv.move.end, float)
                rapid_time += 60.0 * float(np.hypot(*(b - a))) / rapid_rate
                self.rapid(mv, op.name, next(rapid_regions))
                continue
            last = first + len(pts[i_feed]) - 1
            for k in range(first, last):
                removed, vol, depth = self.feed_piece(mv, op.name, swept, k)
                area += removed
                volume += vol
                part_cut = max(part_cut, depth)
                p_a[k] = removed
            first, i_feed = last, i_feed + 1
            self.pos = tuple(mv.move.end)
        after = self.stock_geometry()
        removed_geom = shapely.difference(before, after)
        if len(p_s):
            s, e, f, a = p_s, p_e, p_f, p_a
            t = feed_time(s, e, f, lathe)
            length = np.hypot(*(e - s).T)
            air = a <= 1e-4 * np.maximum(length, 1e-3)
            ap = _windowed_depth(a, length)
            r_mid = 0.5 * (s[:, 0] + e[:, 0])
            mrr = 2 * math.pi * np.abs(r_mid) * ap * f * rpm(r_mid, lathe) / 1000.0  # cm^3/min
            cut_time, air_time = float(t[~air].sum()), float(t[air].sum())
            d = e - s
            down = (d[:, 1] < 0) & (np.abs(d[:, 0]) <= math.tan(PLUNGE_ANGLE) * -d[:, 1])
            plunge = float(length[down & ~air].sum())
            max_ap = float(ap.max())
            max_chip = float((ap * f).max())
            max_mrr = float(mrr.max())
        else:
            cut_time = air_time = max_ap = max_chip = max_mrr = plunge = 0.0
        feed = next((m.feed for m in op.moves if not m.rapid), 0.0)
        drill = drill_figures(self.shapes.get(op.station, self.shapes[None]), before, feeds)
        return OperationFigures(name=op.name, station=op.station, feed_mm_rev=feed, removed_area_mm2=area,
                                removed_volume_mm3=volume, max_depth_of_cut_mm=None if drill else max_ap,
                                max_chip_section_mm2=max_chip, max_removal_rate_cm3_min=max_mrr,
                                cut_time_s=cut_time, air_time_s=air_time, rapid_time_s=rapid_time,
                                max_part_cut_mm=part_cut, plunge_mm=plunge, stock_after=after, removed=removed_geom, **drill)

    def rapid(self, mv: SimMove, op: str, regions: tuple) -> None:
        """Stock or part inside the tool swept along the rapid ("rapid"), else over the
        box its ends span, the path of a controller that moves one axis first ("dogleg"):
        regions ((kind, region), ...) as swept.sweep_rapids gives them."""
        import shapely

        for kind, region in regions:
            self.check_chuck(region, mv, op)
            geom = None
            idx = self.tiles_near(region.bounds)
            if idx.size:
                shapely.prepare(region)
                idx = idx[shapely.intersects(region, self.tiles[idx])]  # the others' intersection is empty
            if idx.size:
                hit = shapely.intersection(self.tiles[idx], region)
                hit = hit[shapely.area(hit) > 0]
                if hit.size and float(shapely.area(hit).sum()) > AREA_TOL:
                    geom = shapely.union_all(hit)
            if geom is None and shapely.intersects(self.part, region):
                inside = shapely.intersection(self.part, region)
                if inside.area > AREA_TOL:
                    geom = inside
            if geom is not None:
                self.add(kind, op, mv, geom, region)
                return

    def feed_piece(self, mv: SimMove, op: str, swept: Swept, k: int) -> tuple[float, float, float]:
        """Cut the operation's straight piece k (swept: swept_pieces); returns (area
        removed mm^2, volume mm^3, depth into the part mm)."""
        import shapely

        region = swept.regions[k]
        if swept.chuck[k]:
            self.chuck_contact(region, mv, op)
        part_depth = swept.depths[k]
        if part_depth > self.gouge:
            self.add("part", op, mv, swept.part_inside[k], None, depth=part_depth)
        idx = self.tiles_near(swept.boxes[k])
        if idx.size == 0:
            return 0.0, 0.0, part_depth
        tiles = self.tiles[idx]
        touch = shapely.intersects(region, tiles)
        idx, tiles = idx[touch], tiles[touch]
        if idx.size == 0:
            return 0.0, 0.0, part_depth
        hit = shapely.intersection(tiles, region)
        areas = shapely.area(hit)
        removed = float(areas.sum())
        if removed <= 0.0:
            return 0.0, 0.0, part_depth
        if not areas.all():
            hit, areas = hit[areas > 0], areas[areas > 0]
        cx = shapely.get_x(shapely.centroid(hit))
        volume = float(np.sum(2 * math.pi * np.abs(cx) * areas))
        zone = swept.zones[k]
        # the body's contact, measured only where the hit may stick out of the zone by AREA_TOL: not
        # when its vertices are all in the (convex) zone, and its pieces beyond the zone may add up to it
        if (not swept.within_zone(k, shapely.get_coordinates(hit))
                and float(shapely.area(shapely.difference(hit, zone)).sum()) > 0.5 * AREA_TOL):
            body = shapely.difference(shapely.union_all(hit), zone)
            if body.area > AREA_TOL:
                depth = _depth_inside(body, zone.boundary)
                if depth > BODY_TOL:
                    self.add("body", op, mv, body, None, depth=depth)
        self.set_tiles(idx, shapely.difference(tiles, region))
        return removed, volume, part_depth

    def check_chuck(self, region, mv: SimMove, op: str) -> None:
        import shapely

        if region.bounds[1] < self.chuck.bounds[3] and shapely.intersects(self.chuck, region):
            self.chuck_contact(region, mv, op)

    def chuck_contact(self, region, mv: SimMove, op: str) -> None:
        """The chuck inside `region` (which meets it), a contact if it has area."""
        import shapely

        geom = shapely.intersection(self.chuck, region)
        if geom.area > AREA_TOL:
            self.add("chuck", op, mv, geom, region)

    def add(self, kind: str, op: str, mv: SimMove, geom, region, *, depth: float | None = None) -> None:
        """Record a contact once per block and kind."""
        if any(c.kind == kind and c.label == mv.label for c in self.contacts):
            return
        if depth is None:
            depth = _depth_inside(geom, region.boundary)
        at = _deepest_point(geom, region.boundary if region is not None else None)
        self.contacts.append(Contact(kind=kind, operation=op, label=mv.label, area=float(geom.area),
                                     depth=float(depth), at=at))


def _piece_ends(feeds: list) -> tuple[np.ndarray, np.ndarray, list]:
    """The straight pieces of feed moves (SimMove): starts (n, 2), ends (n, 2), snapped
    (swept's module doc), and each move's points."""
    pts = [snap(p) for p in _pieces([mv.move for mv in feeds])]
    if not pts:
        return np.empty((0, 2)), np.empty((0, 2)), pts
    return np.concatenate([p[:-1] for p in pts]), np.concatenate([p[1:] for p in pts]), pts


def _pieces(moves: list) -> list[np.ndarray]:
    """Points along each move: a line in pieces of at most PIECE mm (numpy's linspace, all
    lines at once), an arc (LinuxCNC's spiral when its radii differ) in chords of at most
    CHORD mm."""
    out: list = [None] * len(moves)
    lines = [i for i, m in enumerate(moves) if not isinstance(m, Arc)]
    for i in range(len(moves)):
        if isinstance(moves[i], Arc):
            move = moves[i]
            length = abs(move.sweep) * max(move.radius, move.end_radius)
            n = max(2, int(math.ceil(length / CHORD)) + 1)
            pts = move.sample(n)
            pts[0], pts[-1] = move.start, move.end
            out[i] = pts
    if lines:
        a = np.array([moves[i].start for i in lines], dtype=float)
        b = np.array([moves[i].end for i in lines], dtype=float)
        d = b - a
        n = np.maximum(1, np.ceil(np.hypot(d[:, 0], d[:, 1]) / PIECE).astype(int))
        # linspace(0, 1, n + 1): k * (1 / n), the last exactly 1
        k = np.arange(int(n.sum()) + len(lines)) - np.repeat(np.cumsum(n + 1) - (n + 1), n + 1)
        step = np.repeat(1.0 / n, n + 1)
        t = k * step
        t[np.cumsum(n + 1) - 1] = 1.0
        owner = np.repeat(np.arange(len(lines)), n + 1)
        pts = a[owner] + d[owner] * t[:, None]
        for j, chunk in enumerate(np.split(pts, np.cumsum(n + 1)[:-1])):
            out[lines[j]] = chunk
    return out


def _windowed_depth(area: np.ndarray, length: np.ndarray) -> np.ndarray:
    """Depth of cut (mm) per piece: the removed area over the path length of the window
    of consecutive pieces (at least STAT_WINDOW mm) it belongs to."""
    out = np.zeros(area.size)
    i = 0
    while i < area.size:
        j, acc = i, 0.0
        while j < area.size and acc < STAT_WINDOW:
            acc += length[j]
            j += 1
        out[i:j] = area[i:j].sum() / acc if acc > 0 else 0.0
        i = j
    return out


def _depth_inside(geom, boundary) -> float:
    """Largest distance (mm) from a vertex of geom to `boundary`."""
    import shapely

    pts = shapely.get_coordinates(geom)
    if pts.size == 0:
        return 0.0
    return float(shapely.distance(shapely.points(pts), boundary).max())


def _deepest_point(geom, boundary) -> tuple[float, float]:
    import shapely

    pts = shapely.get_coordinates(geom)
    if boundary is None or pts.size == 0:
        c = geom.representative_point()
        return (float(c.x), float(c.y))
    d = shapely.distance(shapely.points(pts), boundary)
    k = int(np.argmax(d))
    return (float(pts[k, 0]), float(pts[k, 1]))
