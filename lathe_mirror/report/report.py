"""The report's page and JSON: lays out the figures the pipeline computed.

`pipeline.report_figures` runs the analysis (no files) and `report.plots.report_plots`
draws its figures; `write_report` writes report.json (every figure, ARCHITECTURE.md's
names) and report.html (self-contained: figures embedded as base64 PNG, no external URL,
opens without a network).
"""

from __future__ import annotations

import base64
import html
import math
from pathlib import Path
from typing import TYPE_CHECKING

from ..export.files import json_text, prepare_dir, write_bytes, write_text
from ..results.made import FIVE
from ..results.optics import DEPTH_REPORT_M
from .cells import fmt as _fmt
from .cells import pct as _pct
from .cells import table as _table
from .plots import report_plots
from .spec_section import spec_html
from .tolerance_section import summary_html, tolerance_html

if TYPE_CHECKING:
    from ..results.design import DesignFigures
    from ..results.made import MirrorFigures, ToolpathFigures
    from ..results.optics import CalibrationFigures, RangingFigures, StereoFigures
    from ..results.polishing import PolishingStudy
    from .analysis import ReportData


def write_report(data: ReportData, out_dir: str | Path) -> dict[str, Path]:
    """report.json and report.html (self-contained) into out_dir, atomically each."""
    data.plots = report_plots(data)  # the ones not drawn yet
    d = prepare_dir(out_dir)
    paths = {"json": d / "report.json", "html": d / "report.html"}
    write_text(paths["json"], dumps(data.figures))
    write_bytes(paths["html"], render_html(data).encode("utf-8"))
    return paths


def dumps(figures: dict) -> str:
    """The report's JSON: finite numbers only (NaN / inf -> null), stable key order."""
    return json_text(figures, indent=1)


# --------------------------------------------------------------------------------------
# HTML


def render_html(data: ReportData) -> str:
    """The self-contained page (template.html filled in; figures as data: URIs)."""
    from importlib import resources
    from string import Template

    tpl = Template((resources.files("lathe_mirror.report") / "template.html").read_text(encoding="utf-8"))

    def img(key: str, alt: str) -> str:
        if key not in data.plots:
            return f"<p class='missing'>({html.escape(alt)}: not computed)</p>"
        b64 = base64.b64encode(data.plots[key]).decode("ascii")
        return f"<img alt='{html.escape(alt)}' src='data:image/png;base64,{b64}'>"

    return tpl.substitute(
        title="lathe-mirror report",
        design_table=_design_table(data.design),
        machine_table=_kv_table({**{f"lathe.{k}": v for k, v in data.machine.lathe.items()},
                                 **{f"tool.{k}": v for k, v in data.machine.tool.to_dict().items()}}),
        toolpath_table=_toolpath_table(data.toolpaths),
        programs_table=programs_table(data.shop),
        mirrors_table=_mirrors_table(data.mirrors),
        profile_plot=img("profile_error", "height error along the meridian"),
        images=img("images", "renders side by side"),
        renders_table=(f"<p>{_defocus_text(data.renders.defocus)}</p>" + _kv_table(
            {f"{k}: {m}": v for k, d in data.renders.against_exact.items() for m, v in d.to_dict().items()}))
        if data.renders else "",
        displacement_plot=img("displacement", "image displacement against image radius"),
        polishing_section=_polishing_html(data.polishing, img),
        depth_table=_depth_table(data.stereo),
        depth_plot=img("depth_error", "depth error against range"),
        tolerance_section=tolerance_html(data.tolerance, img),
        calibration_table=_calibration_table(data.calibration, data.mirrors),
        ranging_section=_ranging_html(data.ranging, img),
        spec_section=spec_html(data.spec),
        headline=headline_html(data),
        summary=summary_html(data.tolerance),
        notes="".join(f"<li>{html.escape(n)}</li>" for n in data.notes),
    )


