"""`lathe-mirror measure FILE`: a measured profile of the made part, fitted against the
design; figures per lobe and the machine's set-up errors."""

from __future__ import annotations

import argparse

from .common import add_common, load, print_json

#: The files `measure -o DIR` writes.
OUTPUTS = ("measure.json", "measured_minus_design.png")


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "measure", help="fit a measured profile of the made part; diagnose the machine",
        description="Read a measured profile (CSV/text x,z; Taylor Hobson .prf; .x3p profile or map; Zygo "
        ".dat/.datx; the areal formats surfalize reads), fit it against the design (decentre, tilt, "
        "piston; R and k with --fit-conic), report per lobe over its clear aperture the residual's PV, RMS "
        "and slope RMS, and the lathe's set-up errors (tool centre height, X offset, nose radius, "
        "squareness; backlash where the program's finishing moves reverse X, else why the part cannot show it) "
        "as corrections. The trace is in the machine frame, the part face up.")
    p.add_argument("file", metavar="FILE", help="the measured profile or map")
    add_common(p, output_help="directory for measure.json and measured_minus_design.png")
    p.add_argument("--format", metavar="FMT", default=None,
                   help="the file's format when its suffix does not say: csv, prf, x3p, datx, dat, surfalize")
    p.add_argument("--fit-conic", action="store_true", help="also fit each lobe's radius R and conic constant k")
    add_job_flags(p)
    p.set_defaults(func=run)


def add_job_flags(p: argparse.ArgumentParser) -> None:
    """--program STRATEGY and --from DIR: the job the part was cut by."""
    p.add_argument("--program", default=None, metavar="paper|lattice|arcs|best",
                   help="the program's strategy the part was cut with (default: [toolpath] strategy; with "
                   "--from, the job's)")
    p.add_argument("--from", dest="from_dir", default=None, metavar="DIR",
                   help="the job the part was cut by, as `compensate -o DIR` wrote it: its job.toml (the "
                   "configuration, with the nose radius of the tool table) and the re-cut target in its "
                   "compensate.json; instead of --config")


def job_of(args: argparse.Namespace, load_settings):
    """(settings, strategy, target) of the job the part was cut by: --config and --program,
    or --from DIR (measure.nextjob); target None: the program's usual one."""
    from ..enums import BEST, Strategy, parse

    target = None
    if args.from_dir is None:
        settings = load_settings(args)
    else:
        from pathlib import Path

        from ..errors import InputError
        from ..measure.nextjob import JOB_TOML, read_next_job

        if args.config is not None:
            raise InputError(f"--from {args.from_dir} and --config {args.config}: the job directory holds its "
                             "configuration (job.toml); name one of them")
        d = Path(args.from_dir)
        args.config = str(d / JOB_TOML)
        settings = load_settings(args)
        target, strategy = read_next_job(d, settings.mirror())
        if args.program is None:
            args.program = strategy
    if args.program is None:
        strategy = settings.toolpath.strategy
    else:
        strategy = parse(Strategy, args.program, "--program", aliases={"best": BEST})
    return settings, strategy, target


def run(args: argparse.Namespace) -> int:
    from ..job import design
    from ..shop.measured import measure_part

    settings, strategy, target = job_of(args, load)
    mirror = design(settings)
    if args.output:
        from .common import check_outputs

        check_outputs(args.output, list(OUTPUTS))
    result, out = measure_part(settings, mirror, args.file, strategy, target, fmt=args.format,
                               fit_conic=args.fit_conic)
    if args.output:
        from pathlib import Path

        from ..export.files import json_text, write_bytes, write_text
        from ..report.measure_plots import residual_plot
        from .common import output_dir

        d = output_dir(args.output)
        write_text(Path(d) / OUTPUTS[0], json_text(out, indent=1))
        write_bytes(Path(d) / OUTPUTS[1], residual_plot(result.fit))
    if args.json:
        print_json(out)
    else:
        _print(out)
    return 0


def _print(out: dict) -> None:
    f = out["fit"]
    print(f"{out['source']}: decentre {f['decentre_mm'] * 1e3:+.2f} um, tilt {f['tilt_rad'] * 1e6:+.2f} urad, "
          f"piston {f['piston_mm']:+.4f} mm")
    for lf in out["lobes"]:
        print(f"  {lf['name']:5s} r {lf['aperture_mm'][0]:.2f}..{lf['aperture_mm'][1]:.2f} mm: PV {lf['pv_um']:.3f} um, "
              f"RMS {lf['rms_um']:.3f} um, slope RMS {lf['slope_rms_urad']:.1f} urad")
    for v in out.get("form_tolerance") or ():
        failed = [k for k, ok in v["checks"].items() if not ok]
        print(f"  {v['name']:5s} against {v['iso10110_5']}, slope < {v['slope_urad']:g} urad: "
              + ("PASS" if v["pass"] else f"FAIL ({', '.join(failed)})"))
    print(f"  the trace is this part: {sum(c['ok'] for c in out['this_part']['checks'])} of "
          f"{len(out['this_part']['checks'])} checks hold ({', '.join(c['figure'] for c in out['this_part']['checks'][:4])})")
    print(f"  {out['diagnosis']['touch_off']['text']}")
    for c in out["diagnosis"]["corrections"]:
        print(f"  - {c}")
