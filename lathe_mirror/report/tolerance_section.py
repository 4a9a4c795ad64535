"""The report's tolerance section and its answer first (the summary at the top of the
page), from the typed tolerance analysis (results.tolerance)."""

from __future__ import annotations

import html
from typing import TYPE_CHECKING

from ..tolerance.stats import percent_interval
from .cells import fmt as _fmt
from .cells import table as _table
from .cells import verdict_cell as _verdict_cell

if TYPE_CHECKING:
    from ..results.tolerance import Allocation, Sensitivity, ToleranceAnalysis, ToleranceSpec, ToleranceStereo


def tolerance_html(tol: ToleranceAnalysis | None, img) -> str:
    """The spec, the tolerances, and per program: the yield, the checks, the allocation,
    the Monte Carlo's histograms, the stereo table, the sensitivity and inverse sensitivity."""
    if tol is None:
        return "<p>(tolerance analysis not run)</p>"
    spec = tol.spec
    which = "after calibration" if spec.calibrated else "raw (against the design's own model)"
    first = next(iter(tol.programs.values()), None)
    lim = first.limits if first else {}
    spec_rows = [
        ("image displacement", f"RMS over each lobe's pixels but its outliers, {which}",
         f"{_fmt(spec.image_displacement_px)} px"),
        ("outlier pixels", f"share of each lobe's pixels displaced more than 5 x the image limit, {which}",
         f"{_fmt(spec.outlier_pct)} %"),
        ("stereo", f"90th percentile over the common band at {_fmt(spec.depth_range_m)} m of the "
                   f"disparity-equivalent error, {which}",
         f"{_fmt(lim.get('disparity_px', float('nan')))} px (= {_fmt(spec.depth_error_pct)} % depth error)"),
        ("slope error", "RMS over the radii each lobe's image uses", f"{_fmt(spec.slope_error_rad)} rad"),
    ]
    parts = ["<h3>Spec</h3>" + _table(("criterion", "figure judged", "limit"), spec_rows),
             f"<p>Calibrated: a calibration of the made camera fits its rotation and a smooth radial mapping of "
             f"each lobe (tolerance/calibration.py); the figures judged are what it cannot remove. "
             f"Disparity-equivalent error: the stereo parallax error in pixels of image position in each lobe "
             f"(the matcher's unit); {_fmt(spec.depth_error_pct)} % at {_fmt(spec.depth_range_m)} m is "
             f"{_fmt(lim.get('disparity_px', float('nan')))} px at the band's median elevation.</p>"]
    cost = tol.cost
    trows = [(k, _fmt(v), ("3-sigma bound" if tol.distribution == "normal" else "+/- bound"), _fmt(cost.get(k, "")))
             for k, v in tol.tolerances.items()]
    parts.append("<h3>Tolerances</h3>" + _table(("parameter", "tolerance", "read as", "relative cost"), trows)
                 + f"<p>{tol.trials} trials per Monte Carlo, seed {tol.seed}; {tol.lattice_phases} lattice "
                 f"phases drawn uniformly; each trial's nose cut as drawn (to {_fmt(tol.nose_step_mm)} mm); "
                 f"the seat tilts about a point {_fmt(tol.seat_pivot_mm)} mm above the pinhole.</p>")
    for name, t in tol.programs.items():
        v, mc = t.verdict, t.monte_carlo
        checks = [(k, _fmt(c.limit), _fmt(c.nominal), _verdict_cell(c.passed),
                   f"{100 * mc.pass_fraction[k]:.1f} % ({100 * mc.pass_fraction_wilson95[k][0]:.1f}-"
                   f"{100 * mc.pass_fraction_wilson95[k][1]:.1f} %)") for k, c in v.checks.items()]
        block = [f"<h3>{html.escape(name)} program</h3>",
                 f"<p class='yield'>Yield <b>{percent_interval(mc.passed, mc.trials)}</b>; "
                 f"nominal part {'passes' if v.nominal_pass else 'fails'}.</p>"]
        if t.allocation is not None:
            block.append(f"<p class='answer'>{html.escape(t.allocation.statement)}</p>")
        block.append(f"<p>Surfaces: {html.escape(t.surfaces)}; polished {_fmt(t.nominal_polish_time_s / 60)} "
                     f"min nominal.</p>")
        block.append(_table(("criterion", "limit", "nominal part", "", "trials passing (95 % CI)"), checks, raw=True))
        if t.allocation is not None:
            block.append(_allocation_html(t.allocation))
        block.append(img(f"monte_carlo_{name}", f"Monte Carlo histograms, {name} program"))
        if mc.delivered_r10_m is not None:
            d, dd = mc.delivered_r10_m, mc.delivered or {}
            sharp = f" (sharp, the pixel alone: {_fmt(d['sharp'])} m)" if "sharp" in d else ""
            block.append(f"<p>Delivered range (tolerance/delivered.py): each trial's part, calibrated, its disparity "
                         f"error added in quadrature to the design's pixel and to the matcher's noise on the image "
                         f"blurred {_fmt(dd.get('blur_px', 0.0))} px: R10 {_fmt(d['p5'])} m at the 5th percentile, "
                         f"{_fmt(d['median'])} m median, against the design's {_fmt(d['design'])} m, the nominal "
                         f"part with the same blur{sharp}.</p>")
        block.append(_stereo_html(t.stereo, spec))
        block.append(_sensitivity_html(t.sensitivity))
        inv = [(r.parameter, f"{_fmt(r.tolerance)} {r.unit}",
                "none: " + r.no_margin_why if r.no_margin else
                f"{_fmt(r.largest)} {r.unit}" + ("" if r.limited_by else " or more"),
                r.limited_by or "-") for r in t.inverse_sensitivity]
        block.append("<p>Inverse sensitivity: the largest +/- value of each parameter that alone keeps every "
                     "criterion within its share of the margin (limit&sup2; - worst phase&sup2;, split evenly among "
                     "the parameters).</p>"
                     + _table(("parameter", "tolerance", "largest alone", "set by"), inv))
        parts.append("".join(block))
    return "".join(parts)


