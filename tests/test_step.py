"""STEP of the designed and the programmed mirror: re-imported by OCC and by FreeCAD,
volume against numerical integration, exact faces, reproducible bytes, schemas."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from lathe_mirror.settings import from_config
from lathe_mirror.enums import Mount
from lathe_mirror.body import BodySpec, design_meridian, programmed_parts
from lathe_mirror.export.step import (SCHEMA_NAMES, StepSchema, as_cadquery, read_step,
                                      solid_figures, step_bytes)
from lathe_mirror.profile import ExactProfile

from conftest import require_program
from test_cad_body import integrated_volume

REPO = Path(__file__).resolve().parents[1]

FREECAD_SCRIPT = r'''
import json, os, sys
try:
    import Part
    shape = Part.read(os.environ["LATHE_MIRROR_STEP"])
    solids = shape.Solids
    print("RESULT " + json.dumps({
        "solids": len(solids),
        "valid": bool(shape.isValid()) and all(s.isValid() for s in solids),
        "closed": all(s.isClosed() for s in solids),
        "volume": shape.Volume,
    }))
except Exception as exc:
    print("ERROR %s: %s" % (type(exc).__name__, exc))
    sys.exit(1)
'''


@pytest.fixture(scope="module")
def design(paper_mirror):
    return design_meridian(paper_mirror, BodySpec())


@pytest.fixture(scope="module")
def design_step(tmp_path_factory, design):
    path = tmp_path_factory.mktemp("step") / "design.step"
    path.write_bytes(step_bytes(design))
    return path


@pytest.fixture(scope="module")
def programmed(paper_config, paper_mirror):
    return programmed_parts(_best_toolpath(paper_config, paper_mirror), paper_mirror, BodySpec())


@pytest.fixture(scope="module")
def programmed_step(tmp_path_factory, programmed):
    path = tmp_path_factory.mktemp("step") / "programmed.step"
    path.write_bytes(step_bytes(programmed[0]))
    return path


def test_design_step_is_one_valid_solid_with_the_integrated_volume(design_step, paper_mirror):
    fig = solid_figures(read_step(design_step))
    assert fig["solids"] == 1 and fig["valid"]
    assert fig["volume_mm3"] == pytest.approx(integrated_volume(paper_mirror, BodySpec()), rel=1e-6)


def test_design_faces_follow_the_exact_profile(design_step, paper_mirror):
    """Points of the exact profile (camera-frame ExactProfile, moved to the machine frame)
    at three azimuths lie within 1e-5 mm of the STEP's faces (its shell, not the solid:
    inside a solid the distance is 0). A point 1e-3 mm off the surface must measure
    1e-3 mm: the check can fail."""
    shell = _shell(read_step(design_step))
    prof = ExactProfile(paper_mirror)
    r = np.concatenate([np.linspace(0.0, 20.0, 12), np.linspace(20.0 + 1e-9, 35.0, 12)])
    zm = np.where(r <= 20.0, prof.to_machine_z(paper_mirror.inner.z(r)),
                  prof.to_machine_z(paper_mirror.outer.z(r)))
    dists = []
    for phi in (0.0, 2.1, 4.4):
        pts = np.stack([r * math.cos(phi), r * math.sin(phi), zm], axis=1)
        dists += [_distance(shell, p) for p in pts]
    print(f"exact profile to design faces: max {max(dists):.3g} mm")
    assert max(dists) < 1e-5
    # the negative control: 1e-3 mm along the normal, into the air
    n = prof.normal(np.array([12.0]))[0]  # camera frame (n_r, n_z), n_z < 0: toward the camera
    p = np.array([12.0 + 1e-3 * n[0], 0.0, float(prof.to_machine_z(prof.z(12.0))) - 1e-3 * n[1]])
    assert _distance(shell, p) == pytest.approx(1e-3, rel=1e-3)


def test_programmed_step_is_one_valid_solid(programmed_step, programmed):
    mer = programmed[0]
    fig = solid_figures(read_step(programmed_step))
    assert fig["solids"] == 1 and fig["valid"]
    # OCC's integration of the revolved lines and arcs against Green's theorem on them
    assert fig["volume_mm3"] == pytest.approx(mer.volume(), rel=1e-6)


def test_tool_centre_path_lies_one_nose_radius_from_the_programmed_faces(programmed_step, programmed,
                                                                        paper_config, paper_mirror):
    """The nose (radius rho) touches the surface it cuts (see _assert_nose_touches)."""
    from lathe_mirror.toolpath import Strategy, plan_toolpath

    cfg = paper_config
    tp = plan_toolpath(paper_mirror, from_config(cfg).machine, from_config(cfg).tool,
                       Strategy(cfg["toolpath"]["strategy"]))
    assert tp.nose_radius > 0 and tp.nose_radius == programmed[2]["nose_radius_mm"]
    shell = _shell(read_step(programmed_step))
    _assert_nose_touches(shell, tp, step=5)


def test_freecad_opens_the_steps_as_one_valid_solid(tmp_path, design_step, programmed_step,
                                                     design, programmed, paper_mirror):
    freecad = require_program("freecadcmd")
    script = tmp_path / "check_step.py"
    script.write_text(FREECAD_SCRIPT)
    ap242 = tmp_path / "design_ap242.step"  # the protocol on request reads the same
    ap242.write_bytes(step_bytes(design, schema=StepSchema.AP242))
    expected = {design_step: integrated_volume(paper_mirror, BodySpec()),
                ap242: integrated_volume(paper_mirror, BodySpec()),
                programmed_step: programmed[0].volume()}
    for path, volume in expected.items():
        env = dict(os.environ, LATHE_MIRROR_STEP=str(path))
        proc = subprocess.run([freecad, str(script)], capture_output=True, text=True,
                              env=env, timeout=120, cwd=tmp_path)
        assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
        line = [ln for ln in proc.stdout.splitlines() if ln.startswith("RESULT ")]
        assert line, proc.stdout[-2000:]
        res = json.loads(line[-1][len("RESULT "):])
        assert res["solids"] == 1 and res["valid"] and res["closed"], res
        assert res["volume"] == pytest.approx(volume, rel=1e-6)


def test_same_bytes_in_two_processes(tmp_path):
    code = ("import sys; from lathe_mirror.config import load; "
            "from lathe_mirror.body import design_meridian; "
            "from lathe_mirror.export.step import step_bytes; s = load(); "
            "m = design_meridian(s.mirror(), s.body); "
            "step_bytes(m); sys.stdout.buffer.write(step_bytes(m))")  # the 2nd in-process export
    outs = [subprocess.run([sys.executable, "-c", code], capture_output=True, timeout=120,
                           env=dict(os.environ, PYTHONHASHSEED=str(seed))).stdout
            for seed in (1, 2)]
    assert outs[0].startswith(b"ISO-10303-21;")
    assert outs[0] == outs[1]
    text = outs[0].decode()
    assert "FILE_NAME('lathe-mirror-design','2000-01-01T00:00:00'" in text
    assert "PRODUCT('lathe-mirror','lathe-mirror'" in text  # no per-process counter


@pytest.mark.parametrize("schema", list(StepSchema))
def test_schema_and_units(design, schema):
    text = step_bytes(design, schema=schema).decode()
    header = text[: text.index("ENDSEC;")]
    assert SCHEMA_NAMES[schema] in header
    other = [s for s in StepSchema if s is not schema][0]
    assert SCHEMA_NAMES[other] not in header
    assert ".MILLI.,.METRE." in text.replace(" ", "")


def test_machine_frame(design_step):
    """Axis Z, vertex at the origin, part in -Z: the bounds of the re-imported solid."""
    from OCP.Bnd import Bnd_Box
    from OCP.BRepBndLib import BRepBndLib

    box = Bnd_Box()
    BRepBndLib.AddOptimal_s(read_step(design_step), box, False, False)
    xmin, ymin, zmin, xmax, ymax, zmax = box.Get()
    assert zmax == pytest.approx(0.0, abs=1e-6)
    assert zmin == pytest.approx(-BodySpec().thickness, abs=1e-6)
    assert xmax == pytest.approx(BodySpec().blank_diameter / 2, abs=1e-6)
    assert xmin == pytest.approx(-xmax, abs=1e-6) and ymax == pytest.approx(xmax, abs=1e-6)


# --------------------------------------------------------------------------------------


def _assert_nose_touches(shell, tp, *, step: int) -> None:
    """Points of the moves as the controller cuts them (spirals included), every
    `step`-th move: never closer than rho to the faces (no gouge), and exactly rho for
    the lobes' moves (the nose touches what it cuts; the junction's moves may cut air).
    The STEP's circle through an arc's ends and middle stays within a quarter of the
    spiral's radius mismatch (<= 0.0002 mm) of it: tolerance 1e-4 mm."""
    rho = tp.nose_radius
    dev, air = [], []
    r_end = tp.mirror.r_max
    for move, lobe in list(zip(tp.segments, tp.lobe_of))[::step]:
        if move.end[0] > r_end:
            continue  # beyond the rim the body's shoulder starts (not this pass's cut)
        for p in move.sample(4)[1:3]:
            d = _distance(shell, np.array([p[0] * math.cos(1.0), p[0] * math.sin(1.0), p[1]]))
            (air if lobe == "junction" else dev).append(d - rho)
    dev = np.array(dev)
    print(f"nose centre to programmed faces: max |d - rho| = {np.abs(dev).max():.3g} mm over {dev.size} points")
    assert np.abs(dev).max() < 1e-4
    assert min(air, default=0.0) > -1e-4


