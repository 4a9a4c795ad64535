"""The set-up sheet's model: what the operator needs to run a program, as numbers.

Work zero (Z0 at the mirror's vertex, X0 on the spindle axis), the stock and how far it
must stand out of the chuck, each tool (insert designation, holder, station, tip code
per dialect), the offsets to enter for the nose-centre convention the program uses
(touch the bar's face with the nose's bottom: Z = the face's Z + nose radius; touch a
diameter D with the side of the nose the tool can present: X = D - 2 nose radius for a
bore, D + 2 nose radius for an outside diameter), the centre-height tolerance, what a
0.01 mm setting error costs (tolerance.setting), and per operation its restart block,
the simulation's figures and time (shop.stock). Lengths in mm, times in s.

Which side of the nose can touch what follows from the tool's angles (lathe.Tool): the
nose's arc is exposed from the leading flank's outward normal round through -Z to the
trailing flank's; a direction the insert's body hides cannot touch anything. The paper's
tool (35 deg insert, 3 deg approach) exposes 218 deg to 363 deg from +r: it touches a face
(-Z) and a bore (+r), never an outside diameter.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from ..lathe import grip_needed
from .program import (BORING_STATION, CENTRE_DRILL_STATION, DRILL_STATION, OPPOSITE_ROUGHING_STATION, PARTING_STATION,
                      stations)
from .boring import DRILL_POINT_DEG, MAX_BAR_OVERHANG, SPOT_DRILL_MM, SPOT_POINT_DEG
from .tool_shapes import INSERT_IC, edge_length

if TYPE_CHECKING:
    from ..lathe import Tool
    from .program import Program
    from .stock import Simulation

#: The spindle direction every tool cuts with (M3), as the sheet states it.
SPINDLE = ("M3: clockwise looking from the headstock along +Z (ISO 6983); the insert's rake face toward "
           "the oncoming surface (up in a front tool post, down on a rear turret)")
#: The drills' spindle direction: the work turning M3 is a right-hand drill's cutting
#: direction (clockwise seen from its shank, relative to the work).
DRILL_SPINDLE = "M3: clockwise looking from the headstock along +Z (ISO 6983); a right-hand drill"
#: The bar's length in the first set-up's jaws, mm (the blank is the stick-out plus this).
BAR_GRIP = 10.0

#: ISO 1832 shape letters by included angle (deg).
_SHAPES = {35: "V", 55: "D", 60: "T", 80: "C", 90: "S"}


@dataclass(frozen=True)
class Offsets:
    """How to set one tool's offsets for the nose-centre convention.

    z_touch: what the nose touches for Z and the value to enter (mm); x_touch: the same
    for X (a diameter D, in the program's X convention). z_entry(face_z) and
    x_entry(diameter) give the numbers; each dialect (export.dialects) names the tip code
    of the controlled point: the nose centre, or a sharp corner when nose_radius is 0.
    """

    nose_radius: float
    diameter_mode: bool
    x_side: str  # "bore" (the nose's +r side touches an inside diameter) or "outside"

    def z_entry(self, face_z: float) -> float:
        """Z to enter (mm) with the nose's bottom touching a face at machine Z face_z."""
        return face_z + self.nose_radius

    def x_entry(self, diameter: float) -> float:
        """X to enter with the nose touching a diameter (mm): the nose centre's X."""
        sign = -1.0 if self.x_side == "bore" else 1.0
        centre_r = diameter / 2.0 + sign * self.nose_radius
        return 2.0 * centre_r if self.diameter_mode else centre_r


@dataclass(frozen=True)
class ToolSheet:
    """One tool's line on the sheet: its station, role, insert, holder (with its hand),
    spindle direction, the offsets' convention, and a short label for the tool table's
    comment. Each dialect writes its table entry from these (export.dialects)."""

    station: int
    role: str
    insert: str
    holder: str
    offsets: Offsets
    label: str
    spindle: str = SPINDLE


@dataclass(frozen=True)
class OperationSheet:
    """One operation's line: its restart block and the simulation's figures."""

    name: str
    station: int
    restart_block: int
    figures: dict
    stock_after: object = field(repr=False)
    removed: object = field(repr=False)


@dataclass(frozen=True)
class SetupSheet:
    """Everything the sheet shows (see the module doc); files: the programs it goes with."""

    name: str
    strategy: str
    diameter_mode: bool
    stock: dict
    work_zero: str
    tools: tuple[ToolSheet, ...]
    face_z: float
    centre_height_mm: float
    setting_costs: dict
    operations: tuple[OperationSheet, ...]
    cycle_time_s: float
    home: tuple[float, float]
    stock_start: object = field(repr=False)
    part: object = field(repr=False)
    notes: tuple[str, ...] = ()
    inspection: tuple[InspectionRow, ...] = ()
    second: SecondSheet | None = None

    @property
    def total_time_s(self) -> float:
        """Both set-ups' cycle times, s."""
        return self.cycle_time_s + (self.second.cycle_time_s if self.second is not None else 0.0)


@dataclass(frozen=True)
class SecondSheet:
    """The second set-up on the sheet (shop.second): its program's name, work zero, holding
    and grip length (mm), the Z and X touch-off, its tools, its operations and time, its stock and part
    pictures' geometry (this set-up's frame)."""

    name: str
    work_zero: str
    holding: str
    grip_mm: float
    touch_off: tuple[str, ...]
    tools: tuple[ToolSheet, ...]
    operations: tuple[OperationSheet, ...]
    cycle_time_s: float
    stock_start: object = field(repr=False)
    part: object = field(repr=False)
    deepest_z_mm: float = 0.0
    min_grip_mm: float = 0.0


@dataclass(frozen=True)
class InspectionRow:
    """One probe point of the inspection table: the lobe, the radius r (mm), the nominal
    machine Z (mm, from the datum V1: Z0 at the inner vertex), the sag from the lobe's own
    vertex (mm), the surface's slope there (rad) and the band (+/- um about the nominal,
    after the best-fit piston) the form tolerance allows."""

    lobe: str
    r_mm: float
    z_mm: float
    sag_mm: float
    slope_rad: float
    band_um: float


def exposed_arc(tool: Tool) -> tuple[float, float]:
    """Directions (rad, from +r toward +Z, increasing) from which the nose's arc can
    touch: from the leading flank's outward normal round to the trailing flank's
    (the wedge between the flanks is the insert's body)."""
    a1, a2 = tool.flank_directions()
    return a2 + math.pi / 2, a1 - math.pi / 2 + 2 * math.pi


def can_touch(tool: Tool, direction: float) -> bool:
    """True if the nose can touch a surface at `direction` (rad) from its centre."""
    lo, hi = exposed_arc(tool)
    d = (direction - lo) % (2 * math.pi)
    return d <= (hi - lo) + 1e-12


def holder_text(insert: str, approach: int, x_side: str, opposite: bool) -> str:
    """The holder and its hand. The as-configured insert's edges run up from its nose at
    90 + approach and 90 + approach + included deg from +X toward +Z: the right-hand (R)
    outside-turning seat (edges at approach and approach + included deg) turned 90 deg
    about the vertical, which keeps the hand; the opposite-hand holder is its mirror image (L)."""
    kind = "SVJC" if insert.startswith("V") else "ISO style J"
    if opposite:
        return (f"{approach} deg approach holder, LEFT hand ({kind}L seat, shank along Z: its body toward the rim), "
                "the tip toward -Z and -X: it cuts from the rim in (the outer lobe is recessed; its step wall "
                "faces the rim)")
    return (f"{approach} deg approach holder, RIGHT hand ({kind}R seat, shank along Z: its body toward the axis), "
            f"the tip toward -Z and {'+X: it cuts from the axis outward' if x_side == 'bore' else '-X'}")


def insert_designation(tool: Tool) -> str:
    """ISO 1832-style insert name: shape, 7 deg clearance, G tolerance, T (hole and chip
    breaker), edge length, 04 thickness, nose radius code (0.2 mm -> 02)."""
    deg = round(math.degrees(tool.included_angle))
    shape = _SHAPES.get(deg)
    if shape is None:
        return f"rhombic insert {deg} deg, {tool.nose_radius:g} mm nose (no ISO shape letter)"
    size = int(edge_length(tool))
    nose = f"{round(tool.nose_radius * 10):02d}" if tool.nose_radius > 0 else "00"
    return f"{shape}CGT {size:02d}04{nose}"


def setup_sheet(program: Program, simulation: Simulation, setting_costs: dict,
                inspection: tuple[InspectionRow, ...] = (), *, second: Program | None = None,
                second_simulation: Simulation | None = None) -> SetupSheet:
    """The sheet of a planned, simulated program (see the module doc), with its part-off's
    blade and its second set-up (second_sheet) when it has them."""
    tp, stock, lathe = program.toolpath, program.stock, program.toolpath.lathe
    tool, m = tp.held_tool, tp.mirror  # as the program's hand holds it (toolpath.Hand)
    opposite = tp.held_tool is not tp.tool
    rho = tool.nose_radius
    if can_touch(tool, -math.pi / 2):
        face_z = stock.face_allowance
    else:  # a tool that cannot present its nose to a face: a bug of the tool checks
        raise RuntimeError("the tool cannot touch a face with its nose")
    x_side = "bore" if can_touch(tool, 0.0) else "outside"
    offs = Offsets(nose_radius=rho, diameter_mode=lathe.diameter_mode, x_side=x_side)
    approach = 90 + round(math.degrees(tp.tool.approach_angle))
    insert = insert_designation(tool)
    tools = []
    rough_station, finish_station = stations(tp)
    for station, role in ((rough_station, "roughing"), (finish_station, "finishing, a fresh edge")):
        tools.append(ToolSheet(
            station=station, role=role, insert=insert + ("" if station == rough_station else " (polished, for aluminium)"),
            holder=holder_text(insert, approach, x_side, opposite), offsets=offs,
            label=f"{insert} {role.split(',')[0]}, nose centre" + (", opposite hand" if opposite else "")))
    if program.parting is not None:
        tools.append(blade_sheet(program.parting[1], lathe.diameter_mode))
    ops = []
    for op, fig in zip(program.operations, simulation.operations):
        ops.append(OperationSheet(name=op.name, station=op.station, restart_block=op.number,
                                  figures=fig.figures(), stock_after=fig.stock_after, removed=fig.removed))
    # a tool off centre by h cannot cut r < h: a pip of radius h at the vertex; keep it
    # inside the one pixel the vertex images to (t_pixel z / f on the mirror)
    cam = m.design.camera
    centre_height = cam.t_pixel * m.vertex_z / cam.f
    deepest = float(program.points()[:, 1].min())
    notes = (
        "The program moves the nose CENTRE and applies no nose compensation (G40): the "
        "offsets above put the nose centre where the program expects it.",
        f"Cycle time: feeds at the G96 surface speed {lathe.surface_speed:g} m/min with the "
        f"spindle capped at {lathe.spindle_max_rpm} rpm, rapids at {program.options.rapid_rate:g} mm/min; "
        "tool changes and the optional stop are not included.",
        f"Roughing feed {program.rough_feed:g} mm/rev: machine.feed_rough ({lathe.feed_rough:g} mm/rev)"
        + (", at most half the nose radius per revolution (configure machine.feed_rough to take another)."
           if program.rough_feed < lathe.feed_rough else "."),
    )
    stick_out = stock.length + stock.face_allowance  # at most MAX_STICK_OUT_DIAMETERS bars (shop.plan)
    grip = max(BAR_GRIP, program.options.min_grip_mm)  # the jaws on the bar: at least toolpath.min_grip_mm
    stock_info = {"diameter_mm": stock.diameter, "face_allowance_mm": stock.face_allowance,
                  "length_mm": stock.length, "deepest_z_mm": deepest,
                  "stick_out_mm": stick_out, "grip_mm": grip, "blank_length_mm": stick_out + grip,
                  "insert_ic_mm": INSERT_IC}
    return SetupSheet(
        name=program.name, strategy=tp.strategy.value,
        diameter_mode=lathe.diameter_mode,
        stock=stock_info,
        work_zero=("Z0 at the mirror's vertex (the finished front), part in -Z; the bar's face is "
                   f"Z{stock.face_allowance:g} before facing. X0 on the spindle axis; X words are "
                   + ("diameters (G7)." if lathe.diameter_mode else "radii (G8).")),
        tools=tuple(tools), face_z=face_z, centre_height_mm=centre_height,
        setting_costs=setting_costs, operations=tuple(ops), cycle_time_s=simulation.cycle_time_s,
        home=program.home, stock_start=simulation.stock_start, part=simulation.part, notes=notes,
        inspection=tuple(inspection),
        second=second_sheet(second, second_simulation, tools) if second is not None else None)


def blade_sheet(width: float, diameter_mode: bool) -> ToolSheet:
    """The parting blade's line: its controlled point is the tip's corner on the chuck
    side, so Z is touched with the blade's chuck-side face on the bar's face (enter that
    face's Z) and X with its tip on the bar's outside diameter (enter the diameter)."""
    offs = Offsets(nose_radius=0.0, diameter_mode=diameter_mode, x_side="outside")
    return ToolSheet(
        station=PARTING_STATION, role="parting off", insert=f"parting blade and insert, {width:g} mm wide",
        holder="blade holder square to the axis, the blade's tip at centre height, toward -X; its hand: the "
               "insert's corner toward the chuck (-Z)",
        offsets=offs, label=f"parting blade {width:g} mm, tip corner on the chuck side")


def bore_sheets(plan, opts, diameter_mode: bool) -> list[ToolSheet]:
    """The bore's tools (shop.boring): the spot drill and the drill on the axis (their point
    the controlled point: Z with the point touching the face, X0 on the spindle axis) and
    the boring bar (its nose centre, X touched on a bore with the nose's +r side)."""
    point = Offsets(nose_radius=0.0, diameter_mode=diameter_mode, x_side="outside")
    held = ("in a drill holder (collet) on the turret, its axis on the spindle axis (X0: set it on centre with a "
            "test indicator); no hand")
    rho = plan.bar.nose_radius
    bar_name = f"boring bar {opts.boring_bar_shank_mm:g} mm shank, min bore {opts.boring_bar_min_bore_mm:g} mm"
    return [
        ToolSheet(station=CENTRE_DRILL_STATION, role="centre drill (second set-up)",
                  insert=f"NC spot drill {SPOT_DRILL_MM:g} mm, {SPOT_POINT_DEG:g} deg", holder=held, offsets=point,
                  spindle=DRILL_SPINDLE,
                  label=f"spot drill {SPOT_DRILL_MM:g} mm {SPOT_POINT_DEG:g} deg, point on the axis"),
        ToolSheet(station=DRILL_STATION, role="drill (second set-up)",
                  insert=f"twist drill {plan.drill_mm:g} mm, {DRILL_POINT_DEG:g} deg point (aluminium)",
                  holder=held, offsets=point, label=f"drill {plan.drill_mm:g} mm, point on the axis",
                  spindle=DRILL_SPINDLE),
        ToolSheet(station=BORING_STATION, role="boring (second set-up)",
                  insert=f"CCGT 0602{round(rho * 10):02d} (80 deg, {rho:g} mm nose), a fresh edge for the finish",
                  holder=(f"{bar_name}, 95 deg (SCLC), RIGHT hand: the tip toward +X and -Z, it bores from the "
                          f"drilled hole out; overhang {plan.overhang_mm:g} mm (steel bar: at most "
                          f"{MAX_BAR_OVERHANG:g} x the shank, {MAX_BAR_OVERHANG * opts.boring_bar_shank_mm:g} mm)"),
                  offsets=Offsets(nose_radius=rho, diameter_mode=diameter_mode, x_side="bore"),
                  label=f"{bar_name}, nose centre")]


def second_sheet(program: Program, simulation: Simulation, first_tools: list[ToolSheet]) -> SecondSheet:
    """The second set-up's part of the sheet (see shop.second): its roughing and finishing
    tools (the first set-up's where the station is the same), the touch-off."""
    su, lathe = program.setup, program.toolpath.lathe
    rho = program.toolpath.tool.nose_radius
    insert = insert_designation(program.toolpath.tool)
    outside = su.station == OPPOSITE_ROUGHING_STATION  # the opposite hand touches the outside diameter
    offs = Offsets(nose_radius=rho, diameter_mode=lathe.diameter_mode, x_side="outside" if outside else "bore")
    approach = 90 + round(math.degrees(program.toolpath.tool.approach_angle))
    tools = []
    for station, role in ((su.station, "roughing (second set-up)"), (su.finishing, "finishing (second set-up)")):
        known = next((t for t in first_tools if t.station == station), None)
        tools.append(known if known is not None else ToolSheet(
            station=station, role=role, insert=insert, holder=holder_text(insert, approach, offs.x_side, outside),
            offsets=offs, label=f"{insert} {role.split(' ')[0]}, nose centre" + (", opposite hand" if outside else "")))
    if all(any(t.station == k for t in first_tools) for k in (su.station, su.finishing)):
        x_touch = (f"X: unchanged from the first set-up (T{su.station}, T{su.finishing}; X0 is the spindle axis in both)")
    elif outside:
        x_touch = (f"X: touch the part's outside diameter D (measured) with the nose's inner side and enter "
                   f"X = D + {2 * rho:g} mm" + (" (X is the diameter)" if lathe.diameter_mode else " (X is the radius: D / 2 + rho)"))
    else:
        x_touch = (f"X: in MDI cut a test recess into the parted face from the axis out to about D = 20 mm, 0.2 mm "
                   f"deep (the facing removes it), measure D and enter X = D - {2 * rho:g} mm")
    z_touch = (f"Z: measure the part's length L from the mirror's vertex to the parted face; the parted face is at "
               f"Z = L - {su.thickness:g} (nominally Z{su.top:.3f}); touch it with the nose's bottom and enter "
               f"Z = L - {su.thickness:g} + {rho:g} mm")
    touch_off = (z_touch, x_touch)
    if su.bore is not None:
        tools += bore_sheets(su.bore, program.options, lathe.diameter_mode)
        d = su.bore.drill_mm
        touch_off += (f"T{CENTRE_DRILL_STATION}, T{DRILL_STATION} (drills): X0 with the drill's axis on the spindle "
                      "axis (a test indicator round its shank); Z with its point touching the parted face, enter that "
                      f"face's Z as for T{su.station}",
                      f"T{BORING_STATION} (boring bar): Z as for T{su.station} (the nose's bottom on the parted face); "
                      f"X: after the drill, touch the drilled hole (nominally {d:g} mm, measure it: D) with the nose's "
                      f"+X side and enter X = D - {2 * su.bore.bar.nose_radius:g} mm")
    ops = tuple(OperationSheet(name=op.name, station=op.station, restart_block=op.number, figures=fig.figures(),
                               stock_after=fig.stock_after, removed=fig.removed)
                for op, fig in zip(program.operations, simulation.operations))
    lo, hi = su.grip

    return SecondSheet(name=program.name, work_zero=su.work_zero, holding=su.holding, grip_mm=hi - lo,
                       min_grip_mm=grip_needed(su.top, program.options.min_grip_mm),
                       touch_off=touch_off, tools=tuple(tools), operations=ops,
                       cycle_time_s=simulation.cycle_time_s, stock_start=su.start, part=su.part,
                       deepest_z_mm=float(program.points()[:, 1].min()))
