"""Comparing a committed generated file (gcode/, cad/, calib/) with what the code writes
today: the same text and structure, numbers equal to within a stated tolerance, pictures
equal pixel for pixel to within a grey level, CAD read back and measured. Never bytes: a
last-bit difference of a library's arithmetic is not a stale file (issue 23)."""

from __future__ import annotations

import io
import math
import re

import numpy as np

# A number as the writers print it (fixed or scientific); words such as N120 or T0101 are
# split into their letter and their number, and the number is compared like any other.
_NUMBER = re.compile(r"[-+]?(?:\d+\.\d*|\.\d+|\d+)(?:[eE][-+]?\d+)?")
_SVG = re.compile(r"<svg .*?</svg>", re.S)


def _split(text: str) -> tuple[list[str], list[float]]:
    return _NUMBER.split(text), [float(x) for x in _NUMBER.findall(text)]


def numbers_differ(got: str, want: str, *, rel: float, abs_: float) -> str | None:
    """None when got and want have the same text around their numbers and each number of got
    is within abs_ + rel |want| of want's; else a line saying where they first differ."""
    gs, gn = _split(got)
    ws, wn = _split(want)
    if gs != ws:
        for i, (a, b) in enumerate(zip(gs, ws)):
            if a != b:
                return f"text differs near {b!r} (now {a!r})"
        return f"{len(gs)} text pieces against {len(ws)}"
    for a, b in zip(gn, wn):
        if not abs(a - b) <= abs_ + rel * abs(b):
            return f"number {a!r} against the committed {b!r} (tolerance {abs_} + {rel} relative)"
    return None


def gcode_differs(got: str, want: str) -> str | None:
    """G-code: every block outside comments the same text (the words are multiples of the
    lattice, exact); comments (their figures carry 3 to 4 digits) to 1 % or 1e-9."""
    gl, wl = got.splitlines(), want.splitlines()
    if len(gl) != len(wl):
        return f"{len(gl)} lines against the committed {len(wl)}"
    for i, (a, b) in enumerate(zip(gl, wl), 1):
        if "(" in b or ";" in b:
            why = numbers_differ(a, b, rel=1e-2, abs_=1e-9)
            if why:
                return f"line {i}: {why}"
        elif a != b:
            return f"line {i}: {a!r} against the committed {b!r}"
    return None


def html_differs(got: str, want: str) -> str | None:
    """A set-up sheet: the text with numbers to 1e-6 relative (its figures are printed at
    a few digits); each stock picture (inline SVG, coordinates in px at 9 px/mm, written
    to 0.001 px) the same drawing with its coordinates within 0.01 px (about 1 um)."""
    gp, wp = _SVG.findall(got), _SVG.findall(want)
    if len(gp) != len(wp):
        return f"{len(gp)} pictures against the committed {len(wp)}"
    for k, (a, b) in enumerate(zip(gp, wp)):
        why = numbers_differ(a, b, rel=0.0, abs_=0.01)
        if why:
            return f"picture {k}: {why}"
    return numbers_differ(_SVG.sub("SVG", got), _SVG.sub("SVG", want), rel=1e-6, abs_=1e-9)


def dxf_differs(got: bytes, want: bytes, tol_mm: float = 1e-6) -> str | None:
    """Two DXF drawings read back with ezdxf: the same entities (type, layer) in the same
    order, their geometry (points, radii, angles, spline control points and weights, the
    dimensions' measurements) within tol_mm (degrees within tol_mm too)."""
    import ezdxf

    def geometry(doc) -> list[tuple[str, str, list[float]]]:
        out = []
        for e in doc.modelspace():
            t = e.dxftype()
            if t == "LINE":
                v = [*e.dxf.start, *e.dxf.end]
            elif t == "ARC":
                v = [*e.dxf.center, e.dxf.radius, e.dxf.start_angle, e.dxf.end_angle]
            elif t == "CIRCLE":
                v = [*e.dxf.center, e.dxf.radius]
            elif t == "POINT":
                v = [*e.dxf.location]
            elif t == "SPLINE":
                v = [c for p in e.control_points for c in p] + list(e.weights) + list(e.knots)
            elif t == "DIMENSION":
                v = [float(e.get_measurement()), *e.dxf.defpoint]
            else:
                v = []
            out.append((t, e.dxf.layer, [float(x) for x in v]))
        return out

    a = geometry(ezdxf.read(io.StringIO(got.decode("utf-8"))))
    b = geometry(ezdxf.read(io.StringIO(want.decode("utf-8"))))
    if [x[:2] for x in a] != [x[:2] for x in b]:
        return f"entities differ: {len(a)} against the committed {len(b)}"
    for (t, layer, va), (_, _, vb) in zip(a, b):
        if len(va) != len(vb) or not np.allclose(va, vb, rtol=0, atol=tol_mm):
            return f"{t} on {layer}: {va} against the committed {vb}"
    return None


def step_differs(got_path, want_path, tol_mm: float = 1e-6) -> str | None:
    """Two STEP files read back with OpenCASCADE and measured: the same numbers of solids
    and faces, both valid, the same face types in order, volume and area within 1e-9
    relative, and the bounding boxes within tol_mm."""
    from OCP.Bnd import Bnd_Box
    from OCP.BRepAdaptor import BRepAdaptor_Surface
    from OCP.BRepBndLib import BRepBndLib
    from OCP.TopAbs import TopAbs_FACE
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopoDS import TopoDS

    from lathe_mirror.export.step import read_step, solid_figures

    def measure(path):
        shape = read_step(path)
        fig = solid_figures(shape)
        kinds, exp = [], TopExp_Explorer(shape, TopAbs_FACE)
        while exp.More():
            kinds.append(int(BRepAdaptor_Surface(TopoDS.Face_s(exp.Current())).GetType()))
            exp.Next()
        box = Bnd_Box()
        BRepBndLib.AddOptimal_s(shape, box, False, False)
        return fig, kinds, np.array(box.Get())

    (fa, ka, ba), (fb, kb, bb) = measure(got_path), measure(want_path)
    for key in ("solids", "faces", "valid"):
        if fa[key] != fb[key]:
            return f"{key}: {fa[key]} against the committed {fb[key]}"
    if ka != kb:
        return f"face types {ka} against the committed {kb}"
    for key in ("volume_mm3", "area_mm2"):
        if not math.isclose(fa[key], fb[key], rel_tol=1e-9):
            return f"{key}: {fa[key]!r} against the committed {fb[key]!r}"
    if not np.allclose(ba, bb, rtol=0, atol=tol_mm):
        return f"bounding box {ba} against the committed {bb}"
    return None
