"""The design's figures (design_table.design_figures): the camera, each lobe in the
paper's symbols beside the ISO conic's R and k, the junction, the band (mm, px, deg)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .base import RESULT, Range, Result, structured


@dataclass(**RESULT)
class CameraFigures(Result):
    f: float
    t_pixel: float
    sensor_px: tuple[int, int]
    r_pixel_max: float


@dataclass(**RESULT)
class LobeDesign(Result):
    """One lobe (Table 1's columns; `c` is Table 1's focal distance 2e, not a curvature)."""

    name: str
    r_top: float
    r_pixel: float
    f: float
    t_pixel: float
    h: float
    a: float
    b: float
    e: float
    c: float
    focal_distance_2e_mm: float
    R_mm: float
    k: float
    alpha_deg: float
    a_over_b: float
    vertex_z: float
    rim_z: float
    focus_z: float
    fov_deg: Range
    fov_usable_deg: Range
    viewpoint_check_mm: float


@dataclass(**RESULT)
class Junction(Result):
    """The step between the lobes (mm): step_mm its height |Mirror.step| (Mirror.step is
    signed, inner minus outer sheet), recessed the lobe it lowers."""

    r: float
    z_inner: float
    z_outer: float
    step_mm: float
    recessed: str
    r_outer_visible: float


@dataclass(**RESULT)
class DesignFigures(Result):
    """Every design figure; `table()`: one row per lobe (its scalar figures)."""

    camera: CameraFigures
    lobes: tuple[LobeDesign, ...]
    junction: Junction
    vertex_z: float
    far_z: float
    depth_mm: float
    baseline_mm: float
    common_band_deg: Range
    image_radii_px: dict[str, Range]

    #: the lobe columns of table()
    COLUMNS = ("r_top", "r_pixel", "h", "a", "b", "e", "c", "R_mm", "k", "alpha_deg", "a_over_b",
               "vertex_z", "rim_z", "focus_z", "viewpoint_check_mm")

    def lobe(self, name: str) -> LobeDesign:
        return next(lb for lb in self.lobes if lb.name == name)

    def table(self) -> np.ndarray:
        return structured([(lb.name, *(getattr(lb, c) for c in self.COLUMNS)) for lb in self.lobes],
                          [("name", "U8"), *((c, "f8") for c in self.COLUMNS)])


__all__ = ["CameraFigures", "DesignFigures", "Junction", "LobeDesign"]
