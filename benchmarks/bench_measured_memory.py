"""Peak memory of reading a measured map, per point: the figure behind
`measure.bounds.BYTES_PER_POINT` (the working memory a declared grid is checked with
against LATHE_MIRROR_MAX_GIB before anything is inflated).

Each format's map (a paraboloid, float64, N x N) is written in one process and read by
`read_measurement` in a fresh one, which prints its peak resident memory over the memory it
held before the read, divided by the points; the reference workload beside it is numpy
loading the same map from .npy and copying it once (16 B/point).

    PYTHONPATH=. .venv/bin/python benchmarks/bench_measured_memory.py [--n 2000]

Measured (2000 x 2000, 2026-11-27): .x3p 62.4 B/point, .datx 33.6 B/point, the load and copy 16.0.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
from pathlib import Path

_WRITE = r"""
import sys, numpy as np
fmt, n, path = sys.argv[1], int(sys.argv[2]), sys.argv[3]
yy, xx = np.mgrid[0:n, 0:n] * 1e-2
z_mm = 1.0 - 0.01 * (xx - n / 200) ** 2 - 0.01 * (yy - n / 200) ** 2
if fmt == "x3p":
    import x3pio
    x3pio.write(path, z_mm * 1e-3, x_scale=1e-5, y_scale=1e-5)
elif fmt == "datx":
    import h5py
    with h5py.File(path, "w") as f:
        s = f.create_group("Data").create_group("Surface").create_dataset("{0}", data=z_mm * 1e6)
        for k, v in (("No Data", [1e38]), ("Wavelength", [632.8e-9]), ("Unit", [b"NanoMeters"]),
                     ("Interferometric Scale Factor", [0.5]), ("Obliquity Factor", [1.0])):
            s.attrs[k] = np.array(v)
        f.create_group("Attributes").create_group("{1}").attrs["Data Context.Lateral Resolution:Value"] = np.array([1e-5])
else:
    np.save(path, z_mm)
"""

_READ = r"""
import os, resource, sys, warnings, numpy as np
fmt, n, path = sys.argv[1], int(sys.argv[2]), sys.argv[3]
from lathe_mirror.measure.readers import read_measurement
import x3pio, h5py
with warnings.catch_warnings():
    warnings.simplefilter("ignore")
    import prysm.io
held = int(open("/proc/self/statm").read().split()[1]) * os.sysconf("SC_PAGE_SIZE")
if fmt == "copy":
    z = np.load(path)
    out = z.copy()
else:
    out = read_measurement(path)
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
print(f"{fmt:5s} {(peak - held) / n / n:6.1f} B/point")
"""


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--n", type=int, default=2000)
    args = ap.parse_args()
    env = dict(os.environ, PYTHONPATH=str(Path(__file__).resolve().parents[1]))
    with tempfile.TemporaryDirectory() as tmp:
        for fmt in ("copy", "x3p", "datx"):
            path = str(Path(tmp) / f"m.{'npy' if fmt == 'copy' else fmt}")
            subprocess.run([sys.executable, "-c", _WRITE, fmt, str(args.n), path], check=True, env=env)
            subprocess.run([sys.executable, "-c", _READ, fmt, str(args.n), path], check=True, env=env)


if __name__ == "__main__":
    main()
