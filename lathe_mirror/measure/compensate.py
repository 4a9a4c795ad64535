"""The re-cut: what a measured part asks of the next program.

1. The set-up errors the diagnosis names go to the set-up (the sheet's notes) and the tool
   table: a nose radius other than the programmed one re-plans the program for the nose
   actually in the holder (the program is the nose centre's path; its offsets, and the
   touch-off entries on the sheet, follow the nose radius).
2. What the set-up errors do not explain (measured minus the program's nominal part minus
   the predicted effect of the set-up errors, each lobe smoothed over its clear aperture by
   the fit's spline) is subtracted from the program's target with a gain (GAIN: a smaller
   step than the whole error, since a measured residual carries the instrument's error
   too), along the normal by way of the planner: the target is each lobe's sheet less a
   smooth offset (cut_surface.CompensatedLobe, as the polishing allowance is), and the
   planner offsets it by the nose as every program.
3. A residual the lattice cannot express (its PV under the controller's increment) is not
   re-cut: turning cannot place the surface finer than the lattice; polish it instead.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..cut_surface import CompensatedLobe, CompensatedMirror
from ..design import Mirror
from ..machine_errors import machined_with_errors
from ..profile import ExactProfile, Profile
from .fit import lobe_figures
from .nextjob import target_to_dict
from .result import Measurement

#: The share of the remaining residual a re-cut takes off.
GAIN = 0.8
#: Knot spacing (mm) of the compensation's offset spline.
KNOT_MM = 1.0


@dataclass(frozen=True)
class Compensation:
    """What the re-cut changes. nose_radius_mm: the nose to plan for and to enter in the
    tool table. setup: the set-up corrections (lines for the sheet). residual_pv_um /
    residual_rms_um: per lobe, what the set-up errors leave. recut: whether the residual is
    compensated (False: below the lattice, or nothing left). target: the re-cut's target
    (None: the program's usual target; not re-cut: the one the part was cut from). gain: the share taken off."""

    nose_radius_mm: float
    setup: tuple[str, ...]
    residual_pv_um: dict
    residual_rms_um: dict
    recut: bool
    target: CompensatedMirror | None
    gain: float
    message: str

    def to_dict(self) -> dict:
        return {"nose_radius_mm": self.nose_radius_mm, "setup": list(self.setup), "gain": self.gain,
                "target": target_to_dict(self.target),
                "residual_after_setup": {k: {"pv_um": self.residual_pv_um[k], "rms_um": self.residual_rms_um[k]}
                                         for k in self.residual_pv_um},
                "residual_compensated": self.recut, "message": self.message}


def compensation(meas: Measurement, toolpath, nominal: Profile, base_target: Mirror, *,
                 resolution_mm: float, gain: float = GAIN) -> Compensation:
    """The re-cut for a measured part cut with `toolpath` (its nominal as-machined surface
    `nominal`); base_target: the program's usual target (program_target). resolution_mm:
    the controller's increment."""
    from scipy.interpolate import make_lsq_spline

    fit, dg = meas.fit, meas.diagnosis
    m = fit.mirror
    exact = ExactProfile(m)
    r = fit.r
    errors = dg.errors()
    predicted = nominal if errors.is_zero else machined_with_errors(toolpath, errors)
    # machine Z: measured - nominal part - what the set-up errors do
    d = fit.resid - (exact.z(r) - nominal.z(r)) - (nominal.z(r) - predicted.z(r))
    mask = fit.used & (r > 3 * max(abs(dg.centre_height_mm), 0.1))
    pv, rms, splines = {}, {}, []
    for k in (0, 1):
        lf, sp = lobe_figures(m, k, r, d, mask, fit.options)
        splines.append(sp)
        if lf is not None:
            pv[lf.name], rms[lf.name] = lf.pv_um, lf.rms_um
    setup = tuple(c for c in dg.corrections if not c.startswith(("nose radius:", "centre height: no", "X offset: none", "backlash:")))
    nose = (dg.entries or {}).get("nose_radius_mm", dg.nose_radius_mm)  # as the corrections say
    big = [n for n in pv if pv[n] * 1e-3 >= resolution_mm]
    if not big:
        msg = (f"the residual left by the set-up errors (PV {max(pv.values(), default=0):.2f} um) is below the "
               f"lattice ({resolution_mm * 1e3:g} um): a re-cut cannot place the surface finer; polish instead")
        # the program keeps the target it was cut from (a re-cut's stays)
        keep = base_target if isinstance(base_target, CompensatedMirror) else None
        return Compensation(nose, setup, pv, rms, False, keep, gain, msg)
    lobes = []
    for k, lobe in enumerate(base_target.lobes):
        sp = splines[k]
        lo, hi = (0.0, m.r_junction) if k == 0 else (m.r_junction, m.r_max)
        grid = np.linspace(lo, hi, max(int((hi - lo) / 0.05), 8) + 1)
        if k == 1:
            grid[0] = np.nextafter(lo, hi)
        base_off = np.asarray(m.lobes[k].z(grid)) - np.asarray(lobe.z(grid))  # the usual target's allowance
        corr = np.zeros_like(grid) if sp is None else sp(np.clip(grid, sp.t[0], sp.t[-1]))
        off = base_off - gain * corr  # machine Z too high by corr: lower the target (camera z up)
        n_in = max(int(round((hi - lo) / KNOT_MM)) - 1, 0)
        t = np.concatenate([[grid[0]] * 4, np.linspace(grid[0], grid[-1], n_in + 2)[1:-1], [grid[-1]] * 4])
        spline = make_lsq_spline(grid, off, t, k=3)
        lobes.append(CompensatedLobe(m.lobes[k], offset_knots=tuple(float(v) for v in spline.t),
                                     offset_coef=tuple(float(v) for v in spline.c)))
    target = CompensatedMirror(m, lobes[0], lobes[1])
    msg = (f"re-cut with {gain:g} of the residual the set-up errors leave subtracted "
           f"({', '.join(f'{n} PV {pv[n]:.2f} um' for n in pv)}), smoothed over {fit.options.smooth_mm:g} mm")
    return Compensation(nose, setup, pv, rms, True, target, gain, msg)
