"""The tolerance spec (limits a made mirror must meet) and the parameters' tolerances.

Read from the [tolerance] section (lathe_mirror/data/tolerance.toml, overridable by the
user's --config). Edge units (px, %, m, degrees, s) are kept in the names; the analysis
converts to mm and radians.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import Enum

from ..errors import InputError


class Distribution(str, Enum):
    """How a parameter's tolerance is read when drawing trials."""

    NORMAL = "normal"    # the tolerance is a 3-sigma bound of a normal distribution
    UNIFORM = "uniform"  # uniform within +/- the tolerance


class Program(str, Enum):
    """Which programmed contour the toleranced parts are turned from."""

    BEST = "best"
    PAPER = "paper"


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


def settings_from_config(cfg: dict) -> ToleranceSettings:
    """Validated ToleranceSettings (reads [tolerance], and [tool] nose_radius and [machine]
    resolution to bound their tolerances); an InputError names the offending key."""
    t = cfg["tolerance"]
    _int_at_least("tolerance.trials", t["trials"], 1)
    _int_at_least("tolerance.lattice_phases", t["lattice_phases"], 1)
    _int_at_least("tolerance.azimuths", t["azimuths"], 1)
    _int_at_least("tolerance.depth_points", t["depth_points"], 1)
    _int_at_least("tolerance.seed", t["seed"], 0)
    if not (math.isfinite(t["bin_px"]) and 0.05 <= t["bin_px"] <= 50):
        raise InputError(f"tolerance.bin_px = {t['bin_px']!r} must be 0.05 .. 50 px")
    # The sparse pixel sample is image-radius bins x azimuths per lobe: bound its size so a
    # trial's rays fit in memory (the default, 504 / 4 px x 12, is ~1500).
    r_pixel = max((float(lb.get("r_pixel", 0.0)) for lb in cfg.get("lobes", {}).values()), default=504.0)
    rays = t["azimuths"] * r_pixel / t["bin_px"]
    if rays > MAX_SAMPLE_RAYS:
        raise InputError(f"tolerance.azimuths = {t['azimuths']} with tolerance.bin_px = {t['bin_px']:g} px gives "
                         f"{rays:.3g} sample rays per lobe, at most {MAX_SAMPLE_RAYS} allowed: fewer azimuths or "
                         f"wider bins")
    programs = tuple(_enum(f"tolerance.programs[{i}]", v, Program) for i, v in enumerate(t["programs"]))
    if not programs:
        raise InputError("tolerance.programs = []: name at least one of \"paper\", \"best\"")
    dist = _enum("tolerance.distribution", t["distribution"], Distribution)
    s = t["spec"]
    for key in ("image_displacement_px", "depth_error_pct", "slope_error_rad"):
        _positive(f"tolerance.spec.{key}", s[key])
    if not (math.isfinite(s["depth_range_m"]) and 0.2 <= s["depth_range_m"] <= 100.0):
        raise InputError(f"tolerance.spec.depth_range_m = {s['depth_range_m']!r} must be 0.2 .. 100 m")
    tol = {}
    for key, value in t["params"].items():
        if not (math.isfinite(value) and value >= 0):
            raise InputError(f"tolerance.params.{key} = {value!r} must be a finite number >= 0")
        tol[key] = float(value)
    # The nodes span the nominal -/+ each tolerance: a nose or a controller step cannot go
    # to zero or below.
    nose0 = float(cfg.get("tool", {}).get("nose_radius", 0.0))
    if tol.get("nose_radius_mm", 0.0) > nose0:
        raise InputError(f"tolerance.params.nose_radius_mm = {tol['nose_radius_mm']:g} mm exceeds the nominal "
                         f"nose radius tool.nose_radius = {nose0:g} mm: the nose cannot be negative")
    res0 = float(cfg.get("machine", {}).get("resolution", 0.005))
    if tol.get("resolution_mm", 0.0) >= res0:
        raise InputError(f"tolerance.params.resolution_mm = {tol['resolution_mm']:g} mm must be smaller than "
                         f"machine.resolution = {res0:g} mm")
    return ToleranceSettings(
        seed=int(t["seed"]), trials=int(t["trials"]), programs=programs, distribution=dist,
        lattice_phases=int(t["lattice_phases"]), azimuths=int(t["azimuths"]),
        bin_px=float(t["bin_px"]), depth_points=int(t["depth_points"]),
        spec=Spec(**{k: float(v) for k, v in s.items()}), tolerances=tol)


def _enum(key: str, value: str, enum: type[Enum]):
    try:
        return enum(value)
    except ValueError:
        allowed = ", ".join(f'"{m.value}"' for m in enum)
        raise InputError(f"{key} = {value!r}: allowed {allowed}") from None


def _int_at_least(key: str, value: int, lo: int) -> None:
    if value < lo:
        raise InputError(f"{key} = {value!r} must be an integer >= {lo}")


def _positive(key: str, value: float) -> None:
    if not (math.isfinite(value) and value > 0):
        raise InputError(f"{key} = {value!r} must be a finite number > 0")
