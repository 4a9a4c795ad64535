"""The report: lays out what the pipeline computed.

- report.py      report.json and the self-contained report.html (write_report, render_html)
- plots.py       the plots (matplotlib, Agg): plain data in, PNG bytes out
- template.html  the page
- render_figures.py, stereo_figures.py, tolerance_files.py: what `render`, `stereo` and
  `tolerance` compute and write beside the report
"""

from .report import dumps, render_html, write_report

__all__ = ["dumps", "render_html", "write_report"]
