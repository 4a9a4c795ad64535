"""`lathe-mirror compensate FILE -o DIR`: the re-cut program for a measured part."""

from __future__ import annotations

import argparse

from .common import add_common, load, print_json


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "compensate", help="write the re-cut program for a measured part",
        description="Measure FILE as `lathe-mirror measure` does, then write the re-cut: the set-up "
        "errors found go to the set-up sheet and the tool table (a nose radius other than the "
        "programmed one re-plans the program for it); what they do not explain is subtracted from the "
        "program's target with --gain, through the same nose offset, lattice, budget, gouge and stock "
        "checks as every program. A residual below the lattice is not re-cut (polish instead).")
    p.add_argument("file", metavar="FILE", help="the measured profile or map of the part")
    add_common(p, output_help="directory for mirror_recut.ngc / .nc, its set-up sheet, tools.tbl and "
                              "compensate.json (required)")
    p.add_argument("--format", metavar="FMT", default=None,
                   help="the file's format when its suffix does not say: csv, prf, x3p, datx, dat, surfalize")
    p.add_argument("--program", default=None, metavar="paper|best",
                   help="the program the part was cut with (default: [toolpath] strategy)")
    p.add_argument("--gain", type=float, default=None,
                   help="share of the remaining residual the re-cut takes off (default 0.8)")
    p.add_argument("--dialect", default="linuxcnc", metavar="linuxcnc|fanuc", help="G-code dialect")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    import dataclasses
    from pathlib import Path

    from ..errors import InputError
    from ..measure.compensate import GAIN, compensation
    from ..measure.fit import FitOptions
    from ..measure.result import measure
    from ..job import check_program, design, machine, program_target
    from ..shop.programs import shop_program
    from .common import check_outputs, output_dir, program_strategy

    if not args.output:
        raise InputError("-o/--output: compensate writes a program; name a directory")
    gain = GAIN if args.gain is None else args.gain
    # --gain is within its range (commands/flags.py, at parsing)
    from ..export.dialects import dialect as find_dialect

    dialect = find_dialect(args.dialect)
    settings = load(args)
    mirror = design(settings)
    strategy = program_strategy(args.program, settings)
    names = [f"mirror_recut.{dialect.extension}", "mirror_recut.setup.html", dialect.offsets_file, "compensate.json"]
    check_outputs(args.output, names)
    tp = check_program(settings, mirror, strategy)
    nominal = machine(tp)
    meas = measure(args.file, mirror, nominal, settings.tool.nose_radius, fmt=args.format,
                   options=FitOptions(), resolution_mm=settings.machine.resolution, toolpath=tp)
    comp = compensation(meas, tp, nominal, program_target(settings, mirror),
                        resolution_mm=settings.machine.resolution, gain=gain)
    tool = dataclasses.replace(settings.tool, nose_radius=round(comp.nose_radius_mm, 3))  # as a tool table takes it
    # the re-cut: the same checks as every program (plan on the lattice within the budget,
    # gouge), then the stock simulation (shop_program refuses contact)
    recut_tp = check_program(settings, mirror, strategy, tool=tool, target=comp.target)
    shop = shop_program(recut_tp, settings.stock, settings.toolpath, name="mirror_recut")
    notes = tuple(f"Set-up correction from the measured part: {c}" for c in comp.setup) + (comp.message,)
    sheet = dataclasses.replace(shop.sheet, notes=shop.sheet.notes + notes)

    from ..export.files import json_text, write_text
    from ..export.gcode import format_program, offset_table
    from ..export.setup_sheet import setup_sheet_html

    d = Path(output_dir(args.output))
    write_text(d / names[0], format_program(shop.program, dialect))
    write_text(d / names[1], setup_sheet_html(sheet))
    write_text(d / names[2], offset_table(sheet.tools, dialect, diameter_mode=settings.machine.diameter_mode)[1])
    out = {"measurement": meas.to_dict(), "compensation": comp.to_dict(),
           "program": {"file": names[0], "strategy": strategy.value, "nose_radius_mm": tool.nose_radius,
                       "n_points": recut_tp.n_points, "max_points": settings.machine.max_points,
                       "residual_compensated": comp.recut}}
    write_text(d / names[3], json_text(out, indent=1))
    if args.json:
        print_json(out)
    else:
        for c in comp.setup:
            print(f"- {c}")
        print(comp.message)
        print(f"wrote {', '.join(str(d / n) for n in names)}")
    return 0
