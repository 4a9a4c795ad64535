"""Seeded Monte Carlo over the machine, the polishing and the assembly; the yield.

`prepare` does what does not vary per trial (the program cut at each lattice phase, the
pixel sample, the spec's limits); `run_monte_carlo` draws the trials from
numpy.random.default_rng(seed) in a fixed order, cuts the nose radii they drew
(tolerance.surfaces) and evaluates them vectorised (tolerance.perturb), raw and after
calibration. Same config and seed, same JSON bytes. Every yield is quoted with its
Wilson 95 % interval and its trial count.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from ..compute import active
from ..compute import blocks as split_blocks
from ..design import Mirror
from ..optics.ranging.resolution import parallax_per_px
from ..optics.stereo import band_elevations
from ..optics.zones import zones as zones_of
from ..progress import bar
from .calibration import Calibration
from .delivered import DeliveredRange, delivered_range
from .perturb import (
    LOBE_FIGURES,
    STEREO_FIGURES,
    TrialFigures,
    Trials,
    batch_trials,
    evaluate,
)
from .samples import PixelSample, matching_floor_pct, pixel_sample
from .registry import REGISTRY, standard_draws, tolerances_of
from .spec import DRAWN, Program, ToleranceSettings
from .stats import wilson
from .surfaces import SurfaceBank, time_nodes

#: The judged criteria, in order.
#: The disparity criterion's quantile: 90 % of the band's points seen and within the limit.
DISPARITY_QUANTILE = 0.9
CRITERIA = ("image_displacement_px", "outlier_pct", "disparity_px", "slope_error_rad")
#: A pixel whose image displacement exceeds this many times the spec's limit is an outlier
#: (perturb.evaluate): it leaves the RMS and counts in outlier_pct.
OUTLIER_FACTOR = 5.0


@dataclass
class Context:
    """What every trial of one program's part shares: the mirror, its made surfaces, the
    pixel samples, the nominal nose (mm) and polishing time (s), the judged limits."""

    mirror: Mirror
    settings: ToleranceSettings
    bank: SurfaceBank
    samples: tuple[PixelSample, PixelSample]
    nominal_nose_mm: float
    nominal_time_s: float
    source: str
    program: Program
    limits: dict[str, float]
    progress: bool = False
    zones: object = None   # optics.zones.Zones: the pixels and radii the criteria judge
    cut_plus_x: bool = True  # the finishing pass runs in +X (axis -> rim): backlash shifts it
    blur_px: float = 0.0  # the design's defocus blur circle (px; tolerance.delivered)
    band: tuple[float, float] | None = None  # elevations (rad) R10 is the median over; None: common band

    def ensure(self, trials: Trials, progress: bool | None = None) -> None:
        """Cut and polish every nose the trials drew that is not made yet."""
        new = self.bank.missing(trials.nose_mm)
        if new.size == 0:
            return
        bar = _bar(int(new.size), f"tolerance ({self.program.value}): cutting the noses drawn",
                   self.progress if progress is None else progress)
        self.bank.ensure(trials.nose_mm, progress=bar)
        bar.close()


@dataclass
class MonteCarloResult:
    """Trials, their figures, pass flags per criterion and the yield."""

    trials: Trials
    figures: TrialFigures
    passed: dict[str, np.ndarray]
    settings: ToleranceSettings
    program: Program
    limits: dict[str, float]
    tolerances: dict[str, float]
    seed: int
    nominal_nose_mm: float = 0.0
    nominal_time_s: float = 0.0
    phases: np.ndarray = field(default_factory=lambda: np.zeros(1))
    zones: object = None   # optics.zones.Zones the figures cover
    delivered: DeliveredRange | None = None  # the range each trial's part delivers

    @property
    def pass_all(self) -> np.ndarray:
        out = np.ones(len(self.trials), dtype=bool)
        for v in self.passed.values():
            out &= v
        return out

    @property
    def yield_fraction(self) -> float:
        return float(np.mean(self.pass_all))

    def to_dict(self, *, per_trial: bool = True) -> dict:
        """JSON-ready: the yield and each criterion's pass fraction with Wilson 95 %
        intervals, the limits, distributions over trials (mean, p05, p50, p95, max) of the
        raw and calibrated figures; per_trial adds every trial's parameters and figures."""
        f = self.figures
        n = len(self.trials)
        k_pass = int(np.sum(self.pass_all))
        judged = f.judged(self.settings.spec.calibrated)

        def figs(d: dict) -> dict:
            out = {"lobes": [{"name": name, **{key: _dist(d[key][:, k]) for key in LOBE_FIGURES}}
                             for k, name in enumerate(("inner", "outer"))]}
            out.update({key: _dist(d[key][:, 0]) for key in STEREO_FIGURES})
            return out

        out = {
            "program": self.program.value,
            "seed": self.seed,
            "trials": n,
            "calibrated": self.settings.spec.calibrated,
            "tolerances": dict(self.tolerances),
            "yield": k_pass / n,
            "passed": k_pass,
            "yield_wilson95": list(wilson(k_pass, n)),
            "pass_fraction": {c: float(np.mean(v)) for c, v in self.passed.items()},
            "pass_fraction_wilson95": {c: list(wilson(int(np.sum(v)), n)) for c, v in self.passed.items()},
            "limits": dict(self.limits),
            "spec": self.settings.spec_dict(),
            "judged": {"image_displacement_px": _dist(np.max(judged["image_displacement_px_rms"], axis=1)),
                       "outlier_pct": _dist(np.max(judged["outlier_pct"], axis=1)),
                       "disparity_px": _dist(judged["disparity_px_p90"][:, 0]),
                       "slope_error_rad": _dist(np.max(f.slope_error_rad_rms, axis=1))},
            **({} if self.delivered is None else {"delivered_r10_m": self.delivered.summary(),
                                                  "delivered": self.delivered.to_dict()}),
            "raw": figs(f.raw),
            "calibrated_figures": figs(f.calibrated),
            "surface": {"lobes": [{"name": name, "slope_error_rad": _dist(f.slope_error_rad_rms[:, k]),
                                   "normal_deviation_mm": _dist(f.normal_deviation_mm_rms[:, k])}
                                  for k, name in enumerate(("inner", "outer"))]},
            "lost_pixel_fraction": _dist(f.lost_fraction),
            "zones": None if self.zones is None else self.zones.as_dict(),
            "calibration_rotation_deg": _dist(np.degrees(_rotation_angle(f.calibration.rotation))),
            "note": "per-trial figures: RMS over each lobe's pixels (image displacement, ray error, viewpoint "
                    "spread), over its radii (slope error, normal deviation); stereo figures over the band's "
                    "points at the spec's range (disparity px: the point value with 50 % / 90 % of the points "
                    "at or below it, over the points both lobes see; seen_fraction counts the others); distributions give the mean and "
                    "percentiles over trials",
        }
        if per_trial:
            out["per_trial"] = {**self.parameter_columns(),
                                "image_displacement_px_rms": judged["image_displacement_px_rms"].tolist(),
                                "outlier_pct": judged["outlier_pct"].tolist(),
                                "disparity_px_p90": judged["disparity_px_p90"][:, 0].tolist(),
                                "slope_error_rad_rms": f.slope_error_rad_rms.tolist(),
                                "depth_error_pct_rms": judged["depth_error_pct_rms"][:, 0].tolist(),
                                **({} if self.delivered is None else {
                                    "delivered_r10_m": self.delivered.r10_m.tolist(),
                                    "delivered_depth_error_pct": self.delivered.depth_error_pct.tolist()}),
                                "pass": [bool(x) for x in self.pass_all]}
        return out

    def parameter_columns(self) -> dict[str, list]:
        """Each trial's drawn parameters, edge units (phase in lattice steps, tilts in deg)."""
        t = self.trials
        deg = 180.0 / math.pi
        return {"phase_steps": [float(self.phases[i]) for i in t.phase], "nose_mm": t.nose_mm.tolist(),
                "polish_time_s": t.time_s.tolist(), "tool_x_mm": t.tool_x_mm.tolist(),
                "tool_z_mm": t.tool_z_mm.tolist(), "camera_x_mm": t.cam_x_mm.tolist(),
                "camera_y_mm": t.cam_y_mm.tolist(), "camera_axial_mm": t.cam_z_mm.tolist(),
                "camera_tilt_x_deg": (t.tilt_x * deg).tolist(), "camera_tilt_y_deg": (t.tilt_y * deg).tolist(),
                "seat_tilt_x_deg": (t.seat_x * deg).tolist(), "seat_tilt_y_deg": (t.seat_y * deg).tolist()}

    def __repr__(self) -> str:
        return (f"MonteCarloResult(program={self.program.value}, trials={len(self.trials)}, seed={self.seed}, "
                f"yield={self.yield_fraction:.4g}, nominal_time_s={self.nominal_time_s:g})")

    def table(self) -> np.ndarray:
        """One row per trial as a numpy structured array: the CSV's columns (csv_rows;
        run "api"): the drawn parameters, every raw and calibrated figure, the pass flags."""
        header, rows = self.csv_rows("api")
        cols = [np.asarray(c) for c in zip(*rows)] if rows else [np.zeros(0) for _ in header]
        out = np.empty(len(rows), dtype=[(name, c.dtype) for name, c in zip(header, cols)])
        for name, c in zip(header, cols):
            out[name] = c
        return out

    def csv_rows(self, run: str) -> tuple[list[str], list[list]]:
        """Header and one row per trial: the drawn parameters, every raw and calibrated
        figure (per lobe for the lobe figures), the surface figures, the fitted rotation,
        each criterion's pass flag and the trial's."""
        f = self.figures
        cols: dict[str, list] = {"program": [self.program.value] * len(self.trials), "run": [run] * len(self.trials),
                                 "trial": list(range(len(self.trials))), **self.parameter_columns()}
        for label, d in (("raw", f.raw), ("cal", f.calibrated)):
            for key in LOBE_FIGURES:
                for k, lobe in enumerate(("inner", "outer")):
                    cols[f"{label}_{key}_{lobe}"] = d[key][:, k].tolist()
            for key in STEREO_FIGURES:
                cols[f"{label}_{key}"] = d[key][:, 0].tolist()
        for k, lobe in enumerate(("inner", "outer")):
            cols[f"slope_error_rad_rms_{lobe}"] = f.slope_error_rad_rms[:, k].tolist()
            cols[f"normal_deviation_mm_rms_{lobe}"] = f.normal_deviation_mm_rms[:, k].tolist()
        cols["lost_pixel_fraction"] = f.lost_fraction.tolist()
        ang = f.calibration.angles_deg()
        for i, axis in enumerate("xyz"):
            cols[f"cal_rotation_{axis}_deg"] = ang[:, i].tolist()
        if self.delivered is not None:
            cols["delivered_r10_m"] = self.delivered.r10_m.tolist()
            cols["delivered_depth_error_pct"] = self.delivered.depth_error_pct.tolist()
        for c, v in self.passed.items():
            cols[f"pass_{c}"] = [bool(x) for x in v]
        cols["pass"] = [bool(x) for x in self.pass_all]
        header = list(cols)
        return header, [list(row) for row in zip(*cols.values())]


