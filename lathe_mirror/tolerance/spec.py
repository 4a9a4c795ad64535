"""The tolerance spec (limits a made mirror must meet) and the parameters' tolerances.

Read from the [tolerance] section (lathe_mirror/data/tolerance.toml, overridable by the
user's --config). Edge units (px, %, m, degrees, s) are kept in the names; the analysis
converts to mm and radians.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from ..declared.section import FLOATS, choice, nested, section_repr, setting
from ..enums import Distribution, Program
from .registry import REGISTRY


@dataclass(frozen=True)
class Spec:
    """Limits (defaults: lathe_mirror/data/tolerance.toml).

    image_displacement_px: per-lobe RMS image displacement, px (after calibration when
    `calibrated`: the residual of the calibration fit), over the pixels whose ray lands on
    the lobe, but its outliers (displaced more than 5 x this limit).
    outlier_pct: per lobe, the outliers' share of those pixels, %.
    depth_error_pct at depth_range_m (m): the stereo limit, %. It is judged as a
    disparity-equivalent error: the parallax error that this depth error means at the
    band's median elevation (to first order, depth_error_pct / 100 of the parallax angle),
    in pixels of image position (montecarlo.disparity_limit_px; 0.44 px for 20 % at 1 m
    on the paper mirror), against the 90th percentile over the band's points.
    slope_error_rad: per-lobe RMS over the radii the image uses, rad.
    calibrated: judge the figures left after what a user's calibration removes (the
    camera's rotation, a smooth radial mapping per lobe: tolerance.calibration) instead
    of the raw ones against the design's own model.
    """

    image_displacement_px: float = setting("tolerance.spec.image_displacement_px")
    depth_error_pct: float = setting("tolerance.spec.depth_error_pct")
    depth_range_m: float = setting("tolerance.spec.depth_range_m")
    slope_error_rad: float = setting("tolerance.spec.slope_error_rad")
    calibrated: bool = setting("tolerance.spec.calibrated")
    outlier_pct: float = setting("tolerance.spec.outlier_pct")


#: The toleranced parameters, in table order: key -> (what it is, unit at the edge): the
#: controller's resolution and the lattice phase, then the drawn ones (tolerance.registry).
PARAMETERS: dict[str, tuple[str, str]] = {
    "resolution_mm": ("controller resolution (sensitivity only)", "mm"),
    "lattice_phase": ("offset of the work zero on the controller's lattice (resolution)", "step"),
    **{p.key: (p.what, p.unit) for p in REGISTRY},
}

#: The parameters the Monte Carlo draws and the allocation may tighten ([tolerance.params]),
#: in draw order.
DRAWN = tuple(p.key for p in REGISTRY if p.section == "params")

#: The lathe's set-up errors the Monte Carlo draws ([tolerance.machine_errors]), in draw
#: order, after DRAWN's.
MACHINE_DRAWN = tuple(p.key for p in REGISTRY if p.section == "machine_errors")

#: Largest sparse pixel sample per lobe (rays): image-radius bins x azimuths.
MAX_SAMPLE_RAYS = 200_000


@dataclass(frozen=True)
class ToleranceSettings:
    """Everything the tolerance analysis reads from [tolerance].

    seat_pivot_mm: height above the pinhole (mm, on the axis) of the point the mirror's
    seat tilts about; 0: the design's rim (pivot_mm). nose_step_mm: the drawn nose radius is rounded to this step and the
    part re-machined with it (mm). matching_noise_px: the stereo matcher's sub-pixel noise
    (px), the floor of the depth error. target_yield: the allocation's target (0..1).
    delivered_p5_min_fraction: the allocation's other target, the delivered R10's 5th
    percentile over the design's R10 (tolerance.allocation).
    cost: relative cost of holding each drawn parameter at its configured tolerance
    (tightening it by a factor k costs k times as much). machine_errors: tolerance of
    each [machine.errors] set-up error about its configured value ([tolerance.machine_errors],
    the same meaning as `tolerances` under `distribution`; edge units mm and urad).
    """

    __repr__ = section_repr  # one line: the fields off their declared defaults

    seed: int = setting("tolerance.seed")
    trials: int = setting("tolerance.trials")
    programs: tuple[Program, ...] = setting("tolerance.programs", choice(Program))
    distribution: Distribution = setting("tolerance.distribution", choice(Distribution))
    lattice_phases: int = setting("tolerance.lattice_phases")
    azimuths: int = setting("tolerance.azimuths")
    bin_px: float = setting("tolerance.bin_px")
    depth_points: int = setting("tolerance.depth_points")
    spec: Spec = nested(Spec)
    tolerances: dict[str, float] = setting("tolerance.params", FLOATS)
    seat_pivot_mm: float = setting("tolerance.seat_pivot_mm")
    nose_step_mm: float = setting("tolerance.nose_step_mm")
    matching_noise_px: float = setting("tolerance.matching_noise_px")
    target_yield: float = setting("tolerance.target_yield")
    delivered_p5_min_fraction: float = setting("tolerance.delivered_p5_min_fraction")
    cost: dict[str, float] = setting("tolerance.cost", FLOATS)
    machine_errors: dict[str, float] = setting("tolerance.machine_errors", FLOATS)
    shop: str = setting("tolerance.shop")  # the shop class the tolerances came from (tolerance.shops)

    def pivot_mm(self, mirror) -> float:
        """The seat's pivot height above the pinhole (mm) for `mirror`: seat_pivot_mm, or
        with 0 the design's rim (Mirror.far_z, its farthest point from the pinhole): a seat
        tilt t moves the pinhole sideways by pivot x sin t, so the lever follows the mirror
        (a 14 mm mirror 56 mm above a 6 mm lens is not tilted about a point 125 mm up)."""
        return float(self.seat_pivot_mm) if self.seat_pivot_mm != 0 else float(mirror.far_z)

    def spec_dict(self) -> dict:
        """The spec as JSON-ready key -> value."""
        return dict(self.spec.__dict__)
