"""The report's polishing study (report.polishing_study): both programs' polishing curves,
the time the objective chooses, form against facets, pre-compensation, the process
presets side by side. `params` is [polish] as plain data (its keys are the settings')."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from .base import RESULT, Range, Result, Stat, key, omitted, structured
from .optics import DepthAt


#: a figure along the curve (one value per time) or at one time (the optimum)
Figure = tuple[float, ...] | float


@dataclass(**RESULT)
class LapLobe(Result):
    """A lobe's lap: its reach, the stroke's dwell-time profile, the removal rate along r."""

    reach_mm: tuple[float, float]
    lap_radius_mm: float
    stroke_centres_mm: tuple[float, ...]
    dwell_weight: tuple[float, ...]
    r_mm: tuple[float, ...]
    removal_rate_um_per_h: tuple[float, ...]


@dataclass(**RESULT)
class LapPlan(Result):
    lobes: tuple[LapLobe, ...]


@dataclass(**RESULT)
class MeanMax(Result):
    mean: Figure
    max: Figure


@dataclass(**RESULT)
class Series(Result):
    """An RMS and a maximum per polishing time (or at one time, in a curve's optimum)."""

    rms: Figure
    max: Figure


@dataclass(**RESULT)
class CurveLobe(Result):
    """A lobe's figures along the polishing curve (roughness, TIS, haze with a process's finish)."""

    name: str
    slope_error_rad: Series
    normal_deviation_mm: Series
    form_change_mm: Series
    image_displacement_px: Series
    roughness_nm: Series | None = omitted()
    tis: MeanMax | None = omitted()
    haze: MeanMax | None = omitted()


@dataclass(**RESULT)
class Combined(Result):
    """Both lobes' figures: image displacement (px), slope error (rad), the calibrated
    stereo residual and the depth error (%)."""

    image_displacement_px: Figure
    slope_error_rad: Figure
    stereo_residual_pct: Figure
    depth_error_pct: Figure


@dataclass(**RESULT)
class CurveOptimum(Result):
    time_s: float
    inside_range: bool
    objective: str
    combined: Combined
    combined_image_displacement_px_rms: float
    lobes: tuple[CurveLobe, ...]


@dataclass(**RESULT)
class PolishCurveFigures(Result):
    """A program's polishing curve (optics.polishing_curve.PolishCurve.to_dict); `table()`:
    per time, both lobes' figures."""

    times_s: tuple[float, ...]
    objective: str
    objective_tolerance: float
    range_m: float
    combined: Combined
    combined_image_displacement_px_rms: tuple[float, ...]
    lobes: tuple[CurveLobe, ...]
    chosen_time_s: dict[str, float]
    optimum: CurveOptimum

    def table(self) -> np.ndarray:
        c = self.combined
        return structured(list(zip(self.times_s, c.image_displacement_px, c.slope_error_rad, c.stereo_residual_pct,
                                   c.depth_error_pct)),
                          [("time_s", "f8"), ("image_displacement_px", "f8"), ("slope_error_rad", "f8"),
                           ("stereo_residual_pct", "f8"), ("depth_error_pct", "f8")])


@dataclass(**RESULT)
class BeforeAfter(Result):
    before: float
    at_optimum: float
    unit: str | None = omitted()


@dataclass(**RESULT)
class PolishSummary(Result):
    """The chosen time, the figures before and at it, and the sentence `polish` prints."""

    program: str
    objective: str
    assumption: str
    range_m: float
    optimum_time_s: float
    optimum_inside_range: bool
    chosen_time_s: dict[str, float]
    range_s: tuple[float, float]
    objective_value: BeforeAfter
    image_displacement_px_rms: BeforeAfter
    stereo_residual_pct: BeforeAfter
    depth_error_pct: BeforeAfter
    form_cost_mm: dict[str, Stat]
    statement: str


@dataclass(**RESULT)
class Decomposition(Result):
    """Depth error (and calibrated stereo residual) of a polished part, of the design with
    its form alone, its facets alone, the lap's removal alone."""

    time_s: float
    lap: str
    range_m: float
    form_degree: int
    clear_edge_mm: float
    depth_error_pct: dict[str, DepthAt]
    stereo_residual_pct: dict[str, DepthAt] | None = omitted()


@dataclass(**RESULT)
class PolishedLobe(Result):
    name: str
    form_change_mm: Stat
    form_pv_mm: float
    slope_error_rad: Stat
    normal_deviation_mm: Stat
    image_displacement_px: Stat


@dataclass(**RESULT)
class PolishedSurface(Result):
    """What the polishing section states of a made surface (report.polishing_study.surface_figures)."""

    lobes: tuple[PolishedLobe, ...]
    image_displacement_px_rms: float
    stereo_residual_pct: float
    depth_error_pct: float
    range_m: float


@dataclass(**RESULT)
class Allowance(Result):
    min_um: float
    max_um: float


@dataclass(**RESULT)
class Precompensation(Result):
    """A program polished as programmed on the design and on the design lowered by the allowance."""

    program: str
    time_s: float
    allowance: dict[str, Allowance]
    without: PolishedSurface
    with_: PolishedSurface = key("with")


@dataclass(**RESULT)
class ScatterLobe(Result):
    """A lobe's roughness, TIS and haze (optics.scatter.haze_figures)."""

    name: str
    roughness_nm: Stat
    tis: MeanMax
    haze: MeanMax
    order_spacing_deg: float
    order_spacing_px: Range


@dataclass(**RESULT)
class ProcessRow(Result):
    """A process preset: turning, polish, the made surface's figures (or why it cannot cut)."""

    name: str
    label: str
    program: str
    nose_radius_mm: float
    feed_mm: float
    resolution_mm: float
    cannot_cut: str | None = omitted()
    feed_mark_pv_nm: float | None = omitted()
    feed_mark_rms_nm: float | None = omitted()
    feed_mark_period_um: float | None = omitted()
    polish_time_s: float | None = omitted()
    as_turned: tuple[ScatterLobe, ...] | None = omitted()
    finished: tuple[ScatterLobe, ...] | None = omitted()
    image_displacement_px_rms: float | None = omitted()
    stereo_residual_pct: float | None = omitted()
    depth_error_pct: float | None = omitted()
    slope_error_rad: tuple[Stat, ...] | None = omitted()


@dataclass(**RESULT)
class PolishingStudy(Result):
    """The report's polishing section."""

    params: dict[str, Any]
    model: str
    lap_plan: LapPlan
    objective: str
    paper_program: PolishCurveFigures
    best_program: PolishCurveFigures
    summary: PolishSummary
    summary_best: PolishSummary
    decomposition: dict[str, Decomposition]
    precompensation: dict[str, Precompensation]
    processes: tuple[ProcessRow, ...]
    precompensated_programs: bool
    conclusion: str
