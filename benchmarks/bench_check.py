"""`toolpath --check` on programs of growing length (issue 24): wall-clock time and peak
memory of a fresh process, against the number of moves, up to the stated limit
(shop.replay.MAX_MOVES). The program is the paper's, with its finishing operation's moves
repeated (air cuts after the first pass), so each move is simulated as a real one.

    .venv/bin/python benchmarks/bench_check.py [--moves 1000 5000 10000]
"""

from __future__ import annotations

import yardstick  # benchmarks/yardstick.py: the machine-speed reference, timed in every run
import argparse
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def program(base: list[str], moves: int) -> str:
    """The paper program with its motion blocks repeated until it has `moves` moves."""
    end = max(i for i, ln in enumerate(base) if "M30" in ln and not ln.startswith("("))
    start = next(i for i, ln in enumerate(base) if re.match(r"N\d+ G[0-3] ", ln))
    body = [ln for ln in base[start:end] if re.match(r"N\d+ G[0-3] ", ln)]
    head = base[:start]
    n = len([ln for ln in head if re.match(r"N\d+ G[0-3] ", ln)])
    out = list(head)
    while n < moves:
        take = body[: moves - n]
        out += take
        n += len(take)
    return "\n".join(out + base[end:]) + "\n"


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--moves", type=int, nargs="+", default=[1000, 5000, 10000])
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        subprocess.run([sys.executable, "-m", "lathe_mirror", "toolpath", "-o", "p.ngc"], cwd=d, check=True,
                       capture_output=True)
        base = (d / "p.ngc").read_text().splitlines()
        print(f"{'moves':>7s} {'bytes':>9s} {'seconds':>8s} {'peak MB':>8s}  load")
        for moves in args.moves:
            (d / "m.ngc").write_text(program(base, moves))
            t0 = time.perf_counter()
            proc = subprocess.run(["/usr/bin/time", "-f", "%M", sys.executable, "-m", "lathe_mirror", "toolpath",
                                   "--check", "m.ngc", "--json"], cwd=d, capture_output=True, text=True)
            seconds = time.perf_counter() - t0
            peak = int(proc.stderr.strip().splitlines()[-1]) / 1024
            status = "" if proc.returncode == 0 else f" exit {proc.returncode}"
            print(f"{moves:7d} {(d / 'm.ngc').stat().st_size:9d} {seconds:8.1f} {peak:8.0f}  "
                  f"{os.getloadavg()[0]:.1f}{status}")


if __name__ == "__main__":
    yardstick.start()
    main()
