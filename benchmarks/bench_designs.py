"""The design matrix of issue 20, full settings: each design through the whole chain as a
user runs it, in fresh processes, and the figures each command quotes for the same made
mirror and zone.

Per design: `optimize -o best.toml` (with its tolerance check), `run --config best.toml`,
`toolpath --check` on the arcs program `run` wrote, `calib`, `render`, `stereo`, `tolerance
--allocate`, `polish`; every exit status and CPU time, the winner, the nominal verdict and
the yield of the best program (optimize's check and tolerance's), and the image
displacement (RMS per lobe, px) over the used zone of the made mirror every command
describes by default (the best program as machined with the configured nose) as `calib`,
`render`, `tolerance` (its as_machined_over_zone) and the report quote it, with the
spread between them; beside it the figure of the part tolerance judges (polished for the
polishing curve's time). Each design is held by a shop class ([tolerance] shop, SHOPS):
the table gives the design's R10 (the nominal part's, its blur counted; the sharp
pixel-limited one beside it), the range its made parts deliver (the best program's
delivered R10, 5th percentile and median, tolerance.delivered), the yield at the class's
tolerances, and the cost of the tolerances optimize allocated into best.toml when the
class's fall short.

Run: .venv/bin/python benchmarks/bench_designs.py [--only NAME ...] [--markdown] [--keep DIR]
Prints a table (--markdown: the README's). Writes only into a temporary directory (or
--keep DIR).
"""

from __future__ import annotations

import yardstick  # benchmarks/yardstick.py: the machine-speed reference, timed in every run
import argparse
import json
import resource
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
                     "[tool]\nnose_radius = 0.8\n[machine]\nresolution = 0.0025\n"
                     "[tolerance.params]\nresolution_mm = 0.001\n"),  # below the 0.0025 mm lattice
    # docs/reference/guide.md's deep.toml, as written there (the envelope as rim_max_mm)
    "guide_deep": ("the guide's deep.toml (rim_max_mm = 138.6)",
                   "[optimize]\nrim_max_mm = 138.6\n[stock]\nlength = 50.0\n[cad]\nthickness = 45.0\n"),
    # issue 31's cameras of today's market
    "cam12mp": ("12 MP hobby camera: 6 mm lens at f/2.8, 1.55 um pixels (IMX477 class), nose 0.2 mm, "
                "0.001 mm lattice, 50 mm bar",
                "[camera]\nf = 6.0\nt_pixel = 0.00155\nsensor_px = [4056, 3040]\nf_number = 2.8\n"
                "[machine]\nresolution = 0.001\n[stock]\ndiameter = 50.0\n[cad]\nblank_diameter = 50.0\n"
                "[optimize]\nmax_diameter_mm = 46.0\nmax_depth_mm = 25.0\n"
                "[tolerance.params]\nresolution_mm = 0.0005\n"),
    "gs2mp": ("2 MP global shutter: 25 mm lens at f/4, 5 um pixels (1920 x 1080), nose 0.8 mm, 0.0025 mm "
              "lattice, 100 mm bar",
              "[camera]\nf = 25.0\nt_pixel = 0.005\nsensor_px = [1920, 1080]\nf_number = 4.0\n"
              "[tool]\nnose_radius = 0.8\n[machine]\nresolution = 0.0025\n[stock]\ndiameter = 100.0\n"
              "length = 80.0\n[cad]\nblank_diameter = 100.0\nthickness = 60.0\n"
              "[optimize]\nmax_diameter_mm = 96.0\nmax_depth_mm = 50.0\n"
              "[tolerance.params]\nresolution_mm = 0.001\n"),
}

#: The shop class each design's parts are made and assembled by ([tolerance] shop).
SHOPS = {"paper": "job", "deep": "job", "cam6": "job", "cam12": "job", "cam4": "precision",
         "paper_nose08": "job", "guide_deep": "job", "cam12mp": "hobby", "gs2mp": "job"}


#: processes for optimize and tolerance (--workers); 1 on a shared machine
WORKERS = ["--workers", "1"]


def cli(args: list[str], cwd: Path) -> tuple[int, str, str, float, float]:
    """(exit status, stdout, stderr, wall s, CPU s of the child: user + system)."""
    t0, r0 = time.perf_counter(), resource.getrusage(resource.RUSAGE_CHILDREN)
    p = subprocess.run([sys.executable, "-m", "lathe_mirror", *args], capture_output=True, text=True, cwd=cwd)
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)
    return p.returncode, p.stdout, p.stderr, time.perf_counter() - t0, cpu


