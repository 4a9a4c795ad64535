"""Time `lathe-mirror run` on the paper default in a fresh process (target < 60 s).

Run: .venv/bin/python benchmarks/bench_run.py
Writes into a temporary directory (report, programs, CAD, calibration files), so the
repository's gcode/, cad/ and calib/ are left alone; prints the wall time and the run's summary.
"""

from __future__ import annotations

import subprocess
import sys
import tempfile
import time
from pathlib import Path


def main() -> None:
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        cmd = [sys.executable, "-m", "lathe_mirror", "run", "-o", str(tmp / "out"),
               "--gcode-dir", str(tmp / "gcode"), "--cad-dir", str(tmp / "cad"),
               "--calib-dir", str(tmp / "calib")]
        t0 = time.perf_counter()
        proc = subprocess.run(cmd, capture_output=True, text=True)
        dt = time.perf_counter() - t0
        if proc.returncode != 0:
            sys.stderr.write(proc.stderr)
            raise SystemExit(f"lathe-mirror run failed with status {proc.returncode}")
        print(proc.stdout.strip())
        print(f"lathe-mirror run (paper default): {dt:.1f} s wall")


if __name__ == "__main__":
    main()
