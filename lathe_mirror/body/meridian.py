"""The mirror's solid as plain data: a closed meridian of lines, arcs and hyperbola arcs.

Machine frame (ARCHITECTURE.md): the revolution axis is Z, the vertex is at the origin,
the part lies in -Z, and the meridian is drawn in the (r, Z) half plane, r >= 0. Every
writer (STEP, STL, DXF) revolves or draws the same `Meridian`, so they cannot disagree
about the body.

The loop runs: the mirror face from the vertex outward (the two hyperbolic lobes and the
step wall between them, or the toolpath's programmed contour), a flat shoulder out to
the blank's radius, the blank's side down to the back face, the back face with its bore
or boss, and up the axis to the vertex. Nothing here imports cadquery.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from enum import Enum
from typing import Any, Iterable

import numpy as np

from ..declared import check as check_declared, key as declared_key
from ..declared.section import choice, setting
from ..design import Lobe, Mirror
from ..enums import Mount, StepSchema
from ..errors import InputError


class SegmentKind(str, Enum):
    """What a meridian segment is; the writers turn each into an exact entity."""

    LINE = "line"
    ARC = "arc"
    HYPERBOLA = "hyperbola"


class Role(str, Enum):
    """Which part of the body a segment belongs to (DXF layers, face checks)."""

    MIRROR = "mirror"  # the reflective face: a lobe or the programmed contour
    WALL = "wall"      # the step wall between the lobes (part of the turned face)
    BODY = "body"      # shoulder, side, back, mount, axis


@dataclass(frozen=True)
class Segment:
    """One piece of the meridian, machine frame (r, Z), mm.

    LINE: start to end. ARC: circle of `radius` about `centre`, from start to end,
    `clockwise` as seen with r to the right and Z up. HYPERBOLA: the curve
    Z = centre[1] - a sqrt(1 + r^2 / b^2) (a lobe's upper sheet, Eq. 4 moved to the machine
    frame: centre[1] = vertex_z - e), from start to end.
    """

    kind: SegmentKind
    start: tuple[float, float]
    end: tuple[float, float]
    role: Role = Role.BODY
    centre: tuple[float, float] = (0.0, 0.0)
    radius: float = 0.0
    clockwise: bool = False
    a: float = 0.0
    b: float = 0.0
    lobe: str = ""

    # -- geometry ---------------------------------------------------------------------

    def arc_angles(self) -> tuple[float, float]:
        """ARC: start and end angles (rad) about the centre, signed so that end - start
        is the swept angle (negative when clockwise)."""
        cr, cz = self.centre
        t0 = math.atan2(self.start[1] - cz, self.start[0] - cr)
        t1 = math.atan2(self.end[1] - cz, self.end[0] - cr)
        if self.clockwise:
            while t1 >= t0:
                t1 -= 2.0 * math.pi
        else:
            while t1 <= t0:
                t1 += 2.0 * math.pi
        return t0, t1

    def hyperbola_params(self) -> tuple[float, float]:
        """HYPERBOLA: the parameters u (r = b sinh u) of the start and the end."""
        return math.asinh(self.start[0] / self.b), math.asinh(self.end[0] / self.b)

    def hyperbola_point(self, u: np.ndarray) -> np.ndarray:
        """HYPERBOLA: points (r, Z), mm, at parameters u: r = b sinh u, Z = zc - a cosh u."""
        u = np.asarray(u, dtype=float)
        return np.stack([self.b * np.sinh(u), self.centre[1] - self.a * np.cosh(u)], axis=-1)

    def conic_bezier(self) -> tuple[np.ndarray, float]:
        """HYPERBOLA: the arc as an exact rational quadratic Bezier curve: control points
        (3, 2) (start, the tangents' intersection, end) and the middle weight w.

        A conic arc is exactly C(t) = ((1-t)^2 P0 + 2t(1-t) w P1 + t^2 P2) / ((1-t)^2 +
        2t(1-t) w + t^2) (Piegl & Tiller, The NURBS Book, sec. 7.2). C(1/2) = (M + w P1) /
        (1 + w), M the chord's midpoint, is the arc's point whose tangent is parallel to
        the chord; on the sheet the slope is dZ/dr = -(a / b) tanh u there.
        """
        p0, p2 = np.array(self.start, float), np.array(self.end, float)
        u0, u1 = self.hyperbola_params()
        t0 = np.array([self.b * math.cosh(u0), -self.a * math.sinh(u0)])  # dP/du
        t2 = np.array([self.b * math.cosh(u1), -self.a * math.sinh(u1)])
        # P1 = p0 + s t0 = p2 + q t2.
        s, _ = np.linalg.solve(np.stack([t0, -t2], axis=1), p2 - p0)
        p1 = p0 + s * t0
        chord = p2 - p0
        us = math.atanh(-(chord[1] / chord[0]) * self.b / self.a)
        shoulder = self.hyperbola_point(us)
        mid = 0.5 * (p0 + p2)
        w = float(np.linalg.norm(shoulder - mid) / np.linalg.norm(p1 - shoulder))
        return np.stack([p0, p1, p2]), w

    def points(self, tolerance: float) -> np.ndarray:
        """Points (n, 2) along the segment, start and end included, such that the chords
        stay within `tolerance` (mm) of the curve. Lines give their two ends."""
        if self.kind is SegmentKind.LINE:
            return np.array([self.start, self.end], dtype=float)
        if self.kind is SegmentKind.ARC:
            t0, t1 = self.arc_angles()
            n = arc_chords(abs(t1 - t0), self.radius, tolerance)
            t = np.linspace(t0, t1, n + 1)
            pts = np.stack([self.centre[0] + self.radius * np.cos(t),
                            self.centre[1] + self.radius * np.sin(t)], axis=-1)
        else:
            u0, u1 = self.hyperbola_params()
            # The sheet's curvature is largest at its vertex, a / b^2; a chord of length L
            # on a curve of curvature k has sagitta ~ k L^2 / 8. Uniform u steps are
            # longest at the far end, where |dP/du| = sqrt(b^2 cosh^2 + a^2 sinh^2) peaks.
            k = self.a / self.b**2
            chord = math.sqrt(8.0 * tolerance / k)
            um = max(abs(u0), abs(u1))
            speed = math.hypot(self.b * math.cosh(um), self.a * math.sinh(um))
            n = max(1, math.ceil(abs(u1 - u0) * speed / chord))
            pts = self.hyperbola_point(np.linspace(u0, u1, n + 1))
        pts[0], pts[-1] = self.start, self.end  # exact ends: the loop must close
        return pts

    def integral_r2_dz(self) -> float:
        """Integral of r^2 dZ along the segment (mm^3), closed form; the body's volume is
        pi times its sum around the loop (Green's theorem on V = 2 pi (double integral of
        r dr dZ))."""
        (r0, z0), (r1, z1) = self.start, self.end
        if self.kind is SegmentKind.LINE:
            return (z1 - z0) * (r0 * r0 + r0 * r1 + r1 * r1) / 3.0
        if self.kind is SegmentKind.HYPERBOLA:
            # dZ = -a r / (b^2 sqrt(s)) dr with s = 1 + r^2 / b^2, so
            # integral r^2 dZ = -a b^2 (s^1.5 / 3 - s^0.5).
            def f(r: float) -> float:
                s = 1.0 + (r / self.b) ** 2
                return -self.a * self.b**2 * (s**1.5 / 3.0 - math.sqrt(s))

            return f(r1) - f(r0)
        cr, R = self.centre[0], self.radius
        t0, t1 = self.arc_angles()

        def g(t: float) -> float:
            # r = cr + R cos t, dZ = R cos t dt.
            s = math.sin(t)
            return R * (cr * cr * s + cr * R * (t + math.sin(2.0 * t) / 2.0) + R * R * (s - s**3 / 3.0))

        return g(t1) - g(t0)


@dataclass(frozen=True)
class BodySpec:
    """The mounting body around the turned face. Lengths in mm.

    blank_diameter: the turned blank (>= 2 r_max of the face). thickness: from the vertex
    plane Z = 0 down to the back face. mount: bore, boss or none, of mount_diameter and
    mount_depth (bore depth into the back, or boss length). min_wall: the thinnest
    material allowed under the face (above the back face and above the bore).
    """

    blank_diameter: float = setting("cad.blank_diameter")
    thickness: float = setting("cad.thickness")
    mount: Mount = setting("cad.mount", choice(Mount))
    mount_diameter: float = setting("cad.mount_diameter")
    mount_depth: float = setting("cad.mount_depth")
    min_wall: float = setting("cad.min_wall")

    @property
    def length(self) -> float:
        """From the vertex plane to the body's lowest point, mm: the thickness, plus the
        boss's length when the mount is a boss (what the part-off cuts below)."""
        return self.thickness + (self.mount_depth if self.mount is Mount.BOSS else 0.0)

    def __post_init__(self) -> None:
        # Each length within its key's declaration (cad.<field>): the line load() gives;
        # what the mirror asks of them (close_body) is checked with the mirror.
        for name in ("blank_diameter", "thickness", "mount_diameter", "mount_depth", "min_wall"):
            check_declared(f"cad.{name}", getattr(self, name))