def one(name: str, text: str, root: Path) -> dict:
    d = root / name
    d.mkdir(parents=True, exist_ok=True)
    shop = SHOPS.get(name, "custom")
    (d / "design.toml").write_text(f'[tolerance]\nshop = "{shop}"\n' + text)
    row: dict = {"design": name, "shop": shop, "status": {}, "seconds": {}, "cpu_seconds": {}}

    def step(label: str, args: list[str]) -> str | None:
        rc, out, err, s, cpu = cli(args, d)
        row["status"][label], row["seconds"][label], row["cpu_seconds"][label] = rc, round(s, 1), round(cpu, 1)
        if rc != 0:
            row.setdefault("errors", {})[label] = err.strip().splitlines()[-1:] if err.strip() else []
            return None
        return out

    out = step("optimize", ["optimize", "--config", "design.toml", "-o", "best.toml", "--json", "--no-progress",
                            *WORKERS])
    if out is None:
        return row
    opt = json.loads(out)
    row["winner"] = {lb["name"]: {k: lb[k] for k in ("r_top", "r_pixel", "alpha_deg")} for lb in opt["best"]["lobes"]}
    row["r10_m"] = opt["best"]["design_r10_m"]  # the nominal part's, its blur counted
    row["sharp_r10_m"] = opt["best"]["sharp_r10_m"]
    alloc = opt["check"].get("allocation")
    if alloc is not None:
        row["allocated"] = {"reached": alloc["reached"], "cost_ratio": alloc["cost_ratio"], "yield": alloc["yield"],
                            "statement": alloc["statement"]}
    row["check"] = {k: opt["check"][k] for k in ("nominal_pass", "yield", "target_yield")} | (
        {"why": opt["check"]["why"]} if "why" in opt["check"] else {}) | {
        "failing": [k for k, v in opt["check"]["nominal"].items() if not v["pass"]]}
    row["warnings"] = len(opt["warnings"])
    step("run", ["run", "--config", "best.toml", "-o", "out", "--no-render", "--no-progress"])
    step("toolpath --check", ["toolpath", "--config", "best.toml", "--check", "out/gcode/mirror_arcs.ngc"])
    cal = step("calib", ["calib", "--config", "best.toml", "--surface", "best", "-o", "calib", "--json",
                         "--no-progress"])
    ren = step("render", ["render", "--config", "best.toml", "--json", "--no-progress", "--supersample", "1"])
    step("stereo", ["stereo", "--config", "best.toml", "--json", "--no-progress"])
    tol = step("tolerance --allocate", ["tolerance", "--config", "best.toml", "--allocate", "--json",
                                        "--no-progress", *WORKERS])
    step("polish", ["polish", "--config", "best.toml", "--json", "--no-progress"])
    quotes = {}
    if cal:
        c = json.loads(cal)["made"][0]
        quotes["calib"] = [lb["image_displacement_px"]["rms"] for lb in c["over_zone"]]
    if ren:
        quotes["render"] = [lb["image_displacement_px"]["rms"] for lb in json.loads(ren)["lobes"]]
    if tol:
        t = json.loads(tol)["programs"]["best"]
        row["delivered_r10_m"] = t["monte_carlo"].get("delivered_r10_m")
        row["yield_wilson95"] = t["monte_carlo"]["yield_wilson95"]
        row["tolerance"] = {"nominal_pass": t["verdict"]["nominal_pass"], "yield": t["monte_carlo"]["yield"],
                            "allocation": t.get("allocation", {}).get("statement", ""),
                            "judged": t["made_mirror"]["label"],
                            "failing": [k for k, c in t["verdict"]["checks"].items() if not c["pass"]]}
        # the made mirror the other commands describe (as machined), and the judged (polished) part
        quotes["tolerance"] = [lb["image_displacement_px"]["rms"] for lb in t["as_machined_over_zone"]["lobes"]]
        row["tolerance_judged_px_rms"] = [lb["image_displacement_px"]["rms"] for lb in t["nominal_over_zone"]["lobes"]]
        row["tolerance_sparse_estimate"] = t["sensitivity"]["nominal"]["raw"]["image_displacement_px_rms"]
    rep = d / "out" / "report.json"
    if rep.exists():
        r = json.loads(rep.read_text())
        quotes["report"] = [lb["image_displacement_px"]["rms"] for lb in r["mirrors"]["best"]["lobes"]]
    row["image_displacement_px_rms"] = quotes
    return row


