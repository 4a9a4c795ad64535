"""What the shop must tighten: inverse sensitivity and a least-cost allocation to a yield.

Inverse sensitivity: for each parameter, the largest +/- offset that alone keeps each
judged criterion within its share of the margin. The margin of a criterion is what its
limit leaves above the nominal part's worst lattice phase, taken in squares (independent
errors add in quadrature: c^2 = c0^2 + sum_i h_i(x_i)), and split evenly among the
toleranced parameters: h_i(x) <= (limit^2 - c0^2) / N.

Allocation: the response scans (sensitivity.responses) give each parameter's h_i(x) per
criterion; the surrogate c_j^2 = c0_j(phase)^2 + sum_i h_ij(x_i) judges thousands of draws
at the cost of a lookup. A greedy least-cost search (marginal analysis) tightens, one
rung of TIGHTEN at a time, the parameter whose rung buys the most surrogate yield per unit
of cost (cost of parameter i at k times tighter: cost_i x k, [tolerance.cost]), until the
surrogate yield reaches the yield a Monte Carlo of n trials must show for its Wilson 95 %
interval to clear the target; then loosens back any rung not needed. No tolerance is
tightened past what a precision shop holds (tolerance.shops, the class's value: the
tightest a shop can be asked for; a parameter no class lists stops at MAX_RUNGS rungs),
the last rung landing on that value.

The delivered range is the allocation's second target: the 5th percentile of the made
parts' delivered R10 (tolerance.delivered) must reach delivered_p5_min_fraction (f) of the
design's R10. A part keeps f of the design's range exactly when its own disparity error d
stays within d_max = sqrt((1 + n^2)(1 / f^2 - 1)) (delivered.disparity_limit_px), so the
p5 holds when at most ceil(0.05 x trials) - 1 trials exceed d_max: a second surrogate of
the same form, on d (the band's median at the spec's range, the delivered range's input),
gives the share of draws within d_max, and the greedy search also needs that share to
reach its aim (at first the share the p5 needs). While the share stays above its aim its
penalty is 0 and the search is the yield's alone; a confirming run short of either target
raises that target's aim by its shortfall. A Monte Carlo with the allocated tolerances confirms
it, drawn from the configured run's seed (common random numbers, tolerance.registry: every
trial is the configured run's trial with its offsets scaled, so the two yields differ only
by the trials the tightening flips). If it falls short, the surrogate is refitted to every
trial traced so far (the confirming run's trials sit where the allocation is, the
configured run's may sit far from it), its aim is raised by the shortfall, and the search
continues (at most ROUNDS confirming runs; an allocation already found short is never
confirmed twice: the aim rises until the surrogate asks for a new one). When the surrogate
sees no new allocation within the precision shop's values, the Monte Carlo judges all of
them at once; if even that falls
short, the statement names the parameter whose precision-shop value limits the yield
most (the one the surrogate gains most from, set perfect).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .delivered import range_share
from .montecarlo import CRITERIA, Context, MonteCarloResult, run_monte_carlo
from .range_goal import RangeGoal, disparity_of, fit_tail, range_responses
from .sensitivity import Responses, judged_values
from .registry import BY_KEY, standard_draws, tolerances_of
from .shops import shop_values
from .spec import PARAMETERS
from .stats import percent_interval, wilson, yield_to_show

#: One rung of tightening: the tolerance times this.
TIGHTEN = 0.8
#: Rungs down from the configured tolerance (0.8^20 ~ 1/87).
MAX_RUNGS = 20
#: Draws of the surrogate (common random numbers for every candidate).
SURROGATE_DRAWS = 4000
#: Confirming Monte Carlo runs at most.
ROUNDS = 5


@dataclass
class Surrogate:
    """The additive-in-squares model of the judged criteria, from the response scans:
    c_j^2 = c0_j(phase)^2 + scale_j sum_i h_ij(x_i). scale_j (1 until `calibrate`) is
    fitted to the Monte Carlo's own traced trials: the parameters' effects are patterns
    over the pixels and the band's points that do not all peak together, so the squares
    of a percentile add to less than their sum."""

    resp: Responses
    limits: np.ndarray  # (criteria,)
    scale: np.ndarray | None = None

    def calibrate(self, phase: np.ndarray, x: dict[str, np.ndarray], actual: np.ndarray) -> None:
        """Fit scale_j by least squares (through the origin) of the traced trials' criteria
        (trials, criteria) on the sum of their parameters' h_ij; bounded to 0.25 .. 4."""
        c0 = self.resp.phases[phase] ** 2
        h = sum(self.squares(k, v) for k, v in x.items())
        y = actual**2 - c0
        ok = np.isfinite(y) & np.isfinite(h) & (h < 1e29)
        num = np.sum(np.where(ok, h * y, 0.0), axis=0)
        den = np.sum(np.where(ok, h * h, 0.0), axis=0)
        self.scale = np.clip(np.where(den > 0, num / np.where(den > 0, den, 1.0), 1.0), 0.25, 4.0)

    def squares(self, key: str, x: np.ndarray) -> np.ndarray:
        """h_ij(x): the increase of each criterion's square with parameter `key` at x (edge
        units), (..., criteria); linear between the scan points, growing as x^2 beyond."""
        v = self.resp.values[key]
        c = self.resp.criteria[key]
        c0 = c[np.searchsorted(self.resp.fractions, 0.0)]
        with np.errstate(invalid="ignore"):
            h = c**2 - c0**2
        h = np.where(np.isfinite(h), h, 1e30)
        x = np.asarray(x, float)
        out = np.empty(x.shape + (c.shape[1],))
        for j in range(c.shape[1]):
            out[..., j] = np.interp(x, v, h[:, j])
            lo, hi = v[0], v[-1]
            out[..., j] = np.where(x > hi, h[-1, j] * (x / hi) ** 2, out[..., j])
            out[..., j] = np.where(x < lo, h[0, j] * (x / lo) ** 2, out[..., j])
        return out

    def criteria(self, phase: np.ndarray, x: dict[str, np.ndarray]) -> np.ndarray:
        """Surrogate criteria (draws, criteria) for phase indices and offsets x[key]."""
        sq = self.resp.phases[phase] ** 2
        sq = np.where(np.isfinite(sq), sq, 1e30)
        add = sum(self.squares(key, val) for key, val in x.items())
        scale = 1.0 if self.scale is None else self.scale
        return np.sqrt(np.maximum(sq + scale * add, 0.0))

    def passes(self, phase: np.ndarray, x: dict[str, np.ndarray]) -> np.ndarray:
        return np.all(self.criteria(phase, x) <= self.limits, axis=1)