@dataclass(frozen=True)
class Meridian:
    """A closed meridian loop in the machine frame (r, Z), mm: revolve it about Z.

    The first `n_face` segments are the turned face, from the axis outward.
    """

    segments: tuple[Segment, ...]
    n_face: int
    spec: BodySpec
    name: str = "design"
    features: dict[str, float] = field(default_factory=dict)

    @property
    def face(self) -> tuple[Segment, ...]:
        return self.segments[: self.n_face]

    def volume(self) -> float:
        """Volume of the solid of revolution (mm^3), closed form per segment."""
        return abs(math.pi * sum(s.integral_r2_dz() for s in self.segments))

    def polyline(self, tolerance: float) -> np.ndarray:
        """The loop as points (n, 2), chords within `tolerance` mm. The loop is implied
        closed: the first point is not repeated at the end."""
        parts = [s.points(tolerance)[:-1] for s in self.segments]
        return np.concatenate(parts, axis=0)


# --------------------------------------------------------------------------------------
# Building meridians


#: Allowed STL tolerances (mm). Finer than 0.001 mm the mesh passes 0.24 M triangles
#: (12 MB, growing as 1 / tolerance: viewers and slicers suffer); coarser than 1 mm the
#: facets no longer resolve the 1.8 mm step between the lobes.
STL_TOLERANCE_RANGE = (declared_key("cad.stl_tolerance").lo, declared_key("cad.stl_tolerance").hi)


