"""`lathe-mirror optimize`: search the design under the envelope, the focus and the lathe."""

from __future__ import annotations

import argparse

from .common import add_common, add_no_progress, compute_options, load, print_json
from ..settings.keys import help_default


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "optimize", help="search the lobes for the best design under the constraints",
        description="Keep the camera fixed, search both lobes' r_top, r_pixel and alpha with seeded "
        "differential evolution, and maximise [optimize] objective (by default the R10 the made parts "
        "deliver, 5th percentile) under the "
        "envelope, band, image, focus and lathe constraints. Prints the winner beside the configured "
        "(paper's) design; -o writes it as a TOML every command takes with --config, and the Pareto "
        "plot beside it.")
    add_common(p, output_help="write the best design as a TOML configuration (and <stem>_pareto.png "
                              "beside it)")
    p.add_argument("--workers", type=int, default=None, metavar="N",
                   help="processes evaluating each generation (default [compute] workers, else "
                   "optimize.workers when set above 1, else all cores; 1 runs them in this process); "
                   "the same seed gives the same winner with any number")
    p.add_argument("--scheduler", metavar="ADDRESS", default=None,
                   help="evaluate the generations on the Dask cluster at this scheduler address "
                   "(tcp://HOST:PORT; default [compute] scheduler)")
    p.add_argument("--no-check", action="store_true",
                   help="skip the winner's tolerance check (the best program with the configured tool: the "
                   "nominal part against [tolerance.spec] and the yield against tolerance.target_yield; a winner "
                   "that fails nominal is replaced by the best runner-up design of the search that passes)")
    add_no_progress(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    import dataclasses

    from ..errors import InputError
    from ..optimize import Problem, search
    from ..optimize.spec import Objective
    from ..optimize.evaluate import constraint_table

    settings = load(args, [("optimize.workers", args.workers, "--workers")])  # the estimate counts them
    out = pareto_path = None
    if args.output:
        from ..export.files import check_writable
        from .flags import check_suffix

        check_suffix(args.output, "TOML")
        out = check_writable(args.output)
        pareto_path = check_writable(out.with_name(out.stem + "_pareto.png"))
    problem = Problem(camera=settings.camera, tool=settings.tool, stock=settings.stock, body=settings.body,
                      clearance=settings.toolpath.clearance, settings=settings.optimize,
                      reference=settings.lobes)
    from ..compute import activate, default_workers

    workers, scheduler = compute_options(args, settings)
    if workers is None and not scheduler:
        workers = settings.optimize.workers if settings.optimize.workers > 1 else default_workers()
    ex = activate(workers, scheduler)  # the search's generations and the winner's Monte Carlo
    robust = settings.optimize.objective is Objective.DELIVERED
    made = None
    if robust:
        problem, made = made_parts(problem, settings, progress=not args.no_progress)
    result = search(problem, workers=min(max(ex.workers, 1), 64),  # optimize.workers' range
                    progress=not args.no_progress)
    best = dataclasses.replace(settings, lobes=result.best)
    check_made(best)
    check = None
    if not args.no_check:
        from ..optimize.focus import design_blur_px
        from ..tolerance.runs import winner_check

        check = winner_check(best.mirror(), best, progress=not args.no_progress,
                             blur_px=design_blur_px(best.mirror(), best), allocate=robust)
        if not check["nominal_pass"]:  # the runner-up designs, until one passes nominal
            result, best, check = runner_up(result, problem, settings, check, progress=not args.no_progress)
    ref_name = "paper" if _is_paper(settings) else "configured"
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
        "pareto": _fronts(result),
        "heights_above_pinhole_mm": {"vertex": result.best_figures.vertex_mm, "far": result.best_figures.far_mm},
        "bound_margin": o.bound_margin,
        "warnings": bound_warnings(result, problem),
    }
    if made is not None:
        data["made_parts"] = made
    if check is not None:
        data["check"] = check
    if out is not None:
        from ..export.design_toml import design_toml, write_design_toml
        from ..export.files import write_bytes

        extra = _user_sections(args.config)
        comments = _toml_comments(data)
        alloc = (check or {}).get("allocation")
        if alloc is not None and alloc.get("reached"):
            comments += allocated_tolerances(extra, alloc)
        text = design_toml(settings.camera, result.best, comments=comments, extra=extra)
        png = _pareto_png(result, o.objective, ref_name)
        write_design_toml(out, text)
        write_bytes(pareto_path, png)
        data["output"] = {"design": str(out), "pareto_plot": str(pareto_path)}
    if args.json:
        print_json(data)
    else:
        print(format_result(data))
    return 0


