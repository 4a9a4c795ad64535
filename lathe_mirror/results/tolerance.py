"""The tolerance analysis's results (tolerance.runs.tolerance_analysis): per toleranced
program the Monte Carlo, the sensitivity, the inverse sensitivity, the stereo table, the
allocation and the verdict against the spec. Dicts keyed by a criterion's or a
parameter's name stay dicts (their keys are the spec's and the settings')."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

import numpy as np

from .base import RESULT, Range, Result, Stat, key, omitted, structured
from .made import MadeMirror, ZoneFigures


@dataclass(**RESULT)
class ToleranceSpec(Result):
    """The spec the parts are judged against ([spec])."""

    image_displacement_px: float
    depth_error_pct: float
    depth_range_m: float
    slope_error_rad: float
    calibrated: bool
    outlier_pct: float


@dataclass(**RESULT)
class Check(Result):
    """One criterion on the nominal part: its limit, the nominal figure, pass."""

    limit: float
    nominal: float
    range_m: float | None = omitted()
    depth_error_pct: float | None = omitted()
    passed: bool = key("pass")


@dataclass(**RESULT)
class Verdict(Result):
    """A program's verdict: each check, the nominal part's pass, the yield (Wilson 95 %)."""

    checks: dict[str, Check]
    nominal_pass: bool
    calibrated: bool
    yield_: float = key("yield")
    yield_wilson95: tuple[float, float]
    trials: int
    allocation: str | None = omitted()

    @property
    def passed_trials(self) -> int:
        return round(self.yield_ * self.trials)


@dataclass(**RESULT)
class Spread(Result):
    """A figure's distribution over the trials."""

    mean: float
    p05: float
    p50: float
    p95: float
    max: float


@dataclass(**RESULT)
class LobeSpread(Result):
    name: str
    image_displacement_px_rms: Spread
    image_displacement_px_max: Spread
    image_displacement_px_median: Spread
    outlier_pct: Spread
    ray_error_deg_rms: Spread
    viewpoint_spread_mm_rms: Spread


@dataclass(**RESULT)
class TrialFigures(Result):
    """The trials' image (per lobe) and stereo figures, raw or calibrated."""

    lobes: tuple[LobeSpread, ...]
    disparity_px_median: Spread
    disparity_px_p90: Spread
    within_5_pct: Spread
    within_10_pct: Spread
    seen_fraction: Spread
    depth_error_pct_rms: Spread


@dataclass(**RESULT)
class SurfaceSpreadLobe(Result):
    name: str
    slope_error_rad: Spread
    normal_deviation_mm: Spread


@dataclass(**RESULT)
class SurfaceSpread(Result):
    lobes: tuple[SurfaceSpreadLobe, ...]


@dataclass(**RESULT)
class MonteCarloFigures(Result):
    """A program's Monte Carlo (tolerance.montecarlo.MonteCarloResult.to_dict); `table()`:
    one row per trial (its drawn parameters, judged figures per lobe, pass)."""

    program: str
    seed: int
    trials: int
    calibrated: bool
    tolerances: dict[str, float]
    yield_: float = key("yield")
    passed: int
    yield_wilson95: tuple[float, float]
    pass_fraction: dict[str, float]
    pass_fraction_wilson95: dict[str, tuple[float, float]]
    limits: dict[str, float]
    spec: ToleranceSpec
    judged: dict[str, Spread]
    raw: TrialFigures
    calibrated_figures: TrialFigures
    surface: SurfaceSpread
    lost_pixel_fraction: Spread
    zones: ZoneFigures | None
    calibration_rotation_deg: Spread
    note: str
    per_trial: dict[str, list] | None = omitted()
    # the range the made parts deliver (tolerance.delivered): {design, p5, median} (m), and its model's inputs
    delivered_r10_m: dict[str, float] | None = omitted()
    delivered: dict[str, Any] | None = omitted()

    def table(self) -> np.ndarray:
        if self.per_trial is None:
            raise ValueError("the Monte Carlo was kept without its trials")
        cols, dtype = [], []
        for name, col in self.per_trial.items():
            a = np.asarray(col)
            kind = "?" if a.dtype == bool else "f8"
            if a.ndim == 2:  # per lobe
                for k, lobe in enumerate(("inner", "outer")[:a.shape[1]]):
                    cols.append(a[:, k])
                    dtype.append((f"{name}_{lobe}", kind))
            else:
                cols.append(a)
                dtype.append(("pass" if name == "pass" else name, kind))
        return structured(list(zip(*cols)), dtype)


