"""Seeded Monte Carlo over the machine, the polishing and the assembly; the yield.

`prepare` does everything that does not vary per trial (the machined surfaces at each
lattice phase and nose-radius node, their polishing snapshots, the pixel sample);
`run_monte_carlo` draws the trials from numpy.random.default_rng(seed) in a fixed order
and evaluates them vectorised (tolerance.perturb). Same config and seed, same JSON bytes.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..design import Mirror
from .perturb import (
    NodeSurfaces,
    PixelSample,
    TrialFigures,
    Trials,
    build_nodes,
    evaluate,
    pixel_sample,
)
from .spec import Distribution, Program, ToleranceSettings

#: Polishing-time snapshots per machined surface, as fractions of the time tolerance.
TIME_NODES = (-1.0, -0.5, 0.0, 0.5, 1.0)
#: Nose radii of the machined node surfaces, as fractions of the nose tolerance.
NOSE_NODES = (-1.0, -0.5, 0.0, 0.5, 1.0)


@dataclass(frozen=True)
class Context:
    """What every trial shares: the mirror, the node surfaces, the pixel samples, nominals."""

    mirror: Mirror
    settings: ToleranceSettings
    nodes: NodeSurfaces
    samples: tuple[PixelSample, PixelSample]
    nominal_nose_mm: float
    nominal_time_s: float
    source: str
    program: Program


@dataclass
class MonteCarloResult:
    """Trials, their figures, pass flags per criterion and the yield."""

    trials: Trials
    figures: TrialFigures
    passed: dict[str, np.ndarray]
    settings: ToleranceSettings
    program: Program

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
        """JSON-ready: yield, pass fraction per criterion, distributions (mean, p05, p50, p95,
        max) of the per-lobe figures (px, rad, mm) and of the depth error (%); per_trial adds
        every trial's parameters and figures."""
        f = self.figures
        lobes = []
        for k, name in enumerate(("inner", "outer")):
            lobes.append({"name": name,
                          "image_displacement_px": _dist(f.image_displacement_px_rms[:, k]),
                          "slope_error_rad": _dist(f.slope_error_rad_rms[:, k]),
                          "normal_deviation_mm": _dist(f.normal_deviation_mm_rms[:, k])})
        out = {
            "program": self.program.value,
            "seed": self.settings.seed,
            "trials": len(self.trials),
            "yield": self.yield_fraction,
            "pass_fraction": {k: float(np.mean(v)) for k, v in self.passed.items()},
            "spec": self.settings.spec.__dict__,
            "lobes": lobes,
            "depth_error_pct": _dist(f.depth_error_pct_rms),
            "lost_pixel_fraction": _dist(f.lost_fraction),
            "note": "per-trial figures are RMS over each lobe's pixels (image displacement), its "
                    "radii (slope error, normal deviation) or the band's points (depth error); "
                    "distributions give the mean and percentiles over trials",
        }
        if per_trial:
            out["per_trial"] = {
                **{k: [float(x) for x in v] for k, v in self.trials.__dict__.items()},
                "image_displacement_px_rms": f.image_displacement_px_rms.tolist(),
                "slope_error_rad_rms": f.slope_error_rad_rms.tolist(),
                "depth_error_pct_rms": f.depth_error_pct_rms.tolist(),
                "pass": [bool(x) for x in self.pass_all],
            }
        return out


def prepare(mirror: Mirror, settings: ToleranceSettings, polish_params, nominal_time_s: float,
            program: Program, *, nose0: float, machine_at: Callable, progress: bool = False) -> Context:
    """Machined surfaces at each lattice phase x nose node, polished at the time nodes.

    nose0: the programmed nose radius, mm. machine_at(phase, nose_radius) -> a made surface
    (attributes profile, source): the pipeline's made-surface builder for this program,
    the part cut with its work zero `phase` lattice steps off and a nose of nose_radius mm.
    """
    tol = settings.tolerances
    dn = tol.get("nose_radius_mm", 0.0)
    # Five nose nodes: a nose larger than the program's rounds the step's sharp top edge,
    # a feature that grows non-linearly with the excess; linear interpolation needs the
    # nodes close together to follow it.
    # (settings.py has checked dn <= nose0: no node has a negative nose.)
    nose_nodes = nose0 + dn * np.array(NOSE_NODES) if dn > 0 else np.array([nose0])
    dt = tol.get("polish_time_s", 0.0)
    times = np.unique(np.clip([nominal_time_s + f * dt for f in TIME_NODES], 0.0, None))
    phases = np.arange(settings.lattice_phases) / settings.lattice_phases
    bar = _bar(len(phases) * len(nose_nodes), f"tolerance ({program.value}): machining + polishing", progress)
    machined = []
    source = ""
    for ph in phases:
        row = []
        for nose in nose_nodes:
            made = machine_at(float(ph), float(nose))
            if ph == 0.0 and math.isclose(nose, nose0):
                source = made.source
            row.append(made.profile)
        machined.append(row)
    nodes = build_nodes(mirror, machined, nose_nodes, phases, polish_params, times, source=source,
                        progress=bar)
    bar.close()
    samples = (pixel_sample(mirror, 0, bin_px=settings.bin_px, azimuths=settings.azimuths),
               pixel_sample(mirror, 1, bin_px=settings.bin_px, azimuths=settings.azimuths))
    return Context(mirror, settings, nodes, samples, nose0, float(nominal_time_s), source, program)


