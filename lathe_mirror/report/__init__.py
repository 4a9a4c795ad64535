"""The report: HTML + JSON of every figure (report.py), plots (figures.py), template.html."""
