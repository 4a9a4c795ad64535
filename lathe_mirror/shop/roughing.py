"""The operations around the finishing contour: facing, roughing levels, semi-finish,
the finishing contour's approach and exit, a spring pass, the way home.

Machine frame (r, Z), mm; every point on the lathe's lattice (rounded away from the
part). The moves are the nose centre's. What each operation leaves:

- face: levels from the stock's face down to the first level through X0, each a feed
  from outside the bar to the axis, so no stub is left at the centre for a later plunge.
- rough: Z levels every rough_depth below it, each from outside the bar toward the axis
  as far as the part allows (a disc of allowance + nose radius around the part stays
  uncut). A pocket (free columns not open to the outside: under the step's top, inside
  the wall) is entered by ramps at ramp_angle, zig-zag if it is narrow, then cleared flat.
  After each level the tool retracts in Z, then traverses out: no rapid crosses the
  staircase.
- semi-finish: the profile offset by the allowance, from the vertex into the step's
  inside corner (the corner point is where the inner lobe's offset meets the wall's),
  up the wall, around the step's top on two tangents, along the outer lobe, and across
  the shoulder at the finished shoulder's height plus the allowance.
- finish k/n (the finishing tool, after M1): when the allowance is deeper than
  max_finish_depth, the semi-finish's path at smaller offsets (finish_allowances), so that
  no pass takes more than max_finish_depth.
- finish (the finishing tool): a ramped lead-in onto the contour's start, the
  contour (the toolpath's moves, unchanged), out across the shoulder, up.
- A design whose OUTER lobe is recessed (toolpath.Hand.OPPOSITE): both tools in
  opposite-hand holders (stations 3 and 4), every pass the mirror image: the semi-finish
  and the finishing pass run from outside the bar in across the shoulder, along the
  outer lobe, up the wall (it faces the rim), around the step's top, along the inner
  lobe to the axis and a little past it, off the vertex at feed, and up at rapid.
- spring pass (optional): the same contour again.
Between tools and at the end the tool goes home: up in Z, then across in X.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..lathe import Stock
from ..sheet import Target, solve_rs_for_centre_r
from .operations import OperationWriter
from .program import Operation, rough_feed, stations

if TYPE_CHECKING:
    from ..toolpath import Toolpath, ToolpathSettings

#: Column spacing (mm) of the roughing planner's map of where the nose centre may go.
GRID = 0.01
#: Chord spacing (mm) of the semi-finish along the offset profile (sag < 0.002 mm).
SEMI_CHORD = 0.5
#: Most ramp legs a pocket may take; a narrower pocket is left to the semi-finish.
MAX_RAMP_LEGS = 20


@dataclass(frozen=True)
class Plan:
    """The operations (unnumbered) and the program's fixed positions (mm)."""

    operations: list[Operation]
    home: tuple[float, float]
    safe_z: float
    r_out: float


def plan_operations(toolpath: Toolpath, stock: Stock, options: ToolpathSettings, finish_passes: int = 0) -> Plan:
    """Every operation of the program around `toolpath` (see the module doc); finish_passes:
    see finish_allowances."""
    return _Planner(toolpath, stock, options, finish_passes).plan()


def part_top(mirror, r: np.ndarray) -> np.ndarray:
    """Machine Z (mm) of the exact part's top at radius |r| (mm): the inner lobe up to the
    junction, the outer lobe beyond it, at the junction the wall's top, beyond the rim a
    flat shoulder at the rim's height."""
    r = np.minimum(np.abs(np.asarray(r, dtype=float)), mirror.r_max)
    rj = mirror.r_junction
    zi = mirror.vertex_z - mirror.inner.z(np.minimum(r, rj))
    zo = mirror.vertex_z - mirror.outer.z(np.maximum(r, rj))
    return np.where(r < rj, zi, np.where(r > rj, zo, np.maximum(zi, zo)))