def disparity_limit_px(mirror: Mirror, depth_error_pct: float, depth_range_m: float, n_elev: int) -> float:
    """The disparity-equivalent limit (px) of a depth-error limit (%) at a range (m): the
    parallax error depth_error_pct / 100 x B cos(el) / R (first order) over the parallax one
    pixel stands for (optics.ranging.resolution.parallax_per_px), at the band's median
    elevation. 20 % at 1 m on the paper
    mirror: 2.5 mrad, 0.44 px."""
    el = float(np.median(band_elevations(mirror, max(n_elev, 2))))
    parallax = mirror.baseline * math.cos(el) / (depth_range_m * 1e3)
    return float(depth_error_pct / 100.0 * parallax / parallax_per_px(mirror, np.array([el]))[0])


def prepare(mirror: Mirror, settings: ToleranceSettings, polish_params, nominal_time_s: float,
            program: Program, *, nose0: float, machine_at: Callable, progress: bool = False,
            leave_junction: bool = True, zones=None) -> Context:
    """The program's part cut at each lattice phase with the programmed nose, polished at
    the time nodes (nominal -/+ the time tolerance); noses are cut as trials draw them.

    nose0: the programmed nose radius, mm. machine_at(phase, nose_radius) -> a made surface
    (attributes profile, source): the pipeline's made-surface builder for this program,
    the part cut with its work zero `phase` lattice steps off and a nose of nose_radius mm.
    leave_junction: polish each nose's part without the groove or rim its nose leaves at
    the step (put back as cut); False polishes the part as cut (tolerance.surfaces).
    """
    tol = settings.tolerances
    times = time_nodes(nominal_time_s, tol.get("polish_time_s", 0.0))
    phases = np.arange(settings.lattice_phases) / settings.lattice_phases
    bar = _bar(len(phases), f"tolerance ({program.value}): cutting the lattice phases", progress)
    bank = SurfaceBank(mirror, machine_at, polish_params, times, phases, nose0, settings.nose_step_mm,
                       leave_junction=leave_junction, progress=bar)
    bar.close()
    # the pixels and radii the criteria judge (optics.zones: default without the lattice's guard)
    zn = zones_of(mirror, float(nose0), float(tol.get("nose_radius_mm", 0.0))) if zones is None else zones
    samples = (pixel_sample(mirror, 0, bin_px=settings.bin_px, azimuths=settings.azimuths, zones=zn),
               pixel_sample(mirror, 1, bin_px=settings.bin_px, azimuths=settings.azimuths, zones=zn))
    sp = settings.spec
    limits = {"image_displacement_px": sp.image_displacement_px, "outlier_pct": sp.outlier_pct,
              "disparity_px": disparity_limit_px(mirror, sp.depth_error_pct, sp.depth_range_m, settings.depth_points),
              "slope_error_rad": sp.slope_error_rad}
    return Context(mirror, settings, bank, samples, float(nose0), float(nominal_time_s), bank.source, program,
                   limits, progress, zn)


