"""The report's polishing section: the curve, the objective's time, form against facets,
pre-compensation, the process presets side by side."""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING

import numpy as np

from ..design import Mirror
from ..enums import Program, Strategy
from ..errors import InputError
from ..finish import feed_mark_height, feed_mark_rms
from ..job import MachiningJob, polishing_curve, process_for
from ..optics.calibrated_stereo import calibrated_depth_error
from ..optics.polishing_curve import (CURVE_BIN_PX, PolishCurve, clear_surface_errors, form_change,
                                     form_facet_decomposition, polish_summary)
from ..optics.radial import pooled_rms, radial_figures
from ..optics.scatter import haze_figures, lobe_geometry
from ..optics.stereo import depth_error_curve
from ..polishing import FIRST_MODEL, PolishParams, compensated_mirror, lap_plan, polish, polished_design
from ..profile import Profile
from ..results.polishing import PolishingStudy, PolishSummary

if TYPE_CHECKING:
    from ..settings import Settings



def polishing_study(settings: Settings, job: MachiningJob, made: dict[str, Profile], *,
                    progress: bool = False) -> tuple[PolishingStudy, dict[str, PolishCurve]]:
    """The report's polishing section: both programs' polishing curves (the conventional
    process's finish on them) and the time polish.objective chooses; the form / facet
    decomposition of the polished paper mirror (and of the first model's: a fixed lap, 60
    min); pre-compensation at each program's chosen time; the process presets side by side.

    job: the machining job; made: its as-machined "paper" and "best" parts (with
    polish.precompensate, the parts its programs cut from the pre-compensated target).
    Returns (results.polishing.PolishingStudy, {"paper": curve, "best": curve}).
    """
    mirror = job.mirror
    params = settings.polish
    process = process_for(settings)
    parts = {"paper": made["paper"], "best": made["best"]}
    curves = {key: polishing_curve(parts[key], mirror, params, process=process, progress=progress)
              for key in ("paper", "best")}
    paper = curves["paper"]
    time_s = paper.optimum_time_s

    def decompose(surface: Profile, p: PolishParams, t: float) -> dict:
        d = form_facet_decomposition(surface, mirror, degree=p.form_degree, edge_mm=p.clear_edge_mm,
                                     range_m=p.objective_range_m, removal_only=polished_design(mirror, p, t),
                                     knot_px=p.calibration_knot_px)
        return {"time_s": t, "lap": p.lap.value, **d.to_dict()}

    first = dataclasses.replace(params, **FIRST_MODEL)
    decomposition = {
        "first_model": decompose(polish(made["paper"], first, 3600.0), first, 3600.0),
        "polished": decompose(paper.profiles[paper.optimum_index], params, time_s),
    }
    # The paper program, the one polishing rescues (the best program's figures after the
    # same study are in the README; each program costs ~1.5 s).
    precomp = {"paper": precompensation_study(job.but(strategy=Strategy.PAPER), time_s,
                                              polished=paper.profiles[paper.optimum_index])}
    out = {
        "params": polish_params_dict(params),
        "model": "Preston's law dh/dt = k_p p v; the lap's kinematics give the time-averaged k_p p0 v "
                 "at each radius (polishing.LapPlan); compliant pad p = p0 max(0, 1 + d / l_c), its "
                 "surface a Gaussian-weighted local cubic fit (no ringing)",
        "lap_plan": lap_plan(mirror, params).to_dict(),
        "objective": params.objective.value,
        "paper_program": paper.to_dict(),
        "best_program": curves["best"].to_dict(),
        "summary": polish_summary(paper, "paper"),
        "summary_best": polish_summary(curves["best"], "best"),
        "decomposition": decomposition,
        "precompensation": precomp,
        "processes": process_table(settings, job, curves),
        "precompensated_programs": job.target is not None,
        "conclusion": "",
    }
    study = PolishingStudy.from_dict(out)
    return dataclasses.replace(study, conclusion=polishing_conclusion(study)), curves


def polish_params_dict(params: PolishParams) -> dict:
    """[polish] as plain data (enums as their values, the presets as tables)."""
    d = {}
    for f in dataclasses.fields(params):
        v = getattr(params, f.name)
        if f.name == "processes":
            v = {p.name: {k: (x.value if hasattr(x, "value") else x) for k, x in p.__dict__.items() if k != "name"}
                 for p in v}
        elif hasattr(v, "value"):
            v = v.value
        d[f.name] = v
    return d


