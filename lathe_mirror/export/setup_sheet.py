"""The set-up sheet as one self-contained HTML page (pictures embedded), written beside
the programs it goes with. It lays out the model it is handed (shop.setup.SetupSheet);
nothing is computed here but the pictures of the stock after each operation (inline SVG,
export.stock_svg: geometry snapped to 0.001 mm, so the same sheet gives the same bytes).
"""

from __future__ import annotations

import html
from pathlib import Path
from typing import TYPE_CHECKING

from .dialects import dialects
from .files import write_text
from .stock_svg import polygons, stock_svg

if TYPE_CHECKING:
    from ..shop.setup import SetupSheet


def setup_sheet_html(sheet: SetupSheet) -> str:
    """The sheet as an HTML page."""
    e = html.escape
    x_unit = "diameter" if sheet.diameter_mode else "radius"
    ds = dialects()
    labels = ", ".join(d.label for d in ds)
    files = [f"{sheet.name}.{d.extension}" for d in ds]
    out = [
        "<!DOCTYPE html>", "<html><head><meta charset='utf-8'>",
        f"<title>Set-up sheet {e(sheet.name)}</title>",
        "<style>body{font-family:sans-serif;max-width:62em;margin:1em auto}"
        "table{border-collapse:collapse;margin:.5em 0}td,th{border:1px solid #999;padding:.2em .5em;"
        "text-align:left}th{background:#eee}td.n{text-align:right}svg{max-width:100%;height:auto;display:block}</style>",
        "</head><body>",
        f"<h1>Set-up sheet: {e(sheet.name)}</h1>",
        f"<p>Programs: {', '.join(f'<code>{e(f)}</code>' for f in files)} ({e(labels)}; the "
        f"same block numbers N), each control's tool data beside them: "
        f"{', '.join(f'<code>{e(d.offsets_file)}</code>' for d in ds)}. Strategy <b>{e(sheet.strategy)}</b>. Estimated cycle time "
        f"<b>{_time(sheet.cycle_time_s)}</b>"
        + (f"; the second set-up (below) {_time(sheet.second.cycle_time_s)}" if sheet.second is not None else "")
        + ".</p>",
        "<h2>Work zero</h2>", f"<p>{e(sheet.work_zero)}</p>",
        "<h2>Stock and chucking</h2>", "<table>",
        _row("bar diameter", f"{sheet.stock['diameter_mm']:g} mm"),
        _row("face allowance (faced off)", f"{sheet.stock['face_allowance_mm']:g} mm above Z0"),
        _row("deepest programmed point", f"Z{sheet.stock['deepest_z_mm']:.3f}"),
        _row("stick-out from the jaws", f"at least {sheet.stock['stick_out_mm']:g} mm (jaws below "
             f"Z-{sheet.stock['length_mm']:g})"),
        _row("blank length", f"<b>{sheet.stock['blank_length_mm']:g} mm</b>: the stick-out and "
             f"{sheet.stock['grip_mm']:g} mm in the jaws (the least they grip)"),
        "</table>",
        "<h2>Tools</h2>", _tool_table(sheet.tools, sheet.diameter_mode),
    ]
    off = sheet.tools[0].offsets
    rho = off.nose_radius
    d_example = 20.0
    side = ("a bore (inside diameter) with the nose's outer (+X) side" if off.x_side == "bore"
            else "an outside diameter with the nose's inner side")
    sign = "-" if off.x_side == "bore" else "+"
    out += [
        "<h2>Offsets: the nose-centre convention</h2>",
        "<p>The program moves the nose <b>centre</b>; enter the offsets so that the controlled point "
        "is the nose centre (tip code below), for each tool:</p><table>",
        _row("Z", f"touch the bar's face (Z{sheet.face_z:g}) with the nose's bottom and enter "
                  f"<b>Z{off.z_entry(sheet.face_z):.3f}</b> (the touched face + {rho:g} mm)"),
        _row("X", f"touch {side}, diameter D, and enter <b>X = D {sign} {2 * rho:g}</b> mm "
                  f"(X is the {x_unit}); e.g. D = {d_example:.3f} mm: enter "
                  f"<b>X{off.x_entry(d_example):.3f}</b>. " + _x_surface(sheet, off, d_example)),
        _row("tip code", "; ".join(f"{e(d.label)} {e(d.tip_code(sheet.tools[0]))}" for d in ds)
             + " (the nose centre); the program uses no nose compensation (G40)"),
        _row("centre height", f"within &plusmn;{sheet.centre_height_mm:.3f} mm: a tool off centre by h cannot "
                              "cut r &lt; h and leaves a pip of radius h at the vertex; beyond this it "
                              "covers more than the one pixel the vertex images to"),
        _row("centre height check", f"before the program, face a scrap bar (or this bar's face allowance) "
                                    f"through X0 with each turning tool in MDI and measure the pip left at the "
                                    f"centre: its diameter is twice the tool's height error; allowed at most "
                                    f"<b>{2 * sheet.centre_height_mm:.3f} mm</b> (a tool above centre leaves no "
                                    "pip but rubs the centre: look for a torn spot instead; shim until neither)"),
        "</table>",
        f"<h2>What a {sheet.setting_costs['delta_mm']:g} mm setting error costs</h2>",
        "<p>The exact mirror turned with one offset off by that much (the turning's own errors "
        "aside):</p><table><tr><th>offset off</th><th>lobe</th><th>slope error max</th>"
        "<th>image displacement rms / max</th></tr>",
    ]
    for axis in ("x", "z"):
        for lobe in sheet.setting_costs[axis]["lobes"]:
            se, idp = lobe["slope_error_rad"], lobe["image_displacement_px"]
            out.append(f"<tr><td>{axis.upper()} {'(radius)' if axis == 'x' else ''}</td><td>{e(lobe['name'])}</td>"
                       f"<td class='n'>{se['max'] * 1e3:.3f} mrad</td>"
                       f"<td class='n'>{idp['rms']:.3f} / {idp['max']:.3f} px</td></tr>")
    out += [
        "</table>",
        "<h2>Operations</h2>",
        "<table><tr><th>operation</th><th>tool</th><th>restart at</th><th>feed mm/rev</th>"
        "<th>removed mm&sup3;</th><th>max depth of cut mm</th><th>max chip section mm&sup2;</th>"
        "<th>max removal cm&sup3;/min</th><th>plunge mm</th><th>cutting</th><th>air</th><th>rapid</th>"
        "<th>time</th></tr>",
    ]
    for op in sheet.operations:
        f = op.figures
        out.append(
            f"<tr><td>{e(op.name)}</td><td>T{op.station}</td><td>N{op.restart_block}</td>"
            f"<td class='n'>{f['feed_mm_rev']:g}</td><td class='n'>{f['removed_volume_mm3']:.0f}</td>"
            f"<td class='n'>{_depth_of_cut(f)}</td><td class='n'>{f['max_chip_section_mm2']:.4f}</td>"
            f"<td class='n'>{f['max_removal_rate_cm3_min']:.1f}</td><td class='n'>{f['plunge_mm']:.2f}</td>"
            f"<td class='n'>{_time(f['cut_time_s'])}</td><td class='n'>{_time(f['air_time_s'])}</td>"
            f"<td class='n'>{_time(f['rapid_time_s'])}</td><td class='n'>{_time(f['cycle_time_s'])}</td></tr>")
    out.append(f"<tr><th colspan='12'>total (no tool change, no optional stop)</th>"
               f"<th>{_time(sheet.cycle_time_s)}</th></tr></table>")
    out += [f"<p>{e(n)}</p>" for n in sheet.notes]
    if sheet.inspection:
        out += ["<h2>Inspection</h2>",
                "<p>Probe each lobe at these radii (a stylus trace through the axis or a CMM), Z from "
                "the datum V1 (Z0, the inner vertex) after fitting the piston; each point must lie within "
                "the band, the lobe's ISO 10110-5 form tolerance (PV / 2 either side; "
                "<code>lathe-mirror spec</code> states it). The sag is from the lobe's own vertex.</p>",
                "<table><tr><th>lobe</th><th>r mm</th><th>Z mm</th><th>sag mm</th><th>slope rad</th>"
                "<th>band &plusmn;um</th></tr>"]
        for row in sheet.inspection:
            out.append(f"<tr><td>{e(row.lobe)}</td><td class='n'>{row.r_mm:.3f}</td><td class='n'>{row.z_mm:.6f}</td>"
                       f"<td class='n'>{row.sag_mm:.6f}</td><td class='n'>{row.slope_rad:.5f}</td>"
                       f"<td class='n'>{row.band_um:.2f}</td></tr>")
        out.append("</table>")
    out.append(f"<p>End position: home X{sheet.home[0] * (2 if sheet.diameter_mode else 1):.3f} "
               f"Z{sheet.home[1]:.3f}, reached Z first.</p>")
    out.append("<h2>The stock after each operation</h2>")
    for i, op in enumerate(sheet.operations):
        out.append(f"<h3>{e(op.name)}</h3>{_stock_picture(sheet, op, f'op{i + 1}')}")
    if sheet.second is not None:
        out += _second_html(sheet)
    out.append("</body></html>")
    return "\n".join(out) + "\n"


