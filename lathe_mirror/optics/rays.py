"""What both tracers share: ray fates, the hits of rays in 3-D, a point's azimuth, and a
profile's piecewise-linear vertices. Camera frame (pinhole at the origin, +z up the
axis), mm."""

from __future__ import annotations

from dataclasses import dataclass
from enum import IntEnum

import numpy as np

from ..profile import PathProfile, PolylineProfile, Profile, TabulatedProfile

#: Newton / bisection stop: change of r (meridian) or ray length s (3-D) below this, mm.
ROOT_TOL_MM = 1e-12


class Fate(IntEnum):
    """Where a camera ray ends on the mirror."""

    INNER = 0  # reflected by the inner lobe
    OUTER = 1  # reflected by the outer lobe
    WALL = 2   # hits the step wall between the lobes (lost ring)
    MISS = 3   # passes the outer rim: sees the mirror's mount, not the mirror


@dataclass(frozen=True)
class RayHits:
    """Rays meeting the mirror in 3-D, mirror frame, mm.

    fate: Fate codes (...). point: hit point (..., 3). direction: unit reflected direction
    (..., 3). Both NaN unless the ray met a lobe. blocked: the reflected ray runs into the
    mirror itself (a lobe hit the camera sees but whose view is vignetted).
    """

    fate: np.ndarray
    point: np.ndarray
    direction: np.ndarray
    blocked: np.ndarray

    @property
    def lobe(self) -> np.ndarray:
        """Lobe index per ray: 0 inner, 1 outer, -1 for the wall or a miss."""
        return np.where(self.fate <= Fate.OUTER, self.fate, -1).astype(np.int8)


def azimuth(x: np.ndarray, y: np.ndarray, r: np.ndarray, *,
            on_axis: tuple[float, float] = (1.0, 0.0)) -> tuple[np.ndarray, np.ndarray]:
    """(cos, sin) of the azimuth of points (x, y) at radius r = hypot(x, y); `on_axis`
    where r = 0 (any meridian will do there)."""
    safe = np.where(r > 0, r, 1.0)
    return np.where(r > 0, x / safe, on_axis[0]), np.where(r > 0, y / safe, on_axis[1])


def polyline_vertices(profile: Profile, k: int) -> tuple[np.ndarray, np.ndarray] | None:
    """(r, z) vertices (mm, camera frame) of lobe k if its z is piecewise linear, else None.

    PolylineProfile: its samples. TabulatedProfile: its samples (z interpolated linearly).
    PathProfile of G1 lines only, end to end: its move ends. Beyond the end vertices the
    end segments extend, as these profiles evaluate there.
    """
    if isinstance(profile, PolylineProfile):
        s = profile.lobes[k]
        return s.r, s.z
    if isinstance(profile, TabulatedProfile):
        r, z, _ = profile.lobes[k]
        return r, z
    if isinstance(profile, PathProfile):
        return profile.vertices(k)
    return None
