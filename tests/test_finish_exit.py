"""Every rapid of the first set-up clears the designed part, whatever the nose: the nose
disc (the part turns, so a centre at -r cuts at +r) swept along each rapid stays at least
its radius from the designed surface. The model here is the designed meridian sampled
from the lobes' own sag functions and a distance test, written apart from the project's
stock simulation (shop.stock folds shapely hulls over tiles); the simulation itself is run
on the nose that once failed (0.181 mm on conftest.RECESSED_OUTER: the opposite hand's
finishing pass ended on the axis a lattice step inside the nose radius and went up at
rapid from there).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from conftest import RECESSED_OUTER, run_cli
from lathe_mirror.config import load
from lathe_mirror.job import check_program
from lathe_mirror.shop import plan_program
from lathe_mirror.shop.program import Rapid
from lathe_mirror.shop.program import stations as stations_of

#: Noses swept: both ends of the range a shop stocks around the paper's 0.2 mm, and noses
#: whose centre height over the vertex rounds down on the 0.005 mm lattice (0.152, 0.181,
#: 0.247: before the fix 40 of the 101 noses 0.150..0.250 on the recessed design started a
#: rapid 0.0009 to 0.0019 mm inside the part); each plans and is checked in about a second.
NOSES = [0.15, 0.152, 0.181, 0.2, 0.219, 0.247, 0.25]
#: Surface sampling step (mm): a chord this long sags step^2 / (8 R) < 1e-5 mm below the
#: lobes, so a sampled point inside the disc is a real intrusion.
STEP = 0.005


def _meridian(mirror, stock_radius: float, shoulder_z: float) -> np.ndarray:
    """Points (k, 2) of the designed part's top: inner lobe, step wall, outer lobe,
    shoulder out to the bar (machine frame: Z = vertex_z - sag)."""
    rj, rm, z0 = mirror.r_junction, mirror.r_max, mirror.vertex_z
    ri = np.arange(0.0, rj, STEP)
    ro = np.arange(rj, rm + STEP / 2, STEP)
    zi, zo = z0 - mirror.inner.z(ri), z0 - mirror.outer.z(ro)
    wall_lo, wall_hi = sorted((float(z0 - mirror.inner.z(rj)), float(zo[0])))
    zw = np.arange(wall_lo, wall_hi, STEP)
    rs = np.arange(rm, stock_radius + STEP, STEP)
    return np.concatenate([np.column_stack([ri, zi]), np.column_stack([np.full(zw.size, rj), zw]),
                           np.column_stack([ro, zo]), np.column_stack([rs, np.full(rs.size, shoulder_z)])])


def _rapid_clearance(program) -> float:
    """Least distance (mm) from the designed part to the nose disc's edge along the
    turning tools' rapids (negative: the disc reaches into the part)."""
    tp = program.toolpath
    rho = tp.nose_radius
    m = tp.mirror
    # the shoulder where the finishing pass leaves it (its rim point's nose bottom)
    shoulder = min(tp.segments[-1].end[1] - rho, float(m.vertex_z - m.outer.z(m.r_max)))
    surf = _meridian(m, program.stock.radius, shoulder)
    stations = set(stations_of(tp))
    seg = np.array([[b.move.start, b.move.end] for op in program.operations if op.station in stations
                    for b in op.blocks if isinstance(b, Rapid)], float)
    worst = np.inf
    for s in (seg, seg * [-1.0, 1.0]):  # the rapid and its mirror image: the part turns
        a, ab = s[:, None, 0, :], (s[:, 1] - s[:, 0])[:, None, :]
        t = np.clip(np.sum((surf[None] - a) * ab, axis=2) / np.maximum(np.sum(ab * ab, axis=2), 1e-300), 0.0, 1.0)
        d = np.hypot(*np.moveaxis(surf[None] - a - t[..., None] * ab, 2, 0))
        worst = min(worst, float(d.min()))
    return worst - rho


@pytest.mark.parametrize("design", ["paper", "recessed"])
def test_no_rapid_of_any_nose_touches_the_part(design, tmp_path):
    """Planned whole (part-off included) for each nose: the nose disc along every rapid of
    the turning tools stays out of the designed part (before the fix the 0.181 mm nose on
    the recessed design started its last rapid 0.00094 mm inside it, at the vertex)."""
    cfg = None
    if design == "recessed":
        cfg = tmp_path / "recessed.toml"
        cfg.write_text(RECESSED_OUTER)
    base = load(cfg)
    worst = {}
    for rho in NOSES:
        s = dataclasses.replace(base, tool=dataclasses.replace(base.tool, nose_radius=rho))
        mirror = s.mirror()
        tp = check_program(s, mirror, s.toolpath.strategy)
        prog = plan_program(tp, s.stock, s.toolpath, body=s.body)
        worst[rho] = _rapid_clearance(prog)
    assert min(worst.values()) >= 0.0, worst


def test_the_nose_that_failed_is_simulated_clean(tmp_path):
    """`toolpath` on the recessed design with a 0.181 mm nose: the stock simulation (both
    set-ups) finds no contact and the program is written."""
    cfg = tmp_path / "r.toml"
    cfg.write_text(RECESSED_OUTER + "[tool]\nnose_radius = 0.181\n")
    out = tmp_path / "out"
    out.mkdir()
    res = run_cli("toolpath", "--config", str(cfg), "-o", str(out))
    assert res.returncode == 0, res.stderr
    text = (out / "mirror_arcs.ngc").read_text()
    # past the axis at the contour's last height (the nose centre 0.001 mm below 0.181 on
    # the 0.005 mm lattice), off the vertex at feed by the gouge tolerance (0.005 mm) and a
    # lattice step, then up at rapid
    tail = text[text.index("(finish contour end)"):].splitlines()[1:4]
    assert [ln.split()[1] for ln in tail] == ["G1", "G1", "G0"], tail
    assert tail[0].split()[2:] == ["X-0.070", "Z0.180"] and tail[1].split()[2:] == ["X-0.070", "Z0.190"], tail