def nose_floor(mirror, r: np.ndarray, clearance: float) -> np.ndarray:
    """Lowest machine Z (mm) of a nose centre at radius r (mm, a grid of spacing GRID)
    that keeps a disc of radius `clearance` (mm) off the exact part: the highest
    part_top(r') + sqrt(clearance^2 - (r' - r)^2) over |r' - r| <= clearance."""
    k = int(math.floor(clearance / GRID + 1e-9))
    out = np.full(r.shape, -np.inf)
    for j in range(-k, k + 1):
        dr = j * GRID
        out = np.maximum(out, part_top(mirror, r + dr) + math.sqrt(max(clearance**2 - dr * dr, 0.0)))
    return out


def finish_allowances(options: ToolpathSettings, finish_passes: int = 0) -> list[float]:
    """The offsets (mm, decreasing, > 0) of the finishing tool's passes before the contour:
    rough_allowance (n - k) / n for k = 1 .. n - 1, n = finish_passes (0: the fewest passes
    that keep each at most max_finish_depth deep on the profile, ceil(rough_allowance /
    max_finish_depth))."""
    a = options.rough_allowance
    n = finish_passes or max(1, math.ceil(a / options.max_finish_depth_mm - 1e-9))
    return [round(a * (n - k) / n, 6) for k in range(1, n)]


