"""The report: every stage's figures on one configuration, as JSON and one HTML page.

`compute` runs the analysis (no files): design, the toolpath of each strategy and its
as-machined surface, the distortion each made mirror causes, the polishing curve and the
polished mirror, stereo depth error against range, renders side by side, the tolerance
Monte Carlo and sensitivity table, and the verdict against the spec. `write_report`
writes report.json (every figure, ARCHITECTURE.md's names) and report.html (self-
contained: figures embedded as base64 PNG, no external URL, opens without a network).

Millimetres and radians inside; the JSON and the page carry the edge units in the names.
"""

from __future__ import annotations

import base64
import html
import json
import math
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..progress import Stages

#: Ranges (m) of the depth-error curve (the issue: 0.5 m to 5 m).
DEPTH_RANGES_M = (0.5, 0.75, 1.0, 1.5, 2.0, 3.0, 4.0, 5.0)
#: The range (m) at which the report states the depth error of every mirror.
DEPTH_REPORT_M = 2.0
#: The mirrors compared throughout, in order.
MIRRORS = ("exact", "paper", "best", "polished")


#: What a reader needs to know to read the figures right.
NOTES = (
    "Optical figures count, per lobe, the pixel centres whose exact and made rays land on the "
    "lobe and leave it unobstructed; on this design the step wall vignettes the inner lobe's "
    "reflected rays beyond r = {r_used:.2f} mm (image radius {rho_used:.0f} px), so those pixels show the wall, "
    "not the world, and are left out (each lobe's usable annulus, as optics.distortion counts it; "
    "its per-pixel figures, with those pixels counted too under with_vignetted, are kept "
    "alongside under optics_distortion).",
    "Slope error in the tolerance spec and on the polishing curve is over the radii the image "
    "uses (the inner lobe up to the vignetting radius, where the tool's corner fillet also lies); "
    "the toolpath tables give it over whole lobes (toolpath.profile_errors).",
    "Depth error: a point at range R from the stereo centre is imaged at the exact design's pixel "
    "by each lobe; the made mirror's rays through those two pixels are crossed; error = 100 "
    "(R_made - R) / R. With a {baseline:.1f} mm baseline the two rays meet at only {angle_2m:.2f} deg at 2 m "
    "(the parallax gamma), and a difference delta between the two lobes' ray errors gives "
    "R_made / R = gamma / (gamma - delta): where delta nears gamma the rays turn parallel and the error "
    "diverges, past it they cross behind. So each point's |error| is capped at 100 % (no usable depth, "
    "like a point one lobe does not see; 'failed' counts them) before the RMS over the band: uncapped, "
    "the RMS of a mirror whose delta crosses gamma in the band grows without bound as the band is "
    "sampled more finely (it is set by whichever sample falls nearest the pole), while the capped RMS "
    "and the median converge. This is why polishing the paper program's mirror, which cuts its ray "
    "deviation about tenfold, can still leave many points failed: its low-order form change bends the "
    "two lobes' rays by a few tenths of a degree, the size of the parallax itself.",
    "Polishing: removal k_p p omega r grows from nothing at the vertex, so facets near the "
    "axis outlast those at the rim; the band at the foot of the step (polish.corner_mm) is "
    "out of the pad's reach and stays as machined.",
    "Monte Carlo: machined surfaces are precomputed at tolerance.lattice_phases lattice phases "
    "(the Z work zero's offset on the controller's lattice) x 5 nose radii, each polished once "
    "with snapshots at 5 times; a trial interpolates linearly between them, shifts the surface "
    "by the tool setting errors, and is traced in 3-D through its misaligned camera on a sparse "
    "pixel sample (tolerance.bin_px image-radius bins x tolerance.azimuths azimuths, weighted "
    "by pixel counts).",
)


@dataclass
class ReportData:
    """What the report shows: JSON-ready figures, plots (PNG bytes) and renders (arrays)."""

    figures: dict[str, Any]
    plots: dict[str, bytes] = field(default_factory=dict)
    images: dict[str, np.ndarray] = field(default_factory=dict)


