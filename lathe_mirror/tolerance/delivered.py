"""The range each made part delivers: R10 of a Monte Carlo trial after calibration.

Three R10s (optics.ranging.resolution), in metres:

- sharp: the range at which one pixel of disparity costs 10 % of range, for the exact
  mirror and a sharp image (`r10`; the pixel alone limits it);
- design: what the nominal part delivers: the lens's blur (defocus and the Airy disc,
  `blur_circle_px`, b px) makes the matcher's disparity noise n = hypot(matching_noise_px,
  BLUR_NOISE_PER_PX x b) (an SGBM measurement, the constant's comment), and
  design = sharp / sqrt(1 + n^2) (`design_r10`): the range `optimize` promises;
- delivered, per trial: the made part, once calibrated, adds its own disparity error d
  (px: the trial's disparity-equivalent error, median over the band's points at the
  spec's range, tolerance.perturb._stereo), delivered = sharp / sqrt(1 + d^2 + n^2).

The errors add in quadrature in units of the design's pixel, and the range error is first
order in the disparity error (dR / R = R d(gamma) / (B cos el)). delivered / design is
then what manufacturing costs, the design's own blur being counted in both. The depth
error the robot reads at a range R counts the matcher's real noise instead of the design's
one pixel: 10 % x (R / sharp) x sqrt(d^2 + n^2). Closed form per trial: nothing is traced
beyond the Monte Carlo's own stereo figures; b is the design's (optimize.focus, the same
for every trial: a trial's axial offset moves the focus by a fraction of the depth of
field and is left out), taken for scene points at optimize.focus_range_m, not at range_m:
the virtual images sit near the mirror's focal points whatever the scene's range, so the
largest blur moves by at most 2.3 % from 0.2 m to infinity on the paper default, the
delivered R10 by 0.09 % (docs/explanation/monte-carlo.md, "The blur at other ranges").

Metres for ranges, px for image figures.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..design import Mirror
from ..optics.ranging.resolution import BLUR_NOISE_PER_PX, R10_FRACTION, blur_noise_px, delivered_r10, design_r10, r10


@dataclass(frozen=True)
class DeliveredRange:
    """Per trial: r10_m (m), the delivered R10; disparity_px, the made part's own
    disparity error (px, median over the band at range_m); depth_error_pct (%), the depth
    error the robot reads at range_m (the matcher's noise and the part's error, without
    the design's one pixel). design_r10_m: the nominal part's R10 with its blur (m);
    sharp_r10_m: the pixel-limited R10 (m); blur_px: the blur circle's diameter (px);
    matching_noise_px: the matcher's noise on a sharp feature (px)."""

    design_r10_m: float
    sharp_r10_m: float
    blur_px: float
    matching_noise_px: float
    range_m: float
    disparity_px: np.ndarray
    r10_m: np.ndarray
    depth_error_pct: np.ndarray

    @property
    def blur_noise_px(self) -> float:
        """The matcher's noise on the blurred image (px)."""
        return blur_noise_px(self.blur_px, self.matching_noise_px)

    def summary(self) -> dict:
        """{design, sharp, p5, median} (m): the figure `tolerance --json` and `optimize`
        quote (p5 / design: what manufacturing costs)."""
        r = self.r10_m
        fin = np.where(np.isfinite(r), r, 0.0)
        return {"design": self.design_r10_m, "sharp": self.sharp_r10_m,
                "p5": float(np.quantile(fin, 0.05, method="inverted_cdf")),
                "median": float(np.quantile(fin, 0.5, method="inverted_cdf"))}

    def to_dict(self) -> dict:
        return {**self.summary(), "blur_px": self.blur_px, "matching_noise_px": self.matching_noise_px,
                "blur_noise_px": self.blur_noise_px, "range_m": self.range_m,
                "depth_error_pct_at_range": {
                    "p50": float(np.quantile(self.depth_error_pct, 0.5, method="inverted_cdf")),
                    "p95": float(np.quantile(self.depth_error_pct, 0.95, method="inverted_cdf"))},
                "model": "sharp R10 / sqrt(1 + d^2 + n^2), n = hypot(matching_noise_px, "
                         f"{BLUR_NOISE_PER_PX:g} x blur_px), d the made part's calibrated disparity error "
                         "(px, band median at range_m); design: d = 0"}


def delivered_range(mirror: Mirror, disparity_px: np.ndarray, *, blur_px: float, matching_noise_px: float,
                    range_m: float, band: tuple[float, float] | None = None) -> DeliveredRange:
    """The delivered range of trials whose made parts show disparity errors disparity_px
    (px, (trials,)) at range_m (m): module doc. band: the elevations (rad) R10 is the
    median over (default the mirror's common band)."""
    sharp = r10(mirror, band)
    d = np.asarray(disparity_px, float)
    noise = blur_noise_px(blur_px, matching_noise_px)
    r = delivered_r10(sharp, d, blur_px, matching_noise_px)
    depth = 100.0 * R10_FRACTION * range_m / sharp * np.sqrt(d * d + noise * noise)
    design = float(design_r10(sharp, blur_px, matching_noise_px))
    return DeliveredRange(design, sharp, float(blur_px), float(matching_noise_px), float(range_m), d, r, depth)


#: The delivered R10's percentile the allocation holds up (its 5th, as `summary` quotes).
P5 = 0.05


def disparity_limit_px(fraction: float, blur_noise: float) -> float:
    """The largest made-part disparity error d (px) whose delivered R10 keeps `fraction` of
    the design's: sharp / sqrt(1 + d^2 + n^2) >= fraction x sharp / sqrt(1 + n^2), i.e.
    d^2 <= (1 + n^2)(1 / fraction^2 - 1), n the matcher's noise on the blurred image."""
    return float(np.sqrt((1.0 + blur_noise**2) * (1.0 / fraction**2 - 1.0)))


def range_share(n: int) -> float:
    """The share of n trials that must keep the range for their P5 quantile (inverted_cdf,
    as `summary`) to keep it: at most ceil(P5 n) - 1 of them below."""
    return 1.0 - (int(np.ceil(P5 * n - 1e-9)) - 1) / n

