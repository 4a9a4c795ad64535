"""lathe-mirror: design, turn, render and tolerance double-lobed hyperbolic mirrors.

The Python API (names load on first use, so `import lathe_mirror` stays light):

    import lathe_mirror as lm

    settings = lm.load()                      # the paper default, or lm.load("my.toml")
    mirror = settings.mirror()                # Eqs. 3-6: both lobes, Table 1's figures
    made = lm.made_surface(mirror, settings.machine, settings.tool, lm.Strategy.BEST)
    lm.distortion_figures(made.profile, mirror)          # DistortionFigures, per lobe

Settings and the design: `load`, `Settings` (`.mirror()` designs it), `Camera`,
`LobeSpec` and `mirror_from_specs` (a design from a camera and two lobe specs;
`checked_mirror` the same with every check `load()` gives),
`design_mirror`, `Mirror`, `Lobe`, `design_figures` (a `DesignFigures`).
The lathe: `Lathe`, `Tool`, `Stock`, `Strategy` (`BEST` is `ARCS`), `MachiningJob` (the
one machining job every command uses), `plan` (the toolpath), `machine` (the nose
envelope), `made_surface` / `MadeSurface` (plan -> machine -> polish, the one builder),
`Program` and `shop_program` (the whole part program), `ExactProfile`, `Profile`.
Polishing: `PolishParams`, `polish`, `polishing_curve`, `nominal_polish_time_s`.
Optics: `image_displacement` (per-pixel maps), `distortion_figures` (a
`DistortionFigures`; NaN pixels left out and counted), `zones` / `Zones`
(the pixels and radii every figure covers), `render_image`,
`SceneSpec` / `build_scene` / `Scene`, `UnifiedModel` and `design_model` (each lobe's
camera model, as OpenCV's omnidir and Kalibr take it); ranging: `r10` (the range at
which one pixel of disparity costs 10 %, m), `stereo_range` (range an image).
Tolerance: `monte_carlo` (trials=, seed=, the polishing time chosen as the command
chooses it unless given, the trials run where `settings.compute` says), `ProgramName`
(which program a toleranced part is cut from).
The shop and the inspection room: `spec_of` / `PartSpec` (ISO 10110), `measure` /
`Measurement` (a measured profile fitted and diagnosed; `lm.measure` stays this function
when the subpackage `lathe_mirror.measure` is imported), `measured_profile`.
The report's analysis: `report_figures` (every stage, no files) gives a `ReportData` of
typed results, frozen dataclasses with `to_dict()` (report.json's sections) and, where
they are tables, `table()` (numpy structured arrays): `DesignFigures`,
`ToolpathFigures`, `MirrorFigures` (each made mirror's five figures per lobe),
`StereoFigures`, `CalibrationFigures`, `RenderFigures`, `RangingFigures`,
`PolishingStudy` / `PolishCurveFigures`, `ToleranceAnalysis` / `MonteCarloFigures`
(`table()`: one row per trial) / `Verdict`.
Errors: `Error`, the one family, of kinds input (`InputError`), design (`DesignError`)
and internal (`InternalError`); `lm.Settings(...)` or `dataclasses.replace(settings, ...)`
to a design that cannot exist raises the message `load()` gives for the same values.
Arguments are checked where they are given: a wrong type, a number out of range or an
unknown name raises an `InputError` of one line naming the function and the argument.
Choices take their enum or its name (`Strategy("best")`, `plan(..., "best")`).
Lengths in mm, angles in radians, image positions in px (docs/architecture.md).
`help(lm.NAME)` documents each name; there is no `import *`: name what you use.
"""

import sys
from importlib import import_module
from types import ModuleType

from .version import __version__

#: Public name -> the module that defines it.
_API = {
    "load": "config", "Settings": "settings",
    "Camera": "design", "LobeSpec": "design", "mirror_from_specs": "design", "design_mirror": "design",
    "Mirror": "design", "Lobe": "design", "design_figures": "api",
    "Lathe": "lathe", "Tool": "lathe", "Stock": "lathe", "Strategy": "enums",
    "MachiningJob": "job", "plan": "job", "machine": "job", "made_surface": "job", "MadeSurface": "job",
    "polishing_curve": "job", "Program": "shop.program", "shop_program": "shop.programs",
    "ExactProfile": "profile", "Profile": "profile",
    "PolishParams": "polishing", "polish": "polishing", "nominal_polish_time_s": "api",
    "image_displacement": "optics.distortion", "distortion_figures": "api",
    "render_image": "optics.render", "SceneSpec": "optics.scene", "build_scene": "optics.scene",
    "Scene": "optics.scene", "UnifiedModel": "optics.camera_model", "design_model": "optics.camera_model",
    "zones": "optics.zones", "Zones": "optics.zones",
    "r10": "optics.ranging.resolution", "stereo_range": "optics.ranging.stereo",
    "monte_carlo": "api", "ProgramName": "enums:Program",
    "spec_of": "iso10110", "PartSpec": "iso10110",
    "measure": "measure.result", "Measurement": "measure.result", "measured_profile": "measure.surface",
    "checked_mirror": "settings",
    "report_figures": "pipeline", "ReportData": "report.analysis",
    "DesignFigures": "results", "ToolpathFigures": "results", "MirrorFigures": "results",
    "DistortionFigures": "results",
    "StereoFigures": "results", "CalibrationFigures": "results", "RenderFigures": "results",
    "RangingFigures": "results", "PolishingStudy": "results", "PolishCurveFigures": "results",
    "ToleranceAnalysis": "results", "MonteCarloFigures": "results", "Verdict": "results",
    "Error": "errors", "InputError": "errors", "DesignError": "errors", "InternalError": "errors",
}

#: API names that are also a subpackage's name (lathe_mirror.measure): the name stays the
#: function, whatever is imported (the import system sets a loaded subpackage as its
#: parent's attribute; _Package refuses that for these names). The subpackage's modules are
#: imported by their full names: `from lathe_mirror.measure import readers`.
_SHADOWED = frozenset(n for n in _API if n in ("measure",))


def __getattr__(name: str):
    if name in _API:
        module, _, attr = _API[name].partition(":")
        return getattr(import_module(f".{module}", __name__), attr or name)
    raise AttributeError(f"module 'lathe_mirror' has no attribute {name!r}")


def __dir__():
    return sorted(["__version__", *_API])


class _Package(ModuleType):
    def __setattr__(self, name: str, value) -> None:
        if name in _SHADOWED and isinstance(value, ModuleType):
            return
        super().__setattr__(name, value)


sys.modules[__name__].__class__ = _Package
