"""Finishing toolpaths on the lathe's lattice, within its point budget; profile errors.

Machine frame (ARCHITECTURE.md): Z = vertex_z - z (vertex at Z = 0, part in -Z), r the
radius; every programmed coordinate is a multiple of `Lathe.resolution` in r and Z.

The programmed path is the path of the tool nose's CENTRE: the exact lobe offset
outward along its normal by the nose radius (0 for the ideal sharp tool, when the path
is the contour itself). Each strategy puts that path on the lattice:

- `Strategy.PAPER`: the paper's method (section 6): points spread evenly along the
  profile, each coordinate rounded to the lattice, joined by G1 lines.
- `Strategy.LATTICE`: G1 lines through the same number of points, each vertex chosen
  among the lattice points near its place on the curve by dynamic programming so
  that the chords' slope errors and offsets are smallest (an optimisation over the
  lattice, not rounding): 4-8x less RMS slope error than rounding.
- `Strategy.ARCS` (BEST, the default): G2/G3 arcs whose end points are the lattice
  points nearest the curve and whose centres are the lattice points that make the arc
  the controller actually cuts (LinuxCNC's spiral when the two radii differ) follow
  the curve's slope best. An arc follows a smooth curve's turning tangent, a chord
  cannot: on the paper's machine the max slope error falls ~80x, and the lattice,
  not the budget, is then the limit (about 80 of the 528 points are used).

The junction: the contour runs out along the inner lobe, up the step wall (r =
r_junction, the inner lobe recessed), then out along the outer lobe. A nose of radius
rho touches the wall at r = r_junction - rho and cannot reach the inside corner at the
wall's foot: it leaves a fillet there (see machining.as_machined).
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass, field

import numpy as np

from ..design import Lobe, Mirror
from ..errors import InputError
from ..machine import Lathe, Tool
from ..profile import ExactProfile, PathProfile, Profile


class Strategy(enum.Enum):
    """How the exact profile becomes lattice moves. BEST (= ARCS) is the default."""

    PAPER = "paper"
    LATTICE = "lattice"
    ARCS = "arcs"


#: The strategy with the smallest slope error on the paper's machine (see module doc).
BEST = Strategy.ARCS


@dataclass(frozen=True)
class Line:
    """A G1 move, machine frame (r, Z), mm."""

    start: tuple[float, float]
    end: tuple[float, float]
    kind: str = field(default="line", init=False)
    n_points: int = field(default=1, init=False)  # budget: its end point

    def sample(self, n: int) -> np.ndarray:
        """n points (n, 2) from start to end."""
        t = np.linspace(0.0, 1.0, n)[:, None]
        return (1 - t) * np.asarray(self.start) + t * np.asarray(self.end)


@dataclass(frozen=True)
class Arc:
    """A G2/G3 move, machine frame (r, Z), mm.

    centre: lattice centre (the block's I, K are centre - start). radius: |start -
    centre|; end_radius: |end - centre|. LinuxCNC cuts the arc with its radius linear in
    the swept angle from one to the other (a spiral when they differ). clockwise: as the
    controller cuts it in G18 (rotation in the (Z, X) plane seen from +Y): True is G2.
    """

    start: tuple[float, float]
    end: tuple[float, float]
    centre: tuple[float, float]
    clockwise: bool
    kind: str = field(default="arc", init=False)
    n_points: int = field(default=2, init=False)  # budget: end point and centre

    @property
    def radius(self) -> float:
        return math.hypot(self.start[0] - self.centre[0], self.start[1] - self.centre[1])

    @property
    def end_radius(self) -> float:
        return math.hypot(self.end[0] - self.centre[0], self.end[1] - self.centre[1])

    @property
    def sweep(self) -> float:
        """Signed swept angle (rad) in the (r, Z) plane, |sweep| < pi."""
        a0 = math.atan2(self.start[1] - self.centre[1], self.start[0] - self.centre[0])
        a1 = math.atan2(self.end[1] - self.centre[1], self.end[0] - self.centre[0])
        return (a1 - a0 + math.pi) % (2 * math.pi) - math.pi

    def sample(self, n: int) -> np.ndarray:
        """n points (n, 2) along the spiral the controller cuts."""
        c = np.asarray(self.centre)
        a0 = math.atan2(self.start[1] - c[1], self.start[0] - c[0])
        t = np.linspace(0.0, 1.0, n)
        phi = a0 + self.sweep * t
        rad = self.radius + (self.end_radius - self.radius) * t
        return c + rad[:, None] * np.stack([np.cos(phi), np.sin(phi)], axis=-1)


Move = Line | Arc


@dataclass
class Toolpath:
    """The finishing contour of one mirror on one lathe with one tool.

    segments: the programmed moves (machine frame, cutting order) of the tool nose's
      centre, from the vertex (r = 0) out to the outer rim; every coordinate (and every
      arc centre) on the lattice.
    lobe_of: for each segment, "inner", "junction" or "outer".
    n_points: points of the controller's budget used (G1: 1 per move; G2/G3: 2, the end
      point and the centre; plus the start point).
    """

    strategy: Strategy
    lathe: Lathe
    tool: Tool
    mirror: Mirror
    segments: tuple[Move, ...]
    lobe_of: tuple[str, ...]
    n_points: int

    @property
    def nose_radius(self) -> float:
        """Nose radius (mm) the path was planned for (its offset from the surface)."""
        return self.tool.nose_radius

    def lobe_segments(self, name: str) -> tuple[Move, ...]:
        return tuple(s for s, k in zip(self.segments, self.lobe_of) if k == name)

    def points(self) -> np.ndarray:
        """The programmed end points (with the start), (n, 2) machine (r, Z), mm."""
        pts = [self.segments[0].start] + [s.end for s in self.segments]
        return np.asarray(pts, dtype=float)

    def centres(self) -> np.ndarray:
        """Arc centres (m, 2) machine (r, Z), mm."""
        c = [s.centre for s in self.segments if s.kind == "arc"]
        return np.asarray(c, dtype=float).reshape(-1, 2)

    def contour_profile(self) -> Profile:
        """The surface the programmed contour describes, camera frame.

        For a zero nose radius: the moves themselves, exactly (a PathProfile). For a
        nose radius rho > 0: the envelope of the nose along each lobe's moves (the
        path offset back by rho, without the junction's inside-corner fillet, which
        machining.as_machined adds).
        """
        m = self.mirror
        if self.nose_radius == 0.0:
            return PathProfile(self.lobe_segments("inner"), self.lobe_segments("outer"),
                               r_junction=m.r_junction, r_max=m.r_max, vertex_z=m.vertex_z)
        from ..machining import nose_envelope

        return nose_envelope(self, self.nose_radius, include_junction=False)


def plan_toolpath(mirror: Mirror, lathe: Lathe, tool: Tool, strategy: Strategy = BEST, *,
                  max_deviation: float = 0.01) -> Toolpath:
    """Plan the finishing contour of `mirror` on `lathe` with `tool`.

    max_deviation (mm): the largest normal deviation the budget must allow a polyline
    (decides "budget too small"; the config's toolpath.max_deviation).
    Raises InputError when the budget cannot hold the profile within it, the nose
    cannot fit the junction, the tool's flanks would rub the profile, or the contour
    leaves the lathe's travel.
    """
    if not isinstance(strategy, Strategy):
        raise InputError(f"strategy {strategy!r}: allowed {', '.join(s.value for s in Strategy)}")
    rho = tool.nose_radius
    check_junction(mirror, tool)
    tool.check_reach(_normal_angles(mirror), what="the mirror's profile")
    layout = _Layout(mirror, lathe, rho)
    need = layout.min_points(max_deviation)
    if lathe.max_points < need:
        raise InputError(
            f"machine.max_points = {lathe.max_points}: too small to hold the profile; lines "
            f"within {max_deviation:g} mm of it need at least {need} points"
        )
    if strategy is Strategy.PAPER:
        inner, outer = _paper_points(layout, lathe)
        segs, lobes = layout.assemble_lines(inner, outer)
    elif strategy is Strategy.LATTICE:
        inner, outer = _lattice_points(layout, lathe)
        segs, lobes = layout.assemble_lines(inner, outer)
    else:
        segs, lobes = _arc_moves(layout, lathe)
    n_points = 1 + sum(s.n_points for s in segs)
    tp = Toolpath(strategy=strategy, lathe=lathe, tool=tool, mirror=mirror,
                  segments=tuple(segs), lobe_of=tuple(lobes), n_points=n_points)
    if n_points > lathe.max_points:  # a bug, not bad input: every strategy plans within it
        raise RuntimeError(f"{strategy.value}: {n_points} points exceed the budget {lathe.max_points}")
    check_travel(tp.points(), lathe, what="the finishing contour")
    return tp


def check_junction(mirror: Mirror, tool: Tool) -> float:
    """Largest nose radius (mm) the junction allows; raise InputError if the tool's is larger.

    A nose in the inside corner at the wall's foot touches the inner lobe and the wall
    at once; its centre then sits on the corner's bisector, rho / tan(half opening)
    above the foot. If that is above the top of the step, the nose can never touch the
    wall: it would round the whole step and the inner lobe's rim with it. So rho_max is
    the radius whose wall contact is the top of the step (found exactly on the curved
    lobe by bisection).
    """
    if mirror.recessed != "inner":
        raise InputError("lobes: this toolpath handles a recessed inner lobe only (the paper's "
                         "design); the outer lobe is recessed in this design")
    rj = mirror.r_junction
    z_top_m = mirror.vertex_z - mirror.outer.z(rj)  # machine Z of the step's top

    def centre_z(rho: float) -> float:
        # nose centre at r = rj - rho touching the inner lobe: on its offset curve
        rs = _solve_rs_for_centre_r(mirror.inner, rho, rj - rho)
        nr, nz = _normal_m(mirror.inner, rs)
        return float(mirror.vertex_z - mirror.inner.z(rs) + rho * nz)

    lo, hi = 0.0, float(abs(mirror.step)) * 2
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if centre_z(mid) <= z_top_m:
            lo = mid
        else:
            hi = mid
    rho_max = lo
    if tool.nose_radius > rho_max:
        zi, zo = mirror.junction_z
        raise InputError(
            f"tool.nose_radius = {tool.nose_radius:g} mm is too large for the junction: a nose "
            f"touching both the inner lobe and the step wall (step {abs(zi - zo):.3f} mm) needs "
            f"nose_radius <= {rho_max:.3f} mm, else it cannot reach the wall at all"
        )
    return rho_max


def check_travel(points: np.ndarray, lathe: Lathe, what: str) -> None:
    """Raise InputError if any point (r, Z) lies outside the lathe's travel."""
    pts = np.asarray(points, dtype=float).reshape(-1, 2)
    r_hi = float(pts[:, 0].max())
    if r_hi > lathe.travel_x + 1e-9:
        raise InputError(
            f"machine.travel_x = {lathe.travel_x:g} mm: {what} needs a radius of {r_hi:.3f} mm; "
            "allowed up to travel_x"
        )
    z_lo, z_hi = float(pts[:, 1].min()), float(pts[:, 1].max())
    if z_lo < lathe.travel_z_min - 1e-9 or z_hi > lathe.travel_z_max + 1e-9:
        raise InputError(
            f"machine.travel_z_min/max = {lathe.travel_z_min:g}/{lathe.travel_z_max:g} mm: {what} "
            f"spans Z {z_lo:.3f}..{z_hi:.3f} mm"
        )


# --------------------------------------------------------------------------------------
# Profile-error figures


def profile_errors(profile: Profile, mirror: Mirror, *, n: int = 20001) -> dict:
    """Normal deviation (mm) and slope error (rad) of a made profile, per lobe.

    normal_deviation_mm: distance from the made point (r, z(r)) to the exact lobe
    sheet (foot point by Newton's method). slope_error_rad: angle between made and exact
    normals at the same r. RMS over r uniform on the lobe; max also over the made
    profile's breakpoints (both sides), where a polyline's slope error peaks.
    """
    exact = ExactProfile(mirror)
    lobes = []
    for k, lobe in enumerate(mirror.lobes):
        lo, hi = profile.lobe_range(k)
        r = np.linspace(lo, hi, n)
        if k == 1:
            r[0] = np.nextafter(lo, hi)
        rr = r
        if hasattr(profile, "breakpoints"):
            bp = profile.breakpoints(k)
            bp = bp[(bp > lo) & (bp < hi)]
            eps = 1e-9
            rr = np.concatenate([r, bp - eps, bp + eps])
        z = profile.z(rr)
        s = profile.slope(rr)
        dist = np.abs(_signed_distance_camera(lobe, rr, z))
        slope_err = np.abs(np.arctan(s) - np.arctan(exact.slope(rr)))
        m = r.size  # the uniform samples come first: RMS over them
        lobes.append({
            "name": lobe.name,
            "normal_deviation_mm": {"rms": float(np.sqrt(np.mean(dist[:m] ** 2))), "max": float(dist.max())},
            "slope_error_rad": {"rms": float(np.sqrt(np.mean(slope_err[:m] ** 2))), "max": float(slope_err.max())},
        })
    return {"lobes": lobes}


def _signed_distance_camera(lobe: Lobe, r: np.ndarray, z: np.ndarray) -> np.ndarray:
    """Signed distance (mm) of camera-frame points from the lobe's sheet (+ toward the camera)."""
    # In the machine frame with any vertex height the geometry is the same; use Z = -z.
    rf = foot_on_sheet(lobe, r, -np.asarray(z), zero=0.0)
    nr, nz = _normal_m(lobe, rf)
    return (r - rf) * nr + (-z + lobe.z(rf)) * nz


# --------------------------------------------------------------------------------------
# Geometry of a lobe in the machine frame (Z = zero - z, zero = vertex_z)


def _zm(lobe: Lobe, r, zero: float):
    return zero - lobe.z(r)


def _dzm(lobe: Lobe, r):
    return -lobe.slope(r)


def _d2zm(lobe: Lobe, r):
    r = np.asarray(r, dtype=float)
    q = np.sqrt(1.0 + (r / lobe.b) ** 2)
    return -lobe.a / (lobe.b**2 * q**3)


def _normal_m(lobe: Lobe, r):
    """Outward (free-side, +Z) unit normal of the sheet in the machine frame."""
    s = lobe.slope(r)
    k = 1.0 / np.sqrt(1.0 + s * s)
    return s * k, k


def foot_on_sheet(lobe: Lobe, pr, pz, *, zero: float, r0=None) -> np.ndarray:
    """Radius of the point of the sheet (machine frame) nearest to points (pr, pz).

    Newton's method on d/dr of the squared distance; the points lie within a fraction of
    the radius of curvature (>= b^2/a... 15 mm) of the sheet, where it converges fast.
    """
    pr = np.asarray(pr, dtype=float)
    pz = np.asarray(pz, dtype=float)
    r = pr.copy() if r0 is None else np.asarray(r0, dtype=float).copy()
    for _ in range(8):
        zm = _zm(lobe, r, zero)
        d1 = _dzm(lobe, r)
        g = (r - pr) + (zm - pz) * d1
        dg = 1.0 + d1 * d1 + (zm - pz) * _d2zm(lobe, r)
        step = g / dg
        r = r - step
        if np.all(np.abs(step) < 1e-13):
            break
    return r


def _solve_rs_for_centre_r(lobe: Lobe, rho: float, r_centre: float) -> float:
    """Surface radius whose nose centre (offset rho outward) lies at radius r_centre."""
    lo, hi = 0.0, lobe.r_top * 2 + 10.0
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        nr, _ = _normal_m(lobe, mid)
        if mid + rho * nr < r_centre:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


def _normal_angles(mirror: Mirror) -> np.ndarray:
    """Directions (rad, from +r toward +Z) of the outward normals of the whole profile."""
    angles = []
    for lobe, (lo, hi) in ((mirror.inner, (0.0, mirror.r_junction)),
                           (mirror.outer, (mirror.r_junction, mirror.r_max))):
        r = np.linspace(lo, hi, 201)
        nr, nz = _normal_m(lobe, r)
        angles.append(np.arctan2(nz, nr))
    angles.append(np.array([math.pi]))  # the step wall faces the axis (-r)
    return np.concatenate(angles)


class _Target:
    """One lobe's nose-centre curve: the sheet offset outward by rho (machine frame).

    Parametrised by the surface radius rs in [rs_lo, rs_hi]; tabulated densely for arc
    length, r -> rs and allocation; evaluated exactly (closed form) everywhere else.
    """

    def __init__(self, lobe: Lobe, zero: float, rho: float, rs_lo: float, rs_hi: float,
                 n: int = 8001) -> None:
        self.lobe, self.zero, self.rho = lobe, zero, rho
        self.rs_lo, self.rs_hi = rs_lo, rs_hi
        rs = np.linspace(rs_lo, rs_hi, n)
        p = self.point(rs)
        self.rs = rs
        self.r_tab = p[:, 0]
        self.s_tab = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(p, axis=0).T))])
        self.theta_tab = self.theta(rs)
        self.length = float(self.s_tab[-1])

    def point(self, rs) -> np.ndarray:
        rs = np.asarray(rs, dtype=float)
        nr, nz = _normal_m(self.lobe, rs)
        return np.stack([rs + self.rho * nr, _zm(self.lobe, rs, self.zero) + self.rho * nz], axis=-1)

    def theta(self, rs) -> np.ndarray:
        """Tangent direction (rad) of the curve (toward +r) at surface radius rs."""
        return np.arctan(_dzm(self.lobe, rs))

    def rs_at_s(self, s) -> np.ndarray:
        return np.interp(s, self.s_tab, self.rs)

    def rs_at_r(self, r) -> np.ndarray:
        """Surface radius whose nose centre lies at radius r (refined by Newton)."""
        rs = np.interp(r, self.r_tab, self.rs)
        if self.rho == 0.0:
            return np.asarray(rs, dtype=float) * 0 + np.asarray(r, dtype=float)
        for _ in range(3):
            nr, _ = _normal_m(self.lobe, rs)
            h = 1e-6
            nr2, _ = _normal_m(self.lobe, rs + h)
            f = rs + self.rho * nr - r
            df = 1.0 + self.rho * (nr2 - nr) / h
            rs = rs - f / df
        return rs

    def z_at_r(self, r) -> np.ndarray:
        return self.point(self.rs_at_r(r))[..., 1]

    def errors(self, pr, pz) -> tuple[np.ndarray, np.ndarray]:
        """Signed offset error (mm, + outside) and target tangent angle at the foot."""
        rf = foot_on_sheet(self.lobe, pr, pz, zero=self.zero)
        nr, nz = _normal_m(self.lobe, rf)
        d = (np.asarray(pr) - rf) * nr + (np.asarray(pz) - _zm(self.lobe, rf, self.zero)) * nz
        return d - self.rho, self.theta(rf)


