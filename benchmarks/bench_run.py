"""Time the main job and the test suite on this machine (targets: run <= 20 s, suite <= 3 min).

Run: .venv/bin/python benchmarks/bench_run.py [--runs 3] [--no-suite] [--suite-args "-x"] [--stages N]

- `lathe-mirror run` on the paper default (what `scripts/run` does after the set-up),
  each time in a fresh process writing into a temporary directory (report, programs, CAD,
  calibration files), so the repository's gcode/, cad/ and calib/ are left alone; the
  median of --runs wall times, with the CPU time (user + system of the child processes:
  above the wall time when both cores work).
- --stages N: `run --workers 1` in one process, N times, each stage's CPU time (the median;
  the report's stages, the tolerance analysis' parts, the files beside the report: STAGES),
  so that a change's saving shows where it is made.
- The test suite as `scripts/test` runs it (`pytest -n auto --dist loadscope --no-loadscope-reorder`),
  wall and CPU time.

Prints the yardstick (benchmarks/yardstick.py, timed first in the same run) and a table in
seconds and in yardsticks: the multiples compare across machines where the seconds do not.
Measure on an idle machine: another job on a 2-core machine doubles the figures.
"""

from __future__ import annotations

import yardstick  # benchmarks/yardstick.py: the machine-speed reference, timed in every run
import argparse
import os
import resource
import shlex
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def timed(cmd: list[str], **kw) -> tuple[float, float, subprocess.CompletedProcess]:
    """Wall and CPU (children's user + system) seconds of one command."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True, **kw)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu, proc


def bench_run(runs: int) -> list[tuple[float, float]]:
    out = []
    for _ in range(runs):
        with tempfile.TemporaryDirectory(prefix="bench-run-") as tmp:
            tmp = Path(tmp)
            cmd = [sys.executable, "-m", "lathe_mirror", "run", "-o", str(tmp / "out"),
                   "--gcode-dir", str(tmp / "gcode"), "--cad-dir", str(tmp / "cad"),
                   "--calib-dir", str(tmp / "calib")]
            wall, cpu, proc = timed(cmd, cwd=tmp)
            if proc.returncode != 0:
                sys.stderr.write(proc.stderr)
                raise SystemExit(f"lathe-mirror run failed with status {proc.returncode}")
            out.append((wall, cpu))
            print(f"  run: {wall:.1f} s wall, {cpu:.1f} s CPU", file=sys.stderr)
    return out


def bench_suite(extra: list[str], log: str | None = None) -> tuple[float, float, str]:
    cmd = [sys.executable, "-m", "pytest", "-n", "auto", "--dist", "loadscope", "--no-loadscope-reorder", "-q",
           "-p", "no:cacheprovider", *extra]
    wall, cpu, proc = timed(cmd, cwd=REPO)
    last = (proc.stdout.strip().splitlines() or ["(no output)"])[-1]
    if log:
        Path(log).write_text(proc.stdout + proc.stderr)
    if proc.returncode != 0:
        sys.stderr.write(proc.stdout[-4000:])
    return wall, cpu, last


#: `--stages`: the functions whose CPU time (inclusive: a stage inside another counts in
#: both) is measured while `run --workers 1` runs in one process: the report's stages, the
#: tolerance analysis' parts, the files beside the report. "module:function" or
#: "module:Class.method".
STAGES = (
    ("programs simulated", "lathe_mirror.shop.programs:shop_programs"),
    ("polishing study", "lathe_mirror.report.polishing_study:polishing_study"),
    ("mirrors' figures", "lathe_mirror.report.analysis:mirror_figures"),
    ("calibration figures", "lathe_mirror.optics.camera_model:calibration_figures"),
    ("renders", "lathe_mirror.report.analysis:render_mirrors"),
    ("ranging", "lathe_mirror.report.analysis:ranging_figures"),
    ("tolerance", "lathe_mirror.pipeline:_tolerance"),
    ("  lattice phases cut, polished", "lathe_mirror.tolerance.surfaces:SurfaceBank.__init__"),
    ("  noses cut, polished", "lathe_mirror.tolerance.surfaces:SurfaceBank.ensure"),
    ("  trials evaluated", "lathe_mirror.tolerance.perturb:evaluate"),
    ("CAD and calibration files", "lathe_mirror.export.reference:cad_and_calibration_files"),
    ("spec drawing", "lathe_mirror.commands.spec:spec_files"),
    ("plots", "lathe_mirror.report.plots:report_plots"),
)


def stage_child(out_dir: str) -> None:
    """`run --workers 1` in this process with STAGES timed; prints their CPU seconds and the
    whole process's as JSON."""
    import functools
    import importlib
    import json

    spent = dict.fromkeys([name for name, _ in STAGES] + ["whole run"], 0.0)
    depth = dict.fromkeys(spent, 0)

    def timed(name, fn):
        @functools.wraps(fn)
        def wrapper(*args, **kw):
            depth[name] += 1
            t0 = time.process_time()
            try:
                return fn(*args, **kw)
            finally:
                depth[name] -= 1
                if depth[name] == 0:  # a recursive or nested call counts once
                    spent[name] += time.process_time() - t0
        return wrapper

    import lathe_mirror.cli as cli

    for name, target in STAGES:
        modname, qual = target.split(":")
        mod = importlib.import_module(modname)
        if "." in qual:
            cls_name, attr = qual.split(".")
            cls = getattr(mod, cls_name)
            setattr(cls, attr, timed(name, cls.__dict__[attr]))
            continue
        fn = getattr(mod, qual, None)
        if fn is None:  # an older tree without it (A/B against a past commit): its figure stays 0
            continue
        wrapper = timed(name, fn)
        for m in list(sys.modules.values()):  # every module that imported it by name
            d = getattr(m, "__dict__", None)
            if d is not None and m is not sys.modules[__name__]:
                for key, value in list(d.items()):
                    if value is fn:
                        d[key] = wrapper
    out = Path(out_dir)
    status = cli.main(["run", "--workers", "1", "--no-progress", "-o", str(out / "out"), "--gcode-dir",
                       str(out / "gcode"), "--cad-dir", str(out / "cad"), "--calib-dir", str(out / "calib")])
    if status:
        raise SystemExit(f"lathe-mirror run failed with status {status}")
    usage = resource.getrusage(resource.RUSAGE_SELF)
    spent["whole run"] = usage.ru_utime + usage.ru_stime
    sys.stdout.flush()
    print(json.dumps(spent), file=sys.__stdout__)