def markdown(rows: list[dict]) -> str:
    head = ("| design | shop | winner r_top in/out mm | design R10 m | delivered R10 p5 / median m | all exit 0 | "
            "nominal: optimize / tolerance | "
            "yield: optimize / tolerance (target 95 %; Wilson low) | allocated (cost x) | image disp. px RMS in, out (as machined): calib / render / "
            "tolerance / report | spread | judged (polished) px RMS in, out | CPU s | CPU in Y |\n"
            "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    lines = [head]
    for r in rows:
        w = r.get("winner", {})
        rt = f"{w['inner']['r_top']:.2f} / {w['outer']['r_top']:.2f}" if w else "-"
        ok = "yes" if r["status"] and all(v == 0 for v in r["status"].values()) else \
            "no: " + ", ".join(k for k, v in r["status"].items() if v != 0)
        c, t = r.get("check", {}), r.get("tolerance", {})

        def verdict(d: dict) -> str:
            return "-" if "nominal_pass" not in d else ("PASS" if d["nominal_pass"] else
                                                         "FAIL " + ", ".join(d.get("failing", [])))

        def yld(d: dict) -> str:
            return f"{100 * d['yield']:.1f} %" if "yield" in d else "-"

        q = r.get("image_displacement_px_rms", {})
        quote = " / ".join(f"{v[0]:.3f}, {v[1]:.3f}" for v in q.values()) if q else "-"
        spread = "-"
        if len(q) > 1:
            vals = list(q.values())
            spread = " , ".join(f"{100 * (max(v[k] for v in vals) / min(v[k] for v in vals) - 1):.2f} %"
                                for k in (0, 1))
        judged = r.get("tolerance_judged_px_rms")
        judged = f"{judged[0]:.3f}, {judged[1]:.3f}" if judged else "-"
        cpu = sum(r.get("cpu_seconds", {}).values())
        dr = r.get("delivered_r10_m") or {}
        dl = f"{dr['p5']:.4f} / {dr['median']:.4f}" if dr else "-"
        lo = f" ({100 * r['yield_wilson95'][0]:.1f} %)" if "yield_wilson95" in r else ""
        a = r.get("allocated")
        al = "-" if a is None else (f"{a['cost_ratio']:.3g}" if a["reached"] else "not reached")
        lines.append(f"| {r['design']} | {r.get('shop', '-')} | {rt} | {r.get('r10_m', float('nan')):.4f} | {dl} | "
                     f"{ok} | {verdict(c)} / {verdict(t)} | {yld(c)} / {yld(t)}{lo} | {al} | {quote} | {spread} | "
                     f"{judged} | {cpu:.0f} | {yardstick.multiple(cpu):.1f} |")
    return "\n".join(lines)


def readme(rows: list[dict]) -> str:
    """The README's table: design R10 (the nominal part's, its blur counted) and the sharp
    one, the delivered p5 / median and p5's shortfall against the design's (the 10 %
    criterion), the yield with its Wilson 95 % lower bound, the allocated cost, CPU."""
    lines = ["| design | shop | design R10 m (sharp) | delivered R10 p5 / median m | p5 vs design | "
             "yield (Wilson low) | allocated (cost x) | all exit 0 | CPU s |",
             "|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        dr = r.get("delivered_r10_m") or {}
        design = r.get("r10_m", float("nan"))
        ok = "yes" if r["status"] and all(v == 0 for v in r["status"].values()) else \
            "no: " + ", ".join(k for k, v in r["status"].items() if v != 0)
        t = r.get("tolerance", {})
        y = (f"{100 * t['yield']:.1f} % ({100 * r['yield_wilson95'][0]:.1f} %)"
             if "yield" in t and "yield_wilson95" in r else "-")
        a = r.get("allocated")
        al = "-" if a is None else (f"{a['cost_ratio']:.3g}" if a["reached"] else "not reached: " + a["statement"])
        cpu = sum(r.get("cpu_seconds", {}).values())
        lines.append(f"| {r['design']} | {r.get('shop', '-')} | {design:.4f} ({r.get('sharp_r10_m', float('nan')):.4f}) | "
                     + (f"{dr['p5']:.4f} / {dr['median']:.4f} | {100 * (dr['p5'] / dr['design'] - 1):+.1f} % | "
                        if dr else "- | - | ")
                     + f"{y} | {al} | {ok} | {cpu:.0f} |")
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--only", nargs="*", default=None, help="design names (default all)")
    ap.add_argument("--markdown", action="store_true")
    ap.add_argument("--readme", action="store_true", help="the README's short table (design R10, delivered, yield)")
    ap.add_argument("--keep", default=None, help="directory to keep the outputs in")
    a = ap.parse_args()
    names = a.only or list(DESIGNS)
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(a.keep) if a.keep else Path(tmp)
        rows = []
        for name in names:
            rows.append(one(name, DESIGNS[name][1], root))
            print(json.dumps(rows[-1]), file=sys.stderr, flush=True)
    for r in rows:  # the times in yardsticks (benchmarks/yardstick.py), beside the seconds
        r["in_yardsticks"] = {k: {st: yardstick.multiple(v) for st, v in r[k].items()}
                              for k in ("seconds", "cpu_seconds")}
    if a.readme:
        print(readme(rows))
    print(markdown(rows) if a.markdown else json.dumps(rows, indent=1))


if __name__ == "__main__":
    yardstick.start(json_output=True)
    main()
