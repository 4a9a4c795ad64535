"""The tolerance spec (limits a made mirror must meet) and the parameters' tolerances.

Read from the [tolerance] section (lathe_mirror/data/tolerance.toml, overridable by the
user's --config). Edge units (px, %, m, degrees, s) are kept in the names; the analysis
converts to mm and radians.
"""

from __future__ import annotations

from dataclasses import dataclass

from ..enums import Distribution, Program


@dataclass(frozen=True)
class Spec:
    """Limits (defaults: lathe_mirror/data/tolerance.toml). image_displacement_px: per-lobe
    RMS, px. depth_error_pct: RMS |depth error| over the common band at depth_range_m (m),
    each point capped at 100 % (optics.stereo.FAILED_PCT), %. slope_error_rad: per-lobe RMS
    over the radii the image uses, rad."""

    image_displacement_px: float
    depth_error_pct: float
    depth_range_m: float
    slope_error_rad: float


#: The toleranced parameters, in table order: key -> (what it is, unit at the edge).
PARAMETERS: dict[str, tuple[str, str]] = {
    "resolution_mm": ("controller resolution (sensitivity only)", "mm"),
    "lattice_phase": ("offset of the work zero on the controller's lattice (resolution)", "step"),
    "nose_radius_mm": ("insert nose radius", "mm"),
    "tool_x_mm": ("tool setting error across the axis (radius)", "mm"),
    "tool_z_mm": ("tool setting error along the axis", "mm"),
    "polish_time_s": ("polishing time", "s"),
    "camera_decentre_mm": ("camera pinhole off the mirror axis (x and y)", "mm"),
    "camera_tilt_deg": ("camera axis tilt (about x and y)", "deg"),
    "camera_axial_mm": ("camera pinhole along the axis", "mm"),
}


#: Largest sparse pixel sample per lobe (rays): image-radius bins x azimuths.
MAX_SAMPLE_RAYS = 200_000


@dataclass(frozen=True)
class ToleranceSettings:
    """Everything the tolerance analysis reads from [tolerance]."""

    seed: int
    trials: int
    programs: tuple[Program, ...]
    distribution: Distribution
    lattice_phases: int
    azimuths: int
    bin_px: float
    depth_points: int
    spec: Spec
    tolerances: dict[str, float]  # PARAMETERS' keys except lattice_phase; edge units
