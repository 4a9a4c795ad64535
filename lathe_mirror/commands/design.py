"""`lathe-mirror design`: the mirror's design table from the camera's constants."""

from __future__ import annotations

import argparse

from .common import add_common, load, print_result


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("design", help="design the two lobes (Eqs. 3-6, Table 1)",
                       description="Design both lobes from the camera's constants and print "
                       "the design table (the paper's symbols; mm, px, degrees).")
    add_common(p, output_help="write the design figures as JSON to this file")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ..design_table import TABLE1_SWAP_NOTE, design_figures
    from ..job import design
    from ..settings.validate import check_commands

    settings = load(args)
    if args.output:
        from .common import check_outputs
        from .flags import check_suffix

        check_suffix(args.output, "JSON")
        check_outputs(None, [args.output])  # before any work, as every command
    mirror = design(settings)
    check_commands(settings, mirror)  # what any command refuses, `design` refuses too
    figures = design_figures(mirror)
    if args.config is None:
        figures["notes"] = [TABLE1_SWAP_NOTE]
    if args.output:
        from ..export.files import json_text, write_text

        write_text(args.output, json_text(figures))
    print_result(args, figures, format_design)
    return 0


def format_design(fig: dict) -> str:
    """The design as a readable table."""
    rows = [
        ("R_top", "mm", "r_top", "{:.3f}"),
        ("R_pixel", "px", "r_pixel", "{:.3f}"),
        ("f", "mm", "f", "{:.6g}"),
        ("T_pixel", "mm", "t_pixel", "{:.6g}"),  # as given: 0.00345, not 0.0034
        ("c = 2e (focal dist.)", "mm", "c", "{:.3f}"),
        ("R = b^2/a (ISO)", "mm", "R_mm", "{:.4f}"),
        ("k (ISO conic)", "", "k", "{:.5f}"),
        ("h (rim height)", "mm", "h", "{:.3f}"),
        ("a", "mm", "a", "{:.3f}"),
        ("b", "mm", "b", "{:.3f}"),
        ("e", "mm", "e", "{:.3f}"),
        ("a/b", "", "a_over_b", "{:.4f}"),
        ("alpha", "deg", "alpha_deg", "{:.3f}"),
        ("vertex height", "mm", "vertex_z", "{:.3f}"),
    ]
    inner, outer = fig["lobes"]
    lines = [f"{'':24s}{'inner (01)':>14s}{'outer (02)':>14s}"]
    for label, unit, key, fmt in rows:
        name = f"{label} [{unit}]" if unit else label
        lines.append(f"{name:24s}{fmt.format(inner[key]):>14s}{fmt.format(outer[key]):>14s}")
    fov = lambda lobe: f"{lobe['fov_deg']['min']:.2f}..{lobe['fov_deg']['max']:.2f}"  # noqa: E731
    lines.append(f"{'elevation FOV [deg]':24s}{fov(inner):>14s}{fov(outer):>14s}")
    ufov = lambda lobe: f"{lobe['fov_usable_deg']['min']:.2f}..{lobe['fov_usable_deg']['max']:.2f}"  # noqa: E731
    lines.append(f"{'  unblocked [deg]':24s}{ufov(inner):>14s}{ufov(outer):>14s}")
    vp = lambda lobe: f"{lobe['viewpoint_check_mm']:.1e}"  # noqa: E731
    lines.append(f"{'rays missing F1 by [mm]':24s}{vp(inner):>14s}{vp(outer):>14s}")
    j = fig["junction"]
    radii = fig["image_radii_px"]
    band = fig["common_band_deg"]
    lines += [
        "",
        f"junction at r = {j['r']:.3f} mm: step {j['step_mm']:.4f} mm, {j['recessed']} lobe recessed "
        f"(inner sheet z = {j['z_inner']:.4f}, outer sheet z = {j['z_outer']:.4f} mm)",
        f"stereo baseline (F1 to F1): {fig['baseline_mm']:.3f} mm; "
        f"common band: {band['min']:.3f} to {band['max']:.3f} deg elevation",
        "image radii: " + _radii_text(radii),
        f"mirror depth (vertex to the farthest point, the higher rim): {fig['depth_mm']:.3f} mm",
    ]
    for note in fig.get("notes", []):
        lines.append(f"note: {note}")
    return "\n".join(lines)


def _radii_text(radii: dict) -> str:
    """The image radii sentence; empty bands (blocked, lost) are left out."""
    inner = f"inner disc 0..{radii['inner_disc']['max']:.3f} px"
    blocked = radii["inner_blocked_by_step"]
    if blocked["max"] > blocked["min"]:
        inner += f" (its world rays are blocked by the step wall from {blocked['min']:.3f} px out)"
    parts = [inner]
    lost = radii["lost_ring"]
    if lost["max"] > lost["min"]:
        parts.append(f"lost ring {lost['min']:.3f}..{lost['max']:.3f} px")
    parts.append(f"outer annulus {radii['outer_annulus']['min']:.3f}..{radii['outer_annulus']['max']:.3f} px")
    return ", ".join(parts)