def headline_html(data: ReportData) -> str:
    """One sentence per headline: which part each headline figure describes (program, nose,
    polish time, calibrated or not) and at which scene range; the made mirror the other
    sections describe by default."""
    parts = []
    tol = data.tolerance
    if tol is not None:
        spec = tol.spec
        for name, t in tol.programs.items():
            mm = t.made_mirror
            parts.append(
                f"The answer's {name} program row judges {mm.label} ({mm.program} program, nose "
                f"{mm.nose_radius_mm:g} mm, polished {mm.polish_time_s / 60:g} min), "
                f"{'after calibration' if spec.calibrated else 'uncalibrated'}: its image displacement with the "
                f"scene at infinity, its disparity and depth error at {spec.depth_range_m:g} m.")
    if data.made_mirror is not None:
        parts.append(f"The other sections name the part of each figure; the made mirror by default is "
                     f"{data.made_mirror.label}, uncalibrated: image "
                     "figures with the scene at infinity, the calibration's reprojection at its stated range, "
                     "surface figures against the design.")
    return "".join(f"<p class='answer'>{html.escape(p)}</p>" for p in parts)


def _kv_table(d: dict) -> str:
    rows = "".join(f"<tr><th>{html.escape(str(k))}</th><td>{_fmt(v)}</td></tr>" for k, v in d.items())
    return f"<table>{rows}</table>"


def _design_table(d: DesignFigures) -> str:
    keys = ("r_top", "r_pixel", "f", "t_pixel", "c", "h", "a", "b", "e", "alpha_deg", "vertex_z")
    head = "<tr><th></th>" + "".join(f"<th>{lb.name}</th>" for lb in d.lobes) + "</tr>"
    label = {"c": "c = 2e (Table 1: focal distance, not a curvature)"}
    rows = "".join(f"<tr><th>{html.escape(label.get(k, k))}</th>"
                   + "".join(f"<td>{_fmt(getattr(lb, k))}</td>" for lb in d.lobes) + "</tr>" for k in keys)
    j = d.junction
    extra = (f"<p>Junction at r = {_fmt(j.r)} mm: step {_fmt(j.step_mm)} mm, {j.recessed} lobe recessed. "
             f"Stereo baseline {_fmt(d.baseline_mm)} mm; common band {_fmt(d.common_band_deg.min)} to "
             f"{_fmt(d.common_band_deg.max)} deg elevation.</p>")
    return f"<table>{head}{rows}</table>{extra}"


def _toolpath_table(rows: tuple[ToolpathFigures, ...]) -> str:
    head = ("<tr><th>strategy</th><th>points</th><th>G1</th><th>G2/G3</th>"
            "<th>lobe</th><th>programmed slope error rad (RMS / max)</th><th>programmed normal deviation mm</th>"
            "<th>as-machined slope error rad</th><th>as-machined normal deviation mm</th></tr>")
    note = ("<p>Every figure against the design (a pre-compensated program's part too: its G-code header "
            "gives it against the program's own target as well), over each whole lobe.</p>")
    body = ""
    for r in rows:
        for k in (0, 1):
            p, a = r.programmed.lobes[k], r.as_machined.lobes[k]
            name = r.strategy + (" (best)" if r.best else "")
            body += (f"<tr><td>{name if k == 0 else ''}</td><td>{r.n_points if k == 0 else ''}</td>"
                     f"<td>{r.moves.g1 if k == 0 else ''}</td><td>{r.moves.g2_g3 if k == 0 else ''}</td>"
                     f"<td>{p.name}</td><td>{_fmt(p.slope_error_rad)}</td><td>{_fmt(p.normal_deviation_mm)}</td>"
                     f"<td>{_fmt(a.slope_error_rad)}</td><td>{_fmt(a.normal_deviation_mm)}</td></tr>")
    return f"{note}<table>{head}{body}</table>"


