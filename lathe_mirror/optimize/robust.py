"""The robust winner: a design whose made parts reach the yield target at the configured
tolerances, when the search's winner's do not.

The search's delivered-R10 surrogate gives every candidate one made-part disparity error,
the configured design's (winner.made_parts), so it cannot see that the error grows with
the design. A pinhole decentred by e (the camera's own decentre, and a tilted seat's
lever arm: the tilt times the pivot's height) moves the image of a lobe at a distance D
from the pinhole by (f / t_pixel) e / D px (the parallax of a pinhole camera); the
calibration's one rotation removes the shift the two lobes share, not their difference:

    S = (f / t_pixel) |<1/z>_inner - <1/z>_outer|   px per mm of decentre,

<1/z> a lobe's mean inverse height above the pinhole over its radii, weighted by r (its
share of the image). S leaves out the mirror's own power, which takes most of that
parallax back: the trial tracer's calibrated disparity of a decentre e is 0.08-0.14 S e
on the 6 mm lens's front (tests/test_robust.py), so S orders the candidates and the
Monte Carlo judges them. On the matrix's 6 mm lens (f / t_pixel = 2000, a 25 mm deep
envelope) the search's winner, lobes at 31 and 49 mm, has S = 23.5 px/mm: its job-shop
parts' disparity error reaches 0.79 px (95th percentile of a 128-trial Monte Carlo) and
79 % of them pass; the candidates the search also found at S = 14.2, 8.4 and 5.9 px/mm
reach 0.55, 0.40 and 0.29 px and 91, 97 and 99 % (design R10 0.423, 0.372 and 0.320 m
against 0.437; the one at 8.4 confirmed by 1000 trials: 97.8 %, delivered p5 -7.3 %).

So when the winner's full Monte Carlo falls short of the target with its nominal part
passing, `robust_winner` takes the search's feasible candidates on the front of the
objective against S (each FRONT_STEP less sensitive than the one before, the winner
first) and walks down it, judging each by a small Monte Carlo of its own made parts
(tolerance.runs.made_disparity: the settings' seed for every candidate, so they are
compared on common random numbers), until one reaches the target and the full Monte
Carlo confirms it: the most-ranging candidate whose parts reach the target replaces the
winner. When none does, the winner stands and its tolerances are allocated
(winner.optimize_design).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np

from ..design import Mirror, mirror_from_specs
from ..errors import InputError
from ..tolerance.runs import made_disparity, winner_check
from .evaluate import Problem, design_of, figures
from .focus import design_blur_px
from .pareto import pareto_front
from .search import SearchResult

if TYPE_CHECKING:
    from ..settings import Settings

#: Each candidate judged on the front is at least this much (a fraction) less sensitive to
#: decentre than the one before it (and than the winner).
FRONT_STEP = 0.1
#: Trials of each candidate's small Monte Carlo (2 lattice phases; ~2.5 s of CPU on the
#: 6 mm lens, most of it cutting the two phases' parts; the pass fraction's standard error
#: at 95 % is 1.9 %).
SMALL_TRIALS = 128
#: Candidates judged by their small Monte Carlo at most (the front's first ones): a bound on
#: the time a design no candidate rescues costs before its tolerances are allocated.
SMALL_RUNS = 12
#: Full Monte Carlos confirming candidates (the bisection's choice, then the next less
#: sensitive ones) before the winner stands and its tolerances are allocated.
CONFIRMS = 3
#: Radii per lobe of the mean inverse height.
_RADII = 32


def decentre_sensitivity(mirror: Mirror) -> float:
    """S (px per mm): the lobes' differential image shift per mm of pinhole decentre that a
    common camera rotation cannot remove, (f / t_pixel) |<1/z>_inner - <1/z>_outer| (module
    doc); z the height above the pinhole, mm, averaged over each lobe's radii weighted by r."""
    cam = mirror.camera
    inv = []
    for lobe, (lo, hi) in zip(mirror.lobes, ((0.0, mirror.r_junction), (mirror.r_junction, mirror.r_max))):
        r = np.linspace(lo, hi, _RADII)
        w = r + 1e-12
        inv.append(float(np.sum(w / lobe.z(r)) / np.sum(w)))
    return cam.f / cam.t_pixel * abs(inv[0] - inv[1])


