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
from typing import TYPE_CHECKING, Any

from ..export.files import json_text, prepare_dir, write_bytes, write_text
from ..results.base import Stat
from ..results.made import FIVE
from ..results.optics import DEPTH_REPORT_M
from ..tolerance.stats import percent_interval
from .plots import report_plots
from .spec_section import spec_html

if TYPE_CHECKING:
    from ..results.design import DesignFigures
    from ..results.made import MirrorFigures, ToolpathFigures
    from ..results.optics import CalibrationFigures, RangingFigures, StereoFigures
    from .analysis import ReportData


def write_report(data: ReportData, out_dir: str | Path) -> dict[str, Path]:
    """report.json and report.html (self-contained) into out_dir, atomically each."""
    if not data.plots:
        data.plots = report_plots(data)
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
    f = data.figures  # the sections not typed yet: polishing, tolerance

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
        programs_table=_programs_table(data.shop),
        mirrors_table=_mirrors_table(data.mirrors),
        profile_plot=img("profile_error", "height error along the meridian"),
        images=img("images", "renders side by side"),
        renders_table=_kv_table({f"{k}: {m}": v for k, d in data.renders.against_exact.items()
                                 for m, v in d.to_dict().items()}) if data.renders else "",
        displacement_plot=img("displacement", "image displacement against image radius"),
        polishing_section=_polishing_html(f["polishing"], img),
        depth_table=_depth_table(data.stereo),
        depth_plot=img("depth_error", "depth error against range"),
        tolerance_section=_tolerance_html(f, img),
        calibration_table=_calibration_table(data.calibration),
        ranging_section=_ranging_html(data.ranging, img),
        spec_section=spec_html(data.spec),
        summary=summary_html(f),
        notes="".join(f"<li>{html.escape(n)}</li>" for n in data.notes),
    )


def _fmt(v: Any) -> str:
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, float):
        if v == 0 or not math.isfinite(v):
            return str(v)
        if abs(v) < 1e-3 or abs(v) >= 1e5:
            return f"{v:.4g}"
        # below 1, significant digits (a 0.00345 mm pixel stays 0.00345, not 0.0035)
        return f"{v:.5g}" if abs(v) < 1 else f"{v:.4f}".rstrip("0").rstrip(".")
    if isinstance(v, Stat):
        return f"{_fmt(v.rms)} / {_fmt(v.max)}"
    if isinstance(v, dict) and set(v) >= {"rms", "max"}:
        return f"{_fmt(v['rms'])} / {_fmt(v['max'])}"
    return html.escape(str(v))


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
    body = ""
    for r in rows:
        for k in (0, 1):
            p, a = r.programmed.lobes[k], r.as_machined.lobes[k]
            name = r.strategy + (" (best)" if r.best else "")
            body += (f"<tr><td>{name if k == 0 else ''}</td><td>{r.n_points if k == 0 else ''}</td>"
                     f"<td>{r.moves.g1 if k == 0 else ''}</td><td>{r.moves.g2_g3 if k == 0 else ''}</td>"
                     f"<td>{p.name}</td><td>{_fmt(p.slope_error_rad)}</td><td>{_fmt(p.normal_deviation_mm)}</td>"
                     f"<td>{_fmt(a.slope_error_rad)}</td><td>{_fmt(a.normal_deviation_mm)}</td></tr>")
    return f"<table>{head}{body}</table>"


def _programs_table(programs: list | None) -> str:
    """The programs' operations against the stock (lathe-mirror run; see their set-up sheets)."""
    if not programs:
        return ""
    head = ("<tr><th>program</th><th>operation</th><th>tool</th><th>removed mm&sup3;</th>"
            "<th>max depth of cut mm</th><th>max chip section mm&sup2;</th><th>air s</th><th>time s</th></tr>")
    body = ""
    for p in programs:
        for i, op in enumerate(p["operations"]):
            body += (f"<tr><td>{html.escape(p['name']) if i == 0 else ''}</td><td>{html.escape(op['name'])}</td>"
                     f"<td>T{op['tool']}</td><td>{op['removed_volume_mm3']:.0f}</td>"
                     f"<td>{_fmt(op['max_depth_of_cut_mm'])}</td><td>{_fmt(op['max_chip_section_mm2'])}</td>"
                     f"<td>{op['air_time_s']:.1f}</td><td>{op['cycle_time_s']:.1f}</td></tr>")
        body += (f"<tr><th colspan='7'>{html.escape(p['name'])}: cycle time, set-up sheet "
                 f"{html.escape(p['setup_sheet'])}; contact at rapid or with the body: "
                 f"{len(p['contacts'])}</th><th>{p['cycle_time_s']:.1f}</th></tr>")
    return ("<p>The whole programs simulated against the stock (nose and insert body): what each "
            f"operation removes and its time (G96 with the spindle cap).</p><table>{head}{body}</table>")


