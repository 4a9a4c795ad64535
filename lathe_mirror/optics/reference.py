"""Reference surfaces that need no toolpath: the paper's fine and coarse polyline models.

  reference   the paper's high-resolution model: 4001 points per lobe, uniform in r,
              coordinates rounded to 1e-6 mm (section 6: "a resolution in the order of
              10^-6"), straight segments between them
  uniform528  a stand-in for the paper's coarse model that needs no toolpath: 528 points
              uniform in r, shared by the lobes in proportion to their arc length, r and z
              rounded to the lathe lattice (0.005 mm), straight segments

The made surfaces (programs, polished) are the machining job's (job.named_surface).
"""

from __future__ import annotations

import numpy as np

from ..design import Mirror
from ..profile import ExactProfile, LobeSamples, PolylineProfile, Profile


def reference_surface(name: str, mirror: Mirror) -> PolylineProfile:
    """The "reference" or "uniform528" polyline of the design (see the module doc)."""
    exact = ExactProfile(mirror)
    if name == "reference":
        return lattice_polyline(exact, (4001, 4001), resolution=1e-6)
    if name == "uniform528":
        return lattice_polyline(exact, _share(exact, 528), resolution=0.005)
    raise ValueError(f"reference_surface: unknown name {name!r}")


def lattice_polyline(profile: Profile, points: tuple[int, int], *, resolution: float) -> PolylineProfile:
    """Polyline through points uniform in r per lobe, r and z rounded to `resolution` mm.

    The paper's coarse model (section 6): its points carry the lathe's resolution.
    """
    lobes = []
    for k, n in enumerate(points):
        lo, hi = profile.lobe_range(k)
        r = np.unique(np.rint(np.linspace(lo, hi, n) / resolution)) * resolution
        r_eval = np.where(r <= lo, np.nextafter(lo, hi), r) if k == 1 else r  # outer side of the step
        z = np.rint(profile.z(r_eval) / resolution) * resolution
        lobes.append(LobeSamples(r, z))
    return PolylineProfile(*lobes, r_junction=profile.r_junction, r_max=profile.r_max,
                           vertex_z=profile.vertex_z)


def _share(profile: Profile, total: int) -> tuple[int, int]:
    """Split `total` points between the lobes in proportion to their meridian arc length."""
    lengths = []
    for k in (0, 1):
        lo, hi = profile.lobe_range(k)
        r = np.linspace(lo, hi, 20001)
        r[0] = np.nextafter(lo, hi) if k == 1 else lo
        lengths.append(float(np.sum(np.hypot(np.diff(r), np.diff(profile.z(r))))))
    n0 = int(round(total * lengths[0] / sum(lengths)))
    return n0, total - n0
