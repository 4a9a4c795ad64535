"""The checks of whether a trace is this part that need no fit (measure.judge's first ones):
made on the trace as read, before the fit (seconds, with --fit-conic) is spent on a trace
they refuse, and again in the verdict.

- points: at least MIN_POINTS;
- x spread: not all at one x;
- heights: the heights' PV at least MIN_HEIGHT_SPAN_MM (a trace with no height at all is
  no profile: the instrument's floor).

The lateral extent and the share of points on the lobes are the fit's: they take the part's
axis, which only the fit finds.
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError

MIN_POINTS = 200
MIN_HEIGHT_SPAN_MM = 1e-4


def check_row(name: str, ok, figure: str, cause: str) -> dict:
    """One check of the verdict: its name, whether it holds, its figure, and the likely
    cause when it does not."""
    return {"check": name, "ok": bool(ok), "figure": figure, "likely_cause": None if ok else cause}


def trace_checks(x: np.ndarray, z: np.ndarray) -> list[dict]:
    """The checks (check_row) of the trace's x and z (mm) that need no fit."""
    n = int(x.size)
    span_x = float(np.ptp(x)) if n else 0.0
    span_z = float(np.ptp(z)) if n else 0.0
    return [check_row("points", n >= MIN_POINTS, f"{n} points (at least {MIN_POINTS})",
                      "a trace cut short or a summary table, not a profile"),
            check_row("x spread", span_x > 0, f"x spans {span_x:.4g} mm",
                      "one column repeated: the x column is not a position"),
            check_row("heights", span_z >= MIN_HEIGHT_SPAN_MM,
                      f"heights span {span_z:.3g} mm (a profile of this part spans its sag)",
                      "heights in the wrong unit or a constant column")]


def refusal(checks: list[dict]) -> str | None:
    """The refusal's text naming every check that does not hold and the first one's likely
    cause; None when all hold."""
    bad = [c for c in checks if not c["ok"]]
    if not bad:
        return None
    return ("not a trace of this part: " + "; ".join(f"{c['check']}: {c['figure']}" for c in bad)
            + f"; likely cause: {bad[0]['likely_cause']}")


def refuse_trace(x: np.ndarray, z: np.ndarray, source) -> None:
    """InputError (exit 2) '<source>: not a trace of this part: ...' when a check that
    needs no fit does not hold."""
    text = refusal(trace_checks(x, z))
    if text:
        raise InputError(f"{source}: {text}")
