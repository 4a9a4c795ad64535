"""Time `lathe-mirror optimize` on the paper default in a fresh process (target <= 60 s),
with 1 and with 2 worker processes; print the evaluations per second and the result.

Run: .venv/bin/python benchmarks/bench_optimize.py [--workers N ...] [--config FILE]
The default optimisation: the paper's camera, its own envelope, R10 over -20..0 deg
(data/optimize.toml). Prints wall and CPU seconds and the load average, since the machine's
other work skews the wall clock. Writes nothing.
"""

from __future__ import annotations

import yardstick  # benchmarks/yardstick.py: the machine-speed reference, timed in every run
import argparse
import json
import os
import resource
import subprocess
import sys
import time


def run(workers: int, config: str | None) -> dict:
    cmd = [sys.executable, "-m", "lathe_mirror", "optimize", "--json", "--no-progress", "--workers", str(workers)]
    if config:
        cmd += ["--config", config]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if proc.returncode != 0:
        sys.stderr.write(proc.stderr)
        raise SystemExit(f"lathe-mirror optimize failed with status {proc.returncode}")
    data = json.loads(proc.stdout)
    data["wall_s"] = wall
    data["cpu_s"] = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return data


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--config", default=None)
    args = ap.parse_args()
    for w in args.workers:
        d = run(w, args.config)
        s = d["search"]
        print(f"workers {w}: {d['wall_s']:.1f} s wall ({d['cpu_s']:.1f} s CPU, load {os.getloadavg()[0]:.2f}); "
              f"search {s['seconds']:.1f} s, {s['evaluations']} designs, {s['evaluations_per_second']:.0f} per "
              f"second, {s['generations']} generations, converged {s['converged']}")
        print(f"  best {d['objective']} {d['best']['r10_m']:.4f} m vs {d['reference_name']} "
              f"{d['reference']['r10_m']:.4f} m: x {d['gain']:.4f}; {'OK' if d['wall_s'] <= 60 else 'OVER'} "
              f"the 60 s target")


if __name__ == "__main__":
    yardstick.start()
    main()
