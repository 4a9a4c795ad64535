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
    from ..config import set_value
    from ..design import mirror_from_config
    from ..polishing import polish_curve, polish_params_from_config
    from ..report.report import _tolerance
    from ..tolerance.spec import Program, settings_from_config
    from ..tolerance.surfaces import machined_surface
    from .report import check_config

    cfg = load(args)
    if args.trials is not None:
        set_value(cfg, "tolerance.trials", args.trials, source="--trials")
    if args.seed is not None:
        set_value(cfg, "tolerance.seed", args.seed, source="--seed")
    check_config(cfg)  # bad input stops here, before the output directory is made
    settings = settings_from_config(cfg)
    params = polish_params_from_config(cfg)
    if args.output:
        from .common import output_dir

        output_dir(args.output)
    mirror = mirror_from_config(cfg)
    curves = {}
    for program in (Program.PAPER, Program.BEST):
        if program in settings.programs:
            made = machined_surface(mirror, cfg, program)
            curves[program] = polish_curve(made.profile, mirror, params)
    out = _tolerance(mirror, cfg, params, curves.get(Program.PAPER), curves.get(Program.BEST),
                     not args.no_progress)
    if args.output:
        from pathlib import Path

        from ..export.files import write_text
        from ..report.report import dumps

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
