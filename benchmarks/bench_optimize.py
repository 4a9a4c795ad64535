"""Time `lathe-mirror optimize` on the paper default in a fresh process (target <= 60 s),
with 1 and with 2 worker processes; print the evaluations per second and the result.
--objective r10 times the nominal objective beside the robust default (delivered_r10_p5:
the configured design's small Monte Carlo before the search, the winner's full one and,
when its yield falls short, the allocation after it; issue 31 allows 3x the r10 time).

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


def run(workers: int, config: str | None, objective: str | None = None) -> dict:
    cmd = [sys.executable, "-m", "lathe_mirror", "optimize", "--json", "--no-progress", "--workers", str(workers)]
    if objective:
        import tempfile

        text = open(config).read() if config else ""
        tmp = tempfile.NamedTemporaryFile("w", suffix=".toml", delete=False)
        tmp.write(text + f'\n[optimize]\nobjective = "{objective}"\n' if "[optimize]" not in text
                  else text.replace("[optimize]", f'[optimize]\nobjective = "{objective}"', 1))
        tmp.close()
        config = tmp.name
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
    ap.add_argument("--objective", nargs="+", default=[None],
                    help="objectives to time (default: the configured one), e.g. r10 delivered_r10_p5")
    args = ap.parse_args()
    for w, objective in [(w, o) for o in args.objective for w in args.workers]:
        d = run(w, args.config, objective)
        s = d["search"]
        print(f"objective {d['objective']}, workers {w}: {d['wall_s']:.1f} s wall ({d['cpu_s']:.1f} s CPU, load {os.getloadavg()[0]:.2f}); "
              f"search {s['seconds']:.1f} s, {s['evaluations']} designs, {s['evaluations_per_second']:.0f} per "
              f"second, {s['generations']} generations, converged {s['converged']}")
        print(f"  best {d['objective']} {d['best']['sharp_r10_m']:.4f} m vs {d['reference_name']} "
              f"{d['reference']['sharp_r10_m']:.4f} m: x {d['gain']:.4f}; {'OK' if d['wall_s'] <= 60 else 'OVER'} "
              f"the 60 s target")
        c = d.get("check")
        if c is not None and "yield" in c:
            dr = c.get("delivered_r10_m", {})
            print(f"  winner: yield {100 * c['yield']:.1f} % of {c['trials']} trials; delivered R10 p5 "
                  f"{dr.get('p5', float('nan')):.4f} m, median {dr.get('median', float('nan')):.4f} m "
                  f"(design {dr.get('design', float('nan')):.4f} m)")
            a = c.get("allocation")
            if a is not None:
                print(f"  allocation: {a['statement']}; cost x {a['cost_ratio']:.3g}")


if __name__ == "__main__":
    yardstick.start()
    main()
