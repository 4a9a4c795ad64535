"""Polishing the turned mirror: Preston's law under a compliant lap.

The paper ends (section 6) on "polish the surface as long as the process does not deform
the mirror profile". This module puts numbers on both halves of that sentence.

Model, per lobe, on a fine uniform grid of r (camera frame, mm; time in s):

    Preston's law (Preston 1927):   dh/dt = k_p * p * v           [mm/s = 1/Pa * Pa * mm/s]
    surface speed of the spinning part under a lap covering the lobe:  v = omega * r
    pressure of a compliant (Winkler) pad, stiffness p0 / l_c per unit deflection:
        p = p0 * max(0, 1 + d / l_c)
    d = how far (along the normal) the surface stands out toward the pad beyond the pad's own local surface,
        which conforms to the part up to cubic terms over the pad size w (a Savitzky-Golay
        cubic fit over a window w): errors much shorter than w (facets, lattice steps) see
        the full stiffness and are worn away; the design's curvature is not.

h is removed along the surface normal, so the height z (measured from the camera; the
material lies at larger z) grows by dh * sqrt(1 + slope^2). Because v grows with r the
lap removes more at the rim than at the vertex: that is the form change, the low-order
departure from the design, which grows linearly with time while the facets decay
exponentially (rate k_p p0 omega r / l_c). Lobes are polished separately: the step wall
and the inside corner at the junction are not modelled (the pad does not reach into the
corner; each lobe's edge is treated as a free edge of the pad's fit).

Explicit Euler in time, with a step that keeps the fastest mode (gain <= ~1.2 per unit
d / l_c) stable and monotone.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from .errors import InputError
from .profile import LobeSamples, Profile, SampledProfile

#: Time step as a fraction of the fastest e-folding time of a short error (see _evolve).
ACCURACY = 0.05
#: Most explicit time steps one polishing run may take (~1 ms each on the paper mirror's
#: 0.005 mm grid, both lobes): the paper default's 0 .. 7200 s curve takes ~320.
MAX_STEPS = 20_000


@dataclass(frozen=True)
class PolishParams:
    """Polishing process parameters (edge units; converted inside).

    preston_coefficient: k_p, 1/Pa. pressure_kpa: mean pad pressure p0, kPa. pad_size_mm:
    w, the length over which the pad conforms, mm (a longer pad smooths longer
    wavelengths). compliance_mm: l_c = p0 / stiffness, the pad deflection that doubles the
    local pressure, mm (smaller: a stiffer pad, faster smoothing). spindle_rpm: rev/min.
    time_s: polishing time, s. grid_step_mm: radial grid of the evolution, mm (finer costs
    time linearly; must resolve the lattice steps). form_degree: degree of the Legendre fit
    in r that defines "form" per lobe. corner_mm: width of the band at the foot of the step
    that the pad cannot reach, mm (left as machined).
    """

    preston_coefficient: float = 4e-13
    pressure_kpa: float = 20.0
    pad_size_mm: float = 6.0
    compliance_mm: float = 0.004
    spindle_rpm: float = 300.0
    time_s: float = 3300.0
    grid_step_mm: float = 0.005
    curve_max_s: float = 7200.0
    curve_points: int = 25
    form_degree: int = 4
    corner_mm: float = 0.5

    def __post_init__(self) -> None:
        for key in ("preston_coefficient", "pressure_kpa", "pad_size_mm", "compliance_mm",
                    "spindle_rpm", "grid_step_mm", "curve_max_s"):
            v = getattr(self, key)
            if not (math.isfinite(v) and v > 0):
                raise InputError(f"polish.{key} = {v!r} must be a finite number > 0")
        if not (math.isfinite(self.corner_mm) and 0 <= self.corner_mm <= 5):
            raise InputError(f"polish.corner_mm = {self.corner_mm!r} must be 0 .. 5 mm")
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
        if self.grid_step_mm * 8 > self.pad_size_mm:
            raise InputError(
                f"polish.grid_step_mm = {self.grid_step_mm:g} mm must be at most pad_size_mm / 8 "
                f"= {self.pad_size_mm / 8:g} mm (the pad's fit needs points to fit)")

    @property
    def pressure_pa(self) -> float:
        return self.pressure_kpa * 1e3

    @property
    def omega(self) -> float:
        """Spindle speed, rad/s."""
        return self.spindle_rpm * 2.0 * math.pi / 60.0

    def time_steps(self, r_max_mm: float, time_s: float) -> float:
        """Explicit time steps (see _evolve) to polish a part of outer radius r_max_mm (mm)
        for time_s (s): the step is ACCURACY l_c over the fastest removal rate, at the rim."""
        with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
            rate = float(removal_rate(np.array([r_max_mm]), self)[0])
            n = time_s * rate / (ACCURACY * self.compliance_mm)
        return float(n) if math.isfinite(n) else math.inf

    def check_time(self, r_max_mm: float, time_s: float) -> None:
        """InputError when polishing for time_s (s) would take more than MAX_STEPS steps."""
        n = self.time_steps(r_max_mm, time_s)
        if n > MAX_STEPS:
            raise InputError(
                f"polishing for {time_s:g} s (polish.time_s / polish.curve_max_s) would take {n:.3g} time "
                f"steps, at most {MAX_STEPS} allowed (the removal rate k_p p0 omega r at r = {r_max_mm:g} mm "
                f"against a compliance of {self.compliance_mm:g} mm sets the step); shorten the time, or "
                f"lower polish.preston_coefficient, "
                f"pressure_kpa or spindle_rpm, or raise compliance_mm")

    @property
    def curve_times(self) -> np.ndarray:
        """Times (s) of the polishing curve: 0 .. curve_max_s, evenly spaced."""
        return np.linspace(0.0, self.curve_max_s, self.curve_points)


def polish(profile: Profile, params: PolishParams, time_s: float | None = None) -> SampledProfile:
    """The surface after polishing `profile` for time_s (s; default params.time_s)."""
    t = params.time_s if time_s is None else time_s
    return polish_series(profile, params, [t])[0]


def polish_series(profile: Profile, params: PolishParams, times_s: Sequence[float] | np.ndarray
                  ) -> list[SampledProfile]:
    """The polished surface at each of times_s (s), from one evolution (snapshots).

    Each lobe evolves on its own grid from r = its inner edge to its outer edge, except a
    band params.corner_mm wide at the foot of the step (the recessed lobe's edge at the
    junction), which the pad cannot reach and which stays as machined.
    """
    times = np.asarray(times_s, dtype=float)
    if times.ndim != 1 or times.size == 0 or not np.all(np.isfinite(times)) or np.any(times < 0):
        raise InputError(f"polishing times {times_s!r} must be finite numbers >= 0 s")
    params.check_time(profile.r_max, float(times.max()))
    order = np.argsort(times, kind="stable")
    corner_lobe = _recessed_lobe(profile)
    per_lobe = []
    for k in (0, 1):
        r = _lobe_grid(profile, k, params.grid_step_mm)
        z0 = np.asarray(profile.z(r), dtype=float)
        # The pad cannot press into the inside corner at the foot of the step: that band
        # of the recessed lobe stays as machined (with the tool's fillet, if any).
        reach = np.ones(r.size, bool)
        if k == corner_lobe and params.corner_mm > 0:
            reach = (r < profile.r_junction - params.corner_mm) if k == 0 else \
                (r > profile.r_junction + params.corner_mm)
        if reach.sum() < 16:
            per_lobe.append((r, [z0.copy() for _ in times]))
            continue
        snaps = _evolve(r[reach], z0[reach], params, times[order])
        full = []
        for zs in snaps:
            z = z0.copy()
            z[reach] = zs
            full.append(z)
        per_lobe.append((r, full))
    out: list[SampledProfile | None] = [None] * times.size
    for j, i in enumerate(order):
        ri, zi = per_lobe[0][0], per_lobe[0][1][j]
        ro, zo = per_lobe[1][0], per_lobe[1][1][j]
        out[i] = SampledProfile(LobeSamples(ri, zi), LobeSamples(ro, zo), r_junction=profile.r_junction,
                                r_max=profile.r_max, vertex_z=profile.vertex_z)
    return out  # type: ignore[return-value]


def _recessed_lobe(profile: Profile) -> int:
    """0 if the inner lobe is recessed at the junction (the step's inside corner is on its
    edge), 1 if the outer lobe is."""
    rj = profile.r_junction
    z_in = float(profile.z(np.array([rj]))[0])
    z_out = float(profile.z(np.array([np.nextafter(rj, np.inf)]))[0])
    return 0 if z_in > z_out else 1


def removal_rate(r: np.ndarray, params: PolishParams) -> np.ndarray:
    """Mean removal rate k_p p0 omega r (mm/s) at radius r (mm), before the pad's response."""
    return params.preston_coefficient * params.pressure_pa * params.omega * np.asarray(r, float)


