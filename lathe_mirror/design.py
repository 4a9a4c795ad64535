"""Design of the double-lobed hyperbolic mirror from the camera's constants.

Frames and units (ARCHITECTURE.md): millimetres and radians; camera frame with the
pinhole at the origin and +z up the optical axis toward the mirror. Each lobe is the
upper sheet of (z - e)^2 / a^2 - r^2 / b^2 = 1, so the camera sits at the lobe's outer
focus (z = 0) and the lobe's single viewpoint is its inner focus F1 at z = 2e (Table 1's
"c"). The equations are the paper's (de Souza & Motta), section 2.2:

    Eq. 3   e = sqrt(a^2 + b^2)
    Eq. 6   h = f * R_top / (T_pixel * R_pixel)
    Table 1 alpha = atan((h - 2e) / R_top)   (the rim's angle above F1's horizon)

Each lobe takes R_top and R_pixel (which fix h through Eq. 6) plus exactly one of alpha,
a/b or e; the rest follows in closed form.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from .declared import SLACK, check as check_declared
from .declared.section import build, defaults, setting
from .errors import ConfigError, DesignError, InputError
from .hyperbola import ray_meets_sheet, sheet_point_seen_from_focus, single_viewpoint_error
from .inputs import check_type, short

@dataclass(frozen=True)
class Camera:
    """Pinhole camera looking up the mirror axis.

    f: focal length, mm. t_pixel: pixel pitch, mm. sensor_px: (width, height), pixels;
    the principal point is the sensor centre. f_number: the lens's aperture, f / diameter
    (the design does not use it; the optimiser's thin-lens focus model does).
    """

    f: float = setting("camera.f")
    t_pixel: float = setting("camera.t_pixel")
    sensor_px: tuple[int, int] = setting("camera.sensor_px")
    f_number: float = setting("camera.f_number")

    def __post_init__(self) -> None:
        # The [camera] declarations (lathe_mirror.declared): the line `load()` gives for the
        # file's key, raised as a design error (a camera that cannot be designed for).
        for name, value in (("camera.f", self.f), ("camera.t_pixel", self.t_pixel),
                            ("camera.f_number", self.f_number)):
            _finite(name, value)
            _declared(name, value)
        if len(self.sensor_px) != 2 or any(int(n) != n for n in self.sensor_px):
            raise DesignError(
                f"camera.sensor_px = {list(self.sensor_px)} must be two positive integers "
                "[width, height] in pixels"
            )
        _declared("camera.sensor_px", [int(n) for n in self.sensor_px])

    @property
    def r_pixel_max(self) -> float:
        """Radius of the largest circle inscribed in the sensor, px (504 for 1008 x 1018)."""
        return min(self.sensor_px) / 2.0

    def image_radius_px(self, tan_theta: np.ndarray | float) -> np.ndarray | float:
        """Image radius (px) of a ray at angle theta off the axis, from tan(theta)."""
        return self.f * np.asarray(tan_theta) / self.t_pixel

    def tan_theta(self, radius_px: np.ndarray | float) -> np.ndarray | float:
        """tan of the off-axis angle (rad) of the ray through image radius radius_px."""
        return np.asarray(radius_px) * self.t_pixel / self.f


@dataclass(frozen=True)
class Lobe:
    """One hyperbolic lobe: upper sheet of (z - e)^2 / a^2 - r^2 / b^2 = 1. Lengths in mm.

    name: "inner" or "outer". r_top: rim radius. r_pixel: image radius of the rim, px.
    h: rim height above the camera (Eq. 6). a, b: semi-axes. e: centre height (Eq. 3),
    so the viewpoint F1 is at z = 2e and the camera at z = 0.
    """

    name: str
    r_top: float
    r_pixel: float
    h: float
    a: float
    b: float
    e: float

    def __post_init__(self) -> None:
        _lobe_name("Lobe", self.name)
        key = f"Lobe {self.name}"
        for k, unit in (("r_top", "mm"), ("r_pixel", "px"), ("h", "mm"), ("a", "mm"), ("b", "mm"), ("e", "mm")):
            _positive(f"{key}: {k}", getattr(self, k), unit)
        if not math.isclose(self.e, math.hypot(self.a, self.b), rel_tol=1e-9):
            raise DesignError(f"{key}: e = {self.e:g} mm must be sqrt(a^2 + b^2) = "
                              f"{math.hypot(self.a, self.b):g} mm (Eq. 3)")

    @property
    def c(self) -> float:
        """Table 1's c: the height of the viewpoint F1, 2e (mm)."""
        return 2.0 * self.e

    @property
    def focus_z(self) -> float:
        """Height of the lobe's viewpoint F1 (mm)."""
        return 2.0 * self.e

    @property
    def alpha(self) -> float:
        """Angle of the rim above F1's horizon (rad), as Table 1 prints it."""
        return math.atan((self.h - 2.0 * self.e) / self.r_top)

    @property
    def a_over_b(self) -> float:
        return self.a / self.b

    @property
    def vertex_z(self) -> float:
        """Height of the sheet's vertex (r = 0), e + a (mm)."""
        return self.e + self.a

    @property
    def vertex_radius(self) -> float:
        """The ISO 10110-12 vertex radius of curvature R = b^2 / a (mm): from the vertex the
        sheet's sag a (sqrt(1 + r^2 / b^2) - 1) is the conic of R and conic_constant."""
        return self.b**2 / self.a

    @property
    def conic_constant(self) -> float:
        """The ISO 10110-12 conic constant k = -(1 + b^2 / a^2) (< -1: a hyperbola)."""
        return -(1.0 + (self.b / self.a) ** 2)

    def z(self, r: np.ndarray | float) -> np.ndarray:
        """Height of the sheet at radius r (mm): e + a sqrt(1 + r^2 / b^2)."""
        r = np.asarray(r, dtype=float)
        return self.e + self.a * np.sqrt(1.0 + (r / self.b) ** 2)

    def slope(self, r: np.ndarray | float) -> np.ndarray:
        """dz/dr of the sheet at radius r (dimensionless)."""
        r = np.asarray(r, dtype=float)
        return self.a * r / (self.b**2 * np.sqrt(1.0 + (r / self.b) ** 2))

    def second_derivative(self, r: np.ndarray | float) -> np.ndarray:
        """d2z/dr2 of the sheet at radius r (1/mm): a / (b^2 (1 + r^2 / b^2)^(3/2))."""
        r = np.asarray(r, dtype=float)
        return self.a / (self.b**2 * (1.0 + (r / self.b) ** 2) ** 1.5)

    def elevation(self, r: np.ndarray | float) -> np.ndarray:
        """Elevation (rad) above F1's horizon of the world direction seen at radius r."""
        r = np.asarray(r, dtype=float)
        return np.arctan2(self.z(r) - self.focus_z, r)


@dataclass(frozen=True)
class Mirror:
    """Two lobes sharing the camera as their outer focus.

    The inner lobe covers 0 <= r <= inner.r_top, the outer lobe inner.r_top < r <=
    outer.r_top; at r = inner.r_top the surface steps between the two sheets.
    """

    camera: Camera
    inner: Lobe
    outer: Lobe

    @property
    def lobes(self) -> tuple[Lobe, Lobe]:
        return (self.inner, self.outer)

    @property
    def design(self) -> Mirror:
        """The designed mirror this surface realises: itself (cut_surface's protocol)."""
        return self

    @property
    def r_junction(self) -> float:
        """Radius of the step between the lobes (mm)."""
        return self.inner.r_top

    @property
    def r_max(self) -> float:
        """Outer rim radius (mm)."""
        return self.outer.r_top

    @property
    def vertex_z(self) -> float:
        """Height of the mirror's vertex (the inner lobe's), mm; machine Z = 0 there."""
        return self.inner.vertex_z

    @property
    def far_z(self) -> float:
        """Height (mm) of the mirror's farthest point from the pinhole: the higher of the
        inner lobe's rim (at the junction) and the outer rim."""
        return max(self.junction_z[0], float(self.outer.z(self.r_max)))

    @property
    def depth(self) -> float:
        """The mirror's depth (mm), the one definition (`design`, `optimize`, the bar and the
        body): from the vertex to the farthest point, far_z - vertex_z."""
        return self.far_z - self.vertex_z

    @cached_property  # asked for by most other figures (the design optimiser: per design)
    def junction_z(self) -> tuple[float, float]:
        """Heights (mm) of the inner and outer sheets at the junction radius."""
        r = self.r_junction
        return float(self.inner.z(r)), float(self.outer.z(r))

    @property
    def step(self) -> float:
        """Height of the step at the junction, inner minus outer sheet (mm), signed.

        Positive: the inner lobe's rim lies farther from the camera, i.e. the inner lobe is
        recessed into the part and the outer lobe stands proud toward the camera. The
        figures (design_figures' junction, the part spec) give the step's height, |step|, as
        `step_mm` beside `recessed`, the lobe it lowers: a drawing dimensions a height.
        """
        zi, zo = self.junction_z
        return zi - zo

    @property
    def recessed(self) -> str:
        """Which lobe is recessed (farther from the camera) at the junction."""
        return "inner" if self.step > 0 else "outer"

    @property
    def baseline(self) -> float:
        """Stereo baseline: distance between the two viewpoints F1 (mm)."""
        return abs(self.outer.focus_z - self.inner.focus_z)

    @cached_property
    def r_outer_visible(self) -> float:
        """Smallest radius of the outer lobe the camera sees (mm).

        With the inner lobe recessed, the camera sees the outer lobe right from the
        junction. With the outer lobe recessed, the inner rim hides a band of it: the
        first outer point seen is where the ray grazing the inner rim meets it.
        """
        r1 = self.r_junction
        zi, zo = self.junction_z
        if zo <= zi:
            return r1
        t = r1 / zi  # tan of the ray grazing the inner rim
        return ray_meets_sheet(self.outer, t)

    def fov(self, lobe: Lobe) -> tuple[float, float]:
        """Elevation range (rad) of world directions the lobe reflects: (lowest, highest).

        The geometric range of the mirror surface the camera sees; see fov_usable for
        the part the step wall does not block.
        """
        if lobe is self.inner:
            return (-math.pi / 2.0, lobe.alpha)
        return (float(lobe.elevation(self.r_outer_visible)), lobe.alpha)

    def fov_usable(self, lobe: Lobe) -> tuple[float, float]:
        """Elevation range (rad) of world directions that reach the lobe unblocked.

        With the inner lobe recessed, a world ray bound for the inner F1 above the
        elevation atan((z_outer(R_junction) - 2e_inner) / R_junction) meets the step wall
        before the inner lobe: the top of the inner lobe's field is lost to the step.
        """
        lo, hi = self.fov(lobe)
        if lobe is self.inner and self.step > 0:
            zo = self.junction_z[1]
            hi = min(hi, math.atan2(zo - lobe.focus_z, self.r_junction))
        return (lo, hi)

    @property
    def common_band(self) -> tuple[float, float]:
        """Elevations (rad) both lobes see unblocked: the stereo band (lowest, highest)."""
        lo = max(self.fov_usable(self.inner)[0], self.fov_usable(self.outer)[0])
        hi = min(self.fov_usable(self.inner)[1], self.fov_usable(self.outer)[1])
        return (lo, hi)

    @property
    def image_radii_px(self) -> dict[str, tuple[float, float]]:
        """Image radii (px): the inner disc, the ring lost at the junction, the outer annulus."""
        cam = self.camera
        r1 = self.r_junction
        zi, zo = self.junction_z
        inner_edge = float(cam.image_radius_px(r1 / zi))
        outer_start = float(cam.image_radius_px(self.r_outer_visible / self.outer.z(self.r_outer_visible)))
        # Rays between the inner rim and the outer sheet's edge hit the step wall (lost).
        lost = (inner_edge, outer_start) if outer_start > inner_edge else (inner_edge, inner_edge)
        # Inner pixels whose world ray the step wall blocks (fov_usable's top).
        blocked_from = inner_edge
        if self.step > 0:
            p = sheet_point_seen_from_focus(self.inner, self.fov_usable(self.inner)[1])
            blocked_from = float(cam.image_radius_px(p[0] / p[1]))
        return {
            "inner_disc": (0.0, inner_edge),
            "inner_blocked_by_step": (min(blocked_from, inner_edge), inner_edge),
            "lost_ring": lost,
            "outer_annulus": (max(inner_edge, outer_start), float(self.outer.r_pixel)),
        }

    def lobe_index(self, r: np.ndarray) -> np.ndarray:
        """0 where r belongs to the inner lobe (r <= r_junction), 1 for the outer lobe."""
        return (np.asarray(r) > self.r_junction).astype(np.intp)


# --------------------------------------------------------------------------------------
# Lobe and mirror design


def design_lobe(
    name: str,
    camera: Camera,
    r_top: float,
    r_pixel: float,
    *,
    alpha_deg: float | None = None,
    a_over_b: float | None = None,
    e: float | None = None,
) -> Lobe:
    """Design one lobe from R_top (mm), R_pixel (px) and exactly one of alpha, a/b or e.

    h follows from Eq. 6. Then, with the rim P = (R_top, h) on the upper sheet whose foci
    are the camera (0, 0) and F1 (0, 2e), |P| - |P - F1| = 2a:
      - alpha given: 2e = h - R_top tan(alpha) (Table 1's definition of alpha);
      - e given: as it is;
      - a/b = k given: with s = sqrt(1 + k^2), b = s h - k sqrt(h^2 + R_top^2) (the
        quadratic of the sheet through P, upper root), a = k b.
    """
    key = f"lobes.{name}"
    _positive(f"{key}.r_top", r_top, "mm")
    _positive(f"{key}.r_pixel", r_pixel, "px")
    given = {k: v for k, v in (("alpha_deg", alpha_deg), ("a_over_b", a_over_b), ("e", e)) if v is not None}
    if len(given) != 1:
        got = " and ".join(given) if given else "none"
        raise DesignError(f"{key}: give exactly one of alpha_deg, a_over_b, e (got {got})")
    for k, v in given.items():
        _finite(f"{key}.{k}", v)

    h = camera.f * r_top / (camera.t_pixel * r_pixel)  # Eq. 6
    rho = math.hypot(r_top, h)  # rim's distance from the camera focus

    if alpha_deg is not None:
        limit = math.degrees(math.atan(h / r_top))
        if not -limit < alpha_deg < limit:
            raise DesignError(
                f"{key}.alpha_deg = {alpha_deg:g} deg: no hyperbola through the rim "
                f"(R_top = {r_top:g} mm, h = {h:.4f} mm) meets it; allowed "
                f"-{limit:.4f} < alpha_deg < {limit:.4f}"
            )
        e = (h - r_top * math.tan(math.radians(alpha_deg))) / 2.0
        a = (rho - math.hypot(r_top, h - 2.0 * e)) / 2.0
        b = math.sqrt((e - a) * (e + a))
    elif e is not None:
        if not 0.0 < e < h:
            raise DesignError(
                f"{key}.e = {e:g} mm: the rim (R_top = {r_top:g} mm, h = {h:.4f} mm) lies on "
                f"an upper sheet only for 0 < e < h = {h:.4f} mm"
            )
        a = (rho - math.hypot(r_top, h - 2.0 * e)) / 2.0
        b = math.sqrt((e - a) * (e + a))
    else:
        k = float(a_over_b)
        if not 0.0 < k < h / r_top:
            raise DesignError(
                f"{key}.a_over_b = {k:g}: a sheet with the camera at its focus reaches the rim "
                f"(R_top = {r_top:g} mm, h = {h:.4f} mm) only for 0 < a_over_b < h / R_top = "
                f"{h / r_top:.4f}"
            )
        s = math.sqrt(1.0 + k * k)
        b = s * h - k * rho
        a = k * b
        e = math.hypot(a, b)  # Eq. 3

    lobe = Lobe(name=name, r_top=float(r_top), r_pixel=float(r_pixel), h=h, a=a, b=b, e=e)
    _check_rim(lobe)
    return lobe


def design_mirror(camera: Camera, inner: Lobe, outer: Lobe) -> Mirror:
    """Assemble two lobes into a mirror, checking they can share the camera."""
    check_type(camera, "design_mirror: camera", Camera, "a Camera")
    check_type(inner, "design_mirror: inner", Lobe, "a Lobe (design_lobe)")
    check_type(outer, "design_mirror: outer", Lobe, "a Lobe (design_lobe)")
    if outer.r_top <= inner.r_top:
        raise DesignError(
            f"lobes.outer.r_top = {outer.r_top:g} mm must exceed lobes.inner.r_top = "
            f"{inner.r_top:g} mm"
        )
    for lobe in (inner, outer):
        if lobe.r_pixel > camera.r_pixel_max + 1e-9:
            raise DesignError(
                f"lobes.{lobe.name}.r_pixel = {lobe.r_pixel:g} px lies outside the sensor: "
                f"allowed up to {camera.r_pixel_max:g} px (the inscribed circle of "
                f"{camera.sensor_px[0]} x {camera.sensor_px[1]} px)"
            )
    if inner.r_pixel >= outer.r_pixel:
        raise DesignError(
            f"lobes.inner.r_pixel = {inner.r_pixel:g} px must be smaller than "
            f"lobes.outer.r_pixel = {outer.r_pixel:g} px: the outer lobe images outside the inner one"
        )
    mirror = Mirror(camera=camera, inner=inner, outer=outer)
    if mirror.r_outer_visible >= outer.r_top:
        raise DesignError(
            "lobes: the inner lobe's rim hides the whole outer lobe from the camera; "
            "lower lobes.outer's alpha_deg or raise its r_pixel"
        )
    return mirror


@dataclass(frozen=True)
class LobeSpec:
    """What the user gives for one lobe: r_top (mm) and r_pixel (px), plus exactly one of
    alpha_deg (Table 1's rim angle above F1's horizon, deg), a_over_b, or e (mm)."""

    name: str
    r_top: float = setting("lobes.*.r_top", required=True)
    r_pixel: float = setting("lobes.*.r_pixel", required=True)
    alpha_deg: float | None = setting("lobes.*.alpha_deg", default=None)
    a_over_b: float | None = setting("lobes.*.a_over_b", default=None)
    e: float | None = setting("lobes.*.e", default=None)

    @classmethod
    def declared(cls, name: str) -> LobeSpec:
        """The lobe `name` ("inner", "outer") with its declared defaults (the paper's)."""
        return build(cls, defaults(), star=name, name=name)

    def __post_init__(self) -> None:
        # the checks design_lobe makes of the numbers, at construction: a spec that
        # cannot be designed is refused where it is written, with load()'s key names
        _lobe_name("LobeSpec", self.name)
        key = f"lobes.{self.name}"
        _positive(f"{key}.r_top", self.r_top, "mm")
        _positive(f"{key}.r_pixel", self.r_pixel, "px")
        for k in ("alpha_deg", "a_over_b", "e"):
            if getattr(self, k) is not None:
                _finite(f"{key}.{k}", getattr(self, k))


def conic_sag(r: np.ndarray | float, R: float, k: float) -> np.ndarray:
    """ISO 10110-12 sag (mm) at radius r (mm) of the conic of vertex radius R (mm) and
    conic constant k: c r^2 / (1 + sqrt(1 - (1 + k) c^2 r^2)), c = 1 / R (the root's
    argument held at 0 beyond the conic's reach, where a fit's trial R, k may wander)."""
    r = np.asarray(r, dtype=float)
    c = 1.0 / R
    return c * r * r / (1.0 + np.sqrt(np.maximum(1.0 - (1.0 + k) * c * c * r * r, 0.0)))


def mirror_from_specs(camera: Camera, lobes: tuple[LobeSpec, LobeSpec]) -> Mirror:
    """The two-lobe mirror of `camera` from the lobes' specs, inner first (Eqs. 3-6).

    Checks the design's equations (a spec no hyperbola meets, lobes that cannot share the
    camera: DesignError). The checks load() adds (the lathe, the room, the costs) are
    settings.checked_mirror's."""
    check_type(camera, "mirror_from_specs: camera", Camera, "a Camera")
    if (not isinstance(lobes, (tuple, list)) or len(lobes) != 2
            or not all(isinstance(s, LobeSpec) for s in lobes)):
        raise InputError(f"mirror_from_specs: lobes = {short(lobes)}: expected two LobeSpecs, inner then outer")
    if [s.name for s in lobes] != ["inner", "outer"]:
        raise InputError(f"mirror_from_specs: lobes named {[s.name for s in lobes]}: expected inner then outer")
    return design_mirror(camera, *(
        design_lobe(s.name, camera, s.r_top, s.r_pixel, alpha_deg=s.alpha_deg, a_over_b=s.a_over_b, e=s.e)
        for s in lobes))


# --------------------------------------------------------------------------------------
# Checks and helpers


def _check_rim(lobe: Lobe) -> None:
    """The rim (R_top, h) must lie on the designed sheet."""
    z_rim = float(lobe.z(lobe.r_top))
    if not (np.isfinite(lobe.b) and lobe.b > 0 and abs(z_rim - lobe.h) <= 1e-9 * max(1.0, lobe.h)):
        raise DesignError(
            f"lobes.{lobe.name}: no hyperbolic sheet passes through the rim "
            f"(R_top = {lobe.r_top:g} mm, h = {lobe.h:.6f} mm) with these constants"
        )


def _positive(key: str, value: float, unit: str) -> None:
    _finite(key, value)
    if value <= 0:
        raise DesignError(f"{key} = {value:g} {unit} must be > 0")


def _lobe_name(what: str, name: object) -> None:
    if name not in ("inner", "outer"):
        raise InputError(f"{what}: name = {short(name)}: allowed 'inner', 'outer'")


def _declared(key: str, value) -> None:
    """DesignError with the line the configuration file's key gets (declared.check)."""
    try:
        check_declared(key, value, slack=SLACK)
    except ConfigError as exc:
        raise DesignError(str(exc)) from None


def _finite(key: str, value: float) -> None:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise DesignError(f"{key} = {value!r} must be a finite number")
