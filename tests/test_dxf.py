"""DXF of the meridian: audit clean, layers, exact lobes, the programmed moves as drawn,
dimensions equal to Table 1, reproducible bytes."""

from __future__ import annotations

import io
import math

import ezdxf
import numpy as np
import pytest

from lathe_mirror.settings import from_config
from lathe_mirror.body import BodySpec, design_meridian, programmed_parts
from lathe_mirror.export.dxf import LAYERS, audit, dxf_bytes
from lathe_mirror.path import Arc


@pytest.fixture(scope="module")
def drawing(paper_config, paper_mirror):
    spec = BodySpec()
    design = design_meridian(paper_mirror, spec)
    prog, centre, fig = programmed_parts(_best_toolpath(paper_config, paper_mirror), paper_mirror, spec)
    data = dxf_bytes(paper_mirror, design, programmed=prog, tool_centre=centre)
    return data, ezdxf.read(io.StringIO(data.decode())), prog, centre


def test_audit_finds_no_error(drawing):
    data, doc, _, _ = drawing
    assert audit(data) == []
    assert doc.units == 4  # mm


def test_layers(drawing):
    _, doc, prog, centre = drawing
    msp = doc.modelspace()
    assert set(LAYERS) <= {layer.dxf.name for layer in doc.layers}
    assert len(msp.query('SPLINE[layer=="MIRROR_EXACT"]')) == 2  # the two lobes
    assert len(msp.query('LINE[layer=="MIRROR_EXACT"]')) == 1    # the step wall
    assert len(msp.query('*[layer=="TOOLPATH"]')) == len(prog.face)
    assert len(msp.query('*[layer=="TOOL_CENTRE"]')) == len(centre)


def test_lobe_splines_lie_on_the_hyperbolas(drawing, paper_mirror):
    """Each SPLINE, evaluated by ezdxf's own NURBS code, satisfies
    (z - e)^2/a^2 - r^2/b^2 = 1 with z = vertex_z - Y (Table 1's lobes)."""
    _, doc, _, _ = drawing
    splines = sorted(doc.modelspace().query('SPLINE[layer=="MIRROR_EXACT"]'),
                     key=lambda s: s.control_points[0][0])
    for spline, lobe in zip(splines, paper_mirror.lobes):
        pts = np.array(list(spline.construction_tool().points(np.linspace(0, 1, 501))))
        z = paper_mirror.vertex_z - pts[:, 1]
        # distance along z to the sheet at the same r
        dz = z - lobe.z(pts[:, 0])
        assert np.abs(dz).max() < 1e-9
    assert splines[0].control_points[0][:2] == pytest.approx((0.0, 0.0))
    assert splines[1].control_points[-1][0] == pytest.approx(35.0)


def test_arcs_are_drawn_the_way_the_tool_moves(drawing, paper_config, paper_mirror):
    """Every TOOL_CENTRE ARC passes through its move's ends and its middle (a DXF arc
    runs counter-clockwise: a clockwise move must be drawn from its end)."""
    from lathe_mirror.toolpath import Strategy, plan_toolpath

    _, doc, _, _ = drawing
    tp = plan_toolpath(paper_mirror, from_config(paper_config).machine, from_config(paper_config).tool,
                       Strategy(paper_config["toolpath"]["strategy"]))
    moves = [m for m in tp.segments if m.start != m.end]
    entities = list(doc.modelspace().query('*[layer=="TOOL_CENTRE"]'))
    assert len(entities) == len(moves)
    n_arcs = 0
    for e, m in zip(entities, moves):
        mid = m.sample(3)[1]
        if isinstance(m, Arc):
            n_arcs += 1
            assert e.dxftype() == "ARC"
            ends = [tuple(e.start_point)[:2], tuple(e.end_point)[:2]]
            for p in (m.start, m.end):
                assert min(math.dist(p, q) for q in ends) < 1e-6
            c = e.dxf.center
            a_mid = math.degrees(math.atan2(mid[1] - c[1], mid[0] - c[0])) % 360
            assert _on_ccw_arc(a_mid, e.dxf.start_angle, e.dxf.end_angle)
            # spiral vs its circle through the ends and the middle
            assert math.dist(mid, tuple(c)[:2]) == pytest.approx(e.dxf.radius, abs=1e-4)
        else:
            assert e.dxftype() == "LINE"
            assert tuple(e.dxf.start)[:2] == pytest.approx(m.start) and tuple(e.dxf.end)[:2] == pytest.approx(m.end)
    assert n_arcs > 0


def test_dimensions_are_the_design(drawing):
    """R_top (20, 35), heights above the camera of the vertex (103.678) and the rims
    (Table 1's h: 115.607, 123.457), rim depths and the step (1.821)."""
    _, doc, _, _ = drawing
    dims = list(doc.modelspace().query('DIMENSION[layer=="DIMENSIONS"]'))
    got = sorted(round(d.get_measurement(), 3) for d in dims)
    want = sorted([20.0, 35.0, 103.678, 115.607, 123.457, 115.607 - 103.678, 123.457 - 103.678, 1.821])
    assert got == pytest.approx(want, abs=1.5e-3)
    # ... and the text a reader sees is that number in mm (no unit scaling, a point)
    shown = sorted(float(_dimension_text(d)) for d in dims)
    assert shown == pytest.approx(want, abs=1.5e-3)


def _dimension_text(dim) -> str:
    texts = [e.dxf.text for e in dim.get_geometry_block() if e.dxftype() == "MTEXT"]
    assert len(texts) == 1
    return texts[0]


def test_same_bytes_twice(paper_config, paper_mirror, drawing):
    spec = BodySpec()
    design = design_meridian(paper_mirror, spec)
    prog, centre, _ = programmed_parts(_best_toolpath(paper_config, paper_mirror), paper_mirror, spec)
    again = dxf_bytes(paper_mirror, design, programmed=prog, tool_centre=centre)
    assert again == drawing[0]
    assert b"$TDCREATE" in again  # present, and fixed by _fixed_metadata


def _on_ccw_arc(a: float, start: float, end: float) -> bool:
    span = (end - start) % 360
    return (a - start) % 360 <= span


def _best_toolpath(cfg, mirror):
    """The configuration's finishing toolpath (its [toolpath] strategy), as the CAD plans it."""
    from lathe_mirror.job import plan

    s = from_config(cfg)
    return plan(mirror, s.machine, s.tool, s.toolpath.strategy, max_deviation=s.toolpath.max_deviation)