def bench_stages(runs: int) -> list[tuple[str, float]]:
    """Median CPU seconds of each of STAGES over `runs` fresh processes (stage_child)."""
    import json

    per = []
    for _ in range(runs):
        with tempfile.TemporaryDirectory(prefix="bench-stages-") as tmp:
            proc = subprocess.run([sys.executable, str(Path(__file__).resolve()), "--stages-child", tmp],
                                  capture_output=True, text=True, cwd=tmp)
            if proc.returncode != 0:
                sys.stderr.write(proc.stderr[-4000:])
                raise SystemExit(f"--stages: the timed run failed with status {proc.returncode}")
            per.append(json.loads(proc.stdout.strip().splitlines()[-1]))
    return [(name, statistics.median(p[name] for p in per)) for name in per[0]]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=3, help="runs of lathe-mirror run (median; 0: none)")
    ap.add_argument("--no-suite", action="store_true", help="skip the test suite")
    ap.add_argument("--suite-args", default="", help="extra pytest arguments (quoted; --suite-args=--durations=25)")
    ap.add_argument("--suite-log", help="write pytest's output to this file")
    ap.add_argument("--stages", type=int, default=0, metavar="N",
                    help="time each stage of `run --workers 1` in one process, N runs (median)")
    args = ap.parse_args()
    if args.runs < 0 or args.stages < 0:
        raise SystemExit("--runs, --stages: allowed 0 or more")

    rows = []
    if args.runs:
        print(f"lathe-mirror run on the paper default, {args.runs} runs ({os.cpu_count()} cores, "
              f"load {os.getloadavg()[0]:.1f}) ...", file=sys.stderr)
        runs = bench_run(args.runs)
        walls = [w for w, _ in runs]
        cpus = [c for _, c in runs]
        rows.append((f"lathe-mirror run (median of {args.runs})", statistics.median(walls),
                     statistics.median(cpus), f"min {min(walls):.1f}, max {max(walls):.1f} s wall; target 20 s"))
    if not args.no_suite:
        print(f"test suite (pytest -n auto, load {os.getloadavg()[0]:.1f}) ...", file=sys.stderr)
        wall, cpu, last = bench_suite(shlex.split(args.suite_args), args.suite_log)
        rows.append(("test suite (pytest -n auto)", wall, cpu, f"{last}; target 180 s"))

    if args.stages:
        print(f"stages of run --workers 1, {args.stages} runs (load {os.getloadavg()[0]:.1f}) ...", file=sys.stderr)
        print(f"{'stage (run --workers 1, in process)':<36} {'CPU s':>8} {'CPU Y':>7}")
        for name, cpu in bench_stages(args.stages):
            print(f"{name:<36} {cpu:8.2f} {yardstick.multiple(cpu):7.3f}")
    # the same figures in yardsticks (benchmarks/yardstick.py), comparable across machines
    print(f"{'what':<36} {'wall s':>8} {'CPU s':>8} {'wall Y':>7} {'CPU Y':>7}  note")
    for what, wall, cpu, note in rows:
        print(f"{what:<36} {wall:8.1f} {cpu:8.1f} {yardstick.multiple(wall):7.2f} {yardstick.multiple(cpu):7.2f}  "
              f"{note}")


if __name__ == "__main__":
    if sys.argv[1:2] == ["--stages-child"]:
        stage_child(sys.argv[2])
    else:
        yardstick.start()
        main()
