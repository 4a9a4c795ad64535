"""The mount's bore in the second set-up: a centre (spot) drill, a drill the boring bar
enters, the boring bar roughing the bore out in levels and finishing its wall and floor.

Frame: the second set-up's (shop.second): Z0 on the finished back face, the part in -Z,
X0 on the spindle axis; mm. The back face stands `fa` (toolpath.max_finish_depth_mm)
above Z0 when the bore is cut (its finishing pass comes last).

- T6, the spot drill (SPOT_DRILL_MM, 90 deg): a cone at the axis from the face down to a
  spot SPOT_MARGIN_MM wider than the drill (the drill's point starts in it, not on the
  face, and the hole's edge is chamfered).
- T7, the drill (lathe.bore_drill_mm, DRILL_POINT_DEG): the bar's minimum bore plus a
  clearance, a stock size; its full diameter down to `fa` above the
  floor, its point below it, in pecks of at most PECK_DIAMETERS diameters with a retract
  between. Its point below the floor is the one place the part departs from the CAD
  body (a drilled blind hole's "drill point permitted"; the drawing says so); bore_part
  takes it out of the part the simulation protects, and refuses a point that would leave
  less than cad.min_wall above the optical surface.
- T8, the boring bar (toolpath.boring_bar_min_bore_mm, _shank_mm; shop.tool_shapes's
  boring_bar_shape): levels of at most toolpath.rough_depth from the face down to `fa`
  above the floor, each started inside the drilled hole and fed out to `fa` from the
  wall, then up the wall; then (the finishing feed) down the wall to the floor and in
  along it to the drilled hole. Its overhang (the bore's depth and the clearance) at most
  MAX_BAR_OVERHANG shank diameters: a steel bar's limit (WIDIA's small-hole boring bar
  guide: 4 x D for steel, beyond it carbide).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

from ..errors import InputError
from ..lathe import DRILL_POINT_DEG, Tool, bore_drill_mm

from .operations import OperationWriter
from .program import BORING_STATION, CENTRE_DRILL_STATION, DRILL_STATION
from .tool_shapes import boring_bar_shape, drill_shape

if TYPE_CHECKING:
    from ..body import BodySpec
    from ..toolpath import ToolpathSettings
    from .program import Operation

#: The spot drill (mm, its point 90 deg) and how much wider than the drill its spot is.
SPOT_DRILL_MM = 10.0
SPOT_POINT_DEG = 90.0
SPOT_MARGIN_MM = 0.5
#: Deepest peck, in drill diameters (chips clear the flutes between pecks).
PECK_DIAMETERS = 2.0
#: The drill's feed, mm/rev (aluminium, 8-12 mm HSS or carbide drill) and the spot drill's.
DRILL_FEED = 0.1
SPOT_FEED = 0.05
#: Longest overhang of a steel boring bar, in shank diameters.
MAX_BAR_OVERHANG = 4.0
#: The bar's insert: an 80 deg C insert, its flanks up the wall and in along the floor.
BAR_INCLUDED_DEG = 80.0
BAR_APPROACH_DEG = 5.0
#: The bar goes down inside the drilled hole this far (mm) from its wall.
HOLE_CLEARANCE = 0.25


@dataclass(frozen=True)
class BorePlan:
    """The bore's tools and depths (mm): the drill's diameter, the spot's radius on the
    face, the drill point's apex Z, the bar's overhang, and its insert (lathe.Tool)."""

    drill_mm: float
    spot_r: float
    apex_z: float
    overhang_mm: float
    bar: Tool


def bore_plan(body: BodySpec, opts: ToolpathSettings, nose_radius: float, *, vertex_z: float,
              resolution: float) -> BorePlan:
    """The bore's tools and depths; InputError naming the key when the bore is smaller
    than the bar needs, the bar would stand out too far, or the drill's point would leave
    less than cad.min_wall over the optical surface (vertex_z: its lowest Z, here). The
    point's apex is on the lattice (resolution, mm), rounded down."""
    fa, mb, shank = opts.max_finish_depth_mm, opts.boring_bar_min_bore_mm, opts.boring_bar_shank_mm
    if shank > mb - 1.0:
        raise InputError(f"toolpath.boring_bar_shank_mm = {shank:g} mm: the bar's shank must sit inside its "
                         f"minimum bore (toolpath.boring_bar_min_bore_mm = {mb:g} mm) with its insert beside it; "
                         f"allowed <= {mb - 1.0:g} mm")
    drill = bore_drill_mm(mb)
    need = drill + 2.0 * (fa + nose_radius + HOLE_CLEARANCE)
    if body.mount_diameter < need - 1e-9:
        raise InputError(f"cad.mount_diameter = {body.mount_diameter:g} mm: the bore is drilled {drill:g} mm for the "
                         f"boring bar (toolpath.boring_bar_min_bore_mm = {mb:g} mm) and bored out from there; "
                         f"allowed >= {need:g} mm (or a bar of a smaller minimum bore)")
    overhang = body.mount_depth + opts.clearance
    if overhang > MAX_BAR_OVERHANG * shank + 1e-9:
        raise InputError(f"cad.mount_depth = {body.mount_depth:g} mm: the boring bar would stand {overhang:g} mm out "
                         f"of its holder, more than {MAX_BAR_OVERHANG:g} x its shank (toolpath.boring_bar_shank_mm "
                         f"= {shank:g} mm, a steel bar); allowed <= {MAX_BAR_OVERHANG * shank - opts.clearance:g} mm")
    cone = drill / 2.0 / math.tan(math.radians(DRILL_POINT_DEG) / 2.0)
    apex = math.floor((-body.mount_depth + fa - cone) / resolution + 1e-9) * resolution
    if apex - vertex_z < body.min_wall - 1e-9:
        raise InputError(f"cad.mount_depth = {body.mount_depth:g} mm: the {drill:g} mm drill's point would come "
                         f"{apex - vertex_z:.2f} mm from the optical surface; allowed a depth that leaves "
                         f"cad.min_wall = {body.min_wall:g} mm")
    spot_r = min(drill / 2.0 + SPOT_MARGIN_MM, SPOT_DRILL_MM / 2.0 - 0.25)
    bar = Tool(nose_radius=nose_radius, included_angle=math.radians(BAR_INCLUDED_DEG),
               approach_angle=math.radians(BAR_APPROACH_DEG))
    return BorePlan(drill_mm=drill, spot_r=spot_r, apex_z=apex, overhang_mm=overhang, bar=bar)


