"""`lathe-mirror toolpath`: the finishing toolpath and its G-code, with profile errors."""

from __future__ import annotations

import argparse

from .common import add_common, load, print_json
from ..settings.keys import help_default


def register(sub: argparse._SubParsersAction) -> None:
    from ..export.dialects import DIALECTS

    names = " | ".join(DIALECTS)
    p = sub.add_parser(
        "toolpath", help="lathe toolpath on the machine's lattice and its G-code",
        description="Plan the finishing contour on the lathe's lattice within its point budget, "
        "write the G-code (roughing + finishing, tool-nose compensation computed here) with its set-up "
        "sheet and the control's tool table, and report the profile errors per lobe.")
    add_common(p, output_help="G-code file, or a directory (gets mirror_<strategy>.<ext>, its second set-up's "
                              "program, the set-up sheet and the tool table)")
    p.add_argument("--strategy", default=None,
                   help=f"paper | lattice | arcs | best (= arcs; {help_default('toolpath.strategy')})")
    p.add_argument("--dialect", default=None,
                   help=f"{names} (default linuxcnc; --check: the program's own, from its first lines or suffix)")
    p.add_argument("--points", type=int, default=None, metavar="N",
                   help=f"point budget of the finishing contour ({help_default('machine.max_points')})")
    p.add_argument("--resolution", type=float, default=None, metavar="MM",
                   help=f"lattice step of r and Z, mm ({help_default('machine.resolution')})")
    p.add_argument("--nose-radius", type=float, default=None, metavar="MM",
                   help=f"tool nose radius, mm, 0 = sharp ({help_default('tool.nose_radius')})")
    p.add_argument("--check", metavar="PROGRAM",
                   help="simulate an existing G-code program (any dialect) against the configured "
                   "stock and tool instead of planning one; exit 2 naming the first block that touches "
                   "stock at rapid or with the insert's body")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    import os
    from pathlib import Path

    from ..enums import BEST, Strategy, parse
    from ..export.dialects import dialect
    from ..job import design

    settings = load(args, [("machine.max_points", args.points, "--points"),
                           ("machine.resolution", args.resolution, "--resolution"),
                           ("tool.nose_radius", args.nose_radius, "--nose-radius")])
    chosen = dialect(args.dialect or "linuxcnc")
    if args.check:
        return check(args, settings)
    if args.strategy:
        strategy = parse(Strategy, args.strategy, "--strategy", aliases={"best": BEST})
    else:
        strategy = settings.toolpath.strategy
    out = None
    if args.output:  # the program's and its companions' names, checked before any work
        from .common import check_outputs
        from .flags import check_suffix

        out = Path(args.output)
        into_dir = os.path.isdir(out) or args.output.endswith("/")
        if into_dir:
            out = out / f"mirror_{strategy.value}.{chosen.extension}"
        check_suffix(out, "G-code")
        stem, rest = out.name.split(".")[0], out.name[len(out.name.split(".")[0]):]
        # beside the program: the second set-up's (the back and the mount), the set-up sheet
        # of both, the control's tool table
        names = [out.name, f"{stem}_op2{rest}", f"{stem}.setup.html", chosen.offsets_file]
        check_outputs(out.parent if into_dir else None, names if into_dir else [str(out.parent / n) for n in names])
    from ..export.gcode import program_files
    from ..shop.programs import toolpath_result

    shop, result = toolpath_result(settings, design(settings), strategy)
    result["dialect"] = chosen.name
    # the program, its second set-up's, the sheet of both, the control's tool table
    files = program_files([shop], (chosen,))
    text = files[f"{shop.program.name}.{chosen.extension}"]
    if out is not None:
        from ..export.files import write_text
        from .common import output_dir

        if into_dir:
            output_dir(out.parent)
        renamed = {f"{shop.program.name}.{chosen.extension}": out.name,  # the names asked for
                   f"{shop.program.name}_op2.{chosen.extension}": f"{stem}_op2{rest}",
                   f"{shop.program.name}.setup.html": f"{stem}.setup.html"}
        for name, content in files.items():
            write_text(out.parent / renamed.get(name, name), content)
    if args.json:
        print_json(result)
    elif not args.output:
        print(text, end="")
    else:
        print(format_figures(result))
    return 0


def check(args: argparse.Namespace, settings) -> int:
    """--check PROGRAM: replay a G-code file against the configured stock and tools
    (shop.check), in its own dialect unless --dialect names one."""
    from ..export.dialects import dialect, for_file
    from ..inputs import read_text
    from ..job import design
    from ..shop.check import MAX_PROGRAM_BYTES, check_text

    # a regular file (or - for stdin) of at most MAX_PROGRAM_BYTES, bounded while reading
    text = read_text(args.check, "--check", MAX_PROGRAM_BYTES)
    reader = dialect(args.dialect) if args.dialect else for_file(args.check, text)
    sim = check_text(text, settings, design(settings), reader, source=f"--check {args.check}")
    sim.check()
    if args.json:
        print_json(sim.figures())
    else:
        for op in sim.operations:
            cut = (f"max depth of cut {op.max_depth_of_cut_mm:.3f} mm" if op.drilled_depth_mm is None
                   else f"drilled {op.drilled_depth_mm:.3f} mm deep to the point")  # a drill's depth of cut is its radius
            print(f"{op.name}: removed {op.removed_volume_mm3:.0f} mm^3, {cut}, air {op.air_time_s:.1f} s, "
                  f"time {op.cycle_time_s:.1f} s")
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
