"""`lathe-mirror cad`: STEP, STL or DXF of the designed or the programmed mirror."""

from __future__ import annotations

import argparse

from ._common import add_common, load, print_json


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
                   help="STEP protocol (overrides cad.step_schema)")
    p.add_argument("--stl-tolerance", type=float, default=None, metavar="MM",
                   help="STL: largest distance of the facets from the surface, mm "
                        "(overrides cad.stl_tolerance; smaller is finer and larger)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from pathlib import Path

    from ..config import set_value
    from ..export.cad import SUFFIXES, CadFormat, Which, export_cad, parse_enum

    which = parse_enum(Which, args.which, "--which")
    if args.format is not None:
        fmt = parse_enum(CadFormat, args.format, "--format")
    elif args.output and Path(args.output).suffix.lower() in SUFFIXES:
        fmt = SUFFIXES[Path(args.output).suffix.lower()]
    elif args.output and Path(args.output).suffix:
        allowed = ", ".join(SUFFIXES)
        raise_input(f"-o {args.output}: unknown format suffix "
                    f"{Path(args.output).suffix!r}; allowed {allowed} (or give --format)")
    else:
        fmt = CadFormat.STEP
    cfg = load(args)
    if args.schema is not None:
        from ..export.step import parse_schema

        set_value(cfg, "cad.step_schema", parse_schema(args.schema, "--schema").value, source="--schema")
    if args.stl_tolerance is not None:
        tol = args.stl_tolerance
        if not 0.0 < tol < 10.0:
            raise_input(f"--stl-tolerance {tol:g} mm: allowed 0 < tolerance < 10 mm")
        set_value(cfg, "cad.stl_tolerance", float(tol), source="--stl-tolerance")
    path = args.output or f"mirror_{which.value}.{fmt.value}"
    figures = export_cad(cfg, which, fmt, path)
    if args.json:
        print_json(figures)
    else:
        print(f"wrote {figures['path']} ({fmt.value.upper()}, {which.value} mirror, "
              f"{figures['bytes']} bytes, volume {figures['volume_mm3']:.3f} mm^3)")
    return 0


def raise_input(message: str) -> None:
    from ..errors import InputError

    raise InputError(message)
