"""Tolerance analysis: what the made mirror does to what the robot sees, how often it
passes, and what the shop must tighten.

One concern per module (after optiland's tolerancing package):
  spec         the tolerance spec (limits), the parameters' tolerances and costs, from TOML
  surfaces     each trial's part: the program cut at each lattice phase and with each nose
               drawn, polished (the pipeline's builder hands it machine_at)
  perturb      one trial's surface and camera / seat pose, traced vectorised over trials:
               image, ray and viewpoint figures, stereo figures, raw and calibrated
  calibration  what a user's calibration removes (the camera's rotation, a smooth radial
               map per lobe), fitted per trial
  montecarlo   the seeded Monte Carlo, its yield and the per-trial CSV
  sensitivity  each parameter alone: the -/+ tolerance table and the response scans
  allocation   inverse sensitivity and the least-cost tolerances for a target yield
  stats        Wilson's interval of a yield
  setting      what a tool-setting error costs on the exact design
  runs         the analysis of each configured program on the machining job
  analysis     the analysis as `lathe-mirror tolerance` runs it: every check, then the run

This package imports nothing heavy at import time.
"""