def _mirrors_table(m: dict[str, MirrorFigures]) -> str:
    head = "<tr><th>mirror</th><th>lobe</th>" + "".join(f"<th>{k} (RMS / max)</th>" for k in FIVE) + "</tr>"
    body = ""
    for name, fig in m.items():
        for lb in fig.lobes:
            label = f"{name}<br><small>{html.escape(fig.made_mirror)}</small>" if fig.made_mirror is not None else name
            body += f"<tr><td>{label}</td><td>{lb.name}</td>" + "".join(
                f"<td>{_fmt(getattr(lb, k))}</td>" for k in FIVE) + "</tr>"
    return f"<table>{head}{body}</table>"


def _depth_table(st: StereoFigures) -> str:
    rows = "".join(f"<tr><th>{n}</th><td>{_fmt(v.rms)}</td><td>{_fmt(v.median)}</td>"
                   f"<td>{_fmt(v.max)}</td><td>{v.failed} of {v.points}</td></tr>"
                   for n, v in st.at.items())
    return (f"<p>{html.escape(st.definition)}; baseline {_fmt(st.baseline_mm)} mm.</p>"
            f"<table><tr><th>mirror</th><th>RMS |depth error| at {DEPTH_REPORT_M:g} m (%)</th>"
            f"<th>median (%)</th><th>max (%)</th><th>points failed (|error| &ge; 100 % or not seen)</th></tr>"
            f"{rows}</table>")