def made_parts(problem, settings, *, progress: bool = False):
    """The delivered-R10 objective's part error: the configured design's made parts at the
    configured tolerances, a small seeded Monte Carlo (tolerance.runs.made_disparity, its
    95th percentile); (problem with it, what was measured). A configured design that
    cannot be made as configured (another camera's lobes) leaves the part error 0: the
    surrogate then counts the blur alone, and the winner's full Monte Carlo the rest."""
    import dataclasses

    from ..errors import InputError
    from ..optimize.focus import design_blur_px
    from ..tolerance.runs import made_disparity

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
    from ..tolerance.spec import MACHINE_DRAWN

    tol = extra.setdefault("tolerance", {})
    for r in alloc["tolerances"]:
        section = "machine_errors" if r["parameter"] in MACHINE_DRAWN else "params"
        tol.setdefault(section, {})[r["parameter"]] = float(f"{r['allocated']:.6g}")
    tight = [r for r in alloc["tolerances"] if r["tighten"]]
    what = ", ".join(f"{r['parameter']} {r['tolerance']:.4g} -> {r['allocated']:.4g} {r['unit']}" for r in tight)
    return [f"[tolerance] carries the least-cost tolerances that reach {100 * alloc['target_yield']:g} % yield "
            f"(tolerance --config THIS_FILE confirms it: {100 * alloc['yield']:.1f} % of {alloc['trials']} trials, "
            f"seed {alloc['seed']})",
            f"their cost: {alloc['cost_ratio']:.3g} x the configured tolerances' ([tolerance.cost]); tightened: "
            f"{what or 'nothing'}"]


def bound_warnings(result, problem) -> list[str]:
    """One line per bound the winner sits on: a searched parameter at the edge of its range
    less optimize.bound_margin (it would go further: widen optimize.search), and each active
    constraint (the key that limits the design)."""
    import numpy as np

    from ..optimize.evaluate import constraint_table, vector_of
    from ..optimize.spec import PARAMETERS

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


def runner_up(result, problem, settings, check: dict, *, progress: bool = False):
    """The winner fails the tolerance verdict nominal (a made-part figure the search does
    not model): the search's runner-up designs (optimize.search.alternates), best first,
    each through check_made and the nominal verdict; the first that passes replaces the
    winner (its full check, with what was replaced and why). (result, settings, check)."""
    import dataclasses

    from ..errors import InputError
    from ..optimize import figures
    from ..optimize.focus import design_blur_px
    from ..optimize.search import alternates
    from ..tolerance.runs import winner_check

    obj0 = result.best_figures.objective(problem.settings.objective)
    tried = []
    for lobes in alternates(result, problem):
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


def check_made(settings) -> None:
    """The winner through the checks `run` makes before it writes anything: the junction
    and the polishing times (job.check_programs), the CAD body (job.check_cad),
    and both programs planned and simulated against the stock (shop.programs.shop_programs:
    gouge, bar, travel, no rapid or insert body in stock). An InputError here names the
    check the winner fails."""
    from ..errors import InputError
    from ..job import check_cad, check_programs
    from ..shop.programs import shop_programs

    mirror = settings.mirror()
    try:
        check_programs(settings, mirror)
        check_cad(settings, mirror)
        shop_programs(settings, mirror)
    except InputError as exc:
        raise InputError(f"the best design found cannot be made as configured: {exc}") from None


