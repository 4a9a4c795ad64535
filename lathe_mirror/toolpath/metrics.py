"""Profile-error figures of a made surface against the exact lobes (ARCHITECTURE.md names).

profile_errors gives each lobe's normal deviation (mm) and slope error (rad), RMS and max;
(the distance itself is sheet.signed_distance_camera, which nose_envelope.gouge_depth
uses too).
"""

from __future__ import annotations

import numpy as np

from ..design import Mirror
from ..hyperbola import sheet_point_seen_from_focus
from ..profile import ExactProfile, Profile
from ..sheet import signed_distance_camera


def slope_error(made_slope, exact_slope):
    """The slope error (rad, signed) at the same r: the angle between the made and the exact
    surface's normals, from their slopes dz/dr. The one definition every slope-error figure
    uses (profile_errors, optics.radial.surface_errors, the polishing curve's clear aperture,
    the tolerance trials)."""
    return np.arctan(made_slope) - np.arctan(exact_slope)


def profile_errors(profile: Profile, mirror: Mirror, *, n: int = 20001,
                   r_ranges: tuple[tuple[float, float], tuple[float, float]] | None = None) -> dict:
    """Normal deviation (mm) and slope error (rad) of a made profile, per lobe.

    normal_deviation_mm: distance from the made point (r, z(r)) to the exact lobe
    sheet (foot point by Newton's method). slope_error_rad: angle between made and exact
    normals at the same r. RMS over r uniform on the lobe; max also over the made
    profile's breakpoints (both sides), where a polyline's slope error peaks.
    r_ranges: radii (mm) per lobe to judge, inner first (e.g. usable_ranges(mirror));
    default the whole lobes. When given, each lobe's entry also carries "r_range_mm".
    """
    exact = ExactProfile(mirror)
    lobes = []
    for k, lobe in enumerate(mirror.lobes):
        lo, hi = profile.lobe_range(k)
        if r_ranges is not None:
            lo, hi = max(lo, r_ranges[k][0]), min(hi, r_ranges[k][1])
        r = np.linspace(lo, hi, n)
        if k == 1 and lo == mirror.r_junction:
            r[0] = np.nextafter(lo, hi)
        rr = r
        if hasattr(profile, "breakpoints"):
            bp = profile.breakpoints(k)
            bp = bp[(bp > lo) & (bp < hi)]
            eps = 1e-9
            rr = np.concatenate([r, bp - eps, bp + eps])
        z = profile.z(rr)
        s = profile.slope(rr)
        dist = np.abs(signed_distance_camera(lobe, rr, z))
        slope_err = np.abs(slope_error(s, exact.slope(rr)))
        m = r.size  # the uniform samples come first: RMS over them
        entry = {"name": lobe.name}
        if r_ranges is not None:
            entry["r_range_mm"] = {"min": float(lo), "max": float(hi)}
        entry["normal_deviation_mm"] = {"rms": float(np.sqrt(np.mean(dist[:m] ** 2))), "max": float(dist.max())}
        entry["slope_error_rad"] = {"rms": float(np.sqrt(np.mean(slope_err[:m] ** 2))),
                                    "max": float(slope_err.max())}
        lobes.append(entry)
    return {"lobes": lobes}


def usable_ranges(mirror: Mirror) -> tuple[tuple[float, float], tuple[float, float]]:
    """Radii (mm) of each lobe the camera uses, inner first.

    The inner lobe from the axis to the point seen from its F1 at the top of
    Mirror.fov_usable: beyond it the step wall blocks the world rays (the pixels of
    Mirror.image_radii_px["inner_blocked_by_step"]), so a junction fillet there costs
    no image. The outer lobe from Mirror.r_outer_visible to the rim.
    """
    r_inner = mirror.r_junction
    if mirror.step > 0:
        el = mirror.fov_usable(mirror.inner)[1]
        r_inner = min(r_inner, float(sheet_point_seen_from_focus(mirror.inner, el)[0]))
    return (0.0, r_inner), (float(mirror.r_outer_visible), float(mirror.r_max))
