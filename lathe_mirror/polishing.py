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

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from .design import Lobe, Mirror
from .enums import Dwell, Lap, PolishObjective
from .errors import InputError
from .finish import DEFAULT_PROCESSES, Process
from .profile import LobeSamples, Profile, SampledProfile

#: Time step as a fraction of the fastest e-folding time of a short error (see _evolve).
ACCURACY = 0.2
#: Most time steps one polishing run may take (~1 ms each on the paper mirror's
#: 0.005 mm grid, both lobes).
MAX_STEPS = 20_000
#: Radial step (mm) of the tabulated removal rate (the tool influence functions are smooth).
RATE_STEP_MM = 0.05
#: Spacing (mm) of the lap centres over which a continuous stroke's removal is integrated.
STROKE_STEP_MM = 0.02
#: Weight of the dwell density's second differences against the flatness of the removal.
SMOOTHING = 0.05
#: Gauss-Legendre nodes of the azimuth integral of the relative speed.
AZIMUTH_NODES = 24
#: A point this many compliances l_c below the pad's surface is bridged: left out of the fit.
BRIDGE = 1.0
#: Steps between renewals of the set of points the pad's surface rests on.
CONTACT_EVERY = 8
#: The pad's Gaussian weight: sigma = pad_size_mm / PAD_SIGMAS, cut at +-pad_size_mm.
PAD_SIGMAS = 4.0
#: Knot spacing (mm) of the spline the pre-compensation allowance is.
COMPENSATION_KNOT_MM = 0.25
#: Corrections of the pre-compensation allowance after the first prediction (each costs one
#: polishing run of the smooth target: ~0.2 s on the paper mirror).
COMPENSATION_ITERATIONS = 2
#: The first polishing model's process (a lap held still over the whole lobe, the part at
#: 300 rev/min, 20 kPa), for comparison: dataclasses.replace(params, **FIRST_MODEL).
FIRST_MODEL = {"lap": Lap.FIXED, "spindle_rpm": 300.0, "pressure_kpa": 20.0, "step_edge_mm": 0.0}


