"""The design's own checks: a lobe that is a hyperbola, not a degenerate conic; lobes
that share a stereo band; assembly tolerances under which each lobe still sees its pixels.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from typing import TYPE_CHECKING

import numpy as np

from ..design import Camera, Lobe, LobeSpec, Mirror, design_lobe, design_mirror
from ..errors import DesignError, InputError, num
from ..optics.camera import CameraPose
from ..optics.trace import trace_pixels
from ..profile import ExactProfile
from .keys import H_RANGE, MAX_VERTEX_RADIUS, MIN_VERTEX_RADIUS

if TYPE_CHECKING:
    from .sections import Sections as Settings


def check_design(settings: Settings) -> Mirror:
    """The designed mirror (Settings.mirror()), each lobe checked first: its rim height h
    (Eq. 6) within H_RANGE, and its given parameter (alpha_deg, a_over_b or e) where the
    lobe is a proper hyperbola: a DesignError names the parameter's allowed range. A
    mirror whose lobes share no stereo band (Mirror.common_band empty) is refused too."""
    return checked_mirror(settings.camera, settings.lobes)


def checked_mirror(camera: Camera, lobes: tuple[LobeSpec, LobeSpec]) -> Mirror:
    """The mirror of `camera` from the lobes' specs (design.mirror_from_specs) with every
    check a configuration's design gets (check_design): the same DesignError and message
    as `load()` for a lobe or a pair of lobes that cannot exist."""
    mirror = design_mirror(camera, *(_checked_lobe(camera, spec) for spec in lobes))
    lo, hi = mirror.common_band
    if not lo < hi:  # a stereo camera whose lobes see no elevation in common
        (_, top), (bottom, _) = mirror.fov_usable(mirror.inner), mirror.fov_usable(mirror.outer)
        raise DesignError(
            f"lobes: no common stereo band: the inner lobe sees up to {math.degrees(top):.3f} deg elevation "
            f"(lobes.inner.alpha_deg, less the step wall), the outer lobe from {math.degrees(bottom):.3f} deg "
            f"(up to lobes.outer.alpha_deg): raise lobes.inner.alpha_deg")
    return mirror


def _checked_lobe(camera: Camera, spec: LobeSpec) -> Lobe:
    key = f"lobes.{spec.name}"
    given = [(k, v) for k, v in (("alpha_deg", spec.alpha_deg), ("a_over_b", spec.a_over_b), ("e", spec.e))
             if v is not None]
    if len(given) != 1 or not (spec.r_top > 0 and spec.r_pixel > 0):
        return _design(camera, spec)  # its own message (exactly one of ...; r_top > 0)
    h = camera.f * spec.r_top / (camera.t_pixel * spec.r_pixel)  # Eq. 6
    if not H_RANGE[0] <= h <= H_RANGE[1]:
        raise DesignError(
            f"{key}: the rim height h = f R_top / (T_pixel R_pixel) = {num(h)} mm (Eq. 6, from camera.f, "
            f"{key}.r_top, camera.t_pixel, {key}.r_pixel): allowed {num(H_RANGE[0])} to {num(H_RANGE[1])} mm")
    param, value = given[0]
    lo, hi = _parameter_bounds(param, h, spec.r_top)
    if not lo < value < hi:
        return _design(camera, spec)  # outside the conic's own range: design_lobe says so
    lobe = _proper(camera, spec, param, value)
    if lobe is not None:
        return lobe
    good_lo, good_hi = _proper_interval(camera, spec, param, lo, hi)
    unit = {"alpha_deg": " deg", "a_over_b": "", "e": " mm"}[param]
    raise DesignError(
        f"{key}.{param} = {num(value)}{unit}: allowed {round_in(good_lo, up=True)} to "
        f"{round_in(good_hi, up=False)}{unit} for this rim (R_top = {num(spec.r_top)} mm, h = {num(h)} mm); "
        f"beyond that the lobe degenerates: its vertex radius of curvature b^2/a leaves "
        f"{num(MIN_VERTEX_RADIUS)} to {num(MAX_VERTEX_RADIUS)} mm (a cone's tip, a plane)")


def _design(camera: Camera, spec: LobeSpec) -> Lobe:
    return design_lobe(spec.name, camera, spec.r_top, spec.r_pixel,
                       alpha_deg=spec.alpha_deg, a_over_b=spec.a_over_b, e=spec.e)


def _parameter_bounds(param: str, h: float, r_top: float) -> tuple[float, float]:
    """The open interval of the parameter over which the conic through the rim exists."""
    if param == "alpha_deg":
        limit = math.degrees(math.atan(h / r_top))
        return -limit, limit
    if param == "a_over_b":
        return 0.0, h / r_top
    return 0.0, h


def _proper(camera: Camera, spec: LobeSpec, param: str, value: float) -> Lobe | None:
    """The lobe with `param` = value, or None if it is degenerate (see check_design)."""
    choice = {"alpha_deg": None, "a_over_b": None, "e": None, param: float(value)}
    trial = dataclasses.replace(spec, **choice)
    try:
        lobe = _design(camera, trial)
    except (DesignError, ValueError, ArithmeticError):
        return None
    ok = (lobe.a > 0 and lobe.b > 0 and math.isfinite(lobe.b)
          and MIN_VERTEX_RADIUS <= lobe.vertex_radius <= MAX_VERTEX_RADIUS)
    return lobe if ok else None


def _proper_interval(camera: Camera, spec: LobeSpec, param: str, lo: float, hi: float) -> tuple[float, float]:
    """Where the parameter gives a proper lobe: bisection from the middle of the conic's
    range (alpha = 0: F1 at half the rim height) toward each end (~120 closed-form designs)."""
    mid = {"alpha_deg": 0.0, "e": 0.5 * (lo + hi)}.get(param)
    if mid is None:  # a_over_b at alpha = 0
        half = _proper(camera, spec, "alpha_deg", 0.0)
        mid = half.a_over_b if half is not None else 0.5 * (lo + hi)
    if _proper(camera, spec, param, mid) is None:
        return lo, hi

    def edge(bad: float, good: float) -> float:
        for _ in range(64):
            m = 0.5 * (bad + good)
            if _proper(camera, spec, param, m) is None:
                bad = m
            else:
                good = m
        return good

    return edge(lo, mid), edge(hi, mid)


def round_in(x: float, *, up: bool) -> str:
    """x to 4 significant digits, rounded toward the inside of an allowed interval."""
    if x == 0 or not math.isfinite(x):
        return num(x)
    scale = 10 ** (math.floor(math.log10(abs(x))) - 3)
    q = (math.ceil if up else math.floor)(x / scale) * scale
    return num(float(f"{q:.4g}"))



def check_assembly_tolerances(mirror: Mirror, tolerances: dict[str, float]) -> None:
    """The camera's assembly tolerances (tolerance.params.camera_*) must leave each lobe
    at least MIN_SEEN of its pixels: beyond that the sample no longer sees the lobe and its
    figures (RMS over the pixels still seen) mean nothing. Traces ~400 pixels per lobe off
    the exact mirror with the camera at each tolerance alone, as the sensitivity table
    moves it; a refusal names the largest tolerance that passes."""
    for key in ("camera_tilt_deg", "camera_decentre_mm", "camera_axial_mm"):
        t = tolerances.get(key, 0.0)
        if t <= 0:
            continue
        seen = seen_fraction(mirror, key, t)
        if seen >= MIN_SEEN:
            continue
        lo, hi = 0.0, t
        for _ in range(14):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if seen_fraction(mirror, key, mid) >= MIN_SEEN else (lo, mid)
        unit = "deg" if key.endswith("deg") else "mm"
        raise InputError(
            f"tolerance.params.{key} = {num(t)} {unit}: a camera that far off sees only "
            f"{100.0 * seen:.0f} % of a lobe's pixels on that lobe (its figures would mean nothing); allowed "
            f"while each lobe keeps {100 * MIN_SEEN:.0f} %: up to about {round_in(lo, up=False)} {unit} here")


#: Share of each lobe's pixels a camera moved by an assembly tolerance must still see on
#: that lobe (check_assembly_tolerances).
MIN_SEEN = 0.5


@functools.lru_cache(maxsize=256)
def seen_fraction(mirror: Mirror, key: str, t: float) -> float:
    """Smallest share (both lobes, both signs of an axial offset) of the lobe's sample
    pixels that still see that lobe with the camera moved by t along `key` (remembered
    per design: every Settings built, replaced or loaded is validated)."""
    radii = mirror.image_radii_px
    if key == "camera_tilt_deg":
        poses = [CameraPose(tilt=(math.radians(t), 0.0))]
    elif key == "camera_decentre_mm":
        poses = [CameraPose(decentre=(t, 0.0))]
    else:
        poses = [CameraPose(axial_offset=t), CameraPose(axial_offset=-t)]
    profile = ExactProfile(mirror)
    psi = (np.arange(24) + 0.5) * (2.0 * math.pi / 24)
    worst = 1.0
    for k, (lo, hi) in enumerate((radii["inner_disc"], radii["outer_annulus"])):
        rho = lo + (hi - lo) * (np.arange(16) + 0.5) / 16
        r, a = np.meshgrid(rho, psi, indexing="ij")
        xy = np.stack([r * np.cos(a), r * np.sin(a)], axis=-1).reshape(-1, 2)
        for pose in poses:
            hits = trace_pixels(profile, mirror.camera, xy, pose=pose)
            worst = min(worst, float(np.mean(hits.fate == k)))
    return worst