def _lobe_grid(profile: Profile, k: int, step: float) -> np.ndarray:
    lo, hi = profile.lobe_range(k)
    n = max(int(math.ceil((hi - lo) / step)) + 1, 16)
    r = np.linspace(lo, hi, n)
    if k == 1:
        r[0] = np.nextafter(lo, hi)  # the junction itself belongs to the inner lobe
    return r


def _evolve(r: np.ndarray, z0: np.ndarray, params: PolishParams, times: np.ndarray) -> list[np.ndarray]:
    """Explicit evolution of z(r) under the pad; snapshots at the (sorted) times."""
    dr = r[1] - r[0]
    window = int(round(params.pad_size_mm / dr)) | 1  # odd number of points
    window = min(window, r.size - (1 - r.size % 2))
    pad_fit = _PadFit(r.size, window, 3)
    rate = removal_rate(r, params)  # mm/s at p = p0
    lc = params.compliance_mm
    # Short errors decay as exp(-rate g t / l_c), g <= ~1.2 the gain of (1 - SG). Euler's
    # factor per step is 1 - rate g dt / l_c: dt = l_c / (20 rate_max) keeps it within
    # (0.94, 1), stable, monotone and within ~3% of the exponential after one e-fold.
    dt_max = ACCURACY * lc / max(float(rate.max()), 1e-300)
    z = z0.copy()
    t = 0.0
    snaps = []
    for target in times:
        while t < target - 1e-12:
            dt = min(dt_max, target - t)
            fit = pad_fit(z)
            # Standing out toward the pad (toward the camera) is lower z; the pad deflects
            # along the normal, by the height difference times cos(beta).
            sec = np.sqrt(1.0 + (np.gradient(fit, dr)) ** 2)  # 1 / cos(beta)
            p_rel = np.maximum(0.0, 1.0 + (fit - z) / (sec * lc))
            # Removal k p v dt along the normal raises z by that over cos(beta).
            z = z + dt * rate * p_rel * sec
            t += dt
        snaps.append(z.copy())
    return snaps


