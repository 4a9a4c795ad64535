"""Time the calibration stage: the design's files, and per made mirror the traced
correspondences, the design model's reprojection error and the refit.

Run: .venv/bin/python benchmarks/bench_calib.py [--repeat N]
Prints the median and best of N runs per step (the made surfaces are built once, outside
the timing; the misaligned case traces every 4th pixel in 3-D).
"""

from __future__ import annotations

import yardstick  # benchmarks/yardstick.py: the machine-speed reference, timed in every run
import argparse
import math
import statistics
import time


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()

    from lathe_mirror.config import load
    from lathe_mirror.enums import Surface
    from lathe_mirror.export.calib import calibration_texts
    from lathe_mirror.optics.camera import CameraPose
    from lathe_mirror.optics.camera_model import made_figures
    from lathe_mirror.job import named_surface

    settings = load()
    mirror = settings.mirror()
    nose = settings.tool.nose_radius
    made = {s.value: named_surface(s, mirror, settings, nose_radius=nose if s is not Surface.POLISHED else 0.0)
            for s in (Surface.PAPER, Surface.BEST, Surface.POLISHED)}
    tilted = CameraPose(tilt=(0.0, math.radians(0.1)))
    rows: dict[str, list[float]] = {}
    for _ in range(args.repeat):
        t0 = time.perf_counter()
        calibration_texts(mirror)
        rows.setdefault("design files (OpenCV, Kalibr, OCamCalib fits)", []).append(time.perf_counter() - t0)
        for name, profile in made.items():
            t0 = time.perf_counter()
            made_figures(profile, mirror)
            rows.setdefault(f"made mirror {name}: both lobes, aligned", []).append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        made_figures(made["best"], mirror, pose=tilted)
        rows.setdefault("made mirror best: both lobes, camera tilted 0.1 deg (3-D)", []).append(time.perf_counter() - t0)
    for name, times in rows.items():
        print(f"{name:60s} median {statistics.median(times):6.2f} s   best {min(times):6.2f} s")


if __name__ == "__main__":
    yardstick.start()
    main()
