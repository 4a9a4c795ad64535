"""The tolerance analysis as `lathe-mirror tolerance` runs it, in two steps so that every
refusal comes before any output is made: `tolerance_plan` (the programs and their checks,
or the measured file read and fitted), then `TolerancePlan.run` (the configured programs'
analysis, tolerance.runs, or the measured part's, tolerance.measured).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

from ..compute import active
from ..design import Mirror
from ..enums import Program
from ..job import MachiningJob, check_programs, design, polishing_curve
from ..measure.surface import measured_profile
from ..optimize.focus import design_blur_px
from ..polishing import PolishParams
from ..profile import Profile
from .measured import ENTRY, measured_tolerance
from .runs import ToleranceRuns, tolerance_runs

if TYPE_CHECKING:
    from ..settings import Settings


@dataclass
class TolerancePlan:
    """What `tolerance` analyses, checked: the configured programs' machining job, or the
    measured part's surface (`profile`, read from `path`)."""

    settings: Settings
    mirror: Mirror
    job: MachiningJob | None = None
    profile: Profile | None = None
    path: str | None = None

    @property
    def histograms(self) -> list[str]:
        """The names of the histograms `-o DIR` writes, one a program (or the measured part)."""
        entries = [ENTRY] if self.profile is not None else [p.value for p in self.settings.tolerance.programs]
        return [f"monte_carlo_{e}.png" for e in entries]

    def run(self, *, progress: bool = False, allocate: bool = False) -> ToleranceRuns:
        """The analysis (figures and every Monte Carlo run behind them); allocate: the
        least-cost tolerances that reach the target yield, for each program."""
        s = self.settings
        if self.profile is not None:
            out, results = measured_tolerance(self.mirror, s, self.profile, self.path, progress=progress,
                                              allocate=allocate)
            return ToleranceRuns(out, results)
        times = nominal_polish_times(s, self.job)
        return tolerance_runs(self.mirror, s, times, progress=progress, job=self.job,
                              allocate=s.tolerance.programs if allocate else (),
                              blur_px=design_blur_px(self.mirror, s))


def tolerance_plan(settings: Settings, measured: str | None = None) -> TolerancePlan:
    """The design, then either the measured file read and fitted against it (`measured`:
    its path; a bad file raises InputError) or the programs checked as every command
    checks them (job.check_programs, each program's MachiningJob.check)."""
    mirror = design(settings)
    if measured is not None:
        profile = measured_profile(measured, mirror, nose_radius_mm=settings.tool.nose_radius)
        return TolerancePlan(settings, mirror, profile=profile, path=measured)
    check_programs(settings, mirror)
    job = MachiningJob.from_settings(settings, mirror)  # the one machining job, each program a variant
    for program in settings.tolerance.programs:
        job.but(strategy=program.strategy).check()
    return TolerancePlan(settings, mirror, job)


def nominal_time_s(job: MachiningJob, program: Program, polish: PolishParams) -> float:
    """The polishing time (s) a program's part is given: the time `polish.objective`
    chooses on the polishing curve of its as-machined mirror."""
    made = job.but(strategy=program.strategy).made()
    return polishing_curve(made.profile, job.mirror, polish).optimum_time_s


def nominal_polish_times(settings: Settings, job: MachiningJob) -> dict[Program, float]:
    """Each configured program's nominal polishing time (s), the programs' polishing curves
    side by side on the active executor (serially they take a tenth of a 2,000-trial run
    on 2 cores)."""
    programs = list(settings.tolerance.programs)
    ex = active()
    if ex.workers == 1 or len(programs) < 2:
        return {p: nominal_time_s(job, p, settings.polish) for p in programs}
    with ex.bound((settings.polish, job)) as run:
        return dict(zip(programs, run.map(_polish_time, programs)))


def _polish_time(shared, program: Program) -> float:
    polish, job = shared
    return nominal_time_s(job, program, polish)
