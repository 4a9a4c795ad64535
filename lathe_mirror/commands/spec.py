"""`lathe-mirror spec`: the mirror as the optics shop and the inspection room read it.

Each lobe as an ISO 10110-12 conic (R, k, vertex, clear aperture), its sag table, its form
tolerance (ISO 10110-5) from the tolerance spec, the surface texture (ISO 10110-8) from
the finish model; with -o, the drawing (PDF and SVG, one A3 page) and the JSON.
"""

from __future__ import annotations

import argparse

from .common import add_common, load, print_result

#: Files `spec -o DIR` writes.
FILES = ("mirror_spec.json", "mirror_drawing.pdf", "mirror_drawing.svg")


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("spec", help="ISO 10110 specification and drawing of the mirror (R, k, sag, tolerances)",
                       description="Each lobe as an ISO 10110-12 conic (vertex radius R, conic constant k, "
                       "vertex, clear aperture) with its sag table, form tolerances (ISO 10110-5) from the "
                       "tolerance spec and the surface texture (ISO 10110-8) from the finish model; -o DIR "
                       "writes the drawing (PDF, SVG) and the JSON.")
    add_common(p, output_help="directory for mirror_spec.json, mirror_drawing.pdf and .svg")
    p.add_argument("--step", type=float, default=None, metavar="MM",
                   help="sag-table spacing, mm of radius (default 0.5; 0.001 to 5)")
    p.add_argument("--process", default=None, metavar="NAME",
                   help="finish process of [polish.process] (default: the first, conventional)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ..iso10110 import SAG_STEP_MM, spec_of

    settings = load(args)
    if args.output:
        from .common import check_outputs

        check_outputs(args.output, list(FILES))
    spec = spec_of(settings, step=SAG_STEP_MM if args.step is None else args.step, process=args.process,
                   as_turned=True)
    data = spec.to_dict()
    if args.output:
        write_spec(args.output, settings, spec)
    print_result(args, data, format_spec)
    return 0


def write_spec(directory, settings, spec, *, files: dict[str, bytes] | None = None) -> None:
    """The JSON and the drawing into `directory` (made if missing). files: spec_files's,
    made already (`run` makes them in its background process)."""
    from ..export.files import write_bytes
    from .common import output_dir

    d = output_dir(directory)
    files = spec_files(settings, spec) if files is None else files
    for name in FILES:
        write_bytes(d / name, files[name])


def spec_files(settings, spec) -> dict[str, bytes]:
    """The bytes of FILES: the spec's JSON and the drawing (PDF, SVG)."""
    from ..body import design_meridian
    from ..export.drawing import drawing_bytes
    from ..export.files import json_text

    drawing = drawing_bytes(spec, design_meridian(settings.mirror(), settings.body))
    return {FILES[0]: json_text(spec.to_dict()).encode("utf-8"), FILES[1]: drawing["pdf"], FILES[2]: drawing["svg"]}


def format_spec(d: dict) -> str:
    """The spec as a short text table."""
    lines = [d["convention"], ""]
    for lb in d["lobes"]:
        ft = lb["form_tolerance"]
        ca = lb["clear_aperture_mm"]
        lines += [f"{lb['name']} lobe: R {lb['R_mm']:.6f} mm (c = 1/R = {lb['curvature_c_per_mm']:.8f} /mm), "
                  f"k {lb['k']:.8f}, vertex Z {lb['vertex_z_mm']:.4f} mm, clear aperture r {ca[0]:.3f}..{ca[1]:.3f} mm, "
                  f"focal distance 2e {lb['focal_distance_2e_mm']:.4f} mm",
                  f"  form: {ft['iso10110_5']}; slope < {ft['slope_urad']:g} urad RMS per "
                  f"{ft['evaluation_length_mm']:g} mm ({ft['governed_by']} limit)",
                  f"  sag table: {len(lb['sag_table'])} rows every {d['sag_step_mm']:g} mm (--json prints them)"]
    f = d["finish"]
    lines += [f"texture (ISO 10110-8): {f['iso10110_8']} (Rq nm... mm band); TIS {f['tis']:.2e} at "
              f"{f['wavelength_nm']:g} nm; kinematic Rz {f['kinematic_rz_um']:.3f} um, Ra {f['kinematic_ra_um']:.3f} um; "
              f"feed-mark grating period {f['grating']['period_mm']:g} mm",
              f"material: {d['material']}", f"process: {d['process']}"]
    return "\n".join(lines)
