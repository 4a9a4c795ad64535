"""`lathe-mirror toolpath`: the finishing toolpath and its G-code, with profile errors."""

from __future__ import annotations

import argparse
import re

from ..path import Arc
from .common import add_common, load, print_json
from ..settings.keys import help_default


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "toolpath", help="lathe toolpath on the machine's lattice and its G-code",
        description="Plan the finishing contour on the lathe's lattice within its point budget, "
        "write the G-code (roughing + finishing, tool-nose compensation computed here) and "
        "report the profile errors per lobe.")
    add_common(p, output_help="G-code file, or a directory (gets mirror_<strategy>.ngc/.nc)")
    p.add_argument("--strategy", default=None,
                   help=f"paper | lattice | arcs | best (= arcs; {help_default('toolpath.strategy')})")
    p.add_argument("--dialect", default="linuxcnc", help="linuxcnc | fanuc (default linuxcnc)")
    p.add_argument("--points", type=int, default=None, metavar="N",
                   help=f"point budget of the finishing contour ({help_default('machine.max_points')})")
    p.add_argument("--resolution", type=float, default=None, metavar="MM",
                   help=f"lattice step of r and Z, mm ({help_default('machine.resolution')})")
    p.add_argument("--nose-radius", type=float, default=None, metavar="MM",
                   help=f"tool nose radius, mm, 0 = sharp ({help_default('tool.nose_radius')})")
    p.add_argument("--check", metavar="PROGRAM",
                   help="simulate an existing G-code program (either dialect) against the configured "
                   "stock and tool instead of planning one; exit 2 naming the first block that touches "
                   "stock at rapid or with the insert's body")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    import os
    from pathlib import Path

    from ..enums import BEST, Dialect, Strategy, parse
    from ..export.gcode import format_program
    from ..export.setup_sheet import setup_sheet_html
    from ..nose_envelope import (
        as_machined,
        contour_profile,
        gouge_depth,
        junction_fillet,
    )
    from ..job import check_program, design
    from ..shop.programs import inspection_table, shop_program
    from ..shop import options_from_settings
    from ..toolpath import profile_errors, usable_ranges

    settings = load(args, [("machine.max_points", args.points, "--points"),
                           ("machine.resolution", args.resolution, "--resolution"),
                           ("tool.nose_radius", args.nose_radius, "--nose-radius")])
    dialect = parse(Dialect, args.dialect, "--dialect")
    if args.check:
        return check(args, settings)
    if args.strategy:
        strategy = parse(Strategy, args.strategy, "--strategy", aliases={"best": BEST})
    else:
        strategy = settings.toolpath.strategy
    out = sheet = None
    into_dir = False
    if args.output:  # the program's and its set-up sheet's names, checked before any work
        from .common import check_outputs
        from .flags import check_suffix

        out = Path(args.output)
        into_dir = os.path.isdir(out) or args.output.endswith("/")
        if into_dir:
            out = out / f"mirror_{strategy.value}.{dialect.extension}"
        check_suffix(out, "G-code")
        sheet = out.with_name(out.name.split(".")[0] + ".setup.html")  # beside the program
        # the second set-up's program (the back and the mount) beside it too
        out2 = out.with_name(out.name.split(".")[0] + "_op2" + out.name[len(out.name.split(".")[0]):])
        check_outputs(out.parent if into_dir else None,
                      [out.name, out2.name, sheet.name] if into_dir else [str(out), str(out2), str(sheet)])
    mirror = design(settings)
    lathe, tool, stock = settings.machine, settings.tool, settings.stock
    opts = options_from_settings(settings.toolpath)
    tp = check_program(settings, mirror, strategy)  # as every command that uses a program
    # simulated against the stock; refused if it touches
    shop = shop_program(tp, stock, opts, inspection=inspection_table(settings), body=settings.body)
    text = format_program(shop.program, dialect)
    text2 = format_program(shop.second, dialect)
    if out is not None:
        from ..export.files import write_text
        from .common import output_dir

        if into_dir:
            output_dir(out.parent)
        write_text(out, text)
        write_text(out2, text2)
        write_text(sheet, setup_sheet_html(shop.sheet))
    made = as_machined(tp)
    figures = profile_errors(made, mirror)
    used = profile_errors(made, mirror, r_ranges=usable_ranges(mirror))
    contour = profile_errors(contour_profile(tp), mirror) if tp.nose_radius > 0 else figures
    result = {
        "strategy": strategy.value,
        "dialect": dialect.value,
        "n_points": tp.n_points,
        "max_points": lathe.max_points,
        "resolution_mm": lathe.resolution,
        "nose_radius_mm": tool.nose_radius,
        "moves": len(tp.segments),
        "arcs": sum(1 for s in tp.segments if isinstance(s, Arc)),
        "gouge_depth_mm": gouge_depth(tp),
        "junction_fillet": junction_fillet(tp),
        "lobes": figures["lobes"],
        "contour_lobes": contour["lobes"],
        # the radii the camera uses (the step wall hides the inner lobe's rim and with it
        # the junction fillet): what the image sees of the as-machined surface
        "usable_lobes": used["lobes"],
        "shop": shop.simulation.figures(),
        "second_setup": {"name": shop.second.name, **shop.second_simulation.figures()},
    }
    if args.json:
        print_json(result)
    elif not args.output:
        print(text, end="")
    else:
        print(format_figures(result))
    return 0