def inverse_sensitivity(resp: Responses, limits: dict[str, float]) -> list[dict]:
    """Per parameter: the largest +/- offset (edge units) that alone keeps each criterion
    within its share of the margin ((limit^2 - c0^2) / N, c0 the worst lattice phase's
    nominal), the smallest of them and the criterion that sets it. An offset at the end of
    the scan means "at least this much"; 0 means the nominal part leaves no margin."""
    lim = np.array([limits[c] for c in CRITERIA])
    c0 = np.max(resp.phases, axis=0)
    n = max(len(resp.keys), 1)
    share = (lim**2 - c0**2) / n
    rows = []
    for key in resp.keys:
        v = resp.values[key]
        c = resp.criteria[key]
        mid = np.searchsorted(resp.fractions, 0.0)
        with np.errstate(invalid="ignore"):
            h = np.where(np.isfinite(c), c**2 - c[mid] ** 2, np.inf)
        per = {}
        for j, crit in enumerate(CRITERIA):
            if share[j] <= 0:
                per[crit] = 0.0
                continue
            sides = []
            for side in (slice(mid, None), slice(mid, None, -1)):
                xs, hs = np.abs(v[side]), h[side, j]
                over = np.flatnonzero(hs > share[j])
                if over.size == 0:
                    sides.append(float(xs[-1]))
                    continue
                i = int(over[0])
                # linear between the last point within the share and the first beyond it
                x0, x1, h0, h1 = xs[i - 1], xs[i], hs[i - 1], hs[i]
                sides.append(float(x0 + (x1 - x0) * (share[j] - h0) / (h1 - h0)) if np.isfinite(h1) else float(x0))
            per[crit] = min(sides)
        limiting = min(per, key=per.get)
        scanned = float(min(abs(resp.values[key][0]), abs(resp.values[key][-1])))
        rows.append({"parameter": key, "unit": PARAMETERS[key][1], "tolerance": resp.tolerances[key],
                     "largest": per[limiting], "limited_by": limiting if per[limiting] < scanned else "",
                     "per_criterion": per, "scanned_to": scanned,
                     "no_margin": [c for j, c in enumerate(CRITERIA) if share[j] <= 0],
                     "no_margin_why": no_margin_text(c0, lim, share)})
    return rows


