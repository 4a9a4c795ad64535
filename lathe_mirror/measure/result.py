"""One measurement, start to end: the file read, fitted against the design, the machine
diagnosed against the program's nominal part; its figures as the JSON of `measure`."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from ..design import Mirror
from ..profile import Profile
from .diagnose import Diagnosis, diagnose
from .fit import FitOptions, TraceFit, fit_trace, profile_through_axis
from .readers import AreaMap, read_measurement


@dataclass(frozen=True)
class Measurement:
    """A measured part: the fit (figures per lobe) and the machine's diagnosis. spec: the
    per-lobe verdicts against a form tolerance, or None when no tolerance is given."""

    fit: TraceFit
    diagnosis: Diagnosis
    areal: bool
    spec: list | None = None

    def to_dict(self) -> dict:
        return {"source": self.fit.trace.source, "areal": self.areal, "fit": self.fit.to_dict(),
                "lobes": [lf.to_dict() for lf in self.fit.lobes],
                **({"conic_fit": self.fit.conic_params} if self.fit.conic_params else {}),
                "diagnosis": self.diagnosis.to_dict(),
                "form_tolerance": self.spec}


def measure(path: str | Path, mirror: Mirror, nominal: Profile, programmed_nose_mm: float, *,
            fmt: str | None = None, options: FitOptions = FitOptions(),
            resolution_mm: float = 0.005) -> Measurement:
    """Read `path` (readers.MeasuredFormat), fit it against `mirror` and diagnose the
    machine against `nominal`, the program's as-machined surface on a perfect machine cut
    with a nose of programmed_nose_mm (mm)."""
    data = read_measurement(path, fmt)
    areal = isinstance(data, AreaMap)
    trace = profile_through_axis(data, mirror) if areal else data
    fit = fit_trace(trace, mirror, nose_radius_mm=programmed_nose_mm, options=options)
    return Measurement(fit, diagnose(fit, nominal, programmed_nose_mm, resolution_mm=resolution_mm), areal)
