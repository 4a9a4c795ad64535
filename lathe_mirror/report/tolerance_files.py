"""The files `lathe-mirror tolerance` writes: tolerance.json and a histogram per program
in its directory, one CSV row per trial."""

from __future__ import annotations

from pathlib import Path

from ..export.files import write_bytes, write_text
from ..export.trials import trials_csv
from .plots import monte_carlo_histograms
from .report import dumps


def write_tolerance(directory: str | Path | None, csv: str | Path | None, out: dict, results: list) -> None:
    """DIR/tolerance.json and the histograms (directory), the per-trial CSV of every Monte
    Carlo run in `results` (csv); None: not written."""
    if directory:
        write_text(Path(directory) / "tolerance.json", dumps(out))
        write_histograms(Path(directory), out)
    if csv:
        write_text(csv, trials_csv(results), "--csv")


def write_histograms(directory: Path, out: dict) -> None:
    """DIR/monte_carlo_<program>.png: each program's trials against the limits (the
    report's Monte Carlo chart), with the yield and its 95 % interval in the title."""
    for name, t in out["programs"].items():
        mc = t["monte_carlo"]
        write_bytes(directory / f"monte_carlo_{name}.png",
                    monte_carlo_histograms(mc["per_trial"], mc["limits"], calibrated=mc["calibrated"],
                                           passed=mc["passed"],
                                           title=t["made_mirror"]["label"] if "measured_part" in out
                                           else f"{name} program"))
