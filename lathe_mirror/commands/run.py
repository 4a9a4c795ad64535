"""`lathe-mirror run`: the whole pipeline on the paper default or --config.

design -> programs into gcode/ -> STEP and DXF into cad/ -> calibration files into calib/
-> as-machined, renders, polishing, stereo, tolerance -> report into out/ (or -o), with the
optics shop's specification and drawing beside it (lathe-mirror spec). On the
paper default gcode/, cad/ and calib/ are the repository's reference outputs (regenerated
here); with --config they go into the output directory unless --gcode-dir / --cad-dir /
--calib-dir say otherwise.
"""

from __future__ import annotations

import argparse

from .common import add_common, add_compute, add_no_progress, load_on_executor, print_json


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("run", help="the whole pipeline: programs, CAD, renders, polishing, tolerance, report",
                       description="Design the mirror, write its programs (gcode/) and CAD (cad/), "
                       "predict the made and polished mirrors' images and stereo depth, run the "
                       "tolerance analysis and write the report (out/report.html, out/report.json).")
    add_common(p, output_help="report directory (default: out/)")
    p.add_argument("--gcode-dir", metavar="DIR", help="where the programs go (default: gcode/ on the "
                   "paper default, OUTPUT/gcode with --config)")
    p.add_argument("--cad-dir", metavar="DIR", help="where STEP and DXF go (default: cad/ on the "
                   "paper default, OUTPUT/cad with --config)")
    p.add_argument("--calib-dir", metavar="DIR", help="where the calibration files (OpenCV, Kalibr, "
                   "OCamCalib) go (default: calib/ on the paper default, OUTPUT/calib with --config)")
    p.add_argument("--no-render", action="store_true", help="skip the renders side by side")
    add_compute(p, "the tolerance trials and the allocation's confirmations")
    add_no_progress(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    import sys
    from pathlib import Path

    from ..enums import BEST, Strategy
    from ..export.reference import CALIB_FILES, REFERENCE_FILES, program_names
    from ..job import check_cad, check_program, check_programs, design
    from ..pipeline import report_figures
    from ..compute import active
    from ..report import write_report
    from ..shop.programs import plan_checks
    from .common import check_outputs, output_dir
    from .report import REPORT_FILES, summary

    settings = load_on_executor(args)
    out_dir = Path(args.output or "out")
    default = args.config is None
    gcode_dir = Path(args.gcode_dir) if args.gcode_dir else (Path("gcode") if default else out_dir / "gcode")
    cad_dir = Path(args.cad_dir) if args.cad_dir else (Path("cad") if default else out_dir / "cad")
    calib_dir = Path(args.calib_dir) if args.calib_dir else (Path("calib") if default else out_dir / "calib")
    strategies = (Strategy.PAPER, BEST)
    programs = program_names(strategies)
    from .spec import FILES as SPEC_FILES, write_spec

    for d, names, what in ((out_dir, list(REPORT_FILES) + list(SPEC_FILES), "-o/--output"), (gcode_dir, programs, "--gcode-dir"),
                           (cad_dir, list(REFERENCE_FILES), "--cad-dir"),
                           (calib_dir, list(CALIB_FILES), "--calib-dir")):
        check_outputs(d, names, what)  # every output name, before any work
    mirror = design(settings)
    # Both programs planned and simulated (the stock, the chuck, the part), then the CAD,
    # the calibration files and the spec drawing made (bytes), in the background from here,
    # beside the checks and the report's stages: a check that refuses ends it, and nothing
    # is written before they pass (files commit as a set; this process writes them).
    with active().background(_shop_programs, (settings, mirror, strategies)) as shops_bg:
        check_programs(settings, mirror)  # bad input stops here, before anything is written
        for strategy in strategies:
            check_program(settings, mirror, strategy)  # as every command that uses a program
        check_cad(settings, mirror)       # the CAD body, checked up front too
        plan_checks(settings, mirror, strategies=strategies)  # the bar, the part-off: not waiting for the simulation
        for d, what in ((out_dir, "-o/--output"), (gcode_dir, "--gcode-dir"), (cad_dir, "--cad-dir"),
                        (calib_dir, "--calib-dir")):
            output_dir(d, what)  # one that cannot be made takes the ones before it away
        say = (lambda m: None) if args.no_progress else (lambda m: print(m, file=sys.stderr))
        written: dict[str, list] = {}

        def programs_and_cad() -> None:
            """The programs, the CAD, the calibration files and the spec drawing: beside the
            tolerance analysis."""
            from ..export.reference import write_cad_and_calibration, write_programs

            say("lathe-mirror run: programs")
            made, files = shops_bg.result()  # a design no program can cut, a program that touches the stock: stop here
            shops[:] = made
            written["gcode"] = write_programs(gcode_dir, shops)
            say("lathe-mirror run: CAD")
            written["cad"], written["calib"] = write_cad_and_calibration(cad_dir, calib_dir, settings, mirror,
                                                                         files=files["cad"])
            write_spec(out_dir, settings, None, files=files["spec"])  # the drawing beside the report (`spec`)

        shops: list = []
        data = report_figures(settings, progress=not args.no_progress, renders=not args.no_render,
                              alongside=programs_and_cad, plots=True)
    programs, cad, calib = written["gcode"], written["cad"], written["calib"]
    data.shop = [{"name": shop.program.name, "setup_sheet": f"{shop.program.name}.setup.html",
                  **shop.simulation.figures(),
                  **({"second_setup": {"name": shop.second.name, **shop.second_simulation.figures()}}
                     if shop.second is not None else {})} for shop in shops]
    data.outputs = {kind: [{"path": str(p), "sha256": _sha256(p)} for p in paths]
                    for kind, paths in (("gcode", programs), ("cad", cad), ("calib", calib))}
    paths = write_report(data, out_dir)
    if args.json:
        print_json(data.figures)
    else:
        print(summary(data, paths))
        print("programs: " + ", ".join(str(p) for p in programs))
        print("CAD: " + ", ".join(str(p) for p in cad))
        print("calibration: " + ", ".join(str(p) for p in calib))
    return 0


def _shop_programs(task) -> tuple[list, dict]:
    """The checked, simulated programs (shop.programs.shop_programs) of task = (settings,
    mirror, strategies), and the bytes of the other files `run` writes beside them: the CAD
    and the calibration files (export.reference.cad_and_calibration_files) and the spec's
    JSON and drawing (spec.spec_files). Their making (OCP's import and the STEP, the
    drawing's PDF and SVG: ~5 s) runs here, not in the process the report's stages wait on."""
    from ..export.reference import cad_and_calibration_files
    from ..iso10110 import spec_of
    from ..shop.programs import shop_programs
    from .spec import spec_files

    settings, mirror, strategies = task
    shops = shop_programs(settings, mirror, strategies=strategies)
    return shops, {"cad": cad_and_calibration_files(settings, mirror),
                   "spec": spec_files(settings, spec_of(settings, as_turned=True))}


def _sha256(path) -> str:
    import hashlib

    from ..export.files import written_bytes

    return hashlib.sha256(written_bytes(path)).hexdigest()  # the files are written when run succeeds
