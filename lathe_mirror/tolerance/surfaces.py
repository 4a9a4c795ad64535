"""The made surfaces the analysis starts from: program -> as-machined profile.

The toolpath and the tool-nose envelope are issue 3's (lathe_mirror.toolpath,
lathe_mirror.nose_envelope); this module only picks the program and sets the lattice phase.

The lattice phase is where the part's Z work zero (the face touch-off, arbitrary to
within one step) falls on the controller's lattice: phase_z in units of the step shifts
the Z lattice before rounding, so each phase is a different, equally likely realisation
of the rounding errors. X stays on a lattice through the axis (the X offset is set on
the centre; its error is the separate tool_x tolerance).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from ..design import Mirror
from ..profile import Profile
from .spec import Program


@dataclass(frozen=True)
class MadeSurface:
    """An as-machined profile and where it came from (for the report)."""

    profile: Profile
    source: str


def machined_surface(mirror: Mirror, cfg: dict, program: Program, *, resolution: float | None = None,
                     phase: float = 0.0, nose_radius: float | None = None) -> MadeSurface:
    """The as-machined surface of `program`, resolution (mm) and nose radius (mm) default to
    the config's [machine] resolution and [tool] nose_radius; phase: Z lattice offset in steps."""
    from ..lathe import lathe_from_config, tool_from_config
    from ..nose_envelope import as_machined
    from ..toolpath import BEST, Strategy, plan_toolpath

    lathe = lathe_from_config(cfg)
    if resolution is not None:
        lathe = dataclasses.replace(lathe, resolution=resolution)
    tool = tool_from_config(cfg)
    strategy = BEST if program is Program.BEST else Strategy.PAPER
    # The planner puts machine Z = 0 at mirror.vertex_z; a mirror whose vertex_z sits
    # phase * res higher is the same surface cut with the work zero that far off the lattice.
    planned = mirror if phase == 0.0 else _ZeroShiftedMirror(mirror.camera, mirror.inner, mirror.outer,
                                                             zero_shift=phase * lathe.resolution)
    tp = plan_toolpath(planned, lathe, tool, strategy)
    rho = tool.nose_radius if nose_radius is None else nose_radius
    return MadeSurface(as_machined(tp, rho), f"{strategy.value} program, as-machined with a {rho:g} mm nose")


@dataclasses.dataclass(frozen=True)
class _ZeroShiftedMirror(Mirror):
    """The design with its machine zero moved zero_shift (mm) along the axis."""

    zero_shift: float = 0.0

    @property
    def vertex_z(self) -> float:  # type: ignore[override]
        return self.inner.vertex_z + self.zero_shift