def programs_table(programs: list | None) -> str:
    """The programs' operations against the stock, both set-ups (lathe-mirror run; see their
    set-up sheets). A drill's depth of cut is n/a (its radius whatever the program does);
    how deep it drilled is its own column (to the point / at full diameter)."""
    if not programs:
        return ""
    head = ("<tr><th>program</th><th>operation</th><th>tool</th><th>removed mm&sup3;</th>"
            "<th>max depth of cut mm</th><th>drilled depth mm: to the point / full &Oslash;</th>"
            "<th>max chip section mm&sup2;</th><th>air s</th><th>time s</th></tr>")
    body = ""
    for p in programs:
        setups = [(p["name"], p)] + ([(p["second_setup"]["name"], p["second_setup"])] if "second_setup" in p else [])
        for name, run in setups:
            for i, op in enumerate(run["operations"]):
                ap, drilled = op["max_depth_of_cut_mm"], op.get("drilled_depth_mm")
                full = op.get("drilled_full_depth_mm")
                body += (f"<tr><td>{html.escape(name) if i == 0 else ''}</td><td>{html.escape(op['name'])}</td>"
                         f"<td>T{op['tool']}</td><td>{op['removed_volume_mm3']:.0f}</td>"
                         f"<td>{'n/a' if ap is None else _fmt(ap)}</td>"
                         f"<td>{'' if drilled is None else _fmt(drilled) + ' / ' + ('-' if full is None else _fmt(full))}</td>"
                         f"<td>{_fmt(op['max_chip_section_mm2'])}</td>"
                         f"<td>{op['air_time_s']:.1f}</td><td>{op['cycle_time_s']:.1f}</td></tr>")
        both = " of both set-ups" if len(setups) > 1 else ""
        body += (f"<tr><th colspan='8'>{html.escape(p['name'])}: cycle time{both}, set-up sheet "
                 f"{html.escape(p['setup_sheet'])}; contact at rapid or with the body: "
                 f"{sum(len(run['contacts']) for _, run in setups)}</th>"
                 f"<th>{sum(run['cycle_time_s'] for _, run in setups):.1f}</th></tr>")
    return ("<p>The whole programs simulated against the stock (nose and insert body): what each "
            f"operation removes and its time (G96 with the spindle cap).</p><table>{head}{body}</table>")


def _mirrors_table(m: dict[str, MirrorFigures]) -> str:
    head = ("<tr><th>mirror</th><th>lobe</th>" + "".join(f"<th>{k} (RMS / max)</th>" for k in FIVE)
            + "<th>pixels lost: ray left the lobe's range (% of the lobe's)</th>"
            "<th>edge band: image displacement px (RMS / max), its pixels</th></tr>")
    body = ""
    for name, fig in m.items():
        for lb in fig.lobes:
            label = f"{name}<br><small>{html.escape(fig.made_mirror)}</small>" if fig.made_mirror is not None else name
            edge = "" if lb.edge is None else \
                f"{_fmt(lb.edge.image_displacement_px)}, {lb.edge.pixels} ({_fmt(lb.edge.band_mm)} mm band)"
            body += f"<tr><td>{label}</td><td>{lb.name}</td>" + "".join(
                f"<td>{_fmt(getattr(lb, k))}</td>" for k in FIVE) + \
                f"<td>{lb.pixels_left_range} ({_pct(lb.left_range_pct)} %)</td><td>{edge}</td></tr>"
    return (f"{table_note()}<table>{head}{body}</table>")


def table_note() -> str:
    """What the mirrors' optical figures are measured against, beside them."""
    return ("<p>Optical figures over each lobe's used zone: the made mirror against the exact design "
            "(image displacement: where the exact lobe images the direction the made surface sends the "
            "pixel to, minus the pixel; no calibration; scene at infinity). A pixel whose made ray the exact "
            "lobe would image outside the lobe's annulus (more than half a pixel) has left the lobe's range: "
            "counted lost, not a displacement. The edge band (polish.clear_edge_mm from the step and the rim) "
            "is also shown on its own. Normal deviation: the made surface against the exact design along its "
            "normal, over each whole lobe.</p>")


