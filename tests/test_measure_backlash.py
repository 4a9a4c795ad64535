"""Backlash read off a measured part (measure.backlash, measure.diagnose), round trip.

Parts are cut through machine_errors with a known backlash (the X screw's lost motion,
the zero set approaching in -X: every +X move lands b short), traced and measured:

- the tool's own programs cut the finishing contour in one X direction (checked here
  against the hand: axis -> rim, +X, for a design whose outer lobe stands proud; rim ->
  axis, -X, for one whose outer lobe is recessed). On the paper default the whole pass
  lands b short, which is an X offset of -b: `measure` finds X offset -b (within 0.002 mm)
  and says backlash cannot be split from it; on the recessed design the part is
  untouched: no X offset, and `measure` says backlash does not touch the part;
- the test cut `measure` recommends (the outer lobe's moves run backwards: the two
  lobes cut in opposite X directions) reverses X: its backlash (0.010 mm, with and without
  an X offset of 0.020 mm) is recovered within 0.002 mm, on both designs.
"""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

from conftest import run_cli
from test_machine_errors import trace
from lathe_mirror.job import check_program, machine
from lathe_mirror.machine_errors import MachineErrors
from lathe_mirror.toolpath.moves import reversed_move

BACKLASH_MM = 0.010
TOL_MM = 0.002


@pytest.fixture(scope="module")
def case(design_case):
    s, mirror = design_case["settings"], design_case["mirror"]
    return {**design_case, "tp": check_program(s, mirror, s.toolpath.strategy)}


def reversing_cut(tp):
    """The program with its outer lobe's moves run backwards: the lobes cut toward (paper:
    inner +X, outer -X) or away from (recessed: outer +X, inner -X) each other."""
    outer = [s for s, k in zip(tp.segments, tp.lobe_of) if k == "outer"]
    rest = [(s, k) for s, k in zip(tp.segments, tp.lobe_of) if k != "outer"]
    return dataclasses.replace(tp, segments=tuple([s for s, _ in rest] + [reversed_move(s) for s in reversed(outer)]),
                               lobe_of=tuple([k for _, k in rest] + ["outer"] * len(outer)))


def test_cut_directions_follow_the_hand(case):
    """Each radius's X direction: one direction for the tool's program (by the hand), the
    lobes opposite for the test cut."""
    from lathe_mirror.measure.backlash import directions_at

    m, tp = case["mirror"], case["tp"]
    r = np.concatenate([np.linspace(0.5, m.r_junction - 0.5, 200), np.linspace(m.r_junction + 0.5, m.r_max - 0.3, 200)])
    s = m.lobes[0].slope(np.minimum(r, m.r_junction))
    s = np.where(r <= m.r_junction, s, m.lobes[1].slope(r))
    own = +1 if m.step > 0 else -1
    assert np.all(directions_at(tp, r, s) == own)
    got = directions_at(reversing_cut(tp), r, s)
    assert np.all(got[r < m.r_junction] == own) and np.all(got[r > m.r_junction] == -own)


def test_own_program_backlash_is_said_not_fitted(case):
    """The tool's program: on the paper default backlash b is an X offset of -b; on the
    recessed design it leaves the part as cut."""
    path = trace(case["dir"] / "own.csv", case, case["tp"], MachineErrors(backlash_mm=BACKLASH_MM))
    p = run_cli("measure", str(path), "--json", *(["--config", str(case["cfg"])] if case["cfg"] else []))
    assert p.returncode == 0, p.stderr
    dg = json.loads(p.stdout)["diagnosis"]
    assert dg["backlash_mm"] is None and dg["sigma"]["backlash_mm"] is None
    if case["name"] == "paper":
        assert dg["backlash"] == "plus_only"
        assert abs(dg["x_offset_mm"] + BACKLASH_MM) < TOL_MM
        assert "not separable" in dg["backlash_note"] and "includes -backlash" in dg["backlash_note"]
    else:
        assert dg["backlash"] == "minus_only"
        assert abs(dg["x_offset_mm"]) < TOL_MM / 4
        assert "does not touch this part" in dg["backlash_note"]
    line = next(c for c in dg["corrections"] if c.startswith("backlash:"))
    assert "dial indicator" in line and "outer lobe is cut from the rim in" in line


@pytest.mark.parametrize("x_offset", [0.0, 0.020])
def test_test_cut_recovers_backlash(case, x_offset):
    """The test cut (lobes in opposite X directions) with backlash 0.010 mm (and an X offset):
    `measure` fits both within 0.002 mm and names the backlash as a correction."""
    from lathe_mirror.measure.result import measure

    s, m = case["settings"], case["mirror"]
    cut = reversing_cut(case["tp"])
    path = trace(case["dir"] / f"cut{x_offset}.csv", case, cut,
                 MachineErrors(backlash_mm=BACKLASH_MM, x_offset_mm=x_offset))
    res = measure(path, m, machine(cut), s.tool.nose_radius, toolpath=cut, resolution_mm=s.machine.resolution)
    dg = res.diagnosis.to_dict()
    assert dg["backlash"] == "fitted" and dg["backlash_note"] is None
    assert abs(dg["backlash_mm"] - BACKLASH_MM) < TOL_MM, dg
    assert 0 < dg["sigma"]["backlash_mm"] < TOL_MM
    assert abs(dg["x_offset_mm"] - x_offset) < TOL_MM
    assert any(c.startswith(f"backlash {dg['backlash_mm']:.4f} mm") and "backlash compensation" in c
               for c in dg["corrections"])
    assert res.diagnosis.errors().backlash_mm == pytest.approx(dg["backlash_mm"])
    # the same part with no backlash: none found
    if x_offset == 0.0:
        path = trace(case["dir"] / "clean.csv", case, cut, MachineErrors())
        dg = measure(path, m, machine(cut), s.tool.nose_radius, toolpath=cut,
                     resolution_mm=s.machine.resolution).diagnosis.to_dict()
        assert dg["backlash"] == "fitted" and abs(dg["backlash_mm"]) < TOL_MM / 4
        assert any(c.startswith("backlash: none beyond") for c in dg["corrections"])
