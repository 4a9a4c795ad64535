"""The made surfaces the analysis starts from: program -> as-machined profile.

The toolpath and the tool-nose envelope are issue 3's (lathe_mirror.toolpath,
lathe_mirror.machining). Until those modules exist this falls back, and says so in
`source`, to the paper's own model of section 6: 528 points, uniform in r and split
between the lobes by radial extent, r and machine Z rounded to the lattice, joined by
straight segments, the tool's nose ignored.

The lattice phase is where the part's Z work zero (the face touch-off, arbitrary to
within one step) falls on the controller's lattice: phase_z in units of the step shifts
the Z lattice before rounding, so each phase is a different, equally likely realisation
of the rounding errors. X stays on a lattice through the axis (the X offset is set on
the centre; its error is the separate tool_x tolerance).
"""

from __future__ import annotations

import dataclasses
import importlib.util
from dataclasses import dataclass

import numpy as np

from ..design import Mirror
from ..profile import LobeSamples, PolylineProfile, Profile
from .spec import Program


@dataclass(frozen=True)
class MadeSurface:
    """An as-machined profile and where it came from (for the report)."""

    profile: Profile
    source: str


def issue3_available() -> bool:
    """True when the toolpath planner and the as-machined model are installed."""
    return all(importlib.util.find_spec(f"lathe_mirror.{m}") is not None for m in ("toolpath", "machining"))


def machined_surface(mirror: Mirror, cfg: dict, program: Program, *, resolution: float | None = None,
                     phase: float = 0.0, nose_radius: float | None = None) -> MadeSurface:
    """The as-machined surface of `program`, resolution (mm) and nose radius (mm) default to
    the config's [machine] resolution and [tool] nose_radius; phase: Z lattice offset in steps."""
    res = float(cfg.get("machine", {}).get("resolution", 0.005)) if resolution is None else resolution
    if issue3_available():
        return _issue3_surface(mirror, cfg, program, res, phase, nose_radius)
    return MadeSurface(paper_polyline(mirror, resolution=res, phase=phase),
                       "fallback: the paper's 528-point polyline model (issue 3's toolpath/machining absent)")


def paper_polyline(mirror: Mirror, *, n_points: int = 528, resolution: float = 0.005,
                   phase: float = 0.0) -> PolylineProfile:
    """The paper's section-6 model: n_points on the lattice joined by straight segments."""
    n_in = round(n_points * mirror.r_junction / mirror.r_max)
    lobes = []
    for k, lobe in enumerate(mirror.lobes):
        if k == 0:
            r = np.linspace(0.0, mirror.r_junction, n_in)
        else:
            r = np.linspace(mirror.r_junction, mirror.r_max, n_points - n_in + 1)[1:]
        zm = mirror.vertex_z - lobe.z(r)
        r_q = _snap(r, resolution, 0.0)
        z_q = _snap(zm, resolution, phase)
        r_q, keep = np.unique(r_q, return_index=True)  # rounding may merge neighbours
        lobes.append(LobeSamples(r_q, mirror.vertex_z - z_q[keep]))
    return PolylineProfile(*lobes, r_junction=mirror.r_junction, r_max=mirror.r_max, vertex_z=mirror.vertex_z)


def _snap(x: np.ndarray, step: float, phase: float) -> np.ndarray:
    """Nearest lattice point of a lattice offset by phase (in steps)."""
    off = phase * step
    return np.round((x - off) / step) * step + off


def _issue3_surface(mirror: Mirror, cfg: dict, program: Program, res: float, phase: float,
                    nose_radius: float | None) -> MadeSurface:
    from ..machine import lathe_from_config, tool_from_config
    from ..machining import as_machined
    from ..toolpath import BEST, Strategy, plan_toolpath

    lathe = dataclasses.replace(lathe_from_config(cfg), resolution=res)
    tool = tool_from_config(cfg)
    strategy = BEST if program is Program.BEST else Strategy.PAPER
    # The planner puts machine Z = 0 at mirror.vertex_z; a mirror whose vertex_z sits
    # phase * res higher is the same surface cut with the work zero that far off the lattice.
    planned = mirror if phase == 0.0 else _ZeroShiftedMirror(mirror.camera, mirror.inner, mirror.outer,
                                                             zero_shift=phase * res)
    tp = plan_toolpath(planned, lathe, tool, strategy)
    rho = tool.nose_radius if nose_radius is None else nose_radius
    return MadeSurface(as_machined(tp, rho),
                       f"{strategy.value} program (issue 3), as-machined with a {rho:g} mm nose")


@dataclasses.dataclass(frozen=True)
class _ZeroShiftedMirror(Mirror):
    """The design with its machine zero moved zero_shift (mm) along the axis."""

    zero_shift: float = 0.0

    @property
    def vertex_z(self) -> float:  # type: ignore[override]
        return self.inner.vertex_z + self.zero_shift
