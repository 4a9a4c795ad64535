"""Time the stock simulation (shop.stock.simulate_program): both programs (paper method and
best) of the paper default and of a design that is not the paper's (a 6 mm lens, the outer
lobe recessed: tests' RECESSED_OUTER), each its first set-up (with the part-off) and its
second set-up (the back and the mount), the programs `lathe-mirror toolpath` writes.

Run: .venv/bin/python benchmarks/bench_stock.py [--repeat N] [--profile]
Prints the best of N runs per program, each from the bar (shop.stock.forget_runs: not a run
the process kept), CPU seconds (process time) and wall seconds, and the figures the
simulation reports (--json FILE: every figure and contact, to compare two trees); then each
design's programs in one process, as shop_programs simulates them (the arc program's first
set-up goes on from the paper one's stock after the face and the roughing), and all of
them again (the runs the process kept).
"""

from __future__ import annotations

import yardstick  # benchmarks/yardstick.py: the machine-speed reference, timed in every run
import argparse
import json
import tempfile
import time
from pathlib import Path

#: The non-paper design (as tests/conftest.py's RECESSED_OUTER).
RECESSED_OUTER = ("[camera]\nf = 6.0\nt_pixel = 0.003\nsensor_px = [1280, 1024]\n"
                  "[lobes.inner]\nr_top = 12.0\nr_pixel = 265.0\na_over_b = 2.0\n"
                  "[lobes.outer]\nr_top = 25.0\nr_pixel = 500.0\nalpha_deg = 5.0\n")


def programs(cfg: Path | None) -> dict:
    """{name: Program} of both strategies' two set-ups, as `toolpath` plans them."""
    from lathe_mirror.config import load
    from lathe_mirror.shop.programs import shop_programs

    settings = load(cfg)
    out = {}
    for sp in shop_programs(settings, settings.mirror()):
        out[sp.program.name] = sp.program
        if sp.second is not None:
            out[sp.second.name] = sp.second
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--profile", action="store_true", help="cProfile one run of every program (top 25)")
    ap.add_argument("--sort", default="tottime")
    ap.add_argument("--top", type=int, default=25)
    ap.add_argument("--json", type=Path, help="write every simulation's figures here")
    args = ap.parse_args()

    from lathe_mirror.shop.stock import forget_runs, simulate_program

    with tempfile.TemporaryDirectory() as tmp:
        cfg = Path(tmp) / "recessed.toml"
        cfg.write_text(RECESSED_OUTER)
        designs = {"paper default": programs(None), "recessed outer": programs(cfg)}
    if args.profile:
        import cProfile
        import pstats

        prof = cProfile.Profile(time.process_time)
        prof.enable()
        for progs in designs.values():
            for prog in progs.values():
                simulate_program(prog)
        prof.disable()
        pstats.Stats(prof).sort_stats(args.sort).print_stats(args.top)
        return
    figures = {}
    total_cpu = total_wall = 0.0
    for design, progs in designs.items():
        print(f"{design}:")
        for name, prog in progs.items():
            cpu, wall = [], []
            for _ in range(args.repeat):
                forget_runs()  # a fresh run each time, not the one this process kept
                c0, w0 = time.process_time(), time.perf_counter()
                sim = simulate_program(prog)
                cpu.append(time.process_time() - c0)
                wall.append(time.perf_counter() - w0)
            figures[f"{design}: {name}"] = sim.figures()
            total_cpu += min(cpu)
            total_wall += min(wall)
            moves = sum(len(op.blocks) for op in prog.operations)
            print(f"  {name:24s} {moves:5d} blocks  CPU best {min(cpu):6.3f} s  wall best {min(wall):6.3f} s"
                  f"  cycle {sim.cycle_time_s:7.1f} s  contacts {len(sim.contacts)}")
    print(f"all programs: CPU {total_cpu:.3f} s, wall {total_wall:.3f} s (best of {args.repeat} each)")
    # as shop_programs simulates them in one process: the arc program's first set-up goes on
    # from the paper one's stock after the face and the roughing; then all of them again
    # (check_made, the report, the tests): the runs the process kept
    for design, progs in designs.items():
        chained, again = [], []
        for _ in range(args.repeat):
            forget_runs()
            c0 = time.process_time()
            for prog in progs.values():
                simulate_program(prog)
            c1 = time.process_time()
            for prog in progs.values():
                simulate_program(prog)
            chained.append(c1 - c0)
            again.append(time.process_time() - c1)
        print(f"{design}, its programs in one process: CPU best {min(chained):6.3f} s, "
              f"all again {min(again):6.3f} s")
    if args.json:
        args.json.write_text(json.dumps(figures, indent=1))


if __name__ == "__main__":
    yardstick.start()
    main()
