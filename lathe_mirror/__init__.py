"""lathe-mirror: design, turn, render and tolerance double-lobed hyperbolic mirrors.

The Python API (names load on first use, so `import lathe_mirror` stays light):

    import lathe_mirror as lm

    settings = lm.load()                      # the paper default, or lm.load("my.toml")
    mirror = settings.mirror()                # Eqs. 3-6: both lobes, Table 1's figures
    made = lm.made_surface(mirror, settings.machine, settings.tool, lm.Strategy.ARCS)
    lm.distortion_figures(made.profile, mirror)          # five figures per lobe

Settings and the design: `load`, `Settings` (`.mirror()` designs it), `Mirror`, `Camera`,
`design_figures`.
The lathe: `Lathe`, `Tool`, `Stock`, `Strategy`, `plan` (the toolpath), `machine` (the
nose envelope), `made_surface` / `MadeSurface` (plan -> machine -> polish, the one builder).
Polishing: `PolishParams`, `polish`, `polishing_curve`. Optics: `image_displacement`
(per-pixel maps), `distortion_figures`; ranging: `r10` (the range at which one pixel of
disparity costs 10 %, m), `stereo_range` (range an image). Tolerance: `monte_carlo`.
`checked_mirror(camera, lobe_specs)` designs a mirror with every check `load()` gives.
Errors: `Error`, the one family, of kinds input (`InputError`), design (`DesignError`)
and internal (`InternalError`); `lm.Settings(...)` or `dataclasses.replace(settings, ...)`
to a design that cannot exist raises the message `load()` gives for the same values.
Lengths in mm, angles in radians, image positions in px (docs/architecture.md).
"""

from importlib import import_module

from .version import __version__

#: Public name -> the module that defines it.
_API = {
    "load": "config", "Settings": "settings",
    "plan": "job", "machine": "job", "made_surface": "job",
    "MadeSurface": "job", "polishing_curve": "job", "monte_carlo": "tolerance.runs",
    "Mirror": "design", "Camera": "design", "design_figures": "design",
    "Lathe": "lathe", "Tool": "lathe", "Stock": "lathe", "Strategy": "enums",
    "PolishParams": "polishing", "polish": "polishing",
    "image_displacement": "optics.distortion", "distortion_figures": "optics.distortion",
    "r10": "optics.ranging.resolution", "stereo_range": "optics.ranging.stereo",
    "checked_mirror": "settings",
    "Error": "errors", "InputError": "errors", "DesignError": "errors", "InternalError": "errors",
}

__all__ = ["__version__", *_API]


def __getattr__(name: str):
    if name in _API:
        return getattr(import_module(f".{_API[name]}", __name__), name)
    raise AttributeError(f"module 'lathe_mirror' has no attribute {name!r}")


def __dir__():
    return sorted(__all__)
