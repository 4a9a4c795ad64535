"""Benchmark: the aligned (meridian) tracer against optiland's conic `Surface.trace` on the
same rays, and the ratio.

    .venv/bin/python benchmarks/bench_tracer_vs_optiland.py [--repeat 9] [--config FILE]
        [--optiland-python /path/to/venv/bin/python]

The rays: the camera's chief rays from the pinhole through every pixel centre of the full
sensor (the paper default: 1008 x 1018 = 1,026,144 rays). The project traces them all in
one `trace_pixels` call (it sorts them into inner lobe, outer lobe, wall and miss itself,
and flags the vignetted ones) on the exact design and on the paper program and the best
strategy as machined (tabulated tool-nose envelopes). optiland traces, with
`Surface.trace(rays, record=False)`, each lobe's rays on that lobe's conic (a standard
surface, R = b^2 / a, k = -(1 + b^2 / a^2), vertex at e + a above the pinhole, reflective):
the sorting is done for it outside the clock and it skips the wall and miss rays, so the
ratio on the sensor rows is conservative; the rows "lobe rays" give the project the very
rays optiland traces (788,440 of the paper default's), in the sensor's order. optiland can only trace the exact conic: the made surfaces' rows
compare the project on the made profile with optiland on the exact conic (what a
conic-only tracer would cost on the same rays).

Alternating: each round times every project surface once, then optiland once; the figure
is the best of --repeat rounds, by wall clock and (in brackets) by the process's CPU time,
which other processes loading the machine skew less (on a 2-core machine loaded 10 times
over, the wall-clock ratios swing by 2x from run to run; the CPU ones by 10-20%). The
yardstick (benchmarks/yardstick.py) is timed first and every time figure is also given in
yardsticks. A made surface's fate table (optics.meridian_table, built on the first trace
of a profile and kept while it lives) is built before the clock: the first trace's time
is printed. Both sides are single-threaded
(numpy; optiland's conic kernel is a numba loop). rays/s counts each row's rays; the
ratio is optiland's time over the row's (> 1: the project is faster). The load average
is printed before and after. Before timing, the hit points and reflected directions of
the exact design are compared ray by ray (max |difference| in mm and in direction
components; the run fails above 1e-9).

optiland is not a dependency of the project. When `import optiland` works in this
interpreter it runs in-process; otherwise give --optiland-python (or set
LATHE_MIRROR_OPTILAND_PYTHON) to another environment's python that has optiland and numpy
(e.g. `python3 -m venv /tmp/ol && /tmp/ol/bin/pip install optiland`): this file then runs
there as a worker (`--optiland-worker DIR`, which imports numpy and optiland only) and is
driven over a pipe, so the alternation is kept. Without either, the project's side alone.
"""

from __future__ import annotations

import argparse
import importlib.util
import math
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

WAVELENGTH_UM = 0.55


# --------------------------------------------------------------------------------------
# optiland's side (runs in whichever interpreter has optiland; imports nothing of ours)


class OptilandSide:
    """Both lobes as optiland reflective standard surfaces, and each lobe's rays."""

    def __init__(self, data: dict[str, np.ndarray]):
        from optiland.coordinate_system import CoordinateSystem
        from optiland.geometries import StandardGeometry
        from optiland.interactions.refractive_reflective_model import RefractiveReflectiveModel
        from optiland.materials import IdealMaterial
        from optiland.surfaces import Surface

        air = IdealMaterial(1.0)
        self.surfaces, self.rays = [], []
        for k in (0, 1):
            R, conic, vertex = (float(x) for x in data[f"lobe{k}"])
            before = Surface(None, air, StandardGeometry(CoordinateSystem(), math.inf))
            geometry = StandardGeometry(CoordinateSystem(z=vertex), R, conic)
            model = RefractiveReflectiveModel(parent_surface=None, is_reflective=True)
            self.surfaces.append(Surface(before, air, geometry, interaction_model=model))
            d = data[f"dir{k}"]
            zero = np.zeros(d.shape[1])
            self.rays.append((zero, zero, zero, d[0], d[1], d[2], np.ones_like(zero),
                              np.full_like(zero, WAVELENGTH_UM)))
        self.last = None

    def trace(self) -> None:
        from optiland.rays import RealRays

        self.last = [s.trace(RealRays(*r), record=False) for s, r in zip(self.surfaces, self.rays)]

    def result(self) -> dict[str, np.ndarray]:
        return {f"{q}{k}": np.stack([np.asarray(getattr(r, c)) for c in cs])
                for k, r in enumerate(self.last) for q, cs in (("point", "xyz"), ("dir", "LMN"))}