STAGES = ["design", "toolpaths", "polishing", "distortion", "stereo", "renders", "tolerance", "plots"]


def compute(cfg: dict, *, progress: bool = False, renders: bool = True, tolerance: bool = True) -> ReportData:
    """Run every analysis stage on a validated configuration."""
    from ..design import TABLE1_SWAP_NOTE, design_figures, mirror_from_config
    from ..polishing import polish_curve, polish_params_from_config
    from ..profile import ExactProfile

    steps = Stages(STAGES, progress)
    out: dict[str, Any] = {"schema": "lathe-mirror report 1", "notes": []}
    # ---- design
    steps.start("design")
    mirror = mirror_from_config(cfg)
    out["design"] = design_figures(mirror)
    from ..optics.radial import corner_limit_px, used_extent

    r_used = used_extent(mirror, 0)[1]
    facts = {"r_used": r_used, "rho_used": corner_limit_px(mirror, mirror.r_junction - r_used),
             "baseline": mirror.baseline, "angle_2m": math.degrees(mirror.baseline / 2000.0)}
    out["notes"] += [TABLE1_SWAP_NOTE, *(n.format(**facts) for n in NOTES)]
    steps.done()
    # ---- toolpaths and as-machined surfaces
    steps.start("toolpaths")
    made, out["machine"], out["toolpaths"] = _toolpaths(mirror, cfg)
    steps.done()
    # ---- polishing (the paper's proposal: polish the 528-point mirror) and distortion
    steps.start("polishing")
    params = polish_params_from_config(cfg)
    curve_paper = polish_curve(made["paper"], mirror, params, progress=progress)
    curve_best = polish_curve(made["best"], mirror, params, progress=progress)
    made["polished"] = curve_paper.profiles[curve_paper.optimum_index]
    out["polishing"] = {
        "params": {k: v for k, v in params.__dict__.items()},
        "model": "Preston's law, dh/dt = k_p p v, v = omega r, compliant pad p = p0 max(0, 1 + d / l_c)",
        "paper_program": curve_paper.to_dict(),
        "best_program": curve_best.to_dict(),
    }
    out["polishing"]["summary"] = polish_summary(curve_paper, "paper")
    out["polishing"]["summary_best"] = polish_summary(curve_best, "best")
    steps.done()
    steps.start("distortion")
    made["exact"] = ExactProfile(mirror)
    out["mirrors"] = {name: _mirror_figures(made[name], mirror) for name in MIRRORS}
    out["mirrors"]["polished"]["polish_time_s"] = curve_paper.optimum_time_s
    steps.done()
    # ---- stereo
    steps.start("stereo")
    from ..optics.stereo import depth_error_curve

    depth = {name: depth_error_curve(made[name], mirror, DEPTH_RANGES_M) for name in MIRRORS}
    out["stereo"] = {
        "definition": "depth error = 100 (R_made - R) / R, R from the stereo centre (midway between "
                      "the viewpoints), points across the common band; RMS, median and max over the band "
                      "of |depth error| capped at 100 % per point (a point not seen by both lobes counts "
                      "100 %); failed: points at the cap",
        "baseline_mm": mirror.baseline,
        "curves": {name: c.to_dict() for name, c in depth.items()},
        f"at_{DEPTH_REPORT_M:g}_m": {name: c.at(DEPTH_REPORT_M) for name, c in depth.items()},
    }
    steps.done()
    # ---- renders
    data = ReportData(out)
    steps.start("renders")
    if renders:
        data.images, out["renders"] = _renders(made, mirror, cfg)
    steps.done()
    # ---- tolerance
    steps.start("tolerance")
    if tolerance:
        out["tolerance"] = _tolerance(mirror, cfg, params, curve_paper, curve_best, progress)
        out["verdict"] = {name: t["verdict"] for name, t in out["tolerance"]["programs"].items()}
    steps.done()
    # ---- plots
    steps.start("plots")
    data.plots = _plots(out, made, mirror, data.images)
    steps.done()
    steps.close()
    return data


