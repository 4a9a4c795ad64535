"""What the stock simulation (shop.stock) replays and reports: the moves it is handed
(SimMove, SimOperation), what the tool must not touch (Contact), each operation's
figures (OperationFigures) and the whole run (Simulation), including the part the
part-off separates from the bar.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from ..errors import InputError
from ..path import Move


@dataclass(frozen=True)
class SimMove:
    """One programmed move as the simulation replays it. feed: mm/rev (rapids: unused).
    label: how the operator finds the block ("N130 G0 X0.000 Z3.000", "line 130: ...")."""

    rapid: bool
    move: Move
    feed: float
    label: str


@dataclass(frozen=True)
class SimOperation:
    """An operation's moves, in order."""

    name: str
    station: int
    moves: tuple[SimMove, ...]


@dataclass(frozen=True)
class Contact:
    """Something the tool must not touch: kind "rapid" (stock at rapid; "dogleg" when
    only a rapid that moves one axis first touches it), "body" (stock
    touched by the insert's body), "part" (a cut into the designed part beyond the gouge
    tolerance) or "chuck". area mm^2; depth mm; at: (r, Z) of the deepest point."""

    kind: str
    operation: str
    label: str
    area: float
    depth: float
    at: tuple[float, float]

    def message(self, diameter_mode: bool = True) -> str:
        x = self.at[0] * (2 if diameter_mode else 1)
        where = f"{self.depth:.3f} mm deep near X{x:.3f} Z{self.at[1]:.3f}"
        what = {
            "rapid": "drives the tool through stock at rapid",
            "dogleg": "drives the tool through stock at rapid if the controller moves one axis first",
            "body": "touches stock with the insert's body, beyond its cutting edge",
            "attached": "leaves the part joined to the bar across the part-off's slot",
            "part": "cuts into the finished part beyond the gouge tolerance",
            "chuck": "runs the tool into the chuck",
        }[self.kind]
        fix = {
            "rapid": "a rapid must retract from the stock first, then traverse",
            "dogleg": "a rapid must retract from the stock first, then traverse",
            "body": "less depth per pass, toolpath.rough_depth, or another tool",
            "part": "toolpath.rough_allowance, or a finer toolpath",
            "chuck": "stock.length, or a shorter part",
            "attached": "the part-off must feed through the axis",
        }[self.kind]
        return f"program refused: block {self.label} ({self.operation}) {what}: {where} ({fix})"


@dataclass(frozen=True)
class OperationFigures:
    """What one operation does to the stock.

    removed_area_mm2: material removed in the (r, Z) plane; removed_volume_mm3: turned
    (2 pi r dA). max_depth_of_cut_mm: largest removed area per unit path (windows of
    STAT_WINDOW mm); None for a drill (its lips cut from the axis to its radius whatever
    the program does: no depth a machinist sets or checks), which gives drilled_depth_mm
    (its point below the stock's top it entered) and drilled_full_depth_mm (where the hole
    has the drill's full diameter; None when only the point's cone went in) instead
    (tool_shapes.drill_figures). max_chip_section_mm2: largest depth x feed. max_removal_rate_cm3_min.
    cut_time_s, air_time_s (feed moves that remove nothing), rapid_time_s, cycle_time_s.
    max_part_cut_mm: deepest point of the designed part its cutting zone reached (the
    finishing contour's own gouge, a few microns, shows here). plunge_mm: path length
    fed into stock straight down the axis (within PLUNGE_ANGLE of -Z). stock_after: shapely
    geometry of the bar after it; removed: what it removed.
    """

    name: str
    station: int
    feed_mm_rev: float
    removed_area_mm2: float
    removed_volume_mm3: float
    max_depth_of_cut_mm: float | None
    max_chip_section_mm2: float
    max_removal_rate_cm3_min: float
    cut_time_s: float
    air_time_s: float
    rapid_time_s: float
    max_part_cut_mm: float
    plunge_mm: float
    stock_after: object = field(repr=False)
    removed: object = field(repr=False)
    drilled_depth_mm: float | None = None
    drilled_full_depth_mm: float | None = None

    @property
    def cycle_time_s(self) -> float:
        """Cutting + air + rapid time, s (no tool change, no optional stop)."""
        return self.cut_time_s + self.air_time_s + self.rapid_time_s

    def figures(self) -> dict:
        """The numbers, for JSON."""
        return {"name": self.name, "tool": self.station, "feed_mm_rev": self.feed_mm_rev,
                "removed_area_mm2": self.removed_area_mm2, "removed_volume_mm3": self.removed_volume_mm3,
                "max_depth_of_cut_mm": self.max_depth_of_cut_mm,
                "max_chip_section_mm2": self.max_chip_section_mm2,
                "max_removal_rate_cm3_min": self.max_removal_rate_cm3_min,
                "cut_time_s": self.cut_time_s, "air_time_s": self.air_time_s,
                "rapid_time_s": self.rapid_time_s, "cycle_time_s": self.cycle_time_s,
                "max_part_cut_mm": self.max_part_cut_mm, "plunge_mm": self.plunge_mm,
                "drilled_depth_mm": self.drilled_depth_mm, "drilled_full_depth_mm": self.drilled_full_depth_mm}


@dataclass(frozen=True)
class Simulation:
    """The whole program against the stock: per operation figures, every contact."""

    operations: tuple[OperationFigures, ...]
    contacts: tuple[Contact, ...]
    stock_start: object = field(repr=False)
    part: object = field(repr=False)
    diameter_mode: bool = True
    parted: object = field(default=None, repr=False)

    @property
    def cycle_time_s(self) -> float:
        return sum(op.cycle_time_s for op in self.operations)

    def check(self) -> None:
        """Raise InputError naming the first block that touches what it must not."""
        if self.contacts:
            raise InputError(self.contacts[0].message(self.diameter_mode))

    def figures(self) -> dict:
        return {"operations": [op.figures() for op in self.operations],
                "cycle_time_s": self.cycle_time_s,
                "contacts": [{"kind": c.kind, "operation": c.operation, "block": c.label,
                              "area_mm2": c.area, "depth_mm": c.depth} for c in self.contacts]}