def check(args: argparse.Namespace, settings) -> int:
    """--check PROGRAM: replay a G-code file against the configured stock and tool (a
    second set-up's program, named so in its header: against the part the configured
    program parts off, reversed, shop.second)."""
    from ..errors import InputError
    from ..inputs import read_text
    from ..job import design
    from ..shop.replay import MAX_PROGRAM_BYTES, read_program
    from ..shop.stock import simulate

    # a regular file (or - for stdin) of at most MAX_PROGRAM_BYTES, bounded while reading
    text = read_text(args.check, "--check", MAX_PROGRAM_BYTES)
    lathe, t = settings.machine, settings.toolpath
    ops = read_program(text, lathe, source=f"--check {args.check}")
    if not ops:
        raise InputError(f"--check {args.check}: no moves to simulate")
    from ..toolpath.moves import Hand

    from ..shop import ProgramOptions
    from ..shop.partoff import parting_z
    from ..shop.program import PARTING_STATION
    from ..shop.tool_shapes import blade_shape

    mirror = design(settings)
    # the back and the mount (the header's first comment says so): against the parted part, reversed
    if re.search(r"^\(lathe-mirror \S+: second set-up of", text[:2000], re.M | re.I):
        from ..job import check_program
        from ..shop import options_from_settings
        from ..shop.programs import shop_program
        from ..shop.stock import simulate_setup

        tp = check_program(settings, mirror, t.strategy)
        su = shop_program(tp, settings.stock, options_from_settings(t), body=settings.body).second.setup
        sim = simulate_setup(ops, su.shapes, lathe, su.start, su.part, su.chuck, rapid_rate=t.rapid_rate,
                             gouge_tolerance=t.gouge_tolerance)
        return _report(args, sim)
    # a part-off (T5) is the parting blade, at the [cad] body's length (shop.partoff)
    parting = None
    if any(op.station == PARTING_STATION for op in ops):
        opts = ProgramOptions(parting_width=t.parting_width_mm, back_allowance=t.back_allowance_mm)
        parting = (parting_z(settings.body, settings.stock, opts, lathe), t.parting_width_mm)
    # the tool as the design's hand holds it (the opposite hand when the outer lobe is recessed)
    sim = simulate(ops, mirror, Hand.for_mirror(mirror).held(settings.tool), lathe, settings.stock,
                   rapid_rate=t.rapid_rate, gouge_tolerance=t.gouge_tolerance,
                   shapes={PARTING_STATION: blade_shape(t.parting_width_mm)}, parting=parting)
    return _report(args, sim)


def _report(args: argparse.Namespace, sim) -> int:
    """--check's answer: refused (the first contact) or the figures."""
    sim.check()
    if args.json:
        print_json(sim.figures())
    else:
        for op in sim.operations:
            print(f"{op.name}: removed {op.removed_volume_mm3:.0f} mm^3, max depth of cut "
                  f"{op.max_depth_of_cut_mm:.3f} mm, air {op.air_time_s:.1f} s, time {op.cycle_time_s:.1f} s")
        print(f"no contact at rapid, none with the insert's body; cycle time {sim.cycle_time_s:.1f} s")
    return 0


def format_figures(res: dict) -> str:
    lines = [f"strategy {res['strategy']}: {res['moves']} moves ({res['arcs']} arcs), "
             f"{res['n_points']} of {res['max_points']} points, nose radius {res['nose_radius_mm']:g} mm, "
             f"gouge {res['gouge_depth_mm']:.4f} mm"]
    for lobe in res["lobes"]:
        nd, se = lobe["normal_deviation_mm"], lobe["slope_error_rad"]
        lines.append(f"  {lobe['name']:5s} normal deviation rms {nd['rms']:.2e} max {nd['max']:.2e} mm; "
                     f"slope error rms {se['rms']:.2e} max {se['max']:.2e} rad (whole lobe)")
    for lobe in res["usable_lobes"]:
        nd, se, rr = lobe["normal_deviation_mm"], lobe["slope_error_rad"], lobe["r_range_mm"]
        lines.append(f"  {lobe['name']:5s} normal deviation rms {nd['rms']:.2e} max {nd['max']:.2e} mm; "
                     f"slope error rms {se['rms']:.2e} max {se['max']:.2e} rad "
                     f"(used r {rr['min']:.3f}..{rr['max']:.3f} mm)")
    return "\n".join(lines)