def no_margin_text(worst: np.ndarray, lim: np.ndarray, share: np.ndarray) -> str:
    """Why a parameter has no margin, naming only the criteria that leave none: the part at
    its worst lattice phase (worst, per criterion) already at or beyond the limit (lim);
    "" when every criterion leaves a margin."""
    bad = [f"{c} ({_num(float(worst[j]))} >= {_num(float(lim[j]))})" for j, c in enumerate(CRITERIA) if share[j] <= 0]
    return ("at its worst lattice phase the part already fails " + ", ".join(bad)) if bad else ""


def allocate(ctx: Context, resp: Responses, mc: MonteCarloResult, *, target: float | None = None,
             progress: bool = False) -> tuple[dict, MonteCarloResult | None]:
    """Least-cost tolerances that reach the target yield (default the settings') and keep
    the delivered R10's p5 within delivered_p5_min_fraction of the design's (module doc),
    confirmed by a Monte Carlo on the same seed; mc is the Monte Carlo at the configured
    tolerances (its trials check the surrogates). Returns the JSON-ready allocation and the
    last confirming Monte Carlo (None when the configured tolerances already reach both)."""
    s = ctx.settings
    target = s.target_yield if target is None else float(target)
    n = s.trials
    lim = np.array([ctx.limits[c] for c in CRITERIA])
    sur = Surrogate(resp, lim)
    keys = resp.keys
    base = {k: tolerances_of(s)[k] for k in keys}  # the lathe's set-up errors too
    cost = {k: s.cost.get(k, 1.0) for k in keys}
    # Common random numbers: one set of standard draws for every candidate.
    rng = np.random.default_rng(s.seed + 2)
    phase = rng.integers(0, len(ctx.bank.phases), SURROGATE_DRAWS)
    std = standard_draws(rng, SURROGATE_DRAWS, s.distribution)
    goal = RangeGoal.of(mc, s.delivered_p5_min_fraction)
    ranged = None if goal is None else Surrogate(range_responses(resp, s.spec.calibrated), np.array([goal.d_max_px]))

    def offsets(scale: dict[str, float]) -> dict[str, np.ndarray]:
        out = {}
        for k in keys:
            p = BY_KEY[k]
            d = p.scale(std[k], base[k] * scale[k], s.distribution)
            out[k] = np.abs(d[0]) if p.one_sided else (np.hypot(d[0], d[1]) if p.paired else d[0])
        return out

    def surrogate_yields(scale: dict[str, float]) -> tuple[float, float]:
        """(yield, share of draws keeping the range) of the surrogates at `scale`."""
        x = offsets(scale)
        share = 1.0 if ranged is None else float(np.mean(ranged.passes(phase, x)))
        return float(np.mean(sur.passes(phase, x))), share

    def surrogate_yield(scale: dict[str, float]) -> float:
        return surrogate_yields(scale)[0]

    check = _surrogate_check(sur, mc, keys)
    if ranged is not None:
        _refit(ranged, [mc], keys, disparity_of, fit_tail)
    floor = precision_floor(base, keys)
    top = {k: _top_rung(floor[k]) for k in keys}
    rungs = {k: 0 for k in keys}
    scale = {k: 1.0 for k in keys}
    aim = yield_to_show(target, n)
    aim_r = range_share(n)
    y_sur = (0.0, 0.0)
    history = []
    confirm = None
    traced = [mc]
    short_y, short_r = mc.yield_fraction < target, goal is not None and not goal.kept(mc)
    reached = not (short_y or short_r)
    rounds = 0
    nominal_fails = [c for j, c in enumerate(CRITERIA) if not np.min(resp.phases[:, j]) <= lim[j]]
    unreachable = ""
    if nominal_fails:
        unreachable = ("no tolerance can fix it: the nominal part fails " + ", ".join(
            f"{c} ({_num(float(np.min(resp.phases[:, CRITERIA.index(c)])))} > {_num(ctx.limits[c])})"
            for c in nominal_fails) + " at every lattice phase")
    # the configured tolerances (rung 0 everywhere) are mc's own: never confirmed again
    tried: set[tuple[int, ...]] = {tuple(0 for _ in keys)}
    while not reached and not unreachable and rounds < ROUNDS:
        rungs, scale, y_sur = _greedy(surrogate_yields, rungs, cost, aim, aim_r, top, floor)
        # an allocation a Monte Carlo already found short would only repeat its trials:
        # the short target's aim rises until the surrogates ask for something new, or cannot
        while (_met(y_sur, aim, aim_r) and tuple(rungs.values()) in tried
               and ((short_y and aim < 1.0) or (short_r and aim_r < 1.0))):
            if short_y:
                aim = min(1.0, aim + max(1.0 / n, 0.5 * (1.0 - aim)))
            if short_r:
                aim_r = min(1.0, aim_r + max(1.0 / n, 0.5 * (1.0 - aim_r)))
            rungs, scale, y_sur = _greedy(surrogate_yields, rungs, cost, aim, aim_r, top, floor)
        all_out = not _met(y_sur, aim, aim_r) or tuple(rungs.values()) in tried
        if all_out:
            # The surrogate sees no way within a precision shop's values: the Monte Carlo
            # judges them all at once, so the verdict and the yield quoted come from the
            # same trials.
            rungs, scale = dict(top), dict(floor)
        rounds += 1
        tol = {k: base[k] * scale[k] for k in keys}
        # the configured run's seed: its trials' standard draws scaled to the allocated
        # tolerances (common random numbers), so the yields compare trial for trial
        confirm = run_monte_carlo(ctx, seed=s.seed, tolerances={**s.tolerances, **tol},
                                  progress=progress, desc=f"tolerance: confirming the allocation ({rounds})")
        k_pass = int(np.sum(confirm.pass_all))
        history.append({"round": rounds, "aim": aim, "surrogate_yield": y_sur[0], "yield": k_pass / n,
                        "yield_wilson95": list(wilson(k_pass, n)), "seed": confirm.seed,
                        "tolerances": {k: tol[k] for k in keys},
                        **({} if goal is None else {"range_aim": aim_r, "surrogate_range_share": y_sur[1],
                                                    "range_share": goal.share(confirm),
                                                    "delivered_r10_p5_m": goal.p5(confirm)})})
        short_y, short_r = confirm.yield_fraction < target, goal is not None and not goal.kept(confirm)
        reached = not (short_y or short_r)
        if reached:
            break
        tried.add(tuple(rungs.values()))
        traced.append(confirm)
        _refit(sur, traced, keys)
        if ranged is not None:
            _refit(ranged, traced, keys, disparity_of, fit_tail)
        if all_out:
            unreachable = _out_of_reach(goal, confirm, k_pass, n, short_y, surrogate_yields, floor, keys)
            break
        if short_y:
            aim = min(1.0, aim + (target - confirm.yield_fraction) + 1.0 / n)
        if short_r:
            aim_r = min(1.0, aim_r + (range_share(n) - goal.share(confirm)) + 1.0 / n)
    rows = []
    for k in keys:
        rows.append({"parameter": k, "what": PARAMETERS[k][0], "unit": PARAMETERS[k][1], "tolerance": base[k],
                     "allocated": base[k] * scale[k], "factor": scale[k], "cost": cost[k],
                     "tighten": scale[k] < 1.0})
    total0 = sum(cost.values())
    total = sum(cost[k] / scale[k] for k in keys)
    final = confirm if confirm is not None else mc
    k_final = int(np.sum(final.pass_all))
    delivered = None if goal is None else goal.describe(final)
    out = {"program": ctx.program.value, "target_yield": target, "trials": n, "reached": bool(reached),
           "yield": k_final / n, "yield_wilson95": list(wilson(k_final, n)), "seed": final.seed,
           "confirmed_by": "a Monte Carlo of the same seed at the allocated tolerances" if confirm is not None else "the Monte Carlo at the configured tolerances",
           "rounds": history, "tolerances": rows, "cost_ratio": total / total0 if total0 > 0 else 1.0,
           "surrogate": {"draws": SURROGATE_DRAWS, "yield_at_configured": surrogate_yield({k: 1.0 for k in keys}),
                         **check},
           "unreachable": unreachable,
           **({} if delivered is None else {"delivered": delivered}),
           "statement": statement(target, reached, rows, k_final, n, unreachable, delivered)}
    return out, confirm