class _Layout:
    """Where each lobe's path starts and ends on the lattice, and the junction moves."""

    def __init__(self, mirror: Mirror, lathe: Lathe, rho: float) -> None:
        self.mirror, self.lathe, self.rho = mirror, lathe, rho
        res = lathe.resolution
        zero = mirror.vertex_z
        rj = mirror.r_junction
        # the nose centre's column on the wall: at or inside rj - rho (never into the wall)
        self.r_wall = math.floor((rj - rho) / res + 1e-9) * res
        rs_end = rj if rho == 0.0 else _solve_rs_for_centre_r(mirror.inner, rho, self.r_wall)
        self.inner = _Target(mirror.inner, zero, rho, 0.0, rs_end)
        self.outer = _Target(mirror.outer, zero, rho, rj, mirror.r_max)
        # fixed columns of the end points: the axis, the wall; for a sharp tool also the
        # rim; with a nose the outer ends float (nearest lattice point to the target)
        self.inner_cols = (0.0, self.r_wall)
        self.outer_cols = (rj, mirror.r_max) if rho == 0.0 else (None, None)

    def targets(self) -> tuple[_Target, _Target]:
        return self.inner, self.outer

    def junction_extra(self) -> int:
        """Points the junction adds beyond the lobes' own end points."""
        return 0 if self.rho == 0.0 else 1

    def min_points(self, max_dev: float) -> int:
        """Points a polyline needs to stay within max_dev of both lobes (chord sag k L^2/8)."""
        total = 0
        for t in self.targets():
            kappa = np.abs(np.gradient(t.theta_tab, t.s_tab))
            total += int(math.ceil(np.trapezoid(np.sqrt(kappa / (8.0 * max_dev)), t.s_tab))) + 1
        return total + self.junction_extra()

    def assemble_lines(self, inner: np.ndarray, outer: np.ndarray) -> tuple[list, list]:
        """G1 moves through the inner points, the junction, the outer points."""
        segs: list[Move] = []
        lobes: list[str] = []
        for a, b in zip(inner[:-1], inner[1:]):
            segs.append(Line(_pt(a), _pt(b)))
            lobes.append("inner")
        segs_j = self.junction_moves(inner[-1], outer[0])
        segs += segs_j
        lobes += ["junction"] * len(segs_j)
        for a, b in zip(outer[:-1], outer[1:]):
            segs.append(Line(_pt(a), _pt(b)))
            lobes.append("outer")
        return segs, lobes

    def junction_moves(self, inner_end: np.ndarray, outer_start: np.ndarray) -> list[Move]:
        """Up the step wall from the inner lobe's last point to the outer lobe's first.

        Sharp tool: one G1 up the wall (same column). With a nose: up the wall at the
        nose's column, then along the outer lobe's start tangent to its first point, so
        the path passes the step's top corner at >= rho (a corner circumscribed by two
        tangents, the corner left sharp).
        """
        if self.rho == 0.0:
            return [Line(_pt(inner_end), _pt(outer_start))]
        res = self.lathe.resolution
        lobe = self.mirror.outer
        s0 = float(lobe.slope(self.mirror.r_junction))
        # the outer offset's tangent line at its start, back to the wall column; round
        # up (away from the part)
        z2 = outer_start[1] + (outer_start[0] - self.r_wall) * s0
        z2 = math.ceil(z2 / res - 1e-9) * res
        p2 = np.array([self.r_wall, z2])
        return [Line(_pt(inner_end), _pt(p2)), Line(_pt(p2), _pt(outer_start))]


