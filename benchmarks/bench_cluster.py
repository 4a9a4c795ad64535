"""The Monte Carlo on local processes and on Dask LocalClusters (issue 34.4).

Run: .venv/bin/python benchmarks/bench_cluster.py [trials]   (default 2000)

Prints, each beside the machine's load (os.getloadavg, 1 min) and a reference workload timed
in the same run (a numpy and a pure-Python kernel, so figures from another machine compare):

1. the per-trial cost of the paper default's best program, serial: the time of n trials
   fitted as a + b n over two counts (b: seconds a trial on one core);
2. `tolerance --trials N` with --workers 1 and 2 (wall, this process's CPU and the
   workers'): the serial share is the parent's CPU while the workers run the trials;
3. the same trials' evaluation on LocalClusters of 1, 2 and 4 worker processes (one thread
   each, no nanny: see docs/explanation/monte-carlo.md), wall and speed-up over 1 worker;
4. the broadcasts of the shared state in a whole tolerance analysis on a LocalCluster
   (each part once per content) against the stages that bind it.
"""

from __future__ import annotations

import os
import resource
import subprocess
import sys
import time


def load() -> str:
    return f"load {os.getloadavg()[0]:.1f}"


def reference_s() -> float:
    """A fixed workload (numpy: sin and exp of 4e6 values x 5; Python: 3e6 loop steps)."""
    import numpy as np

    t0 = time.perf_counter()
    x = np.linspace(0.0, 10.0, 4_000_000)
    for _ in range(5):
        float(np.sum(np.sin(x) * np.exp(-x)))
    acc = 0
    for i in range(3_000_000):
        acc += i * i % 7
    return time.perf_counter() - t0


def context(trials: int):
    from lathe_mirror.config import load as load_settings
    from lathe_mirror.enums import Program
    from lathe_mirror.api import nominal_polish_time_s
    from lathe_mirror.tolerance.runs import tolerance_context

    s = load_settings(overrides=[("tolerance.trials", trials, "argv")])
    mirror = s.mirror()
    return tolerance_context(mirror, s, Program.BEST, nominal_polish_time_s(s, Program.BEST))


def per_trial(ctx, counts=(200, 1000)) -> tuple[float, float]:
    from lathe_mirror.tolerance.montecarlo import draw_trials, evaluate_trials

    times = []
    for n in counts:
        trials = draw_trials(ctx, n, seed=1)
        ctx.ensure(trials)
        t0 = time.process_time()
        evaluate_trials(ctx, trials)
        times.append(time.process_time() - t0)
    b = (times[1] - times[0]) / (counts[1] - counts[0])
    return times[0] - b * counts[0], b


def cli(trials: int, workers: int) -> tuple[float, float, float]:
    """(wall, parent CPU, workers' CPU) of `tolerance --trials N --workers W`."""
    code = ("import resource, sys, time\n"
            "from lathe_mirror.cli import main\n"
            "t0 = time.perf_counter()\n"
            f"rc = main(['tolerance', '--trials', '{trials}', '--workers', '{workers}', '--no-progress'])\n"
            "me, ch = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)\n"
            "print(time.perf_counter() - t0, me.ru_utime + me.ru_stime, ch.ru_utime + ch.ru_stime, file=sys.stderr)\n")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    wall, me, ch = (float(v) for v in proc.stderr.split()[-3:])
    return wall, me, ch


def on_cluster(ctx, trials, workers: int) -> float:
    from dask.distributed import LocalCluster

    from lathe_mirror import compute
    from lathe_mirror.tolerance.montecarlo import evaluate_trials

    with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, worker_class="distributed.Worker",
                      dashboard_address=None, host="127.0.0.1", protocol="tcp") as lc:
        with compute.session(scheduler=lc.scheduler_address):
            evaluate_trials(ctx, trials.take(slice(0, 200)))  # the workers import lathe_mirror, get the state
            t0 = time.perf_counter()
            evaluate_trials(ctx, trials)
            return time.perf_counter() - t0


def broadcasts(trials: int) -> tuple[int, float, int, float]:
    """(stages binding the shared state, MB of one whole state a stage, parts broadcast,
    their MB) of a whole tolerance analysis on a LocalCluster."""
    from dask.distributed import LocalCluster

    from lathe_mirror import compute
    from lathe_mirror.compute import cluster
    from lathe_mirror.config import load as load_settings
    from lathe_mirror.api import nominal_polish_time_s
    from lathe_mirror.tolerance.runs import tolerance_runs

    s = load_settings(overrides=[("tolerance.trials", trials, "argv")])
    mirror = s.mirror()
    times = {p: nominal_polish_time_s(s, p) for p in s.tolerance.programs}
    stages = [0, 0]
    real = cluster.DaskExecutor.bound

    def counted(self, shared):
        import cloudpickle

        stages[0] += 1
        stages[1] += len(cloudpickle.dumps(shared))  # what one broadcast a stage sent before
        return real(self, shared)

    cluster.DaskExecutor.bound = counted
    try:
        with LocalCluster(n_workers=2, threads_per_worker=1, processes=False, dashboard_address=None,
                          host="127.0.0.1", protocol="tcp") as lc:
            with compute.session(scheduler=lc.scheduler_address) as ex:
                tolerance_runs(mirror, s, times)
                return stages[0], stages[1] / 1e6, ex.broadcasts, ex.broadcast_bytes / 1e6
    finally:
        cluster.DaskExecutor.bound = real


def main() -> None:
    from lathe_mirror.tolerance.montecarlo import draw_trials

    n = int(sys.argv[1]) if len(sys.argv) > 1 else 2000
    ref = reference_s()
    print(f"reference workload {ref:.2f} s ({load()})")
    ctx = context(n)
    a, b = per_trial(ctx)
    print(f"per trial (best program, serial CPU): {a:.2f} s + {b * 1e3:.2f} ms a trial = {b / ref * 1e3:.2f} ms per "
          f"reference-second ({load()})")
    for w in (1, 2):
        wall, me, ch = cli(n, w)
        print(f"tolerance --trials {n} --workers {w}: {wall:.1f} s wall, parent CPU {me:.1f} s, workers' CPU {ch:.1f} s "
              f"({wall / ref:.1f} references; {load()})")
    trials = draw_trials(ctx, n, seed=3)
    ctx.ensure(trials)
    base = None
    for w in (1, 2, 4):
        wall = on_cluster(ctx, trials, w)
        base = wall if base is None else base
        print(f"LocalCluster {w} worker(s), {n} trials: {wall:.1f} s ({wall / ref:.1f} references), speed-up "
              f"{base / wall:.2f} ({load()})")
    stages, whole, sent, sent_mb = broadcasts(200)
    print(f"a tolerance analysis on a cluster: {stages} stages bind the shared state ({whole:.0f} MB, one whole "
          f"state a stage, to every worker before), {sent} parts broadcast ({sent_mb:.0f} MB) ({load()})")
    me = resource.getrusage(resource.RUSAGE_SELF)
    print(f"reference workload again {reference_s():.2f} s; this process's CPU {me.ru_utime + me.ru_stime:.0f} s")


if __name__ == "__main__":
    main()
