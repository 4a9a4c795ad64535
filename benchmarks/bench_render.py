"""Benchmark: the full sensor (1008 x 1018, 1 ray per pixel) through the 528-point paper
program, our renderer as a whole process against POV-Ray 3.7 on the exported scene.

    .venv/bin/python benchmarks/bench_render.py [--repeat 3] [--threads 2]

Both render the same thing: the paper strategy's programmed contour for a sharp tool
(nose radius 0: the surface is the program's 528 G1 points, as the paper simulated it),
the paper's room, the aligned camera. Ours: `python -m lathe_mirror render --surface paper
--image-only` (start-up, config, toolpath planning, tracing, PNG writing). POV-Ray:
`povray -D -V +FN +W1008 +H1018 +WT<threads> File_Gamma=1.0` on the exported .pov.
Wall-clock times, best of --repeat runs (the target's measure), and each process's CPU
time (user + sys over all its threads: less skewed when others load the machine); the
images are compared pixel by pixel.

Ours is timed twice: in the environment as it is, and with Python's default bytecode
caching (PYTHONDONTWRITEBYTECODE unset, one warm-up run writing the caches first). This
sandbox sets PYTHONDONTWRITEBYTECODE=1, which makes every process recompile the ~60
modules it imports (about 0.07 s); an ordinary installation caches them.
"""

from __future__ import annotations

import yardstick  # benchmarks/yardstick.py: the machine-speed reference, timed in every run
import argparse
import json
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from PIL import Image


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3, help="runs of each renderer (best is kept)")
    ap.add_argument("--threads", type=int, default=2, help="POV-Ray worker threads (+WT)")
    args = ap.parse_args()
    povray = shutil.which("povray")
    if povray is None:
        print("povray is not installed", file=sys.stderr)
        return 1

    from lathe_mirror.config import load
    from lathe_mirror.enums import Surface
    from lathe_mirror.export.povray import povray_command, povray_scene
    from lathe_mirror.optics.scene import build_scene
    from lathe_mirror.optics.trace import polyline_vertices
    from lathe_mirror.job import named_surface

    work = Path(tempfile.mkdtemp(prefix="bench_render_"))
    cfg_path = work / "sharp.toml"
    # f/100: the lens's blur stays within a pixel (0.53 px on the paper's camera), so render
    # leaves the image as traced, as POV-Ray's pinhole camera sees it (optics.defocus)
    cfg_path.write_text("[tool]\nnose_radius = 0.0\n[camera]\nf_number = 100.0\n")
    settings = load(cfg_path)
    mirror = settings.mirror()
    made = named_surface(Surface.PAPER, mirror, settings)
    points = sum(polyline_vertices(made, k)[0].size for k in (0, 1))
    scene = build_scene(settings.scene, mirror_top=mirror.outer.h, mirror_radius=mirror.r_max)
    pov = work / "paper.pov"
    pov.write_text(povray_scene(made, mirror, scene))

    ours_cmd = [sys.executable, "-m", "lathe_mirror", "render", "--config", str(cfg_path),
                "--surface", "paper", "--image-only", "--no-progress", "-o", str(work / "ours")]
    pov_png = work / "povray.png"
    pov_cmd = povray_command(pov, pov_png, mirror.camera, threads=args.threads, povray=povray)

    cpu: dict[str, list[float]] = {"ours": [], "cached": [], "povray": []}

    def timed(cmd, key: str, env=None) -> float:
        """Wall-clock seconds of one run; its CPU seconds (user + sys) go to cpu[key]."""
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        t0 = time.perf_counter()
        p = subprocess.run(cmd, capture_output=True, text=True, env=env)
        dt = time.perf_counter() - t0
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        if p.returncode != 0:
            raise SystemExit(f"{cmd[0]} failed: {p.stderr[-1000:]}")
        cpu[key].append(after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime)
        return dt

    ours_t = [timed(ours_cmd, "ours") for _ in range(args.repeat)]
    cached_env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    timed(ours_cmd, "cached", cached_env)  # warm-up: writes the bytecode caches
    cpu["cached"].clear()
    cached_t = [timed(ours_cmd, "cached", cached_env) for _ in range(args.repeat)]
    pov_t = [timed(pov_cmd, "povray") for _ in range(args.repeat)]
    load = os.getloadavg()[0]
    a = np.asarray(Image.open(work / "ours" / "paper.png").convert("RGB")).astype(int)
    b = np.asarray(Image.open(pov_png).convert("RGB")).astype(int)
    same = np.abs(a - b).max(axis=-1) <= 2
    result = {
        "sensor_px": list(mirror.camera.sensor_px),
        "program_points": int(points),
        "ours_s": {"best": min(ours_t), "runs": ours_t},
        "povray_s": {"best": min(pov_t), "runs": pov_t, "threads": args.threads},
        "ours_bytecode_cached_s": {"best": min(cached_t), "runs": cached_t},
        "cpu_s": {k: min(v) for k, v in cpu.items()},  # user + sys, all threads
        "load_average_1min": load,  # other work on the machine skews the wall-clock ratio
        "speedup": min(pov_t) / min(ours_t),
        "speedup_bytecode_cached": min(pov_t) / min(cached_t),
        "pixels_matching": float(same.mean()),
    }
    result.update(yardstick.in_yardsticks(result))
    print(json.dumps(result, indent=2))
    shutil.rmtree(work)
    return 0


if __name__ == "__main__":
    yardstick.start(json_output=True)
    sys.exit(main())