def _pt(p) -> tuple[float, float]:
    return (float(p[0]), float(p[1]))


# --------------------------------------------------------------------------------------
# Strategy PAPER: spread and round


def _paper_points(layout: _Layout, lathe: Lathe) -> tuple[np.ndarray, np.ndarray]:
    """The paper's method: points evenly spaced along the whole profile's length, each
    coordinate rounded to the lattice (section 6: 528 points, 0.005 mm)."""
    n_inner, n_outer = _split_budget(layout, lathe.max_points - layout.junction_extra(),
                                     weights=[t.length for t in layout.targets()])
    out = []
    for t, n in zip(layout.targets(), (n_inner, n_outer)):
        s = np.linspace(0.0, t.length, n)
        p = t.point(t.rs_at_s(s))
        out.append(lathe.snap(p))
    return out[0], out[1]


def _split_budget(layout: _Layout, total: int, weights) -> tuple[int, int]:
    w = np.asarray(weights, dtype=float)
    n0 = int(round(total * w[0] / w.sum()))
    n0 = min(max(n0, 2), total - 2)
    return n0, total - n0


# --------------------------------------------------------------------------------------
# Strategy LATTICE: equal turning per chord, vertices chosen by dynamic programming


def _lattice_points(layout: _Layout, lathe: Lathe) -> tuple[np.ndarray, np.ndarray]:
    """Lines whose vertices are lattice points chosen for the smallest slope errors.

    Vertex positions are spread along each lobe (see _LATTICE_P/_C), the budget shared
    between the lobes in proportion; then each vertex picks one of the lattice points
    near its position (the 24 nearest the curve within 0.4 of the gap to its
    neighbours) by dynamic programming that minimises the sum over chords of (max end
    slope error)^4 + (weighted end offset)^4, which weighs the worst chords most.
    """
    res = lathe.resolution
    total = lathe.max_points - layout.junction_extra()
    turning = [abs(t.theta_tab[-1] - t.theta_tab[0]) for t in layout.targets()]
    lengths = [t.length for t in layout.targets()]
    # Weight: turning + length * mean curvature / 4 keeps flat stretches from starving.
    mean_k = sum(turning) / sum(lengths)
    weights = []
    for t in layout.targets():
        kappa = np.abs(np.gradient(t.theta_tab, t.s_tab))
        weights.append(np.trapezoid((kappa / mean_k) ** _LATTICE_P + _LATTICE_C, t.s_tab))
    counts = _split_budget(layout, total, weights)
    out = []
    for t, n, cols in zip(layout.targets(), counts, (layout.inner_cols, layout.outer_cols)):
        kappa = np.abs(np.gradient(t.theta_tab, t.s_tab))
        dens = (kappa / mean_k) ** _LATTICE_P + _LATTICE_C
        cum = np.concatenate([[0.0], np.cumsum(0.5 * (dens[1:] + dens[:-1]) * np.diff(t.s_tab))])
        s_nom = np.interp(np.linspace(0.0, cum[-1], n), cum, t.s_tab)
        out.append(_dp_vertices(t, s_nom, res, cols))
    return out[0], out[1]


