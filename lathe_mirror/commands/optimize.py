"""`lathe-mirror optimize`: search the design under the envelope, the focus and the lathe."""

from __future__ import annotations

import argparse

from .common import add_common, add_no_progress, compute_options, load, print_result


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
    from ..optimize.winner import allocated_tolerances, optimize_design, pareto_inputs, toml_comments
    from ..shop.feasible import check_made

    settings = load(args, [("optimize.workers", args.workers, "--workers")])  # the estimate counts them
    out = pareto_path = None
    if args.output:
        from ..export.files import check_writable
        from .flags import check_suffix

        check_suffix(args.output, "TOML")
        out = check_writable(args.output)
        pareto_path = check_writable(out.with_name(out.stem + "_pareto.png"))
    from ..compute import activate, default_workers

    workers, scheduler = compute_options(args, settings)
    if workers is None and not scheduler:
        workers = settings.optimize.workers if settings.optimize.workers > 1 else default_workers()
    ex = activate(workers, scheduler)  # the search's generations and the winner's Monte Carlo
    ref_name = "paper" if _is_paper(settings) else "configured"
    result, data = optimize_design(settings, lambda s: check_made(s, "the best design found"),
                                   workers=min(max(ex.workers, 1), 64),  # optimize.workers' range
                                   check=not args.no_check, progress=not args.no_progress, ref_name=ref_name,
                                   as_written=_as_written(settings.camera))
    if out is not None:
        from ..export.design_toml import design_toml, write_design_toml
        from ..export.files import write_bytes
        from ..report.plots import pareto_plot

        extra = _user_sections(args.config)
        comments = toml_comments(data)
        alloc = (data.get("check") or {}).get("allocation")
        if alloc is not None and alloc.get("reached"):
            comments += allocated_tolerances(extra, alloc)
        text = design_toml(settings.camera, result.best, comments=comments, extra=extra)
        png = pareto_plot(*pareto_inputs(result, settings.optimize.objective, ref_name))
        write_design_toml(out, text)
        write_bytes(pareto_path, png)
        data["output"] = {"design": str(out), "pareto_plot": str(pareto_path)}
    print_result(args, data, format_result)
    return 0


def _as_written(camera):
    """The lobes as the design file holds them (export.design_toml's digits, read back):
    the winner optimize checks is the design it writes."""
    import dataclasses
    import tomllib

    from ..export.design_toml import design_toml

    def read_back(lobes):
        doc = tomllib.loads(design_toml(camera, lobes))["lobes"]
        return tuple(dataclasses.replace(s, **doc[s.name]) for s in lobes)

    return read_back


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
        if "replaced" in c.get("robust", {}):
            from ..optimize.winner import robust_statement

            lines.append(f"robust: {robust_statement(c)}")
        if "why" in c:
            lines.append(f"warning: {c['why']}")
    if best["hand"] != "as configured":
        lines.append("the outer lobe is recessed: the programs cut it with the tools in opposite-hand "
                     "holders (T3, T4), from the rim in")
    if "output" in data:
        lines.append(f"wrote {data['output']['design']} and {data['output']['pareto_plot']}")
    return "\n".join(lines)


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
