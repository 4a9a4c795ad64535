"""`measure` and its pieces on a simulated trace of the paper default (the part cut with a
0.21 mm nose where 0.20 was programmed and the tool 0.05 mm above centre), traced every
`--spacing` mm across the diameter: time to read the CSV, fit, diagnose, build the
simulated part (machine_errors.machined_with_errors) and the nominal part.

    PYTHONPATH=. .venv/bin/python benchmarks/bench_measure.py [--spacing 0.002 0.005 0.02]
"""

from __future__ import annotations

import yardstick  # benchmarks/yardstick.py: the machine-speed reference, timed in every run
import argparse
import math
import tempfile
import time
from pathlib import Path

import numpy as np


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--spacing", type=float, nargs="+", default=[0.002, 0.005, 0.02])
    args = ap.parse_args()
    from lathe_mirror.config import load
    from lathe_mirror.job import check_program, machine
    from lathe_mirror.machine_errors import MachineErrors, machined_with_errors
    from lathe_mirror.measure.diagnose import diagnose
    from lathe_mirror.measure.fit import fit_trace
    from lathe_mirror.measure.readers import read_measurement

    s = load(None)
    m = s.mirror()
    tp = check_program(s, m, s.toolpath.strategy)
    t = time.perf_counter()
    part = machined_with_errors(tp, MachineErrors(centre_height_mm=0.05, nose_radius_error_mm=0.01))
    t_sim = time.perf_counter() - t
    t = time.perf_counter()
    nominal = machine(tp)
    t_nom = time.perf_counter() - t
    print(f"simulated part (machined_with_errors): {t_sim:.2f} s; nominal part (as_machined): {t_nom:.2f} s")
    u = np.linspace(-m.r_max, m.r_max, 600001)
    w = m.vertex_z - part.z(np.abs(u))
    tilt = -2e-4
    X = -0.211 + u * math.cos(tilt) - w * math.sin(tilt)
    Z = 0.5 + u * math.sin(tilt) + w * math.cos(tilt)
    with tempfile.TemporaryDirectory() as tmp:
        for dx in args.spacing:
            x = np.arange(X.min() + 0.01, X.max() - 0.01, dx)
            z = np.interp(x, X, Z) + np.random.default_rng(1).normal(0, 5e-5, x.size)
            path = Path(tmp) / "t.csv"
            np.savetxt(path, np.c_[x, z], delimiter=",", header="x_mm,z_mm", comments="", fmt="%.7f")
            t0 = time.perf_counter()
            tr = read_measurement(path)
            t1 = time.perf_counter()
            f = fit_trace(tr, m)
            t2 = time.perf_counter()
            dg = diagnose(f, nominal, 0.2)
            t3 = time.perf_counter()
            print(f"spacing {dx:g} mm ({x.size} points): read {t1 - t0:.2f} s, fit {t2 - t1:.2f} s, "
                  f"diagnose {t3 - t2:.2f} s; nose {dg.nose_radius_mm:.4f} mm, centre height "
                  f"{dg.centre_height_mm:+.4f} mm, decentre error {(f.decentre_mm + 0.211) * 1e3:+.3f} um")


if __name__ == "__main__":
    yardstick.start()
    main()
