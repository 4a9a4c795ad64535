"""The range each made part delivers: R10 of a Monte Carlo trial after calibration.

The design's R10 (optics.ranging.resolution.r10) is the range at which one pixel of
disparity costs 10 % of range, for the exact mirror and a sharp image. A made part, once
calibrated, adds its own disparity error d (px: the trial's disparity-equivalent error,
median over the band's points at the spec's range, tolerance.perturb._stereo), and the
lens's defocus blurs what the matcher matches: a matcher locates a feature to a fraction of
its width (matching_noise_px of a one-pixel feature, 0.1 px by default), so on an image
blurred into circles b px across it matches to matching_noise_px x b. The three add in
quadrature to the delivered disparity error

    e = sqrt(1 + d^2 + (matching_noise_px x b)^2)     (px; 1: the design's own pixel)

and, the range error being first order in the disparity error (dR / R = R d(gamma) /
(B cos el)), the delivered R10 is the design's divided by e. The depth error the robot
reads at a range R counts the matcher's real noise instead of the design's one pixel:
10 % x (R / R10_design) x sqrt(d^2 + (matching_noise_px x b)^2). Closed form per trial: nothing is traced beyond the
Monte Carlo's own stereo figures; b is the thin-lens blur of the design (optimize.focus,
the same for every trial: a trial's axial offset moves the focus by a fraction of the
depth of field and is left out).

Metres for ranges, px for image figures.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..design import Mirror
from ..optics.ranging.resolution import R10_FRACTION, delivered_r10, r10


@dataclass(frozen=True)
class DeliveredRange:
    """Per trial: r10_m (m), the delivered R10; disparity_px, the made part's own
    disparity error (px, median over the band at range_m); depth_error_pct (%), the depth
    error the robot reads at range_m (the matcher's noise and the part's error, without
    the design's one pixel). design_r10_m: the design's R10 (m); blur_px: the blur circle's
    diameter (px); matching_noise_px: the matcher's noise on a sharp feature (px)."""

    design_r10_m: float
    blur_px: float
    matching_noise_px: float
    range_m: float
    disparity_px: np.ndarray
    r10_m: np.ndarray
    depth_error_pct: np.ndarray

    @property
    def blur_noise_px(self) -> float:
        """The matcher's noise on the blurred image (px)."""
        return self.matching_noise_px * max(self.blur_px, 1.0)

    def summary(self) -> dict:
        """{design, p5, median} (m): the figure `tolerance --json` and `optimize` quote."""
        r = self.r10_m
        fin = np.where(np.isfinite(r), r, 0.0)
        return {"design": self.design_r10_m, "p5": float(np.quantile(fin, 0.05, method="inverted_cdf")),
                "median": float(np.quantile(fin, 0.5, method="inverted_cdf"))}

    def to_dict(self) -> dict:
        return {**self.summary(), "blur_px": self.blur_px, "matching_noise_px": self.matching_noise_px,
                "blur_noise_px": self.blur_noise_px, "range_m": self.range_m,
                "depth_error_pct_at_range": {
                    "p50": float(np.quantile(self.depth_error_pct, 0.5, method="inverted_cdf")),
                    "p95": float(np.quantile(self.depth_error_pct, 0.95, method="inverted_cdf"))},
                "model": "R10 / sqrt(1 + d^2 + (matching_noise_px x blur_px)^2), d the made part's "
                         "calibrated disparity error (px, band median at range_m)"}


def delivered_range(mirror: Mirror, disparity_px: np.ndarray, *, blur_px: float, matching_noise_px: float,
                    range_m: float, band: tuple[float, float] | None = None) -> DeliveredRange:
    """The delivered range of trials whose made parts show disparity errors disparity_px
    (px, (trials,)) at range_m (m): module doc. band: the elevations (rad) R10 is the
    median over (default the mirror's common band)."""
    design = r10(mirror, band)
    d = np.asarray(disparity_px, float)
    noise = matching_noise_px * max(float(blur_px), 1.0)
    r = delivered_r10(design, d, blur_px, matching_noise_px)
    depth = 100.0 * R10_FRACTION * range_m / design * np.sqrt(d * d + noise * noise)
    return DeliveredRange(design, float(blur_px), float(matching_noise_px), float(range_m), d, r, depth)