@dataclass(**RESULT)
class FigureSet(Result):
    """A part's judged figures (nominal or one sensitivity case), raw or calibrated."""

    image_displacement_px_rms: tuple[float, ...]
    outlier_pct: tuple[float, ...]
    disparity_px_median: float
    disparity_px_p90: float
    depth_error_pct_rms: float


@dataclass(**RESULT)
class SensitivityCase(Result):
    """One side of a parameter (or the nominal part): raw and calibrated figures, slope error, pass."""

    resolution_mm: float | None = omitted()
    raw: FigureSet
    calibrated: FigureSet
    slope_error_rad_rms: tuple[float, ...]
    passed: bool = key("pass")


@dataclass(**RESULT)
class SensitivityRow(Result):
    """A parameter at -/+ its tolerance, the others nominal (the lattice phase: best and
    worst phase; the controller resolution: re-planned). `note` where the row needs one."""

    parameter: str
    what: str
    tolerance: float | str
    unit: str
    note_first: str | None = omitted("note")  # the resolution row states its note first
    minus: SensitivityCase
    plus: SensitivityCase
    note: str | None = omitted()

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> SensitivityRow:
        keys = list(d)
        if "note" in d and keys.index("note") < keys.index("minus"):
            rest = {k: v for k, v in d.items() if k != "note"}
            # (a slots dataclass is a new class: no zero-argument super())
            return dataclasses.replace(Result.from_dict.__func__(cls, rest), note_first=d["note"])
        return Result.from_dict.__func__(cls, d)

    @property
    def remark(self) -> str | None:
        return self.note_first if self.note_first is not None else self.note


@dataclass(**RESULT)
class Sensitivity(Result):
    """Each parameter at -/+ its tolerance; `table()`: one row per parameter and side."""

    nominal: SensitivityCase
    rows: tuple[SensitivityRow, ...]
    nominal_values: dict[str, float]

    def table(self) -> np.ndarray:
        out = []
        for r in self.rows:
            for side in ("minus", "plus"):
                c = getattr(r, side)
                out.append((r.parameter, side, *c.raw.image_displacement_px_rms,
                            *c.calibrated.image_displacement_px_rms, c.raw.disparity_px_p90,
                            c.calibrated.disparity_px_p90, c.raw.depth_error_pct_rms,
                            c.calibrated.depth_error_pct_rms, *c.slope_error_rad_rms, c.passed))
        return structured(out, [("parameter", "U32"), ("side", "U5"),
                                ("raw_image_displacement_px_rms_inner", "f8"),
                                ("raw_image_displacement_px_rms_outer", "f8"),
                                ("calibrated_image_displacement_px_rms_inner", "f8"),
                                ("calibrated_image_displacement_px_rms_outer", "f8"),
                                ("raw_disparity_px_p90", "f8"), ("calibrated_disparity_px_p90", "f8"),
                                ("raw_depth_error_pct_rms", "f8"), ("calibrated_depth_error_pct_rms", "f8"),
                                ("slope_error_rad_rms_inner", "f8"), ("slope_error_rad_rms_outer", "f8"),
                                ("pass", "?")])


@dataclass(**RESULT)
class InverseRow(Result):
    """The largest +/- value of a parameter that alone keeps every criterion in its share."""

    parameter: str
    unit: str
    tolerance: float
    largest: float
    limited_by: str
    per_criterion: dict[str, float]
    scanned_to: float
    no_margin: tuple[str, ...]
    no_margin_why: str


@dataclass(**RESULT)
class StereoSide(Result):
    disparity_px_median: tuple[float, ...]
    disparity_px_p90: tuple[float, ...]
    within_5_pct: tuple[float, ...]
    within_10_pct: tuple[float, ...]
    seen_fraction: tuple[float, ...]
    depth_error_pct_rms: tuple[float, ...]


@dataclass(**RESULT)
class ToleranceStereo(Result):
    """The nominal part's stereo figures per range, raw and calibrated; `table()`: per range."""

    ranges_m: tuple[float, ...]
    matching_noise_px: float
    matching_floor_pct: tuple[float, ...]
    disparity_limit_px: float
    raw: StereoSide
    calibrated: StereoSide

    def side(self, label: str) -> StereoSide:
        return self.raw if label == "raw" else self.calibrated

    def table(self) -> np.ndarray:
        names = [f.name for f in dataclasses.fields(StereoSide)]
        rows = [(r, fl, *(getattr(s, n)[i] for s in (self.raw, self.calibrated) for n in names))
                for i, (r, fl) in enumerate(zip(self.ranges_m, self.matching_floor_pct))]
        return structured(rows, [("range_m", "f8"), ("matching_floor_pct", "f8"),
                                 *((f"{s}_{n}", "f8") for s in ("raw", "calibrated") for n in names)])


