"""The tolerance analysis of the configured programs: each program's part cut at each
lattice phase and nose (job.made_surface), its Monte Carlo, sensitivity, inverse
sensitivity, allocation and the verdict against the spec.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import TYPE_CHECKING

from ..design import Mirror
from ..enums import Program
from ..job import MachiningJob, MadeSurface, polishing_curve
from ..optics.radial import radial_figures
from ..optics.zones import zones_for
from .allocation import allocate as allocate_tolerances
from .allocation import inverse_sensitivity
from .montecarlo import CRITERIA, evaluate_trials, judge, prepare, run_monte_carlo, stereo_table
from .perturb import Trials
from .spec import DRAWN
from .sensitivity import judged_values, resolution_row, responses, sensitivity_table

if TYPE_CHECKING:
    from ..settings import Settings

#: Ranges (m) of the depth-error curve (0.5 m to 5 m).
DEPTH_RANGES_M = (0.5, 0.75, 1.0, 1.5, 2.0, 3.0, 4.0, 5.0)


@dataclass
class ToleranceRuns:
    """The tolerance analysis: `figures` (JSON-ready, tolerance_analysis's dict) and every
    Monte Carlo run behind it as (run name, tolerance.montecarlo.MonteCarloResult), for the
    per-trial CSV."""

    figures: dict
    results: list


def tolerance_analysis(mirror: Mirror, settings: Settings, nominal_times_s: dict[Program, float], *,
                       progress: bool = False, allocate: tuple[Program, ...] = (),
                       target_yield: float | None = None, job: MachiningJob | None = None,
                       blur_px: float = 0.0) -> dict:
    """Monte Carlo, sensitivity and inverse sensitivity for each toleranced program
    ([tolerance] programs), each polished for its nominal time (s); the verdict of each
    against the spec; for the programs in `allocate`, the least-cost tolerances that reach
    target_yield (default tolerance.target_yield), confirmed by a fresh Monte Carlo. job: the
    machining job the parts are cut by (default MachiningJob.from_settings); each program's
    part is its variant with that program."""
    return tolerance_runs(mirror, settings, nominal_times_s, progress=progress, allocate=allocate,
                          target_yield=target_yield, job=job, blur_px=blur_px).figures


def tolerance_runs(mirror: Mirror, settings: Settings, nominal_times_s: dict[Program, float], *,
                   progress: bool = False, allocate: tuple[Program, ...] = (),
                   target_yield: float | None = None, job: MachiningJob | None = None,
                   blur_px: float = 0.0) -> ToleranceRuns:
    """tolerance_analysis, keeping the Monte Carlo results (ToleranceRuns). blur_px: the
    design's defocus blur (px, optimize.focus) the delivered range counts (0: left out)."""
    job = MachiningJob.from_settings(settings, mirror) if job is None else job
    ts = settings.tolerance
    target = ts.target_yield if target_yield is None else target_yield
    out = {"spec": ts.spec_dict(), "distribution": ts.distribution.value, "tolerances": ts.tolerances,
           "cost": ts.cost, "seed": ts.seed, "trials": ts.trials, "target_yield": target,
           "seat_pivot_mm": ts.pivot_mm(mirror), "lattice_phases": ts.lattice_phases,
           "nose_step_mm": ts.nose_step_mm, "programs": {}}
    results = []
    for program in ts.programs:
        part = job.but(strategy=program.strategy)
        ctx = tolerance_context(mirror, settings, program, nominal_times_s[program], progress=progress, job=part,
                                blur_px=blur_px)
        mc = run_monte_carlo(ctx, progress=progress)
        results.append((f"{program.value}: monte carlo", mc))
        resp = responses(ctx, progress=progress)
        sens = sensitivity_table(ctx, resp)
        row = resolution_row(ctx, settings.polish, res0=part.lathe.resolution,
                             machine_at=lambda res: part.but(resolution=res, nose_radius=ctx.nominal_nose_mm).made())
        if row is not None:
            sens["rows"].insert(0, row)
        entry = {"made_mirror": part.but(polish_time_s=ctx.nominal_time_s).to_dict(), "surfaces": ctx.source, "nominal_polish_time_s": ctx.nominal_time_s, "limits": ctx.limits,
                 "monte_carlo": mc.to_dict(), "sensitivity": sens,
                 "inverse_sensitivity": inverse_sensitivity(resp, ctx.limits),
                 "stereo": stereo_table(ctx, DEPTH_RANGES_M),
                 "nose_radii_cut": len(ctx.bank.nose_mm),
                 "nominal_over_zone": nominal_over_zone(mirror, part.but(polish_time_s=ctx.nominal_time_s), ctx),
                 # the same figure of the part as machined: the made mirror calib, render and the
                 # report describe by default (job.MachiningJob, not polished), over the same zone
                 "as_machined_over_zone": nominal_over_zone(mirror, part.but(polish_time_s=0.0), ctx)}
        if program in allocate:
            entry["allocation"], confirm = allocate_tolerances(ctx, resp, mc, target=target, progress=progress)
            if confirm is not None:
                results.append((f"{program.value}: allocation confirmed", confirm))
        entry["verdict"] = verdict(entry, ts.spec_dict())
        out["programs"][program.value] = entry
    return ToleranceRuns(out, results)


def nominal_over_zone(mirror: Mirror, part: MachiningJob, ctx) -> dict:
    """The nominal part's shared figure, exactly (optics.radial: every pixel centre of the
    aligned camera) over the zone the criteria judge: the image displacement per lobe (px),
    the figure `calib` and the report quote for the same made mirror (`part`, polished for
    the nominal time); the Monte Carlo's sparse 3-D sample estimates it per trial."""

    made = part.made()
    lobes = radial_figures(made.profile, mirror, zones=ctx.zones)["lobes"]
    return {"surface": made.source, "made_mirror": part.label, "zones": ctx.zones.describe(),
            "lobes": [{"name": lb["name"], "image_displacement_px": lb["image_displacement_px"],
                       "zone_px": lb["zone_px"]} for lb in lobes]}


def monte_carlo(mirror: Mirror, settings: Settings, program: Program, nominal_time_s: float, *,
                progress: bool = False, job: MachiningJob | None = None):
    """The seeded Monte Carlo of one program's part polished nominal_time_s (s): settings.
    tolerance.trials draws from its seed (tolerance.montecarlo.MonteCarloResult: the
    trials, their figures, pass flags per criterion, `.yield_fraction`)."""
    return run_monte_carlo(tolerance_context(mirror, settings, program, nominal_time_s, progress=progress,
                                             job=job), progress=progress)


def tolerance_context(mirror: Mirror, settings: Settings, program: Program, nominal_time_s: float, *,
                      progress: bool = False, job: MachiningJob | None = None, blur_px: float = 0.0):
    """The Monte Carlo's shared context: the program's part (the machining job with that
    program: default MachiningJob.from_settings) cut at each lattice phase (and, as trials
    draw them, with each nose radius), polished at the time nodes. blur_px: the design's
    defocus blur (px) the delivered range counts; R10 over the optimiser's band."""
    job = (MachiningJob.from_settings(settings, mirror) if job is None else job).but(strategy=program.strategy)
    # each phase's program planned once (the noses the trials draw are all cut along the
    # program planned for the [tool] nose); phase 0's here, before the workers fork, so
    # every nose cut in them takes it
    phases: dict[float, MachiningJob] = {0.0: job.but(phase=0.0)}
    phases[0.0].toolpath  # noqa: B018 - planned now (a cached property)

    def machine_at(phase: float, nose: float) -> MadeSurface:
        if phase not in phases:
            phases[phase] = job.but(phase=phase)
        planned = phases[phase]
        planned.toolpath  # noqa: B018 - planned before `but`, which hands the plan on
        return planned.but(nose_radius=nose).made()

    ts = settings.tolerance
    ts = dataclasses.replace(ts, seat_pivot_mm=ts.pivot_mm(mirror))  # 0: the design's rim
    ctx = prepare(mirror, ts, settings.polish, nominal_time_s, program,
                  nose0=job.tool.nose_radius, machine_at=machine_at, progress=progress,
                  zones=zones_for(settings, mirror))
    ctx.cut_plus_x = mirror.step > 0  # the finishing pass runs axis -> rim (+X): backlash shows
    ctx.blur_px = float(blur_px)
    ctx.band = settings.optimize.band
    return ctx


def verdict(t: dict, spec: dict) -> dict:
    """Pass / fail of a program's nominal part against each judged limit (calibrated or raw
    figures as the spec says), its yield with the Wilson 95 % interval, and what to
    tighten when an allocation was made."""
    nominal = t["sensitivity"]["nominal"]
    fig = nominal["calibrated" if spec.get("calibrated", True) else "raw"]
    lim = t["limits"]
    checks = {
        "image_displacement_px": {"limit": lim["image_displacement_px"],
                                  "nominal": max(fig["image_displacement_px_rms"])},
        "outlier_pct": {"limit": lim["outlier_pct"], "nominal": max(fig["outlier_pct"])},
        "disparity_px": {"limit": lim["disparity_px"], "nominal": fig["disparity_px_p90"],
                         "range_m": spec["depth_range_m"], "depth_error_pct": spec["depth_error_pct"]},
        "slope_error_rad": {"limit": lim["slope_error_rad"], "nominal": max(nominal["slope_error_rad_rms"])},
    }
    for c in checks.values():
        c["pass"] = bool(c["nominal"] <= c["limit"])
    mc = t["monte_carlo"]
    out = {"checks": checks, "nominal_pass": all(c["pass"] for c in checks.values()),
           "calibrated": bool(spec.get("calibrated", True)), "yield": mc["yield"],
           "yield_wilson95": mc["yield_wilson95"], "trials": mc["trials"]}
    if "allocation" in t:
        out["allocation"] = t["allocation"]["statement"]
    return out


def winner_check(mirror: Mirror, settings: Settings, *, progress: bool = False,
                 polish_time_s: float | None = None, nominal_only: bool = False, blur_px: float = 0.0,
                 allocate: bool = False, diagnose: bool = True) -> dict:
    """The optimiser's winner through the tolerance analysis of the best program with the
    configured tool and default tolerances: the nominal part (lattice phase 0, every
    parameter nominal) judged against the spec, and the Monte Carlo's yield against
    tolerance.target_yield. When the nominal part fails, the criteria it fails (only
    those); when the yield falls short, the criteria failing trials break and the yield
    with each drawn parameter held perfectly (`yield_without`, the same seed), naming the
    tolerance that makes the target impossible (held perfectly, the target is reached) or
    saying that none does alone. The part judged is `tolerance`'s: the best program
    polished for its polishing curve's time (or polish_time_s), its label under
    "made_mirror". nominal_only: the nominal part alone (no Monte Carlo, no yield).
    allocate: when the yield falls short or the delivered R10's p5 does
    (tolerance.delivered_p5_min_fraction; the nominal part passing), the least-cost
    tolerances that reach both instead of `yield_without` (tolerance.allocation,
    confirmed on the same seed: "allocation", with the delivered range at them).
    diagnose=False: a yield short of the target is stated without `yield_without` (a Monte
    Carlo per drawn parameter) or an allocation."""
    import numpy as np

    ts = settings.tolerance
    job = MachiningJob.from_settings(settings, mirror, strategy=Program.BEST.strategy)
    if polish_time_s is None:  # the best program's polishing curve chooses it, as `tolerance` does
        time_s = polishing_curve(job.made().profile, mirror, settings.polish).optimum_time_s
    else:
        time_s = float(polish_time_s)
    ctx = tolerance_context(mirror, settings, Program.BEST, time_s, progress=progress, job=job, blur_px=blur_px)
    nom = evaluate_trials(ctx, Trials.nominal(1, ctx.nominal_nose_mm, ctx.nominal_time_s))
    ok = judge(nom, ctx.limits, ts.spec.calibrated)

    vals = judged_values(nom, ts.spec.calibrated)[0]
    nominal = {c: {"value": float(vals[j]), "limit": float(ctx.limits[c]), "pass": bool(ok[c][0])}
               for j, c in enumerate(CRITERIA)}
    failing = [c for c in CRITERIA if not nominal[c]["pass"]]
    why = ("the nominal part fails " + ", ".join(
        f"{c} ({nominal[c]['value']:.4g} > {nominal[c]['limit']:.4g})" for c in failing)
        + ": no tolerance can fix it (the design, the tool or the spec must change)")
    if nominal_only:
        return {"program": Program.BEST.value, "made_mirror": job.but(polish_time_s=time_s).label,
                "polish_time_s": time_s, "nominal": nominal, "nominal_pass": not failing,
                **({"why": why} if failing else {})}
    mc = run_monte_carlo(ctx, progress=progress)
    y = float(mc.yield_fraction)
    out = {"program": Program.BEST.value, "made_mirror": job.but(polish_time_s=time_s).label,
           "polish_time_s": time_s, "nominal": nominal,
           "nominal_pass": not failing, "yield": y, "target_yield": ts.target_yield, "trials": len(mc.trials),
           "pass_fraction": {c: float(np.mean(mc.passed[c])) for c in CRITERIA},
           "delivered_r10_m": mc.delivered.summary(), "delivered": mc.delivered.to_dict(),
           "zones": ctx.zones.describe()}
    dr = out["delivered_r10_m"]
    range_short = dr["p5"] < ts.delivered_p5_min_fraction * dr["design"]
    if failing:
        out["why"] = why
    elif allocate and y >= ts.target_yield and range_short:
        alloc, confirm = allocate_tolerances(ctx, responses(ctx, progress=progress), mc, progress=progress)
        out["allocation"] = alloc
        if confirm is not None:
            out["allocation"]["delivered_r10_m"] = confirm.delivered.summary()
        out["why"] = (f"delivered R10 p5 {dr['p5']:.4g} m < {100 * ts.delivered_p5_min_fraction:g} % of the "
                      f"design's {dr['design']:.4g} m; {alloc['statement']}")
    elif y < ts.target_yield:
        broken = [c for c in CRITERIA if float(np.mean(mc.passed[c])) < ts.target_yield]
        alone = ""
        if not broken:  # each criterion reaches the target alone; failing trials break different ones
            broken = [c for c in CRITERIA if float(np.mean(mc.passed[c])) < 1.0]
            alone = " (each at or above the target alone)"
        head = (f"yield {100 * y:.1f} % < {100 * ts.target_yield:g} %: the failing trials break "
                + ", ".join(f"{c} (pass {100 * float(np.mean(mc.passed[c])):.1f} %)" for c in broken) + alone)
        if allocate:
            alloc, confirm = allocate_tolerances(ctx, responses(ctx, progress=progress), mc, progress=progress)
            out["allocation"] = alloc
            if confirm is not None:
                out["allocation"]["delivered_r10_m"] = confirm.delivered.summary()
            out["why"] = f"{head}; {alloc['statement']}"
            return out
        if not diagnose:
            out["why"] = head
            return out
        # which tolerance makes the target out of reach: the yield with each drawn
        # parameter held perfectly (its tolerance 0, the others as configured; same seed)
        without = {}
        for k in DRAWN:
            if ts.tolerances.get(k, 0.0) > 0:
                tol = {**ts.tolerances, k: 0.0}
                without[k] = float(run_monte_carlo(ctx, tolerances=tol).yield_fraction)
        out["yield_without"] = without
        ranked = sorted(without, key=lambda k: -without[k])
        if not ranked:
            out["why"] = head
        elif without[ranked[0]] >= ts.target_yield:
            k = ranked[0]
            out["why"] = (f"{head}; {k} (tolerance {ts.tolerances[k]:g}) makes the target impossible: held "
                          f"perfectly it gives {100 * without[k]:.1f} %, so tighten it (`tolerance --allocate` says how far)")
        else:
            top = ", ".join(f"{k} {100 * without[k]:.1f} %" for k in ranked[:3])
            out["why"] = (f"{head}; no single tolerance makes the target impossible alone: held perfectly, each "
                          f"gives at most {top}; `tolerance --allocate` tightens them together at least cost")
    return out


def made_disparity(mirror: Mirror, settings: Settings, *, trials: int = 64, phases: int = 2,
                   quantile: float = 0.95, blur_px: float = 0.0, progress: bool = False) -> dict:
    """The made parts' own disparity error after calibration (px, the band's median at the
    spec's range) at `quantile` over a small seeded Monte Carlo (`trials` trials of the
    settings' seed, `phases` lattice phases) of the best program's part at the configured
    tolerances: the optimiser's delivered-R10 surrogate takes it as every candidate's part
    error (optimize.evaluate.Problem.made_disparity_px), and optimize.robust judges the
    candidates of its front by their own. With its yield, each criterion's pass fraction
    and the delivered range."""
    import numpy as np

    ts = settings.tolerance
    small = dataclasses.replace(settings, tolerance=dataclasses.replace(
        ts, trials=int(trials), lattice_phases=max(1, min(int(phases), ts.lattice_phases))))
    job = MachiningJob.from_settings(small, mirror, strategy=Program.BEST.strategy)
    time_s = polishing_curve(job.made().profile, mirror, small.polish).optimum_time_s
    ctx = tolerance_context(mirror, small, Program.BEST, time_s, progress=progress, job=job, blur_px=blur_px)
    mc = run_monte_carlo(ctx, progress=progress, desc="optimize: the configured design's made parts")
    d = mc.delivered.disparity_px
    return {"disparity_px": float(np.quantile(np.where(np.isfinite(d), d, np.inf), quantile, method="inverted_cdf")),
            "quantile": quantile, "trials": int(trials), "lattice_phases": ctx.settings.lattice_phases,
            "seed": mc.seed, "yield": mc.yield_fraction,
            "pass_fraction": {c: float(np.mean(mc.passed[c])) for c in CRITERIA},
            "delivered_r10_m": mc.delivered.summary()}
