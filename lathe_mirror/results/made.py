"""The made mirrors' figures: the toolpaths per strategy, the lathe and tool, the zones
the criteria judge, and the five figures per lobe of each made mirror."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from .base import RESULT, Range, Result, Stat, key, omitted, structured


@dataclass(**RESULT)
class LobeSurface(Result):
    """A lobe's surface figures (toolpath.profile_errors)."""

    name: str
    normal_deviation_mm: Stat
    slope_error_rad: Stat


@dataclass(**RESULT)
class SurfaceErrors(Result):
    lobes: tuple[LobeSurface, ...]


@dataclass(**RESULT)
class Moves(Result):
    g1: int = key("G1")
    g2_g3: int = key("G2/G3")


@dataclass(**RESULT)
class ToolpathFigures(Result):
    """One strategy's toolpath: its moves and its surface as programmed and as machined."""

    strategy: str
    best: bool
    n_points: int
    moves: Moves
    programmed: SurfaceErrors
    as_machined: SurfaceErrors


def toolpath_table(rows: tuple[ToolpathFigures, ...]) -> np.ndarray:
    """The toolpath table as a numpy structured array: one row per strategy and lobe."""
    out = []
    for r in rows:
        for p, a in zip(r.programmed.lobes, r.as_machined.lobes):
            out.append((r.strategy, r.best, r.n_points, r.moves.g1, r.moves.g2_g3, p.name,
                        p.slope_error_rad.rms, p.normal_deviation_mm.rms, a.slope_error_rad.rms,
                        a.normal_deviation_mm.rms))
    return structured(out, [("strategy", "U16"), ("best", "?"), ("n_points", "i8"), ("G1", "i8"),
                            ("G2_G3", "i8"), ("lobe", "U8"), ("programmed_slope_error_rad_rms", "f8"),
                            ("programmed_normal_deviation_mm_rms", "f8"),
                            ("as_machined_slope_error_rad_rms", "f8"), ("as_machined_normal_deviation_mm_rms", "f8")])


@dataclass(**RESULT)
class ToolFigures(Result):
    nose_radius: float
    included_angle_deg: float
    approach_angle_deg: float


@dataclass(**RESULT)
class MachineFigures(Result):
    """The lathe's settings as configured and the tool."""

    lathe: dict[str, Any]
    tool: ToolFigures


@dataclass(**RESULT)
class ZoneLobe(Result):
    name: str
    designed_px: Range | None
    seen_mm: Range | None
    used_mm: Range | None
    used_px: Range | None
    fillet_mm: Range | None
    fillet_px: Range | None
    fillet_width_mm: float
    fillet_width_px: float
    used_pixels: int
    fillet_pixels_lost: int


@dataclass(**RESULT)
class ZoneFigures(Result):
    """The zones the criteria judge (optics.zones); `text` in the report's own copy."""

    nose_radius_mm: float
    guard_mm: float
    recessed_lobe: str
    step_shadow_px: Range
    lobes: tuple[ZoneLobe, ...]
    text: str | None = omitted()


@dataclass(**RESULT)
class VignettedFigures(Result):
    pixels: int
    ray_deviation_deg: Stat
    image_displacement_px: Stat
    viewpoint_spread_mm: Stat


@dataclass(**RESULT)
class PixelFigures(Result):
    """A lobe's per-pixel optical figures (optics.distortion), the vignetted pixels apart."""

    name: str
    pixels: int
    pixels_lost: int
    pixels_left_range: int
    left_range_pct: float
    pixels_vignetted: int
    with_vignetted: VignettedFigures
    ray_deviation_deg: Stat
    image_displacement_px: Stat
    viewpoint_spread_mm: Stat
    zone_px: Range | None = omitted()


@dataclass(**RESULT)
class DistortionFigures(Result):
    """A made surface's per-pixel optical figures, lobes inner first (optics.distortion:
    lm.distortion_figures). `table()`: one row per lobe."""

    lobes: tuple[PixelFigures, ...]

    def lobe(self, name: str) -> PixelFigures:
        return next(lb for lb in self.lobes if lb.name == name)

    def table(self) -> np.ndarray:
        figs = ("ray_deviation_deg", "image_displacement_px", "viewpoint_spread_mm")
        rows = [(lb.name, lb.pixels, lb.pixels_lost, lb.pixels_vignetted,
                 *(x for f in figs for x in (getattr(lb, f).rms, getattr(lb, f).max, getattr(lb, f).nan_excluded or 0)))
                for lb in self.lobes]
        return structured(rows, [("name", "U8"), ("pixels", "i8"), ("pixels_lost", "i8"), ("pixels_vignetted", "i8"),
                                 *((f"{f}_{s}", "i8" if s == "nan_excluded" else "f8")
                                   for f in figs for s in ("rms", "max", "nan_excluded"))])


@dataclass(**RESULT)
class EdgeFigures(Result):
    """A lobe's edge band (polish.clear_edge_mm at the step and the rim: a polished part's
    turned-down edge) on its own: its pixels, those whose ray left the lobe's range, and
    their image displacement (px)."""

    band_mm: float
    pixels: int
    pixels_left_range: int
    image_displacement_px: Stat


@dataclass(**RESULT)
class LobeFigures(Result):
    """The five figures of one lobe of a made mirror (ARCHITECTURE.md), surface and optics.
    pixels_excluded counts the pixels whose made ray misses the lobe or leaves its range
    (pixels_left_range, left_range_pct of the lobe's pixels: lost, optics.radial)."""

    name: str
    slope_error_rad: Stat
    normal_deviation_mm: Stat
    ray_deviation_deg: Stat
    image_displacement_px: Stat
    viewpoint_spread_mm: Stat
    pixels: int
    pixels_excluded: int
    pixels_left_range: int
    left_range_pct: float
    zone_px: Range | None = omitted()
    edge: EdgeFigures | None = omitted()
    optics_distortion: PixelFigures


#: the five figures, in the report's order
FIVE = ("slope_error_rad", "normal_deviation_mm", "ray_deviation_deg", "image_displacement_px",
        "viewpoint_spread_mm")


@dataclass(**RESULT)
class MirrorFigures(Result):
    """A made mirror's figures per lobe; which part it is (`made_mirror`) and, polished,
    for how long. `table()`: one row per lobe, RMS and max of each of the five figures."""

    lobes: tuple[LobeFigures, ...]
    polish_time_s: float | None = omitted()
    made_mirror: str | None = omitted()

    def lobe(self, name: str) -> LobeFigures:
        return next(lb for lb in self.lobes if lb.name == name)

    def table(self) -> np.ndarray:
        rows = [(lb.name, lb.pixels, *(x for f in FIVE for x in (getattr(lb, f).rms, getattr(lb, f).max)))
                for lb in self.lobes]
        return structured(rows, [("name", "U8"), ("pixels", "i8"),
                                 *((f"{f}_{s}", "f8") for f in FIVE for s in ("rms", "max"))])


@dataclass(**RESULT)
class MadeMirror(Result):
    """Which part a made mirror is (job.MachiningJob.to_dict)."""

    label: str
    program: str
    nose_radius_mm: float
    resolution_mm: float
    lattice_phase: float
    polish_time_s: float
    precompensated: bool
    max_deviation_mm: float