def check_stl_tolerance(tolerance: Any, key: str = "cad.stl_tolerance") -> float:
    """The tolerance (mm) as a float if within cad.stl_tolerance's declared range
    (ConfigError naming `key` otherwise, the line load() gives)."""
    check_declared("cad.stl_tolerance", tolerance, where=key)
    return float(tolerance)


def check_product_name(name: str, key: str = "cad.product_name") -> str:
    """The name if a STEP string can hold it as written (InputError naming `key`
    otherwise): 1 to 80 printable ASCII characters, no quote (STEP escapes it as '')."""
    if not (isinstance(name, str) and name and name.isascii() and name.isprintable()
            and "'" not in name and len(name) <= 80):
        raise InputError(
            f"{key} = {name!r}: allowed 1 to 80 printable ASCII characters without "
            "quotes (STEP strings)"
        )
    return name


@dataclass(frozen=True)
class CadSettings:
    """The [cad] export settings, checked: STEP protocol and product name, STL tolerance
    (mm, the facets' largest distance from the surface)."""

    schema: StepSchema = setting("cad.step_schema", choice(StepSchema))
    product_name: str = setting("cad.product_name")
    stl_tolerance: float = setting("cad.stl_tolerance")

    def __post_init__(self) -> None:
        check_product_name(self.product_name)
        check_stl_tolerance(self.stl_tolerance)


#: Largest body length accepted (mm): a sanity bound, not a machine limit (the lathe's
#: travel is checked by the toolpath); it keeps a typo such as 3e30 from writing a file
#: of overflowed coordinates.
MAX_LENGTH = 10_000.0

#: Smallest feature of the body (mm): a mount, a wall, a shoulder. Below it a face is a
#: sliver that the STEP kernel cannot sew (a 1e-9 mm bore gave FreeCAD two shells, one
#: open, of volume 2.7e102 mm^3); 0.01 mm is two lattice steps of the paper's lathe.
MIN_FEATURE = 0.01


def design_meridian(mirror: Mirror, spec: BodySpec) -> Meridian:
    """The designed mirror: both lobes exactly (hyperbola arcs), the step wall as
    designed, on the mounting body of `spec`."""
    vz = mirror.vertex_z
    r1, rmax = mirror.r_junction, mirror.r_max

    def lobe_arc(lobe: Lobe, ra: float, rb: float) -> Segment:
        zc = vz - lobe.e  # the hyperbola's centre (z = e) in the machine frame
        zf = lambda r: zc - lobe.a * math.sqrt(1.0 + (r / lobe.b) ** 2)  # noqa: E731
        return Segment(SegmentKind.HYPERBOLA, (ra, zf(ra)), (rb, zf(rb)), Role.MIRROR,
                       centre=(0.0, zc), a=lobe.a, b=lobe.b, lobe=lobe.name)

    inner = lobe_arc(mirror.inner, 0.0, r1)
    inner = Segment(inner.kind, (0.0, 0.0), inner.end, inner.role, inner.centre,
                    a=inner.a, b=inner.b, lobe=inner.lobe)  # the vertex is Z = 0 by definition
    outer = lobe_arc(mirror.outer, r1, rmax)
    wall = Segment(SegmentKind.LINE, inner.end, outer.start, Role.WALL)
    face = [inner, wall, outer]
    features = {
        "r_top_inner": r1, "r_top_outer": rmax,
        "z_vertex": 0.0, "z_rim_inner": inner.end[1], "z_rim_outer": outer.end[1],
        "z_step_outer": outer.start[1], "step": outer.start[1] - inner.end[1],
    }
    return close_body(face, spec, name="design", features=features)