def draw_trials(ctx: Context, n: int | None = None, seed: int | None = None) -> Trials:
    """Trials drawn from default_rng(seed), parameters in a fixed order."""
    s = ctx.settings
    n = s.trials if n is None else n
    rng = np.random.default_rng(s.seed if seed is None else seed)
    tol = s.tolerances

    def draw(key: str, scale: float = 1.0) -> np.ndarray:
        t = tol.get(key, 0.0) * scale
        if s.distribution is Distribution.NORMAL:
            return rng.normal(0.0, t / 3.0, n)
        return rng.uniform(-t, t, n)

    phase = rng.integers(0, len(ctx.nodes.phases), n)
    nose = ctx.nominal_nose_mm + draw("nose_radius_mm")
    time = np.maximum(ctx.nominal_time_s + draw("polish_time_s"), 0.0)
    tx, tz = draw("tool_x_mm"), draw("tool_z_mm")
    cx, cy = draw("camera_decentre_mm"), draw("camera_decentre_mm")
    cz = draw("camera_axial_mm")
    deg = math.pi / 180.0
    ax, ay = draw("camera_tilt_deg", deg), draw("camera_tilt_deg", deg)
    return Trials(phase=phase.astype(np.intp), nose_mm=np.maximum(nose, 0.0), time_s=time, tool_x_mm=tx,
                  tool_z_mm=tz, cam_x_mm=cx, cam_y_mm=cy, cam_z_mm=cz, tilt_x=ax, tilt_y=ay)


def evaluate_trials(ctx: Context, trials: Trials, *, progress: bool = False, desc: str = "tolerance: trials",
                    **kw) -> TrialFigures:
    """Figures of each trial (tolerance.perturb.evaluate) at the spec's depth range (m), with
    a progress bar on stderr when asked."""
    bar = _bar(len(trials), desc, progress)
    fig = evaluate(ctx.mirror, ctx.nodes, trials, ctx.samples, depth_range_m=ctx.settings.spec.depth_range_m,
                   depth_points=ctx.settings.depth_points, progress=bar, **kw)
    bar.close()
    return fig


def judge(figures: TrialFigures, settings: ToleranceSettings) -> dict[str, np.ndarray]:
    """Pass flags of each criterion of the spec, per trial (both lobes must pass)."""
    sp = settings.spec
    return {
        "image_displacement_px": np.all(figures.image_displacement_px_rms <= sp.image_displacement_px, axis=1),
        "depth_error_pct": figures.depth_error_pct_rms <= sp.depth_error_pct,
        "slope_error_rad": np.all(figures.slope_error_rad_rms <= sp.slope_error_rad, axis=1),
    }


def run_monte_carlo(ctx: Context, *, progress: bool = False) -> MonteCarloResult:
    """Draw settings.trials trials from settings.seed, evaluate them and judge them: same
    context and seed, same result to the bit."""
    trials = draw_trials(ctx)
    fig = evaluate_trials(ctx, trials, progress=progress)
    return MonteCarloResult(trials, fig, judge(fig, ctx.settings), ctx.settings, ctx.program)


def _dist(x: np.ndarray) -> dict:
    x = np.asarray(x, float)
    return {"mean": float(np.mean(x)), "p05": float(np.percentile(x, 5)), "p50": float(np.percentile(x, 50)),
            "p95": float(np.percentile(x, 95)), "max": float(np.max(x))}


def _bar(total: int, desc: str, enabled: bool):
    from ..progress import bar

    return bar(total, desc, enabled)