@dataclass(frozen=True)
class PolishParams:
    """Polishing process parameters (edge units; converted inside).

    Preston and pad: preston_coefficient k_p (1/Pa); pressure_kpa p0, mean pad pressure
    (kPa); pad_size_mm w, the length over which the pad conforms (mm: a longer pad smooths
    longer wavelengths); compliance_mm l_c = p0 / stiffness, the pad deflection that doubles
    the local pressure (mm; smaller: a stiffer pad, faster smoothing).
    Kinematics: spindle_rpm, the part (rev/min); lap (Lap); lap_radius_mm a; lap_rpm, the
    lap on its own axis (rev/min; = spindle_rpm: synchronous, speed omega c everywhere under
    the lap; negative: against the part, the default, whose flat dwell plan is the most
    uniform on the paper mirror);
    overhang, the fraction of a past a free edge the stroke may carry the lap; dwell (Dwell);
    stroke_points, the nodes of the stroke's piecewise-linear dwell density per lobe.
    Time: time_s, the time `lathe-mirror polish` reports and the pre-compensation plans for
    (s); curve_max_s, curve_points: the polishing curve explores 0 .. curve_max_s (s).
    Grid: grid_step_mm, the evolution's radial grid (mm; finer costs time linearly; must
    resolve the lattice steps).
    Edges: corner_mm, the band at the foot of the step on the recessed lobe; step_edge_mm,
    the band at the step's top edge on the proud lobe (both out of the pad's contact, mm);
    clear_edge_mm, the band at each edge of a lobe (the step and the rim) left out of every
    slope and form figure (the clear aperture, mm).
    PolishObjective: objective (PolishObjective), the figure that chooses the time; objective_range_m,
    the range of the stereo objective (m); objective_tolerance, the chosen time is the
    earliest whose objective is within this fraction of the explored minimum;
    calibration_knot_px, the knot spacing (px) of the per-lobe radial spline calibration
    absorbs (optics.calibrated_stereo);
    form_degree, the degree of the Legendre fit in r that defines "form" per lobe.
    Finish: wavelength_nm (nm), the light of the scatter figures; processes, the presets.
    precompensate: plan the finishing programs on the design lowered by the removal of
    time_s (the G-code then carries it).
    """

    preston_coefficient: float = 4e-13
    pressure_kpa: float = 30.0
    pad_size_mm: float = 6.0
    compliance_mm: float = 0.004
    spindle_rpm: float = 3000.0
    lap: Lap = Lap.ROTATE
    lap_radius_mm: float = 8.0
    lap_rpm: float = 3000.0
    stroke_mm: float = 0.75
    overhang: float = 0.3
    dwell: Dwell = Dwell.UNIFORM
    stroke_points: int = 16
    time_s: float = 26400.0
    grid_step_mm: float = 0.005
    curve_max_s: float = 28800.0
    curve_points: int = 25
    form_degree: int = 4
    corner_mm: float = 0.5
    step_edge_mm: float = 0.0
    clear_edge_mm: float = 0.5
    objective: PolishObjective = PolishObjective.STEREO
    objective_range_m: float = 2.0
    objective_tolerance: float = 0.05
    calibration_knot_px: float = 24.0
    wavelength_nm: float = 550.0
    precompensate: bool = False
    processes: tuple[Process, ...] = field(default=DEFAULT_PROCESSES)

    def __post_init__(self) -> None:
        for key in ("preston_coefficient", "pressure_kpa", "pad_size_mm", "compliance_mm",
                    "spindle_rpm", "grid_step_mm", "curve_max_s", "lap_radius_mm", "stroke_mm", "wavelength_nm",
                    "objective_range_m"):
            v = getattr(self, key)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise InputError(f"polish.{key} = {v!r} must be a finite number > 0")
        if not (math.isfinite(self.lap_rpm) and abs(self.lap_rpm) <= 1e5):
            raise InputError(f"polish.lap_rpm = {self.lap_rpm!r} must be a finite number of rev/min "
                             "(negative: against the part), |lap_rpm| <= 100000")
        if not (math.isfinite(self.overhang) and 0 <= self.overhang <= 0.5):
            raise InputError(f"polish.overhang = {self.overhang!r} must be 0 .. 0.5 (of the lap's radius)")
        if not 2 <= self.stroke_points <= 200:
            raise InputError(f"polish.stroke_points = {self.stroke_points} must be 2 .. 200")
        for key in ("corner_mm", "step_edge_mm", "clear_edge_mm"):
            v = getattr(self, key)
            if not (math.isfinite(v) and 0 <= v <= 5):
                raise InputError(f"polish.{key} = {v!r} must be 0 .. 5 mm")
        if not (math.isfinite(self.time_s) and self.time_s >= 0):
            raise InputError(f"polish.time_s = {self.time_s!r} must be a finite number >= 0 s")
        # Each point of the curve keeps its polished surface (~0.1 MB on the default grid).
        if not 3 <= self.curve_points <= 1000:
            raise InputError(f"polish.curve_points = {self.curve_points} must be 3 .. 1000")
        if self.grid_step_mm < 0.0005:
            raise InputError(f"polish.grid_step_mm = {self.grid_step_mm:g} mm must be at least 0.0005 mm "
                             f"(70 000 points over 35 mm; the cost grows linearly as it shrinks)")
        if not 0 <= self.form_degree <= 12:
            raise InputError(f"polish.form_degree = {self.form_degree} must be 0..12")
        if not (math.isfinite(self.calibration_knot_px) and 4 <= self.calibration_knot_px <= 500):
            raise InputError(f"polish.calibration_knot_px = {self.calibration_knot_px!r} must be 4 .. 500 px")
        if not (math.isfinite(self.objective_tolerance) and 0 <= self.objective_tolerance <= 1):
            raise InputError(f"polish.objective_tolerance = {self.objective_tolerance!r} must be 0 .. 1")
        if not 0.2 <= self.objective_range_m <= 100:
            raise InputError(f"polish.objective_range_m = {self.objective_range_m!r} must be 0.2 .. 100 m")
        if self.grid_step_mm * 8 > self.pad_size_mm:
            raise InputError(
                f"polish.grid_step_mm = {self.grid_step_mm:g} mm must be at most pad_size_mm / 8 "
                f"= {self.pad_size_mm / 8:g} mm (the pad's fit needs points to fit)")
        names = [p.name for p in self.processes]
        if len(set(names)) != len(names):
            raise InputError(f"polish.process: names must differ, got {names}")

    @property
    def pressure_pa(self) -> float:
        return self.pressure_kpa * 1e3

    @property
    def omega(self) -> float:
        """Spindle (part) speed, rad/s."""
        return self.spindle_rpm * 2.0 * math.pi / 60.0

    @property
    def omega_lap(self) -> float:
        """Lap speed on its own axis, rad/s (same sense as the part when positive)."""
        return self.lap_rpm * 2.0 * math.pi / 60.0

    @property
    def preston_rate(self) -> float:
        """k_p p0 (1/s per mm/s of speed): the removal rate (mm/s) per mm/s of rubbing."""
        return self.preston_coefficient * self.pressure_pa

    @property
    def wavelength_mm(self) -> float:
        return self.wavelength_nm * 1e-6

    def process(self, name: str) -> Process:
        """The process preset called name."""
        for p in self.processes:
            if p.name == name:
                return p
        raise KeyError(name)

    def max_speed(self, r_max_mm: float) -> float:
        """An upper bound (mm/s) of the rubbing speed anywhere on a part of outer radius
        r_max_mm (mm): omega_p r for the fixed lap; |omega_p - omega_l| r + |omega_l| c with
        r <= r_max and c <= stroke_mm (ROTATE) or r_max (STROKE)."""
        if self.lap is Lap.FIXED:
            return self.omega * r_max_mm
        reach_c = min(self.stroke_mm, r_max_mm) if self.lap is Lap.ROTATE else r_max_mm
        return abs(self.omega - self.omega_lap) * r_max_mm + abs(self.omega_lap) * reach_c

    def time_steps(self, r_max_mm: float, time_s: float) -> float:
        """Explicit time steps (see _evolve), at most, to polish a part of outer radius
        r_max_mm (mm) for time_s (s): the step is ACCURACY l_c over the fastest removal rate
        (bounded by max_speed)."""
        with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
            rate = self.preston_rate * self.max_speed(r_max_mm)
            n = time_s * rate / (ACCURACY * self.compliance_mm)
        return float(n) if math.isfinite(n) else math.inf

    def check_time(self, r_max_mm: float, time_s: float) -> None:
        """InputError when polishing for time_s (s) could take more than MAX_STEPS steps."""
        n = self.time_steps(r_max_mm, time_s)
        if n > MAX_STEPS:
            raise InputError(
                f"polishing for {time_s:g} s (polish.time_s / polish.curve_max_s) would take {n:.3g} time "
                f"steps, at most {MAX_STEPS} allowed (the removal rate k_p p0 v, v up to "
                f"{self.max_speed(r_max_mm):.4g} mm/s on r <= {r_max_mm:g} mm, against a compliance of "
                f"{self.compliance_mm:g} mm sets the step); shorten the time, or lower "
                f"polish.preston_coefficient, pressure_kpa, spindle_rpm or lap_rpm, or raise compliance_mm")

    @property
    def curve_times(self) -> np.ndarray:
        """Times (s) of the polishing curve: 0 .. curve_max_s, evenly spaced."""
        return np.linspace(0.0, self.curve_max_s, self.curve_points)


