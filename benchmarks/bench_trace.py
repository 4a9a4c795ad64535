"""Benchmark: the tracers' speed, rays per second, on the full sensor (1008 x 1018, one ray
per pixel centre): the aligned camera (the meridian tracer) beside a misaligned one (the
3-D tracer: optics.trace3d, and its fallback march alone, as the 3-D path ran before).

    .venv/bin/python benchmarks/bench_trace.py [--repeat 5] [--march] [--config FILE]

Surfaces: the exact design (closed form), the paper program and the best strategy as
machined (tabulated tool-nose envelopes). Pose of the misaligned camera: decentre
(0.05, -0.03) mm, axial +0.1 mm, tilt (0.1, -0.06) deg (a tolerance trial's order). The
time is the best of --repeat runs of trace_pixels on the whole sensor (wall clock; the
process's CPU time beside it, less skewed when other processes load the machine; with
threads it is their sum, so the rate by CPU time is per core). The 3-D tracer runs once
serial (one core: what a Monte Carlo worker does) and once on all cores (a command's
default --workers: its chunks in threads, numpy releasing the GIL). The
per-profile tables (built once per surface) are warmed first. --march also times the
march on its own (slow: tens of seconds).
"""

from __future__ import annotations

import yardstick  # benchmarks/yardstick.py: the machine-speed reference, timed in every run
import argparse
import math
import os
import time

import numpy as np


def best_of(fn, repeat: int) -> tuple[float, float]:
    wall, cpu = math.inf, math.inf
    for _ in range(repeat):
        t0, c0 = time.perf_counter(), time.process_time()
        fn()
        wall = min(wall, time.perf_counter() - t0)
        cpu = min(cpu, time.process_time() - c0)
    return wall, cpu


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--march", action="store_true", help="also time the march alone (slow)")
    ap.add_argument("--config", default=None)
    args = ap.parse_args()

    from lathe_mirror import compute
    from lathe_mirror.config import load
    from lathe_mirror.enums import Surface
    from lathe_mirror.optics.camera import CameraPose, pixel_centres, ray_directions
    from lathe_mirror.optics.trace import trace_pixels
    from lathe_mirror.optics.trace3d import trace_rays
    from lathe_mirror.job import named_surface
    from lathe_mirror.profile import ExactProfile

    s = load(args.config)
    mirror = s.mirror()
    cam = mirror.camera
    u, v = pixel_centres(cam)
    xy = np.stack([u[..., 0], v[..., 0]], axis=-1)
    n = xy[..., 0].size
    pose = CameraPose(decentre=(0.05, -0.03), axial_offset=0.1, tilt=(math.radians(0.1), math.radians(-0.06)))
    origin, d = ray_directions(cam, xy[..., 0], xy[..., 1], pose)
    surfaces = [("exact", ExactProfile(mirror)), ("paper", named_surface(Surface.PAPER, mirror, s)),
                ("best", named_surface(Surface.BEST, mirror, s))]
    cores = compute.default_workers()
    print(f"{n} rays per run, best of {args.repeat}; rays/s by wall clock (by CPU time); "
          f"load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores")
    for name, prof in surfaces:
        trace_pixels(prof, cam, xy[:4, :4], pose=pose)  # the per-profile tables
        rows = [("aligned (meridian)", 1, lambda: trace_pixels(prof, cam, xy)),
                ("3-D (trace3d)", 1, lambda: trace_pixels(prof, cam, xy, pose=pose)),
                (f"3-D, {cores} threads", cores, lambda: trace_pixels(prof, cam, xy, pose=pose))]
        if args.march:
            rows.append(("3-D march alone", 1, lambda: trace_rays(prof, origin, d, fast=False)))
        for label, workers, fn in rows:
            with compute.session(workers=workers):  # a command's --workers: the 3-D chunks on its cores
                wall, cpu = best_of(fn, args.repeat if "march" not in label else 1)
            print(f"  {name:6s} {label:20s} {n / wall:10.3g} rays/s  ({n / cpu:.3g})")
    print(f"load average at the end {os.getloadavg()[0]:.2f}")
    return 0


if __name__ == "__main__":
    yardstick.start()
    raise SystemExit(main())
