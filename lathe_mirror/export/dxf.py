"""DXF of the mirror's meridian profile for AutoCAD and friends (ezdxf).

Drawing plane: the meridian half plane of the machine frame drawn in the DXF's XY plane,
X = r (radius) and Y = machine Z (the vertex at the origin, the part below, the camera
above at Y = vertex height). Units mm ($INSUNITS = 4).

Layers:
  MIRROR_EXACT  both lobes as exact conics (rational quadratic SPLINEs) and the step wall
  BODY          the rest of the blank's meridian (shoulder, side, back, bore or boss)
  AXIS          the revolution axis (CENTER line type)
  CAMERA        the camera's pinhole and both lobes' viewpoints F1 (POINTs)
  TOOLPATH      the programmed finishing contour, the surface the program cuts: LINEs and
                ARCs (the G-code moves offset back by the nose radius, see
                body.programmed_contour; the moves themselves for a sharp tool)
  TOOL_CENTRE   the path of the tool nose's centre: the G-code's moves as LINE and ARC
                (lathe_mirror.toolpath programs the nose centre)
  DIMENSIONS    both R_top, the vertex and rim heights above the camera (Table 1's h),
                the rim depths below the vertex, and the step between the lobes

The file is reproducible: ezdxf's creation/update dates and GUIDs are written fixed, and
every float group code is rewritten at its stated precision (export.numbers.dxf_text).
"""

from __future__ import annotations

import io
import math
from contextlib import contextmanager
from pathlib import Path
from typing import Iterator, Sequence

from ..body import Meridian, Role, Segment, SegmentKind
from ..design import Mirror
from .numbers import dxf_text

#: The dimension style of the drawing (mm, three decimals).
DIMSTYLE = "LATHE_MIRROR_MM"

LAYERS = {  # name: (AutoCAD colour index, line type)
    "MIRROR_EXACT": (5, "CONTINUOUS"),
    "BODY": (7, "CONTINUOUS"),
    "AXIS": (1, "CENTER"),
    "CAMERA": (3, "CONTINUOUS"),
    "TOOLPATH": (6, "CONTINUOUS"),
    "TOOL_CENTRE": (4, "DASHED"),
    "DIMENSIONS": (30, "CONTINUOUS"),  # orange: legible on dark and light backgrounds
}


def dxf_bytes(mirror: Mirror, design: Meridian, *, programmed: Meridian | None = None,
              tool_centre: Sequence[Segment] | None = None) -> bytes:
    """The DXF (bytes) of the meridian: the exact profile and body of `design`, the
    programmed contour (the face of `programmed`) and the tool-centre path if given."""
    import ezdxf
    from ezdxf import units

    with _fixed_metadata():
        doc = ezdxf.new("R2010", setup=True)
        doc.units = units.MM
        doc.header["$MEASUREMENT"] = 1  # metric
        # Our own dimension style: 1 drawing unit = 1 mm shown as mm (ezdxf's "EZDXF"
        # style scales measurements by 100, for drawings in metres shown in cm).
        doc.dimstyles.new(DIMSTYLE, dxfattribs={
            "dimlfac": 1.0, "dimdec": 3, "dimtxt": 2.0, "dimasz": 1.5, "dimexe": 1.0,
            "dimexo": 0.6, "dimgap": 0.6, "dimtad": 1, "dimzin": 8,
            "dimdsep": ord(".")})
        for name, (color, linetype) in LAYERS.items():
            doc.layers.add(name, color=color, linetype=linetype)
        msp = doc.modelspace()

        for seg in design.segments:
            if seg.role is Role.BODY and seg.start[0] <= 1e-12 and seg.end[0] <= 1e-12:
                continue  # the axis edge: drawn once as the centre line below
            layer = "BODY" if seg.role is Role.BODY else "MIRROR_EXACT"
            _add_segment(msp, seg, layer)

        f = design.features
        vz = mirror.vertex_z  # the camera (z = 0) sits at machine Z = vertex_z
        top = vz + 5.0
        bottom = min(f["z_back"], min(s.end[1] for s in design.segments)) - 5.0
        msp.add_line((0.0, bottom), (0.0, top), dxfattribs={"layer": "AXIS"})
        msp.add_point((0.0, vz), dxfattribs={"layer": "CAMERA"})
        for lobe in mirror.lobes:
            msp.add_point((0.0, vz - lobe.focus_z), dxfattribs={"layer": "CAMERA"})

        if programmed is not None:
            for seg in programmed.face:
                _add_segment(msp, seg, "TOOLPATH")
        for seg in tool_centre or ():
            _add_segment(msp, seg, "TOOL_CENTRE")

        _add_dimensions(msp, mirror, design)
        # ezdxf registers a CLASS per entity type in use by iterating a set, whose order
        # changes with the process's hash seed: register them now in a fixed order (the
        # writer keeps classes already present).
        doc.classes.add_required_classes(doc.dxfversion)
        ordered = sorted(doc.classes.classes.items())
        doc.classes.classes.clear()
        doc.classes.classes.update(ordered)
        stream = io.StringIO()
        doc.write(stream)
    # Every float at its stated precision (export.numbers: mm to 1e-9, degrees to 1e-10).
    return dxf_text(stream.getvalue()).encode("utf-8")


