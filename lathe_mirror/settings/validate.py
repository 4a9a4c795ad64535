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
from ..enums import Surface
from ..job import check_cad, check_program, check_programs, check_render_nose
from ..optics.scene import build_scene
from ..shop.partoff import parting_z
from ..shop.plan import check_stock
from ..tolerance.spec import MAX_SAMPLE_RAYS
from .costs import check_costs
from .design_checks import check_design
from .dump import to_config
from .keys import check_ranges

if TYPE_CHECKING:
    from .sections import Sections as Settings



def validate(settings: Settings) -> Mirror:
    """Refuse (one InputError line naming the key and what is allowed) a Settings that
    cannot exist; return its designed mirror."""
    check_ranges(to_config(settings), slack=SLACK)
    check_body_in_bar(settings, settings.toolpath)
    check_sample(settings)
    check_scheduler(settings.compute.scheduler)
    mirror = check_design(settings)   # the design's own checks, and a lobe that is no degenerate conic
    if settings.scene is not None:
        build_scene(settings.scene, mirror_top=float(mirror.outer.z(mirror.r_max)), mirror_radius=mirror.r_max)
    check_costs(settings, mirror)     # what the keys cost: estimated, refused above the limits
    return mirror


def check_body_in_bar(settings: Settings, options) -> None:
    """The body is turned from the bar and parted off it: cad.blank_diameter at most
    stock.diameter, and the body, the stock the part-off leaves on its back and the blade
    within stock.length (shop.partoff.parting_z, the toolpath's own check)."""
    body, stock = settings.body, settings.stock
    if body.blank_diameter > stock.diameter:
        raise InputError(f"cad.blank_diameter = {num(body.blank_diameter)} mm is larger than the bar it is turned "
                         f"from (stock.diameter = {num(stock.diameter)} mm): allowed <= {num(stock.diameter)} mm "
                         "(left out, it follows the bar)")
    parting_z(body, stock, options, settings.machine)


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


def check_commands(settings: Settings, mirror: Mirror | None = None) -> None:
    """What the commands check before their work, on the design and its programs, all at
    once: `lathe-mirror design` runs it, so a configuration is valid for every command or
    for none. The junction, the polishing times and the tolerances' bounds
    (job.check_programs, tolerance and report), the CAD body (job.check_cad, cad and run),
    the bar and the end position (shop.plan.check_stock, toolpath), the finishing
    processes with the configured feed and nose (polish.process.*, the report), the
    render's own nose (render), the configured program and each toleranced one planned
    and held to the gouge tolerance (job.check_program: toolpath, cad, stereo, tolerance).
    Plans up to three programs (~0.1-0.5 s each). Not here: the shop program's stock
    simulation (the insert's body against the bar, seconds), which only `toolpath` runs."""
    mirror = settings.mirror() if mirror is None else mirror
    check_stock(mirror, settings.stock, settings.toolpath, settings.machine)
    check_programs(settings, mirror)
    check_cad(settings, mirror)
    check_processes(settings)
    check_render_nose(settings, mirror)
    strategies = {settings.toolpath.strategy}
    for surface in (settings.render.surface, settings.stereo.surface):
        strategies.add(settings.toolpath.strategy if surface is Surface.MADE else surface.strategy)
    if settings.tolerance is not None:
        strategies |= {program.strategy for program in settings.tolerance.programs}
    for strategy in sorted(strategies - {None}, key=lambda s: s.value):
        check_program(settings, mirror, strategy)


def check_processes(settings: Settings) -> None:
    """Each finishing process (polish.process.*) with the configured nose, feed and lattice
    it takes when its own are 0 (finish.Process.resolved: the feed under twice the nose)."""
    tool, lathe = settings.tool, settings.machine
    for p in settings.polish.processes:
        try:
            p.resolved(nose_radius_mm=tool.nose_radius, feed_mm=lathe.feed_finish, resolution_mm=lathe.resolution)
        except InputError as exc:
            taken = [k for k, v in (("machine.feed_finish", p.feed_mm), ("tool.nose_radius", p.nose_radius_mm)) if v == 0]
            if not taken:
                raise
            raise InputError(f"{exc} (polish.process.{p.name} takes {' and '.join(taken)} from the "
                             "configuration)") from None
