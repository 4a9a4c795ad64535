"""The optics' results in the report: stereo depth error, the calibration (unified model
per lobe, made mirrors' reprojection), the renders' differences, range from the image."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from .base import RESULT, Range, Result, Stat, key, omitted, structured
from .made import ZoneFigures

#: The range (m) at which the report states the depth error of every mirror.
DEPTH_REPORT_M = 2.0
#: its JSON key in the stereo section
AT_KEY = f"at_{DEPTH_REPORT_M:g}_m"


# -- stereo ----------------------------------------------------------------------------

#: |Depth error| (%) at which a point counts as failed, and the value a failed or lost
#: point contributes to the band's figures (optics.stereo's module doc says why).
FAILED_PCT = 100.0


def capped_abs_error(error_pct: np.ndarray) -> np.ndarray:
    """|depth error| (%) capped at FAILED_PCT; NaN (a point not seen by both lobes) -> FAILED_PCT."""
    e = np.abs(np.asarray(error_pct, dtype=float))
    return np.where(np.isfinite(e), np.minimum(e, FAILED_PCT), FAILED_PCT)


def _band(error_pct: np.ndarray) -> dict:
    e = capped_abs_error(error_pct)
    return {"rms": float(np.sqrt(np.mean(e**2))), "max": float(np.max(e)),
            "median": float(np.median(e)), "failed": int(np.sum(e >= FAILED_PCT)),
            "lost": int(np.sum(~np.isfinite(error_pct))), "points": int(e.size)}


@dataclass(**RESULT)
class DepthAt(Result):
    """|Depth error| (%) over the band at one range, each point capped at 100 % (optics.stereo)."""

    rms: float
    max: float
    median: float
    failed: int
    lost: int
    points: int


@dataclass(**RESULT)
class DepthStats(Result):
    """Per range: RMS, max, median |depth error| (%), points failed, points lost."""

    rms: tuple[float, ...]
    max: tuple[float, ...]
    median: tuple[float, ...]
    failed: tuple[int, ...]
    lost: tuple[int, ...]


@dataclass(**RESULT)
class DepthCurve(Result):
    """Depth error (%) against range (m) at elevations across the common band
    (optics.stereo.depth_error_curve, optics.calibrated_stereo): the signed error per
    (range, elevation) and per range the band's capped figures; `at(range_m)`: one range's;
    `table()`: per range."""

    ranges_m: tuple[float, ...]
    elevations_deg: tuple[float, ...]
    depth_error_pct: DepthStats
    signed_error_pct: tuple[tuple[float, ...], ...]

    @classmethod
    def of(cls, ranges_m, elevations, error_pct) -> DepthCurve:
        """The curve of ranges_m (m), elevations (rad) and the signed error_pct of shape
        (len(ranges_m), len(elevations)) (NaN: a point the made mirror does not show to
        both lobes)."""
        err = np.asarray(error_pct, dtype=float)
        rows = [_band(row) for row in err]
        return cls(ranges_m=tuple(float(x) for x in ranges_m),
                   elevations_deg=tuple(float(math.degrees(x)) for x in elevations),
                   depth_error_pct=DepthStats(**{k: tuple(r[k] for r in rows)
                                                 for k in ("rms", "max", "median", "failed", "lost")}),
                   signed_error_pct=tuple(tuple(float(v) for v in row) for row in err))

    @property
    def error_pct(self) -> np.ndarray:
        """The signed depth error (%) as an array, (len(ranges_m), len(elevations_deg))."""
        return np.asarray(self.signed_error_pct, dtype=float).reshape(len(self.ranges_m), len(self.elevations_deg))

    def at(self, range_m: float) -> dict:
        """|Depth error| (%) over the elevations at one range (m), each point capped at
        FAILED_PCT and a lost point (NaN) counted at FAILED_PCT: {"rms", "median", "max"};
        "failed": points at the cap (lost ones included), "lost": the lost ones alone,
        "points": all of them. The median does not depend on the cap."""
        ranges = np.asarray(self.ranges_m)
        i = int(np.argmin(np.abs(ranges - range_m)))
        if not math.isclose(ranges[i], range_m, rel_tol=1e-9):
            raise ValueError(f"range {range_m} m is not on the curve")
        return _band(np.asarray(self.signed_error_pct[i], dtype=float))

    def table(self) -> np.ndarray:
        d = self.depth_error_pct
        return structured(list(zip(self.ranges_m, d.rms, d.max, d.median, d.failed, d.lost)),
                          [("range_m", "f8"), ("rms_pct", "f8"), ("max_pct", "f8"), ("median_pct", "f8"),
                           ("failed", "i8"), ("lost", "i8")])


@dataclass(**RESULT)
class StereoFigures(Result):
    """Each made mirror's depth error against range, and at DEPTH_REPORT_M."""

    definition: str
    baseline_mm: float
    curves: dict[str, DepthCurve]
    at: dict[str, DepthAt] = key(AT_KEY)


# -- calibration -----------------------------------------------------------------------


@dataclass(**RESULT)
class LobeModel(Result):
    """A lobe's design model (unified, Kalibr's omni-radtan; px)."""

    name: str
    xi: float
    gamma_px: float
    fu_px: float
    fv_px: float
    cx_px: float
    cy_px: float
    k1: float
    k2: float
    annulus_px: Range
    viewpoint_z_mm: float
    image_size_px: tuple[int, int]


@dataclass(**RESULT)
class DesignCalibration(Result):
    frame: str
    lobes: tuple[LobeModel, ...]
    t_cn_cnm1_mm: tuple[float, float, float]


@dataclass(**RESULT)
class Reprojection(Result):
    reprojection_error_px: Stat