#: Vertex density along the curve ~ (kappa / mean kappa)^P + C. Measured on the paper's
#: mirror: P = 0 (even spacing) beats spreading by curvature, which crowds the flat
#: vertex where the lattice's rows quantise short chords' slopes coarsely.
_LATTICE_P = 0.0
_LATTICE_C = 1.0
#: Weight (rad per mm) of a chord end's offset from the curve against its slope error:
#: 5 halves the paper method's normal deviation for a few % more slope error.
_DEV_WEIGHT = 5.0


def _candidates(t: _Target, s_nom: np.ndarray, res: float, cols, k_best: int):
    """Up to k_best lattice points near each nominal vertex, those nearest the curve."""
    rs = t.rs_at_s(s_nom)
    p = t.point(rs)
    gaps = np.diff(p[:, 0])
    half = np.empty(len(s_nom))
    half[:] = np.inf
    half[:-1] = np.minimum(half[:-1], gaps)
    half[1:] = np.minimum(half[1:], gaps)
    half = np.maximum(0.4 * half, res)  # windows of neighbours never overlap
    # a lobe's end points stay at its ends (the rim must be cut to the rim)
    half[0] = min(half[0], 2 * res)
    half[-1] = min(half[-1], 2 * res)
    w = int(max(1, min(60, np.max(np.floor(half / res)))))
    offs = np.arange(-w, w + 1)
    col = np.rint(p[:, 0] / res).astype(np.int64)[:, None] + offs[None, :]
    ok = np.abs(col * res - p[:, [0]]) <= half[:, None] + 1e-12
    for i, c in ((0, cols[0]), (len(s_nom) - 1, cols[1])):
        if c is not None:
            ok[i] = col[i] == int(round(c / res))
    r = col * res
    r_safe = np.where(ok, r, p[:, [0]])
    z = t.z_at_r(np.clip(r_safe, t.r_tab[0], t.r_tab[-1]))
    zl = np.floor(z / res).astype(np.int64)
    cand_r = np.concatenate([r_safe, r_safe], axis=1)
    cand_zk = np.concatenate([zl, zl + 1], axis=1)
    cand_ok = np.concatenate([ok, ok], axis=1)
    cand_z = cand_zk * res
    d, th = t.errors(cand_r, cand_z)
    score = np.where(cand_ok, np.abs(d), np.inf)
    order = np.argsort(score, axis=1, kind="stable")[:, :k_best]
    take = lambda a: np.take_along_axis(a, order, axis=1)  # noqa: E731
    return take(cand_r), take(cand_z), take(d), take(th), np.isfinite(take(score))