def surface_figures(profile: Profile, mirror: Mirror, params: PolishParams) -> dict:
    """What the polishing section states of a made surface: per lobe the form change and
    slope error over the clear aperture; both lobes: RMS image displacement (px), the
    calibrated stereo residual and the depth error at polish.objective_range_m (%)."""
    rng = params.objective_range_m
    form = form_change(profile, mirror, degree=params.form_degree, edge_mm=params.clear_edge_mm)
    surf = clear_surface_errors(profile, mirror, edge_mm=params.clear_edge_mm)
    rad = radial_figures(profile, mirror, bin_px=CURVE_BIN_PX)
    disp = [lb["image_displacement_px"]["rms"] for lb in rad["lobes"]]
    pix = [lb["pixels"] for lb in rad["lobes"]]
    return {
        "lobes": [{"name": f["name"], "form_change_mm": f["form_change_mm"], "form_pv_mm": f["form_pv_mm"],
                   "slope_error_rad": s_["slope_error_rad"], "normal_deviation_mm": s_["normal_deviation_mm"],
                   "image_displacement_px": r_["image_displacement_px"]}
                  for f, s_, r_ in zip(form["lobes"], surf["lobes"], rad["lobes"])],
        "image_displacement_px_rms": pooled_rms(zip(disp, pix)),
        "stereo_residual_pct": calibrated_depth_error(profile, mirror, [rng], knot_px=params.calibration_knot_px,
                                                      clear_edge_mm=params.clear_edge_mm,
                                                      bin_px=CURVE_BIN_PX).at(rng)["rms"],
        "depth_error_pct": depth_error_curve(profile, mirror, [rng]).at(rng)["rms"],
        "range_m": rng,
    }


def precompensation_study(job: MachiningJob, time_s: float, *, polished: Profile | None = None) -> dict:
    """The program's part polished time_s (s) as programmed on the design and as programmed on
    the design lowered by the allowance (polishing.compensated_mirror): the form each lands
    with (surface_figures), and the allowance itself (um, per lobe: min, max). polished: the
    program's part on the design polished time_s, if already made."""
    mirror, params, strategy = job.mirror, job.polish, job.strategy
    target = compensated_mirror(mirror, params, time_s)
    on_design = dataclasses.replace(job, target=None, precompensation_s=0.0, polish_time_s=time_s)
    plain = polished if polished is not None else on_design.made().profile
    comp = dataclasses.replace(on_design, target=target, precompensation_s=time_s).made().profile
    allowance = {}
    for k, lobe in enumerate(target.lobes):
        lo, hi = (0.0, mirror.r_junction) if k == 0 else (mirror.r_junction, mirror.r_max)
        off = lobe.offset(np.linspace(lo, hi, 401))
        allowance[lobe.name] = {"min_um": float(off.min() * 1e3), "max_um": float(off.max() * 1e3)}
    return {"program": strategy.value, "time_s": time_s, "allowance": allowance,
            "without": surface_figures(plain, mirror, params), "with": surface_figures(comp, mirror, params)}


