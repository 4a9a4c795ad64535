"""Statistics of a yield: Wilson's score interval, and the yield a Monte Carlo must show.

A yield estimated from n trials is a binomial proportion; every yield the tolerance
analysis quotes carries its Wilson 95 % interval and n.
"""

from __future__ import annotations

import math

#: z of the two-sided 95 % normal interval.
Z95 = 1.959963984540054


def wilson(k: int, n: int, z: float = Z95) -> tuple[float, float]:
    """Wilson's score interval (Wilson 1927) for k successes in n trials: the proportions p
    that the normal test |k/n - p| <= z sqrt(p (1 - p) / n) accepts; 95 % by default.
    Unlike k/n -/+ z sqrt(k/n (1 - k/n) / n) it stays inside [0, 1] and is not empty at
    k = 0 or k = n. Newcombe (1998), Table I: 81 of 263 gives 0.2553 .. 0.3662."""
    if n <= 0:
        return (0.0, 1.0)
    p = k / n
    den = 1.0 + z * z / n
    centre = (p + z * z / (2 * n)) / den
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / den
    return (max(0.0, centre - half), min(1.0, centre + half))


def yield_to_show(target: float, n: int, z: float = Z95) -> float:
    """The smallest observed yield k / n (n trials) whose Wilson interval lies at or above
    `target`: what an allocation aims for so that its confirming Monte Carlo of n trials
    clears the target with 95 % confidence (0.962 for 0.95 over 1000 trials)."""
    for k in range(int(math.floor(target * n)), n + 1):
        if wilson(k, n, z)[0] >= target:
            return k / n
    return 1.0


def percent_interval(k: int, n: int) -> str:
    """'95.3 % (95 % CI 93.8-96.5 %, 1000 trials)': a yield as the report writes it."""
    lo, hi = wilson(k, n)
    return f"{100 * k / n:.1f} % (95 % CI {100 * lo:.1f}-{100 * hi:.1f} %, {n} trials)"