def _calibration_table(cal: CalibrationFigures | None) -> str:
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
    made_head = ("<tr><th>mirror</th><th>lobe</th><th>design model: reprojection error px (RMS / max)</th>"
                 "<th>refit xi, gamma px, k1, k2</th><th>refit: reprojection error px (RMS / max)</th></tr>")
    made_rows = ""
    for name, m in cal.made.items():
        for lb in m.lobes:
            r = lb.refit
            made_rows += (f"<tr><td>{html.escape(name)}</td><td>{lb.name}</td>"
                          f"<td>{_fmt(lb.design.reprojection_error_px)}</td>"
                          f"<td>{r.xi:.5g}, {r.gamma_px:.6g}, {r.k1:.3g}, {r.k2:.3g}</td>"
                          f"<td>{_fmt(r.reprojection_error_px)}</td></tr>")
    rng = next(iter(cal.made.values())).range_m if cal.made else 0
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
    return (f"<p>{html.escape(rg.definition)}. One pixel of disparity (one image pixel in each lobe) stands "
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


def _pct(v: float) -> str:
    """A percentage (or any figure read to two decimals); n/a where not finite."""
    return f"{v:.2f}" if isinstance(v, (int, float)) and math.isfinite(v) else "n/a"

def _polishing_html(p: dict, img) -> str:
    """Section 7: the conclusion, the lap, the curves, form against facets, pre-compensation
    and the processes side by side."""
    pc = p["precompensation"]
    rows = ""
    for prog, st in pc.items():
        for which in ("without", "with"):
            s = st[which]
            rows += (f"<tr><td>{html.escape(prog) if which == 'without' else ''}</td>"
                     f"<td>{_fmt(st['time_s'] / 60)} min</td><td>{which}</td>"
                     + "".join(f"<td>{_fmt(lb['form_change_mm']['rms'] * 1e3)}</td>" for lb in s["lobes"])
                     + f"<td>{_fmt(s['image_displacement_px_rms'])}</td><td>{_fmt(s['stereo_residual_pct'])}</td>"
                     f"<td>{_fmt(s['depth_error_pct'])}</td></tr>")
    precomp = ("<table><tr><th>program</th><th>polished</th><th>pre-compensation</th>"
               "<th>form inner um RMS</th><th>form outer um RMS</th><th>image displacement px RMS</th>"
               "<th>calibrated stereo residual %</th><th>depth error % (design assumed)</th></tr>" + rows + "</table>")
    proc_rows = ""
    for r in p["processes"]:
        if "cannot_cut" in r:
            proc_rows += (f"<tr><th>{html.escape(r['label'])}</th><td>{html.escape(r['program'])}</td>"
                          f"<td colspan=\"10\">cannot cut this design: {html.escape(r['cannot_cut'])}</td></tr>")
            continue
        fin = r["finished"]
        proc_rows += (
            f"<tr><th>{html.escape(r['label'])}</th><td>{html.escape(r['program'])}</td>"
            f"<td>{_fmt(r['nose_radius_mm'])} / {_fmt(r['feed_mm'])} / {_fmt(r['resolution_mm'])}</td>"
            f"<td>{_fmt(r['feed_mark_pv_nm'])} nm / {_fmt(r['feed_mark_period_um'])} um</td>"
            f"<td>{_fmt(r['as_turned'][0]['roughness_nm']['rms'])}</td>"
            f"<td>{_fmt(r['polish_time_s'] / 60)} min</td>"
            f"<td>{_fmt(fin[0]['roughness_nm']['rms'])}</td>"
            + "".join(f"<td>{_fmt(100 * lb['haze']['mean'])}</td>" for lb in fin)
            + f"<td>{_fmt(r['image_displacement_px_rms'])}</td><td>{_fmt(r['stereo_residual_pct'])}</td>"
            f"<td>{_fmt(r['depth_error_pct'])}</td></tr>")
    processes = ("<table><tr><th>process</th><th>program</th><th>nose / feed / lattice mm</th>"
                 "<th>feed marks PV / period</th><th>as turned nm RMS</th><th>polished</th>"
                 "<th>finished nm RMS</th><th>haze inner %</th><th>haze outer %</th>"
                 "<th>image displacement px RMS</th><th>calibrated stereo residual %</th>"
                 "<th>depth error % (design assumed)</th></tr>" + proc_rows + "</table>")
    rng = p["paper_program"].get("range_m", 2.0)
    return (f"<p><b>{html.escape(p['conclusion'])}</b></p>"
            f"<p>{html.escape(p['summary']['statement'])}</p><p>{html.escape(p['summary_best']['statement'])}</p>"
            + img("polishing_lap", "the lap's removal along r")
            + img("polishing_paper", "polishing curve, paper program")
            + img("polishing_best", "polishing curve, best program")
            + "<h3>Form against facets</h3>" + img("polishing_decomposition", "form against facets")
            + "<h3>Pre-compensation</h3><p>The finishing program cut on the design lowered by the lap's "
              "predicted removal (polish.precompensate puts it into the G-code); form over the clear aperture "
              f"(polish.clear_edge_mm = {_fmt(p['params']['clear_edge_mm'])} mm from each edge).</p>" + precomp
            + f"<h3>Processes side by side</h3><p>Haze: the fraction of light scattered out of the pixel "
              f"(feed-mark orders and roughness), mean over each lobe's pixels at "
              f"{_fmt(p['params']['wavelength_nm'])} nm; stereo figures at {_fmt(rng)} m.</p>" + processes)


def _tolerance_html(f: dict, img) -> str:
    if "tolerance" not in f:
        return "<p>(tolerance analysis not run)</p>"

    tol = f["tolerance"]
    spec = tol["spec"]
    which = "after calibration" if spec["calibrated"] else "raw (against the design's own model)"
    first = next(iter(tol["programs"].values()), None)
    lim = first["limits"] if first else {}
    spec_rows = [
        ("image displacement", f"RMS over each lobe's pixels but its outliers, {which}",
         f"{_fmt(spec['image_displacement_px'])} px"),
        ("outlier pixels", f"share of each lobe's pixels displaced more than 5 x the image limit, {which}",
         f"{_fmt(spec['outlier_pct'])} %"),
        ("stereo", f"90th percentile over the common band at {_fmt(spec['depth_range_m'])} m of the "
                   f"disparity-equivalent error, {which}",
         f"{_fmt(lim.get('disparity_px', float('nan')))} px (= {_fmt(spec['depth_error_pct'])} % depth error)"),
        ("slope error", "RMS over the radii each lobe's image uses", f"{_fmt(spec['slope_error_rad'])} rad"),
    ]
    parts = ["<h3>Spec</h3>" + _table(("criterion", "figure judged", "limit"), spec_rows),
             f"<p>Calibrated: a calibration of the made camera fits its rotation and a smooth radial mapping of "
             f"each lobe (tolerance/calibration.py); the figures judged are what it cannot remove. "
             f"Disparity-equivalent error: the stereo parallax error in pixels of image position in each lobe "
             f"(the matcher's unit); {_fmt(spec['depth_error_pct'])} % at {_fmt(spec['depth_range_m'])} m is "
             f"{_fmt(lim.get('disparity_px', float('nan')))} px at the band's median elevation.</p>"]
    cost = tol.get("cost", {})
    trows = [(k, _fmt(v), ("3-sigma bound" if tol["distribution"] == "normal" else "+/- bound"), _fmt(cost.get(k, "")))
             for k, v in tol["tolerances"].items()]
    parts.append("<h3>Tolerances</h3>" + _table(("parameter", "tolerance", "read as", "relative cost"), trows)
                 + f"<p>{tol['trials']} trials per Monte Carlo, seed {tol['seed']}; {tol['lattice_phases']} lattice "
                 f"phases drawn uniformly; each trial's nose cut as drawn (to {_fmt(tol['nose_step_mm'])} mm); "
                 f"the seat tilts about a point {_fmt(tol['seat_pivot_mm'])} mm above the pinhole.</p>")
    for name, t in tol["programs"].items():
        v, mc = t["verdict"], t["monte_carlo"]
        checks = [(k, _fmt(c["limit"]), _fmt(c["nominal"]), _verdict_cell(c["pass"]),
                   f"{100 * mc['pass_fraction'][k]:.1f} % ({100 * mc['pass_fraction_wilson95'][k][0]:.1f}-"
                   f"{100 * mc['pass_fraction_wilson95'][k][1]:.1f} %)") for k, c in v["checks"].items()]
        block = [f"<h3>{html.escape(name)} program</h3>",
                 f"<p class='yield'>Yield <b>{percent_interval(mc['passed'], mc['trials'])}</b>; "
                 f"nominal part {'passes' if v['nominal_pass'] else 'fails'}.</p>"]
        if "allocation" in t:
            block.append(f"<p class='answer'>{html.escape(t['allocation']['statement'])}</p>")
        block.append(f"<p>Surfaces: {html.escape(t['surfaces'])}; polished {_fmt(t['nominal_polish_time_s'] / 60)} "
                     f"min nominal.</p>")
        block.append(_table(("criterion", "limit", "nominal part", "", "trials passing (95 % CI)"), checks, raw=True))
        if "allocation" in t:
            block.append(_allocation_html(t["allocation"]))
        block.append(img(f"monte_carlo_{name}", f"Monte Carlo histograms, {name} program"))
        block.append(_stereo_html(t["stereo"], spec))
        block.append(_sensitivity_html(t["sensitivity"]))
        inv = [(r["parameter"], f"{_fmt(r['tolerance'])} {r['unit']}",
                "none: " + r["no_margin_why"] if r["no_margin"] else
                f"{_fmt(r['largest'])} {r['unit']}" + ("" if r["limited_by"] else " or more"),
                r["limited_by"] or "-") for r in t["inverse_sensitivity"]]
        block.append("<p>Inverse sensitivity: the largest +/- value of each parameter that alone keeps every "
                     "criterion within its share of the margin (limit&sup2; - worst phase&sup2;, split evenly among "
                     "the parameters).</p>"
                     + _table(("parameter", "tolerance", "largest alone", "set by"), inv))
        parts.append("".join(block))
    return "".join(parts)


def summary_html(f: dict) -> str:
    """The answer first: per toleranced program the verdict, the headline figures, the
    yield with its Wilson interval and what to tighten."""
    if "tolerance" not in f:
        return ""

    rows = []
    spec = f["tolerance"]["spec"]
    for name, t in f["tolerance"]["programs"].items():
        v, mc = t["verdict"], t["monte_carlo"]
        c = v["checks"]
        st = t["stereo"]
        i = st["ranges_m"].index(spec["depth_range_m"]) if spec["depth_range_m"] in st["ranges_m"] else None
        label = "calibrated" if spec["calibrated"] else "raw"
        within = f"; {100 * st[label]['within_10_pct'][i]:.0f} % of the band within 10 %" if i is not None else ""
        head = (f"image displacement {_fmt(c['image_displacement_px']['nominal'])} px RMS; disparity "
                f"{_fmt(c['disparity_px']['nominal'])} px (90 % of the band) at {_fmt(spec['depth_range_m'])} m"
                f"{within}; slope error {_fmt(c['slope_error_rad']['nominal'])} rad")
        todo = t["allocation"]["statement"] if "allocation" in t else "(no allocation run for this program)"
        rows.append((f"{name} program", _verdict_cell(v["nominal_pass"]), html.escape(head),
                     percent_interval(mc["passed"], mc["trials"]), html.escape(todo)))
    return ("<div class='summary'><h2>The answer</h2>"
            + _table(("", "nominal part", f"headline figures ({'after calibration' if spec['calibrated'] else 'raw'})",
                      "Monte Carlo yield (95 % CI)", f"to reach {100 * f['tolerance']['target_yield']:g} %"),
                     rows, raw=True) + "</div>")


def _verdict_cell(ok: bool) -> str:
    return f"<span class='{'pass' if ok else 'fail'}'>{'PASS' if ok else 'FAIL'}</span>"


def _table(head, rows, *, raw: bool = False) -> str:
    """An HTML table; cells are escaped unless raw (already HTML)."""
    h = "".join(f"<th>{html.escape(str(x))}</th>" for x in head)
    body = "".join("<tr>" + "".join(f"<td>{x if raw else html.escape(str(x))}</td>" for x in r) + "</tr>"
                   for r in rows)
    return f"<table><tr>{h}</tr>{body}</table>"


def _allocation_html(a: dict) -> str:
    rows = [(r["parameter"], f"{_fmt(r['tolerance'])} {r['unit']}", f"{_fmt(r['allocated'])} {r['unit']}",
             "tighten" if r["tighten"] else "keep", _fmt(r["cost"])) for r in a["tolerances"]]
    rounds = [(h["round"], f"{100 * h['aim']:.1f} %", f"{100 * h['surrogate_yield']:.1f} %",
               f"{100 * h['yield']:.1f} % ({100 * h['yield_wilson95'][0]:.1f}-{100 * h['yield_wilson95'][1]:.1f} %)",
               h["seed"]) for h in a["rounds"]]
    sur = a["surrogate"]
    out = (f"<p>Allocation to {100 * a['target_yield']:g} % at least cost (relative cost "
           f"{_fmt(a['cost_ratio'])} x the configured tolerances'):</p>"
           + _table(("parameter", "configured", "allocated", "", "relative cost"), rows))
    if rounds:
        out += _table(("round", "surrogate aim", "surrogate yield", f"confirmed yield, {a['trials']} trials (95 % CI)",
                       "seed"), rounds)
    out += (f"<p>Surrogate (each parameter's response alone, added in squares; {sur['draws']} draws): "
            f"{100 * sur['yield_on_monte_carlo_trials']:.1f} % on the Monte Carlo's own trials against their traced "
            f"{100 * sur['monte_carlo_yield']:.1f} %; it agrees with the traced pass / fail on "
            f"{100 * sur['agreement']:.1f} % of them.</p>")
    return out


def _stereo_html(st: dict, spec: dict) -> str:
    rows = []
    for i, r in enumerate(st["ranges_m"]):
        row = [_fmt(r)]
        for label in ("raw", "calibrated"):
            d = st[label]
            row += [_fmt(d["disparity_px_median"][i]), _fmt(d["disparity_px_p90"][i]),
                    f"{100 * d['within_5_pct'][i]:.0f} %", f"{100 * d['within_10_pct'][i]:.0f} %",
                    f"{100 * d['seen_fraction'][i]:.0f} %", _fmt(d["depth_error_pct_rms"][i])]
        row.append(_fmt(st["matching_floor_pct"][i]))
        rows.append(row)
    head = ["range (m)"]
    for label in ("raw", "calibrated"):
        head += [f"{label}: disparity median (px)", "p90 (px)", "within 5 %", "within 10 %", "seen",
                 "capped RMS depth error (%)"]
    head.append(f"matching floor, {_fmt(st['matching_noise_px'])} px (%)")
    return ("<p>Stereo figures of the nominal part (the band's points at each range; disparity limit "
            f"{_fmt(st['disparity_limit_px'])} px):</p>" + _table(head, rows))


def _sensitivity_html(sens: dict) -> str:
    rows = []
    for r in sens["rows"]:
        for which in ("minus", "plus"):
            c = r[which]
            first = which == "minus"
            rows.append([r["parameter"] if first else "", (f"{_fmt(r['tolerance'])} {r['unit']}") if first else "",
                         which]
                        + [_fmt(x) for x in c["raw"]["image_displacement_px_rms"]]
                        + [_fmt(x) for x in c["calibrated"]["image_displacement_px_rms"]]
                        + [_fmt(c["raw"]["disparity_px_p90"]), _fmt(c["calibrated"]["disparity_px_p90"]),
                           _fmt(c["raw"]["depth_error_pct_rms"]), _fmt(c["calibrated"]["depth_error_pct_rms"])]
                        + [_fmt(x) for x in c["slope_error_rad_rms"]] + [_verdict_cell(c["pass"])])
    head = ("parameter", "tolerance", "", "raw disp. inner px", "raw disp. outer px", "cal. disp. inner px",
            "cal. disp. outer px", "raw disparity p90 px", "cal. disparity p90 px", "raw depth err %",
            "cal. depth err %", "slope inner rad", "slope outer rad", "spec")
    return ("<p>Sensitivity: each parameter at -/+ its tolerance, the others nominal.</p>"
            + _table(head, [[x if i == len(r) - 1 else html.escape(str(x)) for i, x in enumerate(r)] for r in rows],
                     raw=True))