def write_report(data: ReportData, out_dir: str | Path) -> dict[str, Path]:
    """report.json and report.html (self-contained) into out_dir, atomically each."""
    from ..export.files import prepare_dir, write_bytes, write_text

    d = prepare_dir(out_dir)
    paths = {"json": d / "report.json", "html": d / "report.html"}
    write_text(paths["json"], dumps(data.figures))
    write_bytes(paths["html"], render_html(data).encode("utf-8"))
    return paths


def dumps(figures: dict) -> str:
    """The report's JSON: finite numbers only (NaN / inf -> null), stable key order."""
    from ..export.files import json_text

    return json_text(figures, indent=1)


# --------------------------------------------------------------------------------------
# Stages


def _toolpaths(mirror, cfg: dict):
    """As-machined profile per strategy; machine/tool table; toolpath figures per strategy."""
    from ..lathe import lathe_from_config, tool_from_config
    from ..nose_envelope import as_machined, contour_profile
    from ..toolpath import BEST, Strategy, plan_toolpath, profile_errors

    lathe, tool = lathe_from_config(cfg), tool_from_config(cfg)
    machine = {"lathe": {k: v for k, v in lathe.__dict__.items()},
               "tool": {"nose_radius": tool.nose_radius,
                        "included_angle_deg": math.degrees(tool.included_angle),
                        "approach_angle_deg": math.degrees(tool.approach_angle)}}
    made, table = {}, []
    for strategy in Strategy:
        tp = plan_toolpath(mirror, lathe, tool, strategy)
        prof = as_machined(tp)
        row = {"strategy": strategy.value, "best": strategy is BEST, "n_points": int(tp.n_points),
               "moves": {"G1": sum(1 for s in tp.segments if type(s).__name__ == "Line"),
                         "G2/G3": sum(1 for s in tp.segments if type(s).__name__ == "Arc")},
               "programmed": profile_errors(contour_profile(tp), mirror),
               "as_machined": profile_errors(prof, mirror)}
        table.append(row)
        if strategy is Strategy.PAPER:
            made["paper"] = prof
        if strategy is BEST:
            made["best"] = prof
    return made, machine, table


def _mirror_figures(profile, mirror) -> dict:
    """The five figures per lobe (ARCHITECTURE.md), surface and optics.

    Surface figures: toolpath.profile_errors (issue 3). Optical figures: over the pixels
    each lobe images unobstructed on the exact design (optics.radial: every pixel
    centre, aligned camera; equal to optics.distortion's per-pixel figures over the usable
    annulus, which the tests check); those per-pixel figures (with the pixels the step wall
    vignettes counted too under "with_vignetted") are kept alongside under "optics_distortion".
    """
    from ..optics.distortion import distortion_figures
    from ..optics.radial import radial_figures
    from ..toolpath import profile_errors

    surf = profile_errors(profile, mirror)
    rad = radial_figures(profile, mirror)
    full = distortion_figures(profile, mirror)
    lobes = []
    for s, o, f in zip(surf["lobes"], rad["lobes"], full["lobes"]):
        lobes.append({"name": s["name"], "slope_error_rad": s["slope_error_rad"],
                      "normal_deviation_mm": s["normal_deviation_mm"],
                      "ray_deviation_deg": o["ray_deviation_deg"],
                      "image_displacement_px": o["image_displacement_px"],
                      "viewpoint_spread_mm": o["viewpoint_spread_mm"],
                      "pixels": o["pixels"], "pixels_excluded": o["pixels_excluded"],
                      "optics_distortion": f})
    return {"lobes": lobes}