class _PadFit:
    """The pad's conforming surface: a Savitzky-Golay fit (polynomial of `order` over a
    window of `window` points, Savitzky & Golay 1964), by FFT convolution in the interior
    and by the window's own polynomial fit at each end (as scipy's mode="interp")."""

    def __init__(self, n: int, window: int, order: int):
        h = window // 2
        x = np.arange(-h, h + 1, dtype=float)
        vander = np.vander(x, order + 1, increasing=True)  # window x (order + 1)
        self.pinv = np.linalg.pinv(vander)  # window values -> polynomial coefficients
        self.kernel = (vander[h] @ self.pinv)[::-1].copy()  # centre value, as a convolution
        self.v_left = vander[:h]  # the first h points of the first window
        self.v_right = vander[h + 1:]  # the last h points of the last window
        self.n, self.h, self.window = n, h, window
        self.size = 1 << int(math.ceil(math.log2(n + window - 1)))
        self.kernel_f = np.fft.rfft(self.kernel, self.size)

    def __call__(self, z: np.ndarray) -> np.ndarray:
        full = np.fft.irfft(np.fft.rfft(z, self.size) * self.kernel_f, self.size)
        out = np.empty_like(z)
        h, w = self.h, self.window
        out[h:self.n - h] = full[w - 1:self.n]
        out[:h] = self.v_left @ (self.pinv @ z[:w])
        out[self.n - h:] = self.v_right @ (self.pinv @ z[self.n - w:])
        return out
