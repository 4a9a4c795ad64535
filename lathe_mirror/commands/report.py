"""`lathe-mirror report`: every stage's figures as report.json and a self-contained report.html."""

from __future__ import annotations

import argparse

from .common import add_common, add_no_progress, load, print_json


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("report", help="the report: HTML (self-contained) + JSON of every figure",
                       description="Compute every stage on the paper default or --config and write "
                       "report.json and report.html (figures embedded, opens without a network).")
    add_common(p, output_help="output directory (default: out/)")
    p.add_argument("--no-render", action="store_true", help="skip the renders side by side")
    add_no_progress(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ..report.report import compute, write_report
    from .common import output_dir

    cfg = load(args)
    check_config(cfg)
    out_dir = args.output or "out"
    output_dir(out_dir)
    data = compute(cfg, progress=not args.no_progress, renders=not args.no_render)
    paths = write_report(data, out_dir)
    if args.json:
        print_json(data.figures)
    else:
        print(summary(data.figures, paths))
    return 0


def check_config(cfg: dict, *, tolerance: bool = True) -> None:
    """Build every stage's settings once, so bad input fails before any file is written
    (tolerance=False: up to polishing, for `lathe-mirror polish`)."""
    from ..design import mirror_from_config
    from ..lathe import lathe_from_config, tool_from_config
    from ..polishing import polish_params_from_config
    from ..tolerance.spec import settings_from_config
    from ..toolpath import check_junction

    mirror = mirror_from_config(cfg)
    lathe_from_config(cfg)
    # Every program needs a junction the toolpath can cut (an inner lobe recessed, a nose
    # that reaches the wall): checked here, before a progress display or a directory.
    check_junction(mirror, tool_from_config(cfg))
    params = polish_params_from_config(cfg)
    params.check_time(mirror.r_max, max(params.time_s, params.curve_max_s))
    if not tolerance:
        return
    settings = settings_from_config(cfg)
    # The Monte Carlo polishes each part up to the curve's end plus the time tolerance.
    params.check_time(mirror.r_max, params.curve_max_s + settings.tolerances.get("polish_time_s", 0.0))


def summary(fig: dict, paths: dict) -> str:
    lines = [f"report: {paths['html']} (figures: {paths['json']})",
             fig["polishing"]["summary"]["statement"]]
    at = fig["stereo"]["at_2_m"]
    lines.append("depth error at 2 m (RMS / median over the band, each point capped at 100 %): " + ", ".join(
        f"{k} {v['rms']:.3g} / {v['median']:.3g} % ({v['failed']} of {v['points']} points failed)"
        for k, v in at.items()))
    for name, v in fig.get("verdict", {}).items():
        lines.append(f"{name} program: nominal {'PASS' if v['nominal_pass'] else 'FAIL'}, "
                     f"yield {100 * v['yield']:.1f} % of {v['trials']} trials")
    return "\n".join(lines)