def draw_trials(ctx: Context, n: int | None = None, seed: int | None = None,
                tolerances: dict[str, float] | None = None) -> Trials:
    """Trials drawn from default_rng(seed): the lattice phase, then every registered
    parameter's standard draws in REGISTRY's order (x before y), taken whatever the
    tolerances and scaled by `tolerances` (any of REGISTRY's keys; default the settings'
    params and machine errors). Common random numbers: the same seed gives nested samples
    (tolerance.registry), so tightening a tolerance moves only that parameter's values,
    each to the same fraction of its old one."""
    s = ctx.settings
    n = s.trials if n is None else n
    rng = np.random.default_rng(s.seed if seed is None else seed)
    tol = tolerances_of(s, tolerances)
    if not ctx.cut_plus_x:  # a finishing pass run in -X takes up the lost motion before it cuts
        tol["backlash_mm"] = 0.0
    phase = rng.integers(0, len(ctx.bank.phases), n)
    std = standard_draws(rng, n, s.distribution)
    tr = Trials.nominal(n, ctx.nominal_nose_mm, ctx.nominal_time_s)
    tr.phase = phase.astype(np.intp)
    for p in REGISTRY:
        p.add(tr, p.offsets(std[p.key], tol[p.key], s.distribution))
    # The nose is cut as drawn, rounded to the nose step; never at or below zero.
    tr.nose_mm = ctx.bank.snapped(np.maximum(tr.nose_mm, ctx.bank.nose_step))
    return tr