def write_setup_sheet(path: str | Path, sheet: SetupSheet) -> Path:
    """Write the sheet atomically."""
    return write_text(path, setup_sheet_html(sheet))


def _x_surface(sheet: SetupSheet, off, d_example: float) -> str:
    """Which surface the X touch-off uses: one that exists before the program runs."""
    if off.x_side != "bore":
        return f"Touch the bar's outside diameter ({sheet.stock['diameter_mm']:g} mm, turned true first)."
    allow = sheet.stock["face_allowance_mm"]
    if allow < 0.2:
        return ("The bar has no bore and too little face allowance for a test recess: set X with the same "
                "tool in its holder on a scrap bar (a recess bored and measured as below), then mount this bar.")
    depth = min(0.3, allow / 2)
    return (f"The bar has no bore: before the program, in MDI, cut a test recess into the face allowance "
            f"from the axis out to about D = {d_example:g} mm, {depth:g} mm deep (its bottom stays above Z0; "
            f"the facing removes it), measure its diameter D with a bore gauge or inside caliper and enter "
            f"X as above.")


def _tool_table(tools, diameter_mode: bool) -> str:
    """The tools: station, role, insert, holder and its hand, spindle, each dialect's entry."""
    e, ds = html.escape, dialects()
    out = ["<table><tr><th>tool</th><th>role</th><th>insert</th><th>holder, hand</th><th>spindle</th>"
           + "".join(f"<th>{e(d.label)} ({e(d.offsets_file)})</th>" for d in ds) + "</tr>"]
    for t in tools:
        out.append(f"<tr><td>{' / '.join(e(d.tool_word(t.station)) for d in ds)}</td><td>{e(t.role)}</td>"
                   f"<td>{e(t.insert)}</td><td>{e(t.holder)}</td><td>{e(t.spindle)}</td>"
                   + "".join(f"<td><code>{e(d.offset_entry(t, diameter_mode))}</code></td>" for d in ds) + "</tr>")
    return "".join(out) + "</table>"


