"""Pareto fronts of the search's feasible candidates (both axes maximised)."""

from __future__ import annotations

import numpy as np


def pareto_front(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Indices of the points not dominated when both a and b are maximised, sorted by a
    descending. A point is dominated if another is >= in both and > in one (ties: the
    first kept). O(n log n): sort by a descending, keep the running maximum of b."""
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    if a.size == 0:
        return np.zeros(0, dtype=np.intp)
    order = np.lexsort((-b, -a))  # by a descending, then b descending
    keep = []
    best_b = -np.inf
    for i in order:
        if b[i] > best_b:
            keep.append(i)
            best_b = b[i]
    return np.asarray(keep, dtype=np.intp)
