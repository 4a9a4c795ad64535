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


def insert_outline(tool: Tool):
    """The insert in the (r, Z) plane, nose centre at the origin (shapely Polygon, mm)."""
    import shapely

    rho, theta = tool.nose_radius, tool.included_angle
    a1, a2 = tool.flank_directions()
    u1 = np.array([math.cos(a1), math.sin(a1)])
    u2 = np.array([math.cos(a2), math.sin(a2)])
    bis = (u1 + u2) / np.linalg.norm(u1 + u2)
    tip = -(rho / math.sin(theta / 2)) * bis  # the sharp corner the flanks meet at
    edge = edge_length(tool)
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


def edge_length(tool: Tool) -> float:
    """Edge length (mm) of a rhombic insert of inscribed circle INSERT_IC."""
    return INSERT_IC / math.sin(tool.included_angle)


def cutting_zone(tool: Tool):
    """The cutting part of the insert: within nose radius + a quarter edge of the nose
    centre (shapely Polygon, mm, nose centre at the origin)."""
    import shapely

    reach = tool.nose_radius + CUTTING_EDGE_FRACTION * edge_length(tool)
    return insert_outline(tool).intersection(shapely.Point(0.0, 0.0).buffer(reach, quad_segs=32))
