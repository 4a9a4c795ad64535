"""The machine-speed yardstick: a fixed reference workload timed in the same run as every
benchmark here, so that a figure measured on one machine compares with one measured on
another (issue 34: the same `run` took 16.6 s on one 2-core machine and 31-36 s on
another, and nobody could tell a regression from a slower machine).

The workload, Y, is two kernels of the kinds the project spends its time in, each the best
of REPEAT runs (the best, not the median: another job on the machine only ever adds):
- numpy: elementwise sin, exp, sqrt and hypot over NUMPY_N doubles, a sort and a gather
  (one thread: no BLAS, whose thread count would make Y a measure of the cores);
- pure Python: a loop of float arithmetic, dict and list work (PYTHON_N iterations), what
  the interpreter pays in the planners and the simulation's per-block bookkeeping.
Both draw their data from fixed seeds, so Y is the same work on every machine. On the
developers' 2-core AMD EPYC (no AVX-512) Y measured 1.4-1.6 s (numpy 0.5-0.7 s, Python
0.9 s) with the machine loaded 7 times over; the repeats make it a few seconds.

Use: `yardstick.start()` at the top of a benchmark's main: it times Y, prints it, and from
then on every time figure the benchmark prints on a line ("12.3 s", "45 ms") is followed
on that line by the same figure in yardsticks ("[Y: 8.2]": 12.3 s / Y). A benchmark that
prints JSON calls `start(json_output=True)` (Y goes to stderr, stdout stays JSON) and
adds in_yardsticks(result) to its result.
"""

from __future__ import annotations

import atexit
import io
import math
import os
import re
import sys
import time
from dataclasses import dataclass

#: Doubles the numpy kernel works on, and iterations of the pure-Python kernel: about
#: 0.5-0.9 s each per run on the developers' machine.
NUMPY_N = 1_000_000
PYTHON_N = 1_000_000
#: Runs of each kernel; the best counts.
REPEAT = 3

# A time figure as the benchmarks print it: a number, then s or ms (not "rays/s").
_TIME = re.compile(r"(?<![\w.])(\d+(?:\.\d*)?(?:[eE][-+]?\d+)?)\s?(ms|s)\b(?!/)")


@dataclass(frozen=True)
class Yardstick:
    """The reference workload's best times on this machine, s."""

    numpy_s: float
    python_s: float

    @property
    def seconds(self) -> float:
        """Y, s: both kernels."""
        return self.numpy_s + self.python_s

    def multiple(self, seconds: float) -> float:
        """A time (s) in yardsticks."""
        return seconds / self.seconds

    def __str__(self) -> str:
        return (f"yardstick Y = {self.seconds:.3f} s (numpy kernel {self.numpy_s:.3f} s, pure Python "
                f"{self.python_s:.3f} s, best of {REPEAT}; load {os.getloadavg()[0]:.1f})")


def numpy_kernel() -> float:
    """A fixed numpy workload; returns a checksum (so nothing is optimised away)."""
    import numpy as np

    rng = np.random.default_rng(20261127)
    x = rng.uniform(-10.0, 10.0, NUMPY_N)
    y = np.sin(x) * np.exp(-0.1 * np.abs(x)) + np.sqrt(np.hypot(x, 1.0))
    order = np.argsort(y)
    z = np.cumsum(x[order]) / NUMPY_N
    return float(z[::1000].sum() + y.mean())


def python_kernel() -> float:
    """A fixed pure-Python workload: float arithmetic, a dict and a list."""
    seen: dict[int, float] = {}
    acc, out = 0.0, []
    x = 0.5
    for i in range(PYTHON_N):
        x = 3.7 * x * (1.0 - x)  # the logistic map: chaotic, so every step is computed
        key = i % 1024
        seen[key] = seen.get(key, 0.0) + x
        if x > 0.9:
            out.append(math.floor(x * 100))
        acc += x * x
    return acc + sum(seen.values()) + len(out)


def measure() -> Yardstick:
    """Time both kernels (best of REPEAT each)."""
    best = []
    for kernel in (numpy_kernel, python_kernel):
        times = []
        for _ in range(REPEAT):
            t0 = time.perf_counter()
            kernel()
            times.append(time.perf_counter() - t0)
        best.append(min(times))
    return Yardstick(numpy_s=best[0], python_s=best[1])


_CURRENT: Yardstick | None = None


def start(*, json_output: bool = False) -> Yardstick:
    """Time Y, print it, and (json_output False) follow every time figure printed to stdout
    from now on with its multiple of Y (see the module doc)."""
    global _CURRENT
    _CURRENT = measure()
    print(str(_CURRENT), file=sys.stderr if json_output else sys.stdout, flush=True)
    if not json_output and not isinstance(sys.stdout, _Annotating):
        sys.stdout = _Annotating(sys.stdout, _CURRENT)
        atexit.register(sys.stdout.flush)
    return _CURRENT


def multiple(seconds: float) -> float:
    """A time (s) in the yardsticks start() measured."""
    assert _CURRENT is not None, "yardstick.start() first"
    return _CURRENT.multiple(seconds)


def annotate(line: str, y: Yardstick) -> str:
    """A printed line with its time figures in yardsticks appended ("[Y: a, b]")."""
    figures = [float(v) * (1e-3 if unit == "ms" else 1.0) for v, unit in _TIME.findall(line)]
    if not figures:
        return line
    return f"{line}  [Y: {', '.join(f'{y.multiple(s):.3g}' for s in figures)}]"


def in_yardsticks(result, y: Yardstick | None = None) -> dict:
    """For a JSON result: Y and, for every key ending in _s (a number, a list of them or
    a dict of them), the same in yardsticks under the key ending in _Y."""
    y = y or _CURRENT
    assert y is not None, "yardstick.start() first"

    def scaled(v):
        if isinstance(v, (int, float)) and not isinstance(v, bool):
            return y.multiple(v)
        if isinstance(v, list):
            return [scaled(x) for x in v]
        if isinstance(v, dict):
            return {k: scaled(x) for k, x in v.items()}
        return v

    out = {"yardstick_s": y.seconds, "yardstick_numpy_s": y.numpy_s, "yardstick_python_s": y.python_s}
    for k, v in result.items():
        if k.endswith("_s") and isinstance(v, (int, float, list, dict)):
            out[k[:-2] + "_Y"] = scaled(v)
    return out


class _Annotating(io.TextIOBase):
    """stdout that passes each complete line through annotate."""

    def __init__(self, stream, y: Yardstick) -> None:
        self.stream, self.y, self.pending = stream, y, ""

    def write(self, text: str) -> int:
        self.pending += text
        *lines, self.pending = self.pending.split("\n")
        for line in lines:
            self.stream.write(annotate(line, self.y) + "\n")
        return len(text)

    def flush(self) -> None:
        if self.pending:
            self.stream.write(annotate(self.pending, self.y))
            self.pending = ""
        self.stream.flush()


if __name__ == "__main__":
    print(measure())