@dataclass(**RESULT)
class ZoneLobeDisplacement(Result):
    name: str
    image_displacement_px: Stat
    zone_px: Range


@dataclass(**RESULT)
class NominalOverZone(Result):
    """A part's image displacement per lobe over the zone the criteria judge (optics.radial)."""

    surface: str
    made_mirror: str
    zones: str
    lobes: tuple[ZoneLobeDisplacement, ...]


@dataclass(**RESULT)
class AllocationRound(Result):
    round: int
    aim: float
    surrogate_yield: float
    yield_: float = key("yield")
    yield_wilson95: tuple[float, float]
    seed: int
    tolerances: dict[str, float]
    range_aim: float | None = omitted()
    surrogate_range_share: float | None = omitted()
    range_share: float | None = omitted()
    delivered_r10_p5_m: float | None = omitted()


@dataclass(**RESULT)
class AllocationDelivered(Result):
    """The allocation's second target: the delivered R10's p5 (m) against min_fraction of
    the design's R10 (m), and the made-part disparity error (px) that keeps it."""

    min_fraction: float
    design_r10_m: float
    p5_m: float
    p5_fraction: float
    disparity_limit_px: float
    kept: bool


@dataclass(**RESULT)
class AllocatedTolerance(Result):
    parameter: str
    what: str
    unit: str
    tolerance: float
    allocated: float
    factor: float
    cost: float
    tighten: bool


@dataclass(**RESULT)
class Surrogate(Result):
    draws: int
    yield_at_configured: float
    yield_on_monte_carlo_trials: float
    monte_carlo_yield: float
    agreement: float
    agreement_unfitted: float
    scale: dict[str, float]


@dataclass(**RESULT)
class Allocation(Result):
    """The least-cost tolerances that reach the target yield, confirmed by a Monte Carlo."""

    program: str
    target_yield: float
    trials: int
    reached: bool
    yield_: float = key("yield")
    yield_wilson95: tuple[float, float]
    seed: int
    confirmed_by: str
    rounds: tuple[AllocationRound, ...]
    tolerances: tuple[AllocatedTolerance, ...]
    cost_ratio: float
    surrogate: Surrogate
    unreachable: str
    delivered: AllocationDelivered | None = omitted()
    statement: str

    def table(self) -> np.ndarray:
        """One row per parameter: configured, allocated, factor, relative cost, tighten."""
        return structured([(t.parameter, t.unit, t.tolerance, t.allocated, t.factor, t.cost, t.tighten)
                           for t in self.tolerances],
                          [("parameter", "U32"), ("unit", "U8"), ("tolerance", "f8"), ("allocated", "f8"),
                           ("factor", "f8"), ("cost", "f8"), ("tighten", "?")])


@dataclass(**RESULT)
class ProgramTolerance(Result):
    """One toleranced program: its part, Monte Carlo, sensitivity, stereo, allocation, verdict."""

    made_mirror: MadeMirror
    surfaces: str
    nominal_polish_time_s: float
    limits: dict[str, float]
    monte_carlo: MonteCarloFigures
    sensitivity: Sensitivity
    inverse_sensitivity: tuple[InverseRow, ...]
    stereo: ToleranceStereo
    nose_radii_cut: int
    nominal_over_zone: NominalOverZone
    as_machined_over_zone: NominalOverZone
    allocation: Allocation | None = omitted()
    verdict: Verdict


@dataclass(**RESULT)
class ToleranceAnalysis(Result):
    """The tolerance analysis of every toleranced program ([tolerance])."""

    spec: ToleranceSpec
    distribution: str
    tolerances: dict[str, float]
    cost: dict[str, float]
    seed: int
    trials: int
    target_yield: float
    seat_pivot_mm: float
    lattice_phases: int
    nose_step_mm: float
    programs: dict[str, ProgramTolerance]

    @property
    def verdicts(self) -> dict[str, Verdict]:
        return {name: t.verdict for name, t in self.programs.items()}
