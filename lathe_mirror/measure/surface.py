"""The measured part as a surface every command takes (`--surface measured:FILE`): the
design plus the fitted, axisymmetric residual (each lobe's smoothed residual folded about
the fitted axis; measure.fit), camera frame."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..design import Mirror
from ..errors import InputError
from ..inputs import check_real, check_type, short
from ..profile import ExactProfile, Profile
from .diagnose import centre_pip
from .fit import FitOptions, TraceFit, fit_trace, profile_through_axis
from .readers import AreaMap, read_measurement
from .result import without_pip


class MeasuredProfile(Profile):
    """The made part as measured: z(r) = design z(r) - residual(r) (the residual is measured
    minus design in the machine frame, Z = vertex - z), per lobe; beyond a lobe's measured
    extent its residual is held at its end value."""

    def __init__(self, fit: TraceFit):
        m = fit.mirror
        self.fit = fit
        self._exact = ExactProfile(m)
        self._d = [None if sp is None else sp.derivative() for sp in fit.splines]
        super().__init__(r_junction=m.r_junction, r_max=m.r_max, vertex_z=m.vertex_z)

    def z(self, r: np.ndarray) -> np.ndarray:
        r = np.asarray(r, float)
        return self._exact.z(r) - self.fit.residual_at(r)

    def slope(self, r: np.ndarray) -> np.ndarray:
        r = np.asarray(r, float)
        out = np.asarray(self._exact.slope(r), float)
        for k, (sp, d) in enumerate(zip(self.fit.splines, self._d)):
            if sp is None:
                continue
            sel = (r <= self.r_junction) if k == 0 else (r > self.r_junction)
            inside = (r >= sp.t[0]) & (r <= sp.t[-1])
            out = np.where(sel & inside, out - d(np.clip(r, sp.t[0], sp.t[-1])), out)
        return out

    def __repr__(self) -> str:
        return f"MeasuredProfile({self.fit.trace.source})"


def measured_profile(path: str | Path, mirror: Mirror, *, nose_radius_mm: float, fmt: str | None = None) -> MeasuredProfile:
    """The measured part in `path` (readers.MeasuredFormat) as a surface of `mirror`'s
    design; nose_radius_mm: the programmed nose (the step's masked band)."""
    if not isinstance(path, (str, Path)):
        raise InputError(f"measured_profile: path = {short(path)} ({type(path).__name__}): expected a measured "
                         "file's path")
    check_type(mirror, "measured_profile: mirror", Mirror, "a Mirror (settings.mirror())")
    check_real(nose_radius_mm, "measured_profile: nose_radius_mm", unit="mm", above=0.0)
    data = read_measurement(path, fmt)
    trace = profile_through_axis(data, mirror) if isinstance(data, AreaMap) else data
    fit = fit_trace(trace, mirror, nose_radius_mm=nose_radius_mm, options=FitOptions())
    h, kind, _ = centre_pip(fit)
    if kind is not None:  # the pip (radius h) is not the lobe's form: leave it out of the spline
        fit = without_pip(fit, 2.0 * h)
    return MeasuredProfile(fit)
