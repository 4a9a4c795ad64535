"""`lathe-mirror toolpath`: the finishing toolpath and its G-code, with profile errors."""

from __future__ import annotations

import argparse

from ..path import Arc
from .common import add_common, load, print_json


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "toolpath", help="lathe toolpath on the machine's lattice and its G-code",
        description="Plan the finishing contour on the lathe's lattice within its point budget, "
        "write the G-code (roughing + finishing, tool-nose compensation computed here) and "
        "report the profile errors per lobe.")
    add_common(p, output_help="G-code file, or a directory (gets mirror_<strategy>.ngc/.nc)")
    p.add_argument("--strategy", default=None,
                   help="paper | lattice | arcs | best (= arcs; default: the config's toolpath.strategy)")
    p.add_argument("--dialect", default="linuxcnc", help="linuxcnc | fanuc (default linuxcnc)")
    p.add_argument("--points", type=int, default=None, metavar="N",
                   help="point budget of the finishing contour (machine.max_points, default 528)")
    p.add_argument("--resolution", type=float, default=None, metavar="MM",
                   help="lattice step of r and Z, mm (machine.resolution, default 0.005)")
    p.add_argument("--nose-radius", type=float, default=None, metavar="MM",
                   help="tool nose radius, mm (tool.nose_radius, default 0.2; 0 = sharp)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from pathlib import Path

    from ..enums import BEST, Strategy, parse
    from ..export.gcode import Dialect, parse_dialect, program, program_options
    from ..nose_envelope import (
        as_machined,
        contour_profile,
        gouge_depth,
        junction_fillet,
    )
    from ..pipeline import design, plan
    from ..toolpath import profile_errors, usable_ranges

    settings = load(args, [("machine.max_points", args.points, "--points"),
                           ("machine.resolution", args.resolution, "--resolution"),
                           ("tool.nose_radius", args.nose_radius, "--nose-radius")])
    dialect = parse_dialect(args.dialect)
    if args.strategy:
        strategy = parse(Strategy, args.strategy, "--strategy", aliases={"best": BEST})
    else:
        strategy = settings.toolpath.strategy
    mirror = design(settings)
    lathe, tool, stock = settings.machine, settings.tool, settings.stock
    opts = program_options(settings)
    tp = plan(mirror, lathe, tool, strategy, max_deviation=settings.toolpath.max_deviation)
    text = program(tp, stock, dialect, options=opts, name=f"mirror_{strategy.value}")
    if args.output:
        from ..export.files import write_text
        from .common import output_dir

        out = Path(args.output)
        if out.is_dir() or args.output.endswith("/"):
            ext = "ngc" if dialect is Dialect.LINUXCNC else "nc"
            out = output_dir(out) / f"mirror_{strategy.value}.{ext}"
        write_text(out, text)
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
    }
    if args.json:
        print_json(result)
    elif not args.output:
        print(text, end="")
    else:
        print(format_figures(result))
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