def boring_shapes(plan: BorePlan, opts: ToolpathSettings) -> dict:
    """{station: ToolShape} of the bore's tools (shop.tool_shapes)."""
    return {CENTRE_DRILL_STATION: drill_shape(SPOT_DRILL_MM, SPOT_POINT_DEG),
            DRILL_STATION: drill_shape(plan.drill_mm, DRILL_POINT_DEG),
            BORING_STATION: boring_bar_shape(plan.bar, opts.boring_bar_min_bore_mm, opts.boring_bar_shank_mm)}


def bore_tools(plan: BorePlan, opts: ToolpathSettings) -> tuple[tuple[int, str], ...]:
    """(station, what it is) of the bore's tools, for the program's header."""
    return ((CENTRE_DRILL_STATION, f"the spot drill, {SPOT_DRILL_MM:g} mm, {SPOT_POINT_DEG:g} deg point, on the axis"),
            (DRILL_STATION, f"the drill, {plan.drill_mm:g} mm, {DRILL_POINT_DEG:g} deg point, on the axis"),
            (BORING_STATION, f"the boring bar: minimum bore {opts.boring_bar_min_bore_mm:g} mm, shank "
                             f"{opts.boring_bar_shank_mm:g} mm, overhang {plan.overhang_mm:g} mm (at most "
                             f"{MAX_BAR_OVERHANG * opts.boring_bar_shank_mm:g}), a C insert with a "
                             f"{plan.bar.nose_radius:g} mm nose; offsets to the nose centre"))


def bore_part(part, body: BodySpec, plan: BorePlan):
    """The part the second set-up makes (shapely, its frame): the CAD body's `part` less
    the drill's point below the bore's floor."""
    import shapely

    r_floor = (-body.mount_depth - plan.apex_z) * math.tan(math.radians(DRILL_POINT_DEG) / 2.0)
    point = shapely.Polygon([(0.0, plan.apex_z), (r_floor, -body.mount_depth), (0.0, -body.mount_depth)])
    return part.difference(point.buffer(1e-4, join_style="mitre")).normalize()


def drill_rpm(lathe, diameter: float) -> int:
    """A drill's constant spindle speed (rev/min): machine.surface_speed at its diameter
    (mm), within the spindle cap (what G96 on the axis would run at)."""
    return int(min(lathe.spindle_max_rpm, math.floor(1000.0 * lathe.surface_speed / (math.pi * diameter))))


