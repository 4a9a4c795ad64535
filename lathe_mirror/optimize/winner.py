"""The optimiser's winner as `lathe-mirror optimize` gives it: the search on the configured
problem (with the made parts' disparity when the objective is the delivered R10), the
winner's tolerance check (a winner that fails it nominal replaced by the best runner-up
that passes), the figures the command prints and writes, and the design file's comments.

The optimiser sits before the shop in the data flow: the checks a design must pass to be
made (the programs simulated against the stock, the CAD body) are handed in as `check_made`
(shop.feasible.check_made).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import TYPE_CHECKING

from ..design import LobeSpec
from ..errors import InputError
from ..tolerance.runs import made_disparity, winner_check
from ..tolerance.spec import MACHINE_DRAWN
from .evaluate import Problem, check_grip_room, constraint_table, figures, second_grip_mm, vector_of
from .focus import design_blur_px
from .robust import robust_winner
from .search import SearchResult, alternates, search
from .spec import PARAMETERS, Objective

if TYPE_CHECKING:
    from ..settings import Settings

#: A design's feasibility check: raises InputError naming what cannot be made.
CheckMade = Callable[["Settings"], None]
#: The lobes as the design file holds them (its floats' digits): what `tolerance --config`
#: on the written file judges, so the winner's check judges the same.
AsWritten = Callable[[tuple[LobeSpec, LobeSpec]], tuple[LobeSpec, LobeSpec]]


def problem_of(settings: Settings) -> Problem:
    """The search's problem: the configured camera, tool, stock, body, clearance and the
    second set-up's grip under [optimize], the configured lobes as the reference.
    InputError when the configured grip leaves no body possible (before any search)."""
    check_grip_room(settings.body, settings.toolpath, settings.machine)
    return Problem(camera=settings.camera, tool=settings.tool, stock=settings.stock, body=settings.body,
                   clearance=settings.toolpath.clearance, settings=settings.optimize,
                   reference=settings.lobes,
                   grip_mm=second_grip_mm(settings.body, settings.toolpath, settings.machine))


def optimize_design(settings: Settings, check_made: CheckMade, *, workers: int, check: bool = True,
                    progress: bool = False, ref_name: str = "configured",
                    as_written: AsWritten | None = None) -> tuple[SearchResult, dict]:
    """The search on `workers` processes of the active executor, the winner through
    check_made and (check) its tolerance check; (the search's result, the figures).
    as_written: the lobes as the design file will hold them; the winner (and any runner-up)
    is that design, so the check judges the part `tolerance --config` on the file judges."""
    problem = problem_of(settings)
    robust = settings.optimize.objective is Objective.DELIVERED
    made = None
    if robust:
        problem, made = made_parts(problem, settings, progress=progress)
    result = search(problem, workers=workers, progress=progress)
    if as_written is not None:
        lobes = as_written(result.best)
        result = dataclasses.replace(result, best=lobes, best_figures=figures(lobes, problem))
    best = dataclasses.replace(settings, lobes=result.best)
    check_made(best)
    verdict = None
    if check:
        # the robust objective: a winner whose parts fall short gives way to the most-ranging
        # candidate whose parts reach the target (optimize.robust); if none does, its
        # tolerances are allocated
        verdict = winner_check(best.mirror(), best, progress=progress,
                               blur_px=design_blur_px(best.mirror(), best), diagnose=not robust)
        if not verdict["nominal_pass"]:  # the runner-up designs, until one passes nominal
            result, best, verdict = runner_up(result, problem, settings, verdict, check_made, progress=progress,
                                              as_written=as_written)
        elif robust and verdict["yield"] < settings.tolerance.target_yield:
            found = robust_winner(result, problem, settings, verdict, check_made, progress=progress,
                                  as_written=as_written)
            if found is not None:
                result, best, verdict = found
            else:
                tried = verdict.get("robust")
                verdict = winner_check(best.mirror(), best, progress=progress,
                                       blur_px=design_blur_px(best.mirror(), best), allocate=True)
                if tried is not None:
                    verdict["robust"] = tried
        elif robust and _range_short(verdict, settings):
            # the yield holds but the made parts lose more range than
            # tolerance.delivered_p5_min_fraction allows: the allocation tightens for it
            verdict = winner_check(best.mirror(), best, progress=progress,
                                   blur_px=design_blur_px(best.mirror(), best), allocate=True)
    return result, result_figures(result, problem, settings, made, verdict, ref_name)


def _range_short(verdict: dict, settings: Settings) -> bool:
    """Whether the winner's delivered R10 p5 falls below tolerance.delivered_p5_min_fraction
    of its design R10 (winner_check's Monte Carlo)."""
    d = verdict.get("delivered_r10_m")
    return d is not None and d["p5"] < settings.tolerance.delivered_p5_min_fraction * d["design"]


def result_figures(result: SearchResult, problem: Problem, settings: Settings, made: dict | None,
                   check: dict | None, ref_name: str = "configured") -> dict:
    """The winner beside the configured design, the search, the fronts, the bounds it sits
    on, the made parts measured and the tolerance check (None: not made); ref_name: what
    the configured design is called ("paper" on the paper's)."""
    o = settings.optimize
    data = {
        "objective": o.objective.value,
        "objective_unit": o.objective.unit,
        "band_deg": {"min": o.band_deg[0], "max": o.band_deg[1]},
        "best": result.best_figures.to_dict(),
        "reference": None if result.reference_figures is None else result.reference_figures.to_dict(),
        "reference_name": ref_name,
        "reference_feasible": result.reference_feasible,
        "gain": result.gain,
        "constraints": constraint_table(result.best_figures, problem),
        "search": {"seed": o.seed, "workers": result.workers, "evaluations": result.evaluations,
                   "feasible": int(result.history.feasible.sum()), "generations": result.generations,
                   "converged": result.converged, "seconds": result.seconds,
                   "evaluations_per_second": result.evaluations_per_second},
        "pareto": fronts(result),
        "heights_above_pinhole_mm": {"vertex": result.best_figures.vertex_mm, "far": result.best_figures.far_mm},
        "bound_margin": o.bound_margin,
        "warnings": bound_warnings(result, problem),
    }
    if made is not None:
        data["made_parts"] = made
    if check is not None:
        data["check"] = check
    return data


def made_parts(problem, settings, *, progress: bool = False):
    """The delivered-R10 objective's part error: the configured design's made parts at the
    configured tolerances, a small seeded Monte Carlo (tolerance.runs.made_disparity, its
    95th percentile); (problem with it, what was measured). A configured design that
    cannot be made as configured (another camera's lobes) leaves the part error 0: the
    surrogate then counts the blur alone, and the winner's full Monte Carlo the rest."""
    noise = settings.tolerance.matching_noise_px
    try:
        mirror = settings.mirror()
        made = made_disparity(mirror, settings, blur_px=design_blur_px(mirror, settings), progress=progress)
    except InputError as exc:
        made = {"disparity_px": 0.0, "skipped": str(exc)}
    return dataclasses.replace(problem, made_disparity_px=made["disparity_px"], matching_noise_px=noise), made


def allocated_tolerances(extra: dict, alloc: dict) -> list[str]:
    """Write the allocation's tolerances into the design's [tolerance.params] and
    [tolerance.machine_errors] (extra: the sections passed through), so that `tolerance
    --config` on the file draws the same trials at them (its seed) and confirms the yield;
    the comment lines saying what they cost."""
    tol = extra.setdefault("tolerance", {})
    for r in alloc["tolerances"]:
        section = "machine_errors" if r["parameter"] in MACHINE_DRAWN else "params"
        tol.setdefault(section, {})[r["parameter"]] = float(f"{r['allocated']:.6g}")
    tight = [r for r in alloc["tolerances"] if r["tighten"]]
    what = ", ".join(f"{r['parameter']} {r['tolerance']:.4g} -> {r['allocated']:.4g} {r['unit']}" for r in tight)
    d = alloc.get("delivered")
    rng = "" if d is None else (f" and a delivered R10 p5 of at least {100 * d['min_fraction']:g} % of the design's "
                                f"{d['design_r10_m']:.4g} m")
    got = "" if d is None else f"; delivered R10 p5 {d['p5_m']:.4g} m, {100 * d['p5_fraction']:.1f} %"
    return [f"[tolerance] carries the least-cost tolerances that reach {100 * alloc['target_yield']:g} % yield{rng} "
            f"(tolerance --config THIS_FILE confirms it: {100 * alloc['yield']:.1f} % of {alloc['trials']} trials"
            f"{got}, seed {alloc['seed']})",
            f"their cost: {alloc['cost_ratio']:.3g} x the configured tolerances' ([tolerance.cost]); tightened: "
            f"{what or 'nothing'}"]


def bound_warnings(result, problem) -> list[str]:
    """One line per bound the winner sits on: a searched parameter at the edge of its range
    less optimize.bound_margin (it would go further: widen optimize.search), and each active
    constraint (the key that limits the design)."""
    s = problem.settings
    out = []
    x = vector_of(result.best, problem)
    for name, v, (lo, hi), (lo0, hi0) in zip(PARAMETERS, x, s.margin_bounds(), s.search.bounds()):
        if hi0 <= lo0:
            continue
        tol = 1e-3 * (hi0 - lo0)
        for end, b, b0 in (("low", lo, lo0), ("high", hi, hi0)):
            if abs(v - b) <= tol and not (name.startswith("outer_r_") and end == "high" and b >= 1.0):
                out.append(f"optimize.search.{name} = {float(v):.6g} sits on its {end} bound ({b0:g}, kept "
                           f"{100 * s.bound_margin:g} % of the range clear: {b:.6g}); widen the range to let it go on")
    for c in constraint_table(result.best_figures, problem):
        if c["active"]:
            out.append(f"{c['key']}: the winner sits on this bound ({c['what']} {c['value']:.6g}, {c['bound']} "
                       f"{c['limit']:.6g}{' ' + c['unit'] if c['unit'] else ''})")
    return out


def runner_up(result, problem, settings, check: dict, check_made: CheckMade, *, progress: bool = False,
              as_written: AsWritten | None = None):
    """The winner fails the tolerance verdict nominal (a made-part figure the search does
    not model): the search's runner-up designs (optimize.search.alternates), best first,
    each through check_made and the nominal verdict; the first that passes replaces the
    winner (its full check, with what was replaced and why). (result, settings, check)."""
    obj0 = result.best_figures.objective(problem.settings.objective)
    tried = []
    for lobes in alternates(result, problem):
        lobes = lobes if as_written is None else as_written(lobes)
        cand = dataclasses.replace(settings, lobes=lobes)
        fig = figures(lobes, problem)
        obj = fig.objective(problem.settings.objective)
        try:
            check_made(cand)
        except InputError as exc:
            tried.append({"objective": obj, "refused": str(exc)})
            continue
        nom = winner_check(cand.mirror(), cand, nominal_only=True, progress=progress)
        tried.append({"objective": obj, "failing": [c for c, v in nom["nominal"].items() if not v["pass"]]})
        if nom["nominal_pass"]:
            full = winner_check(cand.mirror(), cand, progress=progress,
                                blur_px=design_blur_px(cand.mirror(), cand),
                                allocate=settings.optimize.objective.value == "delivered_r10_p5")
            full["replaced"] = {"objective": obj0, "why": check["why"], "tried": tried}
            gain = None if result.gain is None else result.gain * obj / obj0
            return dataclasses.replace(result, best=lobes, best_figures=fig, gain=gain), cand, full
    check["alternates"] = tried
    if tried:
        check["why"] += f"; the next {len(tried)} designs the search found fail it too"
    return result, dataclasses.replace(settings, lobes=result.best), check


def fronts(result: SearchResult) -> dict:
    """Both Pareto fronts of the search (objective against band width, against depth)."""
    h = result.history
    obj, band, depth = h.column("objective"), h.column("band_width_deg"), h.column("depth_mm")
    return {"band_width": [[float(obj[i]), float(band[i])] for i in result.pareto_band],
            "depth": [[float(obj[i]), float(depth[i])] for i in result.pareto_depth]}


def toml_comments(data: dict) -> list[str]:
    """The design file's head: what it is, its objective against the configured design's,
    the search, the winner's figures."""
    best, s = data["best"], data["search"]
    lines = ["lathe-mirror optimize: the best design found (lathe-mirror run --config THIS_FILE machines it)",
             f"objective {data['objective']}: {best_value(data, best):.6g} {data['objective_unit']}".rstrip()]
    if data["gain"] is not None:
        lines.append(f"{data['gain']:.4f} x the {data['reference_name']} design's "
                     f"{best_value(data, data['reference']):.6g} {data['objective_unit']}".rstrip())
    lines.append(f"seed {s['seed']}, {s['generations']} generations, {s['evaluations']} designs evaluated")
    lines.append(f"baseline {best['baseline_mm']:.3f} mm, common band {best['band_deg']['min']:.2f}.."
                 f"{best['band_deg']['max']:.2f} deg, design R10 {best['design_r10_m']:.4f} m (sharp {best['sharp_r10_m']:.4f}), blur {best['blur_px']:.2f} px, "
                 f"step {best['step_mm']:.3f} mm ({best['recessed']} lobe recessed), usable "
                 f"{100 * best['usable_share']:.1f} %")
    robust = (data.get("check") or {}).get("robust")
    if robust is not None and "replaced" in robust:
        lines.append(robust_statement(data["check"]))
    return lines


def robust_statement(check: dict) -> str:
    """One line: the search's winner's parts fell short of the yield, so this design, the
    most-ranging candidate whose parts reach it, replaced it (optimize.robust)."""
    r = check["robust"]
    rep = r["replaced"]
    return (f"replaces the search's winner (objective {rep['objective']:.6g}, decentre sensitivity "
            f"{r['winner_sensitivity_px_per_mm']:.3g} px/mm): its parts yield {100 * rep['yield']:.1f} % at the "
            f"configured tolerances; this design ({r['chosen_sensitivity_px_per_mm']:.3g} px/mm) is the "
            f"most-ranging one the search found whose parts reach {100 * check['target_yield']:g} % "
            f"({100 * check['yield']:.1f} % of {check['trials']} trials)")


def best_value(data: dict, fig: dict) -> float:
    """A design's figures' value of the objective."""
    key = {"delivered_r10_p5": "delivered_r10_m", "r10": "sharp_r10_m", "baseline": "baseline_mm", "band_width": "band_width_deg",
           "usable_area": "usable_share"}[data["objective"]]
    return fig[key]


def pareto_inputs(result: SearchResult, objective: Objective, ref_name: str) -> tuple:
    """report.plots.pareto_plot's arguments: the objective's label, the feasible designs'
    objective, band width and depth, the two fronts (indices into them) and the configured
    design's and the winner's marks."""
    h = result.history
    feas = h.feasible
    idx = {i: k for k, i in enumerate(feas.nonzero()[0])}
    cand = {k: h.column(k)[feas] for k in ("objective", "band_width_deg", "depth_mm")}
    fronts = {"band": [idx[i] for i in result.pareto_band], "depth": [idx[i] for i in result.pareto_depth]}
    marks = {}
    for name, fig in ((ref_name + " design", result.reference_figures), ("best", result.best_figures)):
        if fig is not None:
            marks[name] = {"objective": fig.objective(objective), "band_width_deg": fig.band_width_deg,
                           "depth_mm": fig.depth_mm}
    return objective.label, cand, fronts, marks

