"""The polishing curve: a made surface's figures against polishing time, and the time the
user's objective chooses.

polishing.py evolves the surface (Preston's law, a lap that moves, a compliant pad); this
module judges each snapshot with the optics and picks the time:

- the objective (polish.objective): `stereo` (default), the calibrated stereo residual at
  polish.objective_range_m (optics.calibrated_stereo: the depth error once a per-lobe
  smooth radial map, what calibration absorbs, is fitted out); `image_displacement`, the RMS
  image displacement over both lobes' usable pixels; `slope_error`, the RMS slope error over
  both lobes' clear apertures. The chosen time is the earliest whose objective is within
  polish.objective_tolerance of the least the explored range reaches (polishing past it buys
  nothing the objective sees). The curve states the time each objective would choose.
- every slope and form figure is over the clear aperture (`clear_aperture`): the extent of
  the lobe the image uses, less polish.clear_edge_mm at each edge (the step, the rim).
- the surface finish of the configured process (finish.py, optics.scatter): roughness, TIS
  and the haze in the image per lobe after each time.

`form_facet_decomposition` splits a made surface's error into its low-order form (the
Legendre fit that form_change reports) and the rest (facets), and gives the depth error of
the design carrying each alone: on the paper program it is the facets, not the form, that
carry the depth error.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from ..design import Mirror
from ..enums import PolishObjective
from ..finish import Process
from ..polishing import LapPlan, PolishParams, lap_plan, polish_series
from ..profile import LobeSamples, Profile, SampledProfile
from ..progress import bar as progress_bar
from ..toolpath.metrics import slope_error
from .radial import lobe_pixel_radii, pooled_rms, radial_displacement, trace_lobe, used_extent, weighted_stats
from .stereo import band_elevations, depth_error_curve

#: Width (px) of the image-radius bins over which the curve evaluates the image figures: a
#: facet of the paper program images ~1 px wide, so ten samples per pixel resolve it, at a
#: twentieth of the cost of every distinct radius of the sensor (the report's mirror table
#: uses every radius; the two agree to ~1 %).
CURVE_BIN_PX = 0.1
#: What each objective is called in a sentence, and its unit.
OBJECTIVE_WORDS = {
    PolishObjective.STEREO: ("the calibrated stereo residual", "%"),
    PolishObjective.IMAGE_DISPLACEMENT: ("the image displacement", "px"),
    PolishObjective.SLOPE_ERROR: ("the slope error", "rad"),
}
#: The figure (combined over both lobes) each objective minimises.
OBJECTIVE_FIGURES = {
    PolishObjective.STEREO: "stereo_residual_pct",
    PolishObjective.IMAGE_DISPLACEMENT: "image_displacement_px",
    PolishObjective.SLOPE_ERROR: "slope_error_rad",
}


# --------------------------------------------------------------------------------------
# Clear aperture, form


def clear_aperture(mirror: Mirror, k: int, edge_mm: float) -> tuple[float, float]:
    """Radii (mm) of lobe k over which slope and form figures are taken: the extent the
    image uses (optics.radial.used_extent: the inner lobe stops where the step wall starts
    to vignette its rays, which leaves out the tool's fillet in the corner), less edge_mm
    (mm) at each edge of the lobe (the step and the outer rim; the axis is no edge)."""
    lo, hi = used_extent(mirror, k)
    lobe_lo, lobe_hi = (0.0, mirror.r_junction) if k == 0 else (mirror.r_junction, mirror.r_max)
    if k == 1:
        lo = max(lo, lobe_lo + edge_mm)
    hi = min(hi, lobe_hi - edge_mm)
    if hi <= lo:
        raise ValueError(f"the clear aperture of the {mirror.lobes[k].name} lobe is empty "
                         f"(polish.clear_edge_mm = {edge_mm:g} mm)")
    return lo, hi


def _radii(lo: float, hi: float, n: int, k: int) -> np.ndarray:
    r = np.linspace(lo, hi, n)
    if k == 1:
        r[0] = np.nextafter(lo, hi)
    return r


def form_fit(profile: Profile, mirror: Mirror, k: int, *, degree: int = 4, edge_mm: float = 0.0,
             n: int = 2001) -> np.polynomial.legendre.Legendre:
    """Lobe k's form: the least-squares Legendre fit of degree `degree` in r of (profile -
    design) over the clear aperture (mm -> mm, domain the clear aperture)."""
    lo, hi = clear_aperture(mirror, k, edge_mm)
    r = _radii(lo, hi, n, k)
    dz = np.asarray(profile.z(r)) - mirror.lobes[k].z(r)
    return np.polynomial.legendre.Legendre.fit(r, dz, degree, domain=[lo, hi])


def form_change(profile: Profile, mirror: Mirror, *, degree: int = 4, edge_mm: float = 0.0,
                n: int = 2001) -> dict:
    """Per-lobe form change: the low-order part of (profile - design), mm.

    The form_fit of the given degree over the clear aperture (edge_mm, mm, at each edge);
    returns {"rms", "max"} of that fit (all terms, piston included: a polish's removal is
    real) under "form_change_mm", plus the fit's peak-to-valley "form_pv_mm".
    """
    lobes = []
    for k, lobe in enumerate(mirror.lobes):
        lo, hi = clear_aperture(mirror, k, edge_mm)
        fit = form_fit(profile, mirror, k, degree=degree, edge_mm=edge_mm, n=n)(_radii(lo, hi, n, k))
        lobes.append({"name": lobe.name,
                      "form_change_mm": {"rms": float(np.sqrt(np.mean(fit**2))),
                                         "max": float(np.max(np.abs(fit)))},
                      "form_pv_mm": float(np.ptp(fit))})
    return {"lobes": lobes}


def clear_surface_errors(profile: Profile, mirror: Mirror, *, edge_mm: float = 0.0, n: int = 4001) -> dict:
    """Per-lobe slope_error_rad and normal_deviation_mm ({rms, max}) uniform in r over the
    clear aperture (edge_mm, mm), by the shared definitions (ARCHITECTURE.md): the angle
    between the made and exact normals at the same r; |dz| cos(beta)."""
    out = []
    for k, lobe in enumerate(mirror.lobes):
        r = _radii(*clear_aperture(mirror, k, edge_mm), n, k)
        s_exact = lobe.slope(r)
        slope = np.abs(slope_error(profile.slope(r), s_exact))
        dev = np.abs(profile.z(r) - lobe.z(r)) / np.hypot(1.0, s_exact)
        out.append({"name": lobe.name,
                    "slope_error_rad": {"rms": float(np.sqrt(np.mean(slope**2))), "max": float(np.max(slope))},
                    "normal_deviation_mm": {"rms": float(np.sqrt(np.mean(dev**2))), "max": float(np.max(dev))}})
    return {"lobes": out}


# --------------------------------------------------------------------------------------
# The curve


@dataclass(frozen=True)
class PolishCurve:
    """Figures against polishing time.

    times_s: s. lobes[k][name] -> {"rms": array, "max": array} (or "mean"/"max") over
    times. combined[name] -> array over times, both lobes together:
    image_displacement_px (RMS over every usable pixel), slope_error_rad (RMS over both
    clear apertures), stereo_residual_pct and depth_error_pct (RMS |error| over the band at
    range_m, calibrated and not). objective: what chooses the time; tolerance: the chosen
    time is the earliest within (1 + tolerance) of the objective's least value.
    """

    times_s: np.ndarray
    lobes: list[dict]
    combined: dict[str, np.ndarray]
    objective: PolishObjective = PolishObjective.STEREO
    tolerance: float = 0.05
    range_m: float = 2.0
    profiles: list[SampledProfile] = field(repr=False, default_factory=list)

    @property
    def combined_displacement_px(self) -> np.ndarray:
        """RMS image displacement over all usable pixels of both lobes (px) at each time."""
        return self.combined["image_displacement_px"]

    def chosen_index(self, objective: PolishObjective | None = None) -> int:
        """Index of the time `objective` (default the curve's) chooses: the earliest whose
        value is within (1 + tolerance) of the least over the curve."""
        values = self.combined[OBJECTIVE_FIGURES[objective or self.objective]]
        best = float(np.nanmin(values))
        ok = np.flatnonzero(values <= best * (1.0 + self.tolerance) + 1e-300)
        return int(ok[0]) if ok.size else int(np.nanargmin(values))

    @property
    def optimum_index(self) -> int:
        """Index of the time the curve's objective chooses."""
        return self.chosen_index()

    @property
    def optimum_time_s(self) -> float:
        return float(self.times_s[self.optimum_index])

    @property
    def optimum_inside(self) -> bool:
        """True when the chosen time is not the end of the explored range: the objective
        reached its floor within it (else the range may be too short)."""
        return self.optimum_index < self.times_s.size - 1

    def to_dict(self) -> dict:
        """JSON-ready curve (times s; figures in the units their names carry), the time each
        objective chooses, and the figures at the curve's objective's choice."""
        i = self.optimum_index

        def at(val: dict, j: int) -> dict:
            return {s: float(v[j]) for s, v in val.items()}

        return {
            "times_s": [float(t) for t in self.times_s],
            "objective": self.objective.value,
            "objective_tolerance": self.tolerance,
            "range_m": self.range_m,
            "combined": {key: [float(v) for v in val] for key, val in self.combined.items()},
            "combined_image_displacement_px_rms": [float(v) for v in self.combined_displacement_px],
            "lobes": [{"name": lb["name"], **{key: {s: [float(v) for v in arr] for s, arr in val.items()}
                                              for key, val in lb.items() if key != "name"}}
                      for lb in self.lobes],
            "chosen_time_s": {o.value: float(self.times_s[self.chosen_index(o)]) for o in PolishObjective},
            "optimum": {
                "time_s": self.optimum_time_s,
                "inside_range": self.optimum_inside,
                "objective": self.objective.value,
                "combined": {key: float(val[i]) for key, val in self.combined.items()},
                "combined_image_displacement_px_rms": float(self.combined_displacement_px[i]),
                "lobes": [{"name": lb["name"], **{key: at(val, i) for key, val in lb.items() if key != "name"}}
                          for lb in self.lobes],
            },
        }


def polish_curve(profile: Profile, mirror: Mirror, params: PolishParams,
                 times_s: Sequence[float] | np.ndarray | None = None, *,
                 process: Process | None = None, plan: LapPlan | None = None,
                 progress: bool = False) -> PolishCurve:
    """Figures against polishing time and the time params.objective chooses.

    times_s: s (default params.curve_times). Per lobe: slope error and normal deviation
    (clear aperture), form change (form_fit over it), image displacement (every usable pixel,
    optics.radial, on CURVE_BIN_PX bins), and with a resolved `process` (finish.Process: nose, feed set) the
    roughness, TIS and haze (optics.scatter). Both lobes: image displacement, slope error,
    the calibrated stereo residual and the uncalibrated depth error at
    params.objective_range_m (m).
    """
    from .calibrated_stereo import calibrated_depth_error, fit_calibration  # lazy: off the CLI's start-up path
    from .scatter import haze_figures, lobe_geometry  # lazy: optics.scatter off the CLI's start-up path

    times = params.curve_times if times_s is None else np.asarray(times_s, dtype=float)
    plan = lap_plan(profile, params) if plan is None else plan
    profiles = polish_series(profile, params, times, plan=plan)
    edge = params.clear_edge_mm
    px = [lobe_pixel_radii(mirror, k, bin_px=CURVE_BIN_PX) for k in (0, 1)]
    # The calibration's fit: every usable pixel whose made ray lands (radial_displacement is
    # NaN elsewhere), as a user's calibration and the tolerance analysis' fit them. Fitting
    # only inside the clear aperture (edge_mm off each edge) while the stereo residual is
    # judged over the whole band left the edge bands to the spline's extrapolation: on a
    # small mirror (a 6 mm lens: 0.5 mm of a 5 mm lobe) the residual then rose with every
    # minute of polishing (8-9 % at 2 m, against 0.13-0.25 % fitted over every pixel) and
    # the curve chose too short a polish or none (the paper's times are unchanged).
    in_clear = []
    for k in (0, 1):
        r = trace_lobe(mirror.lobes[k], mirror, k, px[k].radius_px).r
        in_clear.append(np.isfinite(r))
    geometry = (lobe_geometry(mirror, 0, bin_px=CURVE_BIN_PX), lobe_geometry(mirror, 1, bin_px=CURVE_BIN_PX)) \
        if process is not None else None
    elev = band_elevations(mirror)
    rng = params.objective_range_m
    keys = ["slope_error_rad", "normal_deviation_mm", "form_change_mm", "image_displacement_px"]
    if process is not None:
        keys += ["roughness_nm", "tis", "haze"]
    lobes: list[dict] = [{"name": lb.name} for lb in mirror.lobes]
    combined: dict[str, list[float]] = {k: [] for k in ("image_displacement_px", "slope_error_rad",
                                                        "stereo_residual_pct", "depth_error_pct")}
    bar = progress_bar(len(profiles), "polishing curve", progress)
    for t, prof in zip(times, profiles):
        surf = clear_surface_errors(prof, mirror, edge_mm=edge)
        form = form_change(prof, mirror, degree=params.form_degree, edge_mm=edge)
        haze = None
        if process is not None:
            haze = haze_figures(mirror, process, removal_mm=lambda k, r, t=t: plan.rate(k, r) * t,
                                compliance_mm=params.compliance_mm, wavelength_mm=params.wavelength_mm,
                                geometry=geometry)
        disp, pooled_disp, pooled_slope = [], [], []
        for k in (0, 1):
            d = radial_displacement(prof, mirror, k, px[k].radius_px)
            disp.append(d)
            w = px[k].count
            shown = weighted_stats(d, w)  # over the pixels the made lobe still images
            pooled_disp.append((shown["rms"], float(np.sum(w[np.isfinite(d)]))))
            lo_c, hi_c = clear_aperture(mirror, k, edge)
            pooled_slope.append((surf["lobes"][k]["slope_error_rad"]["rms"], hi_c - lo_c))
            figs = {"slope_error_rad": surf["lobes"][k]["slope_error_rad"],
                    "normal_deviation_mm": surf["lobes"][k]["normal_deviation_mm"],
                    "form_change_mm": form["lobes"][k]["form_change_mm"],
                    "image_displacement_px": shown}
            if haze is not None:
                figs.update({key: haze["lobes"][k][key] for key in ("roughness_nm", "tis", "haze")})
            for key in keys:
                slot = lobes[k].setdefault(key, {s: [] for s in figs[key]})
                for s, v in figs[key].items():
                    slot[s].append(v)
        combined["image_displacement_px"].append(pooled_rms(pooled_disp))
        combined["slope_error_rad"].append(pooled_rms(pooled_slope))
        cal = fit_calibration(prof, mirror, params.calibration_knot_px, displacements=[
            (px[k].radius_px[in_clear[k]], px[k].count[in_clear[k]], disp[k][in_clear[k]]) for k in (0, 1)])
        combined["stereo_residual_pct"].append(
            calibrated_depth_error(prof, mirror, [rng], calibration=cal, elevations=elev).at(rng)["rms"])
        combined["depth_error_pct"].append(depth_error_curve(prof, mirror, [rng], elevations=elev).at(rng)["rms"])
        bar.update(1)
    bar.close()
    for lb in lobes:
        for key in keys:
            lb[key] = {s: np.asarray(v) for s, v in lb[key].items()}
    return PolishCurve(times_s=times, lobes=lobes, combined={k: np.asarray(v) for k, v in combined.items()},
                       objective=params.objective, tolerance=params.objective_tolerance, range_m=rng,
                       profiles=profiles)


#: What each objective assumes of the camera that uses the mirror.
ASSUMPTIONS = {
    PolishObjective.STEREO: "calibrated",
    PolishObjective.IMAGE_DISPLACEMENT: "uncalibrated",
    PolishObjective.SLOPE_ERROR: "uncalibrated",
}


def trade_sentence(curve: PolishCurve) -> str:
    """The recommendation's assumption and the figure it trades: a calibrated objective
    against the uncalibrated depth error at the objective's range, an uncalibrated one
    against the calibrated stereo residual (before -> at the chosen time)."""
    i = curve.optimum_index
    c = curve.combined
    rng = f"{curve.range_m:g} m"
    if ASSUMPTIONS[curve.objective] == "calibrated":
        d = c["depth_error_pct"]
        return (f"It assumes a calibrated camera; uncalibrated, the depth error at {rng} goes "
                f"{d[0]:.3g} -> {d[i]:.3g} %.")
    d = c["stereo_residual_pct"]
    return (f"It assumes an uncalibrated camera; calibrated, the stereo residual at {rng} goes "
            f"{d[0]:.3g} -> {d[i]:.3g} %.")


def polish_summary(curve: PolishCurve, program: str) -> dict:
    """The chosen time (s), what the objective and image displacement are before and at it,
    the time each objective would choose, the form it costs per lobe (mm), and a sentence."""
    i = curve.optimum_index
    d = curve.to_dict()
    opt = d["optimum"]
    form = [lb["form_change_mm"] for lb in opt["lobes"]]
    word, unit = OBJECTIVE_WORDS[curve.objective]
    fig = OBJECTIVE_FIGURES[curve.objective]
    values = curve.combined[fig]
    disp = curve.combined_displacement_px
    chosen = d["chosen_time_s"]
    others = "; ".join(f"{OBJECTIVE_WORDS[o][0]} would choose {chosen[o.value] / 60:.0f} min"
                       for o in PolishObjective if o is not curve.objective)

    def fmt(v: float) -> str:
        return f"{v:.3g}"

    where = f" at {curve.range_m:g} m" if curve.objective is PolishObjective.STEREO else ""
    if i == 0:
        statement = (f"The {program} program's mirror is best left unpolished by {word}{where}: "
                     f"{fmt(values[0])} {unit} as machined, {fmt(values[-1])} {unit} after "
                     f"{curve.times_s[-1] / 60:.0f} min ({others}).")
    else:
        statement = (
            f"Polishing the {program} program's mirror for {curve.optimum_time_s / 60:.0f} min, the time "
            f"{word}{where} chooses ({fmt(values[0])} -> {fmt(values[i])} {unit}; {others}); "
            f"image displacement {disp[0]:.2f} -> {disp[i]:.2f} px RMS over both lobes, form change "
            f"{form[0]['rms'] * 1e3:.1f} um RMS on the inner lobe and {form[1]['rms'] * 1e3:.1f} um on the outer "
            f"(the lap's even removal; pre-compensation takes it out of the program)."
            + ("" if curve.optimum_inside else
               " The objective still falls at the end of the explored range: widen polish.curve_max_s."))
    statement += " " + trade_sentence(curve)
    return {
        "program": program,
        "objective": curve.objective.value,
        "assumption": ASSUMPTIONS[curve.objective],
        "range_m": curve.range_m,
        "optimum_time_s": curve.optimum_time_s,
        "optimum_inside_range": curve.optimum_inside,
        "chosen_time_s": chosen,
        "range_s": [float(curve.times_s[0]), float(curve.times_s[-1])],
        "objective_value": {"before": float(values[0]), "at_optimum": float(values[i]), "unit": unit},
        "image_displacement_px_rms": {"before": float(disp[0]), "at_optimum": float(disp[i])},
        "stereo_residual_pct": {"before": float(curve.combined["stereo_residual_pct"][0]),
                                "at_optimum": float(curve.combined["stereo_residual_pct"][i])},
        "depth_error_pct": {"before": float(curve.combined["depth_error_pct"][0]),
                            "at_optimum": float(curve.combined["depth_error_pct"][i])},
        "form_cost_mm": {lb["name"]: f for lb, f in zip(opt["lobes"], form)},
        "statement": statement,
    }


# --------------------------------------------------------------------------------------
# Form against facets


@dataclass(frozen=True)
class Decomposition:
    """A made surface split into the design plus its form, and the design plus its facets
    (everything but the form), with the depth error of each (%, RMS over the band at
    range_m, each point capped) and of the made surface itself; `removal` the depth error of
    the lap's removal on the design alone, when given."""

    range_m: float
    form: SampledProfile
    facets: SampledProfile
    figures: dict

    def to_dict(self) -> dict:
        return dict(self.figures)


def form_facet_decomposition(profile: Profile, mirror: Mirror, *, degree: int = 4, edge_mm: float = 0.0,
                             range_m: float = 2.0, removal_only: Profile | None = None,
                             knot_px: float | None = None, step_mm: float = 0.001) -> Decomposition:
    """Split (profile - design) per lobe into its form (form_fit: degree, clear aperture
    edge_mm; extended over the whole lobe) and its facets (the rest), build the design
    carrying each alone (sampled every step_mm, mm), and give each one's depth error at
    range_m (m): {"made", "form", "facets"[, "removal_only"]} -> stereo.DepthCurve.at(),
    and with knot_px (px) the calibrated stereo residual of each too."""
    from .calibrated_stereo import calibrated_depth_error  # lazy: optics.calibrated_stereo off the CLI's start-up path

    forms, facets = [], []
    for k, lobe in enumerate(mirror.lobes):
        fit = form_fit(profile, mirror, k, degree=degree, edge_mm=edge_mm)
        lo, hi = (0.0, mirror.r_junction) if k == 0 else (mirror.r_junction, mirror.r_max)
        r = _radii(lo, hi, int(round((hi - lo) / step_mm)) + 1, k)
        z0 = lobe.z(r)
        f = fit(r)
        forms.append(LobeSamples(r, z0 + f))
        facets.append(LobeSamples(r, np.asarray(profile.z(r)) - f))
    frame = {"r_junction": mirror.r_junction, "r_max": mirror.r_max, "vertex_z": mirror.vertex_z}
    form_p = SampledProfile(forms[0], forms[1], **frame)
    facet_p = SampledProfile(facets[0], facets[1], **frame)
    surfaces = {"made": profile, "form": form_p, "facets": facet_p}
    if removal_only is not None:
        surfaces["removal_only"] = removal_only
    figures: dict = {"range_m": range_m, "form_degree": degree, "clear_edge_mm": edge_mm,
                     "depth_error_pct": {n: depth_error_curve(p, mirror, [range_m]).at(range_m)
                                         for n, p in surfaces.items()}}
    if knot_px is not None:
        figures["stereo_residual_pct"] = {
            n: calibrated_depth_error(p, mirror, [range_m], knot_px=knot_px, clear_edge_mm=edge_mm,
                                      bin_px=CURVE_BIN_PX).at(range_m)
            for n, p in surfaces.items()}
    return Decomposition(range_m, form_p, facet_p, figures)
