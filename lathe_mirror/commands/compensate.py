"""`lathe-mirror compensate FILE -o DIR`: the next job for a measured part, whole: the
re-cut program(s), their set-up sheet, the tool table (LinuxCNC) or offset list (Fanuc),
the next job's configuration (job.toml) and figures (compensate.json), so the next
`measure` and `compensate` take it with `--from DIR` (measure.nextjob)."""

from __future__ import annotations

import argparse

from .common import add_common, load, print_json
from .measure import add_job_flags


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "compensate", help="write the next job (re-cut programs, tool table, configuration) for a measured part",
        description="Measure FILE as `lathe-mirror measure` does, then write the next job: the set-up "
        "errors found go to the set-up sheet and the tool table (a nose radius other than the "
        "programmed one re-plans the program for it); what they do not explain is subtracted from the "
        "program's target with --gain, through the same nose offset, lattice, budget, gouge and stock "
        "checks as every program. A residual below the lattice is not re-cut (polish instead). "
        "The directory holds everything the next iteration needs: `measure PART2 --from DIR`, "
        "`compensate PART2 --from DIR -o DIR2`.")
    p.add_argument("file", metavar="FILE", help="the measured profile or map of the part")
    add_common(p, output_help="directory for the next job: mirror_recut.ngc / .nc and _op2, its set-up sheet, "
                              "the control's tool table (tools.tbl, offsets.nc, tools.ini), job.toml and compensate.json (required)")
    p.add_argument("--format", metavar="FMT", default=None,
                   help="the file's format when its suffix does not say: csv, prf, x3p, datx, dat, surfalize")
    add_job_flags(p)
    p.add_argument("--gain", type=float, default=None,
                   help="share of the remaining residual the re-cut takes off (default 0.8)")
    p.add_argument("--dialect", default="linuxcnc", metavar="linuxcnc|fanuc", help="G-code dialect")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from pathlib import Path

    from ..errors import InputError
    from ..job import design
    from ..measure.nextjob import JOB_JSON, JOB_TOML
    from ..config import read_user
    from ..export.dialects import dialect as find_dialect
    from ..shop.measured import GAIN, next_job
    from .common import check_outputs, output_dir
    from .measure import job_of

    if not args.output:
        raise InputError("-o/--output: compensate writes the next job; name a directory")
    gain = GAIN if args.gain is None else args.gain
    # --gain is within its range (commands/flags.py, at parsing)
    dialect = find_dialect(args.dialect)
    settings, strategy, cut_target = job_of(args, load)
    mirror = design(settings)
    ext = dialect.extension
    names = [f"mirror_recut.{ext}", f"mirror_recut_op2.{ext}", "mirror_recut.setup.html", dialect.offsets_file,
             JOB_TOML, JOB_JSON]
    check_outputs(args.output, names)
    job = next_job(settings, mirror, args.file, strategy, cut_target, gain=gain, fmt=args.format,
                   files=tuple(names[:3]))
    comp = job.compensation
    # the configuration it was run with (what the user set), the tool table's nose and the
    # program's strategy over it; the defaults stay the defaults
    cfg = read_user(args.config) if args.config is not None else {}
    cfg.setdefault("tool", {})["nose_radius"] = job.nose_radius_mm
    cfg.setdefault("toolpath", {})["strategy"] = strategy.value

    from ..export.files import json_text, toml_text, write_text
    from ..export.gcode import format_program, offset_table
    from ..export.setup_sheet import setup_sheet_html

    d = Path(output_dir(args.output))
    write_text(d / names[0], format_program(job.shop.program, dialect))
    write_text(d / names[1], format_program(job.shop.second, dialect))
    write_text(d / names[2], setup_sheet_html(job.sheet))
    write_text(d / names[3], offset_table(job.tools, dialect, diameter_mode=settings.machine.diameter_mode)[1])
    write_text(d / names[4], toml_text(cfg, job.comments, exact=True))
    out = job.figures
    write_text(d / names[5], json_text(out, indent=1))
    if args.json:
        print_json(out)
    else:
        for c in comp.setup:
            print(f"- {c}")
        print(comp.message)
        print(f"repeats {job.repeats}")
        print(f"wrote {', '.join(str(d / n) for n in names)}")
        print(f"next: lathe-mirror measure PART2 --from {d}; lathe-mirror compensate PART2 --from {d} -o DIR2")
    return 0
