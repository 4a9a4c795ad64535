"""`lathe-mirror render`: the paper's room through the exact and a made mirror, and the
per-pixel distortion of the made one (ray deviation, image displacement, viewpoint spread)."""

from __future__ import annotations

import argparse

from .common import add_common, load, print_json
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
    import dataclasses
    import math

    import numpy as np

    from ..enums import Surface
    from ..optics.render import image_difference, render_image
    from ..job import (MachiningJob, check_program, check_render_nose, design, named_surface, scene_for,
                       surface_label)
    from ..profile import ExactProfile

    from .common import surface_arg

    surface, measured = surface_arg(args.surface)  # a name, or measured:FILE
    # The flags are the [render] keys: validated (ranges, the render's memory) with the rest.
    settings = load(args, [("render.supersample", args.supersample, "--supersample"),
                           ("render.nose_radius", args.nose_radius, "--nose-radius"),
                           ("render.surface", surface.value if surface and not measured else None, "--surface")])
    rc = settings.render
    surface, nose, n = (rc.surface if measured is None else Surface.MEASURED), rc.nose_radius, rc.supersample
    if args.output:  # every output name, before any work
        from .common import check_outputs

        check_outputs(args.output, output_names(surface.value, nose, image_only=args.image_only))
    mirror = design(settings)
    pose = settings.pose
    exact = ExactProfile(mirror)
    tool = dataclasses.replace(settings.tool, nose_radius=nose) if nose > 0 else None
    check_render_nose(settings, mirror)  # the render's own nose, named as render.nose_radius
    check_program(settings, mirror, surface, tool=tool)  # a program's surface: its program checked
    job = MachiningJob.from_settings(settings, mirror)  # the made mirror every command describes by default
    made = named_surface(surface, mirror, settings, nose_radius=float(nose), measured=measured,
                         job=job)
    label = surface_label(surface, job, nose_radius=float(nose))
    # The zones of the nose that cut this surface (a program's contour: none), as every
    # command states its figures over them (optics.zones.zones_for).
    from ..optics.zones import zones_for

    cut_nose = float(nose) if nose > 0 else (job.cutting_nose if surface in (Surface.MADE, Surface.POLISHED) else 0.0)
    zn = zones_for(dataclasses.replace(settings, tool=dataclasses.replace(settings.tool, nose_radius=cut_nose)),
                   mirror)
    z_top = float(max(np.max(made.z(np.linspace(0, made.r_max, 2001))), mirror.outer.h))
    scene = scene_for(settings, mirror, mirror_top=z_top + abs(pose.axial_offset))
    _check_sees_mirror(made, mirror, pose)
    progress = not args.no_progress  # tqdm on stderr
    out = None
    if args.output:
        from .common import output_dir

        out = output_dir(args.output)
    # the lens's defocus (optics.defocus): every image as the camera records it
    from ..optics.defocus import blur_figures, blur_map, defocus_image, lens_for

    lens = lens_for(mirror, settings.optimize.focus_range_m * 1000.0)
    blur = blur_map(mirror, lens)
    made_img = defocus_image(render_image(made, mirror, scene, pose=pose, supersample=n, progress=progress), blur)
    surface = surface.value
    files = []
    if args.image_only:
        if out is not None:
            files.append(_write_png(out / f"{surface}.png", made_img))
        if args.json:
            print_json({"surface": surface, "made_mirror": label, "files": files})
        return 0

    from ..optics.distortion import image_displacement

    maps = image_displacement(made, mirror, pose=pose, progress=progress)
    exact_img = made_img if surface == "exact" and nose == 0 else defocus_image(render_image(
        exact, mirror, scene, pose=pose, supersample=n, progress=progress), blur)
    # Over the lobes' usable annuli, as the distortion figures: the step-vignetted band is
    # black in both images and would only dilute the difference.
    # maps.annulus: the design's own pixels (optics.distortion.usable_annulus, the report's)
    diff = image_difference(exact_img, made_img, mask=maps.annulus)
    figures = {
        "surface": surface,
        "made_mirror": label,
        "nose_radius_mm": float(nose),
        "supersample": n,
        "pose": {"decentre_mm": list(pose.decentre), "axial_offset_mm": pose.axial_offset,
                 "tilt_deg": [math.degrees(t) for t in pose.tilt]},
        **maps.figures(zn, edge_mm=settings.polish.clear_edge_mm),
        "zones": zn.as_dict(),
        "image_difference": diff,
        "defocus": blur_figures(mirror, lens, zn),
        "image_radii_px": {k: {"min": v[0], "max": v[1]} for k, v in mirror.image_radii_px.items()},
    }
    if out is not None:
        from ..export.files import json_text, write_bytes, write_text
        from ..export.povray import write_povray
        from ..optics.plots import displacement_map_png, displacement_vs_radius_png
        from ..optics.render import difference_image

        same = surface == "exact" and not nose  # the made mirror is the exact one
        files.append(_write_png(out / "exact.png", exact_img))
        if not same:
            files.append(_write_png(out / f"{surface}.png", made_img))
            files.append(_write_png(out / f"difference_{surface}.png", difference_image(exact_img, made_img)))
        title = label
        files.append(str(write_bytes(out / f"displacement_radius_{surface}.png",
                                     displacement_vs_radius_png(maps, title=title))))
        files.append(str(write_bytes(out / f"displacement_map_{surface}.png",
                                     displacement_map_png(maps, title=title))))
        files.append(str(write_povray(out / "exact.pov", exact, mirror, scene, pose=pose)))
        if not same:
            files.append(str(write_povray(out / f"{surface}.pov", made, mirror, scene, pose=pose)))
        figures["files"] = files
        write_text(out / f"figures_{surface}.json", json_text(figures))
    if args.json:
        print_json(figures)
    else:
        print(format_figures(figures))
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