def write_bore(planner, pos: tuple[float, float], rough: float, finish: float, body: BodySpec,
               opts: ToolpathSettings, plan: BorePlan, up, down, levels) -> list[Operation]:
    """The bore's operations (see the module doc), each tool from home and back to it:
    spot, drill, rough, finish. planner: the operation writers' (shop.operations.Planner);
    pos: where the tool is (mm); rough, finish: the bar's feeds (mm/rev); up / down round to
    the lattice; levels(hi, lo) the nose-centre Z of levels from hi down to lo."""
    fa, rho, clr = opts.max_finish_depth_mm, plan.bar.nose_radius, opts.clearance
    safe = up(fa + clr)
    ops: list[Operation] = []
    spot = OperationWriter(planner, CENTRE_DRILL_STATION, "centre drill", SPOT_FEED, pos=pos)
    spot.rpm = drill_rpm(planner.lathe, SPOT_DRILL_MM)
    spot.start("centre drill", f"centre drill: the {SPOT_DRILL_MM:g} mm {SPOT_POINT_DEG:g} deg spot drill at the "
                               f"axis, a spot {2 * plan.spot_r:g} mm across for the {plan.drill_mm:g} mm drill",
               first=True)
    spot.rapid((0.0, spot.pos[1]))
    spot.rapid((0.0, safe))
    spot.feed((0.0, down(fa - plan.spot_r)))
    spot.rapid((0.0, safe))
    spot.go_home(stop=False, change=True)
    ops += spot.ops
    d, apex = plan.drill_mm, plan.apex_z
    pecks = max(1, math.ceil((fa - apex) / (PECK_DIAMETERS * d) - 1e-9))
    drill = OperationWriter(planner, DRILL_STATION, "drill", DRILL_FEED, pos=planner.home)
    drill.rpm = drill_rpm(planner.lathe, d)
    drill.start("drill", f"drill: {d:g} mm, {DRILL_POINT_DEG:g} deg point, its full diameter to {fa:g} mm above the "
                         f"bore's floor (the point to Z{apex:.3f}, below it), {pecks} peck{'s' if pecks > 1 else ''}",
                first=True)
    drill.rapid((0.0, drill.pos[1]))
    drill.rapid((0.0, safe))
    for k in range(1, pecks + 1):
        z = apex if k == pecks else down(fa - (fa - apex) * k / pecks)
        drill.feed((0.0, z))
        drill.rapid((0.0, safe))
        if k < pecks:
            drill.rapid((0.0, up(z + 0.5)))
    drill.go_home(stop=False, change=True)
    ops += drill.ops
    r_in = down(d / 2.0 - rho - HOLE_CLEARANCE)
    rm = body.mount_diameter / 2.0
    wall = down(rm - fa - rho)
    above = up(safe + rho)
    bore = levels(fa, -body.mount_depth + fa)
    bar = OperationWriter(planner, BORING_STATION, "boring", rough, pos=planner.home)
    bar.start("bore", f"bore the mount with the boring bar: diameter {body.mount_diameter:g} mm, "
                      f"{body.mount_depth:g} mm deep, {len(bore)} levels from the drilled hole out, {fa:g} mm left "
                      "on the wall and the floor", first=True)
    prev = up(fa + rho)
    for nc in bore:
        bar.rapid((bar.pos[0], above))
        bar.rapid((r_in, above))
        bar.feed((r_in, nc))
        bar.feed((wall, nc))
        bar.feed((wall, prev))
        prev = nc
    bar.rapid((bar.pos[0], above))
    bar.feed_rate = finish  # the next operation's feed: start() writes it
    wall_f, floor_f = down(rm - rho), up(-body.mount_depth + rho)
    bar.start("finish bore", f"finish the bore with the boring bar at the finishing feed: down the wall (diameter "
                             f"{body.mount_diameter:g} mm) to the floor ({body.mount_depth:g} mm deep) and in along "
                             "it to the drilled hole")
    bar.rapid((wall_f, above))
    bar.feed((wall_f, floor_f))
    bar.feed((r_in, floor_f))
    bar.rapid((r_in, above))
    bar.go_home(stop=True, note="check the part and the bore; the finishing tool takes the mount's face with a "
                                "fresh edge")
    return ops + bar.ops