def _met(y: tuple[float, float], aim: float, aim_r: float) -> bool:
    return y[0] >= aim and y[1] >= aim_r


def _out_of_reach(goal, confirm, k_pass: int, n: int, short_y: bool, surrogate_yields, floor, keys) -> str:
    """Why the precision shop's values fall short: the yield, or else the delivered p5."""
    if short_y:
        return (f"with every tolerance at a precision shop's value the Monte Carlo still passes "
                f"only {percent_interval(k_pass, n)} of its trials; "
                f"{limiting(lambda sc: surrogate_yields(sc)[0], floor, keys)} limits it most")
    p5 = goal.p5(confirm)
    return (f"with every tolerance at a precision shop's value the delivered R10 p5 is still {_num(p5)} m, "
            f"{100 * p5 / goal.design_m:.1f} % of the design's {_num(goal.design_m)} m (at least "
            f"{100 * goal.fraction:g} % asked); {limiting(lambda sc: surrogate_yields(sc)[1], floor, keys)} "
            "limits it most")


def statement(target: float, reached: bool, rows: list[dict], k: int, n: int, unreachable: str = "",
              delivered: dict | None = None) -> str:
    """One sentence: what to tighten to reach the target, and the yield (and the delivered
    R10's p5 against the design's) that shows it."""
    got = percent_interval(k, n)
    if delivered is not None:
        got += (f"; delivered R10 p5 {delivered['p5_m']:.4g} m, {100 * delivered['p5_fraction']:.1f} % of the "
                f"design's {delivered['design_r10_m']:.4g} m (at least {100 * delivered['min_fraction']:g} % asked)")
    tight = [r for r in rows if r["tighten"]]
    goal = f"{100 * target:g} %"
    if not tight and reached:
        return f"already at {goal}: yield {got} at the configured tolerances; nothing to tighten"
    what = ", ".join(f"{r['parameter']} to +/-{_num(r['allocated'])} {r['unit']} (from {_num(r['tolerance'])})"
                     for r in tight)
    if reached:
        return f"to reach {goal}: tighten {what}; confirmed yield {got}"
    if unreachable:
        return f"{goal} is out of reach by tightening: {unreachable}; yield {got}"
    return f"{goal} not confirmed: tightening {what or 'nothing'} gave a yield of {got}"