def _depth_table(st: StereoFigures) -> str:
    rows = "".join(f"<tr><th>{n}</th><td>{_fmt(v.rms)}</td><td>{_fmt(v.median)}</td>"
                   f"<td>{_fmt(v.max)}</td><td>{v.failed} of {v.points}</td></tr>"
                   for n, v in st.at.items())
    return (f"<p>{html.escape(st.definition)}; baseline {_fmt(st.baseline_mm)} mm.</p>"
            f"<table><tr><th>mirror</th><th>RMS |depth error| at {DEPTH_REPORT_M:g} m (%)</th>"
            f"<th>median (%)</th><th>max (%)</th><th>points failed (|error| &ge; 100 % or not seen)</th></tr>"
            f"{rows}</table>")


def _calibration_table(cal: CalibrationFigures | None, mirrors: dict[str, MirrorFigures] | None = None) -> str:
    """Each lobe's unified model and, per made mirror, the design model's reprojection error
    and what the refitted model leaves."""
    if not cal:
        return "<p>(calibration not computed)</p>"
    head = ("<tr><th>lobe</th><th>xi</th><th>gamma px</th><th>principal point px</th>"
            "<th>valid annulus px</th></tr>")
    rows = "".join(f"<tr><td>{lb.name}</td><td>{lb.xi:.9f}</td><td>{lb.gamma_px:.6f}</td>"
                   f"<td>({_fmt(lb.cx_px)}, {_fmt(lb.cy_px)})</td>"
                   f"<td>{_fmt(lb.annulus_px.min)} to {_fmt(lb.annulus_px.max)}</td></tr>"
                   for lb in cal.design.lobes)
    dz = cal.design.t_cn_cnm1_mm[2]
    rng = next(iter(cal.made.values())).range_m if cal.made else 0
    made_head = ("<tr><th>mirror</th><th>lobe</th><th>design model: reprojection error px (RMS / max), world "
                 f"points at {_fmt(rng)} m</th><th>the same at infinity: image displacement px (section 4)</th>"
                 "<th>refit xi, gamma px, k1, k2</th><th>refit: reprojection error px (RMS / max)</th></tr>")
    made_rows = ""
    for name, m in cal.made.items():
        for lb in m.lobes:
            r = lb.refit
            inf = "" if not mirrors or name not in mirrors else _fmt(mirrors[name].lobe(lb.name).image_displacement_px)
            made_rows += (f"<tr><td>{html.escape(name)}</td><td>{lb.name}</td>"
                          f"<td>{_fmt(lb.design.reprojection_error_px)}</td><td>{inf}</td>"
                          f"<td>{r.xi:.5g}, {r.gamma_px:.6g}, {r.k1:.3g}, {r.k2:.3g}</td>"
                          f"<td>{_fmt(r.reprojection_error_px)}</td></tr>")
    return (f"<p>{html.escape(cal.design.frame)}. The design is an exact calibration (unified "
            f"model, no distortion); the viewpoints are {_fmt(dz)} mm apart along the axis (Kalibr's "
            f"T_cn_cnm1).</p><table>{head}{rows}</table>"
            f"<p>Made mirrors (as machined, polished): world points on each traced ray {_fmt(rng)} m from "
            "the lobe's viewpoint; the refit (scipy least_squares; principal point fixed at the sensor "
            "centre) shows what a calibration of the made mirror can recover.</p>"
            f"<table>{made_head}{made_rows}</table>")


