"""A made part measured at the shop: the trace fitted against the design and the machine
diagnosed (`lathe-mirror measure`: measure_part), and the next job it asks for
(`lathe-mirror compensate`: next_job): the set-up corrections, the re-cut program with
its sheet, and what the next iteration reads (measure.nextjob).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from ..design import Mirror
from ..enums import Strategy
from ..errors import InputError
from ..iso10110 import spec_of
from ..job import check_program, machine, program_target
from ..measure.compensate import GAIN, Compensation, compensation  # GAIN: compensate's default
from ..measure.diagnose import TouchOff
from ..measure.fit import FitOptions
from ..measure.nextjob import JOB_TOML
from ..measure.judge import judge
from ..measure.result import Measurement, measure
from .programs import ShopProgram, inspection_table, shop_program
from .setup import can_touch

if TYPE_CHECKING:
    from ..cut_surface import CompensatedMirror
    from ..settings import Settings


def measure_part(settings: Settings, mirror: Mirror, path: str, strategy: Strategy,
                 target: CompensatedMirror | None = None, *, fmt: str | None = None,
                 fit_conic: bool = False) -> tuple[Measurement, dict]:
    """The part in `path` measured against the program that cut it (strategy, and target:
    a re-cut's, None the program's usual one): the fit, the diagnosis, the verdict that the
    trace is this part (InputError when it is not) and each lobe against its form
    tolerance; (the measurement, its figures as `measure` writes them)."""
    tp = check_program(settings, mirror, strategy, target=target)
    result = measure(path, mirror, machine(tp), settings.tool.nose_radius, fmt=fmt,
                     options=FitOptions(conic=fit_conic), resolution_mm=settings.machine.resolution,
                     toolpath=tp, touch_off=touch_off_of(tp))
    verdict = refuse_unfit(result, settings, path)
    out = result.to_dict()
    out["job"] = {"strategy": strategy.value, "programmed_nose_radius_mm": settings.tool.nose_radius,
                  "target": "re-cut (--from)" if target is not None else "the design's usual",
                  "touch_off": result.diagnosis.touch_off.to_dict()}
    out["this_part"] = verdict
    out["form_tolerance"] = form_verdicts(settings, out["lobes"])
    return result, out


@dataclass
class NextJob:
    """The next job for a measured part: the re-cut program (`shop`), its sheet with the
    set-up corrections among its notes, the tools of its table (one a station), the
    nose radius the tool table holds, and what `compensate` writes and says of it."""

    measurement: Measurement
    compensation: Compensation
    shop: ShopProgram
    sheet: Any
    tools: list
    nose_radius_mm: float
    repeats: str
    comments: list[str]
    figures: dict


def next_job(settings: Settings, mirror: Mirror, path: str, strategy: Strategy,
             cut_target: CompensatedMirror | None = None, *, gain: float = GAIN, fmt: str | None = None,
             files: tuple[str, ...] = ()) -> NextJob:
    """Measure the part in `path` as measure_part does, then plan its re-cut: the set-up
    errors to the sheet and the tool table (a nose radius other than the programmed one
    re-plans the program for it), the residual they do not explain taken off the target
    with `gain`, through the same checks as every program and the stock simulation.
    files: the names the program, its second set-up and its sheet are written under."""
    tp = check_program(settings, mirror, strategy, target=cut_target)
    nominal = machine(tp)
    touch = touch_off_of(tp)
    meas = measure(path, mirror, nominal, settings.tool.nose_radius, fmt=fmt,
                   options=FitOptions(), resolution_mm=settings.machine.resolution, toolpath=tp, touch_off=touch)
    refuse_unfit(meas, settings, path)
    base = cut_target if cut_target is not None else program_target(settings, mirror)
    comp = compensation(meas, tp, nominal, base, resolution_mm=settings.machine.resolution, gain=gain)
    tool = dataclasses.replace(settings.tool, nose_radius=round(comp.nose_radius_mm, 3))  # as a tool table takes it
    # the re-cut: the same checks as every program (plan on the lattice within the budget,
    # gouge), then the stock simulation (shop_program refuses contact)
    recut_tp = check_program(settings, mirror, strategy, tool=tool, target=comp.target)
    shop = shop_program(recut_tp, settings.stock, settings.toolpath, name="mirror_recut",
                        inspection=inspection_table(settings), body=settings.body)
    ops = [op.name for op in shop.program.operations]
    finishing = [f"{op.name} (N{op.number})" for op in shop.program.operations if op.name.startswith("finish")]
    repeats = (f"a new part from the bar: the whole program ({', '.join(ops)}) and the second set-up "
               f"({', '.join(op.name for op in shop.second.operations)}); the part measured is not re-cut in "
               f"place (its re-chucking would not hold the axis to the micrometre)")
    notes = (tuple(f"Set-up correction from the measured part: {c}" for c in comp.setup)
             + (comp.message, f"{touch.describe()}, with the nose radius {tool.nose_radius:g} mm of the tool table.",
                f"This re-cut repeats {repeats}. Finishing passes: {', '.join(finishing)}."))
    sheet = dataclasses.replace(shop.sheet, notes=shop.sheet.notes + notes)
    entries = dict(meas.diagnosis.entries or {})
    entries["nose_radius_mm"] = tool.nose_radius
    nxt = {"config": JOB_TOML, "strategy": strategy.value, "nose_radius_mm": tool.nose_radius,
           "touch_off": touch.to_dict(), "set_up_entries": entries, "repeats": repeats,
           "target": comp.to_dict()["target"]}
    dg = meas.diagnosis
    program_file = files[0] if files else "the program"
    comments = [f"lathe-mirror compensate: the next job for {meas.fit.trace.source}",
                f"measured: nose radius {dg.nose_radius_mm:.4f} mm (programmed {dg.programmed_nose_mm:g}), "
                f"centre height {dg.centre_height_mm:+.4f} mm, X offset {dg.x_offset_mm:+.4f} mm",
                f"entered at the machine: {', '.join(f'{k} {v:+.4f}' for k, v in entries.items())}",
                f"the program {program_file} cuts the {strategy.value} program "
                + ("from the re-cut target in compensate.json beside this file: use --from DIR (not --config alone)"
                   if comp.target is not None else "from the design's usual target"),
                touch.describe()]
    tools, seen = [], set()
    for t in list(sheet.tools) + (list(sheet.second.tools) if sheet.second is not None else []):
        if t.station not in seen:  # one row a station (the second set-up reuses the first's)
            seen.add(t.station)
            tools.append(t)
    figures = {"measurement": meas.to_dict(), "compensation": comp.to_dict(),
               "program": {"files": list(files), "strategy": strategy.value, "nose_radius_mm": tool.nose_radius,
                           "n_points": recut_tp.n_points, "max_points": settings.machine.max_points,
                           "residual_compensated": comp.recut, "operations": ops},
               "next_job": nxt}
    return NextJob(meas, comp, shop, sheet, tools, tool.nose_radius, repeats, comments, figures)


def refuse_unfit(result: Measurement, settings: Settings, path: str) -> dict:
    """The fit's verdict on whether the trace is this part (measure.judge), against each
    lobe's form tolerance (iso10110.spec_of); InputError (exit 2) naming what does not fit
    and its likely cause when it is not: nothing of it reaches a verdict or a re-cut."""
    spec = spec_of(settings)
    tol = {lb.name: spec.lobe(lb.name).form.pv_um for lb in result.fit.lobes}
    verdict = judge(result, tol)
    if verdict["refusal"]:
        raise InputError(f"{path}: {verdict['refusal']}")
    return verdict


def touch_off_of(toolpath) -> TouchOff:
    """The touch-off the program's set-up sheet prescribes (shop.setup.setup_sheet: X on a
    bore with the nose's +X side when the tool as held can present it, else on an outside
    diameter; Z on the face with the nose's bottom)."""
    tool = toolpath.held_tool
    if not can_touch(tool, -math.pi / 2):
        raise RuntimeError("the tool cannot touch a face with its nose")  # the tool checks refuse it first
    return TouchOff("bore" if can_touch(tool, 0.0) else "outside")


def form_verdicts(settings: Settings, lobes: list[dict]) -> list[dict]:
    """Each measured lobe against its form tolerance from `lathe-mirror spec`
    (iso10110.spec_of: PV and RMS over the clear aperture, RMS slope): pass when all three
    hold. The slope is the residual's over the fit's smoothing band (0.5 mm knots), the
    spec's per its evaluation length."""
    spec = spec_of(settings)
    out = []
    for lb in lobes:
        form = spec.lobe(lb["name"]).form
        checks = {"pv": lb["pv_um"] <= form.pv_um, "rms": lb["rms_um"] <= form.rms_um,
                  "slope": lb["slope_rms_urad"] <= form.slope_urad}
        out.append({"name": lb["name"], "iso10110_5": form.iso10110_5, "pv_um": form.pv_um, "rms_um": form.rms_um,
                    "slope_urad": form.slope_urad, "evaluation_length_mm": form.evaluation_length_mm,
                    "checks": checks, "pass": all(checks.values())})
    return out