def precision_floor(base: dict[str, float], keys) -> dict[str, float]:
    """The smallest scale each tolerance may be allocated (allocated / configured): a
    precision shop's value over the configured (1 when the configured is already as
    tight), TIGHTEN^MAX_RUNGS for a parameter no shop class lists."""
    precise = {k: v for section in shop_values("precision").values() for k, v in section.items()}
    out = {}
    for k in keys:
        if k in precise and base[k] > 0:
            out[k] = min(1.0, precise[k] / base[k])
        else:
            out[k] = TIGHTEN ** MAX_RUNGS
    return out


def _top_rung(floor: float) -> int:
    """The rung whose scale reaches `floor` (scales clip at it)."""
    if floor >= 1.0:
        return 0
    return int(math.ceil(math.log(floor) / math.log(TIGHTEN) - 1e-9))


def limiting(surrogate_yield, floor: dict[str, float], keys) -> str:
    """The parameter whose tolerance, at its floor, costs the surrogate's yield most: the
    one whose setting perfect (0) gains most, named with its floor."""
    base_y = surrogate_yield(floor)
    gain = {k: surrogate_yield({**floor, k: 0.0}) - base_y for k in keys}
    k = max(keys, key=lambda key: gain[key])
    return f"{k} (perfect, the surrogate's yield would gain {100 * gain[k]:.1f} points)"