def summary_html(tol: ToleranceAnalysis | None) -> str:
    """The answer first: per toleranced program the verdict, the headline figures, the
    yield with its Wilson interval and what to tighten."""
    if tol is None:
        return ""
    rows = []
    spec = tol.spec
    label = "calibrated" if spec.calibrated else "raw"
    for name, t in tol.programs.items():
        v, mc = t.verdict, t.monte_carlo
        c = v.checks
        st = t.stereo
        i = st.ranges_m.index(spec.depth_range_m) if spec.depth_range_m in st.ranges_m else None
        within = f"; {100 * st.side(label).within_10_pct[i]:.0f} % of the band within 10 %" if i is not None else ""
        head = (f"image displacement {_fmt(c['image_displacement_px'].nominal)} px RMS; disparity "
                f"{_fmt(c['disparity_px'].nominal)} px (90 % of the band) at {_fmt(spec.depth_range_m)} m"
                f"{within}; slope error {_fmt(c['slope_error_rad'].nominal)} rad")
        todo = t.allocation.statement if t.allocation is not None else "(no allocation run for this program)"
        rows.append((f"{name} program", _verdict_cell(v.nominal_pass), html.escape(head),
                     percent_interval(mc.passed, mc.trials), html.escape(todo)))
    return ("<div class='summary'><h2>The answer</h2>"
            + _table(("", "nominal part", f"headline figures ({'after calibration' if spec.calibrated else 'raw'})",
                      "Monte Carlo yield (95 % CI)", f"to reach {100 * tol.target_yield:g} %"),
                     rows, raw=True) + "</div>")


