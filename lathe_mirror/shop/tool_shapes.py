"""The tools' shapes in the (r, Z) plane as the stock simulation sweeps them: the turning
insert (a rhombus of the tool's included angle, its tip rounded to the nose radius, the
nose centre at the origin) and the parting blade (a rectangle of the blade's width, its
controlled point the tip's corner on the chuck side). Each shape has a cutting part; the
rest is body, and stock it touches is a contact (shop.stock).

Machine frame (r, Z), mm; shapely geometry, convex (the simulation sweeps the convex
hull of a shape's two end positions).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from ..lathe import Tool

#: Inscribed circle of the insert, mm (a 16 mm V insert, VCGT 1604..: 9.525 mm = 3/8").
INSERT_IC = 9.525
#: The part of each flank that cuts, as a fraction of the edge length (a V insert's
#: usable edge, ~4 mm on a 16.6 mm edge); beyond it the insert is body.
CUTTING_EDGE_FRACTION = 0.25
#: How far the parting blade reaches out from its tip (its usable depth), mm: more than
#: the bar's radius on the lathes this tool plans for; the blade's body beyond.
BLADE_LENGTH = 60.0
#: A drill's body above its point, and its lips' part of it (mm).
DRILL_LENGTH = 60.0
DRILL_LIP = 0.5
#: How much narrower (mm, on the radius) the drill's body is than its lips at its top: a
#: drill's back taper (about 0.02 to 0.08 mm per 100 mm of flute), so it does not rub
#: the hole it cut.
DRILL_BODY_CLEARANCE = 0.02
#: The boring bar: its C insert's inscribed circle (CCGT 0602..: 6.35 mm), the shank's end
#: this far above the nose centre, the shank's length, and the bore's clearance round the
#: bar at its minimum bore (mm).
BAR_INSERT_IC = 6.35
BAR_SHANK_LIFT = 2.0
BAR_LENGTH = 60.0
BAR_CLEARANCE = 0.5
#: The blade's cutting part: its tip, this high (mm, along r) from the cutting edge; its
#: sides beyond it only rub (and are body: a blade moved sideways into stock touches it).
BLADE_TIP = 0.5


@dataclass(frozen=True)
class ToolShape:
    """A tool as the simulation sweeps it: its outline and its cutting part (shapely
    Polygons, controlled point at the origin), and the vertices of each (closed ring
    without the repeated point)."""

    kind: str  # "insert" or "blade"
    outline: object
    cutting: object

    @property
    def outline_xy(self) -> np.ndarray:
        return np.asarray(self.outline.exterior.coords)[:-1]

    @property
    def cutting_xy(self) -> np.ndarray:
        return np.asarray(self.cutting.exterior.coords)[:-1]


def insert_shape(tool: Tool) -> ToolShape:
    """The turning insert (insert_outline, cutting_zone)."""
    return ToolShape(kind="insert", outline=insert_outline(tool), cutting=cutting_zone(tool))


def blade_shape(width: float) -> ToolShape:
    """The parting blade: a rectangle `width` mm along Z from its controlled point (the
    tip's corner on the chuck side, -Z) up, reaching BLADE_LENGTH mm out in +r; it cuts
    with its tip (the first BLADE_TIP mm)."""
    import shapely

    outline = shapely.box(0.0, 0.0, BLADE_LENGTH, width)
    cutting = shapely.box(0.0, 0.0, BLADE_TIP, width)
    return ToolShape(kind="blade", outline=outline, cutting=cutting)


def insert_outline(tool: Tool, ic: float = INSERT_IC):
    """The insert in the (r, Z) plane, nose centre at the origin (shapely Polygon, mm);
    ic: its inscribed circle (mm)."""
    import shapely

    rho, theta = tool.nose_radius, tool.included_angle
    a1, a2 = tool.flank_directions()
    u1 = np.array([math.cos(a1), math.sin(a1)])
    u2 = np.array([math.cos(a2), math.sin(a2)])
    bis = (u1 + u2) / np.linalg.norm(u1 + u2)
    tip = -(rho / math.sin(theta / 2)) * bis  # the sharp corner the flanks meet at
    edge = edge_length(tool, ic)
    rhombus = shapely.Polygon([tip, tip + edge * u1, tip + edge * (u1 + u2), tip + edge * u2])
    if rho == 0.0:
        return rhombus
    return rhombus.buffer(-rho, join_style="mitre").buffer(rho, quad_segs=16)


def reach_toward_axis(tool: Tool, height: float) -> float:
    """How far (mm) the insert reaches toward the axis (-r) from its nose centre at
    heights of at most `height` mm above the nose centre (the band a level's stock
    occupies beside the tool)."""
    import shapely

    ins = insert_outline(tool)
    x0, y0, x1, _ = ins.bounds
    if height <= y0:
        return 0.0
    part = ins.intersection(shapely.box(x0 - 1.0, y0 - 1.0, x1 + 1.0, height))
    return max(0.0, -part.bounds[0]) if not part.is_empty else 0.0


def edge_length(tool: Tool, ic: float = INSERT_IC) -> float:
    """Edge length (mm) of a rhombic insert of inscribed circle ic (mm)."""
    return ic / math.sin(tool.included_angle)


def cutting_zone(tool: Tool, ic: float = INSERT_IC):
    """The cutting part of the insert: within nose radius + a quarter edge of the nose
    centre (shapely Polygon, mm, nose centre at the origin)."""
    import shapely

    reach = tool.nose_radius + CUTTING_EDGE_FRACTION * edge_length(tool, ic)
    return insert_outline(tool, ic).intersection(shapely.Point(0.0, 0.0).buffer(reach, quad_segs=32))


def drill_shape(diameter: float, point_angle_deg: float) -> ToolShape:
    """A drill on the spindle axis (a twist drill, or the 90 deg spot drill that centres
    it): its point's apex the controlled point at the origin, the cone of `point_angle_deg`
    up to the full `diameter` (mm), the body above; both sides of the axis (the
    simulation folds them). It cuts with its lips (the cone); the body's margins only
    rub the hole the lips cut."""
    import shapely

    r = diameter / 2.0
    h = r / math.tan(math.radians(point_angle_deg) / 2.0)  # the cone's height
    b = r - DRILL_BODY_CLEARANCE  # the body behind the margins
    outline = shapely.Polygon([(0.0, 0.0), (r, h), (r, h + DRILL_LIP), (b, h + DRILL_LENGTH), (-b, h + DRILL_LENGTH),
                               (-r, h + DRILL_LIP), (-r, h)])
    cutting = shapely.Polygon([(0.0, 0.0), (r, h), (r, h + DRILL_LIP), (-r, h + DRILL_LIP), (-r, h)])
    return ToolShape(kind="drill", outline=outline, cutting=cutting)


def drill_figures(shape: ToolShape, before, feeds) -> dict:
    """What a machinist sets a drill by, for an operation of the tool `shape` on the stock
    `before` (shapely) whose feed moves are `feeds` (shop.stock's SimMove); {} for a tool
    that is not a drill. drilled_depth_mm: how deep the point goes below the stock's top
    (the face it enters); drilled_full_depth_mm: how deep the hole has the drill's full
    diameter (the point's cone above the apex; None where only the cone went in, as a spot
    drill's). A drill's depth of cut is its radius whatever the program does, so the
    figures carry these instead (mm)."""
    if shape.kind != "drill" or not feeds:
        return {}
    xy = shape.outline_xy
    r = float(xy[:, 0].max())
    cone = float(xy[xy[:, 0] >= r - 1e-12, 1].min())  # the apex at the origin, the full diameter from here up
    point = float(before.bounds[3]) - min(float(mv.move.end[1]) for mv in feeds)
    return {"drilled_depth_mm": point, "drilled_full_depth_mm": point - cone if point > cone else None}


def boring_bar_shape(bar: Tool, min_bore: float, shank: float) -> ToolShape:
    """The boring bar seen in the (r, Z) plane, its nose centre at the origin: the insert
    (`bar`: an 80 deg C insert of BAR_INSERT_IC with its flanks up the wall and in along
    the floor, the nose toward +r and -Z) and the round shank along +Z, from
    BAR_SHANK_LIFT above the nose centre, its back `min_bore` - BAR_CLEARANCE from the
    nose's outer side (the bar's width, tip to back: what a bore must hold), `shank` mm
    thick. A cylinder parallel to the axis covers the radii |c| - shank/2 .. |c| + shank/2
    about its centre c, which is what the folded section gives, so the shank's section is
    exact. The outline is the convex hull of both (the simulation sweeps convex shapes);
    the cutting part the hull within the nose radius and a quarter edge of the nose centre."""
    import shapely

    ins = insert_outline(bar, BAR_INSERT_IC)
    back = bar.nose_radius - (min_bore - BAR_CLEARANCE)
    body = shapely.box(back, BAR_SHANK_LIFT, back + shank, BAR_SHANK_LIFT + BAR_LENGTH)
    outline = shapely.convex_hull(shapely.union(ins, body))
    # the cutting part: the hull near the nose (the hull's sliver beside the wall-side flank
    # is the insert's, not the bar's)
    reach = bar.nose_radius + CUTTING_EDGE_FRACTION * edge_length(bar, BAR_INSERT_IC)
    cutting = outline.intersection(shapely.Point(0.0, 0.0).buffer(reach, quad_segs=32))
    return ToolShape(kind="bar", outline=outline, cutting=cutting)
