"""Profile-error figures of a made surface against the exact lobes (ARCHITECTURE.md names).

profile_errors gives each lobe's normal deviation (mm) and slope error (rad), RMS and max;
_signed_distance_camera is the camera-frame distance it measures (machining.gouge_depth
uses it too).
"""

from __future__ import annotations

import numpy as np

from ..design import Lobe, Mirror
from ..profile import ExactProfile, Profile
from .geometry import _signed_distance_m


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
    return _signed_distance_m(lobe, r, -np.asarray(z), 0.0)[0]
