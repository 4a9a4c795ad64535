"""What one validation costs (issue 26): every Settings is validated on construction
(settings.validate: declared ranges, the design, the room, the costs), by `load()` and by
each `dataclasses.replace(settings, ...)`; and the endpoint walk of tests/test_keys.py
(every declared key at both documented ends and just beyond them, in-process).

Usage: python benchmarks/bench_settings.py  (prints medians of 5 runs, seconds)
"""

from __future__ import annotations

import yardstick  # benchmarks/yardstick.py: the machine-speed reference, timed in every run
import dataclasses
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from lathe_mirror.config import default_config, load  # noqa: E402
from lathe_mirror.errors import InputError  # noqa: E402
from lathe_mirror.settings import from_config  # noqa: E402
from lathe_mirror.settings.keys import KEYS  # noqa: E402


def median(f, n: int = 5) -> float:
    times = []
    for _ in range(n):
        t0 = time.perf_counter()
        f()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def walk() -> int:
    """Each numeric key at its ends with the defaults (the test's cases, serial)."""
    import copy

    base = default_config()
    n = 0
    for k in KEYS:
        if not k.numeric or k.type == "table" or "[]" in k.name or k.default is None or isinstance(k.default, list):
            continue
        parts = k.name.split(".")
        for end in (k.lo, k.hi):
            if end is None:
                continue
            cfg = copy.deepcopy(base)
            node = cfg
            for p in parts[:-1]:
                node = node[p]
            node[parts[-1]] = type(k.default)(end)
            try:
                from_config(cfg)
            except InputError:
                pass
            n += 1
    return n


def main() -> None:
    settings = load()
    print(f"load() (defaults, validated): {median(load) * 1e3:.1f} ms")
    print(f"dataclasses.replace(settings, render=...) (validated): "
          f"{median(lambda: dataclasses.replace(settings, render=dataclasses.replace(settings.render, supersample=2))) * 1e3:.1f} ms")
    t0 = time.perf_counter()
    n = walk()
    print(f"endpoint walk, scalar keys: {n} configurations in {time.perf_counter() - t0:.2f} s")


if __name__ == "__main__":
    yardstick.start()
    main()