def robust_front(result: SearchResult, problem: Problem) -> list[tuple]:
    """The search's feasible candidates on the front of the objective (maximised) against
    decentre_sensitivity (minimised), each at least FRONT_STEP less sensitive than the one
    before, starting from the winner (not included): [(lobes, objective, S)], the most
    ranging first."""
    h = result.history
    feas = np.flatnonzero(h.feasible)
    if feas.size == 0:
        return []
    obj = h.column("objective")[feas]
    sens = np.array([decentre_sensitivity(mirror_from_specs(problem.camera, design_of(h.x[i], problem)))
                     for i in feas])
    s_last = decentre_sensitivity(mirror_from_specs(problem.camera, result.best))
    out = []
    for j in pareto_front(obj, -sens):  # objective descending
        if sens[j] <= (1.0 - FRONT_STEP) * s_last:
            out.append((design_of(h.x[feas[j]], problem), float(obj[j]), float(sens[j])))
            s_last = sens[j]
    return out


def robust_winner(result: SearchResult, problem: Problem, settings: Settings, check: dict,
                  check_made: Callable, *, progress: bool = False, as_written=None):
    """The most-ranging candidate of robust_front whose made parts reach the yield target
    (module doc): (result with it as the winner, its settings, its full check with what it
    replaced under "robust"), or None (the record of what was tried is put in `check`
    under "robust")."""
    target = settings.tolerance.target_yield
    front = robust_front(result, problem)
    if as_written is not None:
        front = [(as_written(lobes), obj, s) for lobes, obj, s in front]
    s0 = decentre_sensitivity(mirror_from_specs(problem.camera, result.best))
    small: dict[int, dict] = {}  # front index -> its small Monte Carlo (made_disparity)
    notes: dict[int, dict] = {}  # front index -> its full check's yield, or why it cannot be made

    def passes(i: int) -> bool:
        if i not in small:
            cand = dataclasses.replace(settings, lobes=front[i][0])
            m = cand.mirror()
            small[i] = made_disparity(m, cand, trials=SMALL_TRIALS, blur_px=design_blur_px(m, cand),
                                      progress=progress)
        return small[i]["yield"] >= target

    chosen, confirms = None, 0
    # down the front from the winner, each candidate's small Monte Carlo, until one
    # reaches the target and the full Monte Carlo confirms it (the yield is not monotone
    # along the front: S leaves out the machining, and the far end's designs fail other
    # criteria, so no bisection)
    for i in range(min(len(front), SMALL_RUNS)):
        if confirms >= CONFIRMS:
            break
        if not passes(i):
            continue
        cand = dataclasses.replace(settings, lobes=front[i][0])
        try:
            check_made(cand)
        except InputError as exc:
            notes[i] = {"refused": str(exc)}
            continue
        confirms += 1
        m = cand.mirror()
        full = winner_check(m, cand, progress=progress, blur_px=design_blur_px(m, cand), diagnose=False)
        notes[i] = {"confirmed_yield": full["yield"]}
        if full["nominal_pass"] and full["yield"] >= target:
            chosen = (i, cand, full)
            break
    record = {"why": "the search's surrogate gives every candidate the configured design's made-part disparity; "
                     "the winner's own parts fall short, so the candidates less sensitive to a decentred pinhole "
                     "are judged by their own (optimize.robust)",
              "winner_sensitivity_px_per_mm": s0, "front": len(front), "small_trials": SMALL_TRIALS,
              "judged": [{"objective": front[i][1], "sensitivity_px_per_mm": front[i][2],
                          "yield": small[i]["yield"], "pass_fraction": small[i]["pass_fraction"],
                          "disparity_px_p95": small[i]["disparity_px"],
                          "delivered_r10_m": small[i]["delivered_r10_m"], **notes.get(i, {})}
                         for i in sorted(small)]}
    if chosen is None:
        check["robust"] = record
        return None
    i, cand, full = chosen
    lobes = front[i][0]
    # the winner's figures with its own made parts' disparity (the small Monte Carlo's 95th percentile)
    fig = figures(lobes, dataclasses.replace(problem, made_disparity_px=small[i]["disparity_px"]))
    obj = fig.objective(problem.settings.objective)
    gain = None
    if result.reference_figures is not None:
        ref = result.reference_figures.objective(problem.settings.objective)
        gain = obj / ref if ref > 0 else None
    record.update({"chosen_sensitivity_px_per_mm": front[i][2],
                   "replaced": {"lobes": [{"name": s.name, "r_top": s.r_top, "r_pixel": s.r_pixel,
                                           "alpha_deg": s.alpha_deg} for s in result.best],
                                "objective": result.best_figures.objective(problem.settings.objective),
                                "yield": check["yield"], "why": check.get("why", "")}})
    full["robust"] = record
    return dataclasses.replace(result, best=lobes, best_figures=fig, gain=gain), cand, full