def programmed_meridian(face: list[Segment], mirror: Mirror, spec: BodySpec) -> Meridian:
    """The as-programmed mirror: the contour the program cuts (see `programmed_contour`),
    lines and arcs revolved exactly, on the same body. The contour runs outward from the
    axis; a contour that starts off the axis is faced flat to it."""
    face = list(face)
    if not face:
        raise InputError("toolpath: no finishing moves to revolve")
    if face[0].start[0] > 1e-9:
        face.insert(0, Segment(SegmentKind.LINE, (0.0, face[0].start[1]), face[0].start, Role.MIRROR))
    for prev, nxt in zip(face, face[1:]):
        if math.dist(prev.end, nxt.start) > 1e-9:
            raise RuntimeError(f"toolpath: the contour is broken between {prev.end} and {nxt.start}")
    r1 = mirror.r_junction
    features = {
        "r_top_inner": r1, "r_top_outer": face[-1].end[0],
        "z_vertex": face[0].start[1], "z_rim_inner": _face_z_at(face, r1, side=-1),
        "z_rim_outer": face[-1].end[1], "z_step_outer": _face_z_at(face, r1, side=+1),
    }
    features["step"] = features["z_step_outer"] - features["z_rim_inner"]
    return close_body(face, spec, name="programmed", features=features)


def close_body(face: list[Segment], spec: BodySpec, *, name: str,
               features: dict[str, float] | None = None) -> Meridian:
    """Close a turned face (from the axis outward) into the body's meridian loop,
    checking that the body holds the face (InputError naming the [cad] key otherwise)."""
    r_face = face[-1].end[0]
    z_rim = face[-1].end[1]
    R = spec.blank_diameter / 2.0
    T = spec.thickness
    pts = np.concatenate([s.points(1e-4) for s in face], axis=0)
    z_low = float(pts[:, 1].min())

    if R < r_face - 1e-9:
        raise InputError(
            f"cad.blank_diameter = {spec.blank_diameter:g} mm is smaller than the mirror "
            f"(diameter {2 * r_face:.3f} mm): allowed >= {2 * r_face:.3f} mm"
        )
    if 1e-9 < R - r_face < MIN_FEATURE - 1e-9:
        raise InputError(
            f"cad.blank_diameter = {spec.blank_diameter:.8g} mm leaves a shoulder of {R - r_face:.3g} mm beyond "
            f"the mirror (diameter {2 * r_face:.4f} mm): allowed the mirror's diameter or at least "
            f"{2 * MIN_FEATURE:g} mm more (the body's smallest feature is {MIN_FEATURE:g} mm)"
        )
    _check_features(spec)
    if -T > z_low - spec.min_wall + 1e-9:
        need = -z_low + spec.min_wall
        raise InputError(
            f"cad.thickness = {T:g} mm is thinner than the mirror's depth ({-z_low:.3f} mm "
            f"below the vertex) plus cad.min_wall = {spec.min_wall:g} mm: allowed >= {need:.3f} mm"
        )

    loop = list(face)
    cur = face[-1].end

    def line_to(p: tuple[float, float]) -> None:
        nonlocal cur
        if math.dist(cur, p) > 1e-12:
            loop.append(Segment(SegmentKind.LINE, cur, p, Role.BODY))
            cur = p

    line_to((R, z_rim))  # the shoulder beyond the rim
    line_to((R, -T))     # the blank's side
    rm = spec.mount_diameter / 2.0
    if spec.mount is Mount.BORE:
        if rm > R - spec.min_wall:
            raise InputError(
                f"cad.mount_diameter = {spec.mount_diameter:g} mm: a bore must leave "
                f"cad.min_wall = {spec.min_wall:g} mm of side wall; allowed <= "
                f"{2 * (R - spec.min_wall):.3f} mm"
            )
        z_top = -T + spec.mount_depth
        limit = _face_min_within(face, rm) - spec.min_wall
        if z_top > limit + 1e-9:
            raise InputError(
                f"cad.mount_depth = {spec.mount_depth:g} mm: the bore would come within "
                f"cad.min_wall = {spec.min_wall:g} mm of the mirror face; allowed <= "
                f"{limit + T:.3f} mm"
            )
        line_to((rm, -T))
        line_to((rm, z_top))
        line_to((0.0, z_top))
    elif spec.mount is Mount.BOSS:
        if rm > R - MIN_FEATURE:
            raise InputError(
                f"cad.mount_diameter = {spec.mount_diameter:g} mm: the boss must be narrower than "
                f"the blank by a step of {MIN_FEATURE:g} mm at least; allowed <= "
                f"{spec.blank_diameter - 2 * MIN_FEATURE:g} mm"
            )
        line_to((rm, -T))
        line_to((rm, -T - spec.mount_depth))
        line_to((0.0, -T - spec.mount_depth))
    else:
        line_to((0.0, -T))
    line_to(face[0].start)  # up the axis
    feats = dict(features or {})
    feats.update({"blank_radius": R, "z_back": -T, "depth": -z_low})
    return Meridian(tuple(loop), n_face=len(face), spec=spec, name=name, features=feats)


