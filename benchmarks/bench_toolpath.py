"""Time the generation of the paper mirror's two programs (paper method and best).

Run: .venv/bin/python benchmarks/bench_toolpath.py [--repeat N]
Target (issue 3): both programs, planning + G-code (gouge check and figures included),
under 2 s together. Prints the median and best of N runs per step.
"""

from __future__ import annotations

import argparse
import statistics
import time


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args()

    from lathe_mirror.config import load
    from lathe_mirror.export.gcode import Dialect, program, program_options
    from lathe_mirror.toolpath import BEST, Strategy, plan_toolpath

    settings = load()
    mirror = settings.mirror()
    lathe, tool, stock = settings.machine, settings.tool, settings.stock
    opts = program_options(settings)

    rows: dict[str, list[float]] = {}
    for _ in range(args.repeat):
        total = 0.0
        for st in (Strategy.PAPER, BEST):
            t0 = time.perf_counter()
            tp = plan_toolpath(mirror, lathe, tool, st)
            t1 = time.perf_counter()
            program(tp, stock, Dialect.LINUXCNC, options=opts)
            t2 = time.perf_counter()
            rows.setdefault(f"plan {st.value}", []).append(t1 - t0)
            rows.setdefault(f"program {st.value}", []).append(t2 - t1)
            total += t2 - t0
        rows.setdefault("both programs", []).append(total)
    print(f"paper mirror, nose radius {tool.nose_radius:g} mm, {args.repeat} runs")
    for name, ts in rows.items():
        print(f"  {name:18s} median {statistics.median(ts):.3f} s   best {min(ts):.3f} s")


if __name__ == "__main__":
    main()
