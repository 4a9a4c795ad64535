"""The pipeline: the house plan's arrows in order, on typed objects. It orchestrates only.

    Settings -> design -> plan toolpath -> machine (nose envelope) -> polish
             -> optics -> tolerance -> (the report lays it out; export/ writes files)

Where each arrow lives:
  job.py                    the machining job and the made mirror: plan, machine,
                            made_surface (the one builder), named_surface, the program checks
  shop/programs.py          the whole lathe program around a toolpath, simulated, with its sheet
  report/analysis.py        each made mirror's figures, curves, renders, range from the image
  report/polishing_study.py the report's polishing section
  tolerance/runs.py         Monte Carlo, sensitivity, allocation and the verdict per program

This module strings them together for the report (`report_figures`); the commands call
the rooms directly. Nothing here touches the disk.

Follow one made surface from the config to the report:

    settings = config.load("my.toml")              # typed, validated once
    mirror = design(settings)                      # Eqs. 3-6
    made = job.made_surface(mirror, settings.machine, settings.tool, Strategy.ARCS)
    made.profile                                   # the as-machined surface (camera frame)
    distortion_figures(made.profile, mirror)       # optics: the five figures per lobe

Millimetres and radians inside (ARCHITECTURE.md).
"""

from __future__ import annotations

import contextlib
import dataclasses
import math
from collections.abc import Callable
from typing import TYPE_CHECKING

from .compute import active
from .design_table import TABLE1_SWAP_NOTE, design_figures
from .enums import BEST, Program, Strategy
from .iso10110 import spec_of
from .job import MachiningJob, design
from .notes import NOTES
from .optics.camera_model import calibration_figures
from .optimize.focus import design_blur_px
from .optics.radial import corner_limit_px, used_extent
from .optics.stereo import depth_error_curve
from .optics.zones import zones_for
from .profile import ExactProfile, Profile
from .progress import Stages
from .report.analysis import (
    MIRRORS,
    ReportData,
    figure_definitions,
    mirror_figures,
    ranging_figures,
    render_mirrors,
    report_curves,
    strategy_table,
)
from .report.polishing_study import polishing_study
from .results.design import DesignFigures
from .results.made import MadeMirror, ZoneFigures
from .results.optics import DEPTH_REPORT_M, CalibrationFigures, DepthAt, StereoFigures
from .report.plots import report_plots
from .results.tolerance import ToleranceAnalysis
from .tolerance.runs import DEPTH_RANGES_M, tolerance_analysis

if TYPE_CHECKING:
    from .settings import Settings

#: The report's stages, in order (the progress display names them).
STAGES = ["design", "toolpaths", "polishing", "distortion", "stereo", "renders", "ranging", "tolerance"]



def report_figures(settings: Settings, *, progress: bool = False, renders: bool = True,
                   tolerance: bool = True, alongside: Callable[[], None] | None = None,
                   measured: Profile | None = None, plots: bool = False) -> ReportData:
    """Run every analysis stage on the settings: design, the toolpath of each strategy and
    its as-machined surface, polishing, the distortion of each made mirror, stereo depth
    error against range, renders, the tolerance analysis and the verdict. No files.
    measured: a measured part (measure.surface.MeasuredProfile) added to the mirrors'
    figures as "measured".

    The tolerance analysis needs only the polishing times: it runs in the background
    (lathe_mirror.compute) beside the stages after polishing and `alongside()` (the
    caller's own work, e.g. `run`'s programs and CAD), the same figures as in turn.
    plots: draw the report's plots that do not need the tolerance analysis while it runs
    (report.plots.report_plots; `write_report` draws the rest), not after it."""
    steps = Stages(STAGES, progress)
    steps.start("design")
    mirror = design(settings)
    r_used = used_extent(mirror, 0)[1]
    facts = {"r_used": r_used, "rho_used": corner_limit_px(mirror, mirror.r_junction - r_used),
             "baseline": mirror.baseline, "angle_2m": math.degrees(mirror.baseline / 2000.0)}
    data = ReportData(design=DesignFigures.from_dict(design_figures(mirror)),
                      notes=(TABLE1_SWAP_NOTE, *(n.format(**facts) for n in NOTES)),
                      definitions=figure_definitions(mirror),
                      spec=spec_of(settings))  # R, k, sag tables, ISO 10110 tolerances (lathe-mirror spec)
    steps.done()

    steps.start("toolpaths")
    job = MachiningJob.from_settings(settings, mirror)  # the one machining job every stage takes
    made, data.machine, data.toolpaths = strategy_table(job)
    steps.done()

    steps.start("polishing")
    data.polishing, polish_curves = polishing_study(settings, job, made, progress=progress)
    curve_paper, curve_best = polish_curves["paper"], polish_curves["best"]
    made["polished"] = curve_paper.profiles[curve_paper.optimum_index]
    steps.done()
    with contextlib.ExitStack() as stack:
        tol = None
        if tolerance:  # the tolerance analysis needs only the polishing times: it runs beside the rest
            times = {Program.PAPER: curve_paper.optimum_time_s, Program.BEST: curve_best.optimum_time_s}
            tol = stack.enter_context(active().background(_tolerance, (mirror, settings, times, job)))
        _optics_stages(data, made, mirror, settings, steps, renders, curve_paper.optimum_time_s, job, measured)
        if alongside is not None:
            alongside()
        if plots:
            data.plots = report_plots(data)
        steps.start("tolerance")
        if tol is not None:
            data.tolerance = ToleranceAnalysis.from_dict(tol.result())
        steps.done()
    steps.close()
    return data


