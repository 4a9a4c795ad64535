"""The second set-up: the parted mirror reversed in soft jaws on its outside diameter, its
back faced to the body's thickness and the mount cut as the CAD body has it.

Its own frame (r, Z), mm: Z0 on the finished back face, the part in -Z (the mirror's
vertex at Z = -thickness), X0 on the spindle axis; a point Z of the first set-up is at
-Z - thickness here (reversed). The stock is the part the first program parted off (the
stock simulation's Simulation.parted), reversed; the designed part is the CAD body's
meridian (body.design_meridian), reversed; the chuck is the soft jaws: on the outside
diameter from the mirror's shoulder up to JAW_GAP below the back face, and the step
under the shoulder the part seats on.

What it cuts, by the CAD body's mount (cad.mount):
- "bore" or "none": the insert as configured (station 1, it cuts from the axis out)
  faces the back in levels of at most toolpath.rough_depth through the axis, leaving
  toolpath.max_finish_depth_mm on the back face; "bore" then bores the pocket of
  mount_diameter x mount_depth in levels, each out to the wall (its nose centre a nose
  radius inside it) and up it; the finishing tool (station 2, a fresh edge, the finishing
  feed) then takes the back face, the face the mirror mounts on, in one pass from the
  bore's edge (or the axis) out.
- "boss": the insert in the opposite-hand holder (station 3, it cuts from the outside
  in) faces the boss's end in levels, then turns the ring around the boss down to the
  back face in levels, each in to the boss's wall and up it, leaving
  max_finish_depth_mm on the ring's face and the wall; the finishing tool in its
  opposite-hand holder (station 4) then takes the ring's face in to the wall and up it.
The nose leaves its radius as a fillet in the inside corners (the bore's floor, the
boss's root); every other dimension is on the lattice, rounded away from the part.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from types import SimpleNamespace
from typing import TYPE_CHECKING

from ..body import design_meridian
from ..enums import Mount
from ..errors import InputError
from ..lathe import GRIP_PER_STAND_OUT, JAW_GAP, JAW_WIDTH, grip_needed
from ..toolpath.moves import Hand
from .boring import BorePlan, bore_part, bore_plan, bore_tools, boring_shapes, write_bore
from .operations import OperationWriter
from .plan import numbered
from .program import (FINISHING_STATION, OPPOSITE_FINISHING_STATION, OPPOSITE_ROUGHING_STATION, ROUGHING_STATION,
                      Program, rough_feed)
from .tool_shapes import insert_shape

if TYPE_CHECKING:
    from ..body import BodySpec

#: The name of the second set-up's first operation (shop.check tells its programs by it).
FACE_BACK = "face back"


@dataclass(frozen=True)
class SecondSetup:
    """The second set-up as the simulation and the set-up sheet need it.

    shapes: {station: ToolShape}; start, part, chuck: shapely (r, Z) of this set-up;
    thickness: the body's (mm); top: the parted face's Z (mm) before facing; grip: (Z low,
    Z high) of the jaws on the outside diameter (mm); station: the roughing tool; finishing:
    the finishing tool; tools: (station, what it is) of every tool; mount: its kind; bore:
    the bore's tools and depths (shop.boring), for a bore.
    """

    shapes: dict = field(repr=False)
    start: object = field(repr=False)
    part: object = field(repr=False)
    chuck: object = field(repr=False)
    thickness: float
    top: float
    grip: tuple[float, float]
    station: int
    mount: Mount
    diameter: float
    finishing: int = FINISHING_STATION
    tools: tuple = ()
    bore: BorePlan | None = None

    @property
    def work_zero(self) -> str:
        return ("Z0 on the finished back face (the part reversed: the mirror's vertex at "
                f"Z-{self.thickness:g}, the parted face at Z{self.top:.3f} before facing), part in -Z; "
                "X0 on the spindle axis, as in the first set-up.")

    @property
    def holding(self) -> str:
        lo, hi = self.grip
        return (f"the part reversed, its mirror face toward the chuck, in soft jaws bored to its outside "
                f"diameter ({self.diameter:g} mm) gripping it from Z{lo:.3f} to Z{hi:.3f} "
                f"({hi - lo:.1f} mm), the shoulder beyond the rim seated on the jaws' step; the optical "
                "surface touches nothing (protect it with paper or film)")


def check_grip(grip: tuple[float, float], top: float, min_grip: float, thickness: float) -> None:
    """InputError naming cad.thickness when the soft jaws' grip (Z low, Z high; mm) is
    shorter than grip_needed."""
    need = grip_needed(top, min_grip)
    have = grip[1] - grip[0]
    if have < need - 1e-9:
        raise InputError(f"cad.thickness = {thickness:g} mm: the second set-up's soft jaws grip the outside diameter "
                         f"from the shoulder to {JAW_GAP:g} mm below the back, {have:.2f} mm; allowed a thickness "
                         f"that leaves at least {need:.2f} mm (toolpath.min_grip_mm = {min_grip:g} mm, and "
                         f"{GRIP_PER_STAND_OUT:g} x the {top + JAW_GAP:.2f} mm the part stands out of the jaws)")


def reverse(geom, thickness: float):
    """A shapely geometry of the first set-up's frame in this one's: Z -> -Z - thickness."""
    import shapely

    return shapely.transform(geom, lambda c: c * [1.0, -1.0] + [0.0, -thickness]).normalize()


def plan_second(first: Program, parted, body: BodySpec, *, name: str) -> Program:
    """The second set-up's program for the part `parted` (shapely, the first set-up's
    frame, shop.stock's Simulation.parted) of the first program `first` (see the module
    doc). InputError naming the key when the part cannot be held or the home is low."""
    import shapely

    tp, opts, lathe, stock = first.toolpath, first.options, first.toolpath.lathe, first.stock
    m, T, res = tp.mirror, body.thickness, lathe.resolution
    boss = body.mount is Mount.BOSS
    tool = Hand.OPPOSITE.held(tp.tool) if boss else tp.tool
    station = OPPOSITE_ROUGHING_STATION if boss else ROUGHING_STATION
    finishing = OPPOSITE_FINISHING_STATION if boss else FINISHING_STATION
    fa = opts.max_finish_depth_mm  # left on the mount's faces for the finishing pass
    rho = tool.nose_radius
    start = reverse(parted, T)
    top = float(start.bounds[3])
    R = float(start.bounds[2])
    part = reverse(shapely.Polygon(design_meridian(m.design, body).polyline(1e-3)).buffer(0), T)
    shoulder = -float(m.vertex_z - m.outer.z(m.r_max)) - T  # the shoulder beyond the rim, reversed
    grip = (round(shoulder, 6), -JAW_GAP)
    check_grip(grip, top, opts.min_grip_mm, T)
    step_in = min(1.5, max(0.0, (R - m.r_max) / 2))
    chuck = shapely.union(shapely.box(R, grip[0] - 1000.0, R + JAW_WIDTH, grip[1]),
                          shapely.box(R - step_in, grip[0] - 1000.0, R + JAW_WIDTH, grip[0]))
    home = first.home
    if home[1] < top + opts.clearance + rho:
        raise InputError(f"toolpath.home_z = {opts.home_z:g} mm: the second set-up's end position must be above "
                         f"the parted face (Z{top:.3f}) by the clearance; allowed >= {top + opts.clearance + rho:g} mm")
    planner = SimpleNamespace(lathe=lathe, opts=opts, home=home)
    b = OperationWriter(planner, station, "roughing", rough_feed(lathe, tool))

    def begin(name: str, note: str) -> None:  # every operation from home, Z first (a restart is safe)
        b.start(name, note, first=True)

    def up(v: float) -> float:
        return math.ceil(v / res - 1e-9) * res

    def down(v: float) -> float:
        return math.floor(v / res + 1e-9) * res

    def levels(hi: float, lo: float) -> list[float]:
        """Nose-centre Z of levels from the surface `hi` down to `lo`, at most rough_depth each."""
        n = max(1, math.ceil((hi - lo) / opts.rough_depth - 1e-9))
        return [round(up(hi - (hi - lo) * k / n + rho), 6) for k in range(1, n + 1)]

    r_out = up(R + opts.clearance)
    face_to = body.mount_depth if boss else fa
    face = levels(top, face_to)
    begin(FACE_BACK, f"{FACE_BACK}: {len(face)} level{'s' if len(face) != 1 else ''} of at most "
            f"{opts.rough_depth:g} mm from the parted face Z{top:.3f} to Z{face_to:g}"
            + (", the boss's end" if boss else f", {fa:g} mm above the back face for its finishing pass"))
    surface = top
    for nc in face:
        safe = up(surface + opts.clearance + rho)
        if boss:  # from outside in, through the axis
            b.rapid((b.pos[0], max(safe, b.pos[1])))
            b.rapid((r_out, b.pos[1]))
            b.rapid((r_out, nc))
            b.feed((0.0, nc))
            b.rapid((0.0, up(nc + opts.clearance)))
        else:  # down at the axis, out past the rim
            b.rapid((b.pos[0], max(safe, b.pos[1])))
            b.rapid((0.0, b.pos[1]))
            b.rapid((0.0, safe))
            b.feed((0.0, nc))
            b.feed((r_out, nc))
        surface = nc - rho
    rm = body.mount_diameter / 2.0
    bore_ops: list = []
    plan = None
    if body.mount is Mount.BORE:
        plan = bore_plan(body, opts, rho, vertex_z=-T, resolution=res)
        part = bore_part(part, body, plan)
        b.go_home(stop=False, change=True)
        bore_ops = write_bore(planner, home, rough_feed(lathe, plan.bar), lathe.feed_finish, body, opts, plan,
                              up, down, levels)
    elif boss:
        wall = up(rm + rho + fa)
        ring = levels(body.mount_depth, fa)
        begin("boss", f"turn the boss: diameter {body.mount_diameter:g} mm, {body.mount_depth:g} mm long, "
                f"{len(ring)} levels from outside in to its wall, and up it")
        safe = up(body.mount_depth + opts.clearance + rho)
        prev = up(body.mount_depth + rho)
        for nc in ring:
            b.rapid((b.pos[0], max(safe, b.pos[1])))
            b.rapid((r_out, b.pos[1]))
            b.rapid((r_out, nc))
            b.feed((wall, nc))
            b.feed((wall, prev))
            prev = nc
    if not bore_ops:
        b.go_home(stop=True, note="check the part; the finishing tool takes the mount's face with a fresh edge")
    fin = OperationWriter(planner, finishing, "finishing", lathe.feed_finish, pos=home)
    face_nc = up(rho)  # the nose's bottom on the finished face, Z0
    if boss:
        wall_f = up(rm + rho)
        fin.start("finish mount", f"finish the mount: the ring's face Z0 from outside in to the boss's wall "
                  f"(diameter {body.mount_diameter:g} mm) and up it, a fresh edge", first=True)
        fin.rapid((r_out, fin.pos[1]))
        fin.rapid((r_out, up(face_nc + opts.clearance)))
        fin.feed((r_out, face_nc))
        fin.feed((wall_f, face_nc))
        fin.feed((wall_f, up(body.mount_depth + rho)))
        fin.rapid((wall_f, up(body.mount_depth + opts.clearance + rho)))
    else:
        r0 = down(rm - rho - opts.clearance / 2) if body.mount is Mount.BORE else 0.0
        r0 = max(r0, 0.0)
        fin.start("finish back", "finish the back face, the face the mirror mounts on, Z0: one pass "
                  + (f"from the bore's edge (diameter {body.mount_diameter:g} mm) out" if r0 > 0 else "from the axis out")
                  + ", a fresh edge", first=True)
        fin.rapid((r0, fin.pos[1]))
        fin.rapid((r0, up(face_nc + fa + opts.clearance)))
        fin.feed((r0, face_nc))
        fin.feed((r_out, face_nc))
        fin.rapid((r_out, up(face_nc + fa + opts.clearance)))
    fin.go_home(stop=False)
    hand = "in the opposite-hand holder (it cuts from the outside in)" if boss else "held as configured (it cuts from the axis out)"
    tools = ((station, f"the roughing insert {hand}"), (finishing, f"the finishing insert {hand}, a fresh edge"))
    shapes = {None: insert_shape(tool)}
    if plan is not None:
        tools += bore_tools(plan, opts)
        shapes.update(boring_shapes(plan, opts))
    setup = SecondSetup(shapes=shapes, start=start, part=part, chuck=chuck, thickness=T,
                        top=top, grip=grip, station=station, mount=body.mount, diameter=2 * R,
                        finishing=finishing, tools=tools, bore=plan)
    return Program(name=name, toolpath=tp, stock=stock, options=opts, operations=numbered(b.ops + bore_ops + fin.ops), home=home,
                   safe_z=up(top + opts.clearance + rho), r_out=r_out, gouge_depth=first.gouge_depth,
                   figures=first.figures, used=first.used, fillet=first.fillet, setup=setup)