def _check_sees_mirror(profile, mirror, pose) -> None:
    """InputError unless some pixel of a coarse grid sees a lobe of the mirror."""
    import math

    import numpy as np

    from ..errors import InputError
    from ..optics.camera import pixel_centres
    from ..optics.trace import Fate, trace_pixels

    cam = mirror.camera
    u, v = pixel_centres(cam)
    step = max(1, min(cam.sensor_px) // 64)
    xy = np.stack([u[::step, ::step, 0], v[::step, ::step, 0]], axis=-1).reshape(-1, 2)
    hits = trace_pixels(profile, cam, xy, pose=pose)
    if not np.any(hits.fate <= Fate.OUTER):
        raise InputError(
            f"camera: no pixel sees the mirror (camera_pose decentre {list(pose.decentre)} mm, "
            f"axial_offset {pose.axial_offset:g} mm, tilt {[round(math.degrees(t), 3) for t in pose.tilt]} deg); "
            "the camera must look up the mirror axis"
        )


def _write_png(path, img) -> str:
    from ..export.files import write_bytes

    return str(write_bytes(path, png_bytes(img)))


def png_bytes(img) -> bytes:
    """An 8-bit RGB image (H, W, 3) uint8 as PNG bytes (PNG specification, ISO/IEC 15948:
    signature, IHDR, one IDAT of zlib-deflated rows each led by filter type 0, IEND).

    Deflate level 1 with no row filters: about half the time of Pillow's encoder at its
    level 1 (which tries a filter per row) for files of the same size on these images,
    whose flat colours need no filtering; no time or software chunks, so the same image
    gives the same bytes.
    """
    import struct
    import zlib

    import numpy as np

    img = np.ascontiguousarray(img, dtype=np.uint8)
    if img.ndim != 3 or img.shape[2] != 3:
        raise ValueError(f"png_bytes: expected (H, W, 3) uint8, got shape {img.shape}")
    h, w, _ = img.shape
    rows = np.zeros((h, 1 + 3 * w), dtype=np.uint8)  # a 0 byte (no filter) before each row
    rows[:, 1:] = img.reshape(h, 3 * w)

    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    header = struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0)  # 8 bits, truecolour, no interlace
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header)
            + chunk(b"IDAT", zlib.compress(rows.tobytes(), 1)) + chunk(b"IEND", b""))
