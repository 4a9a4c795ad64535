"""`lathe-mirror calib`: each lobe's camera model for OpenCV, Kalibr and OCamCalib, and how
far a made mirror departs from it (the design's reprojection error; the model refitted)."""

from __future__ import annotations

import argparse

from .common import add_common, add_no_progress, load, print_result

#: The made mirror compared by default: the configured machining job's part (job.MachiningJob),
#: the one every command describes unless told otherwise.
DEFAULT_SURFACES = ("made",)


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "calib", help="calibration files (OpenCV, Kalibr, OCamCalib) and the made mirror's departure",
        description="Write each lobe's unified camera model (xi, gamma; exact for the design) as "
        "OpenCV FileStorage YAML, a Kalibr camchain and OCamCalib calib_results.txt, and for made "
        "mirrors the design model's reprojection error and the model refitted (xi, gamma, k1, k2) "
        "with what it leaves, RMS / max px per lobe.")
    add_common(p, output_help="directory for the calibration files (default: calib/)")
    p.add_argument("--surface", metavar="NAME", default=None,
                   help="the made mirror: exact, reference, uniform528, measured:FILE (a measured part), a "
                   "toolpath strategy (paper, lattice, arcs, best), polished or made (the configured machining "
                   "job's part); default: made")
    p.add_argument("--nose-radius", metavar="MM", type=float, default=None,
                   help="a toolpath strategy's surface as machined by a tool of this nose radius (mm; "
                   "0: the programmed contour); default: the [tool] nose radius")
    p.add_argument("--range-m", metavar="M", type=float, default=None,
                   help="distance (m) from each lobe's viewpoint at which the made mirror's traced "
                   "rays get their world points (inf: directions); default 2")
    add_no_progress(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    import dataclasses
    import math
    from pathlib import Path

    from ..enums import Surface, parse
    from ..errors import InputError
    from ..export.calib import FILE_NAMES
    from ..optics.camera_model import (
        DEFAULT_RANGE_MM,
        design_model_figures,
        made_figures,
    )
    from ..job import MachiningJob, check_program, design, named_surface, surface_label
    from ..optics.radial import radial_figures
    from ..progress import Stages
    from .common import check_outputs

    settings = load(args)
    mirror = design(settings)
    # --range-m and --nose-radius are within their ranges (commands/flags.py, at parsing)
    range_m = DEFAULT_RANGE_MM / 1000.0 if args.range_m is None else args.range_m
    nose = settings.tool.nose_radius if args.nose_radius is None else args.nose_radius
    pose = settings.camera_pose
    from ..optics.zones import zones_for

    zn = zones_for(settings, mirror, nose)  # the zones every command uses, for this nose
    # Before any progress display: a bad name is one line.
    from .common import surface_arg

    measured = None
    if args.surface is not None:
        first, measured = surface_arg(args.surface)  # a name, or measured:FILE
        names = [first]
    else:
        names = [parse(Surface, n, "--surface") for n in DEFAULT_SURFACES]
    builtin = (Surface.EXACT, Surface.REFERENCE, Surface.UNIFORM528, Surface.MEASURED)
    check_outputs(args.output or "calib", list(FILE_NAMES))  # every output name, before any work
    for name in names:  # each program surface's program, checked as every command checks one
        check_program(settings, mirror, name,
                      tool=dataclasses.replace(settings.tool, nose_radius=nose) if nose > 0 else None)
    job = MachiningJob.from_settings(settings, mirror)  # the made mirror every command describes by default
    with Stages([n.value for n in names] + ["files"], not args.no_progress) as steps:
        made = {}
        for name in names:
            steps.start(name.value)
            # The nose applies to toolpath surfaces (and to polished, as its machining).
            nose_k = 0.0 if name in builtin else nose
            surface = named_surface(name, mirror, settings, nose_radius=nose_k, measured=measured, job=job)
            try:
                fig = made_figures(surface, mirror, range_mm=range_m * 1000.0, pose=pose, zones=zn)
            except InputError as exc:
                raise InputError(f"--surface {name.value}: {exc}") from None
            made[name.value] = {"surface": name.value, "made_mirror": surface_label(name, job, nose_radius=nose_k),
                                "nose_radius_mm": nose_k, **fig}
            if pose.aligned:  # the image displacement as every command states it (optics.radial), over the zone
                lobes = radial_figures(surface, mirror, zones=zn)["lobes"]
                made[name.value]["image_displacement_px"] = [
                    {"name": lb["name"], **lb["image_displacement_px"]} for lb in lobes]
                made[name.value]["image_displacement_scene"] = (
                    "at infinity (directions), over the used zone: the figure render, tolerance and the report "
                    "quote; the reprojection errors above are at range_m")
                made[name.value]["over_zone"] = [
                    {"name": lb["name"], "image_displacement_px": lb["image_displacement_px"], "zone_px": lb["zone_px"]}
                    for lb in lobes]
            steps.done()
        steps.start("files")
        from ..export.calib import calibration_texts
        from ..export.files import write_text
        from .common import output_dir

        texts = calibration_texts(mirror, zn)  # every file's text before the directory is made
        out = output_dir(args.output or "calib")
        files = [str(write_text(Path(out) / name, text)) for name, text in texts.items()]
        steps.done()
    figures = {"design": design_model_figures(mirror, zn), "zones": zn.as_dict(), "zones_text": zn.describe(),
               "camera_pose": "aligned" if pose.aligned else {
                   "decentre_mm": list(pose.decentre), "axial_offset_mm": pose.axial_offset,
                   "tilt_deg": [math.degrees(t) for t in pose.tilt]},
               "made": list(made.values()), "files": files}
    print_result(args, figures, format_figures)
    return 0


def format_figures(fig: dict) -> str:
    """The models and the made mirrors' residuals as a short table."""
    lines = [f"{'lobe':8s}{'xi':>14s}{'gamma px':>14s}{'cx, cy px':>16s}{'annulus px':>22s}"]
    for lb in fig["design"]["lobes"]:
        lines.append(f"{lb['name']:8s}{lb['xi']:14.9f}{lb['gamma_px']:14.6f}"
                     f"{lb['cx_px']:>8g},{lb['cy_px']:>7g}{lb['annulus_px']['min']:>11.3f}-"
                     f"{lb['annulus_px']['max']:.3f}")
    dz = fig["design"]["t_cn_cnm1_mm"][2]
    lines.append(f"viewpoints {dz:.6f} mm apart along the axis (Kalibr T_cn_cnm1 of the outer lobe)")
    for m in fig["made"]:
        what = f"{m['surface']} ({m['made_mirror']})"
        rng = "directions" if m["range_m"] == float("inf") else f"world points at {m['range_m']:g} m"
        lines.append(f"{what}, {rng}: reprojection error px RMS / max")
        for lb in m["lobes"]:
            d, r = lb["design"]["reprojection_error_px"], lb["refit"]["reprojection_error_px"]
            lines.append(f"  {lb['name']:6s} design model {d['rms']:.4g} / {d['max']:.4g}; refit "
                         f"(xi {lb['refit']['xi']:.6g}, gamma {lb['refit']['gamma_px']:.6g} px, "
                         f"k1 {lb['refit']['k1']:.3g}, k2 {lb['refit']['k2']:.3g}) {r['rms']:.4g} / {r['max']:.4g}")
        if "image_displacement_px" in m:
            lines.append("  image displacement, scene at infinity, over the used zone (as render, tolerance and the "
                         "report quote it), px RMS / max: " + "; ".join(
                             f"{d['name']} {d['rms']:.4g} / {d['max']:.4g}" for d in m["image_displacement_px"]))
    if "zones_text" in fig:
        lines.append(fig["zones_text"])
    lines += [f"wrote {f}" for f in fig["files"]]
    return "\n".join(lines)
