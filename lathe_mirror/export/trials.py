"""The Monte Carlo's trials as CSV (`tolerance --csv`): one row per trial of each run,
every drawn parameter and figure, each number at its column's stated precision."""

from __future__ import annotations

import csv
import io
from typing import TYPE_CHECKING

from .numbers import csv_cell

if TYPE_CHECKING:
    from ..tolerance.montecarlo import MonteCarloResult


def trials_csv(results: list[tuple[str, MonteCarloResult]]) -> str:
    """CSV text (RFC 4180, "," separated, a header line): one row per trial of each
    (run name, result), every drawn parameter and figure; each number at its column's
    stated precision (export.numbers.csv_cell: 1e-9 mm, 1e-6 px, 1e-10 deg, ...; 12
    significant digits where a column has no unit), so a library's last bit cannot change
    the bytes."""
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    header_written = None
    for run, res in results:
        header, rows = res.csv_rows(run)
        if header_written is None:
            writer.writerow(header)
            header_written = header
        for row in rows:
            writer.writerow([csv_cell(name, v) for name, v in zip(header, row)])
    return buf.getvalue()