def polish_summary(curve, program: str) -> dict:
    """The optimum of a polishing curve (s), the image displacement before and at it (px RMS,
    both lobes), the form it costs per lobe (mm) and a sentence stating them (min, um)."""
    i = curve.optimum_index
    d = curve.to_dict()["optimum"]
    form = [lb["form_change_mm"] for lb in d["lobes"]]
    return {
        "program": program,
        "optimum_time_s": curve.optimum_time_s,
        "optimum_inside_range": curve.optimum_inside,
        "range_s": [float(curve.times_s[0]), float(curve.times_s[-1])],
        "image_displacement_px_rms": {"before": float(curve.combined_displacement_px[0]),
                                      "at_optimum": float(curve.combined_displacement_px[i])},
        "form_cost_mm": {lb["name"]: f for lb, f in zip(d["lobes"], form)},
        "statement": (
            f"The {program} program's mirror is best left unpolished: its image displacement, "
            f"{curve.combined_displacement_px[0]:.2f} px RMS over both lobes as machined, only grows with "
            f"polishing (to {curve.combined_displacement_px[-1]:.2f} px after "
            f"{curve.times_s[-1] / 60:.0f} min) as the lap's form change outweighs what it smooths."
        ) if i == 0 else (
            f"Polishing the {program} program's mirror for {curve.optimum_time_s / 60:.0f} min minimises the "
            f"image displacement (RMS over both lobes {curve.combined_displacement_px[0]:.2f} -> "
            f"{curve.combined_displacement_px[i]:.2f} px); it costs a form change of "
            f"{form[0]['rms'] * 1e3:.1f} um RMS ({form[0]['max'] * 1e3:.1f} um max) on the inner lobe and "
            f"{form[1]['rms'] * 1e3:.1f} um RMS ({form[1]['max'] * 1e3:.1f} um max) on the outer lobe."
            + ("" if curve.optimum_inside else
               " The optimum lies at the end of the explored range: widen polish.curve_max_s.")),
    }


def _renders(made: dict, mirror, cfg: dict):
    """Each mirror's image of the paper's room, and each made image's difference to the exact."""
    from ..optics.render import image_difference, render_image
    from ..optics.scene import scene_from_config

    scene = scene_from_config(cfg, mirror_top=float(mirror.outer.z(mirror.r_max)), mirror_radius=mirror.r_max)
    images = {name: render_image(made[name], mirror, scene) for name in MIRRORS}
    stats = {name: image_difference(images[name], images["exact"]) for name in MIRRORS if name != "exact"}
    return images, {"against_exact": stats}


def _tolerance(mirror, cfg, params, curve_paper, curve_best, progress: bool) -> dict:
    """Monte Carlo and sensitivity for each toleranced program; the verdict of each."""
    from ..tolerance.montecarlo import prepare, run_monte_carlo
    from ..tolerance.sensitivity import resolution_row, sensitivity_table
    from ..tolerance.spec import Program, settings_from_config

    settings = settings_from_config(cfg)
    out = {"spec": settings.spec.__dict__, "distribution": settings.distribution.value,
           "tolerances": settings.tolerances, "seed": settings.seed, "programs": {}}
    for program in settings.programs:
        curve = curve_best if program is Program.BEST else curve_paper
        ctx = prepare(mirror, cfg, settings, params, curve.optimum_time_s, program, progress=progress)
        mc = run_monte_carlo(ctx, progress=progress)
        sens = sensitivity_table(ctx, progress=progress)
        row = resolution_row(ctx, cfg, params)
        if row is not None:
            sens["rows"].insert(0, row)
        entry = {"surfaces": ctx.source, "nominal_polish_time_s": ctx.nominal_time_s,
                 "monte_carlo": mc.to_dict(), "sensitivity": sens}
        entry["verdict"] = _verdict(entry, settings.spec.__dict__)
        out["programs"][program.value] = entry
    return out


def _verdict(t: dict, spec: dict) -> dict:
    nominal = t["sensitivity"]["nominal"]
    checks = {
        "image_displacement_px": {"limit": spec["image_displacement_px"],
                                  "nominal": max(nominal["image_displacement_px_rms"])},
        "depth_error_pct": {"limit": spec["depth_error_pct"], "nominal": nominal["depth_error_pct_rms"],
                            "range_m": spec["depth_range_m"]},
        "slope_error_rad": {"limit": spec["slope_error_rad"], "nominal": max(nominal["slope_error_rad_rms"])},
    }
    for c in checks.values():
        c["pass"] = bool(c["nominal"] <= c["limit"])
    return {"checks": checks, "nominal_pass": all(c["pass"] for c in checks.values()),
            "yield": t["monte_carlo"]["yield"], "trials": t["monte_carlo"]["trials"]}


