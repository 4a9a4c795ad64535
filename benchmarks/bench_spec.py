"""Timings of issue 21: `lathe-mirror spec` (the ISO 10110 specification, its form
tolerances from the closed-form responses, the drawing) and the shop program with its
finishing passes (each raise of the pass count re-simulates the program).

    .venv/bin/python benchmarks/bench_spec.py

Prints the wall-clock time of each piece and the load average (a loaded machine skews it).
"""

from __future__ import annotations

import yardstick  # benchmarks/yardstick.py: the machine-speed reference, timed in every run
import os
import time


def main() -> None:
    from lathe_mirror.config import load
    from lathe_mirror.export.drawing import drawing_bytes
    from lathe_mirror.body import design_meridian
    from lathe_mirror.enums import Strategy
    from lathe_mirror.iso10110 import spec_of
    from lathe_mirror.shop.programs import shop_programs

    s = load()
    t = time.perf_counter()
    spec = spec_of(s)
    t_spec = time.perf_counter() - t
    t = time.perf_counter()
    spec_fine = spec_of(s, step=0.01)
    t_fine = time.perf_counter() - t
    t = time.perf_counter()
    data = drawing_bytes(spec, design_meridian(s.mirror(), s.body))
    t_draw = time.perf_counter() - t
    t = time.perf_counter()
    shop = shop_programs(s, s.mirror(), strategies=(Strategy.ARCS,))[0]
    t_shop = time.perf_counter() - t
    rows = len(spec_fine.lobes[0].sag_table) + len(spec_fine.lobes[1].sag_table)
    print(f"load average {os.getloadavg()[0]:.1f}")
    print(f"spec_of (0.5 mm sag tables): {t_spec * 1e3:.1f} ms")
    print(f"spec_of (0.01 mm, {rows} rows): {t_fine * 1e3:.1f} ms")
    print(f"drawing (PDF {len(data['pdf'])} B + SVG {len(data['svg'])} B): {t_draw:.2f} s")
    n = sum(op.name.startswith("finish") for op in shop.program.operations)
    print(f"shop program, arcs, {n} finishing passes (simulated until each is within "
          f"{shop.program.options.max_finish_depth_mm:g} mm): {t_shop:.2f} s")


if __name__ == "__main__":
    yardstick.start()
    main()
