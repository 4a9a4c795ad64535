"""Strategy PAPER: the paper's method (section 6), spread and round.

Points evenly spaced along the whole profile's length, each coordinate rounded to the
lattice, joined by G1 lines (528 points at 0.005 mm on the paper's machine).
"""

from __future__ import annotations

import numpy as np

from ..lathe import Lathe
from .layout import Layout, split_budget


def paper_points(layout: Layout, lathe: Lathe) -> tuple[np.ndarray, np.ndarray]:
    """The paper's method: points evenly spaced along the whole profile's length, each
    coordinate rounded to the lattice (section 6: 528 points, 0.005 mm)."""
    n_inner, n_outer = split_budget(layout, lathe.max_points - layout.junction_extra(),
                                     weights=[t.length for t in layout.targets()])
    out = []
    for t, n in zip(layout.targets(), (n_inner, n_outer)):
        s = np.linspace(0.0, t.length, n)
        p = t.point(t.rs_at_s(s))
        q = lathe.snap(p)
        # points that round to the same lattice point are one point (a zero-length move
        # is no move); what remains must still advance in r (plan_toolpath checks)
        keep = np.concatenate([[True], np.any(q[1:] != q[:-1], axis=1)])
        out.append(q[keep])
    return out[0], out[1]