def _allocation_html(a: Allocation) -> str:
    rows = [(r.parameter, f"{_fmt(r.tolerance)} {r.unit}", f"{_fmt(r.allocated)} {r.unit}",
             "tighten" if r.tighten else "keep", _fmt(r.cost)) for r in a.tolerances]
    rounds = [(h.round, f"{100 * h.aim:.1f} %", f"{100 * h.surrogate_yield:.1f} %",
               f"{100 * h.yield_:.1f} % ({100 * h.yield_wilson95[0]:.1f}-{100 * h.yield_wilson95[1]:.1f} %)",
               h.seed) for h in a.rounds]
    sur = a.surrogate
    out = (f"<p>Allocation to {100 * a.target_yield:g} % at least cost (relative cost "
           f"{_fmt(a.cost_ratio)} x the configured tolerances'):</p>"
           + _table(("parameter", "configured", "allocated", "", "relative cost"), rows))
    if rounds:
        out += _table(("round", "surrogate aim", "surrogate yield", f"confirmed yield, {a.trials} trials (95 % CI)",
                       "seed"), rounds)
    out += (f"<p>Surrogate (each parameter's response alone, added in squares; {sur.draws} draws): "
            f"{100 * sur.yield_on_monte_carlo_trials:.1f} % on the Monte Carlo's own trials against their traced "
            f"{100 * sur.monte_carlo_yield:.1f} %; it agrees with the traced pass / fail on "
            f"{100 * sur.agreement:.1f} % of them.</p>")
    return out


def _stereo_html(st: ToleranceStereo, spec: ToleranceSpec) -> str:
    rows = []
    for i, r in enumerate(st.ranges_m):
        row = [_fmt(r)]
        for label in ("raw", "calibrated"):
            d = st.side(label)
            row += [_fmt(d.disparity_px_median[i]), _fmt(d.disparity_px_p90[i]),
                    f"{100 * d.within_5_pct[i]:.0f} %", f"{100 * d.within_10_pct[i]:.0f} %",
                    f"{100 * d.seen_fraction[i]:.0f} %", _fmt(d.depth_error_pct_rms[i])]
        row.append(_fmt(st.matching_floor_pct[i]))
        rows.append(row)
    head = ["range (m)"]
    for label in ("raw", "calibrated"):
        head += [f"{label}: disparity median (px)", "p90 (px)", "within 5 %", "within 10 %", "seen",
                 "capped RMS depth error (%)"]
    head.append(f"matching floor, {_fmt(st.matching_noise_px)} px (%)")
    return ("<p>Stereo figures of the nominal part (the band's points at each range; disparity limit "
            f"{_fmt(st.disparity_limit_px)} px):</p>" + _table(head, rows))


def _sensitivity_html(sens: Sensitivity) -> str:
    rows = []
    for r in sens.rows:
        for which in ("minus", "plus"):
            c = getattr(r, which)
            first = which == "minus"
            rows.append([r.parameter if first else "", (f"{_fmt(r.tolerance)} {r.unit}") if first else "",
                         which]
                        + [_fmt(x) for x in c.raw.image_displacement_px_rms]
                        + [_fmt(x) for x in c.calibrated.image_displacement_px_rms]
                        + [_fmt(c.raw.disparity_px_p90), _fmt(c.calibrated.disparity_px_p90),
                           _fmt(c.raw.depth_error_pct_rms), _fmt(c.calibrated.depth_error_pct_rms)]
                        + [_fmt(x) for x in c.slope_error_rad_rms] + [_verdict_cell(c.passed)])
    head = ("parameter", "tolerance", "", "raw disp. inner px", "raw disp. outer px", "cal. disp. inner px",
            "cal. disp. outer px", "raw disparity p90 px", "cal. disparity p90 px", "raw depth err %",
            "cal. depth err %", "slope inner rad", "slope outer rad", "spec")
    return ("<p>Sensitivity: each parameter at -/+ its tolerance, the others nominal.</p>"
            + _table(head, [[x if i == len(r) - 1 else html.escape(str(x)) for i, x in enumerate(r)] for r in rows],
                     raw=True))