class _Planner:
    def __init__(self, tp: Toolpath, stock: Stock, opts: ToolpathSettings, finish_passes: int = 0) -> None:
        self.tp, self.stock, self.opts, self.finish_passes = tp, stock, opts, finish_passes
        self.lathe, self.m = tp.lathe, tp.mirror
        self.res = self.lathe.resolution
        self.rho = tp.nose_radius
        # the tool as the program's hand holds it; the opposite hand (the outer lobe
        # recessed) runs every pass from the rim in (toolpath.Hand)
        self.tool = tp.held_tool
        self.inward = tp.hand.value != "as configured"
        self.stations = stations(tp)
        self.r_out = self.ceil(stock.radius + opts.clearance)
        self.safe_z = self.ceil(stock.face_allowance + opts.clearance)
        self.home = (self.ceil(opts.home_r), self.ceil(opts.home_z))
        self.tan_ramp = math.tan(opts.ramp_angle)

    # lattice rounding; the small tolerance keeps lattice values where they are
    def ceil(self, v: float) -> float:
        return math.ceil(v / self.res - 1e-9) * self.res

    def floor(self, v: float) -> float:
        return math.floor(v / self.res + 1e-9) * self.res

    def plan(self) -> Plan:
        lathe, o = self.lathe, self.opts
        rough = OperationWriter(self, self.stations[0], "roughing", rough_feed(lathe, self.tp.tool))
        levels_face, levels_rough, floor_map = self.levels()
        rough.start("face", f"face: {len(levels_face)} level{'s' if len(levels_face) != 1 else ''} from the stock face, through X0",
                    first=True)
        top = self.stock.face_allowance
        for z in levels_face:
            # through X0; the opposite hand a little past it (see past_axis)
            d = self.past_axis(top - z + self.rho)
            self.level(rough, z, [(-d if d > 0.0 else 0.0, None)], top)
            top = z - self.rho
        rough.start("rough", f"rough: {len(levels_rough)} Z levels of at most {o.rough_depth:g} mm, "
                             f"{o.rough_allowance:g} mm left on the profile, pockets ramped")
        prev = levels_face[-1] if levels_face else self.ceil(self.stock.face_allowance + self.rho)
        for z in levels_rough:
            self.level(rough, z, self.intervals(floor_map, z), prev - self.rho, prev)
            prev = z
        rough.start("semi-finish", f"semi-finish: the profile offset by {o.rough_allowance:g} mm, "
                                   "into the step corner")
        self.semi_finish(rough, o.rough_allowance)
        rough.go_home(stop=True)
        fin = OperationWriter(self, self.stations[1], "finishing", lathe.feed_finish, pos=self.home)
        steps = finish_allowances(o, self.finish_passes)
        n = len(steps) + 1
        for k, d in enumerate(steps, start=1):
            fin.start(f"finish {k}/{n}", f"finish pass {k} of {n}: the profile offset by {d:g} mm "
                      f"(at most {o.max_finish_depth_mm:g} mm a pass), a fresh edge", first=k == 1)
            self.semi_finish(fin, d)
        fin.start("finish", "finish: the finishing contour, a fresh edge"
                  + (f" (pass {n} of {n})" if n > 1 else ""), first=n == 1)
        self.finish_pass(fin, "finish contour")
        if o.spring_pass:
            fin.start("spring pass", "spring pass: the finishing contour again")
            self.finish_pass(fin, "spring pass")
        fin.go_home(stop=False)
        return Plan(operations=rough.ops + fin.ops, home=self.home, safe_z=self.safe_z, r_out=self.r_out)

    # ----------------------------------------------------------------------------------
    # Levels

    def levels(self):
        """Facing levels (down to the first level through X0), roughing levels below it,
        and the map (r grid, lowest nose-centre Z) they are cut on."""
        o, rho = self.opts, self.rho
        allow = o.rough_allowance + rho
        r = np.arange(0.0, self.stock.radius + allow + GRID, GRID)
        zmin = nose_floor(self.m, r, allow)
        first = self.ceil(float(zmin[0]))  # through X0: the vertex plus the allowance
        top = self.stock.face_allowance  # the stock's face
        depth = top - (first - rho)
        face = []
        if depth > 1e-9:
            n = max(1, math.ceil(depth / o.rough_depth - 1e-9))
            face = [self.ceil(first + depth * (n - 1 - k) / n) for k in range(n)]
        rough = []
        lowest = float(zmin.min())
        k = 1
        while True:
            z = self.ceil(first - k * o.rough_depth)
            if z <= lowest + 1e-9:
                break
            rough.append(z)
            k += 1
        return face, rough, (r, zmin)

    def intervals(self, floor_map, z: float) -> list[tuple[float, float | None]]:
        """Runs of columns a nose centre at Z may sweep: [(r_lo, r_hi)], r_hi None for the
        run open to the outside of the bar (outermost first)."""
        r, zmin = floor_map
        free = zmin <= z + 1e-9
        edges = np.flatnonzero(np.diff(np.concatenate([[0], free.astype(np.int8), [0]])))
        runs = []
        for a, b in zip(edges[::2], edges[1::2]):
            lo = self.ceil(float(r[a]))
            if b >= r.size:
                runs.append((lo, None))
            else:
                hi = self.floor(float(r[b - 1]))
                if hi >= lo:
                    runs.append((lo, hi))
        return sorted(runs, key=lambda run: -run[0])

    def level(self, ops: OperationWriter, z: float, runs, top: float, prev: float | None = None) -> None:
        """One level at nose-centre height z below uncut stock up to `top` (machine Z): the
        open run fed from outside the bar toward the axis, then each pocket entered by
        ramps from the level above (prev). The tool goes down outside the bar far enough
        that its flank, leaning over the bar, stays half the clearance off the layer."""
        from .stock import reach_toward_axis  # lazy: shop.stock off the CLI's start-up path

        c = self.opts.clearance
        reach = reach_toward_axis(self.tool, top - z)
        r_down = self.ceil(self.stock.radius + c + max(0.0, reach - c / 2))
        for lo, hi in runs:
            if hi is None:
                ops.rapid((max(r_down, self.r_out), ops.pos[1]))  # out first (no-op after a level)
                ops.rapid((max(r_down, self.r_out), z))           # down outside the bar
                ops.feed((lo, z))                                 # across toward the axis
                if self.inward:
                    # the opposite hand's leading flank leans toward the rim, over the step
                    # in the stock it just cut: straight up it would drag into it; out
                    # and up at 45 deg it leaves it (through what this level cleared)
                    ops.feed((self.ceil(lo + c), self.ceil(z + c)))
                else:
                    ops.rapid((lo, self.ceil(z + c)))     # retract in Z
                ops.rapid((self.r_out, self.ceil(z + c)))  # then out
            else:
                self.pocket(ops, z, lo, hi, prev)

    def pocket(self, ops: OperationWriter, z: float, lo: float, hi: float, prev: float) -> None:
        """A pocket [lo, hi] at level z below the cleared level prev: in over the top,
        zig-zag ramps at ramp_angle down to z, a flat pass each way, up at its inner end
        and out over the top."""
        width = hi - lo
        if width <= 0 or (prev - z) / (width * self.tan_ramp) > MAX_RAMP_LEGS:
            return  # too narrow to ramp: the semi-finish takes it
        c = self.opts.clearance
        ops.rapid((self.r_out, ops.pos[1]))
        ops.rapid((self.r_out, self.safe_z))
        ops.rapid((hi, self.safe_z))
        ops.rapid((hi, min(self.ceil(prev + c), self.safe_z)))
        ops.comment(f"pocket r {lo:g}..{hi:g} mm at Z {z:g}: ramped entry")
        ops.feed((hi, prev))
        r, zc, left = hi, prev, True
        while zc > z + 1e-9:
            drop = width * self.tan_ramp
            target = lo if left else hi
            if zc - drop > z:
                zc = self.ceil(zc - drop)
                ops.feed((target, zc))
                r = target
            else:
                run = (zc - z) / self.tan_ramp
                r = self.ceil(r - run) if left else self.floor(r + run)
                r = min(max(r, lo), hi)
                zc = z
                ops.feed((r, z))
                break
            left = not left
        # flat both ways, ending at the pocket's inner end: going up there, the trailing
        # flank moves off the stock and the leading one (3 deg off the axis on the paper's
        # tool) over the cleared pocket
        ops.feed((hi, z))
        ops.feed((lo, z))
        ops.rapid((lo, self.safe_z))
        ops.rapid((self.r_out, self.safe_z))

    # ----------------------------------------------------------------------------------
    # Semi-finish

    def semi_finish(self, ops: OperationWriter, allowance: float) -> None:
        """The profile offset by `allowance` (mm) beyond the part: the semi-finish (the
        roughing tool, rough_allowance) and the finishing tool's passes before the contour."""
        if self.m.step <= 0:
            return self.semi_finish_outer_recessed(ops, allowance)
        m = self.m
        allow = allowance + self.rho
        rj = m.r_junction
        # the inner lobe's offset, from the axis to where it meets the wall's offset
        r_w = self.floor(rj - allow)
        rs_w = solve_rs_for_centre_r(m.inner, allow, r_w)
        inner = Target(m.inner, m.vertex_z, allow, 0.0, rs_w, n=2001)
        cols = [self.ceil(v) for v in np.arange(0.0, r_w, SEMI_CHORD)] + [r_w]
        cols = sorted(set(c for c in cols if c <= r_w))
        pts = [(c, self.ceil(float(inner.z_at_r(c)))) for c in cols]
        # around the step's top: up the wall's offset to where the outer offset's start
        # tangent meets it (two tangents of the circle of radius allow about the corner)
        outer = Target(m.outer, m.vertex_z, allow, rj, m.r_max + 2 * allow + 1.0, n=4001)
        p0 = outer.point(rj)
        r0 = self.ceil(float(p0[0]))
        z0 = self.ceil(float(outer.z_at_r(r0)))
        s0 = math.tan(float(outer.theta(rj)))
        pts.append((r_w, self.ceil(z0 + (r_w - r0) * s0)))
        self.semi_finish_outer_lobe(ops, pts, outer, r0, allowance)

    def semi_finish_outer_recessed(self, ops: OperationWriter, allowance: float) -> None:
        """The semi-finish when the outer lobe is recessed (the mirror image at the wall):
        the inner lobe's offset to its rim's offset point, out along its end tangent to
        the wall's offset column (r_junction + allowance), down that column to the outer
        lobe's offset, along it to the shoulder; run from the rim in."""
        m = self.m
        allow = allowance + self.rho
        rj = m.r_junction
        inner = Target(m.inner, m.vertex_z, allow, 0.0, rj, n=2001)
        p_end = inner.point(rj)
        r_end_in = float(p_end[0])
        cols = sorted(set(self.ceil(v) for v in np.arange(0.0, r_end_in, SEMI_CHORD)))
        pts = [(c, self.ceil(float(inner.z_at_r(c)))) for c in cols if c < r_end_in]
        r_w = self.ceil(rj + allow)
        # the inner offset's end tangent (machine Z falls at the sheet's slope) out to the
        # wall's offset column, rounded up: around the step's top at >= allow
        s_end = float(m.inner.slope(rj))
        z_w = self.ceil(float(p_end[1]) - (r_w - float(p_end[0])) * s_end)
        pts.append((self.ceil(r_end_in), self.ceil(float(p_end[1]))))
        pts.append((r_w, z_w))
        rs_w = solve_rs_for_centre_r(m.outer, allow, r_w)
        outer = Target(m.outer, m.vertex_z, allow, rs_w, m.r_max + 2 * allow + 1.0, n=4001)
        # down the wall's offset: the outer sheet is highest at the wall's foot, so allow
        # above it there clears the corner
        pts.append((r_w, self.ceil(float(m.vertex_z - m.outer.z(rj)) + allow)))
        self.semi_finish_outer_lobe(ops, pts, outer, r_w, allowance)

    def semi_finish_outer_lobe(self, ops: OperationWriter, pts: list, outer: Target, r0: float, allowance: float) -> None:
        """Append the outer lobe's offset (from column r0) down to the shoulder to `pts`
        and cut the whole semi-finish: from the axis out, or from the rim in for the
        opposite hand."""
        m, o = self.m, self.opts
        allow = allowance + self.rho
        # the outer lobe's offset to the shoulder: the finished shoulder (the finishing
        # exit's nose bottom) plus the allowance
        z_sh = self.ceil(self.tp.segments[-1].end[1] + allowance)
        r_end = float(outer.point(m.r_max)[0])
        for c in np.arange(r0, r_end + SEMI_CHORD, SEMI_CHORD):
            c = self.ceil(float(c))
            zc = self.ceil(float(outer.z_at_r(c)))
            if zc <= z_sh:
                break
            pts.append((c, zc))
        last = pts[-1]
        if last[1] > z_sh:  # down the offset to the shoulder's height
            rs = outer.rs_at_r(np.linspace(last[0], last[0] + 2 * allow + 1.0, 4001))
            zz = outer.point(rs)[:, 1]
            i = int(np.argmax(zz <= z_sh))
            pts.append((self.ceil(float(outer.point(rs[i])[0])), z_sh))
        else:
            pts.append((last[0], z_sh))
        ops.rapid((self.r_out, ops.pos[1]))
        ops.rapid((self.r_out, self.safe_z))
        if self.inward:  # down outside the bar, across the shoulder, the profile to the axis
            ops.rapid((self.r_out, z_sh))
            for p in pts[::-1]:
                ops.feed(p)
            if allowance < o.rough_allowance - 1e-9:
                # a finishing pass ends on the axis below what the semi-finish left there: a
                # little past it, as the contour does (past_axis), before going up
                d = self.past_axis(o.rough_allowance - allowance + 2 * self.rho)
                if d > 0.0:
                    ops.feed((ops.pos[0] - d, ops.pos[1]))
            ops.rapid((ops.pos[0], self.safe_z))  # up the axis
            return
        if allowance < o.rough_allowance - 1e-9:
            # a finishing pass: ramped onto its start as the contour is (finish_pass), not
            # down the axis (the semi-finish left stock there; the nose would rub at r = 0)
            r_s = self.ceil(pts[0][0] + (o.rough_allowance + 0.02) / self.tan_ramp)
            z_s = self.ceil(pts[0][1] + (r_s - pts[0][0]) * self.tan_ramp)
            ops.rapid((r_s, self.safe_z))
            ops.rapid((r_s, self.ceil(z_s + o.clearance)))
            ops.feed((r_s, z_s))
            ops.feed(pts[0])
        else:
            ops.rapid((0.0, self.safe_z))
            ops.feed(pts[0])  # down the axis through air: the facing level left this height
        for p in pts[1:]:
            ops.feed(p)
        ops.feed((self.r_out, z_sh))  # across the shoulder
        ops.rapid((self.r_out, self.safe_z))

    # ----------------------------------------------------------------------------------
    # Finishing

    def finish_pass(self, ops: OperationWriter, marker: str) -> None:
        """Ramped onto the contour's start from above its allowance, the contour's moves
        exactly, then out across the shoulder at the last point's height and up."""
        o = self.opts
        if self.inward:
            return self.finish_pass_inward(ops, marker)
        segs = self.tp.segments
        start, end = segs[0].start, segs[-1].end
        r_s = self.ceil(start[0] + (o.rough_allowance + 0.02) / self.tan_ramp)
        z_s = self.ceil(start[1] + (r_s - start[0]) * self.tan_ramp)
        c = self.opts.clearance
        ops.rapid((r_s, ops.pos[1]))
        ops.rapid((r_s, self.ceil(z_s + c)))
        ops.feed((r_s, z_s))
        ops.comment(f"{marker} lead-in: ramp onto the start")
        ops.feed(start)
        ops.comment(f"{marker} begin")
        for seg in segs:
            ops.move(seg)
        ops.comment(f"{marker} end")
        ops.feed((self.r_out, end[1]))
        ops.rapid((self.r_out, self.safe_z))


    def past_axis(self, height: float) -> float:
        """How far past the axis (mm, on the lattice) a pass of the opposite hand that ends
        on the axis must run so that its leading flank, leaning toward the rim, leaves no
        cone of stock `height` mm tall standing on the axis (the part turns: beyond X0
        the tool cuts the other side of the same material)."""
        if not self.inward or height <= 0.0:
            return 0.0
        lean = self.tool.flank_directions()[1]  # the flank on the axis side, from +r
        return self.ceil(height / math.tan(lean) + self.res) if lean < math.pi / 2 else 0.0

    def finish_pass_inward(self, ops: OperationWriter, marker: str) -> None:
        """The opposite hand's pass: down outside the bar, in across the shoulder at the
        rim's height onto the contour's start (the rim), the contour's moves from the rim
        in (Toolpath.cutting_moves), a little past the axis at the vertex's height
        (past_axis: the other side of the turning part, above it), off the vertex at
        feed, then up at rapid."""
        moves = self.tp.cutting_moves()
        start = moves[0].start
        c = self.opts.clearance
        ops.rapid((self.r_out, ops.pos[1]))
        ops.rapid((self.r_out, self.ceil(start[1] + c)))
        ops.feed((self.r_out, start[1]))
        ops.comment(f"{marker} lead-in: across the shoulder onto the start")
        ops.feed(start)
        ops.comment(f"{marker} begin")
        for seg in moves:
            ops.move(seg)
        ops.comment(f"{marker} end")
        end = moves[-1].end
        d = self.past_axis(self.opts.rough_allowance + 2 * self.rho)
        if d > 0.0:
            ops.feed((end[0] - d, end[1]))
        # off the vertex at feed before the rapid: the contour's last point is on the
        # lattice, up to the gouge tolerance inside the nose radius of the vertex, so the
        # nose still touches the finished face there; a rapid may only start clear of the
        # part (the as-configured hand leaves outside the bar instead). Lifted by that
        # tolerance and a lattice step, the nose clears the vertex by at least a step.
        ops.feed((ops.pos[0], self.ceil(end[1] + self.opts.gouge_tolerance + self.res)))
        ops.rapid((ops.pos[0], self.safe_z))