def worker(folder: str) -> int:
    """--optiland-worker: load the rays, then per line on stdin `trace` (answer: wall and
    CPU seconds), `dump` (write the hits to result.npz) or `quit`."""
    side = OptilandSide(dict(np.load(Path(folder) / "rays.npz")))
    side.trace()  # the numba kernel's compilation (cached on disk after the first run)
    print("ready", flush=True)
    for line in sys.stdin:
        cmd = line.strip()
        if cmd == "trace":
            t0, c0 = time.perf_counter(), time.process_time()
            side.trace()
            print(f"{time.perf_counter() - t0!r} {time.process_time() - c0!r}", flush=True)
        elif cmd == "dump":
            np.savez(Path(folder) / "result.npz", **side.result())
            print("done", flush=True)
        else:
            break
    return 0


class Remote:
    """OptilandSide in another interpreter, over a pipe."""

    def __init__(self, python: str, data: dict[str, np.ndarray], folder: str):
        self.folder = Path(folder)
        np.savez(self.folder / "rays.npz", **data)
        self.proc = subprocess.Popen([python, __file__, "--optiland-worker", folder],
                                     stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
        if self.proc.stdout.readline().strip() != "ready":
            raise SystemExit(f"--optiland-python {python}: the optiland worker did not start")

    def timed(self) -> tuple[float, float]:
        self.proc.stdin.write("trace\n")
        self.proc.stdin.flush()
        wall, cpu = self.proc.stdout.readline().split()
        return float(wall), float(cpu)

    def result(self) -> dict[str, np.ndarray]:
        self.proc.stdin.write("dump\n")
        self.proc.stdin.flush()
        self.proc.stdout.readline()
        return dict(np.load(self.folder / "result.npz"))

    def close(self) -> None:
        self.proc.stdin.write("quit\n")
        self.proc.stdin.flush()
        self.proc.wait(timeout=60)


class Local:
    """OptilandSide in this interpreter."""

    def __init__(self, data: dict[str, np.ndarray]):
        self.side = OptilandSide(data)
        self.side.trace()

    def timed(self) -> tuple[float, float]:
        return clocked(self.side.trace)

    def result(self) -> dict[str, np.ndarray]:
        return self.side.result()

    def close(self) -> None:
        pass


# --------------------------------------------------------------------------------------
# The project's side and the comparison


def clocked(fn) -> tuple[float, float]:
    t0, c0 = time.perf_counter(), time.process_time()
    fn()
    return time.perf_counter() - t0, time.process_time() - c0


def load_text() -> str:
    return f"load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores"


def optiland_python(arg: str | None) -> str | None:
    """'' for in-process, a path for a worker, None for the project's side alone."""
    if importlib.util.find_spec("optiland") is not None:
        return ""
    return arg or os.environ.get("LATHE_MIRROR_OPTILAND_PYTHON") or None


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=9)
    ap.add_argument("--config", default=None)
    ap.add_argument("--optiland-python", default=None,
                    help="python of an environment with optiland (default: in-process if importable, "
                         "else $LATHE_MIRROR_OPTILAND_PYTHON)")
    ap.add_argument("--optiland-worker", default=None, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.optiland_worker:
        return worker(args.optiland_worker)

    import yardstick  # benchmarks/yardstick.py: the machine-speed reference, timed in every run

    yardstick.start()
    from lathe_mirror.config import load
    from lathe_mirror.enums import Surface
    from lathe_mirror.job import named_surface
    from lathe_mirror.optics.camera import pixel_centres, ray_directions
    from lathe_mirror.optics.trace import trace_pixels
    from lathe_mirror.profile import ExactProfile

    s = load(args.config)
    mirror = s.mirror()
    cam = mirror.camera
    u, v = pixel_centres(cam)
    xy = np.stack([u[..., 0], v[..., 0]], axis=-1)
    n = xy[..., 0].size
    surfaces = [("exact", ExactProfile(mirror)), ("paper", named_surface(Surface.PAPER, mirror, s)),
                ("best", named_surface(Surface.BEST, mirror, s))]
    built = {}
    for name, prof in surfaces:
        t0 = time.perf_counter()
        trace_pixels(prof, cam, xy)  # the first trace of a profile builds its tables
        built[name] = time.perf_counter() - t0

    exact = trace_pixels(surfaces[0][1], cam, xy)
    fate = exact.fate.reshape(-1)
    xy_lobes = xy.reshape(-1, 2)[fate <= 1]  # the rays optiland traces, in the sensor's order
    _, d = ray_directions(cam, xy[..., 0], xy[..., 1])
    d = d.reshape(-1, 3)
    data = {}
    for k, lobe in enumerate(mirror.lobes):
        data[f"lobe{k}"] = np.array([lobe.b**2 / lobe.a, -(1.0 + (lobe.b / lobe.a) ** 2), lobe.vertex_z])
        data[f"dir{k}"] = np.ascontiguousarray(d[fate == k].T)
    on_lobes = int(sum(data[f"dir{k}"].shape[1] for k in (0, 1)))

    python = optiland_python(args.optiland_python)
    print(f"{n} rays per run ({on_lobes} on the lobes), best of {args.repeat} alternating rounds; "
          f"{load_text()}")
    with tempfile.TemporaryDirectory() as folder:
        other = None if python is None else Local(data) if python == "" else Remote(python, data, folder)
        if other is None:
            print("  optiland: not importable here and no --optiland-python: the project's side alone")
        else:
            worst = check(exact, fate, other.result())
            print(f"  same hits as optiland: max |point| difference {worst[0]:.2e} mm, "
                  f"max |direction| difference {worst[1]:.2e}")
            if max(worst) > 1e-9:
                other.close()
                print("  the tracers disagree by more than 1e-9: the comparison is void")
                return 1
        rows = [(f"{name}, {which}", prof, rays) for name, prof in surfaces
                for which, rays in (("sensor", xy), ("lobe rays", xy_lobes))]
        best = {name: (math.inf, math.inf) for name, *_ in rows + [("optiland", None)]}
        for _ in range(args.repeat):
            for name, prof, rays in rows:
                t = clocked(lambda: trace_pixels(prof, cam, rays))
                best[name] = tuple(map(min, best[name], t))
            if other is not None:
                best["optiland"] = tuple(map(min, best["optiland"], other.timed()))
        if other is not None:
            other.close()
    ref = best["optiland"]
    print("  the first trace of each surface (with its tables, once per profile): "
          + ", ".join(f"{name} {1e3 * t:.1f} ms" for name, t in built.items()))
    print(f"  {'':27s} {'rays':>8s} {'rays/s':>9s} (by CPU)  optiland's time / the row's (by CPU)  wall, CPU")
    if other is not None:
        print(f"  {'optiland  exact, lobe rays':27s} {on_lobes:8d} {on_lobes / ref[0]:9.3g} ({on_lobes / ref[1]:.3g})"
              f"  {'':18s}  {1e3 * ref[0]:.1f} ms, {1e3 * ref[1]:.1f} ms")
    for name, _, rays in rows:
        wall, cpu = best[name]
        k = rays[..., 0].size
        ratio = f"{'':18s}" if other is None else f"   {ref[0] / wall:5.2f} ({ref[1] / cpu:.2f})      "
        print(f"  {'project   ' + name:27s} {k:8d} {k / wall:9.3g} ({k / cpu:.3g}){ratio}"
              f"  {1e3 * wall:.1f} ms, {1e3 * cpu:.1f} ms")
    print(f"{load_text()} at the end")
    return 0


def check(exact, fate: np.ndarray, theirs: dict[str, np.ndarray]) -> tuple[float, float]:
    """Max |difference| of the hit points (mm) and the reflected directions, ray by ray."""
    point, direction = exact.point.reshape(-1, 3), exact.direction.reshape(-1, 3)
    dp = dd = 0.0
    for k in (0, 1):
        on = fate == k
        dp = max(dp, float(np.max(np.abs(point[on] - theirs[f"point{k}"].T))))
        dd = max(dd, float(np.max(np.abs(direction[on] - theirs[f"dir{k}"].T))))
    return dp, dd


if __name__ == "__main__":
    raise SystemExit(main())
