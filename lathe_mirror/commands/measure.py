"""`lathe-mirror measure FILE`: a measured profile of the made part, fitted against the
design; figures per lobe and the machine's set-up errors."""

from __future__ import annotations

import argparse

from .common import add_common, load, print_json

#: The files `measure -o DIR` writes.
OUTPUTS = ("measure.json", "measured_minus_design.png")


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "measure", help="fit a measured profile of the made part; diagnose the machine",
        description="Read a measured profile (CSV/text x,z; Taylor Hobson .prf; .x3p profile or map; Zygo "
        ".dat/.datx; the areal formats surfalize reads), fit it against the design (decentre, tilt, "
        "piston; R and k with --fit-conic), report per lobe over its clear aperture the residual's PV, RMS "
        "and slope RMS, and the lathe's set-up errors (tool centre height, X offset, nose radius, "
        "squareness; backlash where the program's finishing moves reverse X, else why the part cannot show it) "
        "as corrections. The trace is in the machine frame, the part face up.")
    p.add_argument("file", metavar="FILE", help="the measured profile or map")
    add_common(p, output_help="directory for measure.json and measured_minus_design.png")
    p.add_argument("--format", metavar="FMT", default=None,
                   help="the file's format when its suffix does not say: csv, prf, x3p, datx, dat, surfalize")
    p.add_argument("--fit-conic", action="store_true", help="also fit each lobe's radius R and conic constant k")
    add_job_flags(p)
    p.set_defaults(func=run)


def add_job_flags(p: argparse.ArgumentParser) -> None:
    """--program STRATEGY and --from DIR: the job the part was cut by."""
    p.add_argument("--program", default=None, metavar="paper|lattice|arcs|best",
                   help="the program's strategy the part was cut with (default: [toolpath] strategy; with "
                   "--from, the job's)")
    p.add_argument("--from", dest="from_dir", default=None, metavar="DIR",
                   help="the job the part was cut by, as `compensate -o DIR` wrote it: its job.toml (the "
                   "configuration, with the nose radius of the tool table) and the re-cut target in its "
                   "compensate.json; instead of --config")


def job_of(args: argparse.Namespace, load_settings):
    """(settings, strategy, target) of the job the part was cut by: --config and --program,
    or --from DIR (measure.nextjob); target None: the program's usual one."""
    from ..enums import BEST, Strategy, parse

    target = None
    if args.from_dir is None:
        settings = load_settings(args)
    else:
        import json
        from pathlib import Path

        from ..errors import InputError
        from ..inputs import read_text
        from ..measure.nextjob import JOB_JSON, JOB_TOML, target_from_dict

        if args.config is not None:
            raise InputError(f"--from {args.from_dir} and --config {args.config}: the job directory holds its "
                             "configuration (job.toml); name one of them")
        d = Path(args.from_dir)
        args.config = str(d / JOB_TOML)
        settings = load_settings(args)
        src = str(d / JOB_JSON)
        try:
            data = json.loads(read_text(src, "--from", 64 << 20))
            nxt = data["next_job"]
        except (json.JSONDecodeError, KeyError, TypeError) as exc:
            raise InputError(f"--from {src}: not a job compensate wrote ({exc.__class__.__name__}: {exc}); "
                             "allowed: the directory of `compensate -o DIR`") from None
        target = target_from_dict(nxt.get("target"), settings.mirror(), src)
        if args.program is None:
            args.program = nxt.get("strategy")
    if args.program is None:
        strategy = settings.toolpath.strategy
    else:
        strategy = parse(Strategy, args.program, "--program", aliases={"best": BEST})
    return settings, strategy, target


def run(args: argparse.Namespace) -> int:
    from ..measure.fit import FitOptions
    from ..measure.result import measure
    from ..job import check_program, design, machine

    settings, strategy, target = job_of(args, load)
    mirror = design(settings)
    if args.output:
        from .common import check_outputs

        check_outputs(args.output, list(OUTPUTS))
    tp = check_program(settings, mirror, strategy, target=target)
    result = measure(args.file, mirror, machine(tp), settings.tool.nose_radius, fmt=args.format,
                     options=FitOptions(conic=args.fit_conic), resolution_mm=settings.machine.resolution,
                     toolpath=tp, touch_off=touch_off_of(tp))
    verdict = refuse_unfit(result, settings, args.file)
    out = result.to_dict()
    out["job"] = {"strategy": strategy.value, "programmed_nose_radius_mm": settings.tool.nose_radius,
                  "target": "re-cut (--from)" if target is not None else "the design's usual",
                  "touch_off": result.diagnosis.touch_off.to_dict()}
    out["this_part"] = verdict
    out["form_tolerance"] = form_verdicts(settings, out["lobes"])
    if args.output:
        from pathlib import Path

        from ..export.files import json_text, write_bytes, write_text
        from ..report.measure_plots import residual_plot
        from .common import output_dir

        d = output_dir(args.output)
        write_text(Path(d) / OUTPUTS[0], json_text(out, indent=1))
        write_bytes(Path(d) / OUTPUTS[1], residual_plot(result.fit))
    if args.json:
        print_json(out)
    else:
        _print(out)
    return 0


