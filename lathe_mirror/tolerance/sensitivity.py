"""Sensitivity table: each parameter at - and + its tolerance, the others nominal.

The lattice phase has no sign: its row gives the best and worst of its realisations.
The controller's resolution is a row of its own (resolution_row): it does not vary from
part to part, so the Monte Carlo varies the lattice phase instead, but the table shows
what a coarser or finer controller would do.
"""

from __future__ import annotations

import math

import numpy as np

from .montecarlo import Context, evaluate_trials, judge
from .perturb import Trials
from .spec import PARAMETERS

#: Trial attribute(s) each tolerance moves, and the factor from its edge unit.
_TARGETS: dict[str, tuple[tuple[str, ...], float]] = {
    "nose_radius_mm": (("nose_mm",), 1.0),
    "tool_x_mm": (("tool_x_mm",), 1.0),
    "tool_z_mm": (("tool_z_mm",), 1.0),
    "polish_time_s": (("time_s",), 1.0),
    "camera_decentre_mm": (("cam_x_mm",), 1.0),
    "camera_tilt_deg": (("tilt_x",), math.pi / 180.0),
    "camera_axial_mm": (("cam_z_mm",), 1.0),
}


def sensitivity_table(ctx: Context, *, progress: bool = False) -> dict:
    """{"nominal": figures, "rows": [{"parameter", "tolerance", "unit", "minus", "plus"}]}.

    Figures per case: per-lobe RMS image displacement (px) and slope error (rad), RMS
    depth error (%) at the spec's range, and whether the case passes the spec.
    Decentre and tilt are applied along x (by symmetry any direction gives the same).
    """
    tol = ctx.settings.tolerances
    cases: list[tuple[str, str]] = [("nominal", "")]
    P = len(ctx.nodes.phases)
    cases += [("lattice_phase", str(i)) for i in range(1, P)]
    for key in _TARGETS:
        cases += [(key, "minus"), (key, "plus")]
    n = len(cases)
    tr = Trials.nominal(n, ctx.nominal_nose_mm, ctx.nominal_time_s)
    for c, (key, which) in enumerate(cases):
        if key == "lattice_phase":
            tr.phase[c] = int(which)
        elif key in _TARGETS:
            attrs, scale = _TARGETS[key]
            sign = -1.0 if which == "minus" else 1.0
            for a in attrs:
                getattr(tr, a)[c] += sign * tol.get(key, 0.0) * scale
    tr.time_s = np.maximum(tr.time_s, 0.0)
    fig = evaluate_trials(ctx, tr, progress=progress, desc="tolerance: sensitivity")
    ok = judge(fig, ctx.settings)
    passed = np.all(np.stack(list(ok.values())), axis=0)

    def case(i: int) -> dict:
        return {"image_displacement_px_rms": [float(x) for x in fig.image_displacement_px_rms[i]],
                "slope_error_rad_rms": [float(x) for x in fig.slope_error_rad_rms[i]],
                "depth_error_pct_rms": float(fig.depth_error_pct_rms[i]),
                "pass": bool(passed[i])}

    rows = []
    if P > 1:
        idx = [0] + [c for c, (k, _) in enumerate(cases) if k == "lattice_phase"]
        worst = max(idx, key=lambda i: float(np.max(fig.image_displacement_px_rms[i])))
        best = min(idx, key=lambda i: float(np.max(fig.image_displacement_px_rms[i])))
        rows.append({"parameter": "lattice_phase", "what": PARAMETERS["lattice_phase"][0],
                     "tolerance": f"{P} phases", "unit": "step", "minus": case(best), "plus": case(worst),
                     "note": "minus: the best phase, plus: the worst (by image displacement)"})
    for key in _TARGETS:
        i_m = cases.index((key, "minus"))
        rows.append({"parameter": key, "what": PARAMETERS[key][0], "tolerance": tol.get(key, 0.0),
                     "unit": PARAMETERS[key][1], "minus": case(i_m), "plus": case(i_m + 1)})
    return {"nominal": case(0), "rows": rows,
            "nominal_values": {"nose_radius_mm": ctx.nominal_nose_mm, "polish_time_s": ctx.nominal_time_s}}


def resolution_row(ctx: Context, polish_params, *, res0: float, machine_at, progress: bool = False) -> dict | None:
    """The nominal part re-planned and re-machined on a controller of resolution -/+ the
    tolerance tolerance.params.resolution_mm (None when that tolerance is 0).

    res0: the nominal resolution, mm. machine_at(resolution) -> a made surface (attributes
    profile, source): the pipeline's builder, the nominal part on that controller."""
    from .perturb import build_nodes

    d = ctx.settings.tolerances.get("resolution_mm", 0.0)
    if d <= 0:
        return None
    # res0 > d: checked by settings.py
    out = {"parameter": "resolution_mm", "what": "controller resolution (re-planned program)",
           "tolerance": d, "unit": "mm",
           "note": "not drawn in the Monte Carlo: one controller makes every part"}
    for which, res in (("minus", res0 - d), ("plus", res0 + d)):
        made = machine_at(res)
        nodes = build_nodes(ctx.mirror, [[made.profile]], np.array([ctx.nominal_nose_mm]), np.array([0.0]),
                            polish_params, np.array([ctx.nominal_time_s]))
        sub = Context(ctx.mirror, ctx.settings, nodes, ctx.samples, ctx.nominal_nose_mm, ctx.nominal_time_s,
                      made.source, ctx.program)
        fig = evaluate_trials(sub, Trials.nominal(1, ctx.nominal_nose_mm, ctx.nominal_time_s))
        ok = judge(fig, ctx.settings)
        out[which] = {"resolution_mm": res,
                      "image_displacement_px_rms": [float(x) for x in fig.image_displacement_px_rms[0]],
                      "slope_error_rad_rms": [float(x) for x in fig.slope_error_rad_rms[0]],
                      "depth_error_pct_rms": float(fig.depth_error_pct_rms[0]),
                      "pass": bool(all(v[0] for v in ok.values()))}
    return out