def _plots(out: dict, made: dict, mirror, images: dict) -> dict[str, bytes]:
    from ..optics.radial import lobe_pixel_radii, radial_displacement
    from . import plots as F

    plots = {}
    r = np.concatenate([np.linspace(0.0, mirror.r_junction, 4001),
                        np.linspace(np.nextafter(mirror.r_junction, 99.0), mirror.r_max, 3001)])
    exact_z = made["exact"].z(r)
    from ..optics.radial import used_extent

    used = (r <= used_extent(mirror, 0)[1]) | (r > mirror.r_junction)
    plots["profile_error"] = F.profile_deviation_plot(
        {n: (r, made[n].z(r) - exact_z) for n in ("paper", "best", "polished")}, mirror.r_junction, used)
    curves = {}
    for name in ("paper", "best", "polished"):
        rho, d = [], []
        for k in (0, 1):
            px = lobe_pixel_radii(mirror, k, bin_px=0.25)
            # NaN where radii are missing (vignetted, the lost ring): the line breaks there.
            gap = np.concatenate([[False], np.diff(px.radius_px) > 1.0])
            r_k = np.insert(px.radius_px, np.flatnonzero(gap), np.nan)
            d_k = np.insert(radial_displacement(made[name], mirror, k, px.radius_px), np.flatnonzero(gap), np.nan)
            rho += [r_k, [np.nan]]
            d += [d_k, [np.nan]]
        curves[name] = (np.concatenate(rho), np.concatenate(d))
    plots["displacement"] = F.displacement_plot(curves, tuple(mirror.image_radii_px["lost_ring"]))
    plots["polishing_paper"] = F.polishing_curve_plot(out["polishing"]["paper_program"],
                                                      "polishing the paper program's mirror")
    plots["polishing_best"] = F.polishing_curve_plot(out["polishing"]["best_program"],
                                                     "polishing the best program's mirror")
    plots["depth_error"] = F.depth_error_plot(out["stereo"]["curves"])
    if images:
        plots["images"] = F.images_side_by_side(images)
    for name, t in out.get("tolerance", {}).get("programs", {}).items():
        mc = t["monte_carlo"]
        plots[f"monte_carlo_{name}"] = F.monte_carlo_histograms(mc["per_trial"], mc["spec"], mc["yield"],
                                                                title=f"{name} program")
    return plots


# --------------------------------------------------------------------------------------
# HTML


def render_html(data: ReportData) -> str:
    """The self-contained page (template.html filled in; figures as data: URIs)."""
    from importlib import resources
    from string import Template

    tpl = Template((resources.files("lathe_mirror.report") / "template.html").read_text(encoding="utf-8"))
    f = data.figures

    def img(key: str, alt: str) -> str:
        if key not in data.plots:
            return f"<p class='missing'>({html.escape(alt)}: not computed)</p>"
        b64 = base64.b64encode(data.plots[key]).decode("ascii")
        return f"<img alt='{html.escape(alt)}' src='data:image/png;base64,{b64}'>"

    return tpl.substitute(
        title="lathe-mirror report",
        design_table=_design_table(f["design"]),
        machine_table=_kv_table({**{f"lathe.{k}": v for k, v in f["machine"]["lathe"].items()},
                                 **{f"tool.{k}": v for k, v in f["machine"]["tool"].items()}}),
        toolpath_table=_toolpath_table(f["toolpaths"]),
        mirrors_table=_mirrors_table(f["mirrors"]),
        profile_plot=img("profile_error", "height error along the meridian"),
        images=img("images", "renders side by side"),
        renders_table=_kv_table({f"{k}: {m}": v for k, d in f.get("renders", {}).get("against_exact", {}).items()
                                 for m, v in d.items()}) if f.get("renders") else "",
        displacement_plot=img("displacement", "image displacement against image radius"),
        polish_statement=html.escape(f["polishing"]["summary"]["statement"]) + "</b></p><p><b>"
        + html.escape(f["polishing"]["summary_best"]["statement"]),
        polishing_plots=img("polishing_paper", "polishing curve, paper program") + img(
            "polishing_best", "polishing curve, best program"),
        depth_table=_depth_table(f["stereo"]),
        depth_plot=img("depth_error", "depth error against range"),
        tolerance_section=_tolerance_html(f, img),
        notes="".join(f"<li>{html.escape(n)}</li>" for n in f.get("notes", [])),
    )