def _dp_vertices(t: _Target, s_nom: np.ndarray, res: float, cols, k_best: int = 24) -> np.ndarray:
    cr, cz, d, th, valid = _candidates(t, s_nom, res, cols, k_best)
    n, k = cr.shape
    # cost[i, a, b]: chord from candidate a of vertex i to candidate b of vertex i+1
    dr = cr[1:, None, :] - cr[:-1, :, None]
    dz = cz[1:, None, :] - cz[:-1, :, None]
    chord = np.arctan2(dz, np.where(dr > 0, dr, np.nan))
    e = np.maximum(np.abs(chord - th[:-1, :, None]), np.abs(chord - th[1:, None, :]))
    # the chord's offset from the curve, weighed in as an angle: _DEV_WEIGHT rad per mm
    dev = _DEV_WEIGHT * np.maximum(np.abs(d[:-1, :, None]), np.abs(d[1:, None, :]))
    cost = np.where(np.isfinite(e) & valid[:-1, :, None] & valid[1:, None, :], e**4 + dev**4, np.inf)
    acc = np.where(valid[0], 0.0, np.inf)
    back = np.zeros((n - 1, k), dtype=np.int64)
    for i in range(n - 1):
        tot = acc[:, None] + cost[i]
        back[i] = np.argmin(tot, axis=0)
        acc = tot[back[i], np.arange(k)]
    j = int(np.argmin(acc))
    if not np.isfinite(acc[j]):
        raise RuntimeError("lattice strategy: no chain of lattice points advances in r")
    idx = np.empty(n, dtype=np.int64)
    idx[-1] = j
    for i in range(n - 2, -1, -1):
        idx[i] = back[i, idx[i + 1]]
    rows = np.arange(n)
    return np.stack([cr[rows, idx], cz[rows, idx]], axis=-1)


