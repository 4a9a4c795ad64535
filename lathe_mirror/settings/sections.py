"""The typed sections: one frozen object per TOML section, gathered by `Sections`
(settings.model's Settings is Sections checked on construction; the checks take Sections,
so they need not know the checked type).

RenderSettings, StereoSettings and ComputeSettings are the sections that have no home in
a lower module. The sections of the lower modules (Camera, Lathe, Tool, PolishParams, ...)
are defined where they are used and only gathered here.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from ..body import BodySpec, CadSettings
from ..declared.section import check_fields, choice, flag, nested, section_repr, setting
from ..design import Camera, LobeSpec, Mirror, mirror_from_specs
from ..enums import Surface
from ..lathe import Lathe, Stock, Tool
from ..machine_errors import MachineErrors
from ..optics.camera import CameraPose
from ..optics.ranging.stereo import StereoParams
from ..optics.scene import SceneSpec
from ..optimize.spec import OptimizeSettings
from ..polishing import PolishParams
from ..tolerance.spec import ToleranceSettings
from ..toolpath import ToolpathSettings

#: Largest supersampling factor of a render (N x N rays per pixel).
MAX_SUPERSAMPLE = 8


@dataclass(frozen=True)
class RenderSettings:
    """The [render] section: supersample N (N x N rays per pixel, N^2 the cost), the made
    surface rendered by default, and the nose radius (mm; > 0: the as-machined surface of
    a tool of that radius along its own program)."""

    supersample: int = setting("render.supersample")
    surface: Surface = setting("render.surface", choice(Surface))
    nose_radius: float = setting("render.nose_radius")

    def __post_init__(self) -> None:
        check_fields(self)  # each field within its key's declaration: the line load() gives


@dataclass(frozen=True)
class StereoSettings:
    """The [stereo] section: the surface ranged by default, the render's supersampling N
    (N x N rays per pixel: the matcher's sub-pixel precision needs anti-aliased edges), how
    an image is ranged (StereoParams), and whether the point cloud is binary PLY."""

    surface: Surface = setting("stereo.surface", choice(Surface))
    supersample: int = setting("stereo.supersample")
    params: StereoParams = nested(StereoParams)
    ply_binary: bool = setting("stereo.ply_format", flag("binary", "ascii"))

    def __post_init__(self) -> None:
        check_fields(self)  # each field within its key's declaration: the line load() gives


@dataclass(frozen=True)
class ComputeSettings:
    """The [compute] section: where the heavy work (Monte Carlo trials, the optimiser's
    evaluations) runs. workers: processes on this machine (0: all cores). scheduler: ""
    runs local processes; else the address of a Dask scheduler, "tcp://HOST:PORT"."""

    workers: int = setting("compute.workers")
    scheduler: str = setting("compute.scheduler")

    def __post_init__(self) -> None:
        check_fields(self)  # each field within its key's declaration: the line load() gives


@dataclass(frozen=True)
class Sections:
    """Every section of a configuration, typed (each section checks its own fields; the
    whole is checked by settings.model.Settings).

    camera, lobes: the design's inputs (pipeline.design builds the Mirror from them).
    machine, tool, stock, toolpath: the lathe, its insert, the bar and the program's knobs.
    body, cad: the mounting body and the CAD export settings. polish: polishing.
    scene, render, camera_pose: the room, how it is rendered, the camera's misalignment.
    stereo: ranging from the image (optics.ranging).
    tolerance: the tolerance analysis (spec, tolerances, Monte Carlo).
    optimize: the design search. machine_errors: the lathe's set-up errors ([machine.errors]).
    compute: where heavy work runs (local processes or a Dask scheduler).
    """

    __repr__ = section_repr  # one line: the fields off their declared defaults

    camera: Camera = nested(Camera)
    lobes: tuple[LobeSpec, LobeSpec] = field(default_factory=lambda: (LobeSpec.declared("inner"),
                                                                      LobeSpec.declared("outer")))
    machine: Lathe = nested(Lathe)
    tool: Tool = nested(Tool)
    stock: Stock = nested(Stock)
    toolpath: ToolpathSettings = nested(ToolpathSettings)
    body: BodySpec = nested(BodySpec)
    cad: CadSettings = nested(CadSettings)
    polish: PolishParams = nested(PolishParams)
    scene: SceneSpec | None = nested(SceneSpec)
    render: RenderSettings = nested(RenderSettings)
    camera_pose: CameraPose = nested(CameraPose)
    tolerance: ToleranceSettings | None = nested(ToleranceSettings)
    stereo: StereoSettings = nested(StereoSettings)
    optimize: OptimizeSettings = nested(OptimizeSettings)
    machine_errors: MachineErrors = nested(MachineErrors)
    compute: ComputeSettings = nested(ComputeSettings)

    def mirror(self) -> Mirror:
        """The designed mirror (design.mirror_from_specs; cheap, the design is closed form)."""
        return mirror_from_specs(self.camera, self.lobes)
