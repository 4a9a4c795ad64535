"""Whether a fitted trace is this part: a fit that judges itself before anything is drawn
from it (a verdict, a diagnosis, a re-cut).

A trace is taken as this part's profile when all of these hold (each a figure in the
verdict, each refusal naming what does not fit and its likely cause):

- the points: at least MIN_POINTS, spread in x (not all at one x; these two and the
  heights' floor below need no fit: measure.trace_checks holds them and its limits, and
  measure.result.measure makes them before the fit too), and at least MIN_USED_SHARE of
  them on the lobes where a stylus follows (the fit's mask);
- the lateral extent: the used points span at least MIN_EXTENT_SHARE of each clear
  aperture they reach and reach at least one lobe's (a centimetre trace read as mm spans a
  tenth of it);
- the residual: what the set-up errors leave unexplained (the diagnosis's fit) at most
  MAX_UNEXPLAINED_UM RMS (a turned part's form error is micrometres; a flat, inverted or
  foreign trace leaves the sag itself, hundreds of um), each lobe's smoothed residual RMS
  at most MAX_FORM_RMS_UM (a set-up error of a tenth of a mm leaves tens of um; more is not
  a finished part), its raw scatter about it at most MAX_NOISE_UM (a stylus on a turned
  surface), and its heights not below the instrument's floor (a trace with no height at
  all: PV of the heights under MIN_HEIGHT_SPAN_MM is no profile);
- the diagnosis within physical bounds: a nose radius between NOSE_RANGE times the
  programmed one, a centre height and an X offset under MAX_SETUP_MM.
"""

from __future__ import annotations

import numpy as np

from ..optics.polishing_curve import clear_aperture
from .result import Measurement
from .trace_checks import check_row, refusal, trace_checks

MIN_USED_SHARE = 0.5
MIN_EXTENT_SHARE = 0.5
MAX_UNEXPLAINED_UM = 20.0
MAX_FORM_RMS_UM = 150.0
MAX_NOISE_UM = 5.0
NOSE_RANGE = (0.5, 2.0)
MAX_SETUP_MM = 0.5


def judge(meas: Measurement, form_pv_um: dict[str, float]) -> dict:
    """The verdict on `meas`: {"this_part": bool, "checks": [...], "refusal": str | None}.
    form_pv_um: each lobe's PV tolerance (um, iso10110.spec_of), shown beside its residual."""
    fit, dg = meas.fit, meas.diagnosis
    m = fit.mirror
    x, z = fit.trace.x, fit.trace.z
    checks = trace_checks(x, z)  # points, x spread, heights: made before the fit too (measure.result.measure)

    def check(name, ok, figure, cause):
        checks.append(check_row(name, ok, figure, cause))

    n = int(x.size)
    used = int(np.count_nonzero(fit.used))
    share = used / max(n, 1)
    check("points used", share >= MIN_USED_SHARE, f"{100 * share:.1f} % of the points on the lobes (at least "
          f"{100 * MIN_USED_SHARE:.0f} %)", "a trace of another part or design (--config), or off the axis")
    ru = fit.r[fit.used]
    reached = []
    for k in (0, 1):
        lo, hi = clear_aperture(m, k, 0.0)
        inside = ru[(ru >= lo) & (ru <= hi)]
        cover = (float(inside.max() - inside.min()) / (hi - lo)) if inside.size > 1 else 0.0
        if inside.size:
            reached.append(cover)
        check(f"{m.lobes[k].name} extent", inside.size == 0 or cover >= MIN_EXTENT_SHARE,
              f"used points span {100 * cover:.0f} % of r {lo:.2f}..{hi:.2f} mm",
              "lateral units not mm (a header's unit not honoured: name it, x [um] or x_mm) or a trace "
              "off the axis")
    check("lobes reached", bool(reached), f"{len(reached)} of 2 clear apertures reached",
          "lateral units not mm, or a trace of another design")
    unexplained = float(dg.sigma.get("unexplained_rms_um", 0.0))
    check("unexplained", unexplained <= MAX_UNEXPLAINED_UM,
          (f"the set-up errors leave {unexplained:.3g} um RMS unexplained (a turned part: under "
           f"{MAX_UNEXPLAINED_UM:g} um)" if np.isfinite(unexplained)
           else "no points on the lobes away from the centre to read the set-up errors from"), "not this design's surface (flat, inverted, another part) or heights in "
          "another unit")
    for lf in fit.lobes:
        tol = form_pv_um.get(lf.name)
        check(f"{lf.name} residual", lf.rms_um <= MAX_FORM_RMS_UM,
              f"RMS {lf.rms_um:.3g} um, PV {lf.pv_um:.3g} um (form tolerance PV {tol if tol is not None else '?'} um; "
              f"a turned part is within {MAX_FORM_RMS_UM:g} um RMS)",
              "not this design's surface (flat, inverted, another part) or heights in another unit")
        check(f"{lf.name} noise", lf.raw_rms_um <= MAX_NOISE_UM,
              f"scatter about the smoothed residual {lf.raw_rms_um:.3g} um (a stylus on a turned surface: under "
              f"{MAX_NOISE_UM:g} um)", "noise or a periodic signal, not a profile of a turned part")
    lo, hi = NOSE_RANGE
    nose0 = dg.programmed_nose_mm
    check("nose radius", lo * nose0 <= dg.nose_radius_mm <= hi * nose0,
          f"{dg.nose_radius_mm:.4f} mm (programmed {nose0:g}: allowed {lo:g} to {hi:g} times)",
          "a residual the set-up errors do not explain: the trace is not this part")
    check("centre height", abs(dg.centre_height_mm) < MAX_SETUP_MM,
          f"{dg.centre_height_mm:+.4f} mm (under {MAX_SETUP_MM:g} mm)", "a pip that is not the tool's")
    check("X offset", abs(dg.x_offset_mm) < MAX_SETUP_MM,
          f"{dg.x_offset_mm:+.4f} mm (under {MAX_SETUP_MM:g} mm)", "the trace is not this part")
    text = refusal(checks)
    return {"this_part": text is None, "checks": checks, "refusal": text}