# --------------------------------------------------------------------------------------
# Strategy ARCS: lattice end points nearest the curve, lattice centres fitted


def _arc_moves(layout: _Layout, lathe: Lathe) -> tuple[list, list]:
    """G2/G3 arcs per lobe, end points and centres on the lattice (see module doc)."""
    budget = lathe.max_points - 1 - (1 + layout.junction_extra())  # start, junction
    n_arcs = _arc_counts(layout, budget)
    inner_arcs = _lobe_arcs(layout.inner, lathe, layout.inner_cols, n_arcs[0])
    outer_arcs = _lobe_arcs(layout.outer, lathe, layout.outer_cols, n_arcs[1])
    j = layout.junction_moves(np.asarray(inner_arcs[-1].end), np.asarray(outer_arcs[0].start))
    segs: list[Move] = [*inner_arcs, *j, *outer_arcs]
    lobes = ["inner"] * len(inner_arcs) + ["junction"] * len(j) + ["outer"] * len(outer_arcs)
    return segs, lobes


def _arc_counts(layout: _Layout, budget: int) -> tuple[int, int]:
    """Arcs per lobe: one per `_ARC_LENGTH` mm, fewer (shared by length) if the budget
    (2 points per arc) cannot hold that many."""
    want = [max(1, int(math.ceil(t.length / _ARC_LENGTH))) + 2 for t in layout.targets()]
    cap = budget // 2
    if sum(want) > cap:
        n0 = max(1, min(cap - 1, int(round(cap * want[0] / sum(want)))))
        return n0, cap - n0
    return want[0], want[1]


