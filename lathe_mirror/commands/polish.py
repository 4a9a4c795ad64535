"""`lathe-mirror polish`: the polishing curve of a program's as-machined mirror."""

from __future__ import annotations

import argparse

from .common import add_common, add_no_progress, load, print_json


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("polish", help="polish the as-machined mirror (Preston's law, compliant pad)",
                       description="Polish a program's as-machined mirror ([polish] settings): the "
                       "polishing curve (slope error, normal deviation, form change, image displacement "
                       "and the stereo figures against time), the time polish.objective chooses (default "
                       "'stereo': the calibrated stereo residual at polish.objective_range_m; "
                       "'image_displacement' and 'slope_error' assume an uncalibrated camera) with its "
                       "assumption and the figure it trades, and the figures after polish.time_s.")
    add_common(p, output_help="directory for polish.json (the curve and the figures)")
    p.add_argument("--program", default="paper", metavar="paper|best",
                   help="which program's as-machined surface to polish (default: paper, the paper's "
                        "528-point program that section 6 proposes to polish)")
    add_no_progress(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ..enums import Program, parse
    from ..optics.polishing_curve import polish_summary
    from ..optics.radial import radial_figures
    from ..job import MachiningJob, check_programs, design, polishing_curve, process_for
    from ..report.polishing_study import polish_params_dict
    from ..polishing import polish
    from ..toolpath import profile_errors

    settings = load(args)
    program = parse(Program, args.program, "--program")
    params = settings.polish
    mirror = design(settings)
    check_programs(settings, mirror, tolerance=False)  # bad input stops here, before the output directory is made
    job = MachiningJob.from_settings(settings, mirror, strategy=program.strategy)
    job.check()
    if args.output:
        from .common import check_outputs, output_dir

        check_outputs(args.output, ["polish.json"])
        output_dir(args.output)
    made = job.made()
    curve = polishing_curve(made.profile, mirror, params, process=process_for(settings),
                            progress=not args.no_progress)
    polished = polish(made.profile, params)
    # The five figures of ARCHITECTURE.md per lobe, surface then optics, as the report's.
    at_time = [{**s, **{k: v for k, v in o.items() if k != "name"}} for s, o in
               zip(profile_errors(polished, mirror)["lobes"], radial_figures(polished, mirror)["lobes"])]
    out = {"program": program.value, "made_mirror": job.to_dict(), "surface": made.source, "params": polish_params_dict(params),
           "summary": polish_summary(curve, program.value), "curve": curve.to_dict(),
           "at_time_s": {"time_s": params.time_s, "lobes": at_time}}
    if args.output:
        from pathlib import Path

        from ..export.files import write_text
        from ..report import dumps

        write_text(Path(args.output) / "polish.json", dumps(out))
    if args.json:
        print_json(out)
    else:
        print(out["summary"]["statement"])
        print(f"after polish.time_s = {params.time_s:g} s: " + "; ".join(
            f"{lb['name']} image displacement {lb['image_displacement_px']['rms']:.3f} px RMS"
            for lb in out["at_time_s"]["lobes"]))
    return 0