def evaluate_trials(ctx: Context, trials: Trials, *, progress: bool = False, desc: str = "tolerance: trials",
                    ranges_m=None, **kw) -> TrialFigures:
    """Figures of each trial (tolerance.perturb.evaluate) at ranges_m (m; default the
    spec's range), the noses they drew cut first, with a progress bar when asked."""
    ctx.ensure(trials, progress)
    bar = _bar(len(trials), desc, progress)
    ranges = (ctx.settings.spec.depth_range_m,) if ranges_m is None else tuple(ranges_m)
    args = dict(ranges_m=ranges, depth_points=ctx.settings.depth_points, seat_pivot_mm=ctx.settings.seat_pivot_mm,
                outlier_px=OUTLIER_FACTOR * ctx.limits["image_displacement_px"], zones=ctx.zones, **kw)
    ex = active()
    batch = batch_trials(ctx.samples, kw.get("chunk", 100))
    n = len(trials)
    if ex.workers == 1 or n <= batch or kw.get("keep_displacements"):
        fig = evaluate(ctx.mirror, ctx.bank, trials, ctx.samples, progress=bar, **args)
    else:
        # Blocks of whole batches (the serial run's batches: the same figures to the bit),
        # as even as whole batches allow, several per worker (compute.blocks).
        blocks = [trials.take(s) for s in split_blocks(n, batch, ex.workers)]
        with ex.bound(_Shared(ctx.mirror, ctx.bank, ctx.samples, args)) as run:
            fig = _concat(run.map(_evaluate_block, blocks, progress=bar))
    bar.close()
    return fig


