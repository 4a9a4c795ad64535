"""The optics shop's drawing of the mirror: one A3 page, PDF and SVG (matplotlib, Agg).

The half-section of the part (the body's meridian, body.Meridian, mirrored about the
axis, the material hatched) with its dimensions, the asphere data of each lobe (ISO
10110-12 conic: R, c = 1/R, k, vertex, the Zemax Even Asphere mapping), the sag tables,
the ISO 10110-5 form and ISO 10110-8 texture indications, the clear apertures, the
material and the notes. Plain data in (iso10110.PartSpec, the meridian), bytes out; no
date or software metadata, so the same part gives the same bytes. matplotlib is imported
only here.
"""

from __future__ import annotations

import io
from pathlib import Path
from typing import TYPE_CHECKING

from ..version import __version__
from .files import write_bytes

if TYPE_CHECKING:
    from ..body import Meridian
    from ..iso10110 import PartSpec

#: A3 landscape, inches.
PAGE = (16.54, 11.69)


def drawing_bytes(spec: PartSpec, meridian: Meridian, *, title: str = "lathe-mirror") -> dict[str, bytes]:
    """{"pdf": ..., "svg": ...}: the drawing in both formats."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    with plt.rc_context({"font.size": 7, "font.family": "DejaVu Sans", "svg.hashsalt": "lathe-mirror",
                         "hatch.linewidth": 0.4, "pdf.fonttype": 42}):
        fig = _figure(plt, spec, meridian, title)
        out = {}
        for fmt, meta in (("pdf", {"CreationDate": None, "Producer": None, "Creator": None}),
                          ("svg", {"Date": None, "Creator": None})):
            buf = io.BytesIO()
            fig.savefig(buf, format=fmt, metadata=meta)
            out[fmt] = buf.getvalue()
        plt.close(fig)
    return out


def write_drawing(directory: str | Path, spec: PartSpec, meridian: Meridian, *, stem: str = "mirror_drawing",
                  title: str = "lathe-mirror") -> list[Path]:
    """Write <stem>.pdf and <stem>.svg into `directory` (atomically, export.files)."""
    data = drawing_bytes(spec, meridian, title=title)
    return [write_bytes(Path(directory) / f"{stem}.{fmt}", data[fmt]) for fmt in ("pdf", "svg")]


# --------------------------------------------------------------------------------------


def _figure(plt, spec: PartSpec, meridian: Meridian, title: str):
    import numpy as np

    fig = plt.figure(figsize=PAGE)
    # frame and title block
    frame = fig.add_axes([0.0, 0.0, 1.0, 1.0])
    frame.set_xlim(0, 420)
    frame.set_ylim(0, 297)
    frame.axis("off")
    frame.add_patch(plt.Rectangle((10, 10), 400, 277, fill=False, lw=1.0))
    _title_block(frame, spec, title)

    # the section: a full section of the part about the axis (Z up the page)
    ax = fig.add_axes([0.035, 0.36, 0.44, 0.60])
    ax.set_aspect("equal")
    ax.axis("off")
    pts = meridian.polyline(0.002)
    R = meridian.features["blank_radius"]
    zb = meridian.features["z_back"]
    for side in (1.0, -1.0):
        ax.fill(side * pts[:, 0], pts[:, 1], facecolor="none", edgecolor="black", hatch="////", lw=0.9)
    face = np.concatenate([s.points(0.002) for s in meridian.face])
    for side in (1.0, -1.0):
        ax.plot(side * face[:, 0], face[:, 1], color="tab:blue", lw=1.6)
    zmin, zmax = float(pts[:, 1].min()), float(pts[:, 1].max())
    ax.plot([0, 0], [zmin - 6, zmax + 10], color="black", lw=0.5, ls=(0, (12, 3, 2, 3)))
    ax.text(0.8, zmin - 5.5, "axis of rotation (machine Z)", fontsize=6)
    ax.set_xlim(-R - 16, R + 20)
    ax.set_ylim(zmin - 22, zmax + 28)
    _dimensions(ax, spec, meridian, R, zb, zmax)
    _clear_apertures(ax, spec)
    _datums_and_frames(ax, spec, meridian, R, zb, zmax)
    ax.set_title("SECTION A-A (through the axis), not to scale: the dimensions govern; mm", fontsize=8, loc="left")

    # asphere data and indications
    tab = fig.add_axes([0.50, 0.36, 0.48, 0.60])
    tab.axis("off")
    tab.set_xlim(0, 1)
    tab.set_ylim(0, 1)
    _asphere_table(tab, spec)

    # sag tables
    sag = fig.add_axes([0.035, 0.045, 0.61, 0.30])
    sag.axis("off")
    sag.set_xlim(0, 1)
    sag.set_ylim(0, 1)
    _sag_tables(sag, spec)
    return fig


def _dim(ax, p0, p1, text, offset, *, vertical=False, fontsize=6.5):
    """A dimension line between p0 and p1, offset perpendicular, with extension lines."""
    (x0, y0), (x1, y1) = p0, p1
    if vertical:
        xd = max(x0, x1) + offset if offset > 0 else min(x0, x1) + offset
        ax.plot([x0, xd], [y0, y0], color="0.3", lw=0.4)
        ax.plot([x1, xd], [y1, y1], color="0.3", lw=0.4)
        ax.annotate("", (xd, y0), (xd, y1), arrowprops=dict(arrowstyle="<->", lw=0.5, shrinkA=0, shrinkB=0))
        ax.text(xd + (0.8 if offset > 0 else -0.8), 0.5 * (y0 + y1), text, rotation=90, va="center",
                ha="left" if offset > 0 else "right", fontsize=fontsize)
    else:
        yd = max(y0, y1) + offset if offset > 0 else min(y0, y1) + offset
        ax.plot([x0, x0], [y0, yd], color="0.3", lw=0.4)
        ax.plot([x1, x1], [y1, yd], color="0.3", lw=0.4)
        ax.annotate("", (x0, yd), (x1, yd), arrowprops=dict(arrowstyle="<->", lw=0.5, shrinkA=0, shrinkB=0))
        ax.text(0.5 * (x0 + x1), yd + (0.6 if offset > 0 else -0.6), text, ha="center",
                va="bottom" if offset > 0 else "top", fontsize=fontsize)


def _dimensions(ax, spec: PartSpec, meridian: Meridian, R: float, zb: float, zmax: float) -> None:
    f = meridian.features
    inner, outer = spec.lobes
    rj = spec.junction["r_mm"]
    z_rim_outer = f.get("z_rim_outer", f.get("z_rim", 0.0))
    _dim(ax, (-R, zb), (R, zb), f"\u00d8{2 * R:.2f}", -7)
    _dim(ax, (R, 0.0), (R, zb), f"{-zb:.2f}", 6, vertical=True)
    _dim(ax, (R, z_rim_outer), (R, 0.0), f"{-z_rim_outer:.3f}", 13, vertical=True)
    ca_i, ca_o = inner.conic.clear_aperture, outer.conic.clear_aperture
    _dim(ax, (-ca_o[1], z_rim_outer), (ca_o[1], z_rim_outer), f"CA outer \u00d8{2 * ca_o[1]:.2f}", zmax - z_rim_outer + 17)
    _dim(ax, (-rj, 0.0), (rj, 0.0), f"\u00d8{2 * rj:.3f} (junction)", 10)
    _dim(ax, (-ca_i[1], 0.0), (ca_i[1], 0.0), f"CA inner \u00d8{2 * ca_i[1]:.3f}", 4)
    if ca_o[0] > rj + 1e-6:
        ax.text(-R - 14, zmax + 2, f"CA outer from \u00d8{2 * ca_o[0]:.3f}", fontsize=6)
    spec_body = meridian.spec
    if spec_body.mount.value == "bore":
        rm = spec_body.mount_diameter / 2
        _dim(ax, (-rm, zb + spec_body.mount_depth), (rm, zb + spec_body.mount_depth),
             f"bore \u00d8{spec_body.mount_diameter:g}", 2.5)
        _dim(ax, (-rm, zb), (-rm, zb + spec_body.mount_depth), f"{spec_body.mount_depth:g}", -4, vertical=True)
    # the outer lobe's vertex: virtual, on the axis
    vz = outer.conic.vertex_z
    ax.plot([-2, 2], [vz, vz], color="tab:red", lw=0.7)
    ax.plot([0], [vz], marker="+", color="tab:red")
    sep = spec.callouts.vertex_separation
    ax.annotate(f"V2: outer lobe's vertex (virtual)\nZ = {vz:.4f}; V1-V2 {sep.nominal_mm:.4f} \u00b1 {sep.plus_minus_mm:.3f}",
                (0, vz), (-R - 14, zb + 14), fontsize=6, arrowprops=dict(arrowstyle="-", lw=0.4))
    ax.annotate("V1: inner vertex, Z = 0 (the sag's origin)", (0, 0), (R * 0.55, 1.5), fontsize=6,
                arrowprops=dict(arrowstyle="-", lw=0.4))
    # the step at the junction, with its tolerance
    st = spec.callouts.step_height
    zi, zo = spec.junction["z_inner_rim_mm"], spec.junction["z_outer_edge_mm"]
    _dim(ax, (rj, zi), (rj, zo), f"step {st.nominal_mm:.3f} \u00b1 {st.plus_minus_mm:.3f}", 3, vertical=True,
         fontsize=5.8)
    fr = spec.junction.get("fillet_r_mm")
    if fr is not None:
        ax.annotate(f"R{spec.junction['fillet_radius_mm']:g} fillet (the tool's nose), r {fr[0]:.3f}..{fr[1]:.3f}: "
                    "not optical", (rj, 0.5 * (zi + zo)), (R * 0.35, zb + 6), fontsize=5.8,
                    arrowprops=dict(arrowstyle="->", lw=0.4))
    # indications on the surfaces
    sag_i = float(inner.conic.sag(0.6 * ca_i[1]))
    ax.annotate("lobe 1 (inner)", (0.6 * ca_i[1], -sag_i), (R * 0.45, zmax + 20), fontsize=6.5,
                arrowprops=dict(arrowstyle="->", lw=0.4))
    ro = 0.5 * (ca_o[0] + ca_o[1])
    z_o = float(outer.conic.vertex_z - outer.conic.sag(ro))
    ax.annotate("lobe 2 (outer)", (-ro, z_o), (-R - 8, zmax + 20), fontsize=6.5, arrowprops=dict(arrowstyle="->", lw=0.4))


def _asphere_table(ax, spec: PartSpec) -> None:
    inner, outer = spec.lobes
    y = 0.985
    ax.text(0.0, y, "OPTICAL SURFACES (ISO 10110)", fontsize=9, weight="bold", va="top")
    y -= 0.045
    rows = [("", "lobe 1 (inner)", "lobe 2 (outer)")]
    ci, co = inner.conic, outer.conic
    fi, fo = inner.form, outer.form
    rows += [
        ("surface", "convex conic, A2n = 0", "convex conic, A2n = 0"),
        ("vertex radius R [mm]", f"{ci.R:.6f}", f"{co.R:.6f}"),
        ("curvature c = 1/R [1/mm]", f"{ci.curvature:.8f}", f"{co.curvature:.8f}"),
        ("conic constant k", f"{ci.k:.8f}", f"{co.k:.8f}"),
        ("vertex Z [mm] (datum V1)", f"{ci.vertex_z:.4f}", f"{co.vertex_z:.4f} (virtual)"),
        ("clear aperture r [mm]", f"{ci.clear_aperture[0]:.3f} .. {ci.clear_aperture[1]:.3f}",
         f"{co.clear_aperture[0]:.3f} .. {co.clear_aperture[1]:.3f}"),
        ("hyperbola a, b [mm]", f"{ci.a:.5f}, {ci.b:.5f}", f"{co.a:.5f}, {co.b:.5f}"),
        ("focal distance 2e [mm]", f"{ci.focal_distance_2e:.4f}", f"{co.focal_distance_2e:.4f}"),
        (f"3/ form (fringes, \u03bb = {fi.wavelength_nm:g} nm)", fi.iso10110_5.split(";")[0],
         fo.iso10110_5.split(";")[0]),
        ("   RMSt / RMSi (\u03bb)", " / ".join(fi.iso10110_5.split("; ")[1:3]),
         " / ".join(fo.iso10110_5.split("; ")[1:3])),
        ("   slope error RMS", f"< {fi.slope_urad:g} urad / {fi.evaluation_length_mm:g} mm ({fi.governed_by})",
         f"< {fo.slope_urad:g} urad / {fo.evaluation_length_mm:g} mm ({fo.governed_by})"),
        ("texture (ISO 10110-8)", spec.finish.iso10110_8, spec.finish.iso10110_8),
        ("imperfections (ISO 10110-7)", spec.callouts.imperfections, spec.callouts.imperfections),
        ("runout to A B", spec.callouts.geometric[0].frame, spec.callouts.geometric[1].frame),
    ]
    x = (0.0, 0.36, 0.68)
    for i, row in enumerate(rows):
        for j, cell in enumerate(row):
            ax.text(x[j], y, cell, fontsize=7, va="top", weight="bold" if i == 0 else "normal",
                    family="DejaVu Sans Mono" if (j and i) else "DejaVu Sans")
        y -= 0.030
        ax.plot([0, 1], [y + 0.007, y + 0.007], color="0.8", lw=0.3)
    y -= 0.01
    fin = spec.finish
    lines = [
        "Sag: z(r) = c r\u00b2 / (1 + \u221a(1 - (1 + k) c\u00b2 r\u00b2)), c = 1/R, from each lobe's vertex along the axis, "
        "positive into the part (away from the camera). Zemax Even Asphere: radius R, conic k, all alpha_n = 0.",
        "3/ form: A = power PV, B = irregularity PV, C = rotationally symmetric irregularity PV, in fringes "
        f"(\u03bb/2 of height) at the test wavelength \u03bb = {fi.wavelength_nm:g} nm; RMSt, RMSi in \u03bb; over each "
        f"lobe's clear aperture, piston and tilt removed per lobe. As heights: lobe 1 {fi.iso10110_5_nm}; "
        f"lobe 2 {fo.iso10110_5_nm}.",
        f"Texture: Rq <= {fin.rq_nm:g} nm RMS in the band {fin.band_mm[0]:g} to {fin.band_mm[1]:g} mm "
        f"(TIS {fin.tis * 100:.2f} % at {fin.wavelength_nm:g} nm). Turned: feed {fin.feed_mm:g} mm/rev, nose r "
        f"{fin.nose_radius_mm:g} mm: kinematic Rz {fin.kinematic_rz_um:.3f} um, Ra {fin.kinematic_ra_um:.3f} um; "
        f"the feed marks are a GRATING of period {fin.grating_period_mm:g} mm (1st order at "
        f"{fin.grating_order_angle_mrad:.1f} mrad): "
        + ("polish until no feed mark is visible." if fin.polished else "they remain on the part."),
        f"Junction at r = {spec.junction['r_mm']:.3f} mm: step {spec.junction['step_mm']:.4f} mm, "
        f"{spec.junction['recessed']} lobe recessed; the ring outside the clear apertures is not optical.",
    ]
    c = spec.callouts
    lines += [f"{c.imperfections} (ISO 10110-7): {c.imperfection_basis}.",
              f"Coating: {c.coating}.",
              f"Vertex separation V1-V2 {c.vertex_separation.nominal_mm:.4f} \u00b1 {c.vertex_separation.plus_minus_mm:.3f},"
              f" step {c.step_height.nominal_mm:.4f} \u00b1 {c.step_height.plus_minus_mm:.3f}: {c.step_height.basis}."]
    if spec.as_turned is not None:
        lines.append(spec.as_turned.note)
    for ln in lines:
        bold = ln.startswith("POLISH REQUIRED")
        for part in _wrap(ln, 150):
            ax.text(0.0, y, part, fontsize=6.0, va="top", weight="bold" if bold else "normal",
                    color="tab:red" if bold else "black")
            y -= 0.0225


def _sag_tables(ax, spec: PartSpec) -> None:
    ax.text(0.0, 1.0, f"SAG TABLES (every {spec.step_mm:g} mm of radius across each clear aperture; "
            "sag from the lobe's own vertex; slope = atan(dz/dr))", fontsize=8, weight="bold", va="top")
    x0 = 0.0
    for lb in spec.lobes:
        rows = lb.sag_table
        cols = max(1, -(-len(rows) // 13))
        width = 0.155
        ax.text(x0, 0.91, f"lobe {1 if lb.conic.name == 'inner' else 2} ({lb.conic.name})", fontsize=7,
                weight="bold", va="top")
        for c in range(cols):
            xc = x0 + c * width
            ax.text(xc, 0.85, "r [mm]   sag [mm]   slope [rad]", fontsize=5.6, va="top", family="DejaVu Sans Mono")
            for i, (r, z, s) in enumerate(rows[c * 13:(c + 1) * 13]):
                ax.text(xc, 0.80 - i * 0.058, f"{r:6.3f} {z:9.6f} {s:8.5f}", fontsize=5.6, va="top",
                        family="DejaVu Sans Mono")
        x0 += cols * width + 0.02


def _title_block(ax, spec: PartSpec, title: str) -> None:
    import matplotlib.pyplot as plt

    x, y, w, h = 272, 10, 138, 95
    ax.add_patch(plt.Rectangle((x, y), w, h, fill=False, lw=0.8))
    d = spec.callouts.datums
    rows = [
        ("part", f"{title}: double-lobed hyperbolic mirror"),
        ("material", spec.material),
        ("process", spec.process),
        ("units", "mm; angles rad; general tolerances ISO 2768-mK"),
        ("datums", f"A {d['A']}; B {d['B']}"),
        ("standard", "ISO 10110-5, -7, -8, -9, -12; ISO 1101"),
        ("optical surfaces", "lobes 1 and 2, coated (see the coating note); no burr at the step"),
    ]
    yy = y + h - 4
    for k, v in rows:
        ax.text(x + 2, yy, k, fontsize=6.3, weight="bold", va="center")
        ax.text(x + 27, yy, v, fontsize=5.8, va="center")
        yy -= 5.6
        ax.plot([x, x + w], [yy + 2.8, yy + 2.8], color="0.6", lw=0.3)
    # identity: number, revision, sheet
    yy -= 1.5
    ax.text(x + 2, yy, "drawing no.", fontsize=6.3, weight="bold", va="center")
    ax.text(x + 27, yy, spec.number, fontsize=9, weight="bold", va="center", family="DejaVu Sans Mono")
    ax.text(x + 78, yy, "rev.", fontsize=6.3, weight="bold", va="center")
    ax.text(x + 88, yy, spec.revision, fontsize=9, weight="bold", va="center")
    ax.text(x + 100, yy, "sheet 1 of 1, A3", fontsize=6, va="center")
    yy -= 4.5
    ax.plot([x, x + w], [yy, yy], color="0.3", lw=0.5)
    # approvals
    cols = (x + 2, x + 27, x + 72, x + 110)
    yy -= 4
    for cx, head in zip(cols, ("approval", "name", "signature", "date")):
        ax.text(cx, yy, head, fontsize=6, weight="bold", va="center")
    for role, name in (("drawn", f"lathe-mirror {__version__}"), ("checked", ""), ("approved (optics)", ""),
                       ("approved (shop)", "")):
        yy -= 5.2
        ax.plot([x, x + w], [yy + 2.6, yy + 2.6], color="0.6", lw=0.3)
        ax.text(cols[0], yy, role, fontsize=6, va="center")
        ax.text(cols[1], yy, name, fontsize=5.8, va="center")
    ax.plot([x, x + w], [yy - 2.6, yy - 2.6], color="0.6", lw=0.3)
    for cx in cols[1:]:
        ax.plot([cx - 1.5, cx - 1.5], [yy - 2.6, yy + 5.2 * 4 + 2.6 + 1.4], color="0.6", lw=0.3)
    notes = [
        "1. Inspect each lobe's sag against the sag table; form per lobe, piston and tilt removed.",
        "2. Tolerances from the tool's analysis (lathe-mirror spec --json states each basis).",
        "3. Break body edges 0.2 x 45 deg; no chamfer on the optical face. Table 1's 'c' is 2e.",
        f"4. Clear apertures end {spec.clear_edge_mm:g} mm inside the rim and the step (the polished edge band).",
    ]
    if spec.drill_point is not None:
        notes.append(f"5. Mount bore: drill point {spec.drill_point[0]:g} mm x {spec.drill_point[1]:g} deg below its "
                     "floor permitted.")
    for i, n in enumerate(notes):
        ax.text(x + 2, y + 12.5 - i * 12.5 / len(notes), n, fontsize=5.3, va="top")


def _clear_apertures(ax, spec: PartSpec) -> None:
    """Each lobe's clear aperture drawn along its surface (ISO 10110: a dash-dot line)."""
    import numpy as np

    for lb in spec.lobes:
        c = lb.conic
        lo, hi = c.clear_aperture
        r = np.linspace(lo, hi, 200)
        z = c.vertex_z - c.sag(r)
        for side in (1.0, -1.0):
            ax.plot(side * r, z + 0.6, color="tab:green", lw=0.9, ls=(0, (8, 2, 1, 2)))
    r_out = spec.lobes[1].conic.clear_aperture[1]
    z_top = max(float(lb.conic.vertex_z - lb.conic.sag(lb.conic.clear_aperture[1])) for lb in spec.lobes)
    ax.text(-r_out - 14, z_top + 5, "- \u00b7 - clear aperture", fontsize=5.8, color="tab:green")