def _ranging_html(rg: RangingFigures | None, img) -> str:
    """Range from the image: each mirror's figures per range bin, the maps, error against
    range with the model, and the resolution table."""
    if not rg:
        return "<p>(ranging not computed: it renders, so --no-render skips it)</p>"
    head = ("<tr><th>mirror</th><th>ranged (% of band)</th><th>range m</th><th>pixels</th><th>ranged (%)</th>"
            "<th>median |range error| (%)</th><th>RMS (%)</th><th>signed median (%)</th>"
            "<th>model, 1 px (%)</th><th>model, matcher's precision (%)</th></tr>")
    body = ""
    for name, m in rg.mirrors.items():
        e = m.range_error_pct
        body += (f"<tr><td>{name}</td><td>{_pct(100 * m.valid_fraction)}</td><td>all</td><td>{m.pixels}</td>"
                 f"<td></td><td>{_pct(e.median)}</td><td>{_pct(e.rms)}</td><td>{_pct(e.signed_median)}</td>"
                 "<td></td><td></td></tr>")
        for b in m.bins:
            r = b.range_error_pct
            body += (f"<tr><td></td><td></td><td>{b.range_m[0]:g}-{b.range_m[1]:g}</td><td>{b.pixels}</td>"
                     f"<td>{_pct(100 * b.valid_fraction)}</td><td>{_pct(r.median)}</td><td>{_pct(r.rms)}</td>"
                     f"<td>{_pct(r.signed_median)}</td><td>{_pct(b.model_1px_pct)}</td>"
                     f"<td>{_pct(b.model_matcher_pct)}</td></tr>")
    res = rg.resolution
    els = res.elevations_deg
    rhead = ("<tr><th>range m</th>" + "".join(f"<th>1 px at {e:g} deg (%)</th>" for e in els)
             + "<th>1 px, band median (%)</th>" + "".join(f"<th>matcher at {e:g} deg (%)</th>" for e in els)
             + "<th>matcher, band median (%)</th></tr>")
    rbody = "".join(
        f"<tr><td>{row.range_m:g}</td>" + "".join(f"<td>{_pct(v)}</td>" for v in row.one_px_pct)
        + f"<td>{_pct(row.one_px_band_median_pct)}</td>"
        + "".join(f"<td>{_pct(v)}</td>" for v in row.matcher_pct or ())
        + f"<td>{_pct(math.nan if row.matcher_band_median_pct is None else row.matcher_band_median_pct)}</td></tr>"
        for row in res.rows)
    exact = rg.mirrors["exact"]
    starved = ", ".join(f"{k} {_pct(100 * v.valid_fraction)} %" for k, v in exact.valid_by_surface.items()
                        if v.pixels)
    return (f"<p>{html.escape(rg.definition)}. {_defocus_text(rg.defocus)} One pixel of disparity (one image pixel in each lobe) stands "
            f"for {exact.parallax_per_px_deg:.3f} deg of parallax (band median): R10 = "
            f"{res.r10_m:.3f} m. The matcher's precision on the exact mirror (median |disparity error|): "
            f"{rg.matcher_precision_px:.3f} panorama px of {exact.grid.elevation_step_deg:.4f} deg. Ranged on the "
            f"exact mirror by surface: {html.escape(starved)} (flat faces whose edges run along the radial epipolar "
            "lines give the matcher nothing: grey on the maps).</p>"
            f"<table>{head}{body}</table>"
            + img("range_maps", "range maps of the exact, paper, best and polished mirrors")
            + img("range_error", "range error against range with the resolution model")
            + f"<p>Resolution model: the range error one pixel of disparity causes, and the matcher's "
            f"precision, against range and elevation.</p><table>{rhead}{rbody}</table>")


def _defocus_text(d) -> str:
    """One sentence: the lens and each lobe's blur circle the images carry."""
    if d is None:
        return ""
    lobes = "; ".join(f"{lb.name} {_fmt(lb.blur_px['min'])} to {_fmt(lb.blur_px['max'])} px (mean "
                      f"{_fmt(lb.blur_px['mean'])})" for lb in d.lobes)
    return html.escape(f"The images carry the lens's defocus (thin lens f/{d.lens.f_number:g} focused at "
                       f"{d.lens.focus_mm:.1f} mm, scene {d.lens.object_range_mm / 1000.0:g} m from the "
                       f"viewpoints): blur circle diameter {lobes} over each lobe's used zone.")