def _fmt(v: Any) -> str:
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, float):
        if v == 0 or not math.isfinite(v):
            return str(v)
        return f"{v:.4g}" if abs(v) < 1e-3 or abs(v) >= 1e5 else f"{v:.4f}".rstrip("0").rstrip(".")
    if isinstance(v, dict) and set(v) >= {"rms", "max"}:
        return f"{_fmt(v['rms'])} / {_fmt(v['max'])}"
    return html.escape(str(v))


def _kv_table(d: dict) -> str:
    rows = "".join(f"<tr><th>{html.escape(str(k))}</th><td>{_fmt(v)}</td></tr>" for k, v in d.items())
    return f"<table>{rows}</table>"


def _design_table(d: dict) -> str:
    keys = ("r_top", "r_pixel", "f", "t_pixel", "c", "h", "a", "b", "e", "alpha_deg", "vertex_z")
    head = "<tr><th></th>" + "".join(f"<th>{lb['name']}</th>" for lb in d["lobes"]) + "</tr>"
    rows = "".join(f"<tr><th>{k}</th>" + "".join(f"<td>{_fmt(lb[k])}</td>" for lb in d["lobes"]) + "</tr>"
                   for k in keys)
    j = d["junction"]
    extra = (f"<p>Junction at r = {_fmt(j['r'])} mm: step {_fmt(j['step_mm'])} mm, {j['recessed']} lobe recessed. "
             f"Stereo baseline {_fmt(d['baseline_mm'])} mm; common band {_fmt(d['common_band_deg']['min'])} to "
             f"{_fmt(d['common_band_deg']['max'])} deg elevation.</p>")
    return f"<table>{head}{rows}</table>{extra}"


def _toolpath_table(rows: list) -> str:
    head = ("<tr><th>strategy</th><th>points</th><th>G1</th><th>G2/G3</th>"
            "<th>lobe</th><th>programmed slope error rad (RMS / max)</th><th>programmed normal deviation mm</th>"
            "<th>as-machined slope error rad</th><th>as-machined normal deviation mm</th></tr>")
    body = ""
    for r in rows:
        for k in (0, 1):
            p, a = r["programmed"]["lobes"][k], r["as_machined"]["lobes"][k]
            name = r["strategy"] + (" (best)" if r["best"] else "")
            body += (f"<tr><td>{name if k == 0 else ''}</td><td>{r['n_points'] if k == 0 else ''}</td>"
                     f"<td>{r['moves']['G1'] if k == 0 else ''}</td><td>{r['moves']['G2/G3'] if k == 0 else ''}</td>"
                     f"<td>{p['name']}</td><td>{_fmt(p['slope_error_rad'])}</td><td>{_fmt(p['normal_deviation_mm'])}</td>"
                     f"<td>{_fmt(a['slope_error_rad'])}</td><td>{_fmt(a['normal_deviation_mm'])}</td></tr>")
    return f"<table>{head}{body}</table>"


def _mirrors_table(m: dict) -> str:
    keys = ("slope_error_rad", "normal_deviation_mm", "ray_deviation_deg", "image_displacement_px",
            "viewpoint_spread_mm")
    head = "<tr><th>mirror</th><th>lobe</th>" + "".join(f"<th>{k} (RMS / max)</th>" for k in keys) + "</tr>"
    body = ""
    for name, fig in m.items():
        for lb in fig["lobes"]:
            body += f"<tr><td>{name}</td><td>{lb['name']}</td>" + "".join(
                f"<td>{_fmt(lb[k])}</td>" for k in keys) + "</tr>"
    return f"<table>{head}{body}</table>"


