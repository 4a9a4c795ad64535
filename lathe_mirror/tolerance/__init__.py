"""Tolerance analysis: what the made mirror does to the image, and how often it passes.

One concern per module (after optiland's tolerancing package):
  radial       the aligned camera's radial image displacement on a 1-D set of radii
  spec         the tolerance spec (limits) and the parameter tolerances, from TOML
  surfaces     the as-machined surface of a program (issue 3's planner and nose envelope)
  perturb      one trial's surface and camera pose, evaluated vectorised over trials
  montecarlo   the seeded Monte Carlo and its yield
  sensitivity  each parameter at +/- its tolerance

This package imports nothing heavy at import time.
"""