def audit(path_or_bytes: str | Path | bytes) -> list[str]:
    """ezdxf's audit of a DXF: the list of errors (empty when clean)."""
    import ezdxf

    if isinstance(path_or_bytes, bytes):
        doc = ezdxf.read(io.StringIO(path_or_bytes.decode("utf-8")))
    else:
        doc = ezdxf.readfile(str(path_or_bytes))
    auditor = doc.audit()
    return [str(e.message) for e in auditor.errors]


# --------------------------------------------------------------------------------------


def _add_segment(msp, seg: Segment, layer: str) -> None:
    attribs = {"layer": layer}
    if seg.kind is SegmentKind.LINE:
        msp.add_line(seg.start, seg.end, dxfattribs=attribs)
    elif seg.kind is SegmentKind.ARC:
        # DXF arcs run counter-clockwise from start_angle to end_angle (degrees); the
        # drawing's X is r and Y is Z, the frame in which Segment.clockwise is stated.
        t0, t1 = seg.arc_angles()
        a0, a1 = (t1, t0) if seg.clockwise else (t0, t1)
        msp.add_arc(seg.centre, seg.radius, math.degrees(a0), math.degrees(a1), dxfattribs=attribs)
    else:
        # A conic arc is exactly a rational quadratic B-spline (see Segment.conic_bezier).
        ctrl, w = seg.conic_bezier()
        msp.add_rational_spline([tuple(p) for p in ctrl], [1.0, w, 1.0], degree=2,
                                dxfattribs=attribs)


def _add_dimensions(msp, mirror: Mirror, design: Meridian) -> None:
    f = design.features
    vz = mirror.vertex_z
    r1, r2 = f["r_top_inner"], f["r_top_outer"]
    zi, zo, zs = f["z_rim_inner"], f["z_rim_outer"], f["z_step_outer"]
    dims = [
        # (point 1, point 2, base point of the dimension line, angle deg): R_top
        ((0.0, 0.0), (r1, zi), (0.0, 5.0), 0.0),
        ((0.0, 0.0), (r2, zo), (0.0, 11.0), 0.0),
        # the heights above the camera: vertex, inner rim, outer rim (Table 1's h)
        ((0.0, vz), (0.0, 0.0), (-8.0, 0.0), 90.0),
        ((0.0, vz), (r1, zi), (-16.0, 0.0), 90.0),
        ((0.0, vz), (r2, zo), (-24.0, 0.0), 90.0),
        # rim depths below the vertex (machine Z) and the step at the junction
        ((0.0, 0.0), (r1, zi), (r2 + 12.0, 0.0), 90.0),
        ((0.0, 0.0), (r2, zo), (r2 + 20.0, 0.0), 90.0),
        ((r1, zi), (r1, zs), (r1 + 4.0, 0.0), 90.0),
    ]
    for p1, p2, base, angle in dims:
        dim = msp.add_linear_dim(base=base, p1=p1, p2=p2, angle=angle, dimstyle=DIMSTYLE,
                                 dxfattribs={"layer": "DIMENSIONS"})
        dim.render()


@contextmanager
def _fixed_metadata() -> Iterator[None]:
    """ezdxf stamps $TDCREATE/$TDUPDATE with the clock and draws fresh GUIDs; its
    testing switch writes them fixed. Restored afterwards (it is a global option)."""
    import ezdxf

    old = ezdxf.options.write_fixed_meta_data_for_testing
    ezdxf.options.write_fixed_meta_data_for_testing = True
    try:
        yield
    finally:
        ezdxf.options.write_fixed_meta_data_for_testing = old