@dataclass(**RESULT)
class Refit(Result):
    xi: float
    gamma_px: float
    fu_px: float
    fv_px: float
    cx_px: float
    cy_px: float
    k1: float
    k2: float
    principal_point: str
    reprojection_error_px: Stat


@dataclass(**RESULT)
class LobeCalibration(Result):
    name: str
    pixels: int
    pixels_excluded: int
    design: Reprojection
    refit: Refit


@dataclass(**RESULT)
class MadeCalibration(Result):
    range_m: float
    lobes: tuple[LobeCalibration, ...]
    zones: ZoneFigures


@dataclass(**RESULT)
class CalibrationFigures(Result):
    """The design's unified models and, per made mirror, the design model's reprojection
    error and what a refitted model leaves (optics.camera_model.calibration_figures)."""

    design: DesignCalibration
    made: dict[str, MadeCalibration]


# -- renders ---------------------------------------------------------------------------


@dataclass(**RESULT)
class ImageDifference(Result):
    """A made mirror's render against the exact one's (optics.render.image_difference)."""

    rms: float
    ssim: float


@dataclass(**RESULT)
class LensFigures(Result):
    """The lens the images are blurred by (optics.defocus.Lens)."""

    f_number: float
    focus_mm: float
    object_range_mm: float


@dataclass(**RESULT)
class LobeBlur(Result):
    name: str
    blur_px: dict[str, float]


@dataclass(**RESULT)
class DefocusFigures(Result):
    """The thin-lens blur circle per lobe (px) the images carry (optics.defocus.blur_figures)."""

    lens: LensFigures
    lobes: tuple[LobeBlur, ...]
    definition: str


@dataclass(**RESULT)
class RenderFigures(Result):
    against_exact: dict[str, ImageDifference]
    defocus: DefocusFigures | None = omitted()


# -- range from the image --------------------------------------------------------------


@dataclass(**RESULT)
class ResolutionRow(Result):
    range_m: float
    one_px_pct: tuple[float, ...]
    one_px_band_median_pct: float
    matcher_pct: tuple[float, ...] | None = omitted()
    matcher_band_median_pct: float | None = omitted()


@dataclass(**RESULT)
class ResolutionTable(Result):
    """The range error one pixel of disparity causes, and the matcher's precision, by
    range and elevation (optics.ranging.resolution)."""

    elevations_deg: tuple[float, ...]
    parallax_per_px_deg: tuple[float, ...]
    matcher_precision_deg: float
    rows: tuple[ResolutionRow, ...]
    r10_m: float

    def table(self) -> np.ndarray:
        n = len(self.elevations_deg)
        nan = (np.nan,) * n
        return structured([(r.range_m, *r.one_px_pct, r.one_px_band_median_pct, *(r.matcher_pct or nan),
                            np.nan if r.matcher_band_median_pct is None else r.matcher_band_median_pct)
                           for r in self.rows],
                          [("range_m", "f8"), *((f"one_px_pct_{i}", "f8") for i in range(n)),
                           ("one_px_band_median_pct", "f8"), *((f"matcher_pct_{i}", "f8") for i in range(n)),
                           ("matcher_band_median_pct", "f8")])


@dataclass(**RESULT)
class RangeGrid(Result):
    n_elevation: int
    n_azimuth: int
    elevation_step_deg: float
    band_deg: Range


@dataclass(**RESULT)
class SurfaceRanged(Result):
    pixels: int
    valid_fraction: float | None


@dataclass(**RESULT)
class RangeError(Result):
    median: float
    rms: float
    signed_median: float


@dataclass(**RESULT)
class DisparityError(Result):
    median: float
    rms: float
    signed_median: float
    precision: float


@dataclass(**RESULT)
class RangeBin(Result):
    range_m: tuple[float, float]
    pixels: int
    valid_fraction: float
    range_error_pct: RangeError
    model_1px_pct: float
    model_matcher_pct: float


@dataclass(**RESULT)
class ErrorCurve(Result):
    range_m: tuple[float, ...]
    measured_pct: tuple[float, ...]
    model_1px_pct: tuple[float, ...]
    model_matcher_pct: tuple[float, ...]
    pixels: tuple[int, ...]
    precision_px: float


@dataclass(**RESULT)
class RangeFigures(Result):
    """One mirror's range from the image against the room's true range; `table()`: its bins."""

    grid: RangeGrid
    matcher: dict[str, Any]
    baseline_mm: float
    r10_m: float
    parallax_per_px_deg: float
    pixels: int
    valid_fraction: float
    valid_by_surface: dict[str, SurfaceRanged]
    true_range_m: Range
    range_error_pct: RangeError
    disparity_error_px: DisparityError
    model_precision_px: float | None
    bins: tuple[RangeBin, ...]
    error_curve: ErrorCurve | None = omitted()

    def table(self) -> np.ndarray:
        return structured([(b.range_m[0], b.range_m[1], b.pixels, b.valid_fraction, b.range_error_pct.median,
                            b.range_error_pct.rms, b.range_error_pct.signed_median, b.model_1px_pct,
                            b.model_matcher_pct) for b in self.bins],
                          [("range_min_m", "f8"), ("range_max_m", "f8"), ("pixels", "i8"), ("valid_fraction", "f8"),
                           ("median_pct", "f8"), ("rms_pct", "f8"), ("signed_median_pct", "f8"),
                           ("model_1px_pct", "f8"), ("model_matcher_pct", "f8")])


@dataclass(**RESULT)
class RangingFigures(Result):
    definition: str
    supersample: int
    matcher_precision_px: float
    resolution: ResolutionTable
    mirrors: dict[str, RangeFigures]
    defocus: DefocusFigures | None = omitted()
