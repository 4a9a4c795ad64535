"""The one validation of a Settings, however it was built: from a configuration
(settings.load.from_config) or in Python (`Settings(...)`, `dataclasses.replace`). Settings
runs it on construction (`Settings.__post_init__`), so a Settings that cannot exist
cannot be built, and its message is the one `load()` gives for the same values.

In order: every key within its declared range (the typed values written back to the
file's units, settings.dump), the cross-key rules of the sections (the program's bounds,
the Monte Carlo's sample, the compute scheduler's address), the design (design_checks),
the room (optics.scene.build_scene) and the costs (costs.check_costs).
"""

from __future__ import annotations

import re
from typing import TYPE_CHECKING

from ..declared import SLACK
from ..design import Mirror
from ..errors import InputError, num
from ..optics.scene import build_scene
from ..tolerance.spec import MAX_SAMPLE_RAYS
from .costs import check_costs
from .design_checks import check_design
from .dump import to_config
from .keys import check_ranges

if TYPE_CHECKING:
    from .model import Settings



def validate(settings: Settings) -> Mirror:
    """Refuse (one InputError line naming the key and what is allowed) a Settings that
    cannot exist; return its designed mirror."""
    check_ranges(to_config(settings), slack=SLACK)
    check_sample(settings)
    check_scheduler(settings.compute.scheduler)
    mirror = check_design(settings)   # the design's own checks, and a lobe that is no degenerate conic
    if settings.scene is not None:
        build_scene(settings.scene, mirror_top=float(mirror.outer.z(mirror.r_max)), mirror_radius=mirror.r_max)
    check_costs(settings, mirror)     # what the keys cost: estimated, refused above the limits
    return mirror


def check_sample(settings: Settings) -> None:
    """The tolerance analysis' sparse pixel sample (image-radius bins x azimuths per lobe)
    fits in memory: at most MAX_SAMPLE_RAYS rays a lobe (the default, 504 / 4 px x 12, is
    ~1500)."""
    t = settings.tolerance
    if t is None:
        return
    r_pixel = max(spec.r_pixel for spec in settings.lobes)
    rays = t.azimuths * r_pixel / t.bin_px
    if rays > MAX_SAMPLE_RAYS:
        raise InputError(f"tolerance.azimuths = {t.azimuths} with tolerance.bin_px = {num(t.bin_px)} px gives "
                         f"{rays:.3g} sample rays per lobe, at most {MAX_SAMPLE_RAYS} allowed: fewer azimuths or "
                         f"wider bins")


def check_scheduler(scheduler: str) -> None:
    """compute.scheduler: "" (local processes) or a Dask scheduler's tcp://HOST:PORT."""
    if scheduler and not re.fullmatch(r"tcp://[A-Za-z0-9._\-\[\]:]+:[0-9]{1,5}", scheduler):
        raise InputError(f"compute.scheduler = {scheduler!r}: allowed \"\" (local processes) or a Dask "
                         "scheduler's address tcp://HOST:PORT")
