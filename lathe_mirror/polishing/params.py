"""The polishing parameters ([polish]) and the model's numerical constants."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..enums import Dwell, Lap, PolishObjective
from ..declared import check as check_declared
from ..declared.section import choice, section_repr, setting
from ..errors import InputError
from ..finish import PROCESSES, Process

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

#: The fields declared as keys of their own name, polish.<field> (lathe_mirror.declared).
DECLARED = ("preston_coefficient", "pressure_kpa", "pad_size_mm", "compliance_mm", "spindle_rpm", "lap_radius_mm",
            "lap_rpm", "stroke_mm", "overhang", "stroke_points", "time_s", "grid_step_mm", "curve_max_s",
            "curve_points", "form_degree", "corner_mm", "step_edge_mm", "clear_edge_mm", "objective_range_m",
            "objective_tolerance", "calibration_knot_px", "wavelength_nm")


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

    __repr__ = section_repr  # one line: the fields off their declared defaults

    preston_coefficient: float = setting("polish.preston_coefficient")
    pressure_kpa: float = setting("polish.pressure_kpa")
    pad_size_mm: float = setting("polish.pad_size_mm")
    compliance_mm: float = setting("polish.compliance_mm")
    spindle_rpm: float = setting("polish.spindle_rpm")
    lap: Lap = setting("polish.lap", choice(Lap))
    lap_radius_mm: float = setting("polish.lap_radius_mm")
    lap_rpm: float = setting("polish.lap_rpm")
    stroke_mm: float = setting("polish.stroke_mm")
    overhang: float = setting("polish.overhang")
    dwell: Dwell = setting("polish.dwell", choice(Dwell))
    stroke_points: int = setting("polish.stroke_points")
    time_s: float = setting("polish.time_s")
    grid_step_mm: float = setting("polish.grid_step_mm")
    curve_max_s: float = setting("polish.curve_max_s")
    curve_points: int = setting("polish.curve_points")
    form_degree: int = setting("polish.form_degree")
    corner_mm: float = setting("polish.corner_mm")
    step_edge_mm: float = setting("polish.step_edge_mm")
    clear_edge_mm: float = setting("polish.clear_edge_mm")
    objective: PolishObjective = setting("polish.objective", choice(PolishObjective))
    objective_range_m: float = setting("polish.objective_range_m")
    objective_tolerance: float = setting("polish.objective_tolerance")
    calibration_knot_px: float = setting("polish.calibration_knot_px")
    wavelength_nm: float = setting("polish.wavelength_nm")
    precompensate: bool = setting("polish.precompensate")
    processes: tuple[Process, ...] = setting("polish.process", PROCESSES)

    def __post_init__(self) -> None:
        # Each field within its key's declaration (polish.<field>): the line load() gives.
        for name in DECLARED:
            check_declared(f"polish.{name}", getattr(self, name))
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