def _shell(shape):
    from OCP.TopAbs import TopAbs_SHELL
    from OCP.TopExp import TopExp_Explorer

    exp = TopExp_Explorer(shape, TopAbs_SHELL)
    assert exp.More()
    return exp.Current()


def _distance(shape, p) -> float:
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeVertex
    from OCP.BRepExtrema import BRepExtrema_DistShapeShape
    from OCP.gp import gp_Pnt

    v = BRepBuilderAPI_MakeVertex(gp_Pnt(float(p[0]), float(p[1]), float(p[2]))).Vertex()
    d = BRepExtrema_DistShapeShape(v, shape)
    assert d.IsDone()
    return float(d.Value())


@pytest.mark.parametrize("strategy", ["paper", "lattice"])
def test_line_strategies_give_valid_programmed_solids(paper_config, paper_mirror, strategy):
    """G1-only contours (hundreds of moves, zig-zags from lattice rounding): one valid
    solid that the nose touches and never enters."""

    from lathe_mirror.export.step import meridian_solid
    from lathe_mirror.toolpath import Strategy, plan_toolpath

    settings = from_config(paper_config)
    tp = plan_toolpath(paper_mirror, settings.machine, settings.tool, Strategy(strategy))
    mer, centre, fig = programmed_parts(tp, paper_mirror, BodySpec())
    solid = meridian_solid(mer)
    f = solid_figures(solid)
    assert f["solids"] == 1 and f["valid"]
    assert f["volume_mm3"] == pytest.approx(mer.volume(), rel=1e-6)
    _assert_nose_touches(_shell(solid), tp, step=20)