def _tolerance(task) -> dict:
    """The report's tolerance analysis (in the background: no progress bars)."""
    mirror, settings, times, job = task
    return tolerance_analysis(mirror, settings, times, progress=False, job=job,
                              allocate=(Program.BEST,) if Program.BEST in settings.tolerance.programs else (),
                              blur_px=design_blur_px(mirror, settings))


def _optics_stages(data: ReportData, made: dict, mirror, settings, steps, renders: bool,
                   polish_time_s: float, job: MachiningJob, measured: Profile | None = None) -> None:
    """The stages after polishing but the tolerance: distortion, calibration, stereo,
    renders, ranging (into `data`)."""
    steps.start("distortion")
    made["exact"] = ExactProfile(mirror)

    zn = zones_for(settings, mirror)
    data.zones = ZoneFigures.from_dict({**zn.as_dict(), "text": zn.describe()})
    parts = {"exact": None, "paper": job.but(strategy=Strategy.PAPER), "best": job.but(strategy=BEST),
             "polished": job.but(strategy=Strategy.PAPER, polish_time_s=polish_time_s)}
    data.mirrors = {}
    for name in MIRRORS:  # which part each mirror is
        fig = mirror_figures(made[name], mirror, zn, edge_mm=settings.polish.clear_edge_mm)
        data.mirrors[name] = dataclasses.replace(
            fig, polish_time_s=polish_time_s if name == "polished" else None,
            made_mirror="the exact design" if parts[name] is None else parts[name].label)
    if measured is not None:  # report --surface measured:FILE: the part that came back
        data.mirrors["measured"] = dataclasses.replace(mirror_figures(measured, mirror, zn, edge_mm=settings.polish.clear_edge_mm),
                                                       made_mirror=f"the measured part: {measured!r}")
    data.made_mirror = MadeMirror.from_dict(job.to_dict())  # the made mirror every command describes by default
    data.calibration = CalibrationFigures.from_dict(
        calibration_figures(mirror, {n: made[n] for n in ("paper", "best", "polished")}, zones=zn))
    steps.done()

    steps.start("stereo")
    depth = {name: depth_error_curve(made[name], mirror, DEPTH_RANGES_M) for name in MIRRORS}
    data.stereo = StereoFigures(
        definition="depth error = 100 (R_made - R) / R, R from the stereo centre (midway between "
                   "the viewpoints), points across the common band; RMS, median and max over the band "
                   "of |depth error| capped at 100 % per point (a point not seen by both lobes counts "
                   "100 %); failed: points at the cap",
        baseline_mm=mirror.baseline,
        curves=dict(depth),
        at={name: DepthAt.from_dict(c.at(DEPTH_REPORT_M)) for name, c in depth.items()},
    )
    steps.done()

    data.made = made
    data.curves = report_curves(made, mirror)
    steps.start("renders")
    if renders:
        data.images, data.renders = render_mirrors(made, mirror, settings, zn)
    steps.done()

    steps.start("ranging")
    if renders:
        data.ranging, data.range_maps = ranging_figures(made, mirror, settings, zn)
    steps.done()