#: Target arc length (mm). Longer arcs tilt less for the same lattice offset of their
#: ends (~1e-5 mm for the lattice point nearest the curve in a 0.6 mm window); shorter
#: ones follow the hyperbola's changing curvature better (slope error ~ k' L^2 / 8).
#: Measured on the paper's mirror (nose 0): max slope error inner/outer 1.40e-3/9.7e-4
#: rad at 0.4 mm, 1.07e-3/9.7e-4 at 0.8, 6.9e-4/9.7e-4 at 1.0, 1.00e-3/9.7e-4 at 1.5,
#: 1.61e-3/9.7e-4 at 2.0, 2.94e-3/9.7e-4 at 3.0 (the outer figure is its fixed-column ends').
_ARC_LENGTH = 1.0


def _lobe_arcs(t: _Target, lathe: Lathe, cols, m: int) -> list[Arc]:
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
    cr, cz, _, _, _ = _candidates(t, s_nom, res, end_cols, k_best=2)
    ends = np.stack([cr[:, 0], cz[:, 0]], axis=-1)
    if first is not None:
        ends[0] = first.end
    if last is not None:
        ends[-1] = last.start
    arcs, _ = _fit_arcs(t, ends, lathe)
    return ([first] if first else []) + arcs + ([last] if last else [])


#: Lengths (mm) tried for an arc ending on a fixed column.
_END_ARC_LENGTHS = (0.4, 0.6, 0.8, 1.0, 1.3, 1.6, 2.0, 2.5, 3.0, 4.0)


