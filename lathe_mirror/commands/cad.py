"""`lathe-mirror cad`: STEP, STL or DXF of the designed or the programmed mirror."""

from __future__ import annotations

import argparse

from .common import add_common, load, print_json
from ..settings.keys import help_default


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "cad", help="STEP / STL / DXF of the mirror (machine frame, mm)",
        description="Write the mirror as a STEP solid, an STL mesh or a DXF meridian "
        "drawing, in the machine frame (axis Z, vertex at the origin, part in -Z, mm). "
        "The body (blank, bore or boss) and the export settings come from [cad].",
    )
    add_common(p, output_help="the file to write (default: mirror_<which>.<format>); "
                              "its suffix sets the format when --format is not given")
    p.add_argument("--which", default="design", metavar="design|programmed",
                   help="the designed mirror (exact lobes) or the toolpath's programmed "
                        "contour revolved (default: design)")
    p.add_argument("--format", default=None, metavar="step|stl|dxf",
                   help="file format (default: from -o's suffix, else step)")
    p.add_argument("--schema", default=None, metavar="AP214|AP242",
                   help=f"STEP protocol ({help_default('cad.step_schema')})")
    p.add_argument("--stl-tolerance", type=float, default=None, metavar="MM",
                   help="STL: largest distance of the facets from the surface, mm "
                        f"({help_default('cad.stl_tolerance')}; smaller is finer and "
                        "larger: 0.01 gives ~26 k triangles, 0.001 ~0.24 M)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from pathlib import Path

    from ..enums import CadFormat, Which, parse
    from ..errors import InputError
    from ..export.cad import SUFFIXES, export_cad

    which = parse(Which, args.which, "--which")
    suffix = Path(args.output).suffix.lower() if args.output else ""
    if args.format is not None:
        fmt = parse(CadFormat, args.format, "--format")
        if suffix in SUFFIXES and SUFFIXES[suffix] is not fmt:
            # An STL named .step would open as garbage in the reader the name picks.
            raise InputError(f"-o {args.output}: a {suffix!r} file cannot hold --format "
                             f"{fmt.value}; name it *.{fmt.value} or drop --format")
    elif suffix in SUFFIXES:
        fmt = SUFFIXES[suffix]
    elif suffix:
        raise InputError(f"-o {args.output}: unknown format suffix {suffix!r}; allowed "
                         f"{', '.join(SUFFIXES)} (or give --format)")
    else:
        fmt = CadFormat.STEP
    # A flag that the chosen format ignores is a mistake the user should hear about.
    for flag, value, needs in (("--schema", args.schema, CadFormat.STEP),
                               ("--stl-tolerance", args.stl_tolerance, CadFormat.STL)):
        if value is not None and fmt is not needs:
            raise InputError(f"{flag} applies to --format {needs.value} only, "
                             f"not {fmt.value}")
    from ..body import check_stl_tolerance
    from ..enums import StepSchema
    from ..export.cad import check_target
    from ..job import cad_model, check_program, design

    overrides = []
    if args.schema is not None:
        overrides.append(("cad.step_schema", parse(StepSchema, args.schema, "--schema").value, "--schema"))
    if args.stl_tolerance is not None:
        tol = check_stl_tolerance(args.stl_tolerance, "--stl-tolerance")
        overrides.append(("cad.stl_tolerance", tol, "--stl-tolerance"))
    settings = load(args, overrides)
    path = args.output or f"mirror_{which.value}.{fmt.value}"
    check_target(path)
    mirror = design(settings)
    # The DXF always carries the toolpath layers: it plans the toolpath and checks the
    # program as `lathe-mirror toolpath` does (exit 2 on a program it would refuse).
    programmed = which is Which.PROGRAMMED or fmt is CadFormat.DXF
    if programmed:
        check_program(settings, mirror, settings.toolpath.strategy)
    model = cad_model(settings, mirror, programmed=programmed, programmed_face_only=(which is Which.DESIGN))
    figures = export_cad(model, settings.cad, which, fmt, path)
    if args.json:
        print_json(figures)
    else:
        print(f"wrote {figures['path']} ({fmt.value.upper()}, {which.value} mirror, "
              f"{figures['bytes']} bytes, volume {figures['volume_mm3']:.3f} mm^3)")
    return 0
