"""The meridian curve z = Z(r) of a surface of revolution, in the camera frame (mm).

One interface for every surface the tool knows: the exact design, the programmed
contour of a toolpath, the as-machined and the polished surface. Every method is
vectorised over r. The surface has two lobes: r <= r_junction belongs to the inner lobe,
r > r_junction to the outer one, and the step between them is a vertical wall at
r_junction (not part of either lobe's Z).

Machine frame (ARCHITECTURE.md): Z_machine = vertex_z - z, so the vertex is Z = 0 and
the part lies in -Z; see `to_machine_z` / `from_machine_z`.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass

import numpy as np

from .design import Mirror
from .path import Arc


class Profile(ABC):
    """Meridian curve of a mirror surface. Camera frame, mm.

    Subclasses set r_junction, r_max (mm) and vertex_z (mm, the design's vertex height,
    which is the machine frame's Z = 0), and implement z and slope.
    """

    r_junction: float
    r_max: float
    vertex_z: float

    def __init__(self, *, r_junction: float, r_max: float, vertex_z: float) -> None:
        self.r_junction = float(r_junction)
        self.r_max = float(r_max)
        self.vertex_z = float(vertex_z)

    @abstractmethod
    def z(self, r: np.ndarray) -> np.ndarray:
        """Height of the surface at radius r (mm)."""

    @abstractmethod
    def slope(self, r: np.ndarray) -> np.ndarray:
        """dZ/dr at radius r (dimensionless)."""

    def normal(self, r: np.ndarray) -> np.ndarray:
        """Unit normal (n_r, n_z) at radius r, pointing toward the camera (n_z < 0)."""
        s = np.asarray(self.slope(r), dtype=float)
        n = np.stack([s, -np.ones_like(s)], axis=-1)
        return n / np.linalg.norm(n, axis=-1, keepdims=True)

    def lobe_index(self, r: np.ndarray) -> np.ndarray:
        """0 for the inner lobe (r <= r_junction), 1 for the outer lobe."""
        return (np.asarray(r) > self.r_junction).astype(np.intp)

    def lobe_range(self, k: int) -> tuple[float, float]:
        """Radial extent (mm) of lobe k (0 inner, 1 outer)."""
        return (0.0, self.r_junction) if k == 0 else (self.r_junction, self.r_max)

    def to_machine_z(self, z: np.ndarray) -> np.ndarray:
        """Camera-frame height (mm) to machine Z (mm): vertex at 0, part in -Z."""
        return self.vertex_z - np.asarray(z, dtype=float)

    def from_machine_z(self, zm: np.ndarray) -> np.ndarray:
        """Machine Z (mm) to camera-frame height (mm)."""
        return self.vertex_z - np.asarray(zm, dtype=float)

    def __repr__(self) -> str:
        return f"{type(self).__name__}(r_junction={self.r_junction:g} mm, r_max={self.r_max:g} mm)"


class ExactProfile(Profile):
    """The designed surface: each lobe's hyperbolic sheet, in closed form."""

    def __init__(self, mirror: Mirror):
        self.mirror = mirror
        super().__init__(r_junction=mirror.r_junction, r_max=mirror.r_max, vertex_z=mirror.vertex_z)

    def z(self, r: np.ndarray) -> np.ndarray:
        r = np.asarray(r, dtype=float)
        return np.where(r <= self.r_junction, self.mirror.inner.z(r), self.mirror.outer.z(r))

    def slope(self, r: np.ndarray) -> np.ndarray:
        r = np.asarray(r, dtype=float)
        return np.where(r <= self.r_junction, self.mirror.inner.slope(r), self.mirror.outer.slope(r))


@dataclass(frozen=True)
class LobeSamples:
    """Samples (r, z) of one lobe's meridian, r strictly increasing, camera frame, mm."""

    r: np.ndarray
    z: np.ndarray

    def __post_init__(self) -> None:
        if self.r.ndim != 1 or self.r.shape != self.z.shape or self.r.size < 2:
            raise ValueError("LobeSamples: r and z must be 1-D arrays of the same length >= 2")
        if np.any(np.diff(self.r) <= 0):
            raise ValueError("LobeSamples: r must be strictly increasing")


class PolylineProfile(Profile):
    """Straight segments between points, per lobe: the paper's 528-point model.

    Between the lobes' samples the profile holds a vertical step at r_junction. Beyond
    the first/last sample of a lobe the end segment is extended.
    """

    def __init__(self, inner: LobeSamples, outer: LobeSamples, *, r_junction: float,
                 r_max: float, vertex_z: float):
        self.lobes = (inner, outer)
        super().__init__(r_junction=r_junction, r_max=r_max, vertex_z=vertex_z)

    def z(self, r: np.ndarray) -> np.ndarray:
        return self._eval(r, derivative=False)

    def slope(self, r: np.ndarray) -> np.ndarray:
        return self._eval(r, derivative=True)

    def _eval(self, r: np.ndarray, derivative: bool) -> np.ndarray:
        r = np.asarray(r, dtype=float)
        out = np.empty_like(r)
        k = self.lobe_index(r)
        for i, s in enumerate(self.lobes):
            m = k == i
            rr = r[m]
            j = np.clip(np.searchsorted(s.r, rr, side="right") - 1, 0, s.r.size - 2)
            dz = (s.z[j + 1] - s.z[j]) / (s.r[j + 1] - s.r[j])
            out[m] = dz if derivative else s.z[j] + dz * (rr - s.r[j])
        return out


class SampledProfile(Profile):
    """A smooth profile from dense samples per lobe (cubic spline of z(r)).

    For surfaces known only by samples: the as-machined envelope, the polished surface.
    The samples should resolve every feature of interest; the spline adds nothing finer.
    """

    def __init__(self, inner: LobeSamples, outer: LobeSamples, *, r_junction: float,
                 r_max: float, vertex_z: float):
        from scipy.interpolate import CubicSpline

        self.lobes = (inner, outer)
        self._splines = tuple(CubicSpline(s.r, s.z, extrapolate=True) for s in (inner, outer))
        super().__init__(r_junction=r_junction, r_max=r_max, vertex_z=vertex_z)

    def z(self, r: np.ndarray) -> np.ndarray:
        return self._eval(r, 0)

    def slope(self, r: np.ndarray) -> np.ndarray:
        return self._eval(r, 1)

    def _eval(self, r: np.ndarray, nu: int) -> np.ndarray:
        r = np.asarray(r, dtype=float)
        inner = self.lobe_index(r) == 0
        if r.ndim == 0 or inner.all() or not inner.any():  # one lobe's spline: the other's is not evaluated
            return np.asarray(self._splines[0 if inner.all() else 1](r, nu), dtype=float)
        out = np.empty(r.shape)
        out[inner] = self._splines[0](r[inner], nu)
        out[~inner] = self._splines[1](r[~inner], nu)
        return out


def sample_lobes(profile: Profile, n: int = 4001) -> tuple[LobeSamples, LobeSamples]:
    """n samples of each lobe of a profile, uniform in r (for SampledProfile, plots)."""
    out = []
    for k in (0, 1):
        lo, hi = profile.lobe_range(k)
        r = np.linspace(lo, hi, n)
        if k == 1:
            r[0] = np.nextafter(lo, hi)  # the junction itself belongs to the inner lobe
        out.append(LobeSamples(r, profile.z(r)))
    return out[0], out[1]


class PathProfile(Profile):
    """A chain of programmed lines and arcs per lobe, as a surface (camera frame, mm).

    The moves are given in the MACHINE frame (r, Z) (what the G-code holds); z = vertex_z
    - Z. Each lobe's moves must advance in r (a lathe contour of a convex lobe does). Arcs
    may be spirals: LinuxCNC cuts an arc whose end radius differs from its start radius
    with the radius linear in the swept angle, and so does this class, so the profile is
    what the controller cuts. Exact (no sampling): z and slope in closed form per move,
    the arc's angle found by Newton's method.

    inner, outer: sequences of moves with attributes kind ("line" | "arc"), start, end
    (r, Z) and, for arcs, centre (r, Z), radius (start radius), end_radius.
    """

    def __init__(self, inner, outer, *, r_junction: float, r_max: float, vertex_z: float):
        super().__init__(r_junction=r_junction, r_max=r_max, vertex_z=vertex_z)
        self._lobes = tuple(_MoveTable(moves) for moves in (inner, outer))

    def vertices(self, k: int) -> tuple[np.ndarray, np.ndarray] | None:
        """(r, z) move ends of lobe k (mm, camera frame) if its moves are G1 lines end to
        end (the surface is then that polyline), else None."""
        t = self._lobes[k]
        if t.is_arc.any() or np.any(t.r1[:-1] != t.r0[1:]) or np.any(t.z1[:-1] != t.z0[1:]):
            return None
        return (np.concatenate([t.r0, t.r1[-1:]]),
                self.from_machine_z(np.concatenate([t.z0, t.z1[-1:]])))

    def breakpoints(self, k: int) -> np.ndarray:
        """Radii (mm) where lobe k's moves join (where the slope jumps)."""
        t = self._lobes[k]
        return np.concatenate([t.r0, t.r1[-1:]])

    def z(self, r: np.ndarray) -> np.ndarray:
        return self._eval(r, derivative=False)

    def slope(self, r: np.ndarray) -> np.ndarray:
        return self._eval(r, derivative=True)

    def _eval(self, r: np.ndarray, derivative: bool) -> np.ndarray:
        r = np.asarray(r, dtype=float)
        flat = r.reshape(-1)
        out = np.empty_like(flat)
        k = self.lobe_index(flat)
        for i, table in enumerate(self._lobes):
            m = k == i
            if np.any(m):
                zm, dzm = table.eval(flat[m])
                # camera frame: z = vertex_z - Z, so dz/dr = -dZ/dr
                out[m] = -dzm if derivative else self.vertex_z - zm
        return out.reshape(r.shape)


class _MoveTable:
    """Lines and arcs of one lobe as arrays, for vectorised evaluation (machine frame)."""

    def __init__(self, moves) -> None:
        moves = list(moves)
        if not moves:
            raise ValueError("PathProfile: a lobe needs at least one move")
        self.r0 = np.array([m.start[0] for m in moves], dtype=float)
        self.r1 = np.array([m.end[0] for m in moves], dtype=float)
        if np.any(self.r1 <= self.r0):
            raise ValueError("PathProfile: every move of a lobe must advance in r")
        self.z0 = np.array([m.start[1] for m in moves], dtype=float)
        self.z1 = np.array([m.end[1] for m in moves], dtype=float)
        self.is_arc = np.array([isinstance(m, Arc) for m in moves])
        nan = float("nan")
        self.cr = np.array([m.centre[0] if isinstance(m, Arc) else nan for m in moves])
        self.cz = np.array([m.centre[1] if isinstance(m, Arc) else nan for m in moves])
        self.rad0 = np.array([m.radius if isinstance(m, Arc) else nan for m in moves])
        self.rad1 = np.array([m.end_radius if isinstance(m, Arc) else nan for m in moves])
        self.phi0 = np.arctan2(self.z0 - self.cz, self.r0 - self.cr)
        self.phi1 = np.arctan2(self.z1 - self.cz, self.r1 - self.cr)

    def eval(self, r: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Machine Z and dZ/dr at radii r (beyond the ends, the end moves extended)."""
        j = np.clip(np.searchsorted(self.r0, r, side="right") - 1, 0, self.r0.size - 1)
        zm = np.empty_like(r)
        dz = np.empty_like(r)
        arc = self.is_arc[j]
        lj = j[~arc]
        if lj.size:
            s = (self.z1[lj] - self.z0[lj]) / (self.r1[lj] - self.r0[lj])
            zm[~arc] = self.z0[lj] + s * (r[~arc] - self.r0[lj])
            dz[~arc] = s
        aj = j[arc]
        if aj.size:
            zm[arc], dz[arc] = spiral_at_r(
                r[arc], self.cr[aj], self.cz[aj], self.rad0[aj], self.rad1[aj],
                self.phi0[aj], self.phi1[aj],
            )
        return zm, dz


def spiral_at_r(r, cr, cz, rad0, rad1, phi0, phi1):
    """Z and dZ/dr of the arc point at radius r: R(phi) = rad0 + (rad1 - rad0) t, t the
    fraction of the sweep (LinuxCNC's spiral); the point lies in the upper half (0 < phi <
    pi) about its centre, as a lathe contour's arcs about centres below the surface do."""
    sweep = phi1 - phi0
    dR = np.where(np.abs(sweep) > 0, (rad1 - rad0) / np.where(sweep == 0, 1.0, sweep), 0.0)
    phi = np.arccos(np.clip((r - cr) / rad0, -1.0, 1.0))
    for _ in range(4):  # Newton on f(phi) = cr + R(phi) cos(phi) - r
        R = rad0 + dR * (phi - phi0)
        cos, sin = np.cos(phi), np.sin(phi)
        f = cr + R * cos - r
        df = dR * cos - R * sin
        phi = phi - f / df
    R = rad0 + dR * (phi - phi0)
    cos, sin = np.cos(phi), np.sin(phi)
    zm = cz + R * sin
    dzdphi = dR * sin + R * cos
    drdphi = dR * cos - R * sin
    return zm, dzdphi / drdphi


class TabulatedProfile(Profile):
    """A profile known by dense samples of z AND slope per lobe (camera frame, mm).

    Both are interpolated linearly between samples. For envelopes whose slope is known
    exactly at each sample (the tool-nose envelope): unlike SampledProfile's spline it
    never invents curvature at a kink, and the slope is the geometric one, not a
    difference quotient of z.
    """

    def __init__(self, inner: tuple[np.ndarray, np.ndarray, np.ndarray],
                 outer: tuple[np.ndarray, np.ndarray, np.ndarray], *, r_junction: float,
                 r_max: float, vertex_z: float):
        for r, z, s in (inner, outer):
            if r.ndim != 1 or r.shape != z.shape or r.shape != s.shape or r.size < 2:
                raise ValueError("TabulatedProfile: r, z, slope must be 1-D of equal length >= 2")
            if np.any(np.diff(r) < 0):
                raise ValueError("TabulatedProfile: r must be non-decreasing")
        self.lobes = (inner, outer)
        super().__init__(r_junction=r_junction, r_max=r_max, vertex_z=vertex_z)

    def z(self, r: np.ndarray) -> np.ndarray:
        return self._eval(r, 1)

    def slope(self, r: np.ndarray) -> np.ndarray:
        return self._eval(r, 2)

    def _eval(self, r: np.ndarray, col: int) -> np.ndarray:
        r = np.asarray(r, dtype=float)
        k = self.lobe_index(r)
        a = np.interp(r, self.lobes[0][0], self.lobes[0][col])
        b = np.interp(r, self.lobes[1][0], self.lobes[1][col])
        return np.where(k == 0, a, b)