# --------------------------------------------------------------------------------------
# Lap kinematics


@dataclass(frozen=True)
class LobeLap:
    """How the lap works one lobe. Radii in mm, rates in mm/s.

    reach: (lo, hi) radii of the lobe the pad touches (the bands at the step excluded).
    radius_mm: the lap's radius (0: the fixed full lap). centres_mm, dwell: the nodes of the
    stroke (radius of the lap's centre) and the dwell density at each, normalised to sum 1
    (the density is linear between nodes: the time spent per mm of stroke).
    r_tab, rate_tab: the removal rate k_p p0 <v> on a smooth surface at radius r_tab.
    """

    lobe: int
    reach: tuple[float, float]
    radius_mm: float
    centres_mm: np.ndarray
    dwell: np.ndarray
    r_tab: np.ndarray
    rate_tab: np.ndarray

    def rate(self, r: np.ndarray) -> np.ndarray:
        """Removal rate (mm/s) at radius r (mm) of this lobe, on a smooth surface at p0;
        zero outside the pad's reach."""
        r = np.asarray(r, dtype=float)
        out = np.interp(r, self.r_tab, self.rate_tab)
        lo, hi = self.reach
        return np.where((r >= lo - 1e-12) & (r <= hi + 1e-12), out, 0.0)

    def to_dict(self) -> dict:
        """JSON-ready: the reach, the lap, the dwell-time profile and the removal rate (um/h)."""
        step = max(1, self.r_tab.size // 100)
        return {"reach_mm": list(self.reach), "lap_radius_mm": self.radius_mm,
                "stroke_centres_mm": [float(c) for c in self.centres_mm],
                "dwell_weight": [float(d) for d in self.dwell],
                "r_mm": [float(r) for r in self.r_tab[::step]],
                "removal_rate_um_per_h": [float(v) * 3.6e6 for v in self.rate_tab[::step]]}


@dataclass(frozen=True)
class LapPlan:
    """The lap's plan for both lobes (inner first): LobeLap each."""

    lobes: tuple[LobeLap, LobeLap]

    def rate(self, k: int, r: np.ndarray) -> np.ndarray:
        """Removal rate (mm/s) of lobe k at radius r (mm) on a smooth surface."""
        return self.lobes[k].rate(r)

    def to_dict(self) -> dict:
        return {"lobes": [lb.to_dict() for lb in self.lobes]}


def lap_plan(frame: Profile | Mirror, params: PolishParams) -> LapPlan:
    """The lap's stroke, dwell-time profile and removal rate for each lobe of a part.

    frame: the part (any Profile, or the designed Mirror): its junction, rim and which lobe
    is recessed at the step set the lap's reach. Cached on the frame's geometry and the
    parameters (the Monte Carlo polishes dozens of parts of one design).
    """
    recessed = recessed_lobe(frame)
    return _lap_plan(float(frame.r_junction), float(frame.r_max), recessed, params)


@functools.lru_cache(maxsize=16)
def _lap_plan(rj: float, r_max: float, recessed: int, params: PolishParams) -> LapPlan:
    lobes = []
    for k in (0, 1):
        band = params.corner_mm if recessed == k else params.step_edge_mm
        lo, hi = (0.0, max(rj - band, 0.0)) if k == 0 else (min(rj + band, r_max), r_max)
        # Where each end of the reach is: the axis, the wall of the recessed lobe's pocket,
        # or a free edge (the proud lobe's step edge, the rim) the lap may overhang.
        ends = ("axis" if k == 0 else ("wall" if recessed == 1 else "free"),
                ("wall" if recessed == 0 else "free") if k == 0 else "free")
        r_tab = np.linspace(lo, hi, max(int(math.ceil((hi - lo) / RATE_STEP_MM)) + 1, 8))
        if params.lap is Lap.FIXED or hi <= lo:
            rate = params.preston_rate * params.omega * r_tab
            lobes.append(LobeLap(k, (lo, hi), 0.0, np.zeros(1), np.ones(1), r_tab, rate))
            continue
        if params.lap is Lap.ROTATE:
            # A full-size lap: in the recessed lobe's pocket as large as the pocket allows
            # at the stroke's end; on a lobe free at its outer edge, large enough to cover
            # it from any stroke position. Its rim lies beyond the lobe's reach (or, in the
            # pocket, where the stroke carries it), so the removal inside is smooth.
            stroke = min(params.stroke_mm, 0.5 * hi)
            a = hi - stroke if ends[1] == "wall" else hi + stroke
            c_lo, c_hi = 0.0, stroke
        else:
            # In the recessed inner lobe's pocket the lap cannot be larger than the pocket.
            a = min(params.lap_radius_mm, hi) if ends[0] == "axis" else params.lap_radius_mm
            # Across the axis the stroke starts a quarter lap out: a lap centred on the axis
            # has its whole rim at r = a, and dwelling there cuts a groove (the removal's
            # slope has a logarithmic singularity at r = a when the dwell density is finite
            # at c = 0).
            c_lo = {"axis": 0.25 * a, "wall": lo + a, "free": lo + a * (1.0 - params.overhang)}[ends[0]]
            c_hi = {"wall": hi - a, "free": hi - a * (1.0 - params.overhang)}[ends[1]]
        if c_hi <= c_lo:  # the lobe is narrower than the lap's stroke needs: one position, centred
            c = np.array([max(0.5 * (c_lo + c_hi), 0.0)])
            tif = params.preston_rate * influence(r_tab, c, a, params.omega, params.omega_lap)
            lobes.append(LobeLap(k, (lo, hi), a, c, np.ones(1), r_tab, tif[:, 0]))
            continue
        # The stroke is continuous: the dwell density is piecewise linear between
        # stroke_points nodes, and the removal integrates the influence functions over a
        # fine grid of centres (discrete dwell positions would each leave the sqrt cusp of a
        # lap's rim in the removal, ripples the pad then holds at l_c times their depth).
        nodes = np.linspace(c_lo, c_hi, params.stroke_points)
        fine = np.linspace(c_lo, c_hi, max(int(math.ceil((c_hi - c_lo) / STROKE_STEP_MM)) + 1, 2))
        hat = _hat_matrix(fine, nodes)
        tif = params.preston_rate * influence(r_tab, fine, a, params.omega, params.omega_lap)
        basis = tif @ hat / fine.size  # removal rate per unit node weight (nodes' densities sum ~1)
        # Flatness is asked over the clear aperture, less a quarter of the lap at a wall: a lap
        # that cannot overhang the wall covers the last millimetres only with its rim.
        clo, chi = clear_range(_Frame(rj, r_max), k, params.clear_edge_mm, (lo, hi))
        clo += 0.25 * a if ends[0] == "wall" else 0.0
        chi -= 0.25 * a if ends[1] == "wall" else 0.0
        weights = dwell_profile(basis, r_tab, params, clear=(clo, max(chi, clo)))
        density = hat @ weights
        fractions = density / density.sum()
        dwell = weights / weights.sum()
        lobes.append(LobeLap(k, (lo, hi), a, nodes, dwell, r_tab, tif @ fractions))
    return LapPlan((lobes[0], lobes[1]))


@dataclass(frozen=True)
class _Frame:
    """The radii clear_range needs (mm)."""

    r_junction: float
    r_max: float


def _hat_matrix(x: np.ndarray, nodes: np.ndarray) -> np.ndarray:
    """Linear-interpolation weights of each x on the nodes (len(x), len(nodes))."""
    eye = np.eye(nodes.size)
    return np.stack([np.interp(x, nodes, eye[j]) for j in range(nodes.size)], axis=1)


def influence(r: np.ndarray, centres: np.ndarray, lap_radius: float, omega_part: float,
              omega_lap: float) -> np.ndarray:
    """Mean rubbing speed (mm/s) at radii r (mm) of a lap of radius lap_radius (mm) centred at
    each of centres (mm from the part's axis), averaged over a part revolution (0 where the
    lap does not reach): (1 / pi) integral over the covered azimuths 0..phi_max of |v|.
    Shape (len(r), len(centres)). Speeds in rad/s."""
    r = np.asarray(r, float)[:, None]
    c = np.asarray(centres, float)[None, :]
    dw = omega_part - omega_lap
    with np.errstate(divide="ignore", invalid="ignore"):
        kappa = (r * r + c * c - lap_radius**2) / (2.0 * r * c)
    # r = 0 or c = 0: the whole circle is in or out.
    inside = np.hypot(r, c) <= lap_radius
    kappa = np.where((r == 0) | (c == 0), np.where(inside, -1.0, 2.0), kappa)
    phi_max = np.arccos(np.clip(kappa, -1.0, 1.0))
    x, w = np.polynomial.legendre.leggauss(AZIMUTH_NODES)
    phi = 0.5 * phi_max[..., None] * (x + 1.0)
    v2 = (dw * r[..., None]) ** 2 + (omega_lap * c[..., None]) ** 2 \
        + 2.0 * dw * omega_lap * r[..., None] * c[..., None] * np.cos(phi)
    integral = 0.5 * phi_max * np.sum(np.sqrt(np.maximum(v2, 0.0)) * w, axis=-1)
    return integral / math.pi


def dwell_profile(tif: np.ndarray, r: np.ndarray, params: PolishParams, *, clear: tuple[float, float]) -> np.ndarray:
    """Fractions of the time (sum 1) the lap's centre spends at each stroke position.

    UNIFORM: equal. FLAT: non-negative least squares for a uniform removal over the clear
    range of radii, with a light second-difference penalty so the stroke's speed varies
    smoothly (an optician's dwell plan)."""
    n = tif.shape[1]
    if params.dwell is Dwell.UNIFORM or n == 1:
        return np.full(n, 1.0 / n)
    from scipy.optimize import nnls

    m = (r >= clear[0] - 1e-12) & (r <= clear[1] + 1e-12)
    a = tif[m]
    scale = float(np.median(a[a > 0])) if np.any(a > 0) else 1.0
    a = a / scale
    # Second differences of the dwell (smooth stroke), weighted lightly against the fit.
    smooth = SMOOTHING * math.sqrt(m.sum() / max(n, 1)) * (np.eye(n)[2:] - 2 * np.eye(n)[1:-1] + np.eye(n)[:-2]) \
        if n > 2 else np.zeros((0, n))
    dwell, _ = nnls(np.vstack([a, smooth]), np.concatenate([np.ones(m.sum()), np.zeros(smooth.shape[0])]),
                    maxiter=50 * n)
    if dwell.sum() <= 0:
        return np.full(n, 1.0 / n)
    return dwell / dwell.sum()


def recessed_lobe(frame: Profile | Mirror) -> int:
    """0 if the inner lobe is recessed at the junction (the step's inside corner is on its
    edge), 1 if the outer lobe is."""
    rj = frame.r_junction
    if isinstance(frame, Mirror):
        return 0 if frame.recessed == "inner" else 1
    z_in = float(frame.z(np.array([rj]))[0])
    z_out = float(frame.z(np.array([np.nextafter(rj, np.inf)]))[0])
    return 0 if z_in > z_out else 1


def reach(frame: Profile | Mirror, k: int, params: PolishParams) -> tuple[float, float]:
    """Radii (mm) of lobe k the pad touches: the lobe less corner_mm at the foot of the step
    (the recessed lobe) or step_edge_mm at its top edge (the proud lobe)."""
    rj, r_max = frame.r_junction, frame.r_max
    band = params.corner_mm if recessed_lobe(frame) == k else params.step_edge_mm
    return (0.0, max(rj - band, 0.0)) if k == 0 else (min(rj + band, r_max), r_max)


def clear_range(frame: Profile | Mirror, k: int, edge_mm: float, within: tuple[float, float] | None = None
                ) -> tuple[float, float]:
    """Radii (mm) of lobe k inside its edges by edge_mm (the step and the rim; the axis is
    no edge), optionally within `within`."""
    lo, hi = (0.0, frame.r_junction) if k == 0 else (frame.r_junction, frame.r_max)
    lo = lo if k == 0 else lo + edge_mm
    hi = hi - edge_mm
    if within is not None:
        lo, hi = max(lo, within[0]), min(hi, within[1])
    return lo, max(hi, lo)


# --------------------------------------------------------------------------------------
# The evolution


def polish(profile: Profile, params: PolishParams, time_s: float | None = None) -> SampledProfile:
    """The surface after polishing `profile` for time_s (s per lobe; default params.time_s)."""
    t = params.time_s if time_s is None else time_s
    return polish_series(profile, params, [t])[0]


def polish_series(profile: Profile, params: PolishParams, times_s: Sequence[float] | np.ndarray, *,
                  plan: LapPlan | None = None) -> list[SampledProfile]:
    """The polished surface at each of times_s (s), from one evolution (snapshots).

    Each lobe evolves on its own grid over the pad's reach (`reach`); the bands at the step
    outside it stay as machined. plan: the lap's plan (default lap_plan(profile, params)).
    """
    times = np.asarray(times_s, dtype=float)
    if times.ndim != 1 or times.size == 0 or not np.all(np.isfinite(times)) or np.any(times < 0):
        raise InputError(f"polishing times {times_s!r} must be finite numbers >= 0 s")
    params.check_time(profile.r_max, float(times.max()))
    plan = lap_plan(profile, params) if plan is None else plan
    order = np.argsort(times, kind="stable")
    per_lobe = []
    for k in (0, 1):
        r = _lobe_grid(profile, k, params.grid_step_mm)
        z0 = np.asarray(profile.z(r), dtype=float)
        lo, hi = plan.lobes[k].reach
        touch = (r >= lo - 1e-12) & (r <= hi + 1e-12)
        if touch.sum() < 16:
            per_lobe.append((r, [z0.copy() for _ in times]))
            continue
        snaps = _evolve(r[touch], z0[touch], plan.rate(k, r[touch]), params, times[order])
        full = []
        for zs in snaps:
            z = z0.copy()
            z[touch] = zs
            full.append(z)
        per_lobe.append((r, full))
    out: list[SampledProfile | None] = [None] * times.size
    for j, i in enumerate(order):
        ri, zi = per_lobe[0][0], per_lobe[0][1][j]
        ro, zo = per_lobe[1][0], per_lobe[1][1][j]
        out[i] = SampledProfile(LobeSamples(ri, zi), LobeSamples(ro, zo), r_junction=profile.r_junction,
                                r_max=profile.r_max, vertex_z=profile.vertex_z)
    return out  # type: ignore[return-value]


@functools.lru_cache(maxsize=8)
def polished_design(mirror: Mirror, params: PolishParams, time_s: float) -> SampledProfile:
    """The smooth design polished for time_s (s): what the lap's removal alone does (cached:
    the pre-compensation and the report's decomposition both start from it)."""
    from .profile import ExactProfile

    return polish(ExactProfile(mirror), params, time_s)


def removal_depth(frame: Profile | Mirror, params: PolishParams, r: np.ndarray, time_s: float, *,
                  plan: LapPlan | None = None) -> np.ndarray:
    """Depth (mm, along the normal) the lap removes from a smooth surface at radii r (mm)
    in time_s (s): rate(r) t, the pad pressing evenly (p = p0)."""
    plan = lap_plan(frame, params) if plan is None else plan
    r = np.asarray(r, dtype=float)
    k = (r > frame.r_junction).astype(int)
    return np.where(k == 0, plan.rate(0, r), plan.rate(1, r)) * time_s


def _lobe_grid(profile: Profile, k: int, step: float) -> np.ndarray:
    lo, hi = profile.lobe_range(k)
    n = max(int(math.ceil((hi - lo) / step)) + 1, 16)
    r = np.linspace(lo, hi, n)
    if k == 1:
        r[0] = np.nextafter(lo, hi)  # the junction itself belongs to the inner lobe
    return r


def _evolve(r: np.ndarray, z0: np.ndarray, rate: np.ndarray, params: PolishParams,
            times: np.ndarray) -> list[np.ndarray]:
    """Explicit evolution of z(r) under the pad; snapshots at the (sorted) times.

    rate: removal rate (mm/s) at p = p0 at each r."""
    dr = r[1] - r[0]
    pad = PadFit(r.size, dr, params.pad_size_mm / PAD_SIGMAS, axis=bool(r[0] == 0.0))
    lc = params.compliance_mm
    # Short errors decay as exp(-rate (1 - H) t / l_c), 0 <= 1 - H <= 1. The step integrates
    # the pad's pull toward its surface exponentially with that surface held for the step
    # (exponential Euler): a full-stiffness error (H = 0) decays by exactly exp(-x) per step,
    # x = rate dt / l_c, at any x, and one with H > 0 by 1 - (1 - H)(1 - exp(-x)) against
    # exp(-(1 - H) x): with x <= ACCURACY = 0.2, within 0.5 % a step.
    dt_max = ACCURACY * lc / max(float(rate.max()), 1e-300)
    z = z0.copy()
    phi = np.ones_like(rate)  # (1 - exp(-x)) / x of the step being taken

    def pressure(z: np.ndarray, contact: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        fit = pad(z, contact)
        # Standing out toward the pad (toward the camera) is lower z; the pad deflects
        # along the normal, by the height difference times cos(beta).
        sec = np.sqrt(1.0 + (np.gradient(fit, dr)) ** 2)  # 1 / cos(beta)
        p = 1.0 + phi * (fit - z) / (sec * lc)
        # The pad's surface leaves out a point lying more than BRIDGE l_c below it (a deep
        # groove, the rounded step edge); one that just lost its pressure still holds the fit
        # (no flicker of the contact pattern between steps).
        return np.maximum(0.0, p), sec, p > -BRIDGE

    # Which points the pad's surface rests on at the start: refitted without the deep ones.
    contact = np.ones(z.size, bool)
    for _ in range(3):
        _, _, held = pressure(z, contact)
        if np.array_equal(held, contact):
            break
        contact = held
    t = 0.0
    snaps = []
    step = 0
    for target in times:
        while t < target - 1e-12:
            dt = min(dt_max, target - t)
            x = rate * dt / lc
            phi = np.where(x > 1e-8, -np.expm1(-x) / np.maximum(x, 1e-300), 1.0)
            p_rel, sec, held = pressure(z, contact)
            # The pattern the pad rests on is renewed every CONTACT_EVERY steps (a rounded
            # edge wears into contact point by point; refitting at each would cost a fresh
            # moment system per step for a change of a few micrometres of edge).
            if step % CONTACT_EVERY == 0:
                contact = held
            step += 1
            # Removal k p v dt along the normal raises z by that over cos(beta).
            z = z + dt * rate * p_rel * sec
            t += dt
        snaps.append(z.copy())
    return snaps


class PadFit:
    """The pad's conforming surface: at each point, the value there of a cubic fitted by
    least squares to the surface around it with Gaussian weights exp(-u^2 / (2 sigma^2)),
    |u| <= PAD_SIGMAS sigma (local polynomial regression), over the points the pad touches.
    Only points of the grid enter a fit, so at the grid's ends the fit is one-sided, not
    extrapolated; a point out of contact (a groove, the rounded top of the step, a fillet:
    deeper than the pad reaches) does not pull the pad's surface either (the pad bridges it).

    In the interior, with every point in contact, the fit is a convolution with the kernel
    (3 - u^2 / sigma^2) / 2 times the Gaussian (a local cubic equals a local quadratic at the
    centre of a symmetric window): transfer H(q) = (1 + (sigma q)^2 / 2) exp(-(sigma q)^2 / 2),
    monotone from 1 to 0 (no ringing). The weighted moments sum_j c_j w(u_j) u_j^m z_j are FFT
    correlations; the fit at each point is the first coefficient of its moment system.

    n: grid points; dr: grid step (mm); sigma: mm. axis: the grid starts on the axis (r = 0),
    across which the surface of revolution continues as its mirror image: the fit there is
    two-sided (on the reflected points), not one-sided.
    """

    DEGREE = 3

    def __init__(self, n: int, dr: float, sigma: float, *, axis: bool = False):
        h = max(int(math.ceil(PAD_SIGMAS * sigma / dr)), self.DEGREE + 1)
        u = np.arange(-h, h + 1) * dr / sigma  # in sigmas (conditioning)
        g = np.exp(-0.5 * u * u)
        d = self.DEGREE + 1
        self.mirror = min(h, n - 1) if axis else 0  # reflected points prepended
        self.n_user = n
        n = n + self.mirror
        self.n, self.h, self.d = n, h, d
        self.size = 1 << int(math.ceil(math.log2(n + 2 * h)))
        # Kernels flipped for a correlation: T_m[i] = sum_j g(u_j) u_j^m z[i + j].
        self.kernels_f = np.stack([np.fft.rfft(g * (-u) ** m, self.size) for m in range(2 * self.DEGREE + 1)])
        self.rows = self._solve(np.ones(n))  # every point in contact
        self._cached_key: bytes | None = None
        self._cached_rows = self.rows

    def _extend(self, x: np.ndarray) -> np.ndarray:
        m = self.mirror
        return np.concatenate([x[m:0:-1], x]) if m else x

    def _moments(self, x: np.ndarray, m: int) -> np.ndarray:
        f = np.fft.rfft(x, self.size)
        return np.fft.irfft(f[None, :] * self.kernels_f[:m], self.size)[:, self.h:self.h + self.n]

    def _rows(self, contact: np.ndarray) -> np.ndarray:
        """Row 0 of each point's inverse moment matrix (d, n), for this contact pattern: only
        the points within a window of one out of contact differ from full contact."""
        if contact.all():
            return self.rows
        out = np.flatnonzero(contact < 0.5)
        near = np.zeros(self.n + 1, int)
        np.add.at(near, np.clip(out - self.h, 0, self.n), 1)
        np.add.at(near, np.clip(out + self.h + 1, 0, self.n), -1)
        touched = np.flatnonzero(np.cumsum(near)[:self.n] > 0)
        rows = self.rows.copy()
        rows[:, touched] = self._solve(contact, touched)
        return rows

    def _solve(self, contact: np.ndarray, points: np.ndarray | None = None) -> np.ndarray:
        """Row 0 of the inverse moment matrix (d, len(points)) at `points` (default all)."""
        d = self.d
        moments = self._moments(contact, 2 * self.DEGREE + 1)
        if points is not None:
            moments = moments[:, points]
        mat = np.empty((moments.shape[1], d, d))
        for i in range(d):
            for j in range(d):
                mat[:, i, j] = moments[i + j]
        # A point with (almost) no contact around it has no pad surface of its own: a tiny
        # ridge keeps its system solvable (its fit is then ~0 departure: no pressure change).
        mat += 1e-9 * np.eye(d)
        return np.linalg.inv(mat)[:, 0, :].T.copy()

    def __call__(self, z: np.ndarray, contact: np.ndarray | None = None) -> np.ndarray:
        ref = float(z[z.size // 2])  # fit the departure from a constant: fewer digits in the FFT
        zz = self._extend(z - ref)
        if contact is None or contact.all():
            rows, t = self.rows, self._moments(zz, self.d)
        else:
            c = self._extend(contact.astype(float))
            # The pattern of points out of contact changes rarely (a rounded edge, a groove,
            # until it wears in): its moment systems are kept for the next steps.
            key = np.flatnonzero(~contact).tobytes()
            if key != self._cached_key:
                self._cached_key, self._cached_rows = key, self._rows(c)
            rows, t = self._cached_rows, self._moments(zz * c, self.d)
        return np.einsum("mi,mi->i", rows, t)[self.mirror:] + ref

    @staticmethod
    def transfer(wavelength_mm: np.ndarray | float, sigma: float) -> np.ndarray:
        """H of a ripple of wavelength_mm (mm) in the interior (closed form, see the class doc)."""
        s2 = (2.0 * math.pi * sigma / np.asarray(wavelength_mm, float)) ** 2
        return (1.0 + 0.5 * s2) * np.exp(-0.5 * s2)


# --------------------------------------------------------------------------------------
# Pre-compensation


@dataclass(frozen=True)
class CompensatedLobe(Lobe):
    """A lobe's sheet lowered toward the camera by a smooth allowance: z = sheet(r) - offset(r).

    offset: a cubic B-spline (knots offset_knots, coefficients offset_coef, mm) of r (mm),
    held at its end values beyond its knots. The sheet's own a, b, e, vertex_z stay the
    design's, so the machine frame (Z = 0 at the design's vertex) does not move: the program
    leaves the allowance standing above the design where the polish will take it off.
    """

    offset_knots: tuple[float, ...] = ()
    offset_coef: tuple[float, ...] = ()

    @functools.cached_property
    def _spline(self):
        from scipy.interpolate import BSpline

        return BSpline(np.asarray(self.offset_knots), np.asarray(self.offset_coef), 3)

    def _series(self, r: np.ndarray, nu: int) -> np.ndarray:
        t = self.offset_knots
        rr = np.clip(np.asarray(r, float), t[0], t[-1])
        out = self._spline(rr, nu)
        # Beyond the knots: the end value held (no slope, no curvature).
        outside = (np.asarray(r, float) < t[0]) | (np.asarray(r, float) > t[-1])
        return np.where(outside, 0.0, out) if nu else out

    def offset(self, r: np.ndarray | float) -> np.ndarray:
        """The allowance (mm, in z) at radius r (mm)."""
        return self._series(np.asarray(r, float), 0)

    def z(self, r: np.ndarray | float) -> np.ndarray:
        return super().z(r) - self._series(np.asarray(r, float), 0)

    def slope(self, r: np.ndarray | float) -> np.ndarray:
        return super().slope(r) - self._series(np.asarray(r, float), 1)

    def second_derivative(self, r: np.ndarray | float) -> np.ndarray:
        return super().second_derivative(r) - self._series(np.asarray(r, float), 2)


def compensated_mirror(mirror: Mirror, params: PolishParams, time_s: float, *,
                       plan: LapPlan | None = None, iterations: int = COMPENSATION_ITERATIONS) -> Mirror:
    """The finishing program's target: each lobe lowered by what a polish of time_s (s)
    removes, so that the polished part lands on the design.

    The allowance is this module's own prediction: first what polishing the smooth design
    for time_s removes (the lap's roll-off and the pad's response included); then
    `iterations` times the target itself is polished and what it misses the design by is
    added (the pad presses an allowance that rolls off near the pocket's wall differently
    from the roll-off it grows itself). Each allowance is a least-squares cubic spline in r
    with knots COMPENSATION_KNOT_MM apart (smooth enough for the planner's curvature; the pad
    evens out anything finer). The bands out of the pad's reach get none.
    """
    from dataclasses import replace

    from .profile import ExactProfile

    plan = lap_plan(mirror, params) if plan is None else plan
    grids = []
    for k in (0, 1):
        lo, hi = (0.0, mirror.r_junction) if k == 0 else (mirror.r_junction, mirror.r_max)
        r = np.linspace(lo, hi, int(math.ceil((hi - lo) / params.grid_step_mm)) + 1)
        if k == 1:
            r[0] = np.nextafter(lo, hi)
        grids.append(r)
    allowance = [np.zeros_like(r) for r in grids]
    target = mirror
    for i in range(iterations + 1):
        polished = polished_design(mirror, params, float(time_s)) if i == 0 and plan is None else \
            polish_series(ExactProfile(target), params, [time_s], plan=plan)[0]
        lobes = []
        for k, lobe in enumerate(mirror.lobes):
            r = grids[k]
            allowance[k] = allowance[k] + (np.asarray(polished.z(r)) - lobe.z(r))
            lobes.append(_compensated_lobe(lobe, r, allowance[k]))
        target = replace(mirror, inner=lobes[0], outer=lobes[1])
    return target


def _compensated_lobe(lobe: Lobe, r: np.ndarray, allowance: np.ndarray) -> CompensatedLobe:
    from scipy.interpolate import make_lsq_spline

    n_in = max(int(round((r[-1] - r[0]) / COMPENSATION_KNOT_MM)) - 1, 0)
    t = np.concatenate([[r[0]] * 4, np.linspace(r[0], r[-1], n_in + 2)[1:-1], [r[-1]] * 4])
    spline = make_lsq_spline(r, allowance, t, k=3)
    fields = {f: getattr(lobe, f) for f in ("name", "r_top", "r_pixel", "h", "a", "b", "e")}
    return CompensatedLobe(**fields, offset_knots=tuple(float(v) for v in spline.t),
                           offset_coef=tuple(float(v) for v in spline.c))