def _depth_of_cut(f: dict) -> str:
    """An operation's largest depth of cut (mm), n/a for a drill (its radius, not a setting)."""
    return "n/a" if f["max_depth_of_cut_mm"] is None else f"{f['max_depth_of_cut_mm']:.3f}"


def _drilled(f: dict) -> str:
    """A drill's depths (mm): to the point / at full diameter (- where only the cone went in)."""
    if f["drilled_depth_mm"] is None:
        return ""
    full = f["drilled_full_depth_mm"]
    return f"{f['drilled_depth_mm']:.3f} / " + ("-" if full is None else f"{full:.3f}")


def _row(head: str, value: str) -> str:
    return f"<tr><th>{html.escape(head)}</th><td>{value}</td></tr>"


def _time(s: float) -> str:
    m, sec = divmod(s, 60.0)
    return f"{int(m)} min {sec:04.1f} s" if m >= 1 else f"{sec:.1f} s"


def _second_html(sheet: SetupSheet) -> list[str]:
    """The second set-up: programs, work zero, holding, touch-off, tool, operations, pictures."""
    e, sec = html.escape, sheet.second
    ds = dialects()
    files = [f"{sec.name}.{d.extension}" for d in ds]
    out = ["<h2>Second set-up: the back and the mount</h2>",
           f"<p>Programs: {', '.join(f'<code>{e(f)}</code>' for f in files)} ({e(', '.join(d.label for d in ds))}), run after "
           f"the part-off. Estimated cycle time <b>{_time(sec.cycle_time_s)}</b>; both set-ups "
           f"<b>{_time(sheet.total_time_s)}</b>.</p>", "<table>",
           _row("work zero", e(sec.work_zero)), _row("holding", e(sec.holding)),
           _row("grip length", f"{sec.grip_mm:.2f} mm (the least the jaws may grip: {sec.min_grip_mm:.2f} mm, "
                "toolpath.min_grip_mm and at least half the length the part stands out of the jaws)")]
    out += [_row("touch-off", e(line)) for line in sec.touch_off]
    out += ["</table>", _tool_table(sec.tools, sheet.diameter_mode),
            "<table><tr><th>operation</th><th>tool</th><th>restart at</th><th>feed mm/rev</th>"
            "<th>removed mm&sup3;</th><th>max depth of cut mm</th><th>drilled depth mm: to the point / "
            "full &Oslash;</th><th>time</th></tr>"]
    for op in sec.operations:
        f = op.figures
        out.append(f"<tr><td>{e(op.name)}</td><td>T{op.station}</td><td>N{op.restart_block}</td>"
                   f"<td class='n'>{f['feed_mm_rev']:g}</td><td class='n'>{f['removed_volume_mm3']:.0f}</td>"
                   f"<td class='n'>{_depth_of_cut(f)}</td><td class='n'>{_drilled(f)}</td>"
                   f"<td class='n'>{_time(f['cycle_time_s'])}</td></tr>")
    out.append("</table>")
    if any(op.figures["drilled_depth_mm"] is not None for op in sec.operations):
        out.append("<p>A drill's depth of cut is its radius whatever the program does (n/a): a drill is set "
                   "and checked by how deep its point goes below the face it enters and how deep the hole has "
                   "its full diameter (-: only the point's cone goes in, as a spot drill's).</p>")
    for i, op in enumerate(sec.operations):
        out.append(f"<h3>second set-up, {e(op.name)}</h3>"
                   f"{_stock_picture(sheet, op, f'second-op{i + 1}', sec.stock_start, sec.part, sec.deepest_z_mm)}")
    return out


def _stock_picture(sheet: SetupSheet, op, ident: str, stock_start=None, part=None, deepest: float | None = None) -> str:
    """SVG: the bar's section after the operation (grey), what it removed (orange), the
    designed part's outline (blue); machine (r, Z), mm. stock_start, part, deepest: the
    set-up's (default: the first set-up's, on the sheet)."""
    stock_start = sheet.stock_start if stock_start is None else stock_start
    deepest = sheet.stock["deepest_z_mm"] if deepest is None else deepest
    x0, z0, x1, z1 = stock_start.bounds
    f = op.figures
    title = (f"after {op.name}: {f['removed_volume_mm3']:.0f} mm\u00b3 removed, "
             + (f"drilled {f['drilled_depth_mm']:.2f} mm deep to the point" if f["drilled_depth_mm"] is not None
                else f"max depth of cut {f['max_depth_of_cut_mm']:.2f} mm"))
    return stock_svg(op.stock_after, op.removed, sheet.part if part is None else part,
                     (-1.0, x1 + 2.0), (max(z0, deepest - 4.0), z1 + 1.0), title, ident)