@dataclass(frozen=True)
class _Shared:
    """What every block of trials is evaluated against (held once by each worker)."""

    mirror: Mirror
    bank: SurfaceBank
    samples: tuple[PixelSample, PixelSample]
    args: dict


def _evaluate_block(shared: _Shared, trials: Trials) -> TrialFigures:
    return evaluate(shared.mirror, shared.bank, trials, shared.samples, **shared.args)


def _concat(parts: list[TrialFigures]) -> TrialFigures:
    """The figures of consecutive blocks of trials, as one (no `extra`)."""
    def cat(get):
        return np.concatenate([get(p) for p in parts])

    first = parts[0]
    return TrialFigures({k: cat(lambda p: p.raw[k]) for k in first.raw},
                        {k: cat(lambda p: p.calibrated[k]) for k in first.calibrated},
                        cat(lambda p: p.slope_error_rad_rms), cat(lambda p: p.normal_deviation_mm_rms),
                        cat(lambda p: p.lost_fraction),
                        Calibration(cat(lambda p: p.calibration.rotation), cat(lambda p: p.calibration.coeffs),
                                    first.calibration.span), first.ranges_m)


def judge(figures: TrialFigures, limits: dict[str, float], calibrated: bool) -> dict[str, np.ndarray]:
    """Pass flags of each criterion per trial (both lobes must pass): the RMS image
    displacement and the outlier pixels' share, the 90th percentile of the disparity-equivalent error over the band at
    the spec's range (the first range of the figures; over the points both lobes see, and
    at least DISPARITY_QUANTILE of the band's points seen), the RMS slope error; calibrated or
    raw figures."""
    d = figures.judged(calibrated)
    return {
        "image_displacement_px": np.all(d["image_displacement_px_rms"] <= limits["image_displacement_px"], axis=1),
        "outlier_pct": np.all(d["outlier_pct"] <= limits["outlier_pct"], axis=1),
        "disparity_px": (d["disparity_px_p90"][:, 0] <= limits["disparity_px"])
        & (d["seen_fraction"][:, 0] >= DISPARITY_QUANTILE),
        "slope_error_rad": np.all(figures.slope_error_rad_rms <= limits["slope_error_rad"], axis=1),
    }