def _depth_table(st: dict) -> str:
    key = f"at_{DEPTH_REPORT_M:g}_m"
    rows = "".join(f"<tr><th>{n}</th><td>{_fmt(v['rms'])}</td><td>{_fmt(v['median'])}</td>"
                   f"<td>{_fmt(v['max'])}</td><td>{v['failed']} of {v['points']}</td></tr>"
                   for n, v in st[key].items())
    return (f"<p>{html.escape(st['definition'])}; baseline {_fmt(st['baseline_mm'])} mm.</p>"
            f"<table><tr><th>mirror</th><th>RMS |depth error| at {DEPTH_REPORT_M:g} m (%)</th>"
            f"<th>median (%)</th><th>max (%)</th><th>points failed (|error| &ge; 100 % or not seen)</th></tr>"
            f"{rows}</table>")


def _tolerance_html(f: dict, img) -> str:
    if "tolerance" not in f:
        return "<p>(tolerance analysis not run)</p>"
    tol = f["tolerance"]
    parts = [f"<p>Spec: {html.escape(json.dumps(tol['spec']))}. Tolerances ({html.escape(tol['distribution'])}; "
             f"normal: each is a 3-sigma bound): {html.escape(json.dumps(tol['tolerances']))}. Seed {tol['seed']}.</p>"]
    for name, t in tol["programs"].items():
        v = t["verdict"]
        checks = "".join(
            f"<tr><th>{k}</th><td>{_fmt(c['limit'])}</td><td>{_fmt(c['nominal'])}</td>"
            f"<td class='{'pass' if c['pass'] else 'fail'}'>{'PASS' if c['pass'] else 'FAIL'}</td></tr>"
            for k, c in v["checks"].items())
        sens_rows = ""
        for r in t["sensitivity"]["rows"]:
            for which in ("minus", "plus"):
                c = r[which]
                first = which == "minus"
                sens_rows += (f"<tr><td>{r['parameter'] if first else ''}</td>"
                              f"<td>{(_fmt(r['tolerance']) + ' ' + r['unit']) if first else ''}</td>"
                              f"<td>{which}</td><td>{_fmt(c['image_displacement_px_rms'][0])}</td>"
                              f"<td>{_fmt(c['image_displacement_px_rms'][1])}</td>"
                              f"<td>{_fmt(c['slope_error_rad_rms'][0])}</td><td>{_fmt(c['slope_error_rad_rms'][1])}</td>"
                              f"<td>{_fmt(c['depth_error_pct_rms'])}</td>"
                              f"<td class='{'pass' if c['pass'] else 'fail'}'>{'PASS' if c['pass'] else 'FAIL'}</td></tr>")
        mc = t["monte_carlo"]
        parts.append(
            f"<h3>{html.escape(name)} program</h3><p>Surfaces: {html.escape(t['surfaces'])}; polished "
            f"{_fmt(t['nominal_polish_time_s'] / 60)} min nominal.</p>"
            f"<table><tr><th>criterion (nominal part)</th><th>limit</th><th>nominal</th><th></th></tr>{checks}</table>"
            f"<p class='yield'>Monte Carlo yield: <b>{100 * mc['yield']:.1f} %</b> of {mc['trials']} trials; "
            f"pass fraction per criterion: {html.escape(json.dumps(mc['pass_fraction']))}</p>"
            + img(f"monte_carlo_{name}", f"Monte Carlo histograms, {name} program")
            + "<p>Sensitivity: each parameter at -/+ its tolerance, the others nominal.</p>"
            "<table><tr><th>parameter</th><th>tolerance</th><th></th><th>disp. inner px</th><th>disp. outer px</th>"
            "<th>slope inner rad</th><th>slope outer rad</th><th>depth err %</th><th>spec</th></tr>"
            + sens_rows + "</table>")
    return "".join(parts)