def _end_arc(t: _Target, lathe: Lathe, col: float, *, at_start: bool) -> Arc:
    res = lathe.resolution
    lens = np.asarray([x for x in _END_ARC_LENGTHS if x < 0.45 * t.length])
    s_fixed = 0.0 if at_start else t.length
    s_free = lens if at_start else t.length - lens[::-1]
    # the fixed column's two lattice rows
    if at_start:
        fr, fz, _, _, _ = _candidates(t, np.array([0.0, 0.1]), res, (col, None), k_best=2)
        fixed = np.stack([fr[0], fz[0]], axis=-1)  # (2, 2)
    else:
        fr, fz, _, _, _ = _candidates(t, np.array([t.length - 0.1, t.length]), res, (None, col), k_best=2)
        fixed = np.stack([fr[-1], fz[-1]], axis=-1)
    gr, gz, _, _, _ = _candidates(t, np.concatenate([[s_fixed], s_free]) if at_start
                                  else np.concatenate([s_free, [s_fixed]]), res, (None, None), k_best=1)
    free = np.stack([gr[:, 0], gz[:, 0]], axis=-1)
    free = free[1:] if at_start else free[:-1]
    pairs_f = np.repeat(fixed, len(free), axis=0)
    pairs_g = np.tile(free, (2, 1))
    S, E = (pairs_f, pairs_g) if at_start else (pairs_g, pairs_f)
    arcs, err = _fit_arcs(t, None, lathe, starts=S, ends_=E)
    return arcs[int(np.argmin(err))]


def _fit_arcs(t: _Target, ends: np.ndarray | None, lathe: Lathe, *, window: int = 10,
              n_check: int = 9, starts: np.ndarray | None = None,
              ends_: np.ndarray | None = None) -> tuple[list[Arc], np.ndarray]:
    """One arc per consecutive pair of end points, its centre the lattice point (within
    `window` steps of the best circle's centre) whose cut arc has the smallest max slope
    error against the curve, among those within the radius tolerance."""
    res = lathe.resolution
    if ends is not None:
        S, E = ends[:-1], ends[1:]
    else:
        S, E = starts, ends_
    m = S.shape[0]
    # the ideal centre: on the normal at the middle, at the middle's radius of curvature
    mid = 0.5 * (S + E)
    rs_mid = foot_on_sheet(t.lobe, mid[:, 0], mid[:, 1], zero=t.zero)
    kap = _kappa_offset(t, rs_mid)
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
    # sample each candidate's spiral and score its max slope error against the curve
    a0 = np.arctan2(S[:, None, 1] - cand[..., 1], S[:, None, 0] - cand[..., 0])
    a1 = np.arctan2(E[:, None, 1] - cand[..., 1], E[:, None, 0] - cand[..., 0])
    sweep = (a1 - a0 + np.pi) % (2 * np.pi) - np.pi
    u = np.linspace(0.0, 1.0, n_check)
    phi = a0[..., None] + sweep[..., None] * u
    rad = r0[..., None] + (r1 - r0)[..., None] * u
    pr = cand[..., 0, None] + rad * np.cos(phi)
    pz = cand[..., 1, None] + rad * np.sin(phi)
    # tangent of the spiral: d/dphi of (R cos, R sin) with dR/dphi = (r1 - r0) / sweep
    dR = ((r1 - r0) / np.where(sweep == 0, 1.0, sweep))[..., None]
    tr = dR * np.cos(phi) - rad * np.sin(phi)
    tz = dR * np.sin(phi) + rad * np.cos(phi)
    sign = np.where(tr < 0, -1.0, 1.0)  # orient toward +r
    ang = np.arctan2(tz * sign, tr * sign)
    d, th = t.errors(pr, pz)
    err = np.max(np.abs(ang - th), axis=-1)
    dev = np.max(np.abs(d), axis=-1)
    score = np.where(ok & (dev < 4 * res), err + 0.1 * dev / 1.0, np.inf)
    best = np.argmin(score, axis=1)
    if not np.all(np.isfinite(score[np.arange(m), best])):
        bad = np.flatnonzero(~np.isfinite(score[np.arange(m), best]))
        raise RuntimeError(f"arcs strategy: no lattice centre within the radius tolerance for arcs {bad[:5]} of {m}: S={S[bad[:2]]} E={E[bad[:2]]} c={c_ideal[bad[:2]]} ok={ok[bad[:2]].sum(axis=1)} dev={dev[bad[:2]].min(axis=1)}")
    arcs = []
    for i in range(m):
        c = cand[i, best[i]]
        arcs.append(Arc(start=_pt(S[i]), end=_pt(E[i]), centre=_pt(c),
                        clockwise=bool(sweep[i, best[i]] > 0)))
    return arcs, score[np.arange(m), best]


def _kappa_offset(t: _Target, rs) -> np.ndarray:
    """Curvature (1/mm) of the nose-centre curve: the sheet's k / (1 + rho k)."""
    s = t.lobe.slope(rs)
    q = np.sqrt(1.0 + (np.asarray(rs) / t.lobe.b) ** 2)
    z2 = t.lobe.a / (t.lobe.b**2 * q**3)
    k = z2 / (1.0 + s * s) ** 1.5
    return k / (1.0 + t.rho * k)
