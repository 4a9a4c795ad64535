"""plan_program: the whole program around a finishing toolpath (see roughing.py for what
each operation does), checked for the stock, the gouge and the travel, numbered.
"""

from __future__ import annotations

from dataclasses import replace
from typing import TYPE_CHECKING

from ..errors import InputError
from ..lathe import Stock
from ..nose_envelope import as_machined, gouge_depth, junction_fillet
from ..toolpath import check_travel, profile_errors, usable_ranges
from ..toolpath import ToolpathSettings
from .program import MAX_BLOCK_NUMBER, Comment, Operation, Program
from .roughing import plan_operations

#: Longest stick-out of the bar from the first set-up's jaws, in bar diameters: a bar held
#: further out without a tailstock chatters and deflects under the roughing cut. (The
#: second set-up's grip: shop.second, lathe.MIN_GRIP.)
MAX_STICK_OUT_DIAMETERS = 3.0

if TYPE_CHECKING:
    from ..body import BodySpec
    from ..design import Mirror
    from ..lathe import Lathe
    from ..toolpath import Toolpath


def plan_program(toolpath: Toolpath, stock: Stock, options: ToolpathSettings | None = None, *,
                 name: str = "mirror", body: BodySpec | None = None, finish_passes: int = 0) -> Program:
    """The whole program around the finishing contour of `toolpath`.

    Facing through X0, roughing levels (pockets ramped), a semi-finish along the profile
    offset by the allowance into the step's corner, then the finishing contour with the
    finishing tool after an optional stop (ramped onto its start), an optional spring
    pass, and the safe end position. Raises InputError when the stock cannot hold the
    mirror, the contour would gouge the part beyond the tolerance, the home position is
    not above the stock, or a move leaves the lathe's travel. The stock simulation
    (shop.stock) checks the moves themselves. body: the CAD body (body.BodySpec); given,
    the program ends with the part-off at its length (shop.partoff) and the second
    set-up (shop.second) faces the back and cuts the mount.
    """
    options = ToolpathSettings() if options is None else options
    lathe, m = toolpath.lathe, toolpath.mirror
    check_stock(m, stock, options, lathe)
    depth = gouge_depth(toolpath)
    if depth > options.gouge_tolerance:
        raise InputError(
            f"the {toolpath.strategy.value} toolpath would gouge the part by {depth:.4f} mm "
            f"(toolpath.gouge_tolerance = {options.gouge_tolerance:g} mm); program refused "
            "(more points, a finer machine.resolution or another strategy cut closer)"
        )
    made = as_machined(toolpath)
    plan = plan_operations(toolpath, stock, options, finish_passes)
    ops_list, parting = list(plan.operations), None
    if body is not None:
        from .partoff import parting_z, with_partoff  # lazy: shop.partoff off the CLI's start-up path

        z = parting_z(body, stock, options, lathe)
        ops_list = with_partoff(ops_list, plan.home, z, stock, options, lathe)
        parting = (z, options.parting_width_mm)
    ops = numbered(ops_list)
    prog = Program(name=name, toolpath=toolpath, stock=stock, options=options, operations=ops,
                   home=plan.home, safe_z=plan.safe_z, r_out=plan.r_out, gouge_depth=depth,
                   figures=as_machined_figures(made, m), used=profile_errors(made, m.design,
                                                                             r_ranges=usable_ranges(m.design)),
                   fillet=junction_fillet(toolpath), parting=parting)
    check_travel(prog.points(), lathe, what="the program")
    return prog


def as_machined_figures(made, target) -> dict:
    """The as-machined part's profile errors over whole lobes against the design (the one
    definition every output uses: report.json's too); when the program cuts another target
    (polish.precompensate: the design lowered by the polish's planned removal), also
    against that target, under "against_target"."""
    out = profile_errors(made, target.design)
    if target is not target.design:
        out["against_target"] = profile_errors(made, target)["lobes"]
    return out


def check_stock(m: Mirror, stock: Stock, options: ToolpathSettings, lathe: Lathe) -> None:
    """What plan_program asks of the bar and the end position before it plans (closed
    form, ~10 us; settings.validate.check_commands runs it for `design`): the bar wider
    than the mirror and longer than its depth plus the clearance, the end position above
    the bar's face by the clearance and within the lathe's travel."""
    if stock.radius <= m.r_max:
        raise InputError(f"stock.diameter = {stock.diameter:g} mm: must exceed the mirror's "
                         f"diameter {2 * m.r_max:g} mm")
    rim_depth = -(m.vertex_z - float(m.outer.z(m.r_max)))
    if stock.length < rim_depth + options.clearance:
        raise InputError(f"stock.length = {stock.length:g} mm: the mirror is {rim_depth:.3f} mm deep; "
                         f"allowed >= {rim_depth + options.clearance:.3f} mm")
    if options.home_z < stock.face_allowance + options.clearance:
        raise InputError(f"toolpath.home_z = {options.home_z:g} mm: the end position must be above the "
                         f"stock's face by the clearance; allowed >= "
                         f"{stock.face_allowance + options.clearance:g} mm")
    stick_out = stock.length + stock.face_allowance
    if stick_out > MAX_STICK_OUT_DIAMETERS * stock.diameter:
        raise InputError(f"stock.length = {stock.length:g} mm: the bar would stand {stick_out:g} mm out of the jaws, "
                         f"more than {MAX_STICK_OUT_DIAMETERS:g} bar diameters ({stock.diameter:g} mm) held without a "
                         f"tailstock; allowed <= {MAX_STICK_OUT_DIAMETERS * stock.diameter - stock.face_allowance:g} mm")
    if options.home_r > lathe.travel_x:
        raise InputError(f"toolpath.home_r = {options.home_r:g} mm: the end position is beyond the lathe's "
                         f"travel; allowed <= machine.travel_x = {lathe.travel_x:g} mm")
    if options.home_z > lathe.travel_z_max:
        raise InputError(f"toolpath.home_z = {options.home_z:g} mm: the end position is beyond the lathe's "
                         f"travel; allowed <= machine.travel_z_max = {lathe.travel_z_max:g} mm")


def numbered(ops: list[Operation]) -> tuple[Operation, ...]:
    """Number every block but the comments, 1, 2, ... through the whole program."""
    n = 0
    out = []
    for op in ops:
        blocks = []
        for b in op.blocks:
            if not isinstance(b, Comment):
                n += 1
                b = replace(b, number=n)
            blocks.append(b)
        out.append(replace(op, blocks=tuple(blocks)))
    if n > MAX_BLOCK_NUMBER:
        raise InputError(f"the program needs {n} blocks; a block number (N) carries at most "
                         f"{MAX_BLOCK_NUMBER} (fewer points, machine.max_points, or a larger "
                         "toolpath.rough_depth)")
    return tuple(out)
