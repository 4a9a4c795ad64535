"""`tolerance --surface measured:FILE`: the tolerance analysis of a part that exists.

The made mirror is the measured one (measure.surface.MeasuredProfile: the design plus the
fitted, axisymmetric residual), held fixed in every trial (tolerance.surfaces.SurfaceBank.
fixed): the part is cut and polished, so nothing of the machining is left to draw (no
lattice phase, nose, tool setting, polishing time or lathe set-up error). What remains
uncertain is how it is assembled: the camera's decentre, axial position and tilt and the
mirror seat's tilt ([tolerance.params], drawn as for a program's part, same seed, same
order). Its nominal verdict is the measured part with the camera aligned, judged over the
zones every command uses (optics.zones.zones_for) against the same criteria; the
sensitivity and inverse sensitivity cover the assembly's parameters.

The trace gives the surface's form, not where it sits along the axis against the seat (the
fit removes the piston): the surface is taken at its designed height, and the camera's
axial tolerance stands for where the assembly puts it.
"""

from __future__ import annotations

import dataclasses

from ..design import Mirror
from ..profile import Profile
from ..optics.radial import radial_figures
from ..optics.zones import zones_for
from .allocation import allocate as allocate_tolerances
from .allocation import inverse_sensitivity
from .montecarlo import Context, disparity_limit_px
from .montecarlo import run_monte_carlo, stereo_table
from .runs import DEPTH_RANGES_M, verdict
from .samples import pixel_sample
from .sensitivity import responses, sensitivity_table
from .surfaces import SurfaceBank

#: The parameters drawn for a part that exists: its assembly.
ASSEMBLY = ("camera_decentre_mm", "camera_axial_mm", "camera_tilt_deg", "seat_tilt_deg")
#: The name of the measured part's entry among tolerance's "programs".
ENTRY = "measured"


class MeasuredPart:
    """What names the part where the Monte Carlo's outputs name a program (its `value`:
    the JSON's and the CSV's "program")."""

    value = ENTRY


def measured_label(path: str) -> str:
    """Which made mirror is judged, in one line."""
    return f"the measured part: {path}"


def measured_context(mirror: Mirror, settings, profile: Profile, label: str, *, progress: bool = False):
    """The Monte Carlo's context (tolerance.montecarlo.Context) for `profile` held fixed,
    only the assembly drawn (module doc)."""

    ts = settings.tolerance
    tol = {k: (float(v) if k in ASSEMBLY else 0.0) for k, v in ts.tolerances.items()}
    fixed = dataclasses.replace(ts, tolerances=tol, machine_errors={k: 0.0 for k in ts.machine_errors},
                                lattice_phases=1, seat_pivot_mm=ts.pivot_mm(mirror))  # 0: the design's rim
    nose = float(settings.tool.nose_radius)
    bank = SurfaceBank.fixed(mirror, profile, settings.polish.grid_step_mm, nose_mm=nose)
    bank.source = label
    zn = zones_for(settings, mirror)  # the zones every command uses
    samples = tuple(pixel_sample(mirror, k, bin_px=ts.bin_px, azimuths=ts.azimuths, zones=zn) for k in (0, 1))
    sp = ts.spec
    # the limits as tolerance.montecarlo.prepare states them for a program's part
    limits = {"image_displacement_px": sp.image_displacement_px, "outlier_pct": sp.outlier_pct,
              "disparity_px": disparity_limit_px(mirror, sp.depth_error_pct, sp.depth_range_m, ts.depth_points),
              "slope_error_rad": sp.slope_error_rad}
    ctx = Context(mirror, fixed, bank, samples, nose, 0.0, label, MeasuredPart(), limits, progress, zn)
    ctx.cut_plus_x = False  # no machining drawn: no backlash
    return ctx


def measured_tolerance(mirror: Mirror, settings, profile: Profile, path: str, *, progress: bool = False,
                       allocate: bool = False):
    """The tolerance analysis of the measured part in `path` (its surface `profile`):
    (figures, [(run name, MonteCarloResult)]) with figures shaped as tolerance_analysis's,
    its one entry under "programs" named ENTRY (module doc)."""

    label = measured_label(path)
    ctx = measured_context(mirror, settings, profile, label, progress=progress)
    ts = ctx.settings
    mc = run_monte_carlo(ctx, progress=progress)
    results = [(f"{ENTRY}: monte carlo", mc)]
    resp = responses(ctx, progress=progress)
    lobes = radial_figures(profile, mirror, zones=ctx.zones)["lobes"]
    note = ("a part that exists: its measured surface (the design plus the fitted, axisymmetric residual) in "
            "every trial; only the assembly is drawn (" + ", ".join(ASSEMBLY) + "); the machining's "
            "tolerances and the lathe's set-up errors are not (the part is made); the surface at its designed "
            "height along the axis (a trace does not tie it to the seat)")
    entry = {"made_mirror": {"label": label, "file": str(path), "surface": "measured"}, "surfaces": label,
             "note": note, "limits": ctx.limits, "monte_carlo": mc.to_dict(),
             "sensitivity": sensitivity_table(ctx, resp), "inverse_sensitivity": inverse_sensitivity(resp, ctx.limits),
             "stereo": stereo_table(ctx, DEPTH_RANGES_M),
             "nominal_over_zone": {"surface": label, "made_mirror": label, "zones": ctx.zones.describe(),
                                   "lobes": [{"name": lb["name"], "image_displacement_px": lb["image_displacement_px"],
                                              "zone_px": lb["zone_px"]} for lb in lobes]}}
    if allocate:
        entry["allocation"], confirm = allocate_tolerances(ctx, resp, mc, target=ts.target_yield, progress=progress)
        if confirm is not None:
            results.append((f"{ENTRY}: allocation confirmed", confirm))
    entry["verdict"] = verdict(entry, ts.spec_dict())
    figures = {"spec": ts.spec_dict(), "distribution": ts.distribution.value, "tolerances": ts.tolerances,
               "cost": ts.cost, "seed": ts.seed, "trials": ts.trials, "target_yield": ts.target_yield,
               "seat_pivot_mm": ts.pivot_mm(mirror), "judged": label,
               "measured_part": {"file": str(path), "made_mirror": label, "drawn": list(ASSEMBLY), "note": note},
               "programs": {ENTRY: entry}}
    return figures, results
