"""Time the allocation on the paper default, and measure what the trials' surfaces cost.

Run: .venv/bin/python benchmarks/bench_tolerance.py              (target: at most 60 s)
     .venv/bin/python benchmarks/bench_tolerance.py --bias 40 [STEP]  (each program, 40 trials;
                                                         STEP overrides tolerance.nose_step_mm)

Default: for the best program (the one `lathe-mirror run` allocates), the one-off cutting
of the lattice phases, the Monte Carlo (its noses cut as drawn), the response scans, and
the allocation with its confirming Monte Carlo; prints each time and the answer.

--bias N: N trials of each program drawn as the Monte Carlo draws them; each trial's
judged figures from the Monte Carlo's surfaces (its phase's part plus what its nose,
rounded to the nose step, changes on the phase-0 part; linear in polishing time between
snapshots) against the same trial cut whole: its phase, its exact nose, polished exactly
its time. Prints per criterion the mean signed and absolute relative differences (the bias and
the scatter) and the largest, and how often the pass / fail verdict agrees.
"""

from __future__ import annotations

import yardstick  # benchmarks/yardstick.py: the machine-speed reference, timed in every run
import sys
import time

import numpy as np


def allocation() -> None:
    from lathe_mirror.config import load
    from lathe_mirror.enums import BEST, Program
    from lathe_mirror.job import made_surface, polishing_curve
    from lathe_mirror.tolerance.runs import tolerance_context
    from lathe_mirror.tolerance.allocation import allocate
    from lathe_mirror.tolerance.montecarlo import run_monte_carlo
    from lathe_mirror.tolerance.sensitivity import responses
    from lathe_mirror.tolerance.stats import percent_interval

    s = load()
    mirror = s.mirror()
    t0 = time.perf_counter()
    t_opt = polishing_curve(made_surface(mirror, s.machine, s.tool, BEST).profile, mirror, s.polish).optimum_time_s
    t1 = time.perf_counter()
    ctx = tolerance_context(mirror, s, Program.BEST, t_opt)
    t2 = time.perf_counter()
    mc = run_monte_carlo(ctx)
    t3 = time.perf_counter()
    resp = responses(ctx)
    t4 = time.perf_counter()
    out, confirm = allocate(ctx, resp, mc)
    t5 = time.perf_counter()
    print(f"best program, {s.tolerance.trials} trials: polishing curve {t1 - t0:.1f} s, {len(ctx.bank.phases)} "
          f"lattice phases {t2 - t1:.1f} s, Monte Carlo {t3 - t2:.1f} s, response scans {t4 - t3:.1f} s, allocation "
          f"+ confirming Monte Carlo {t5 - t4:.1f} s; noses cut {len(ctx.bank.nose_mm)}")
    print(f"yield at the configured tolerances {percent_interval(int(mc.pass_all.sum()), len(mc.trials))}")
    print(out["statement"])
    print(f"surrogate on the Monte Carlo's trials: {out['surrogate']}")
    print(f"allocation total (tolerance context to confirmed answer): {t5 - t1:.1f} s (target <= 60 s)")


def bias(n: int, nose_step: float | None = None) -> None:
    from lathe_mirror.config import load
    from lathe_mirror.enums import BEST, Program, Strategy
    from lathe_mirror.job import made_surface, plan, machine, MadeSurface, polishing_curve
    from lathe_mirror.tolerance.runs import tolerance_context
    from lathe_mirror.tolerance.montecarlo import CRITERIA, Context, draw_trials, evaluate_trials, judge
    from lathe_mirror.tolerance.sensitivity import judged_values
    from lathe_mirror.tolerance.surfaces import SurfaceBank

    s = load(overrides=[("tolerance.nose_step_mm", nose_step, "--nose-step")] if nose_step else None)
    mirror = s.mirror()
    for program in (Program.BEST, Program.PAPER):
        strategy = BEST if program is Program.BEST else Strategy.PAPER
        t_opt = polishing_curve(made_surface(mirror, s.machine, s.tool, strategy).profile, mirror,
                                s.polish).optimum_time_s
        ctx = tolerance_context(mirror, s, program, t_opt)
        tr = draw_trials(ctx, n=n, seed=s.tolerance.seed + 7)
        # the drawn noses before rounding: the draw of draw_trials, redone unrounded
        rng = np.random.default_rng(s.tolerance.seed + 7)
        rng.integers(0, len(ctx.bank.phases), n)
        exact_nose = ctx.nominal_nose_mm + rng.normal(0.0, s.tolerance.tolerances["nose_radius_mm"] / 3.0, n)
        t0 = time.perf_counter()
        bank_fig = evaluate_trials(ctx, tr)
        ours = judged_values(bank_fig, True)
        ok_ours = np.all(np.stack([v for v in judge(bank_fig, ctx.limits, True).values()]), axis=0)
        truth, ok_truth = np.empty_like(ours), np.empty(n, bool)
        for i in range(n):
            phase = float(ctx.bank.phases[tr.phase[i]])
            programs = {}

            def machine_at(_phase, nose, phase=phase):
                if phase not in programs:
                    programs[phase] = plan(mirror, s.machine, s.tool, strategy, phase=phase)
                return MadeSurface(machine(programs[phase], nose), programs[phase], "")

            whole = SurfaceBank(mirror, machine_at, s.polish, np.array([tr.time_s[i]]), np.array([0.0]),
                                ctx.nominal_nose_mm, 1e-7)
            one = tr.take(np.array([i]))
            one.phase[:] = 0
            one.nose_mm[:] = exact_nose[i]
            sub = Context(mirror, ctx.settings, whole, ctx.samples, ctx.nominal_nose_mm, tr.time_s[i], "",
                          program, ctx.limits)
            f = evaluate_trials(sub, one)
            truth[i] = judged_values(f, True)[0]
            ok_truth[i] = all(v[0] for v in judge(f, ctx.limits, True).values())
        with np.errstate(divide="ignore", invalid="ignore"):
            rel = np.abs(ours - truth) / np.abs(truth)
        print(f"{program.value} program, {n} trials ({time.perf_counter() - t0:.0f} s):")
        for j, c in enumerate(CRITERIA):
            good = np.isfinite(rel[:, j]) & (np.abs(truth[:, j]) > 0)
            print(f"  {c}: mean |ours - whole| / whole {100 * np.mean(rel[good, j]):.2f} %, largest "
                  f"{100 * np.max(rel[good, j]):.2f} %; mean ours {np.mean(ours[good, j]):.4g}, whole "
                  f"{np.mean(truth[good, j]):.4g}")
        if "--verbose" in sys.argv:
            for i in range(n):
                print("   ", i, tr.phase[i], round(tr.nose_mm[i], 4), round(exact_nose[i], 5), round(tr.time_s[i]),
                      ours[i], truth[i])
        with np.errstate(divide="ignore", invalid="ignore"):
            signed = np.where(np.abs(truth) > 0, (ours - truth) / np.abs(truth), np.nan)
        print("  bias, the mean of (ours - whole) / whole over the trials: " + ", ".join(
            f"{c} {100 * np.nanmean(signed[:, j]):+.2f} %" for j, c in enumerate(CRITERIA)))
        print(f"  pass / fail agrees on {100 * np.mean(ok_ours == ok_truth):.1f} % of the trials "
              f"(ours {ok_ours.sum()}, whole {ok_truth.sum()} pass)")


if __name__ == "__main__":
    yardstick.start()
    if len(sys.argv) > 2 and sys.argv[1] == "--bias":
        bias(int(sys.argv[2]), float(sys.argv[3]) if len(sys.argv) > 3 else None)
    else:
        allocation()