def _datums_and_frames(ax, spec: PartSpec, meridian: Meridian, R: float, zb: float, zmax: float) -> None:
    """Datum feature symbols A (the back face) and B (the mount) and the feature control
    frames of the runouts and the perpendicularity (ISO 1101)."""
    box = dict(boxstyle="square,pad=0.25", fc="white", ec="black", lw=0.6)
    body = meridian.spec

    def datum(letter, at, to):
        ax.plot([at[0], to[0]], [at[1], to[1]], color="black", lw=0.5)
        ax.fill([at[0] - 1.0, at[0] + 1.0, at[0]], [at[1], at[1], at[1] + (0.9 if to[1] > at[1] else -0.9)],
                color="black")
        ax.text(to[0], to[1], letter, fontsize=7, weight="bold", ha="center", va="center", bbox=box)

    datum("A", (0.55 * R, zb), (0.55 * R, zb - 9))
    if body.mount.value == "bore":
        rm = body.mount_diameter / 2
        datum("B", (-rm, zb + 0.5 * body.mount_depth), (-rm - 6, zb + 0.5 * body.mount_depth))
    elif body.mount.value == "boss":
        rm = body.mount_diameter / 2
        datum("B", (-rm, zb - 0.5 * body.mount_depth), (-rm - 6, zb - 0.5 * body.mount_depth))
    else:
        datum("B", (-R, zb + 2), (-R - 6, zb + 2))
    g = spec.callouts.geometric
    ax.text(0.55 * R + 5, zb - 9, g[2].frame, fontsize=6.2, va="center", bbox=box, family="DejaVu Sans")
    ax.text(-R - 12, zb - 9, f"B: {g[3].frame}", fontsize=6.2, va="center", bbox=box, family="DejaVu Sans")
    ax.text(-R - 14, zmax + 11, f"lobes 1, 2: {g[0].frame}", fontsize=6.2, va="center", bbox=box)


def _wrap(text: str, width: int) -> list[str]:
    """A long note in lines of at most `width` characters, broken at spaces."""
    import textwrap

    return textwrap.wrap(text, width) or [""]
