"""The design's figures as plain data: the design table of `lathe-mirror design`, the
report's and the JSON's (the paper's symbols beside the ISO conic's R and k; mm, px, deg),
and Table 1's note on its swapped R_pixel column."""

from __future__ import annotations

import math

import numpy as np

from .design import Mirror
from .hyperbola import single_viewpoint_error

#: Table 1 prints R_pixel 504 for mirror 01 and 307 for mirror 02, but its h columns
#: follow from the swapped pair: h(01) = 115.607 needs R_pixel = 307.555, h(02) = 123.457
#: needs 504. The embedded default uses the swapped (consistent) values.
TABLE1_SWAP_NOTE = (
    "Table 1's R_pixel column is swapped: h of mirror 01 (inner) follows from "
    "R_pixel = 307.555 px, h of mirror 02 (outer) from R_pixel = 504 px; "
    "the paper default uses the consistent pair"
)


def design_figures(mirror: Mirror) -> dict:
    """Every design figure as plain data (the paper's symbols; mm, px, deg)."""
    cam = mirror.camera
    lobes = []
    for lobe in mirror.lobes:
        lo, hi = mirror.fov(lobe)
        ulo, uhi = mirror.fov_usable(lobe)
        lobes.append(
            {
                "name": lobe.name,
                "r_top": lobe.r_top,
                "r_pixel": lobe.r_pixel,
                "f": cam.f,
                "t_pixel": cam.t_pixel,
                "h": lobe.h,
                "a": lobe.a,
                "b": lobe.b,
                "e": lobe.e,
                "c": lobe.c,  # Table 1's symbol: the focal distance 2e, not a curvature
                "focal_distance_2e_mm": lobe.focus_z,
                # the lobe as an ISO 10110-12 conic (iso10110): vertex radius R (c = 1/R), conic constant k
                "R_mm": lobe.vertex_radius,
                "k": lobe.conic_constant,
                "alpha_deg": math.degrees(lobe.alpha),
                "a_over_b": lobe.a_over_b,
                "vertex_z": lobe.vertex_z,
                "rim_z": float(lobe.z(lobe.r_top)),
                "focus_z": lobe.focus_z,
                "fov_deg": {"min": math.degrees(lo), "max": math.degrees(hi)},
                "fov_usable_deg": {"min": math.degrees(ulo), "max": math.degrees(uhi)},
                # Check of the single viewpoint: worst miss of F1 over 2001 reflected rays.
                "viewpoint_check_mm": float(
                    single_viewpoint_error(lobe, np.linspace(0.0, lobe.r_top, 2001)).max()
                ),
            }
        )
    zi, zo = mirror.junction_z
    band = mirror.common_band
    radii = mirror.image_radii_px
    return {
        "camera": {"f": cam.f, "t_pixel": cam.t_pixel, "sensor_px": list(cam.sensor_px),
                   "r_pixel_max": cam.r_pixel_max},
        "lobes": lobes,
        "junction": {
            "r": mirror.r_junction,
            "z_inner": zi,
            "z_outer": zo,
            "step_mm": abs(mirror.step),
            "recessed": mirror.recessed,
            "r_outer_visible": mirror.r_outer_visible,
        },
        "vertex_z": mirror.vertex_z,
        "far_z": mirror.far_z,
        "depth_mm": mirror.depth,
        "baseline_mm": mirror.baseline,
        "common_band_deg": {"min": math.degrees(band[0]), "max": math.degrees(band[1])},
        "image_radii_px": {k: {"min": v[0], "max": v[1]} for k, v in radii.items()},
    }
