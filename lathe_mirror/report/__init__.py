"""The report: lays out what the pipeline computed.

- report.py      report.json and the self-contained report.html (write_report, render_html)
- plots.py       the plots (matplotlib, Agg): plain data in, PNG bytes out
- template.html  the page
"""

from .report import dumps, render_html, write_report

__all__ = ["dumps", "render_html", "write_report"]