def refuse_unfit(result, settings, path) -> dict:
    """The fit's verdict on whether the trace is this part (measure.judge), against each
    lobe's form tolerance (iso10110.spec_of); InputError (exit 2) naming what does not fit
    and its likely cause when it is not: nothing of it reaches a verdict or a re-cut."""
    from ..errors import InputError
    from ..iso10110 import spec_of
    from ..measure.judge import judge

    spec = spec_of(settings)
    tol = {lb.name: spec.lobe(lb.name).form.pv_um for lb in result.fit.lobes}
    verdict = judge(result, tol)
    if verdict["refusal"]:
        raise InputError(f"{path}: {verdict['refusal']}")
    return verdict


def touch_off_of(toolpath):
    """The touch-off the program's set-up sheet prescribes (shop.setup.setup_sheet: X on a
    bore with the nose's +X side when the tool as held can present it, else on an outside
    diameter; Z on the face with the nose's bottom)."""
    import math

    from ..measure.diagnose import TouchOff
    from ..shop.setup import can_touch

    tool = toolpath.held_tool
    if not can_touch(tool, -math.pi / 2):
        raise RuntimeError("the tool cannot touch a face with its nose")  # the tool checks refuse it first
    return TouchOff("bore" if can_touch(tool, 0.0) else "outside")


def form_verdicts(settings, lobes: list[dict]) -> list[dict]:
    """Each measured lobe against its form tolerance from `lathe-mirror spec`
    (iso10110.spec_of: PV and RMS over the clear aperture, RMS slope): pass when all three
    hold. The slope is the residual's over the fit's smoothing band (0.5 mm knots), the
    spec's per its evaluation length."""
    from ..iso10110 import spec_of

    spec = spec_of(settings)
    out = []
    for lb in lobes:
        form = spec.lobe(lb["name"]).form
        checks = {"pv": lb["pv_um"] <= form.pv_um, "rms": lb["rms_um"] <= form.rms_um,
                  "slope": lb["slope_rms_urad"] <= form.slope_urad}
        out.append({"name": lb["name"], "iso10110_5": form.iso10110_5, "pv_um": form.pv_um, "rms_um": form.rms_um,
                    "slope_urad": form.slope_urad, "evaluation_length_mm": form.evaluation_length_mm,
                    "checks": checks, "pass": all(checks.values())})
    return out


def _print(out: dict) -> None:
    f = out["fit"]
    print(f"{out['source']}: decentre {f['decentre_mm'] * 1e3:+.2f} um, tilt {f['tilt_rad'] * 1e6:+.2f} urad, "
          f"piston {f['piston_mm']:+.4f} mm")
    for lf in out["lobes"]:
        print(f"  {lf['name']:5s} r {lf['aperture_mm'][0]:.2f}..{lf['aperture_mm'][1]:.2f} mm: PV {lf['pv_um']:.3f} um, "
              f"RMS {lf['rms_um']:.3f} um, slope RMS {lf['slope_rms_urad']:.1f} urad")
    for v in out.get("form_tolerance") or ():
        failed = [k for k, ok in v["checks"].items() if not ok]
        print(f"  {v['name']:5s} against {v['iso10110_5']}, slope < {v['slope_urad']:g} urad: "
              + ("PASS" if v["pass"] else f"FAIL ({', '.join(failed)})"))
    print(f"  the trace is this part: {sum(c['ok'] for c in out['this_part']['checks'])} of "
          f"{len(out['this_part']['checks'])} checks hold ({', '.join(c['figure'] for c in out['this_part']['checks'][:4])})")
    print(f"  {out['diagnosis']['touch_off']['text']}")
    for c in out["diagnosis"]["corrections"]:
        print(f"  - {c}")
