"""Programs a shop can run: the whole lathe program around a finishing toolpath (planned by
the machining job), simulated against the stock and refused if it touches it, with its
set-up sheet (shop_program, shop_programs).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

from ..design import Mirror
from ..enums import BEST, Strategy
from ..job import MachiningJob
from ..lathe import Stock
from ..tolerance.setting import setting_error_costs
from ..toolpath import Toolpath
from .plan import plan_program
from .program import options_from_settings
from .setup import setup_sheet
from .stock import simulate_program

if TYPE_CHECKING:
    from ..settings import Settings
    from .program import Program as ShopProgramModel
    from .program import ProgramOptions
    from .setup import SetupSheet
    from .stock import Simulation


#: The setting error whose cost the set-up sheet states, mm.
SETTING_ERROR_MM = 0.01


@dataclass(frozen=True)
class ShopProgram:
    """A checked program (shop.program.Program), its simulation against the stock
    (shop.stock.Simulation) and its set-up sheet (shop.setup.SetupSheet)."""

    program: ShopProgramModel
    simulation: Simulation
    sheet: SetupSheet


def shop_program(toolpath: Toolpath, stock: Stock, options: ProgramOptions | None = None, *,
                 name: str | None = None, setting_costs: dict | None = None) -> ShopProgram:
    """The whole program around `toolpath` (shop.plan_program), simulated against the stock
    and refused (InputError, one line naming the block) if a rapid or the insert's body
    touches stock or the part, with its set-up sheet. setting_costs: what a setting error
    costs (tolerance.setting; computed if None)."""
    program = plan_program(toolpath, stock, options, name=name or f"mirror_{toolpath.strategy.value}")
    sim = simulate_program(program)
    sim.check()
    if setting_costs is None:
        setting_costs = setting_error_costs(toolpath.mirror, SETTING_ERROR_MM)
    return ShopProgram(program=program, simulation=sim, sheet=setup_sheet(program, sim, setting_costs))


def shop_programs(settings: Settings, mirror: Mirror, *,
                  strategies: tuple[Strategy, ...] = (Strategy.PAPER, BEST)) -> list[ShopProgram]:
    """The checked programs of `mirror` for each strategy (default: the paper's method and
    the best), named mirror_<strategy>, with the settings' lathe, tool, stock and knobs."""
    costs = setting_error_costs(mirror, SETTING_ERROR_MM)
    options = options_from_settings(settings.toolpath)
    job = MachiningJob.from_settings(settings, mirror)  # polish.precompensate: the polish's allowance
    return [shop_program(job.but(strategy=strategy).toolpath, settings.stock, options, setting_costs=costs)
            for strategy in strategies]
