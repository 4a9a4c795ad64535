"""`lathe-mirror tolerance`: seeded Monte Carlo, sensitivity, yield, and what to tighten."""

from __future__ import annotations

import argparse

from .common import add_common, add_compute, add_no_progress, load_on_executor, path_arg, print_result
from ..settings.keys import help_default


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("tolerance", help="Monte Carlo over machine, polishing and assembly; yield; allocation",
                       description="Tolerance analysis ([tolerance] settings): a seeded Monte Carlo "
                       "over the machine (lattice phase, nose radius, tool setting X and Z), the polishing "
                       "time and the assembly (camera decentre, tilt and pupil, the mirror seat's tilt), "
                       "judged after what a calibration removes, a sensitivity table, each parameter's "
                       "inverse sensitivity and the yield against the spec, for each program in "
                       "tolerance.programs. --allocate: the least-cost tolerances that reach the target "
                       "yield, confirmed by a fresh Monte Carlo. --surface measured:FILE: a part that exists, as "
                       "measured: its verdict, and a Monte Carlo of its assembly alone.")
    add_common(p, output_help="directory for tolerance.json")
    p.add_argument("--trials", type=int, default=None, metavar="N", help=f"Monte Carlo trials ({help_default('tolerance.trials')})")
    p.add_argument("--seed", type=int, default=None, metavar="S", help=f"seed of every draw ({help_default('tolerance.seed')})")
    p.add_argument("--allocate", action="store_true",
                   help="tighten the tolerances at least cost ([tolerance.cost]) to reach the target yield, "
                   "confirmed by a fresh Monte Carlo of as many trials (about the Monte Carlo's time again)")
    p.add_argument("--target-yield", type=float, default=None, metavar="P",
                   help=f"the allocation's target yield ({help_default('tolerance.target_yield')})")
    p.add_argument("--csv", metavar="FILE", default=None, type=path_arg,
                   help="write one row per trial (drawn parameters, every figure, pass flags) of every "
                   "Monte Carlo run, the allocation's confirming runs included; its directory must exist")
    p.add_argument("--surface", metavar="measured:FILE", default=None,
                   help="judge a part that exists: the measured part (measured:FILE, as `lathe-mirror measure` "
                   "reads it; the design plus the fitted, axisymmetric residual), its nominal verdict over the "
                   "zones every command uses and a Monte Carlo of its assembly only (camera pose, seat tilt): "
                   "a made part has no machining tolerance left")
    add_compute(p, "the Monte Carlo trials, the sensitivity runs and the allocation's confirmations")
    add_no_progress(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ..errors import InputError
    from ..tolerance.analysis import tolerance_plan
    from .common import surface_arg

    if args.target_yield is not None:
        if not args.allocate:
            raise InputError("--target-yield applies to --allocate (the allocation's target)")
    settings = load_on_executor(args, [("tolerance.trials", args.trials, "--trials"), ("tolerance.seed", args.seed, "--seed"),
                                       ("tolerance.target_yield", args.target_yield, "--target-yield")])
    measured = None
    if args.surface is not None:
        _, measured = surface_arg(args.surface)
        if measured is None:
            raise InputError(f"--surface {args.surface!r}: tolerance takes measured:FILE (the programs' parts are "
                             "toleranced without --surface)")
    # bad input stops here (the programs' checks, the measured file read and fitted),
    # before the output directory is made
    plan = tolerance_plan(settings, measured)
    if args.csv:
        from ..export.files import check_writable
        from .flags import check_suffix

        check_suffix(args.csv, "CSV", "--csv")
        check_writable(args.csv, "--csv")
    if args.output:
        from .common import check_outputs, output_dir

        check_outputs(args.output, ["tolerance.json", *plan.histograms])
        output_dir(args.output)
    runs = plan.run(progress=not args.no_progress, allocate=args.allocate)
    from ..report.tolerance_files import write_tolerance

    write_tolerance(args.output, args.csv, runs.figures, runs.results)
    print_result(args, runs.figures, format_tolerance)
    return 0


def format_tolerance(out: dict) -> str:
    """The analysis as text: per program the verdict, the yield with its interval, what to
    tighten, the headline figures, the sensitivity and inverse sensitivity."""
    from ..tolerance.stats import percent_interval

    spec = out["spec"]
    lines = [f"spec ({'calibrated' if spec['calibrated'] else 'raw'} figures): RMS image displacement <= "
             f"{spec['image_displacement_px']:g} px per lobe, depth error <= {spec['depth_error_pct']:g} % at "
             f"{spec['depth_range_m']:g} m (as disparity, 90 % of the band), RMS slope error <= "
             f"{spec['slope_error_rad']:g} rad; {out['trials']} trials, seed {out['seed']}"]
    if "measured_part" in out:
        mp = out["measured_part"]
        lines.append(f"judged: {mp['made_mirror']} ({mp['note']})")
    zn = next((t["monte_carlo"].get("zones") for t in out["programs"].values()), None)
    if zn is not None:
        from ..optics.zones import describe_dict

        lines.append(describe_dict(zn))
    for name, t in out["programs"].items():
        v, mc = t["verdict"], t["monte_carlo"]
        what = t["made_mirror"]["label"] if "measured_part" in out else \
            f"{name} program ({t['made_mirror']['label']} nominal)"
        lines.append(f"{what}: nominal {'PASS' if v['nominal_pass'] else 'FAIL'}, yield "
                     f"{percent_interval(mc['passed'], mc['trials'])}")
        if "allocation" in t:
            lines.append(f"  {t['allocation']['statement']}")
        for key, what in (("nominal_over_zone", "judged"), ("as_machined_over_zone", "as machined")):
            if key in t:  # the shared figure of the judged part and of the part calib and the report describe
                z = t[key]
                lines.append(f"  image displacement over the used zone ({what}: {z['made_mirror']}), px RMS "
                             + " / ".join(f"{lb['name']} {lb['image_displacement_px']['rms']:.4g}" for lb in z["lobes"]))
        for k, c in v["checks"].items():
            lines.append(f"  nominal {k}: {c['nominal']:.4g} (limit {c['limit']:.4g}) {'PASS' if c['pass'] else 'FAIL'}; "
                         f"pass fraction {100 * mc['pass_fraction'][k]:.1f} %")
        st = t["stereo"]
        i = st["ranges_m"].index(spec["depth_range_m"]) if spec["depth_range_m"] in st["ranges_m"] else None
        if i is not None:
            c = st["calibrated"]
            lines.append(f"  stereo at {spec['depth_range_m']:g} m (nominal, calibrated): disparity median "
                         f"{c['disparity_px_median'][i]:.3g} / p90 {c['disparity_px_p90'][i]:.3g} px (limit "
                         f"{st['disparity_limit_px']:.3g}), within 5 % {100 * c['within_5_pct'][i]:.0f} %, within 10 % "
                         f"{100 * c['within_10_pct'][i]:.0f} %, seen {100 * c['seen_fraction'][i]:.0f} %; matching "
                         f"floor {st['matching_floor_pct'][i]:.3g} %")
        for r in t["sensitivity"]["rows"]:
            m, p = r["minus"], r["plus"]
            lines.append(f"  {r['parameter']:>20s} -/+ {r['tolerance']}: calibrated image disp. px "
                         f"{max(m['calibrated']['image_displacement_px_rms']):.3f} / "
                         f"{max(p['calibrated']['image_displacement_px_rms']):.3f}, disparity p90 px "
                         f"{m['calibrated']['disparity_px_p90']:.3g} / {p['calibrated']['disparity_px_p90']:.3g}")
        for r in t["inverse_sensitivity"]:
            if r["no_margin"]:
                lines.append(f"  {r['parameter']:>20s} alone: no margin left ({r['no_margin_why']})")
                continue
            why = f"set by {r['limited_by']}" if r["limited_by"] else "no criterion reaches its share in the scan"
            more = "" if r["limited_by"] else " or more"
            lines.append(f"  {r['parameter']:>20s} alone within its share of the margin up to +/-{r['largest']:.3g}"
                         f"{more} {r['unit']} ({why}; tolerance {r['tolerance']:g})")
    return "\n".join(lines)