# --------------------------------------------------------------------------------------
# Helpers


def _check_features(spec: BodySpec) -> None:
    """The body's own features (the wall, the mount) at least MIN_FEATURE (InputError
    naming the [cad] key): a smaller one makes a sliver face no STEP reader sews."""
    keys = ["min_wall"] + (["mount_diameter", "mount_depth"] if spec.mount is not Mount.NONE else [])
    for key in keys:
        value = getattr(spec, key)
        if value < MIN_FEATURE:
            raise InputError(
                f"cad.{key} = {value:.3g} mm: allowed >= {MIN_FEATURE:g} mm (smaller is a sliver face "
                f"the STEP kernel cannot sew; cad.mount = \"none\" for no mount)"
            )


def arc_chords(sweep: float, radius: float, tolerance: float) -> int:
    """Chords needed on a circular arc of `sweep` rad so that each sagitta <= tolerance:
    a chord over angle p has sagitta R (1 - cos(p / 2))."""
    if sweep <= 0.0:
        return 1
    if tolerance >= radius:
        return max(1, math.ceil(sweep / (math.pi / 2.0)))
    step = 2.0 * math.acos(1.0 - tolerance / radius)
    return max(1, math.ceil(sweep / step))


def _face_z_at(face: Iterable[Segment], r: float, side: int = -1) -> float:
    """Z (mm) of the face at radius r; at a vertical wall, the lower (side=-1: the end
    reached from the inside) or the upper end (side=+1: from the outside)."""
    best = None
    for s in face:
        pts = s.points(1e-4)
        rr, zz = pts[:, 0], pts[:, 1]
        lo, hi = rr.min(), rr.max()
        if lo - 1e-9 <= r <= hi + 1e-9:
            if hi - lo < 1e-12:  # a vertical wall: both ends at r
                continue
            order = np.argsort(rr)
            z = float(np.interp(r, rr[order], zz[order]))
            if best is None:
                best = z
            elif side > 0:
                best = z  # the later segment is the outside one
    if best is None:
        raise InputError(f"toolpath: the contour does not reach r = {r:g} mm")
    return best


def _face_min_within(face: Iterable[Segment], r_limit: float) -> float:
    """Lowest Z (mm) of the face over radii 0..r_limit (the material over a bore)."""
    zs = []
    for s in face:
        pts = s.points(1e-4)
        inside = pts[pts[:, 0] <= r_limit]
        if inside.size:
            zs.append(inside[:, 1].min())
        rr = pts[:, 0]
        if rr.min() < r_limit < rr.max():
            order = np.argsort(rr)
            zs.append(np.interp(r_limit, rr[order], pts[order, 1]))
    return float(min(zs))


@dataclass(frozen=True)
class CadModel:
    """The meridians behind every CAD file of one configuration (job.cad_model).

    design: the designed face on the body. programmed: the programmed contour's face on the
    body (None when not asked for). tool_centre: the programmed moves (the nose centre's
    path). toolpath_figures: the program's counts (moves, arcs, points, nose).
    """

    mirror: Mirror
    design: Meridian
    programmed: Meridian | None
    tool_centre: tuple[Segment, ...] | None
    toolpath_figures: dict[str, Any] | None
