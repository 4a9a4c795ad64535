"""The allocation's second target: the delivered R10's p5 within a fraction of the design's.

The closed form is checked by hand (the disparity model sharp / sqrt(1 + d^2 + n^2)), the
p5 of the Monte Carlo's delivered R10 is re-counted from its per-trial table (and that
table recomputed from the trials' disparity errors by the same hand formula), and the
allocation is shown to tighten further when the p5 binds and not when only the yield does.

The cases: the paper design at tests/test_tolerance.py's fast settings (2 lattice phases,
200 trials), the seat held to 0.08 deg (yield 96.5 %, p5 97.3 % of the design's R10: the
yield holds, a 98 % range target does not) and to 0.3 deg (yield 28.5 %: the yield binds,
the range at 90 % does not).
"""

from __future__ import annotations

import copy
import dataclasses
import json
import math

import numpy as np
import pytest

from lathe_mirror.enums import Program
from lathe_mirror.results.tolerance import Allocation
from lathe_mirror.settings import from_config
from lathe_mirror.tolerance.allocation import allocate
from lathe_mirror.tolerance.delivered import disparity_limit_px, range_share
from lathe_mirror.tolerance.montecarlo import run_monte_carlo
from lathe_mirror.tolerance.runs import tolerance_context
from lathe_mirror.tolerance.sensitivity import responses

TRIALS = 200


def test_disparity_limit_keeps_the_fraction_by_hand():
    """f = 0.9 with the matcher's noise n = 0.5 px: d_max^2 = 1.25 x (1 / 0.81 - 1) =
    23.75 / 81; a part at d_max delivers 1 / sqrt(1 + 23.75 / 81 + 0.25) = 0.80498 of the
    sharp R10, the design 1 / sqrt(1.25) = 0.89443: 0.9 of it."""
    d = disparity_limit_px(0.9, 0.5)
    assert d == pytest.approx(math.sqrt(23.75 / 81.0), rel=1e-12)
    assert (1.0 / math.sqrt(1.0 + d * d + 0.25)) == pytest.approx(0.80498, abs=1e-5)
    assert (1.0 / math.sqrt(1.0 + d * d + 0.25)) / (1.0 / math.sqrt(1.25)) == pytest.approx(0.9, rel=1e-12)


@pytest.mark.parametrize("n, allowed", [(1000, 49), (200, 9), (64, 3)])
def test_range_share_is_what_the_p5_allows(n, allowed):
    """The p5 (numpy's inverted_cdf, as the delivered summary) stays at the threshold with
    `allowed` = ceil(0.05 n) - 1 trials below it and falls below with one more."""
    assert round((1.0 - range_share(n)) * n) == allowed
    for below, holds in ((allowed, True), (allowed + 1, False)):
        r = np.r_[np.full(below, 0.5), np.full(n - below, 1.0)]
        assert bool(np.quantile(r, 0.05, method="inverted_cdf") >= 1.0) is holds


@pytest.fixture(scope="module")
def case(paper_config, paper_mirror):
    def make(seat_deg: float):
        cfg = copy.deepcopy(paper_config)
        cfg["tolerance"]["lattice_phases"] = 2
        cfg["tolerance"]["nose_step_mm"] = 0.005
        cfg["tolerance"]["params"]["seat_tilt_deg"] = seat_deg
        cfg["tolerance"]["trials"] = TRIALS
        c = tolerance_context(paper_mirror, from_config(cfg), Program.BEST, 300.0)
        return c, run_monte_carlo(c), responses(c)
    return {seat: make(seat) for seat in (0.08, 0.3)}


def _with_fraction(c, f: float):
    return dataclasses.replace(c, settings=dataclasses.replace(c.settings, delivered_p5_min_fraction=f))


def _p5_by_hand(m) -> tuple[float, float]:
    """(p5, design R10) of a Monte Carlo's delivered range, recomputed from its trials'
    disparity errors d: sharp / sqrt(1 + d^2 + n^2), n the matcher's 0.1 px (no blur in
    this context), the 10th smallest of 200 (ceil(0.05 x 200))."""
    dl = m.delivered
    assert dl.blur_px == 0.0 and dl.matching_noise_px == 0.1
    r = dl.sharp_r10_m / np.sqrt(1.0 + dl.disparity_px**2 + 0.01)
    assert np.allclose(r, dl.r10_m, rtol=1e-12)
    return float(np.sort(r)[9]), dl.sharp_r10_m / math.sqrt(1.01)


def test_the_p5_binding_tightens_and_the_confirmation_shows_it(case):
    """Seat 0.08 deg: 96.5 % yield and the p5 at 97.3 % of the design's R10. At 90 % (the
    default) nothing is tightened; at 98 % the allocation tightens the seat and its
    confirming Monte Carlo (the same trials, the seat's tilts scaled) keeps 98 % at the
    p5 counted by hand, the yield still >= 95 %."""
    c, mc, resp = case[0.08]
    p5, design = _p5_by_hand(mc)
    assert mc.yield_fraction >= 0.95 and 0.9 < p5 / design < 0.98
    out, confirm = allocate(_with_fraction(c, 0.9), resp, mc)
    assert confirm is None and out["reached"] and out["cost_ratio"] == 1.0
    assert out["delivered"]["p5_m"] == pytest.approx(p5, rel=1e-12)
    assert out["delivered"]["design_r10_m"] == pytest.approx(design, rel=1e-12)

    out, confirm = allocate(_with_fraction(c, 0.98), resp, mc)
    assert out["reached"] and confirm is not None and out["cost_ratio"] > 1.0
    tight = {r["parameter"]: r for r in out["tolerances"] if r["tighten"]}
    assert "seat_tilt_deg" in tight
    p5c, _ = _p5_by_hand(confirm)
    assert p5c >= 0.98 * design and confirm.yield_fraction >= 0.95
    assert out["delivered"]["p5_m"] == pytest.approx(p5c, rel=1e-12) and out["delivered"]["kept"]
    f = tight["seat_tilt_deg"]["factor"]
    assert np.allclose(confirm.trials.seat_x, f * mc.trials.seat_x, rtol=1e-12, atol=0)
    assert "delivered R10 p5" in out["statement"] and "at least 98 % asked" in out["statement"]
    Allocation.from_dict(json.loads(json.dumps(out)))  # the result's declared figures


def test_only_the_yield_binding_leaves_the_allocation_as_the_yield_alone_asks(case):
    """Seat 0.3 deg: 28.5 % yield. The yield's allocation (seat to 0.3 x 0.8^9 = 0.0403
    deg, the allocation before the range target gave the same) already keeps the p5 within
    90 % (and 50 %) of the design's R10, so both fractions give the same tolerances, each
    confirmed at or above the fraction by hand."""
    c, mc, resp = case[0.3]
    assert mc.yield_fraction < 0.95
    runs = {f: allocate(_with_fraction(c, f), resp, mc) for f in (0.5, 0.9)}
    for f, (out, confirm) in runs.items():
        assert out["reached"]
        seat = {r["parameter"]: r for r in out["tolerances"]}["seat_tilt_deg"]
        assert seat["allocated"] == pytest.approx(0.3 * 0.8**9, rel=1e-12)
        assert [r["parameter"] for r in out["tolerances"] if r["tighten"]] == ["seat_tilt_deg"]
        p5, design = _p5_by_hand(confirm)
        assert p5 >= f * design and confirm.yield_fraction >= 0.95
    assert runs[0.5][0]["cost_ratio"] == runs[0.9][0]["cost_ratio"]
