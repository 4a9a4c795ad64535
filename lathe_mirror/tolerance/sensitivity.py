"""Each parameter alone: the sensitivity table and the response scans behind the allocation.

`responses` puts each drawn parameter at SCAN fractions of its tolerance, both signs, the
others nominal (phase 0), and every lattice phase at nominal, in one vectorised
evaluation; `sensitivity_table` reads the -/+ 1 tolerance cases off it (raw and after
calibration). The lattice phase has no sign: its row gives the best and worst of its
realisations. The controller's resolution is a row of its own (resolution_row): it does
not vary from part to part, so the Monte Carlo varies the lattice phase instead, but the
table shows what a coarser or finer controller would do.

Decentre and tilts are applied along x: by the mirror's symmetry any direction gives the
same figures, and a draw (x, y) responds as its magnitude along x.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .montecarlo import CRITERIA, Context, evaluate_trials, judge
from .perturb import TrialFigures, Trials
from .registry import BY_KEY, REGISTRY, tolerances_of
from .spec import PARAMETERS
from .surfaces import SurfaceBank

#: Fractions of a tolerance each parameter is scanned at (both signs).
SCAN = (0.5, 1.0, 4.0 / 3.0)


@dataclass
class Responses:
    """The judged criteria (CRITERIA order) of each parameter alone at each signed scan
    fraction, and of each lattice phase at nominal.

    keys: the scanned parameters (tolerance > 0). fractions: signed, ascending, 0 included
    (the nominal part at phase 0). values[key]: the parameter's offsets (edge units) at
    the fractions. criteria[key]: (fractions, criteria). phases: (phases, criteria).
    figures / index: the evaluation and where each case sits in it.
    """

    keys: tuple[str, ...]
    tolerances: dict[str, float]
    fractions: np.ndarray
    values: dict[str, np.ndarray]
    criteria: dict[str, np.ndarray]
    phases: np.ndarray
    figures: TrialFigures
    index: dict[tuple[str, float], int]
    passed: np.ndarray


def apply(tr: Trials, i: int, key: str, value: float) -> None:
    """Put parameter `key` at `value` (edge units: mm, s, deg, urad) on trial i, along x
    (tolerance.registry: how each parameter moves a trial)."""
    BY_KEY[key].apply(tr, i, value)


def judged_values(fig: TrialFigures, calibrated: bool) -> np.ndarray:
    """(trials, criteria): the worse lobe's RMS image displacement (px) and outlier pixels
    (%), the 90th percentile
    of the disparity-equivalent error (px) at the spec's range, the worse lobe's RMS slope
    error (rad)."""
    d = fig.judged(calibrated)
    return np.stack([np.max(d["image_displacement_px_rms"], axis=1), np.max(d["outlier_pct"], axis=1),
                     d["disparity_px_p90"][:, 0], np.max(fig.slope_error_rad_rms, axis=1)], axis=1)


def responses(ctx: Context, *, progress: bool = False) -> Responses:
    """Evaluate every parameter at -/+ SCAN x its tolerance and every lattice phase."""
    tol = tolerances_of(ctx.settings)
    keys = tuple(p.key for p in REGISTRY if tol[p.key] > 0)
    fr = np.array(sorted([-f for f in SCAN] + [0.0] + list(SCAN)))
    P = len(ctx.bank.phases)
    cases: list[tuple[str, float]] = [("phase", float(p)) for p in range(P)]
    cases += [(k, float(f)) for k in keys for f in fr if f != 0.0]
    tr = Trials.nominal(len(cases), ctx.nominal_nose_mm, ctx.nominal_time_s)
    for c, (key, f) in enumerate(cases):
        if key == "phase":
            tr.phase[c] = int(f)
        else:
            apply(tr, c, key, f * tol[key])
    tr.nose_mm = ctx.bank.snapped(np.maximum(tr.nose_mm, ctx.bank.nose_step))
    fig = evaluate_trials(ctx, tr, progress=progress, desc="tolerance: sensitivity")
    calibrated = ctx.settings.spec.calibrated
    vals = judged_values(fig, calibrated)
    ok = judge(fig, ctx.limits, calibrated)
    passed = np.all(np.stack([ok[c] for c in CRITERIA]), axis=0)
    index = {case: i for i, case in enumerate(cases)}
    crit = {}
    for key in keys:
        rows = [index[("phase", 0.0)] if f == 0.0 else index[(key, float(f))] for f in fr]
        crit[key] = vals[rows]
    values = {key: fr * tol[key] for key in keys}
    return Responses(keys, dict(tol), fr, values, crit, vals[:P], fig, index, passed)


def sensitivity_table(ctx: Context, resp: Responses | None = None, *, progress: bool = False) -> dict:
    """{"nominal": case, "rows": [{"parameter", "what", "tolerance", "unit", "minus", "plus"}]}.

    A case holds, raw and calibrated, per-lobe RMS image displacement (px), the band's
    median and 90th-percentile disparity-equivalent error (px) and capped RMS depth error
    (%) at the spec's range; per-lobe RMS slope error (rad); and whether it passes the
    spec (its judged figures)."""
    resp = responses(ctx, progress=progress) if resp is None else resp
    fig = resp.figures

    def case(i: int) -> dict:
        out = {}
        for label, d in (("raw", fig.raw), ("calibrated", fig.calibrated)):
            out[label] = {"image_displacement_px_rms": [float(x) for x in d["image_displacement_px_rms"][i]],
                          "outlier_pct": [float(x) for x in d["outlier_pct"][i]],
                          "disparity_px_median": float(d["disparity_px_median"][i, 0]),
                          "disparity_px_p90": float(d["disparity_px_p90"][i, 0]),
                          "depth_error_pct_rms": float(d["depth_error_pct_rms"][i, 0])}
        out["slope_error_rad_rms"] = [float(x) for x in fig.slope_error_rad_rms[i]]
        out["pass"] = bool(resp.passed[i])
        return out

    rows = []
    P = len(ctx.bank.phases)
    if P > 1:
        idx = [resp.index[("phase", float(p))] for p in range(P)]
        score = resp.phases[:, 0] / ctx.limits["image_displacement_px"] + resp.phases[:, 1] / ctx.limits["disparity_px"]
        worst, best = idx[int(np.argmax(score))], idx[int(np.argmin(score))]
        rows.append({"parameter": "lattice_phase", "what": PARAMETERS["lattice_phase"][0],
                     "tolerance": f"{P} phases", "unit": "step", "minus": case(best), "plus": case(worst),
                     "note": "minus: the best phase, plus: the worst (by the judged image and stereo figures)"})
    for key in resp.keys:
        rows.append({"parameter": key, "what": PARAMETERS[key][0], "tolerance": resp.tolerances[key],
                     "unit": PARAMETERS[key][1], "minus": case(resp.index[(key, -1.0)]),
                     "plus": case(resp.index[(key, 1.0)])})
    return {"nominal": case(resp.index[("phase", 0.0)]), "rows": rows,
            "nominal_values": {"nose_radius_mm": ctx.nominal_nose_mm, "polish_time_s": ctx.nominal_time_s}}


def resolution_row(ctx: Context, polish_params, *, res0: float, machine_at, progress: bool = False) -> dict | None:
    """The nominal part re-planned and re-machined on a controller of resolution -/+ the
    tolerance tolerance.params.resolution_mm (None when that tolerance is 0).

    res0: the nominal resolution, mm. machine_at(resolution) -> a made surface (attributes
    profile, source): the pipeline's builder, the nominal part on that controller."""
    d = ctx.settings.tolerances.get("resolution_mm", 0.0)
    if d <= 0:
        return None
    # res0 > d: checked by job.check_programs
    out = {"parameter": "resolution_mm", "what": "controller resolution (re-planned program)",
           "tolerance": d, "unit": "mm",
           "note": "not drawn in the Monte Carlo: one controller makes every part"}
    calibrated = ctx.settings.spec.calibrated
    for which, res in (("minus", res0 - d), ("plus", res0 + d)):
        bank = SurfaceBank(ctx.mirror, lambda phase, nose, res=res: machine_at(res), polish_params,
                           np.array([ctx.nominal_time_s]), np.array([0.0]), ctx.nominal_nose_mm, ctx.bank.nose_step)
        sub = Context(ctx.mirror, ctx.settings, bank, ctx.samples, ctx.nominal_nose_mm, ctx.nominal_time_s,
                   bank.source, ctx.program, ctx.limits)
        fig = evaluate_trials(sub, Trials.nominal(1, ctx.nominal_nose_mm, ctx.nominal_time_s))
        ok = judge(fig, ctx.limits, calibrated)
        entry = {"resolution_mm": res}
        for label, dd in (("raw", fig.raw), ("calibrated", fig.calibrated)):
            entry[label] = {"image_displacement_px_rms": [float(x) for x in dd["image_displacement_px_rms"][0]],
                            "outlier_pct": [float(x) for x in dd["outlier_pct"][0]],
                            "disparity_px_median": float(dd["disparity_px_median"][0, 0]),
                            "disparity_px_p90": float(dd["disparity_px_p90"][0, 0]),
                            "depth_error_pct_rms": float(dd["depth_error_pct_rms"][0, 0])}
        entry["slope_error_rad_rms"] = [float(x) for x in fig.slope_error_rad_rms[0]]
        entry["pass"] = bool(all(v[0] for v in ok.values()))
        out[which] = entry
    return out
