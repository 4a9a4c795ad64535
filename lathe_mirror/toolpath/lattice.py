"""Strategy LATTICE: G1 lines whose vertices are lattice points chosen by dynamic programming.

As many points as the paper's method, spread along each lobe by a vertex density; each
vertex then picks one of the lattice points near its place on the curve so that the
chords' slope errors and offsets are smallest (an optimisation over the lattice, not
rounding): 4-8x less RMS slope error than rounding on the paper's mirror.
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from ..lathe import Lathe
from ..sheet import Target
from .layout import Layout, lattice_candidates, split_budget


def lattice_points(layout: Layout, lathe: Lathe) -> tuple[np.ndarray, np.ndarray]:
    """Lines whose vertices are lattice points chosen for the smallest slope errors.

    Vertex positions are spread along each lobe (see _LATTICE_P/_C), the budget shared
    between the lobes in proportion; then each vertex picks one of the lattice points
    near its position (the 24 nearest the curve within 0.4 of the gap to its
    neighbours) by dynamic programming that minimises the sum over chords of (max end
    slope error)^4 + (weighted end offset)^4, which weighs the worst chords most.
    """
    res = lathe.resolution
    total = lathe.max_points - layout.junction_extra()
    turning = [abs(t.theta_tab[-1] - t.theta_tab[0]) for t in layout.targets()]
    lengths = [t.length for t in layout.targets()]
    mean_k = sum(turning) / sum(lengths)
    dens = [_vertex_density(t, mean_k) for t in layout.targets()]
    # each lobe's share of the budget: its integral of the density
    weights = [np.trapezoid(d, t.s_tab) for t, d in zip(layout.targets(), dens)]
    counts = split_budget(layout, total, weights)
    out = []
    for t, d, n, cols in zip(layout.targets(), dens, counts, (layout.inner_cols, layout.outer_cols)):
        cum = np.concatenate([[0.0], np.cumsum(0.5 * (d[1:] + d[:-1]) * np.diff(t.s_tab))])
        s_nom = np.interp(np.linspace(0.0, cum[-1], n), cum, t.s_tab)
        out.append(_dp_vertices(t, s_nom, res, cols))
    return out[0], out[1]


#: Vertex density along the curve ~ (kappa / mean kappa)^P + C. Measured on the paper's
#: mirror: P = 0 (even spacing) beats spreading by curvature, which crowds the flat
#: vertex where the lattice's rows quantise short chords' slopes coarsely.
_LATTICE_P = 0.0
_LATTICE_C = 1.0
#: Weight (rad per mm) of a chord end's offset from the curve against its slope error:
#: 5 halves the paper method's normal deviation for a few % more slope error.
_DEV_WEIGHT = 5.0


def _vertex_density(t: Target, mean_k: float) -> np.ndarray:
    """Vertex density at each of t's tabulated points (see _LATTICE_P/_C)."""
    kappa = np.abs(np.gradient(t.theta_tab, t.s_tab))
    return (kappa / mean_k) ** _LATTICE_P + _LATTICE_C


def _dp_vertices(t: Target, s_nom: np.ndarray, res: float, cols, k_best: int = 24) -> np.ndarray:
    """The chain of lattice candidates (one per nominal vertex) of least total chord cost."""
    cr, cz, d, th, valid = lattice_candidates(t, s_nom, res, cols, k_best)
    n, k = cr.shape
    # cost[i, a, b]: chord from candidate a of vertex i to candidate b of vertex i+1
    dr = cr[1:, None, :] - cr[:-1, :, None]
    dz = cz[1:, None, :] - cz[:-1, :, None]
    chord = np.arctan2(dz, np.where(dr > 0, dr, np.nan))
    e = np.maximum(np.abs(chord - th[:-1, :, None]), np.abs(chord - th[1:, None, :]))
    # the chord's offset from the curve, weighed in as an angle: _DEV_WEIGHT rad per mm
    dev = _DEV_WEIGHT * np.maximum(np.abs(d[:-1, :, None]), np.abs(d[1:, None, :]))
    cost = np.where(np.isfinite(e) & valid[:-1, :, None] & valid[1:, None, :], e**4 + dev**4, np.inf)
    acc = np.where(valid[0], 0.0, np.inf)
    back = np.zeros((n - 1, k), dtype=np.int64)
    for i in range(n - 1):
        tot = acc[:, None] + cost[i]
        back[i] = np.argmin(tot, axis=0)
        acc = tot[back[i], np.arange(k)]
    j = int(np.argmin(acc))
    if not np.isfinite(acc[j]):
        raise InputError(f"machine.resolution = {res:g} mm: too coarse for the lattice strategy's "
                         f"{n} points on this lobe (no chain of lattice points advances in r); "
                         "use a finer resolution or fewer points (machine.max_points)")
    idx = np.empty(n, dtype=np.int64)
    idx[-1] = j
    for i in range(n - 2, -1, -1):
        idx[i] = back[i, idx[i + 1]]
    rows = np.arange(n)
    return np.stack([cr[rows, idx], cz[rows, idx]], axis=-1)
