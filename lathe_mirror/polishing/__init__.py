"""Polishing the turned mirror: Preston's law under a compliant lap that moves.

The paper ends (section 6) on "polish the surface as long as the process does not deform
the mirror profile". This module puts numbers on both halves of that sentence.

Model, per lobe, on a fine uniform grid of r (camera frame, mm; time in s):

    Preston's law (Preston 1927):   dh/dt = k_p * p * v           [mm/s = 1/Pa * Pa * mm/s]

Lap kinematics (`LapPlan`): the time-averaged k_p p0 v at each radius, the *removal rate*.

- `Lap.STROKE` (default): a round lap of radius a spins on its own axis at omega_l while the
  part spins at omega_p; its centre, at radius c from the part's axis, is stroked along r.
  Where the lap covers a point at radius r and azimuth phi (seen from the lap's centre), the
  relative speed is |(omega_p - omega_l) z x P + omega_l z x C|, so
  |v|^2 = (omega_p - omega_l)^2 r^2 + omega_l^2 c^2 + 2 (omega_p - omega_l) omega_l r c cos(phi);
  a synchronous lap (omega_l = omega_p) rubs every point under it at omega c. The lap covers
  the circle of radius r where cos(phi) >= (r^2 + c^2 - a^2) / (2 r c). Averaged over a part
  revolution, one stroke position c removes (k_p p0 / pi) * integral_0^phi_max |v| dphi
  (the tool influence function); the dwell-time profile D(c) (fractions of the time at each
  c, summing to 1) weights them. `Dwell.FLAT` solves for the non-negative D that makes the
  removal most nearly uniform over the lobe's clear aperture (a deterministic-polishing
  dwell plan); `Dwell.UNIFORM` strokes at constant speed. A lap whose centre passes within a
  of the axis polishes the vertex.
- `Lap.FIXED`: a lap covering the whole lobe, held still: v = omega_p r, nothing removed at
  the vertex (the first model; kept for comparison and its closed forms).

Each lobe is polished for the time given (the two one after the other on one machine).
The stroke stays clear of the step: on the recessed lobe the lap never crosses the wall
(its edge stops corner_mm short of it), on the lobe that stands proud at the step and at
the outer rim it may overhang by `overhang` of its radius (the edge pressure rise of an
overhanging lap is not modelled).

Pad (the smoothing): pressure of a compliant (Winkler) pad, stiffness p0 / l_c per unit
deflection, p = p0 * max(0, 1 + d / l_c); d = how far (along the normal) the surface stands
out toward the pad beyond the pad's own local surface. The pad's surface is the part's own
surface seen through a local cubic regression with Gaussian weights (sigma = w / 4, w the
pad size; cut at +-w): it follows every cubic exactly (the design's curvature is not
pressed), and its transfer for a ripple of angular wavenumber q is
H(q) = (1 + s^2 / 2) exp(-s^2 / 2), s = sigma q, which falls monotonically from 1 to 0: a
ripple decays as exp(-(1 - H) k_p p0 v t / l_c) at every wavelength, none grows. (A
Savitzky-Golay window, the first model's pad, has H up to 1.24 near 2.7 mm: ripple there
grew.) At the ends of a lobe's pad contact the regression uses the points on the part
only (no extrapolated end fit).

Edges: the band at the foot of the step on the recessed lobe (polish.corner_mm: the wall
and the tool's fillet in the inside corner) and the band at the top edge of the step on
the lobe that stands proud (polish.step_edge_mm: a nose larger than programmed rounds that
edge) are out of the pad's contact: they stay as machined and the pad's fit does not see
them.

h is removed along the surface normal, so the height z (measured from the camera; the
material lies at larger z) grows by dh * sqrt(1 + slope^2). Explicit Euler in time, with a
step that keeps the fastest mode (gain <= 1 per unit d / l_c) stable and monotone.

Pre-compensation (`compensated_mirror`): the removal on the smooth design is predictable,
rate(r) t sqrt(1 + slope^2) in z; the finishing program can target the design lowered by
it (a `CompensatedLobe` per lobe), so that the polished part lands on the design.
"""

from .compensate import CompensatedLobe, compensated_mirror
from .evolve import PadFit, polish, polish_series, polished_design, removal_depth
from .lap import LapPlan, LobeLap, clear_range, dwell_profile, influence, lap_plan, reach, recessed_lobe
from .params import FIRST_MODEL, PolishParams

__all__ = ["CompensatedLobe", "FIRST_MODEL", "LapPlan", "LobeLap", "PadFit", "PolishParams", "clear_range",
           "compensated_mirror", "dwell_profile", "influence", "lap_plan", "polish", "polish_series",
           "polished_design", "reach", "recessed_lobe", "removal_depth"]
