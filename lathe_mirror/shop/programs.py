"""Programs a shop can run: the whole lathe program around a finishing toolpath (planned by
the machining job), simulated against the stock and refused if it touches it, with its
set-up sheet (shop_program, shop_programs).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

from ..design import Mirror
from ..enums import BEST, Mount, Strategy
from ..errors import InputError
from ..inputs import check_type
from ..iso10110 import spec_of
from ..job import MachiningJob, check_program
from ..nose_envelope import as_machined, contour_profile, gouge_depth, junction_fillet
from ..path import Arc
from ..lathe import Stock
from ..tolerance.setting import setting_error_costs
from ..toolpath import Toolpath, ToolpathSettings, profile_errors, usable_ranges
from .boring import bore_plan
from .plan import plan_program
from .roughing import finish_allowances
from .second import plan_second
from .setup import InspectionRow, setup_sheet
from .resume import Resume
from .stock import simulate_program

if TYPE_CHECKING:
    from ..settings import Settings
    from .program import Program as ShopProgramModel
    from .setup import SetupSheet
    from .stock import Simulation


#: Most finishing passes (the contour and the offset passes before it) a program may take.
MAX_FINISH_PASSES = 12

#: The setting error whose cost the set-up sheet states, mm.
SETTING_ERROR_MM = 0.01


@dataclass(frozen=True)
class ShopProgram:
    """A checked program (shop.program.Program), its simulation against the stock
    (shop.stock.Simulation) and its set-up sheet (shop.setup.SetupSheet)."""

    program: ShopProgramModel
    simulation: Simulation
    sheet: SetupSheet
    second: ShopProgramModel | None = None
    second_simulation: Simulation | None = None

    def __repr__(self) -> str:
        # one line: the program's blocks and the simulation's moves run to 100 kB
        second = f", second set-up {self.second.name!r}" if self.second is not None else ""
        return (f"ShopProgram({self.program.name!r}, {len(self.program.operations)} operations{second}, "
                f"cycle {self.simulation.cycle_time_s / 60:.1f} min)")


def shop_program(toolpath: Toolpath, stock: Stock, options: ToolpathSettings | None = None, *,
                 name: str | None = None, setting_costs: dict | None = None,
                 inspection: tuple = (), body=None) -> ShopProgram:
    """The whole program around `toolpath` (shop.plan_program), simulated against the stock
    and refused (InputError, one line naming the block) if a rapid or the insert's body
    touches stock or the part, with its set-up sheet. body: the CAD body (body.BodySpec):
    given, the program parts the mirror off (shop.partoff) and a second program (shop.second,
    simulated from the parted part) faces its back and cuts its mount; the sheet has both. setting_costs: what a setting error
    costs (tolerance.setting; computed if None).

    The finishing passes: as many as keep the deepest cut of each (the simulation's depth
    of cut) within options.max_finish_depth_mm; an inside corner takes more than the offset
    step, so the count is raised from the simulated depth (at most MAX_FINISH_PASSES)."""
    import math

    check_type(toolpath, "shop_program: toolpath", Toolpath, "a Toolpath (plan)")
    check_type(stock, "shop_program: stock", Stock, "a Stock (settings.stock)")
    if options is not None:
        check_type(options, "shop_program: options", ToolpathSettings, "a ToolpathSettings (settings.toolpath)")
    options = ToolpathSettings() if options is None else options
    passes = 0
    resume = Resume()  # a program planned again with more passes: simulated from its first finishing pass
    while True:
        program = plan_program(toolpath, stock, options, name=name or f"mirror_{toolpath.strategy.value}",
                               body=body, finish_passes=passes)
        sim = simulate_program(program, resume=resume)
        sim.check()
        deepest = max((op.max_depth_of_cut_mm for op in sim.operations if op.name.startswith("finish")),
                      default=0.0)
        limit = options.max_finish_depth_mm
        if deepest <= limit + 1e-6:
            break
        n = len(finish_allowances(options, passes)) + 1
        need = max(n + 1, math.ceil(n * deepest / limit - 1e-9))
        if need > MAX_FINISH_PASSES:
            raise InputError(f"toolpath.max_finish_depth_mm = {limit:g} mm: a finishing pass of the "
                             f"{toolpath.strategy.value} program cuts {deepest:.3f} mm deep with {n} passes; "
                             f"allowed a depth that {MAX_FINISH_PASSES} passes hold (a larger "
                             "max_finish_depth_mm or a smaller toolpath.rough_allowance)")
        passes = need
    second = sim2 = None
    if body is not None:
        second = plan_second(program, sim.parted, body, name=f"{program.name}_op2")
        sim2 = simulate_program(second)
        sim2.check()
    if setting_costs is None:
        setting_costs = setting_error_costs(toolpath.mirror.design, SETTING_ERROR_MM)
    return ShopProgram(program=program, simulation=sim,
                       sheet=setup_sheet(program, sim, setting_costs, inspection=inspection,
                                         second=second, second_simulation=sim2),
                       second=second, second_simulation=sim2)


#: Radii the inspection table probes: every this many mm of each clear aperture, and its ends.
PROBE_STEP_MM = 2.0


def inspection_table(settings: Settings) -> tuple:
    """The set-up sheet's inspection rows (shop.setup.InspectionRow): each lobe's sag at
    every PROBE_STEP_MM of its clear aperture and at its ends (inside it, to 0.01 mm), with the band its form
    tolerance allows (iso10110.spec_of)."""
    import numpy as np

    if settings.tolerance is None:  # no tolerance spec, no band
        return ()
    spec = spec_of(settings)
    rows = []
    for lb in spec.lobes:
        c = lb.conic
        lo, hi = c.clear_aperture
        lo, hi = np.ceil(lo * 100 - 1e-9) / 100, np.floor(hi * 100 + 1e-9) / 100  # probe radii in 0.01 mm
        r = np.arange(np.ceil(lo / PROBE_STEP_MM - 1e-9), np.floor(hi / PROBE_STEP_MM + 1e-9) + 1) * PROBE_STEP_MM
        r = np.unique(np.concatenate([[lo], r[(r > lo + 0.25) & (r < hi - 0.25)], [hi]]))
        for rv, s, t in zip(r, c.sag(r), c.slope(r)):
            rows.append(InspectionRow(lobe=c.name, r_mm=float(rv), z_mm=float(c.vertex_z - s), sag_mm=float(s),
                                      slope_rad=float(t), band_um=lb.form.pv_um / 2.0))
    return tuple(rows)


def plan_checks(settings: Settings, mirror: Mirror, *,
                strategies: tuple[Strategy, ...] = (Strategy.PAPER, BEST)) -> None:
    """The checks of shop_programs that need no simulation, in a fraction of a second: each
    strategy's whole program planned (shop.plan_program: the bar's diameter and length, the
    end position, the block numbers, the part-off below the body). InputError names the
    setting. `run` makes them before any work and simulates in the background, `toolpath`
    before its simulation (toolpath_result); the mount's bore's tools too
    (shop.boring.bore_plan: otherwise refused only after the first set-up's simulation)."""
    options = settings.toolpath
    job = MachiningJob.from_settings(settings, mirror)
    for strategy in strategies:
        plan_program(job.but(strategy=strategy).toolpath, settings.stock, options, body=settings.body)
    body = settings.body
    if body is not None and body.mount is Mount.BORE:  # the bore's drill and bar (shop.boring), before any work
        bore_plan(body, options, settings.tool.nose_radius, vertex_z=-body.thickness,
                  resolution=settings.machine.resolution)


def shop_programs(settings: Settings, mirror: Mirror, *,
                  strategies: tuple[Strategy, ...] = (Strategy.PAPER, BEST)) -> list[ShopProgram]:
    """The checked programs of `mirror` for each strategy (default: the paper's method and
    the best), named mirror_<strategy>, with the settings' lathe, tool, stock and knobs,
    each parting off at the [cad] body's length with its second set-up."""
    costs = setting_error_costs(mirror, SETTING_ERROR_MM)
    options = settings.toolpath
    job = MachiningJob.from_settings(settings, mirror)  # polish.precompensate: the polish's allowance
    inspection = inspection_table(settings)
    return [shop_program(job.but(strategy=strategy).toolpath, settings.stock, options, setting_costs=costs,
                         inspection=inspection, body=settings.body)
            for strategy in strategies]


def toolpath_result(settings: Settings, mirror: Mirror, strategy: Strategy) -> tuple[ShopProgram, dict]:
    """`lathe-mirror toolpath`'s work: the strategy's program, checked as every command that
    uses a program is (job.check_program), planned whole, simulated against the stock and
    refused if it touches, with its sheet; and its figures (the --json answer): the contour's
    lattice and budget, the gouge and the fillet, the profile errors of the as-machined
    surface over the whole lobes, of the contour alone and over the radii the camera uses,
    and the simulation's figures of both set-ups."""
    tp = check_program(settings, mirror, strategy)
    plan_checks(settings, mirror, strategies=(strategy,))  # the bar, the part-off, the bore: before the simulation
    shop = shop_program(tp, settings.stock, settings.toolpath, inspection=inspection_table(settings),
                        body=settings.body)
    made = as_machined(tp)
    figures = profile_errors(made, mirror)
    contour = profile_errors(contour_profile(tp), mirror) if tp.nose_radius > 0 else figures
    lathe = settings.machine
    result = {
        "strategy": strategy.value,
        "n_points": tp.n_points,
        "max_points": lathe.max_points,
        "resolution_mm": lathe.resolution,
        "nose_radius_mm": settings.tool.nose_radius,
        "moves": len(tp.segments),
        "arcs": sum(1 for s in tp.segments if isinstance(s, Arc)),
        "gouge_depth_mm": gouge_depth(tp),
        "junction_fillet": junction_fillet(tp),
        "lobes": figures["lobes"],
        "contour_lobes": contour["lobes"],
        # the radii the camera uses (the step wall hides the inner lobe's rim and with it
        # the junction fillet): what the image sees of the as-machined surface
        "usable_lobes": profile_errors(made, mirror, r_ranges=usable_ranges(mirror))["lobes"],
        "shop": shop.simulation.figures(),
    }
    if shop.second is not None:
        result["second_setup"] = {"name": shop.second.name, **shop.second_simulation.figures()}
    return shop, result
