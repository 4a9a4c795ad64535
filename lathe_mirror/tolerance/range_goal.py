"""The delivered range the allocation holds up (tolerance.allocation's second target).

The 5th percentile of the made parts' delivered R10 (tolerance.delivered) must reach a
fraction f of the design's R10; a part keeps f exactly when its own disparity error d (px,
the band's median at the spec's range) stays within delivered.disparity_limit_px. The
allocation models d as it models the judged criteria (sensitivity's response scans, read
here off the same evaluation) and counts the draws within that limit. The model's scale is
fitted to the traced trials' tail (fit_tail: its 95th percentile matches theirs), not by
least squares over all of them: the band's median moves by jumps as points drop in and out
(the seat's scan on the paper design: 0.034, 0.126, 0.124, 0.193 px at 0, 1/2, 1, 4/3 of
0.08 deg), and a least-squares fit there put the 95th percentile at 0.16 px against the
traced 0.23 px, while the p5 the allocation holds up reads exactly that tail.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from .delivered import disparity_limit_px
from .montecarlo import MonteCarloResult
from .sensitivity import Responses


@dataclass(frozen=True)
class RangeGoal:
    """The delivered range the allocation holds: the p5 of the trials' delivered R10 at
    least `fraction` of the design's (design_m, m); d_max_px, the disparity error that
    keeps it (delivered.disparity_limit_px)."""

    fraction: float
    design_m: float
    d_max_px: float

    @classmethod
    def of(cls, mc: MonteCarloResult, fraction: float) -> RangeGoal | None:
        """The goal for mc's design (None when mc carries no delivered range)."""
        dl = mc.delivered
        if dl is None:
            return None
        return cls(float(fraction), dl.design_r10_m, disparity_limit_px(fraction, dl.blur_noise_px))

    def p5(self, m: MonteCarloResult) -> float:
        return float(m.delivered.summary()["p5"])

    def kept(self, m: MonteCarloResult) -> bool:
        return self.p5(m) >= self.fraction * self.design_m

    def share(self, m: MonteCarloResult) -> float:
        """The share of m's trials whose delivered R10 keeps the fraction."""
        r = m.delivered.r10_m
        return float(np.mean(np.isfinite(r) & (r >= self.fraction * self.design_m)))

    def describe(self, m: MonteCarloResult) -> dict:
        p5 = self.p5(m)
        return {"min_fraction": self.fraction, "design_r10_m": self.design_m, "p5_m": p5,
                "p5_fraction": p5 / self.design_m, "disparity_limit_px": self.d_max_px, "kept": self.kept(m)}


def range_responses(resp: Responses, calibrated: bool) -> Responses:
    """The response scans of the made part's disparity error d (px, the band's median at
    the spec's range: what the delivered range reads), in the form of `resp`'s criteria
    (one column), read off the same evaluation."""
    med = resp.figures.judged(calibrated)["disparity_px_median"][:, 0]
    rows = {k: [resp.index[("phase", 0.0)] if f == 0.0 else resp.index[(k, float(f))] for f in resp.fractions]
            for k in resp.keys}
    phases = [resp.index[("phase", float(p))] for p in range(resp.phases.shape[0])]
    return dataclasses.replace(resp, criteria={k: med[r][:, None] for k, r in rows.items()},
                               phases=med[phases][:, None])


def disparity_of(m: MonteCarloResult) -> np.ndarray:
    """(trials, 1): each trial's made-part disparity error (px), the range surrogate's criterion."""
    return m.delivered.disparity_px[:, None]


#: The traced trials' quantile the range model matches (the p5 of R10 is d's 95th).
TAIL = 0.95
#: The range model's scale stays within 1 / SPAN .. SPAN.
SPAN = 16.0


def fit_tail(sur, phase: np.ndarray, x: dict[str, np.ndarray], actual: np.ndarray) -> None:
    """Set the one-criterion surrogate's scale so that its TAIL quantile over the traced
    trials (phase, offsets x) equals theirs (actual, (trials, 1)): bisection on log scale,
    the quantile rising with the scale."""
    a = np.asarray(actual, float)[:, 0]
    goal = float(np.quantile(np.where(np.isfinite(a), a, np.inf), TAIL, method="inverted_cdf"))
    lo, hi = np.log(1.0 / SPAN), np.log(SPAN)
    if np.isfinite(goal):
        for _ in range(40):
            mid = 0.5 * (lo + hi)
            sur.scale = np.array([np.exp(mid)])
            q = float(np.quantile(sur.criteria(phase, x)[:, 0], TAIL, method="inverted_cdf"))
            lo, hi = (mid, hi) if q < goal else (lo, mid)
    else:
        lo = hi
    sur.scale = np.array([np.exp(0.5 * (lo + hi))])

