"""The CNC lathe, its tool and the stock: the limits a toolpath must respect.

Machine frame (ARCHITECTURE.md): Z along the spindle axis, Z = 0 at the mirror's vertex,
the part in -Z; X is the radius r (radius mode) or 2r (diameter mode). The controller's
lattice (`Lathe.resolution`) applies to r and Z. Lengths in mm, angles in radians inside
(the configuration gives degrees).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .declared import SLACK, check as check_declared, key as declared_key
from .declared.section import DEGREES, setting
from .errors import InputError

#: Finest lattice step (mm) a program can carry: G-code words with 4 decimals.
_FINEST = 0.0001
#: F words (mm/rev): 4 decimals (their range, up to 500 mm/rev, is machine.feed_*'s).
FEED_STEP = 0.0001

# The soft jaws of the second set-up (shop.second), which hold the parted mirror by its
# outside diameter: facts of the workholding the design's body must leave room for
# (optimize's thickness constraint), so they sit with the machine, below both.
#: The soft jaws stop this far below the back face (mm): the facing tool passes over them.
JAW_GAP = 3.0
#: The jaws reach out this far beyond the part (mm).
JAW_WIDTH = 10.0
# The mount's bore is drilled for the boring bar, then bored (shop.boring); the drawing
# states the drill's point below the bore's floor (iso10110), so the drill sits here.
#: The drill: a 118 deg point, the bar's minimum bore plus DRILL_CLEARANCE_MM, up to a
#: stock size (a multiple of DRILL_STEP_MM), mm.
DRILL_POINT_DEG = 118.0
DRILL_CLEARANCE_MM = 0.5
DRILL_STEP_MM = 0.5


def bore_drill_mm(bar_min_bore_mm: float) -> float:
    """The drill (mm) the boring bar of minimum bore `bar_min_bore_mm` (mm) enters."""
    return math.ceil((bar_min_bore_mm + DRILL_CLEARANCE_MM) / DRILL_STEP_MM - 1e-9) * DRILL_STEP_MM


#: They grip at least this long (mm): toolpath.min_grip_mm's default (shop.second checks
#: the configured one, and the part's stand-out besides).
MIN_GRIP = float(declared_key("toolpath.min_grip_mm").default)
#: The soft jaws' grip per mm the part stands out of them: a cut at the part's end tips it
#: about the jaws' end with the stand-out as its lever, against the jaws' friction couple
#: over the grip (a chuck maker's tilting check, e.g. Forkardt's operating manuals,
#: "permissible overhang length"); the jaws' step the part is seated on takes the rest of
#: the moment, so half the stand-out, not all of it.
GRIP_PER_STAND_OUT = 0.5


def grip_needed(top: float, min_grip: float) -> float:
    """The least grip (mm) of the second set-up's soft jaws on a part whose parted face
    stands at Z `top` (mm, above the finished back face): toolpath.min_grip_mm
    (`min_grip`), and GRIP_PER_STAND_OUT of the length the part stands out of the jaws
    (top + JAW_GAP), the lever a cut at the part's end has about the jaws' end. The one
    rule shop.second checks and optimize constrains."""
    return max(min_grip, GRIP_PER_STAND_OUT * (top + JAW_GAP))


def parting_corner_z(length: float, back_allowance: float, width: float, resolution: float) -> float:
    """The parting blade's programmed Z (mm, its chuck-side corner; first set-up frame, Z0
    at the vertex) for a body `length` mm long from the vertex: the slot [Z, Z + width]
    with its part side at least `back_allowance` below the body, rounded down to the
    lattice `resolution`. The parted face then stands -(Z + width) - length above the
    body's end (shop.partoff places the blade here; optimize counts the stand-out)."""
    top = -(length + back_allowance)  # the slot's part side, at most here
    return round(math.floor((top - width) / resolution + 1e-9) * resolution, 6)


