"""What a 12-megapixel design costs against the paper's 1-megapixel one, stage by stage.

Run: .venv/bin/python benchmarks/bench_large_sensor.py [--stages calib tolerance run] [--trials 200]

The 12-megapixel design (issue 34): f 4.4 mm, 1.55 um pixels, 4000 x 3000, the paper's
lobes scaled to the short side (inner r_pixel 915.3 px, outer 1500 px; `design` accepts
it). Each stage runs as `lathe-mirror STAGE` in a fresh process on both designs, writing
into a temporary directory; the figures are wall and CPU seconds (user + system of the
child: CPU is the one to compare on a loaded machine) and the 12-MP / paper ratio (the
target for `run`: at most 2). `tolerance` runs --trials trials on one worker.
Prints the yardstick first (benchmarks/yardstick.py) and every time also in yardsticks.
"""

from __future__ import annotations

import yardstick  # benchmarks/yardstick.py: the machine-speed reference, timed in every run
import argparse
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

TWELVE_MP = """[camera]
f = 4.4
t_pixel = 0.00155
sensor_px = [4000, 3000]
[lobes.inner]
r_pixel = 915.3
[lobes.outer]
r_pixel = 1500.0
"""


def stage_args(stage: str, out: Path, trials: int) -> list[str]:
    if stage == "calib":
        return ["calib", "-o", str(out / "calib"), "--no-progress"]
    if stage == "tolerance":
        return ["tolerance", "--trials", str(trials), "--workers", "1", "--no-progress"]
    if stage == "run":
        return ["run", "-o", str(out / "out"), "--gcode-dir", str(out / "gcode"), "--cad-dir", str(out / "cad"),
                "--calib-dir", str(out / "calib")]
    return [stage, "--no-progress"]


def timed(args: list[str], cwd: Path) -> tuple[float, float]:
    """Wall and CPU (children's user + system) seconds of `lathe-mirror ARGS`."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "lathe_mirror", *args], capture_output=True, text=True, cwd=cwd)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if proc.returncode != 0:
        sys.stderr.write(proc.stderr[-3000:])
        raise SystemExit(f"lathe-mirror {' '.join(args)} failed with status {proc.returncode}")
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--stages", nargs="+", default=["calib", "tolerance"],
                    help="lathe-mirror commands to time (calib, tolerance, stereo, render, run, ...)")
    ap.add_argument("--trials", type=int, default=200, help="tolerance trials")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory(prefix="bench-large-") as tmp:
        tmp = Path(tmp)
        (tmp / "mp12.toml").write_text(TWELVE_MP)
        for stage in args.stages:
            figs = {}
            for name, extra in (("paper", []), ("12 MP", ["--config", str(tmp / "mp12.toml")])):
                out = tmp / f"{stage}-{name.replace(' ', '')}"
                out.mkdir()
                figs[name] = timed(stage_args(stage, out, args.trials) + extra, out)
                print(f"{stage:10s} {name:6s} {figs[name][0]:8.1f} s wall {figs[name][1]:8.1f} s CPU "
                      f"(load {os.getloadavg()[0]:.1f})", flush=True)
            print(f"{stage:10s} 12 MP / paper: wall {figs['12 MP'][0] / figs['paper'][0]:.2f}x, "
                  f"CPU {figs['12 MP'][1] / figs['paper'][1]:.2f}x", flush=True)


if __name__ == "__main__":
    yardstick.start()
    main()
