"""Backlash: where a program's finishing moves reverse X, and what a trace can tell of it.

The machine's model (machine_errors): lost motion of the X screw with the zero set
approaching in -X, so every move that runs in +X lands backlash_mm short and a move in
-X lands where programmed. On the turned surface: a radius cut by a +X move is the
program's surface moved in toward the axis by b (residual -z'(r) b, z' the design's slope
dz/dr >= 0, machine Z up), a radius cut by a -X move is not moved.

What that leaves observable depends on the program alone:

- the finishing moves reverse X over the traced surface (part of it cut in +X, part in
  -X: e.g. the lobes cut toward each other): the +X part moves against the -X part, a
  signature distinct from an X offset (which moves both): fitted (`diagnose`);
- every finishing move runs +X (the programs here for a design whose outer lobe stands
  proud: axis -> rim): the whole pass lands b short, exactly an X offset of -b; the X
  offset fitted includes it and correcting the X zero by it corrects this program, but
  the trace cannot split the two;
- every finishing move runs -X (a design whose outer lobe is recessed: rim -> axis): the
  direction the zero was set in; backlash does not touch the part.

The tool's own programs (every strategy, both hands) cut the finishing contour in one X
direction; a part cut by a program that reverses (a hand-edited one, or the test cut
TEST_CUT describes) has its backlash fitted.
"""

from __future__ import annotations

import math

import numpy as np

#: Spacing (mm) of the nose-centre samples along the finishing moves.
SAMPLE_MM = 0.01
#: Each direction must cut at least this share of the fitted samples for the backlash to
#: be fitted apart from the X offset.
MIN_SIDE = 0.05

#: What a machinist can do when the part cannot show it.
TEST_CUT = ("to measure it, put a dial indicator on the cross slide, approach in -X and zero it, then "
            "step +X: what the controller moves before the indicator does is the backlash; or cut a test "
            "part whose outer lobe is cut from the rim in (its moves reversed, -X) after the inner lobe "
            "from the axis out (+X) and `measure` it: the lobes' offsets differ by the backlash. Enter it "
            "in the controller's backlash compensation (LinuxCNC [JOINT_0]BACKLASH, Fanuc parameter 1851)")


def centre_directions(toolpath) -> tuple[np.ndarray, np.ndarray]:
    """The finishing moves' nose-centre x (mm) in cutting order, sampled every
    SAMPLE_MM, and the X direction each sample is reached in (+1 / -1): a move that
    does not change X keeps the direction of the last one that did (machine_errors)."""
    xs = []
    for seg in toolpath.cutting_moves():
        p0, p1 = np.asarray(seg.start, float), np.asarray(seg.end, float)
        length = float(np.hypot(*(p1 - p0)))
        if hasattr(seg, "sweep"):
            length = max(length, abs(seg.sweep) * max(seg.radius, seg.end_radius))
        xs.append(seg.sample(max(int(math.ceil(length / SAMPLE_MM)) + 1, 2))[:, 0])
    x = np.concatenate(xs)
    step = np.diff(x)
    moving = np.where(np.abs(step) > 1e-12, np.sign(step), 0.0)
    if not np.any(moving):
        return x, np.ones_like(x)
    first = moving[np.flatnonzero(moving)[0]]
    d = np.concatenate([[first], moving])
    idx = np.where(d != 0, np.arange(d.size), 0)
    np.maximum.accumulate(idx, out=idx)
    return x, d[idx]


def directions_at(toolpath, r: np.ndarray, slope: np.ndarray) -> np.ndarray:
    """The X direction (+1 / -1) of the finishing move that cut each radius r (mm) of the
    surface whose slope dz/dr there is `slope` (>= 0): the nose centre touching it sits
    rho s / sqrt(1 + s^2) farther out (the direction of the nearest sample)."""
    x, d = centre_directions(toolpath)
    s = np.abs(np.asarray(slope, float))
    xc = np.asarray(r, float) + toolpath.nose_radius * s / np.sqrt(1.0 + s * s)
    order = np.argsort(x, kind="stable")
    xs, ds = x[order], d[order]
    i = np.clip(np.searchsorted(xs, xc), 1, xs.size - 1)
    nearer = np.where(np.abs(xs[i - 1] - xc) <= np.abs(xs[i] - xc), i - 1, i)
    return ds[nearer]


def observability(plus: np.ndarray | None) -> str:
    """"fitted" (both directions cut the fitted samples), "plus_only", "minus_only" or
    "unknown" (no program given) from the samples cut in +X (bool array)."""
    if plus is None or plus.size == 0:
        return "unknown"
    share = float(np.mean(plus))
    if MIN_SIDE <= share <= 1.0 - MIN_SIDE:
        return "fitted"
    return "plus_only" if share > 0.5 else "minus_only"


def note(state: str) -> str | None:
    """One line on backlash for a state other than "fitted" (observability)."""
    if state == "plus_only":
        return ("backlash: not separable on this part: every finishing move runs +X, so lost motion lands the "
                "whole pass short, the same as an X offset (the X offset above includes -backlash, and "
                "correcting the X zero by it corrects this program); " + TEST_CUT)
    if state == "minus_only":
        return ("backlash: does not touch this part: every finishing move runs -X, the direction the X zero is "
                "set in (the X offset above is the tool's own); a program cutting in +X would land short by "
                "it: " + TEST_CUT)
    if state == "unknown":
        return "backlash: not judged (the program the part was cut with is not known)"
    return None
