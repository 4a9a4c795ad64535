"""Whether a design can be made as configured: the checks `run` makes before it writes
anything, for a design that did not come from the configuration (the optimiser's winner
and its runner-ups)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..errors import InputError
from ..job import check_cad, check_programs
from .programs import shop_programs

if TYPE_CHECKING:
    from ..settings import Settings


def check_made(settings: Settings, what: str = "the design") -> None:
    """The junction and the polishing times (job.check_programs), the CAD body
    (job.check_cad), and both programs planned and simulated against the stock
    (shop.programs.shop_programs: gouge, bar, travel, no rapid or insert body in stock).
    An InputError here names `what` and the check it fails."""
    mirror = settings.mirror()
    try:
        check_programs(settings, mirror)
        check_cad(settings, mirror)
        shop_programs(settings, mirror)
    except InputError as exc:
        raise InputError(f"{what} cannot be made as configured: {exc}") from None
