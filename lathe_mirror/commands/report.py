"""`lathe-mirror report`: every stage's figures as report.json and a self-contained report.html."""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING

from .common import add_common, add_compute, add_no_progress, load_on_executor, print_json

if TYPE_CHECKING:
    from ..report.analysis import ReportData


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("report", help="the report: HTML (self-contained) + JSON of every figure",
                       description="Compute every stage on the paper default or --config and write "
                       "report.json and report.html (figures embedded, opens without a network).")
    add_common(p, output_help="output directory (default: out/)")
    p.add_argument("--no-render", action="store_true", help="skip the renders side by side")
    p.add_argument("--surface", metavar="measured:FILE", default=None,
                   help="add a measured part (measured:FILE, as `lathe-mirror measure` reads it) to the "
                        "made mirrors' figures")
    add_compute(p, "the tolerance trials and the allocation's confirmations")
    add_no_progress(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ..enums import BEST, Strategy
    from ..job import check_program, check_programs, design
    from ..pipeline import report_figures
    from ..report import write_report
    from .common import check_outputs, output_dir

    settings = load_on_executor(args)
    mirror = design(settings)
    check_programs(settings, mirror)
    for strategy in (Strategy.PAPER, BEST):  # the programs it machines, polishes and tolerances
        check_program(settings, mirror, strategy)
    measured = None
    if args.surface is not None:
        from ..enums import Surface
        from ..errors import InputError
        from ..job import named_surface
        from .common import surface_arg

        name, path = surface_arg(args.surface)
        if name is not Surface.MEASURED:
            raise InputError(f"--surface {args.surface!r}: report takes measured:FILE (the programs' parts "
                             "are in the report already)")
        measured = named_surface(name, mirror, settings, measured=path)
    out_dir = args.output or "out"
    check_outputs(out_dir, list(REPORT_FILES))
    output_dir(out_dir)
    data = report_figures(settings, progress=not args.no_progress, renders=not args.no_render, measured=measured,
                          plots=True)  # drawn while the tolerance analysis runs
    paths = write_report(data, out_dir)
    if args.json:
        print_json(data.figures)
    else:
        print(summary(data, paths))
    return 0


#: The files report/ writes into the report directory (report.write_report).
REPORT_FILES = ("report.json", "report.html")


def summary(data: ReportData, paths: dict) -> str:
    """The command's answer on the terminal: the polishing statement, the depth error at
    DEPTH_REPORT_M, each toleranced program's verdict."""
    from ..results.optics import DEPTH_REPORT_M

    lines = [f"report: {paths['html']} (figures: {paths['json']})",
             data.polishing.summary.statement]
    lines.append(f"depth error at {DEPTH_REPORT_M:g} m (RMS / median over the band, each point capped at 100 %): "
                 + ", ".join(f"{k} {v.rms:.3g} / {v.median:.3g} % ({v.failed} of {v.points} points failed)"
                             for k, v in data.stereo.at.items()))
    from ..tolerance.stats import percent_interval

    for name, v in (data.verdict or {}).items():
        lines.append(f"{name} program: nominal {'PASS' if v.nominal_pass else 'FAIL'}, "
                     f"yield {percent_interval(v.passed_trials, v.trials)}"
                     + (f"; {v.allocation}" if v.allocation is not None else ""))
    return "\n".join(lines)
