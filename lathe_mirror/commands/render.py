"""`lathe-mirror render`: the paper's room through the exact and a made mirror, and the
per-pixel distortion of the made one (ray deviation, image displacement, viewpoint spread)."""

from __future__ import annotations

import argparse

from .common import add_common, load, print_json, print_result
from ..settings.keys import help_default


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "render", help="synthetic images through the mirror and the made mirror's distortion",
        description="Trace every pixel of the camera exactly off the exact mirror and a made "
        "one (--surface), render the paper's room ([scene] in the config), write PNGs of both "
        "and their difference, the distortion figures per lobe (ray_deviation_deg, "
        "image_displacement_px, viewpoint_spread_mm), plots, and the POV-Ray 3.7 scene.")
    add_common(p, output_help="output directory for the PNGs, plots, figures.json and .pov")
    p.add_argument("--surface", metavar="NAME", default=None,
                   help="made surface: exact, reference, uniform528, measured:FILE (a measured part), a toolpath strategy "
                   "(paper, best, ...), or polished (the paper program as machined, polished at "
                   "the polishing optimum); " + help_default("render.surface"))
    p.add_argument("--nose-radius", metavar="MM", type=float, default=None,
                   help="trace the as-machined surface of a tool with this nose radius (mm) "
                   "instead of the programmed contour; " + help_default("render.nose_radius"))
    p.add_argument("--supersample", metavar="N", type=int, default=None,
                   help="N x N rays per pixel for the images (N^2 the cost); " + help_default("render.supersample"))
    p.add_argument("--image-only", action="store_true",
                   help="render only the made surface's image (no exact image, figures or plots)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar on stderr")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ..enums import Surface
    from ..report.render_figures import render_plan, write_png

    from .common import surface_arg

    surface, measured = surface_arg(args.surface)  # a name, or measured:FILE
    # The flags are the [render] keys: validated (ranges, the render's memory) with the rest.
    settings = load(args, [("render.supersample", args.supersample, "--supersample"),
                           ("render.nose_radius", args.nose_radius, "--nose-radius"),
                           ("render.surface", surface.value if surface and not measured else None, "--surface")])
    rc = settings.render
    surface, nose = (rc.surface if measured is None else Surface.MEASURED), rc.nose_radius
    if args.output:  # every output name, before any work
        from .common import check_outputs

        check_outputs(args.output, output_names(surface.value, nose, image_only=args.image_only))
    plan = render_plan(settings, surface, measured=measured, progress=not args.no_progress)  # tqdm on stderr
    out = None
    if args.output:
        from .common import output_dir

        out = output_dir(args.output)
    made_img = plan.made_image()
    if args.image_only:
        files = []
        if out is not None:
            files.append(write_png(out / f"{surface.value}.png", made_img))
        if args.json:
            print_json({"surface": surface.value, "made_mirror": plan.label, "files": files})
        return 0
    maps, exact_img, figures = plan.distortion(made_img)
    if out is not None:
        plan.write(out, made_img, exact_img, maps, figures)
    print_result(args, figures, format_figures)
    return 0


def output_names(surface: str, nose: float, *, image_only: bool = False) -> list[str]:
    """The files `render -o DIR` writes for a surface (and nose radius, mm)."""
    if image_only:
        return [f"{surface}.png"]
    same = surface == "exact" and not nose  # the made mirror is the exact one
    names = ["exact.png"]
    if not same:
        names += [f"{surface}.png", f"difference_{surface}.png"]
    names += [f"displacement_radius_{surface}.png", f"displacement_map_{surface}.png", "exact.pov"]
    if not same:
        names.append(f"{surface}.pov")
    return names + [f"figures_{surface}.json"]


def format_figures(fig: dict) -> str:
    """The figures as a short table."""
    lines = [f"surface {fig['surface']}: {fig['made_mirror']}"]
    lines.append(f"{'lobe':8s}{'pixels':>9s}{'ray dev. deg rms/max':>24s}{'image disp. px rms/max':>26s}"
                 f"{'viewpoint mm rms/max':>24s}")
    for lobe in fig["lobes"]:
        cells = [f"{lobe[k]['rms']:.4g} / {lobe[k]['max']:.4g}" for k in
                 ("ray_deviation_deg", "image_displacement_px", "viewpoint_spread_mm")]
        lines.append(f"{lobe['name']:8s}{lobe['pixels']:>9d}{cells[0]:>24s}{cells[1]:>26s}{cells[2]:>24s}")
    lost = [f"{lb['name']} {lb['pixels_left_range']} ({lb['left_range_pct']:.3g} %)" for lb in fig["lobes"]]
    lines.append("pixels lost, their ray left the lobe's range (never a displacement): " + ", ".join(lost))
    edges = [f"{lb['name']} {lb['edge']['pixels']} px, {lb['edge']['image_displacement_px']['rms']:.4g} / "
             f"{lb['edge']['image_displacement_px']['max']:.4g} px" for lb in fig["lobes"]
             if "edge" in lb and lb["edge"]["pixels"]]
    if edges:
        lines.append(f"edge band ({fig['lobes'][0]['edge']['band_mm']:g} mm from the step and the rim) on its own, "
                     "image disp. px rms/max: " + "; ".join(edges))
    if "defocus" in fig:
        lines.append(defocus_line(fig["defocus"]))
    d = fig["image_difference"]
    lines.append(f"image difference against the exact mirror (usable annuli): RMS {d['rms']:.3f} grey levels, "
                 f"SSIM {d['ssim']:.4f}")
    for f in fig.get("files", []):
        lines.append(f"wrote {f}")
    return "\n".join(lines)


def defocus_line(fig: dict) -> str:
    """One line: the lens and the blur circle per lobe (optics.defocus.blur_figures)."""
    lens = fig["lens"]
    lobes = "; ".join(f"{lb['name']} {lb['blur_px']['min']:.2f} to {lb['blur_px']['max']:.2f} px "
                      f"(mean {lb['blur_px']['mean']:.2f})" for lb in fig["lobes"])
    return (f"defocus (thin lens f/{lens['f_number']:g} focused at {lens['focus_mm']:.1f} mm, scene "
            f"{lens['object_range_mm'] / 1000.0:g} m from the viewpoints): blur circle {lobes}; the images are blurred by it")