def _greedy(surrogate_yields, rungs: dict[str, int], cost: dict[str, float], aim: float, aim_r: float,
            top: dict[str, int], floor: dict[str, float]):
    """Tighten rung by rung where the surrogate's score per unit cost gains most, until the
    yield reaches `aim` and the share keeping the range `aim_r` (no parameter past its top
    rung, where its scale is its floor); then loosen every rung that is not needed. The
    score is the yield less the range share's shortfall (none while it holds: the yield's
    search alone). Returns (rungs, scales, (surrogate yield, range share))."""
    def score(yy):
        return yy[0] + min(0.0, yy[1] - aim_r)

    def scale_of(k, r):
        return max(TIGHTEN ** r, floor[k])

    def scales(r):
        return {k: scale_of(k, r[k]) for k in r}

    r = {k: min(v, top[k]) for k, v in rungs.items()}
    y = surrogate_yields(scales(r))
    while not _met(y, aim, aim_r):
        best, best_gain, best_y = None, 0.0, y
        for k in r:
            if r[k] >= top[k]:
                continue
            trial = {**r, k: r[k] + 1}
            yk = surrogate_yields(scales(trial))
            dc = cost[k] * (1.0 / scale_of(k, trial[k]) - 1.0 / scale_of(k, r[k]))
            gain = (score(yk) - score(y)) / dc
            if score(yk) > score(y) and gain > best_gain:
                best, best_gain, best_y = k, gain, yk
        if best is None:
            break
        r[best] += 1
        y = best_y
    changed = True
    while changed and _met(y, aim, aim_r):
        changed = False
        for k in sorted(r, key=lambda k: -cost[k]):
            if r[k] == 0:
                continue
            trial = {**r, k: r[k] - 1}
            yk = surrogate_yields(scales(trial))
            if _met(yk, aim, aim_r):
                r, y, changed = trial, yk, True
    return r, scales(r), y


def _refit(sur: Surrogate, runs: list[MonteCarloResult], keys, actual_of=None, fit=None) -> None:
    """Refit the surrogate's scales to every trial of `runs` (Monte Carlo results); actual_of:
    a run's values of the surrogate's criteria (default its judged criteria); fit(sur,
    phase, x, actual) (default Surrogate.calibrate)."""
    phase = np.concatenate([m.trials.phase for m in runs])
    x = {k: np.concatenate([BY_KEY[k].magnitude(m.trials, {"nose_mm": m.nominal_nose_mm,
                                                            "time_s": m.nominal_time_s}) for m in runs])
         for k in keys}
    actual = np.concatenate([judged_values(m.figures, m.settings.spec.calibrated) if actual_of is None
                             else actual_of(m) for m in runs])
    if fit is None:
        sur.calibrate(phase, x, actual)
    else:
        fit(sur, phase, x, actual)


def _surrogate_check(sur: Surrogate, mc: MonteCarloResult, keys) -> dict:
    """Fit the surrogate's scales to the Monte Carlo's own trials, then: its yield on them
    and how often it agrees with their traced pass / fail (before and after the fit)."""
    t = mc.trials
    nominal = {"nose_mm": mc.nominal_nose_mm, "time_s": mc.nominal_time_s}
    x = {k: BY_KEY[k].magnitude(t, nominal) for k in keys}
    actual = mc.pass_all
    before = sur.passes(t.phase, x)
    sur.calibrate(t.phase, x, judged_values(mc.figures, mc.settings.spec.calibrated))
    pred = sur.passes(t.phase, x)
    return {"yield_on_monte_carlo_trials": float(np.mean(pred)), "monte_carlo_yield": float(np.mean(actual)),
            "agreement": float(np.mean(pred == actual)), "agreement_unfitted": float(np.mean(before == actual)),
            "scale": {c: float(v) for c, v in zip(CRITERIA, sur.scale)}}


def _num(v: float) -> str:
    return f"{v:.3g}"
