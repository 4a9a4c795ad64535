"""The design matrix of issue 20, full settings: each design through the whole chain as a
user runs it, in fresh processes, and the figures each command quotes for the same made
mirror and zone.

Per design: `optimize -o best.toml` (with its tolerance check), `run --config best.toml`,
`toolpath --check` on the arcs program `run` wrote, `calib`, `stereo`, `tolerance
--allocate`, `polish`; every exit status, the winner, the nominal verdict and the yield of
the best program, and the image displacement (RMS per lobe, px) of the as-machined best
program over the used zone as `calib`, `tolerance` (its nominal part, raw figures: the
sparse pixel sample) and the report quote it.

Run: .venv/bin/python benchmarks/bench_designs.py [--only NAME ...] [--markdown] [--keep DIR]
Prints a table (--markdown: the README's). Writes only into a temporary directory (or
--keep DIR).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

#: name -> (what, TOML). Fast settings for the tests live in tests/test_designs.py.
DESIGNS = {
    "paper": ("the paper default (16 mm lens, 9 um pixels, nose 0.2 mm, 0.005 mm lattice)", ""),
    "deep": ("the paper camera opened to 35 mm depth (outer lobe recessed)",
             "[optimize]\nmax_depth_mm = 35.0\n[stock]\nlength = 50.0\n[cad]\nthickness = 45.0\n"),
    "cam6": ("6 mm lens, 3 um pixels, nose 0.4 mm, 60 mm aluminium bar, 50 x 25 mm envelope",
             "[camera]\nf = 6.0\nt_pixel = 0.003\nsensor_px = [1280, 1024]\n[tool]\nnose_radius = 0.4\n"
             "[stock]\ndiameter = 60.0\n[optimize]\nmax_diameter_mm = 50.0\nmax_depth_mm = 25.0\n"),
    "cam12": ("12 mm lens, 5.86 um pixels, 50 mm stock, nose 0.8 mm, 0.01 mm lattice",
              "[camera]\nf = 12.0\nt_pixel = 0.00586\nsensor_px = [1920, 1200]\n[tool]\nnose_radius = 0.8\n"
              "[machine]\nresolution = 0.01\n[toolpath]\ngouge_tolerance = 0.01\n[stock]\ndiameter = 50.0\n"
              "[optimize]\nmax_diameter_mm = 48.0\nmax_depth_mm = 30.0\n"),
    "cam4": ("4 mm lens, 1.4 um pixels, nose 0.1 mm, 0.001 mm lattice",
             "[camera]\nf = 4.0\nt_pixel = 0.0014\nsensor_px = [2592, 1944]\n[tool]\nnose_radius = 0.1\n"
             "[machine]\nresolution = 0.001\n[optimize]\nmax_diameter_mm = 40.0\nmax_depth_mm = 20.0\n"
             "[tolerance.params]\nresolution_mm = 0.0005\n"),
    "paper_nose08": ("the paper camera, nose 0.8 mm, 0.0025 mm lattice",
                     "[tool]\nnose_radius = 0.8\n[machine]\nresolution = 0.0025\n"),
}


def cli(args: list[str], cwd: Path) -> tuple[int, str, str, float]:
    t0 = time.perf_counter()
    p = subprocess.run([sys.executable, "-m", "lathe_mirror", *args], capture_output=True, text=True, cwd=cwd)
    return p.returncode, p.stdout, p.stderr, time.perf_counter() - t0


def one(name: str, text: str, root: Path) -> dict:
    d = root / name
    d.mkdir(parents=True, exist_ok=True)
    (d / "design.toml").write_text(text)
    row: dict = {"design": name, "status": {}, "seconds": {}}

    def step(label: str, args: list[str]) -> str | None:
        rc, out, err, s = cli(args, d)
        row["status"][label], row["seconds"][label] = rc, round(s, 1)
        if rc != 0:
            row.setdefault("errors", {})[label] = err.strip().splitlines()[-1:] if err.strip() else []
            return None
        return out

    out = step("optimize", ["optimize", "--config", "design.toml", "-o", "best.toml", "--json", "--no-progress",
                            "--workers", "2"])
    if out is None:
        return row
    opt = json.loads(out)
    row["winner"] = {lb["name"]: {k: lb[k] for k in ("r_top", "r_pixel", "alpha_deg")} for lb in opt["best"]["lobes"]}
    row["r10_m"] = opt["best"]["r10_m"]
    row["check"] = {k: opt["check"][k] for k in ("nominal_pass", "yield", "target_yield")} | (
        {"why": opt["check"]["why"]} if "why" in opt["check"] else {})
    row["warnings"] = len(opt["warnings"])
    step("run", ["run", "--config", "best.toml", "-o", "out", "--no-render", "--no-progress"])
    step("toolpath --check", ["toolpath", "--config", "best.toml", "--check", "out/gcode/mirror_arcs.ngc"])
    cal = step("calib", ["calib", "--config", "best.toml", "--surface", "best", "-o", "calib", "--json",
                         "--no-progress"])
    step("stereo", ["stereo", "--config", "best.toml", "--json", "--no-progress"])
    tol = step("tolerance --allocate", ["tolerance", "--config", "best.toml", "--allocate", "--json",
                                        "--no-progress"])
    step("polish", ["polish", "--config", "best.toml", "--json", "--no-progress"])
    quotes = {}
    if cal:
        c = json.loads(cal)["made"][0]
        quotes["calib"] = [lb["image_displacement_px"]["rms"] for lb in c["over_zone"]]
    if tol:
        t = json.loads(tol)["programs"]["best"]
        row["tolerance"] = {"nominal_pass": t["verdict"]["nominal_pass"], "yield": t["monte_carlo"]["yield"],
                            "allocation": t.get("allocation", {}).get("statement", "")}
        quotes["tolerance"] = [lb["image_displacement_px"]["rms"] for lb in t["nominal_over_zone"]["lobes"]]
        row["tolerance_sparse_estimate"] = t["sensitivity"]["nominal"]["raw"]["image_displacement_px_rms"]
    rep = d / "out" / "report.json"
    if rep.exists():
        r = json.loads(rep.read_text())
        quotes["report"] = [lb["image_displacement_px"]["rms"] for lb in r["mirrors"]["best"]["lobes"]]
    row["image_displacement_px_rms"] = quotes
    return row


def markdown(rows: list[dict]) -> str:
    head = ("| design | winner r_top in/out mm | R10 m | all exit 0 | nominal | yield (target 95 %) | "
            "image disp. px RMS in/out: calib / tolerance / report |\n|---|---|---|---|---|---|---|")
    lines = [head]
    for r in rows:
        w = r.get("winner", {})
        rt = f"{w['inner']['r_top']:.2f} / {w['outer']['r_top']:.2f}" if w else "-"
        ok = "yes" if r["status"] and all(v == 0 for v in r["status"].values()) else \
            "no: " + ", ".join(k for k, v in r["status"].items() if v != 0)
        t = r.get("tolerance", r.get("check", {}))
        nominal = "PASS" if t.get("nominal_pass") else "FAIL"
        y = f"{100 * t['yield']:.1f} %" if "yield" in t else "-"
        q = r.get("image_displacement_px_rms", {})
        quote = " / ".join(f"{v[0]:.3f}, {v[1]:.3f}" for k, v in q.items()) if q else "-"
        lines.append(f"| {r['design']} | {rt} | {r.get('r10_m', float('nan')):.4f} | {ok} | {nominal} | {y} | {quote} |")
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--only", nargs="*", default=None, help="design names (default all)")
    ap.add_argument("--markdown", action="store_true")
    ap.add_argument("--keep", default=None, help="directory to keep the outputs in")
    a = ap.parse_args()
    names = a.only or list(DESIGNS)
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(a.keep) if a.keep else Path(tmp)
        rows = []
        for name in names:
            rows.append(one(name, DESIGNS[name][1], root))
            print(json.dumps(rows[-1]), file=sys.stderr, flush=True)
    print(markdown(rows) if a.markdown else json.dumps(rows, indent=1))


if __name__ == "__main__":
    main()
