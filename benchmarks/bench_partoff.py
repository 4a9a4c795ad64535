"""Time the complete part program of the paper mirror (arcs): the first set-up with its
part-off planned and simulated (the parting blade's shape, the part separated), the second
set-up (the back and the mount) planned from the parted part and simulated, both written in
both dialects; with the CAD's bore (the default) and with a boss. Prints the median of N
runs per step and each set-up's cycle time.

Run: .venv/bin/python benchmarks/bench_partoff.py [--repeat N]
"""

from __future__ import annotations

import yardstick  # benchmarks/yardstick.py: the machine-speed reference, timed in every run
import argparse
import dataclasses
import statistics
import time


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()

    from lathe_mirror.config import load
    from lathe_mirror.enums import Mount
    from lathe_mirror.export.dialects import DIALECTS
    from lathe_mirror.export.gcode import format_program
    from lathe_mirror.shop import plan_program
    from lathe_mirror.shop.second import plan_second
    from lathe_mirror.shop.stock import simulate_program
    from lathe_mirror.toolpath import Strategy, plan_toolpath

    settings = load()
    mirror = settings.mirror()
    opts = settings.toolpath
    tp = plan_toolpath(mirror, settings.machine, settings.tool, Strategy.ARCS)
    for mount in (Mount.BORE, Mount.BOSS):
        body = dataclasses.replace(settings.body, mount=mount)
        rows: dict[str, list[float]] = {}
        for _ in range(args.repeat):
            t0 = time.perf_counter()
            one = plan_program(tp, settings.stock, opts, body=body)
            t1 = time.perf_counter()
            sim1 = simulate_program(one)
            t2 = time.perf_counter()
            two = plan_second(one, sim1.parted, body, name="mirror_arcs_op2")
            sim2 = simulate_program(two)
            t3 = time.perf_counter()
            for prog in (one, two):
                for d in DIALECTS:
                    format_program(prog, d)
            t4 = time.perf_counter()
            for key, dt in (("plan first set-up", t1 - t0), ("simulate first set-up", t2 - t1),
                            ("plan + simulate second set-up", t3 - t2), ("write both, both dialects", t4 - t3)):
                rows.setdefault(key, []).append(dt)
        print(f"mount = {mount.value}: contacts {len(sim1.contacts) + len(sim2.contacts)}; cycle time first set-up "
              f"{sim1.cycle_time_s:.1f} s (part-off {sim1.operations[-1].cycle_time_s:.1f} s), second set-up "
              f"{sim2.cycle_time_s:.1f} s")
        for key, v in rows.items():
            print(f"  {key:32s} median {statistics.median(v):7.3f} s  best {min(v):7.3f} s")


if __name__ == "__main__":
    yardstick.start()
    main()
