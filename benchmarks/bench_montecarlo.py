"""Time the tolerance Monte Carlo on the paper default: 1000 trials (target < 30 s).

Run: .venv/bin/python benchmarks/bench_montecarlo.py [trials]
Prints the time of the one-off preparation (machined + polished node surfaces) and of the
trials themselves, per program, and the yield.
"""

from __future__ import annotations

import sys
from lathe_mirror.settings import from_config
import time


def main() -> None:
    from lathe_mirror.config import default_config
    from lathe_mirror.polishing import polish_curve
    from lathe_mirror.tolerance.montecarlo import prepare, run_monte_carlo
    from lathe_mirror.tolerance.sensitivity import sensitivity_table
    from lathe_mirror.tolerance.surfaces import machined_surface

    cfg = default_config()
    if len(sys.argv) > 1:
        cfg["tolerance"]["trials"] = int(sys.argv[1])
    mirror = from_config(cfg).mirror()
    settings = from_config(cfg).tolerance
    params = from_config(cfg).polish
    for program in settings.programs:
        t0 = time.perf_counter()
        made = machined_surface(mirror, cfg, program)
        t_opt = polish_curve(made.profile, mirror, params).optimum_time_s
        t1 = time.perf_counter()
        ctx = prepare(mirror, cfg, settings, params, t_opt, program)
        t2 = time.perf_counter()
        mc = run_monte_carlo(ctx)
        t3 = time.perf_counter()
        sensitivity_table(ctx)
        t4 = time.perf_counter()
        print(f"{program.value}: polishing curve {t1 - t0:.2f} s, nodes {ctx.nodes.shape} {t2 - t1:.2f} s, "
              f"{settings.trials} trials {t3 - t2:.2f} s ({(t3 - t2) / settings.trials * 1e3:.2f} ms/trial), "
              f"sensitivity {t4 - t3:.2f} s; Monte Carlo total {t3 - t1:.2f} s; yield {100 * mc.yield_fraction:.1f} %")


if __name__ == "__main__":
    main()
