"""The cost estimates of settings.check_costs against measured runs (issue 14).

Each case runs one command in a fresh process and prints the estimate of the piece of
work it exercises beside the measured wall-clock time and peak resident memory, and the
load average (a loaded machine skews the time). `--edge` runs the slowest inputs each
command accepts (near the limits: minutes and gigabytes each; run it on an idle machine).

    .venv/bin/python benchmarks/bench_bounds.py [--edge] [--only NAME]
"""

from __future__ import annotations

import yardstick  # benchmarks/yardstick.py: the machine-speed reference, timed in every run
import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

#: (name, command arguments, TOML, the estimate's piece of work)
CASES = [
    ("design", ["design"], "", None),
    ("toolpath paper 5000 points at 0.0001 mm", ["toolpath", "--strategy", "paper", "--resolution", "0.0001",
                                                 "--points", "5000", "-o", "t.ngc"], "", "nose envelope"),
    ("cad STL at 0.001 mm", ["cad", "--format", "stl", "--stl-tolerance", "0.001", "-o", "m.stl"], "", "STL"),
    ("cad STL at 0.001 mm, mirror x5", ["cad", "--format", "stl", "--stl-tolerance", "0.001", "-o", "m.stl"],
     "[lobes.inner]\nr_top = 100.0\n[lobes.outer]\nr_top = 175.0\n"
     "[cad]\nblank_diameter = 380.0\nthickness = 150.0\n", "STL"),
    ("render", ["render", "--no-progress", "-o", "R"], "", "rendering"),
    ("render 2016 x 2036", ["render", "--no-progress", "-o", "R"], "[camera]\nsensor_px = [2016, 2036]\n",
     "rendering"),
    ("render supersample 3", ["render", "--no-progress", "--supersample", "3", "-o", "R"], "", "rendering"),
    ("polish", ["polish", "--no-progress", "-o", "P"], "", "polishing"),
    ("polish grid 0.001 mm", ["polish", "--no-progress", "-o", "P"], "[polish]\ngrid_step_mm = 0.001\n",
     "polishing"),
    ("tolerance 200 trials", ["tolerance", "--no-progress", "--trials", "200", "-o", "T"], "", "Monte Carlo"),
    ("tolerance 4000 trials", ["tolerance", "--no-progress", "--trials", "4000", "-o", "T"], "", "Monte Carlo"),
    ("report", ["report", "--no-progress", "-o", "O"], "", None),
    ("run", ["run", "--no-progress", "-o", "O", "--gcode-dir", "G", "--cad-dir", "C"], "[camera]\nf = 16.0\n", None),
]

#: The slowest inputs each command accepts on the paper default (each found by bisection
#: on config.load: one step more is refused), near the memory or the time limit.
EDGE = [
    ("toolpath: paper, 16632 points at 0.0001 mm", ["toolpath", "--strategy", "paper", "--points", "16632",
                                                    "-o", "t.ngc"], "[machine]\nresolution = 0.0001\n",
     "nose envelope"),
    ("cad: STL at 0.001 mm, mirror x10", ["cad", "--format", "stl", "--stl-tolerance", "0.001", "-o", "m.stl"],
     "[lobes.inner]\nr_top = 200.0\n[lobes.outer]\nr_top = 350.0\n[cad]\nblank_diameter = 760.0\n"
     "thickness = 300.0\n[scene]\nroom_height = 5000.0\n[polish]\ngrid_step_mm = 0.05\n"
     "[tolerance]\nlattice_phases = 1\n", "STL"),
    ("render: 5484 x 5484 px", ["render", "--no-progress", "-o", "R"], "[camera]\nsensor_px = [5484, 5484]\n",
     "rendering"),
    ("render: 1456 x 1456 px, supersample 8", ["render", "--no-progress", "--supersample", "8", "-o", "R"],
     "[camera]\nsensor_px = [1456, 1456]\n", "rendering"),
    ("polish: grid 0.0005 mm, curve to 151173 s", ["polish", "--no-progress", "-o", "P"],
     "[polish]\ngrid_step_mm = 0.0005\ncurve_max_s = 151173.0\n", "polishing"),
    ("stereo: 0.01 deg x 15544 azimuths", ["stereo", "--no-progress", "-o", "S"],
     "[stereo]\nelevation_step_deg = 0.01\nazimuth_px = 15544\n", "ranging"),
    ("optimize: popsize 100, maxiter 999", ["optimize", "--no-progress", "-o", "best.toml"],
     "[optimize]\npopsize = 100\nmaxiter = 999\n", "optimiser"),
    ("tolerance: 43380 trials", ["tolerance", "--no-progress", "--trials", "43380", "-o", "T"], "",
     "Monte Carlo"),
    ("report: 43380 trials", ["report", "--no-progress", "-o", "O"], "[tolerance]\ntrials = 43380\n", None),
]


def estimate(toml_path: Path | None, args: list[str]) -> dict[str, tuple[float, float]]:
    """{work: (seconds, bytes)} of settings.estimate_costs for the case's configuration."""
    from lathe_mirror.config import load
    from lathe_mirror.settings import estimate_costs

    flags = {"--points": "machine.max_points", "--resolution": "machine.resolution",
             "--supersample": "render.supersample", "--trials": "tolerance.trials",
             "--stl-tolerance": "cad.stl_tolerance"}
    overrides = []
    for flag, key in flags.items():
        if flag in args:
            text = args[args.index(flag) + 1]
            overrides.append((key, int(text) if key in ("machine.max_points", "render.supersample",
                                                         "tolerance.trials") else float(text), flag))
    s = load(toml_path, overrides=overrides)
    return {c.work: (c.seconds, c.bytes) for c in estimate_costs(s, s.mirror())}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--edge", action="store_true", help="the slowest accepted inputs (minutes, gigabytes)")
    ap.add_argument("--only", default="", help="run the cases whose name contains this")
    opts = ap.parse_args()
    cases = EDGE if opts.edge else CASES
    print(f"{'case':46s} {'estimate':>22s} {'measured':>22s}  load")
    for name, args, toml, work in cases:
        if opts.only and opts.only not in name:
            continue
        with tempfile.TemporaryDirectory() as tmp:
            d = Path(tmp)
            cfg = None
            if toml:
                cfg = d / "c.toml"
                cfg.write_text(toml)
            costs = estimate(cfg, args)
            est = "total %.0f s" % sum(c[0] for c in costs.values())
            if work:
                s, b = next(v for k, v in costs.items() if work.lower() in k.lower())
                est = f"{s:7.1f} s {b / 2**30:6.2f} GiB"
            t0 = time.perf_counter()
            err = d / "stderr.txt"
            with open(err, "w") as fh:
                proc = subprocess.Popen([sys.executable, "-m", "lathe_mirror", *args,
                                         *(["--config", str(cfg)] if cfg else [])],
                                        cwd=d, stdout=subprocess.DEVNULL, stderr=fh)
                _, code, usage = os.wait4(proc.pid, 0)  # this child's own peak memory
            wall = time.perf_counter() - t0
            rss = usage.ru_maxrss * 1024  # kB on Linux
            rc = os.waitstatus_to_exitcode(code)
            status = "" if rc == 0 else f" exit {rc}: {err.read_text().strip()[:200]}"
            print(f"{name:46s} {est:>22s} {wall:7.1f} s {rss / 2**30:6.2f} GiB  "
                  f"{os.getloadavg()[0]:.1f}{status}", flush=True)


if __name__ == "__main__":
    yardstick.start()
    main()
