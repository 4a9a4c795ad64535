"""The [optimize] section as typed data: the objective, the constraints, the search.

Every constraint is a key with a default that keeps the paper's design feasible
(data/optimize.toml documents each one). Lengths in mm, angles in degrees as the file
gives them (converted where they are used), image radii in px, ranges in m.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from enum import Enum

from ..declared import check as check_declared
from ..declared.section import choice, nested, section_repr, setting
from ..errors import InputError

#: Names of the searched parameters, in the order of a design vector (see search.py).
PARAMETERS = ("outer_r_top_fraction", "junction_fraction", "outer_r_pixel_fraction",
              "pixel_fraction", "alpha_inner_deg", "alpha_outer_deg")

#: Parameters whose upper end 1.0 is the envelope or the sensor's edge (a constraint).
ENVELOPE_FRACTIONS = ("outer_r_top_fraction", "outer_r_pixel_fraction")

#: Most DE generations and population factor a configuration may ask for (cost bound).
MAX_GENERATIONS = 5000
MAX_POPSIZE = 100
MAX_WORKERS = 64


class Objective(str, Enum):
    """What the optimiser maximises (larger is better for each)."""

    DELIVERED = "delivered_r10_p5"  # m: R10 the made parts deliver, 5th percentile (surrogate)
    R10 = "r10"                  # m: range at which 1 px of disparity costs 10 % of range
    BASELINE = "baseline"        # mm: distance between the two viewpoints F1
    BAND_WIDTH = "band_width"    # deg: width of the common (stereo) band
    USABLE_AREA = "usable_area"  # share of the inscribed circle's pixels that see the scene

    @property
    def unit(self) -> str:
        return {"delivered_r10_p5": "m", "r10": "m", "baseline": "mm", "band_width": "deg", "usable_area": ""}[self.value]

    @property
    def label(self) -> str:
        return {"delivered_r10_p5": "delivered R10, 5th percentile [m]", "r10": "sharp R10 [m]", "baseline": "baseline [mm]", "band_width": "common band [deg]",
                "usable_area": "usable share of the image"}[self.value]


@dataclass(frozen=True)
class SearchSpace:
    """Ranges (low, high) of the searched parameters; low == high fixes a parameter.

    outer_r_top_fraction: outer r_top as a fraction of the radial envelope r_max_mm.
    junction_fraction: inner r_top / outer r_top. outer_r_pixel_fraction: outer r_pixel as
    a fraction of the inscribed circle's radius less rim_margin_px. pixel_fraction: inner
    r_pixel / outer r_pixel. alpha_inner_deg, alpha_outer_deg: each lobe's Table 1 alpha
    (deg). Fractions keep the inner lobe inside the outer one by construction.
    """

    outer_r_top_fraction: tuple[float, float] = setting("optimize.search.outer_r_top_fraction")
    junction_fraction: tuple[float, float] = setting("optimize.search.junction_fraction")
    outer_r_pixel_fraction: tuple[float, float] = setting("optimize.search.outer_r_pixel_fraction")
    pixel_fraction: tuple[float, float] = setting("optimize.search.pixel_fraction")
    alpha_inner_deg: tuple[float, float] = setting("optimize.search.alpha_inner_deg")
    alpha_outer_deg: tuple[float, float] = setting("optimize.search.alpha_outer_deg")

    def __post_init__(self) -> None:
        for name in PARAMETERS:
            lo, hi = getattr(self, name)
            key = f"optimize.search.{name}"
            if not (math.isfinite(lo) and math.isfinite(hi) and lo <= hi):
                raise InputError(f"{key} = [{lo!r}, {hi!r}]: need two finite numbers, low <= high")
            if name.endswith("_deg"):
                if not -89.0 <= lo <= hi <= 89.0:
                    raise InputError(f"{key} = [{lo:g}, {hi:g}] deg: allowed within -89 .. 89 deg")
            elif not 0.0 < lo <= hi <= 1.0:
                raise InputError(f"{key} = [{lo:g}, {hi:g}]: a fraction, allowed within (0, 1]")
        if self.junction_fraction[1] >= 1.0 or self.pixel_fraction[1] >= 1.0:
            which = "junction_fraction" if self.junction_fraction[1] >= 1.0 else "pixel_fraction"
            raise InputError(f"optimize.search.{which}: the high end must be < 1 (the inner lobe lies "
                             "inside the outer one)")

    def bounds(self) -> list[tuple[float, float]]:
        """(low, high) of every parameter, in PARAMETERS order."""
        return [getattr(self, name) for name in PARAMETERS]


@dataclass(frozen=True)
class OptimizeSettings:
    """The [optimize] section (see data/optimize.toml for each key's meaning).

    Objective and search: objective, seed, workers (processes), popsize (DE population
    per searched parameter), maxiter (DE generations at most), tol (DE's relative
    convergence tolerance), search (the parameter ranges).
    Constraints: r_max_mm (radial envelope: the outer r_top), vertex_min_mm (the nearest
    point of the mirror, its vertex, at least this far from the pinhole), rim_max_mm (the
    farthest point, the higher rim, at most this far), band_deg (elevations, deg, the
    common band must cover; R10 is its median over this band), band_width_min_deg,
    rim_margin_px (the outer rim this far inside the sensor's inscribed circle),
    usable_min (share of the inscribed circle's pixels that see the scene), blur_max_px
    (largest defocus blur over both usable annuli, thin-lens model, [camera] f_number),
    focus_range_m (range of the scene points whose virtual images the focus serves).
    The envelope in the user's terms: max_diameter_mm, max_depth_mm (the mirror's largest
    diameter and depth; 0: r_max_mm, vertex_min_mm and rim_max_mm hold), blur_limit_um
    (the blur limit on the sensor, um; 0: blur_max_px holds). bound_margin: fraction of
    each searched parameter's span the winner keeps clear of its bounds.
    The lathe's constraints come from [tool], [stock], [toolpath] and [cad].
    """

    __repr__ = section_repr  # one line: the fields off their declared defaults

    objective: Objective = setting("optimize.objective", choice(Objective))
    seed: int = setting("optimize.seed")
    workers: int = setting("optimize.workers")
    popsize: int = setting("optimize.popsize")
    maxiter: int = setting("optimize.maxiter")
    tol: float = setting("optimize.tol")
    r_max_mm: float = setting("optimize.r_max_mm")
    vertex_min_mm: float = setting("optimize.vertex_min_mm")
    rim_max_mm: float = setting("optimize.rim_max_mm")
    band_deg: tuple[float, float] = setting("optimize.band_deg")
    band_width_min_deg: float = setting("optimize.band_width_min_deg")
    rim_margin_px: float = setting("optimize.rim_margin_px")
    usable_min: float = setting("optimize.usable_min")
    blur_max_px: float = setting("optimize.blur_max_px")
    focus_range_m: float = setting("optimize.focus_range_m")
    max_diameter_mm: float = setting("optimize.max_diameter_mm")
    max_depth_mm: float = setting("optimize.max_depth_mm")
    blur_limit_um: float = setting("optimize.blur_limit_um")
    bound_margin: float = setting("optimize.bound_margin")
    search: SearchSpace = nested(SearchSpace)

    def __post_init__(self) -> None:
        # Each field within its key's declaration (optimize.<field>): the line load() gives.
        for name in ("seed", "workers", "popsize", "maxiter", "tol", "r_max_mm", "vertex_min_mm", "rim_max_mm",
                     "band_deg", "band_width_min_deg", "rim_margin_px", "usable_min", "blur_max_px",
                     "focus_range_m", "max_diameter_mm", "max_depth_mm", "blur_limit_um", "bound_margin"):
            check_declared(f"optimize.{name}", getattr(self, name))
        # What the ranges do not say (each key's `depends`):
        if not self.rim_max_mm > self.vertex_min_mm:
            raise InputError(f"optimize.rim_max_mm = {self.rim_max_mm!r} mm: must exceed "
                             f"optimize.vertex_min_mm = {self.vertex_min_mm:g} mm")
        lo, hi = self.band_deg
        if not lo < hi:
            raise InputError(f"optimize.band_deg = [{lo!r}, {hi!r}]: need lowest < highest elevation, "
                             "within -90 .. 90 deg")

    @property
    def band(self) -> tuple[float, float]:
        """The required band, rad (lowest, highest elevation)."""
        return (math.radians(self.band_deg[0]), math.radians(self.band_deg[1]))

    @property
    def radial_limit_mm(self) -> float:
        """The outer rim's largest radius (mm): max_diameter_mm / 2 when given, else r_max_mm."""
        return self.max_diameter_mm / 2.0 if self.max_diameter_mm > 0 else self.r_max_mm

    @property
    def users_terms(self) -> bool:
        """The envelope given as the mirror's own diameter and depth (max_diameter_mm or
        max_depth_mm): the heights above the pinhole then follow from the design."""
        return self.max_diameter_mm > 0 or self.max_depth_mm > 0

    @property
    def vertex_limit_mm(self) -> float:
        """The vertex's least height above the pinhole: vertex_min_mm, or 0 in the user's
        terms (the design places the mirror; `optimize` prints the heights)."""
        return 0.0 if self.users_terms else self.vertex_min_mm

    @property
    def radial_key(self) -> str:
        return "optimize.max_diameter_mm" if self.max_diameter_mm > 0 else "optimize.r_max_mm"

    def blur_limit_px(self, t_pixel_mm: float) -> float:
        """The blur limit in pixels of t_pixel_mm: blur_limit_um on the sensor when given
        (the same micrometres for any pixel), else blur_max_px."""
        return self.blur_limit_um * 1e-3 / t_pixel_mm if self.blur_limit_um > 0 else self.blur_max_px

    @property
    def blur_key(self) -> str:
        return "optimize.blur_limit_um" if self.blur_limit_um > 0 else "optimize.blur_max_px"

    def margin_bounds(self) -> list[tuple[float, float]]:
        """The searched ranges less bound_margin of each one's span at both ends (a fixed
        parameter stays fixed): the winner keeps that clear of the search's bounds."""
        out = []
        for name, (lo, hi) in zip(PARAMETERS, self.search.bounds()):
            m = self.bound_margin * (hi - lo)
            # the outer rim's radius and image radius may fill the envelope and the sensor:
            # those ends are constraints (reported when active), not the search's bounds
            top = hi if name in ENVELOPE_FRACTIONS and hi >= 1.0 else hi - m
            out.append((lo + m, top))
        return out
