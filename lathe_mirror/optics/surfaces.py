"""Named mirror surfaces for the tracer: the exact design, references and made surfaces.

  exact       the designed hyperbolic lobes (closed form)
  reference   the paper's high-resolution model: 4001 points per lobe, uniform in r,
              coordinates rounded to 1e-6 mm (section 6: "a resolution in the order of
              10^-6"), straight segments between them
  uniform528  a stand-in for the paper's coarse model that needs no toolpath: 528 points
              uniform in r, shared by the lobes in proportion to their arc length, r and z
              rounded to the lathe lattice (0.005 mm), straight segments
  paper, lattice, arcs, best (= toolpath.BEST)
              the programmed contour of that toolpath strategy (toolpath.py) for the
              configured [tool] (nose_envelope.contour_profile), or with nose_radius > 0 the
              as-machined surface of a tool of that nose radius along its own program
              (machining.as_machined)
  polished    the paper program's as-machined surface (the [tool] nose, or nose_radius)
              polished for the time that minimises its image displacement on the
              polishing curve ([polish]; the report's "polished" mirror); costs ~2 s
"""

from __future__ import annotations

import numpy as np

from ..design import Mirror
from ..errors import InputError
from ..profile import ExactProfile, LobeSamples, PolylineProfile, Profile

BUILTIN = ("exact", "reference", "uniform528")


def surface_names() -> tuple[str, ...]:
    """Every name make_surface accepts (the toolpath strategies once toolpath.py exists)."""
    strategies = _strategies()
    return BUILTIN + strategies + (("polished",) if strategies else ())


def make_surface(name: str, mirror: Mirror, cfg: dict, *, nose_radius: float = 0.0) -> Profile:
    """The Profile called `name` (see the module doc). nose_radius in mm (0: programmed)."""
    names = surface_names()
    if name not in names:
        raise InputError(f"--surface {name!r}: unknown surface; allowed: {', '.join(names)}")
    if not (nose_radius >= 0 and np.isfinite(nose_radius)):
        raise InputError(f"--nose-radius {nose_radius!r}: must be a finite number >= 0 mm")
    if nose_radius > 0 and name in BUILTIN:
        raise InputError(
            f"--nose-radius {nose_radius:g}: the as-machined surface needs a toolpath; use "
            f"--surface with one of {', '.join(_strategies()) or '(no toolpath strategies yet)'}"
        )
    exact = ExactProfile(mirror)
    if name == "exact":
        return exact
    if name == "reference":
        return lattice_polyline(exact, (4001, 4001), resolution=1e-6)
    if name == "uniform528":
        return lattice_polyline(exact, _share(exact, 528), resolution=0.005)
    if name == "polished":
        return _polished_surface(mirror, cfg, nose_radius)
    return _toolpath_surface(name, mirror, cfg, nose_radius)


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


def _strategies() -> tuple[str, ...]:
    try:
        from ..toolpath import Strategy
    except ImportError:
        return ()
    return tuple(s.value for s in Strategy) + ("best",)


def _toolpath_surface(name: str, mirror: Mirror, cfg: dict, nose_radius: float) -> Profile:
    import dataclasses

    from ..lathe import lathe_from_config, tool_from_config
    from ..nose_envelope import as_machined, contour_profile
    from ..toolpath import BEST, Strategy, plan_toolpath

    strategy = BEST if name == "best" else Strategy(name)
    tool = tool_from_config(cfg)
    if nose_radius > 0:
        # The program for that tool (its path is offset by the nose), and what the nose cuts.
        tool = dataclasses.replace(tool, nose_radius=nose_radius)
        return as_machined(plan_toolpath(mirror, lathe_from_config(cfg), tool, strategy), nose_radius)
    return contour_profile(plan_toolpath(mirror, lathe_from_config(cfg), tool, strategy))


def _polished_surface(mirror: Mirror, cfg: dict, nose_radius: float) -> Profile:
    """The paper program's as-machined surface polished at its polishing curve's optimum."""
    import dataclasses

    from ..lathe import lathe_from_config, tool_from_config
    from ..nose_envelope import as_machined, contour_profile
    from ..polishing import polish_curve, polish_params_from_config
    from ..toolpath import Strategy, plan_toolpath

    tool = tool_from_config(cfg)
    if nose_radius > 0:
        tool = dataclasses.replace(tool, nose_radius=nose_radius)
    machined = as_machined(plan_toolpath(mirror, lathe_from_config(cfg), tool, Strategy.PAPER))
    curve = polish_curve(machined, mirror, polish_params_from_config(cfg))
    return curve.profiles[curve.optimum_index]