@dataclass(frozen=True)
class Lathe:
    """Limits of a CNC lathe controller. Lengths in mm.

    resolution: programmable increment of r and Z (the lattice), mm.
    max_points: points (r, Z) the controller holds for the finishing contour; a G1 end
      point counts one, a G2/G3 block two (its end point and its centre I, K).
    diameter_mode: X words are 2 r (LinuxCNC G7) rather than r (G8).
    travel_x: largest reachable radius, mm. travel_z_min / travel_z_max: machine Z range, mm.
    spindle_max_rpm: cap of the spindle under constant surface speed, rev/min.
    surface_speed: constant cutting speed, m/min. feed_rough / feed_finish: mm/rev.
    arc_radius_tolerance: largest |end radius - start radius| we allow an arc, mm.
    """

    resolution: float = setting("machine.resolution")
    max_points: int = setting("machine.max_points")
    diameter_mode: bool = setting("machine.diameter_mode")
    travel_x: float = setting("machine.travel_x")
    travel_z_min: float = setting("machine.travel_z_min")
    travel_z_max: float = setting("machine.travel_z_max")
    spindle_max_rpm: int = setting("machine.spindle_max_rpm")
    surface_speed: float = setting("machine.surface_speed")
    feed_rough: float = setting("machine.feed_rough")
    feed_finish: float = setting("machine.feed_finish")
    arc_radius_tolerance: float = setting("machine.arc_radius_tolerance")

    def __post_init__(self) -> None:
        # Each field within its key's declaration (machine.<field>): the line load() gives.
        for name in ("resolution", "max_points", "travel_x", "travel_z_min", "travel_z_max", "spindle_max_rpm",
                     "surface_speed", "feed_rough", "feed_finish", "arc_radius_tolerance"):
            check_declared(f"machine.{name}", getattr(self, name))
        # What the ranges do not say: every value a G-code word carries is written exactly,
        # a lattice value a whole number of 0.0001 mm (the finest increment LinuxCNC's rs274
        # reports, 4 decimals), S (G96 m/min) and the spindle cap (D / G50 S) whole numbers,
        # F 4 decimals.
        _word("machine.resolution", self.resolution, "mm", _FINEST, "G-code words carry at most 4 decimals")
        _word("machine.spindle_max_rpm", self.spindle_max_rpm, "rev/min", 1,
              "the spindle cap's word (D, G50 S) carries a whole number")
        _word("machine.surface_speed", self.surface_speed, "m/min", 1, "an S word carries a whole number")
        for key in ("feed_rough", "feed_finish"):
            _word(f"machine.{key}", getattr(self, key), "mm/rev", FEED_STEP, "an F word carries 4 decimals")

    # The lattice: integer multiples of the resolution. Working in integer lattice units
    # keeps "on the lattice" exact instead of a float comparison.
    def to_units(self, v: np.ndarray | float) -> np.ndarray:
        """Coordinates (mm) -> integer lattice units (nearest; units of `resolution`)."""
        return np.rint(np.asarray(v, dtype=float) / self.resolution).astype(np.int64)

    def from_units(self, k: np.ndarray | int) -> np.ndarray:
        """Integer lattice units (of `resolution`) -> coordinates, mm."""
        return np.asarray(k, dtype=np.int64) * self.resolution

    def snap(self, v: np.ndarray | float) -> np.ndarray:
        """Nearest lattice value(s), mm (the paper's rounding)."""
        return self.from_units(self.to_units(v))

    def on_lattice(self, v: np.ndarray | float, *, tol: float = 1e-9) -> bool:
        """True if every value is a lattice value (to tol mm of float noise)."""
        v = np.asarray(v, dtype=float)
        return bool(np.all(np.abs(v - self.snap(v)) <= tol))

    @property
    def decimals(self) -> int:
        """Decimals that write every lattice value of X (2r in diameter mode) and Z exactly
        (at most 4: the resolution is a multiple of 0.0001 mm)."""
        step = self.resolution  # Z, I, K are on it; X = 2r is on twice it
        for d in range(0, 4):
            if abs(round(step * 10**d) - step * 10**d) < 1e-9:
                return max(d, 1)
        return 4


