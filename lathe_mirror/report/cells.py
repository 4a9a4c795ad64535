"""The report page's cells: numbers as the page prints them, HTML tables, the verdict."""

from __future__ import annotations

import html
import math
from typing import Any

from ..results.base import Stat


def fmt(v: Any) -> str:
    """A figure as the page prints it (booleans yes / no; an RMS and max as "rms / max")."""
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, float):
        if v == 0 or not math.isfinite(v):
            return str(v)
        if abs(v) < 1e-3 or abs(v) >= 1e5:
            return f"{v:.4g}"
        # below 1, significant digits (a 0.00345 mm pixel stays 0.00345, not 0.0035)
        return f"{v:.5g}" if abs(v) < 1 else f"{v:.4f}".rstrip("0").rstrip(".")
    if isinstance(v, Stat):
        return f"{fmt(v.rms)} / {fmt(v.max)}"
    if isinstance(v, dict) and set(v) >= {"rms", "max"}:
        return f"{fmt(v['rms'])} / {fmt(v['max'])}"
    return html.escape(str(v))


def pct(v: float) -> str:
    """A percentage (or any figure read to two decimals); n/a where not finite."""
    return f"{v:.2f}" if isinstance(v, (int, float)) and math.isfinite(v) else "n/a"


def verdict_cell(ok: bool) -> str:
    return f"<span class='{'pass' if ok else 'fail'}'>{'PASS' if ok else 'FAIL'}</span>"


def table(head, rows, *, raw: bool = False) -> str:
    """An HTML table; cells are escaped unless raw (already HTML)."""
    h = "".join(f"<th>{html.escape(str(x))}</th>" for x in head)
    body = "".join("<tr>" + "".join(f"<td>{x if raw else html.escape(str(x))}</td>" for x in r) + "</tr>"
                   for r in rows)
    return f"<table><tr>{h}</tr>{body}</table>"
