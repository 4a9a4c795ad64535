"""`lathe-mirror tolerance`: seeded Monte Carlo, sensitivity table and yield against the spec."""

from __future__ import annotations

import argparse

from .common import add_common, add_no_progress, load, print_json


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("tolerance", help="Monte Carlo over machine, polishing and assembly; yield",
                       description="Tolerance analysis ([tolerance] settings): a seeded Monte Carlo "
                       "over the machine (lattice, nose radius, tool setting X and Z), the polishing "
                       "time and the camera's assembly (decentre, tilt, axial), a sensitivity table "
                       "and the yield against the spec, for each program in tolerance.programs.")
    add_common(p, output_help="directory for tolerance.json")
    p.add_argument("--trials", type=int, default=None, metavar="N", help="override tolerance.trials")
    p.add_argument("--seed", type=int, default=None, metavar="S", help="override tolerance.seed")
    add_no_progress(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ..enums import BEST, Program, Strategy
    from ..pipeline import (
        check_programs,
        design,
        made_surface,
        polishing_curve,
        tolerance_analysis,
    )

    settings = load(args, [("tolerance.trials", args.trials, "--trials"), ("tolerance.seed", args.seed, "--seed")])
    mirror = design(settings)
    check_programs(settings, mirror)  # bad input stops here, before the output directory is made
    if args.output:
        from .common import output_dir

        output_dir(args.output)
    times = {}
    for program in settings.tolerance.programs:
        strategy = BEST if program is Program.BEST else Strategy.PAPER
        made = made_surface(mirror, settings.machine, settings.tool, strategy)
        times[program] = polishing_curve(made.profile, mirror, settings.polish).optimum_time_s
    out = tolerance_analysis(mirror, settings, times, progress=not args.no_progress)
    if args.output:
        from pathlib import Path

        from ..export.files import write_text
        from ..report import dumps

        write_text(Path(args.output) / "tolerance.json", dumps(out))
    if args.json:
        print_json(out)
    else:
        print(format_tolerance(out))
    return 0


def format_tolerance(out: dict) -> str:
    lines = [f"spec: {out['spec']}"]
    for name, t in out["programs"].items():
        v = t["verdict"]
        mc = t["monte_carlo"]
        lines.append(f"{name} program ({t['surfaces']}; polished {t['nominal_polish_time_s']:g} s nominal):")
        for k, c in v["checks"].items():
            lines.append(f"  nominal {k}: {c['nominal']:.4g} (limit {c['limit']:g}) "
                         f"{'PASS' if c['pass'] else 'FAIL'}")
        lines.append(f"  yield {100 * mc['yield']:.1f} % of {mc['trials']} trials (seed {mc['seed']}); "
                     f"per criterion {mc['pass_fraction']}")
        for r in t["sensitivity"]["rows"]:
            m, p = r["minus"], r["plus"]
            lines.append(f"  {r['parameter']:>20s} -/+ {r['tolerance']}: image disp. px "
                         f"{max(m['image_displacement_px_rms']):.3f} / {max(p['image_displacement_px_rms']):.3f}, "
                         f"depth err % {m['depth_error_pct_rms']:.3g} / {p['depth_error_pct_rms']:.3g}")
    return "\n".join(lines)