def _polishing_html(p: PolishingStudy, img) -> str:
    """Section 7: the conclusion, the lap, the curves, form against facets, pre-compensation
    and the processes side by side."""
    rows = ""
    for prog, st in p.precompensation.items():
        for which, s in (("without", st.without), ("with", st.with_)):
            rows += (f"<tr><td>{html.escape(prog) if which == 'without' else ''}</td>"
                     f"<td>{_fmt(st.time_s / 60)} min</td><td>{which}</td>"
                     + "".join(f"<td>{_fmt(lb.form_change_mm.rms * 1e3)}</td>" for lb in s.lobes)
                     + f"<td>{_fmt(s.image_displacement_px_rms)}</td><td>{_fmt(s.stereo_residual_pct)}</td>"
                     f"<td>{_fmt(s.depth_error_pct)}</td></tr>")
    precomp = ("<table><tr><th>program</th><th>polished</th><th>pre-compensation</th>"
               "<th>form inner um RMS</th><th>form outer um RMS</th><th>image displacement px RMS</th>"
               "<th>calibrated stereo residual %</th><th>depth error % (design assumed)</th></tr>" + rows + "</table>")
    proc_rows = ""
    for r in p.processes:
        if r.cannot_cut is not None:
            proc_rows += (f"<tr><th>{html.escape(r.label)}</th><td>{html.escape(r.program)}</td>"
                          f"<td colspan=\"10\">cannot cut this design: {html.escape(r.cannot_cut)}</td></tr>")
            continue
        fin = r.finished
        proc_rows += (
            f"<tr><th>{html.escape(r.label)}</th><td>{html.escape(r.program)}</td>"
            f"<td>{_fmt(r.nose_radius_mm)} / {_fmt(r.feed_mm)} / {_fmt(r.resolution_mm)}</td>"
            f"<td>{_fmt(r.feed_mark_pv_nm)} nm / {_fmt(r.feed_mark_period_um)} um</td>"
            f"<td>{_fmt(r.as_turned[0].roughness_nm.rms)}</td>"
            f"<td>{_fmt(r.polish_time_s / 60)} min</td>"
            f"<td>{_fmt(fin[0].roughness_nm.rms)}</td>"
            + "".join(f"<td>{_fmt(100 * lb.haze.mean)}</td>" for lb in fin)
            + f"<td>{_fmt(r.image_displacement_px_rms)}</td><td>{_fmt(r.stereo_residual_pct)}</td>"
            f"<td>{_fmt(r.depth_error_pct)}</td></tr>")
    processes = ("<table><tr><th>process</th><th>program</th><th>nose / feed / lattice mm</th>"
                 "<th>feed marks PV / period</th><th>as turned nm RMS</th><th>polished</th>"
                 "<th>finished nm RMS</th><th>haze inner %</th><th>haze outer %</th>"
                 "<th>image displacement px RMS</th><th>calibrated stereo residual %</th>"
                 "<th>depth error % (design assumed)</th></tr>" + proc_rows + "</table>")
    rng = p.paper_program.range_m
    return (f"<p><b>{html.escape(p.conclusion)}</b></p>"
            f"<p>{html.escape(p.summary.statement)}</p><p>{html.escape(p.summary_best.statement)}</p>"
            + img("polishing_lap", "the lap's removal along r")
            + img("polishing_paper", "polishing curve, paper program")
            + img("polishing_best", "polishing curve, best program")
            + "<h3>Form against facets</h3>" + img("polishing_decomposition", "form against facets")
            + "<h3>Pre-compensation</h3><p>The finishing program cut on the design lowered by the lap's "
              "predicted removal (polish.precompensate puts it into the G-code); form over the clear aperture "
              f"(polish.clear_edge_mm = {_fmt(p.params['clear_edge_mm'])} mm from each edge).</p>" + precomp
            + f"<h3>Processes side by side</h3><p>Haze: the fraction of light scattered out of the pixel "
              f"(feed-mark orders and roughness), mean over each lobe's pixels at "
              f"{_fmt(p.params['wavelength_nm'])} nm; stereo figures at {_fmt(rng)} m.</p>" + processes)
