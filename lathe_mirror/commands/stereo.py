"""`lathe-mirror stereo`: range the paper's room from one rendered image of a mirror, as the
robot would (rectify, match, triangulate), and measure it against the room's true range."""

from __future__ import annotations

import argparse

from .common import add_common, add_no_progress, load, print_json
from ..settings.keys import help_default


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "stereo", help="range from the image: stereo matching along the radial epipolar lines",
        description="Render the room through a mirror, unwrap both lobes onto one azimuth x "
        "elevation grid over the common band, match them with OpenCV's StereoSGBM along the "
        "epipolar lines, triangulate range and 3-D points from the two viewpoints, and compare "
        "with the room's true range: valid fraction, median and RMS range error overall and "
        "per range bin, the resolution model and R10. -o DIR writes the range panorama (PNG), "
        "the error against range (PNG), the point cloud (PLY) and the figures (JSON).")
    add_common(p, output_help="output directory for range_<surface>.png, error_range_<surface>.png, "
               "points_<surface>.ply and stereo_<surface>.json")
    p.add_argument("--surface", metavar="NAME", default=None,
                   help="the mirror: exact, reference, uniform528, measured:FILE (a measured part), a toolpath strategy (paper, best, "
                   "...) or polished; " + help_default("stereo.surface"))
    add_no_progress(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    import numpy as np

    from ..optics.ranging.stereo import (band_visibility, error_curve, image_mask, prepare,
                                         range_figures, stereo_range)
    from ..optics.ranging.truth import true_range
    from ..optics.render import render_image
    from ..job import MachiningJob, check_program, design, named_surface, scene_for, surface_label
    from ..progress import Stages

    settings = load(args)
    st = settings.stereo
    from .common import surface_arg

    surface, measured = surface_arg(args.surface)  # a name, or measured:FILE
    surface = surface if surface is not None else st.surface
    mirror = design(settings)
    pose = settings.pose
    grid, match = prepare(mirror, st.params)  # an empty or too narrow band stops here
    if args.output:  # every output name, before any work
        from .common import check_outputs

        files = (("range", "png"), ("error_range", "png"), ("points", "ply"), ("stereo", "json"))
        check_outputs(args.output, [f"{stem}_{surface.value}.{ext}" for stem, ext in files])
    check_program(settings, mirror, surface)  # a surface cut by a program: the program checked
    stages = Stages(["surface", "render", "match", "truth", "write"], enabled=not args.no_progress)
    try:
        stages.start("surface")
        job = MachiningJob.from_settings(settings, mirror)  # the made mirror every command describes
        made = named_surface(surface, mirror, settings, measured=measured, job=job)
        seen = band_visibility(made, mirror, grid, pose)
        for name, frac in zip(("inner", "outer"), seen):
            if frac < 0.5:
                raise_unseen(surface.value, name, frac)
        z_top = float(max(np.max(made.z(np.linspace(0, made.r_max, 2001))), mirror.outer.h))
        scene = scene_for(settings, mirror, mirror_top=z_top + abs(pose.axial_offset))
        stages.done()
        if args.output:
            from ..report.range_plots import preload

            preload()  # pyplot's import overlaps the render and the matching
        stages.start("render")
        # the lens's defocus (optics.defocus): the matcher sees the image as the camera records
        # it; the render reaches as far past the mask as the blur does
        from ..optics.defocus import blur_figures, blur_map, defocus_image, grow_mask, lens_for
        from ..optics.zones import zones_for

        lens = lens_for(mirror, settings.optimize.focus_range_m * 1000.0)
        blur = blur_map(mirror, lens)
        image = defocus_image(render_image(made, mirror, scene, pose=pose, supersample=st.supersample,
                                           pixels=grow_mask(image_mask(mirror, grid, match.num_disparities), blur)),
                              blur)
        stages.done()
        stages.start("match")
        result = stereo_range(image, mirror, st.params)
        stages.done()
        stages.start("truth")
        truth = true_range(mirror, scene, grid)
        figures = {"surface": surface.value, "made_mirror": surface_label(surface, job), "supersample": st.supersample,
                   "camera_pose_aligned": pose.aligned, **range_figures(result, truth, mirror),
                   "defocus": blur_figures(mirror, lens, zones_for(settings, mirror))}
        precision = figures["disparity_error_px"]["precision"]
        curve = {**error_curve(result, truth, mirror, precision), "precision_px": precision}
        figures["error_curve"] = curve
        stages.done()
        stages.start("write")
        files = []
        if args.output:
            files = write_outputs(args.output, surface.value, result, figures, curve, st.ply_binary)
        figures["files"] = files
        stages.done()
    except BaseException:
        if stages.bar is not None:
            stages.bar.leave = False  # clear the bar: the error stays the only line on stderr
        raise
    finally:
        stages.close()
    if args.json:
        print_json(figures)
    else:
        print(format_figures(figures))
    return 0


def raise_unseen(surface: str, lobe: str, frac: float) -> None:
    from ..errors import InputError

    raise InputError(
        f"--surface {surface}: the camera sees the common band through the {lobe} lobe on only "
        f"{100 * frac:.1f} % of its panorama (at least 50 % needed; check the surface and "
        "[camera_pose]): no stereo")


def write_outputs(out, surface: str, result, figures: dict, curve: dict, binary: bool) -> list[str]:
    """Write the range panorama and the error plot (PNG), the point cloud (PLY) and the
    figures (JSON) into the directory out; returns the paths."""
    import math

    from ..export.files import json_text, write_bytes, write_text
    from ..export.ply import write_ply
    from ..report.range_plots import error_vs_range_png, range_map_png
    from .common import output_dir

    out = output_dir(out)
    band = tuple(math.degrees(x) for x in result.grid.band)
    rng_m = result.range_map.range_mm / 1e3
    valid = result.valid
    files = [str(write_bytes(out / f"range_{surface}.png", range_map_png(
        rng_m, band, title=f"{surface}: range from the stereo centre, {100 * valid.mean():.1f} % of the "
        "common band ranged (grey: no range)")))]
    files.append(str(write_bytes(out / f"error_range_{surface}.png", error_vs_range_png(
        {surface: curve}, title=f"{surface}: median |range error| against range"))))
    pts = result.range_map.points[valid] * 1e-3
    files.append(str(write_ply(out / f"points_{surface}.ply", pts, result.colour[valid], binary=binary,
                               comments=(f"lathe-mirror stereo, surface {surface}",
                                         "units m; camera frame: pinhole at the origin, +z up the mirror axis"))))
    path = out / f"stereo_{surface}.json"
    files.append(str(path))
    write_text(path, json_text({**figures, "files": files}))
    return files


def format_figures(fig: dict) -> str:
    """The figures as a short table."""
    e = fig["range_error_pct"]
    d = fig["disparity_error_px"]
    lines = [
        f"surface {fig['surface']} ({fig['made_mirror']}): {fig['grid']['n_elevation']} x {fig['grid']['n_azimuth']} px panoramas over "
        f"{fig['grid']['band_deg']['min']:.2f} to {fig['grid']['band_deg']['max']:.2f} deg "
        f"({fig['grid']['elevation_step_deg']:.4f} deg/px), baseline {fig['baseline_mm']:.3f} mm, "
        f"R10 {fig['r10_m']:.3f} m",
        f"ranged {100 * fig['valid_fraction']:.1f} % of the common band's {fig['pixels']} px; "
        f"|range error| median {e['median']:.2f} %, RMS {e['rms']:.2f} % (signed median {e['signed_median']:+.2f} %); "
        f"|disparity error| median {d['median']:.3f} px, RMS {d['rms']:.3f} px",
        f"{'range m':>10s}{'pixels':>9s}{'ranged %':>10s}{'median %':>10s}{'RMS %':>9s}{'signed %':>10s}"
        f"{'model 1 px %':>14s}{'model matcher %':>17s}",
    ]
    for b in fig["bins"]:
        r = b["range_error_pct"]
        lines.append(f"{b['range_m'][0]:>4.1f}-{b['range_m'][1]:<4.1f}  {b['pixels']:>9d}{100 * b['valid_fraction']:>10.1f}"
                     f"{r['median']:>10.2f}{r['rms']:>9.2f}{r['signed_median']:>+10.2f}{b['model_1px_pct']:>14.1f}"
                     f"{b['model_matcher_pct']:>17.2f}")
    if "defocus" in fig:
        from .render import defocus_line

        lines.append(defocus_line(fig["defocus"]))
    vs = fig["valid_by_surface"]
    lines.append("ranged by surface: " + ", ".join(f"{k} {100 * v['valid_fraction']:.1f} % of {v['pixels']} px"
                                                   for k, v in vs.items() if v["pixels"]))
    for f in fig.get("files", []):
        lines.append(f"wrote {f}")
    return "\n".join(lines)
