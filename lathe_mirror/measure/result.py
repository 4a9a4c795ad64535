"""One measurement, start to end: the file read, fitted against the design, the machine
diagnosed against the program's nominal part; its figures as the JSON of `measure`."""

from __future__ import annotations

import os
from dataclasses import dataclass, replace
from pathlib import Path

from ..design import Mirror
from ..errors import InputError
from ..inputs import check_real, check_type, short
from ..profile import Profile
from .diagnose import Diagnosis, TouchOff, diagnose
from .fit import FitOptions, TraceFit, fit_trace, lobe_figures, profile_through_axis
from .readers import AreaMap, read_measurement
from .trace_checks import refuse_trace


@dataclass(frozen=True)
class Measurement:
    """A measured part: the fit (figures per lobe) and the machine's diagnosis (the verdict
    against the spec's form tolerance is the command's: iso10110 ranks above measure)."""

    fit: TraceFit
    diagnosis: Diagnosis
    areal: bool

    def __repr__(self) -> str:
        # one line: the fit holds the trace's arrays
        lobes = ", ".join(f"{lf.name} PV {lf.pv_um:.3g} um RMS {lf.rms_um:.3g} um" for lf in self.fit.lobes)
        return f"Measurement({self.fit.trace.source!r}, {'map' if self.areal else 'profile'}; {lobes})"

    def to_dict(self) -> dict:
        return {"source": self.fit.trace.source, "areal": self.areal, "fit": self.fit.to_dict(),
                "lobes": [lf.to_dict() for lf in self.fit.lobes],
                **({"conic_fit": self.fit.conic_params} if self.fit.conic_params else {}),
                "diagnosis": self.diagnosis.to_dict()}


def measure(path: str | Path, mirror: Mirror, nominal: Profile, programmed_nose_mm: float, *,
            fmt: str | None = None, options: FitOptions = FitOptions(),
            resolution_mm: float = 0.005, toolpath=None, touch_off: TouchOff = TouchOff()) -> Measurement:
    """Read `path` (readers.MeasuredFormat), fit it against `mirror` and diagnose the
    machine against `nominal`, the program's as-machined surface on a perfect machine cut
    with a nose of programmed_nose_mm (mm); toolpath: that program (its X directions: the
    backlash; None: backlash not judged); touch_off: how its offsets were set (the set-up
    sheet's convention). InputError naming `path` when the trace fails a check that needs
    no fit (measure.trace_checks: too few points, no x spread, no heights): no fit is spent
    on it."""
    _check_path(path, "measure: path")
    check_type(mirror, "measure: mirror", Mirror, "a Mirror (settings.mirror())")
    check_type(nominal, "measure: nominal", Profile, "a Profile (the program's as-machined surface)")
    check_real(programmed_nose_mm, "measure: programmed_nose_mm", unit="mm", above=0.0)
    check_real(resolution_mm, "measure: resolution_mm", unit="mm", above=0.0)
    check_type(options, "measure: options", FitOptions, "a FitOptions")
    data = read_measurement(path, fmt)
    areal = isinstance(data, AreaMap)
    trace = profile_through_axis(data, mirror) if areal else data
    refuse_trace(trace.x, trace.z, path)  # the checks that need no fit (measure.judge's first), before it
    fit = fit_trace(trace, mirror, nose_radius_mm=programmed_nose_mm, options=options)
    dg = diagnose(fit, nominal, programmed_nose_mm, resolution_mm=resolution_mm, toolpath=toolpath,
                  touch_off=touch_off)
    if dg.centre_pip is not None:  # the pip is the diagnosis's: the lobe's form figures are about it
        fit = without_pip(fit, 2.0 * abs(dg.centre_height_mm))
    return Measurement(fit, dg, areal)


def _check_path(path, what: str) -> None:
    if not isinstance(path, (str, os.PathLike)):
        raise InputError(f"{what} = {short(path)} ({type(path).__name__}): expected a measured file's path")


def without_pip(fit: TraceFit, radius_mm: float) -> TraceFit:
    """The fit with its lobe figures taken outside `radius_mm` of the axis (the centre pip,
    reported on its own by the diagnosis)."""
    used = fit.used & (fit.r > radius_mm)
    lobes, splines = [], []
    for k in (0, 1):
        lf, sp = lobe_figures(fit.mirror, k, fit.r, fit.resid, used, fit.options)
        if lf is not None:
            old = next((o for o in fit.lobes if o.name == lf.name), None)
            if old is not None and old.radius_mm is not None:
                lf = replace(lf, radius_mm=old.radius_mm, conic=old.conic)
            lobes.append(lf)
        splines.append(sp)
    step = (lobes[1].mean_um - lobes[0].mean_um) if len(lobes) == 2 else None
    return replace(fit, lobes=tuple(lobes), splines=tuple(splines), step_error_um=step)
