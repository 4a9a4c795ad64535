"""`lathe-mirror stereo`: range the paper's room from one rendered image of a mirror, as the
robot would (rectify, match, triangulate), and measure it against the room's true range."""

from __future__ import annotations

import argparse

from .common import add_common, add_no_progress, load, print_result
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
    from ..progress import Stages
    from ..report.stereo_figures import preload, stereo_plan, write_stereo

    settings = load(args)
    st = settings.stereo
    from .common import surface_arg

    surface, measured = surface_arg(args.surface)  # a name, or measured:FILE
    surface = surface if surface is not None else st.surface
    plan = stereo_plan(settings, surface, measured=measured)  # an empty or too narrow band stops here
    if args.output:  # every output name, before any work
        from .common import check_outputs

        files = (("range", "png"), ("error_range", "png"), ("points", "ply"), ("stereo", "json"))
        check_outputs(args.output, [f"{stem}_{surface.value}.{ext}" for stem, ext in files])
    plan.check_program()  # a surface cut by a program: the program checked
    with Stages(["surface", "render", "match", "truth", "write"], enabled=not args.no_progress) as stages:
        stages.start("surface")
        plan.made_surface()
        stages.done()
        if args.output:
            preload()  # pyplot's import overlaps the render and the matching
        stages.start("render")
        image = plan.image()
        stages.done()
        stages.start("match")
        result = plan.range(image)
        stages.done()
        stages.start("truth")
        figures, curve = plan.figures(result)
        stages.done()
        stages.start("write")
        files = []
        if args.output:
            from .common import output_dir

            files = write_stereo(output_dir(args.output), surface.value, result, figures, curve, st.ply_binary)
        figures["files"] = files
        stages.done()
    print_result(args, figures, format_figures)
    return 0


def format_figures(fig: dict) -> str:
    """The figures as a short table."""
    e = fig["range_error_pct"]
    d = fig["disparity_error_px"]
    lines = [
        f"surface {fig['surface']} ({fig['made_mirror']}): {fig['grid']['n_elevation']} x {fig['grid']['n_azimuth']} px panoramas over "
        f"{fig['grid']['band_deg']['min']:.2f} to {fig['grid']['band_deg']['max']:.2f} deg "
        f"({fig['grid']['elevation_step_deg']:.4f} deg/px), baseline {fig['baseline_mm']:.3f} mm, "
        f"sharp R10 (1 px of disparity) {fig['r10_m']:.3f} m",
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
