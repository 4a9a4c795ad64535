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
    import dataclasses
    from pathlib import Path

    from ..errors import InputError
    from ..job import check_program, design, machine, program_target
    from ..measure.compensate import GAIN, compensation
    from ..measure.fit import FitOptions
    from ..measure.nextjob import JOB_JSON, JOB_TOML
    from ..measure.result import measure
    from ..config import read_user
    from ..export.dialects import dialect as find_dialect
    from ..shop.programs import inspection_table, shop_program
    from .common import check_outputs, output_dir
    from .measure import job_of, touch_off_of

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
    tp = check_program(settings, mirror, strategy, target=cut_target)
    nominal = machine(tp)
    touch = touch_off_of(tp)
    meas = measure(args.file, mirror, nominal, settings.tool.nose_radius, fmt=args.format,
                   options=FitOptions(), resolution_mm=settings.machine.resolution, toolpath=tp, touch_off=touch)
    from .measure import refuse_unfit

    refuse_unfit(meas, settings, args.file)
    base = cut_target if cut_target is not None else program_target(settings, mirror)
    comp = compensation(meas, tp, nominal, base, resolution_mm=settings.machine.resolution, gain=gain)
    tool = dataclasses.replace(settings.tool, nose_radius=round(comp.nose_radius_mm, 3))  # as a tool table takes it
    # the re-cut: the same checks as every program (plan on the lattice within the budget,
    # gouge), then the stock simulation (shop_program refuses contact)
    recut_tp = check_program(settings, mirror, strategy, tool=tool, target=comp.target)
    shop = shop_program(recut_tp, settings.stock, settings.toolpath, name="mirror_recut",
                        inspection=inspection_table(settings), body=settings.body)
    ops = [op.name for op in shop.program.operations]
    finishing = [f"{op.name} (N{op.number})" for op in shop.program.operations if op.name.startswith("finish")]
    repeats = (f"a new part from the bar: the whole program ({', '.join(ops)}) and the second set-up "
               f"({', '.join(op.name for op in shop.second.operations)}); the part measured is not re-cut in "
               f"place (its re-chucking would not hold the axis to the micrometre)")
    notes = (tuple(f"Set-up correction from the measured part: {c}" for c in comp.setup)
             + (comp.message, f"{touch.describe()}, with the nose radius {tool.nose_radius:g} mm of the tool table.",
                f"This re-cut repeats {repeats}. Finishing passes: {', '.join(finishing)}."))
    sheet = dataclasses.replace(shop.sheet, notes=shop.sheet.notes + notes)
    entries = dict(meas.diagnosis.entries or {})
    entries["nose_radius_mm"] = tool.nose_radius
    next_job = {"config": JOB_TOML, "strategy": strategy.value, "nose_radius_mm": tool.nose_radius,
                "touch_off": touch.to_dict(), "set_up_entries": entries, "repeats": repeats,
                "target": comp.to_dict()["target"]}
    # the configuration it was run with (what the user set), the tool table's nose and the
    # program's strategy over it; the defaults stay the defaults
    cfg = read_user(args.config) if args.config is not None else {}
    cfg.setdefault("tool", {})["nose_radius"] = tool.nose_radius
    cfg.setdefault("toolpath", {})["strategy"] = strategy.value
    dg = meas.diagnosis
    comments = [f"lathe-mirror compensate: the next job for {meas.fit.trace.source}",
                f"measured: nose radius {dg.nose_radius_mm:.4f} mm (programmed {dg.programmed_nose_mm:g}), "
                f"centre height {dg.centre_height_mm:+.4f} mm, X offset {dg.x_offset_mm:+.4f} mm",
                f"entered at the machine: {', '.join(f'{k} {v:+.4f}' for k, v in entries.items())}",
                f"the program {names[0]} cuts the {strategy.value} program "
                + ("from the re-cut target in compensate.json beside this file: use --from DIR (not --config alone)"
                   if comp.target is not None else "from the design's usual target"),
                touch.describe()]

    from ..export.files import json_text, toml_text, write_text
    from ..export.gcode import format_program, offset_table
    from ..export.setup_sheet import setup_sheet_html

    d = Path(output_dir(args.output))
    write_text(d / names[0], format_program(shop.program, dialect))
    write_text(d / names[1], format_program(shop.second, dialect))
    write_text(d / names[2], setup_sheet_html(sheet))
    tools, seen = [], set()
    for t in list(sheet.tools) + (list(sheet.second.tools) if sheet.second is not None else []):
        if t.station not in seen:  # one row a station (the second set-up reuses the first's)
            seen.add(t.station)
            tools.append(t)
    write_text(d / names[3], offset_table(tools, dialect, diameter_mode=settings.machine.diameter_mode)[1])
    write_text(d / names[4], toml_text(cfg, comments, exact=True))
    out = {"measurement": meas.to_dict(), "compensation": comp.to_dict(),
           "program": {"files": names[:3], "strategy": strategy.value, "nose_radius_mm": tool.nose_radius,
                       "n_points": recut_tp.n_points, "max_points": settings.machine.max_points,
                       "residual_compensated": comp.recut, "operations": ops},
           "next_job": next_job}
    write_text(d / names[5], json_text(out, indent=1))
    if args.json:
        print_json(out)
    else:
        for c in comp.setup:
            print(f"- {c}")
        print(comp.message)
        print(f"repeats {repeats}")
        print(f"wrote {', '.join(str(d / n) for n in names)}")
        print(f"next: lathe-mirror measure PART2 --from {d}; lathe-mirror compensate PART2 --from {d} -o DIR2")
    return 0