def format_result(data: dict) -> str:
    """The winner beside the configured design, the search and the active constraints."""
    best, ref = data["best"], data["reference"]
    name = data["reference_name"]
    s = data["search"]
    lines = [f"objective {data['objective']} (median over {data['band_deg']['min']:g}..{data['band_deg']['max']:g} "
             f"deg for r10), seed {s['seed']}: {s['evaluations']} designs ({s['feasible']} feasible) in "
             f"{s['seconds']:.1f} s, {s['evaluations_per_second']:.0f} per second on {s['workers']} "
             f"process{'es' if s['workers'] > 1 else ''}, {s['generations']} generations"
             + ("" if s["converged"] else " (not converged: raise optimize.maxiter)"), ""]
    cols = [(name, ref), ("best", best)] if ref is not None else [("best", best)]
    lines.append(f"{'':26s}" + "".join(f"{c:>18s}" for c, _ in cols))

    def row(label, fmt):
        lines.append(f"{label:26s}" + "".join(f"{fmt(d):>18s}" for _, d in cols))

    for k, lobe in enumerate(("inner", "outer")):
        row(f"{lobe} r_top [mm]", lambda d, k=k: f"{d['lobes'][k]['r_top']:.3f}")
        row(f"{lobe} r_pixel [px]", lambda d, k=k: f"{d['lobes'][k]['r_pixel']:.3f}")
        row(f"{lobe} alpha [deg]", lambda d, k=k: f"{d['lobes'][k]['alpha_deg']:.3f}")
    row("baseline [mm]", lambda d: f"{d['baseline_mm']:.3f}")
    row("common band [deg]", lambda d: f"{d['band_deg']['min']:.2f}..{d['band_deg']['max']:.2f}")
    row("design R10 [m]", lambda d: f"{d['design_r10_m']:.4f}")
    row("sharp R10 [m]", lambda d: f"{d['sharp_r10_m']:.4f}")
    row("delivered R10 p5 [m]", lambda d: f"{d['delivered_r10_m']:.4f}")
    row("blur [px]", lambda d: f"{d['blur_px']:.2f}")
    row("step [mm]", lambda d: f"{d['step_mm']:.3f} {d['recessed']}")
    row("usable pixels", lambda d: f"{100 * d['usable_share']:.1f} %")
    row("vertex..far [mm]", lambda d: f"{d['vertex_mm']:.2f}..{d['far_mm']:.2f}")
    row("depth [mm]", lambda d: f"{d['depth_mm']:.3f}")
    lines.append("")
    if data["gain"] is not None:
        lines.append(f"best / {name}: {data['gain']:.4f} x the {name} design's {data['objective']} "
                     f"({100 * (data['gain'] - 1):+.2f} %)"
                     + ("" if data["reference_feasible"] else f"; the {name} design breaks a constraint"))
    h = data["heights_above_pinhole_mm"]
    lines.append(f"heights above the pinhole: vertex {h['vertex']:.3f} mm, farthest point {h['far']:.3f} mm "
                 f"(depth {best['depth_mm']:.3f} mm)")
    for w in data["warnings"]:
        lines.append(f"warning: {w}")
    if "check" in data:
        c = data["check"]
        verdict = "PASS" if c["nominal_pass"] else "FAIL"
        part = f"{c['made_mirror']}, " if "made_mirror" in c else f"{c['program']} program, "
        lines.append(f"tolerance check ({part}default tolerances): nominal "
                     f"{verdict}, yield {100 * c['yield']:.1f} % of {c['trials']} trials (target "
                     f"{100 * c['target_yield']:g} %)")
        if "delivered_r10_m" in c:
            d, dd = c["delivered_r10_m"], c["delivered"]
            lines.append(f"delivered R10 (the made parts, calibrated, blur {dd['blur_px']:.1f} px): 5th percentile "
                         f"{d['p5']:.4f} m, median {d['median']:.4f} m (design {d['design']:.4f} m, sharp {d['sharp']:.4f} m)")
        if "replaced" in c:
            r = c["replaced"]
            lines.append(f"the best design found (objective {r['objective']:.6g}) fails the tolerance verdict "
                         f"nominal ({r['why'].split(':')[0].removeprefix('the nominal part fails ')}): the best "
                         f"of the {len(r['tried'])} runner-up designs tried that passes is the winner")
        if "why" in c:
            lines.append(f"warning: {c['why']}")
    if best["hand"] != "as configured":
        lines.append("the outer lobe is recessed: the programs cut it with the tools in opposite-hand "
                     "holders (T3, T4), from the rim in")
    if "output" in data:
        lines.append(f"wrote {data['output']['design']} and {data['output']['pareto_plot']}")
    return "\n".join(lines)


def _fronts(result) -> dict:
    h = result.history
    obj, band, depth = h.column("objective"), h.column("band_width_deg"), h.column("depth_mm")
    return {"band_width": [[float(obj[i]), float(band[i])] for i in result.pareto_band],
            "depth": [[float(obj[i]), float(depth[i])] for i in result.pareto_depth]}


def _pareto_png(result, objective, ref_name: str) -> bytes:
    from ..report.plots import pareto_plot

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
    return pareto_plot(objective.label, cand, fronts, marks)


def _toml_comments(data: dict) -> list[str]:
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
    return lines


def best_value(data: dict, fig: dict) -> float:
    key = {"delivered_r10_p5": "delivered_r10_m", "r10": "sharp_r10_m", "baseline": "baseline_mm", "band_width": "band_width_deg",
           "usable_area": "usable_share"}[data["objective"]]
    return fig[key]


def _user_sections(path) -> dict:
    """The user's own configuration file (already checked by load), passed through to the
    written design: every section but [camera] and [lobes], which the design replaces."""
    if path is None:
        return {}
    from ..config import read_user

    doc = read_user(path)
    return {k: v for k, v in doc.items() if k not in ("camera", "lobes")}


def _is_paper(settings) -> bool:
    from ..config import load as load_settings

    paper = load_settings()
    cam, ref = settings.camera, paper.camera
    return settings.lobes == paper.lobes and (cam.f, cam.t_pixel, cam.sensor_px) == (ref.f, ref.t_pixel,
                                                                                     ref.sensor_px)