def process_table(settings: Settings, job: MachiningJob, curves: dict[str, PolishCurve]) -> list[dict]:
    """The process presets side by side: turning (feed marks, roughness), the polish (the
    objective's time on the preset's program's curve) or none, and what the made surface
    gives (surface_figures; roughness, TIS and haze per lobe, optics.scatter). A preset
    without polish turns the design (a pre-compensation is for a polish)."""
    mirror, params = job.mirror, settings.polish
    turned_job = dataclasses.replace(job, target=None, precompensation_s=0.0)
    plan = lap_plan(mirror, params)
    geometry = (lobe_geometry(mirror, 0, bin_px=CURVE_BIN_PX), lobe_geometry(mirror, 1, bin_px=CURVE_BIN_PX))
    made_cache: dict[tuple, Profile] = {}
    rows = []
    for preset in params.processes:
        proc = process_for(settings, preset.name)
        strategy = proc.program.strategy
        if proc.polish:
            curve = curves["best" if proc.program is Program.BEST else "paper"]
            t = curve.optimum_time_s
            surface = curve.profiles[curve.optimum_index]
        else:
            t = 0.0
            key = (strategy, proc.nose_radius_mm, proc.resolution_mm)
            if key not in made_cache:
                tool = dataclasses.replace(job.tool, nose_radius=proc.nose_radius_mm)
                try:
                    made_cache[key] = turned_job.but(strategy=strategy, tool=tool,
                                                     resolution=proc.resolution_mm).made().profile
                except InputError as exc:
                    # a preset's tool that cannot cut this design (its nose does not reach
                    # the step): the table says so, the report goes on
                    made_cache[key] = str(exc)
            surface = made_cache[key]
            if isinstance(surface, str):
                rows.append({"name": proc.name, "label": proc.label, "program": strategy.value,
                             "nose_radius_mm": proc.nose_radius_mm, "feed_mm": proc.feed_mm,
                             "resolution_mm": proc.resolution_mm, "cannot_cut": surface})
                continue
        haze = haze_figures(mirror, proc, removal_mm=(lambda k, r, t=t: plan.rate(k, r) * t) if t > 0 else None,
                            compliance_mm=params.compliance_mm, wavelength_mm=params.wavelength_mm,
                            geometry=geometry)
        turned = haze_figures(mirror, proc, removal_mm=None, compliance_mm=params.compliance_mm,
                              wavelength_mm=params.wavelength_mm, geometry=geometry)
        figs = surface_figures(surface, mirror, params)
        rows.append({
            "name": proc.name, "label": proc.label, "program": strategy.value,
            "nose_radius_mm": proc.nose_radius_mm, "feed_mm": proc.feed_mm, "resolution_mm": proc.resolution_mm,
            "feed_mark_pv_nm": feed_mark_height(proc.feed_mm, proc.nose_radius_mm) * 1e6,
            "feed_mark_rms_nm": feed_mark_rms(proc.feed_mm, proc.nose_radius_mm) * 1e6,
            "feed_mark_period_um": proc.feed_mm * 1e3,
            "polish_time_s": t,
            "as_turned": turned["lobes"],
            "finished": haze["lobes"],
            **{k: figs[k] for k in ("image_displacement_px_rms", "stereo_residual_pct", "depth_error_pct")},
            "slope_error_rad": [lb["slope_error_rad"] for lb in figs["lobes"]],
        })
    return rows


def polishing_conclusion(p: PolishingStudy) -> str:
    """The polishing section's conclusion, from its figures (form against facets, the
    objective's time against image displacement's, pre-compensation)."""
    first = p.decomposition["first_model"]
    d1, cal = first.depth_error_pct, first.stereo_residual_pct
    rng = first.range_m
    s = p.summary
    comp = p.precompensation["paper"]
    chosen = s.chosen_time_s
    form_without = max(lb.form_change_mm.rms for lb in comp.without.lobes) * 1e3
    form_with = max(lb.form_change_mm.rms for lb in comp.with_.lobes) * 1e3
    return (
        f"Facets, not form, carry the depth error. The first model's polished paper mirror (a fixed lap, "
        f"60 min) has {d1['made'].rms:.1f} % RMS depth error at {rng:g} m; the design carrying only its "
        f"degree-{first.form_degree} form has {d1['form'].rms:.1f} %, the design carrying only the "
        f"facets left after the form is taken out {d1['facets'].rms:.1f} %, the lap's removal on the "
        f"design alone {d1['removal_only'].rms:.1f} %. The form tilts both lobes' rays alike and barely "
        f"moves the parallax; the facets survive where the removal is slow, about one pixel apart in the "
        f"image, and no calibration removes them (calibrated: facets "
        f"{cal['facets'].rms:.1f} %, form {cal['form'].rms:.2f} %). "
        f"So the time is chosen by {p.objective.replace('_', ' ')} "
        f"({'the calibrated stereo residual' if p.objective == 'stereo' else 'as configured'}): "
        f"{chosen[p.objective] / 60:.0f} min for the paper program, where image displacement would stop at "
        f"{chosen['image_displacement'] / 60:.0f} min (calibrated stereo residual "
        f"{s.stereo_residual_pct.before:.1f} -> {s.stereo_residual_pct.at_optimum:.2f} %). "
        f"The lap's even removal is predictable: programmed on the design lowered by it, the polished paper part "
        f"lands within {form_with:.2f} um RMS of the design's form (without: {form_without:.1f} um). "
        + _trade(s)
    )


def _trade(s: PolishSummary) -> str:
    """The recommendation's assumption and the figure it trades (as `polish` says it)."""
    if s.assumption == "calibrated":
        d = s.depth_error_pct
        return (f"The recommended time assumes a calibrated camera; uncalibrated, its depth error at "
                f"{s.range_m:g} m goes {d.before:.3g} -> {d.at_optimum:.3g} %.")
    d = s.stereo_residual_pct
    return (f"The recommended time assumes an uncalibrated camera; calibrated, its stereo residual goes "
            f"{d.before:.3g} -> {d.at_optimum:.3g} %.")

