"""Time the tolerance Monte Carlo on the paper default: 1000 trials (target < 30 s).

Run: .venv/bin/python benchmarks/bench_montecarlo.py [trials]
Prints the time of the one-off preparation (each lattice phase's part cut and polished) and
of the trials themselves (the noses they draw cut first), per program, and the yield.
"""

from __future__ import annotations

import yardstick  # benchmarks/yardstick.py: the machine-speed reference, timed in every run
import sys
import time


def main() -> None:
    from lathe_mirror.config import load
    from lathe_mirror.enums import BEST, Program, Strategy
    from lathe_mirror.job import made_surface, polishing_curve
    from lathe_mirror.tolerance.runs import tolerance_context
    from lathe_mirror.tolerance.montecarlo import run_monte_carlo
    from lathe_mirror.tolerance.sensitivity import sensitivity_table

    overrides = [("tolerance.trials", int(sys.argv[1]), "argv")] if len(sys.argv) > 1 else []
    s = load(overrides=overrides)
    mirror, settings, params = s.mirror(), s.tolerance, s.polish
    for program in settings.programs:
        t0 = time.perf_counter()
        strategy = BEST if program is Program.BEST else Strategy.PAPER
        made = made_surface(mirror, s.machine, s.tool, strategy)
        t_opt = polishing_curve(made.profile, mirror, params).optimum_time_s
        t1 = time.perf_counter()
        ctx = tolerance_context(mirror, s, program, t_opt)
        t2 = time.perf_counter()
        mc = run_monte_carlo(ctx)
        t3 = time.perf_counter()
        sensitivity_table(ctx)
        t4 = time.perf_counter()
        print(f"{program.value}: polishing curve {t1 - t0:.2f} s, {len(ctx.bank.phases)} lattice phases {t2 - t1:.2f} s, "
              f"{settings.trials} trials {t3 - t2:.2f} s ({(t3 - t2) / settings.trials * 1e3:.2f} ms/trial), "
              f"sensitivity {t4 - t3:.2f} s; Monte Carlo total {t3 - t1:.2f} s ({len(ctx.bank.nose_mm)} noses cut as "
              f"drawn); yield {100 * mc.yield_fraction:.1f} %")


if __name__ == "__main__":
    yardstick.start()
    main()