def run_monte_carlo(ctx: Context, *, progress: bool = False, seed: int | None = None,
                    tolerances: dict[str, float] | None = None, desc: str = "tolerance: trials") -> MonteCarloResult:
    """Draw settings.trials trials from `seed` (default settings.seed) within `tolerances`
    (default the settings'), evaluate and judge them: same context and seed, same result
    to the bit."""
    tol = dict(ctx.settings.tolerances if tolerances is None else tolerances)
    seed = ctx.settings.seed if seed is None else seed
    trials = draw_trials(ctx, seed=seed, tolerances=tol)
    fig = evaluate_trials(ctx, trials, progress=progress, desc=desc)
    return MonteCarloResult(trials, fig, judge(fig, ctx.limits, ctx.settings.spec.calibrated), ctx.settings,
                            ctx.program, dict(ctx.limits), {k: tol.get(k, 0.0) for k in DRAWN}, seed,
                            ctx.nominal_nose_mm, ctx.nominal_time_s, ctx.bank.phases, ctx.zones,
                            delivered_of(ctx, fig))


def delivered_of(ctx: Context, fig: TrialFigures) -> DeliveredRange:
    """The range each trial's part delivers (tolerance.delivered): its disparity error
    (calibrated or raw as the spec judges, the band's median at the spec's range), the
    context's blur and the matcher's noise."""
    d = fig.judged(ctx.settings.spec.calibrated)["disparity_px_median"][:, 0]
    return delivered_range(ctx.mirror, d, blur_px=ctx.blur_px, matching_noise_px=ctx.settings.matching_noise_px,
                           range_m=ctx.settings.spec.depth_range_m, band=ctx.band)


def stereo_table(ctx: Context, ranges_m) -> dict:
    """The nominal part's stereo figures at each range (m), raw and calibrated, beside the
    matcher's floor: per range the band's median and 90th-percentile disparity-equivalent
    error (px), the fractions of its points within 5 % and 10 % of their range and seen
    by both lobes, the capped RMS depth error (%), and the depth error (%) that
    matching_noise_px alone gives."""
    fig = evaluate_trials(ctx, Trials.nominal(1, ctx.nominal_nose_mm, ctx.nominal_time_s), ranges_m=ranges_m)
    floor = matching_floor_pct(ctx.mirror, ranges_m, ctx.settings.matching_noise_px, ctx.settings.depth_points)
    out = {"ranges_m": [float(r) for r in ranges_m], "matching_noise_px": ctx.settings.matching_noise_px,
           "matching_floor_pct": [float(x) for x in floor], "disparity_limit_px": ctx.limits["disparity_px"]}
    for label, d in (("raw", fig.raw), ("calibrated", fig.calibrated)):
        out[label] = {key: [float(x) for x in d[key][0]] for key in STEREO_FIGURES}
    return out

def _rotation_angle(r: np.ndarray) -> np.ndarray:
    """Angle (rad) of each rotation matrix (trials, 3, 3)."""
    c = (np.trace(r, axis1=1, axis2=2) - 1.0) / 2.0
    s = np.linalg.norm(np.stack([r[:, 2, 1] - r[:, 1, 2], r[:, 0, 2] - r[:, 2, 0], r[:, 1, 0] - r[:, 0, 1]], 1),
                       axis=1) / 2.0
    return np.arctan2(s, c)


def _dist(x: np.ndarray) -> dict:
    x = np.asarray(x, float)
    fin = np.where(np.isfinite(x), x, np.inf)
    return {"mean": float(np.mean(x)) if np.all(np.isfinite(x)) else math.inf,
            "p05": float(np.quantile(fin, 0.05, method="inverted_cdf")),
            "p50": float(np.quantile(fin, 0.50, method="inverted_cdf")),
            "p95": float(np.quantile(fin, 0.95, method="inverted_cdf")), "max": float(np.max(fin))}


def _bar(total: int, desc: str, enabled: bool):
    return bar(total, desc, enabled)