def test_cadquery_reads_the_step(design_step, paper_mirror):
    """cadquery's own importer (the user-facing layer) sees one solid of the same volume."""
    import cadquery as cq

    shape = cq.importers.importStep(str(design_step))
    solids = shape.solids().vals()
    assert len(solids) == 1 and solids[0].isValid()
    assert solids[0].Volume() == pytest.approx(integrated_volume(paper_mirror, BodySpec()), rel=1e-6)
    wrapped = as_cadquery(read_step(design_step))  # our solid handed to cadquery users
    assert wrapped.isValid() and wrapped.Volume() == pytest.approx(solids[0].Volume(), rel=1e-12)



def test_committed_program_cuts_the_committed_programmed_step(tmp_path, paper_config):
    """Two reference outputs against each other through an independent interpreter:
    LinuxCNC's rs274 runs gcode/mirror_arcs.ngc (the paper program, nose centre
    programmed), and the nose centre along its finishing moves (arcs as LinuxCNC's
    spirals) stays one nose radius from cad/mirror_programmed.step's faces: within 1e-4
    mm on the lobes (the STEP's circle through a spiral's ends and middle is within a
    quarter of its <= 0.0002 mm radius mismatch), never closer anywhere (the junction's
    moves may cut air)."""
    import re


    exe = require_program("rs274")
    program = REPO / "gcode" / "mirror_arcs.ngc"
    # offsets zero: the nose centre (the roughing tool T1, the finishing tool T2)
    (tmp_path / "tools.tbl").write_text("T1 P1 X0 Z0 D0.4 Q9\nT2 P2 X0 Z0 D0.4 Q9\nT5 P5 X0 Z0 D0 Q9\n")  # T5 parts off
    res = subprocess.run([exe, "-t", str(tmp_path / "tools.tbl"), "-g", str(program)],
                         capture_output=True, text=True, cwd=tmp_path, timeout=60,
                         env=dict(os.environ, HOME=str(tmp_path)))
    assert res.returncode == 0, res.stdout[-2000:] + res.stderr[-2000:]
    lines = res.stdout.splitlines()
    i0 = next(i for i, ln in enumerate(lines) if 'COMMENT("finish contour begin")' in ln)
    i1 = next(i for i, ln in enumerate(lines) if 'COMMENT("finish contour end")' in ln)
    pts, cur = [], None
    for ln in lines[:i0]:  # the contour starts where the lead-in left the nose
        m = re.search(r"STRAIGHT_(?:FEED|TRAVERSE)\(([^)]*)\)", ln)
        if m:
            v = [float(x) for x in m.group(1).split(",")]
            cur = np.array([v[0], v[2]])
    for ln in lines[i0 + 1:i1]:
        m = re.search(r"(STRAIGHT_FEED|ARC_FEED)\(([^)]*)\)", ln)
        if not m:
            continue
        v = [float(x) for x in m.group(2).split(",")]
        if m.group(1) == "STRAIGHT_FEED":  # G7: X is the radius
            end = np.array([v[0], v[2]])
            if cur is not None:
                pts += [cur + t * (end - cur) for t in (0.25, 0.5, 0.75)]
        else:  # XZ plane: (first, second) = (Z, X); rotation +1 = clockwise in (r, Z)
            end, c = np.array([v[1], v[0]]), np.array([v[3], v[2]])
            a0, a1 = (math.atan2(p[1] - c[1], p[0] - c[0]) for p in (cur, end))
            sweep = (a1 - a0 + math.pi) % (2 * math.pi) - math.pi  # under half a turn
            assert (sweep < 0) == (v[4] > 0)
            r0, r1 = np.hypot(*(cur - c)), np.hypot(*(end - c))
            pts += [c + (r0 + (r1 - r0) * t) * np.array([math.cos(a0 + sweep * t),
                                                         math.sin(a0 + sweep * t)])
                    for t in (0.25, 0.5, 0.75)]
        cur = end
    rho = from_config(paper_config).tool.nose_radius
    shell = _shell(read_step(REPO / "cad" / "mirror_programmed.step"))
    pts = [p for p in pts if p[0] > 0.0]  # the plunge along the axis cuts nothing
    d = np.array([_distance(shell, np.array([p[0] * math.cos(2.0), p[0] * math.sin(2.0), p[1]]))
                  for p in pts]) - rho
    r = np.array([p[0] for p in pts])
    lobes = np.abs(r - 20.0) > 0.5
    print(f"rs274 nose centre to the committed programmed STEP: {len(pts)} points, "
          f"max |d - rho| on the lobes {np.abs(d[lobes]).max():.3g} mm")
    assert lobes.sum() > 60
    assert np.abs(d[lobes]).max() < 1e-4
    assert d.min() > -1e-4


@pytest.mark.parametrize("spec", [
    BodySpec(blank_diameter=70.0, thickness=25.0, mount=Mount.BOSS, mount_diameter=30.0, mount_depth=10.0),
    BodySpec(blank_diameter=90.0, thickness=40.0, mount=Mount.NONE),
])
def test_other_bodies_give_one_valid_solid_of_the_integrated_volume(tmp_path, paper_mirror, spec):
    """The body is configurable: a boss on a blank exactly the mirror's diameter (no
    shoulder), and a plain thick disc, each through STEP and back."""
    path = tmp_path / "body.step"
    path.write_bytes(step_bytes(design_meridian(paper_mirror, spec)))
    fig = solid_figures(read_step(path))
    assert fig["solids"] == 1 and fig["valid"]
    assert fig["volume_mm3"] == pytest.approx(integrated_volume(paper_mirror, spec), rel=1e-6)


def _best_toolpath(cfg, mirror):
    """The configuration's finishing toolpath (its [toolpath] strategy), as the CAD plans it."""
    from lathe_mirror.job import plan

    s = from_config(cfg)
    return plan(mirror, s.machine, s.tool, s.toolpath.strategy, max_deviation=s.toolpath.max_deviation)