@dataclass(frozen=True)
class Tool:
    """A turning tool. nose_radius in mm; angles in radians.

    included_angle: the insert's tip angle. approach_angle: direction of the tool's
    trailing flank measured from the +Z axis toward -X. Seen from the tip, the tool's
    body fills the wedge of directions from approach_angle to approach_angle +
    included_angle (both measured from +Z toward -X). A lattice contour with normals
    between those of the lobes and the step wall needs that wedge inside the free
    side of every surface normal (see `check_reach`).
    """

    nose_radius: float = setting("tool.nose_radius")
    included_angle: float = setting("tool.included_angle", DEGREES)
    approach_angle: float = setting("tool.approach_angle", DEGREES)

    def __post_init__(self) -> None:
        # Each within its key's declaration, the angles in the file's degrees: load()'s line.
        check_declared("tool.nose_radius", self.nose_radius)
        check_declared("tool.included_angle", _degrees(self.included_angle), slack=SLACK)
        check_declared("tool.approach_angle", _degrees(self.approach_angle), slack=SLACK)

    def flank_directions(self) -> tuple[float, float]:
        """Directions (rad, in the (r, Z) plane from +r toward +Z) of the two flanks."""
        first = math.pi / 2 + self.approach_angle
        return first, first + self.included_angle

    def check_reach(self, normal_angles: np.ndarray, what: str = "the contour") -> None:
        """Raise InputError unless the tool can cut surfaces with these outward normals.

        normal_angles: directions (rad, from +r toward +Z) of outward surface normals.
        A straight flank clears the surface near the contact only if its direction lies
        in the surface's free half-plane: normal - 90 deg <= flank <= normal + 90 deg.
        """
        lo, hi = self.flank_directions()
        n = np.asarray(normal_angles, dtype=float)
        worst_low = float(np.min(n))
        worst_high = float(np.max(n))
        if hi - math.pi / 2 > worst_low + 1e-12:
            raise InputError(
                f"tool.approach_angle + tool.included_angle = {math.degrees(hi - math.pi / 2):.2f} deg: "
                f"the tool's leading flank would rub {what} where its normal is "
                f"{math.degrees(worst_low):.2f} deg from +r; allowed up to {math.degrees(worst_low):.2f} deg"
            )
        if lo + math.pi / 2 < worst_high - 1e-12:
            raise InputError(
                f"tool.approach_angle = {math.degrees(self.approach_angle):.2f} deg: the trailing flank "
                f"would rub {what} where its normal is {math.degrees(worst_high):.2f} deg from +r "
                f"(the step wall); allowed >= {math.degrees(worst_high - math.pi):.2f} deg"
            )


@dataclass(frozen=True)
class Stock:
    """The bar the mirror is turned from. Lengths in mm.

    diameter: bar diameter. face_allowance: stock above the vertex (Z = 0) faced off.
    length: depth of the part below Z = 0 that roughing may reach.
    """

    diameter: float = setting("stock.diameter")
    face_allowance: float = setting("stock.face_allowance")
    length: float = setting("stock.length")

    def __post_init__(self) -> None:
        for name in ("diameter", "face_allowance", "length"):
            check_declared(f"stock.{name}", getattr(self, name))

    @property
    def radius(self) -> float:
        """Bar radius, mm."""
        return self.diameter / 2.0


def _word(key: str, value, unit: str, step: float, why: str) -> None:
    """A value a G-code word carries (already within its declared range): a multiple of
    `step`."""
    k = value / step
    if abs(k - round(k)) >= 1e-6:
        allowed = "a whole number" if step == 1 else f"a multiple of {step:g} {unit}"
        raise InputError(f"{key} = {_plain(value)} {unit}: {why}; allowed {allowed} within "
                         f"{declared_key(key).text()}")


def _degrees(angle) -> object:
    """An angle (rad) in the file's degrees; anything else as it is (the check refuses it)."""
    ok = isinstance(angle, (int, float)) and not isinstance(angle, bool)
    return math.degrees(angle) if ok else angle


def _plain(v) -> str:
    """A number for a message, fixed-point (no exponent)."""
    if isinstance(v, int):
        return str(v)
    s = f"{v:.12f}".rstrip("0").rstrip(".")
    return s if len(s) <= 24 else f"{v:.6e}"
