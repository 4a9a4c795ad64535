"""Time the paper mirror's two programs (paper method and best): planning the finishing
contour, planning the whole program, simulating it against the stock, the set-up sheet
(setting-error optics and stock pictures) and writing both dialects.

Run: .venv/bin/python benchmarks/bench_toolpath.py [--repeat N]
Prints the median and best of N runs per step, and the figures of each program.
"""

from __future__ import annotations

import yardstick  # benchmarks/yardstick.py: the machine-speed reference, timed in every run
import argparse
import statistics
import time


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()

    from lathe_mirror.config import load
    from lathe_mirror.export.dialects import DIALECTS
    from lathe_mirror.export.gcode import format_program
    from lathe_mirror.export.setup_sheet import setup_sheet_html
    from lathe_mirror.shop import plan_program
    from lathe_mirror.shop.setup import setup_sheet
    from lathe_mirror.shop.stock import simulate_program
    from lathe_mirror.tolerance.setting import setting_error_costs
    from lathe_mirror.toolpath import BEST, Strategy, plan_toolpath

    settings = load()
    mirror = settings.mirror()
    lathe, tool, stock = settings.machine, settings.tool, settings.stock
    opts = settings.toolpath

    rows: dict[str, list[float]] = {}
    sims = {}

    def timed(key: str, fn):
        t0 = time.perf_counter()
        out = fn()
        rows.setdefault(key, []).append(time.perf_counter() - t0)
        return out

    for _ in range(args.repeat):
        t_all = time.perf_counter()
        costs = timed("setting-error optics", lambda: setting_error_costs(mirror, 0.01))
        for st in (Strategy.PAPER, BEST):
            tp = timed(f"contour {st.value}", lambda: plan_toolpath(mirror, lathe, tool, st))
            prog = timed(f"program {st.value}", lambda: plan_program(tp, stock, opts, name=f"mirror_{st.value}"))
            sim = timed(f"simulate {st.value}", lambda: simulate_program(prog))
            sim.check()
            sims[st.value] = sim
            timed(f"write {st.value}", lambda: [format_program(prog, d) for d in DIALECTS])
            timed(f"sheet {st.value}", lambda: setup_sheet_html(setup_sheet(prog, sim, costs)))
        rows.setdefault("both programs, all steps", []).append(time.perf_counter() - t_all)
    print(f"paper mirror, nose radius {tool.nose_radius:g} mm, {args.repeat} runs")
    for name, ts in rows.items():
        print(f"  {name:26s} median {statistics.median(ts):.3f} s   best {min(ts):.3f} s")
    for name, sim in sims.items():
        print(f"mirror_{name}: cycle time {sim.cycle_time_s:.1f} s, contacts {len(sim.contacts)}")
        for op in sim.operations:
            f = op.figures()
            print(f"  {f['name']:12s} removed {f['removed_volume_mm3']:8.0f} mm^3  max ap {f['max_depth_of_cut_mm']:.3f} mm"
                  f"  chip {f['max_chip_section_mm2']:.4f} mm^2  air {f['air_time_s']:5.1f} s"
                  f"  time {f['cycle_time_s']:6.1f} s  plunge {f['plunge_mm']:.2f} mm")


if __name__ == "__main__":
    yardstick.start()
    main()
