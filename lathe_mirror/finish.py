"""Surface finish: the feed marks a turning tool leaves, roughness before and after
polishing, and the light the roughness scatters.

Feed marks. A nose of radius R fed f per revolution leaves circumferential grooves of
period f, each an arc of the nose: peak-to-valley h = R - sqrt(R^2 - f^2 / 4), which is
f^2 / (8 R) (1 + f^2 / (16 R^2) + ...) (the machinist's f^2 / 8R). The grooves' RMS about
their mean is 2 h / sqrt(45) for the parabolic arc (0.298 h).

Roughness. The turned surface carries the feed marks and a floor the material and the
edge leave (tearing, built-up edge, inclusions). The polishing pad sees both as errors much
shorter than itself, which decay as exp(-removal / l_c) (polishing.py: the compliant pad
at full stiffness, in the linear regime: amplitudes below l_c); the abrasive leaves its
own floor. After a removal depth d:

    sigma^2 = D^2 (sigma_feed^2 + sigma_turned_floor^2) + (1 - D^2) sigma_polished_floor^2,
    D = exp(-d / l_c).

Scatter. A surface of RMS roughness sigma << lambda scatters the fraction
TIS = (4 pi sigma cos(theta_i) / lambda)^2 of the light out of the specular direction
(total integrated scatter; Davies 1954, Bennett & Porteus 1961; theta_i the angle of
incidence, 0 at normal incidence). Feed marks are no small roughness: 0.56 um PV is 13 rad
of optical phase, a reflection grating of period f whose orders fall lambda / f apart. The
light left in the specular (zeroth) order of a periodic phase profile phi(x) is
|<exp(i phi)>|^2 over one period (scalar Kirchhoff, thin phase screen); for small phase it
is 1 - TIS. `optics.scatter` turns these into the haze each lobe puts into the image.

Process presets (`Process`): conventional turning then polishing, single-point diamond
turning of aluminium (nm-level finish, no polish), electroless nickel plate then diamond
turning. Lengths in mm inside (nm only in names that say so).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np

from .declared.section import Conv, defaults
from .enums import Program, parse
from .errors import InputError

#: Samples of one feed-mark period for the specular fraction (converges to ~1e-6 at 13 rad).
PERIOD_SAMPLES = 2048


@dataclass(frozen=True)
class Process:
    """A way of making the mirror's surface: how it is turned, and whether it is polished.

    name: the preset's key ("conventional", "diamond", "nickel_diamond"). label: one line
    for the report. program: which finishing program is cut. nose_radius_mm, feed_mm
    (per revolution), resolution_mm (the controller's lattice): the turning, mm; 0 takes
    the configured [tool] nose_radius, [machine] feed_finish, [machine] resolution.
    turned_floor_nm: RMS roughness of the turned surface besides the feed marks, nm.
    polish: whether the part is polished (for the time the polishing objective chooses).
    polished_floor_nm: RMS roughness the polish itself leaves, nm.
    """

    name: str
    label: str
    program: Program = Program.PAPER
    nose_radius_mm: float = 0.0
    feed_mm: float = 0.0
    resolution_mm: float = 0.0
    turned_floor_nm: float = 20.0
    polish: bool = True
    polished_floor_nm: float = 3.0

    def __post_init__(self) -> None:
        key = f"polish.process.{self.name}"
        for field in ("nose_radius_mm", "feed_mm", "resolution_mm", "turned_floor_nm", "polished_floor_nm"):
            v = getattr(self, field)
            if not (math.isfinite(v) and v >= 0):
                raise InputError(f"{key}.{field} = {v!r} must be a finite number >= 0")
        if self.feed_mm > 0 and self.nose_radius_mm > 0 and self.feed_mm >= 2 * self.nose_radius_mm:
            raise InputError(f"{key}.feed_mm = {self.feed_mm:g} mm must be less than twice the nose radius "
                             f"({2 * self.nose_radius_mm:g} mm): the nose would not overlap its last pass")
        if self.turned_floor_nm > 1e4 or self.polished_floor_nm > 1e4:
            raise InputError(f"{key}: roughness floors are nm RMS, at most 10000 nm")

    def resolved(self, *, nose_radius_mm: float, feed_mm: float, resolution_mm: float) -> Process:
        """This process with its zero (inherit) values replaced by the configured ones (mm)."""
        from dataclasses import replace

        return replace(self, nose_radius_mm=self.nose_radius_mm or nose_radius_mm,
                       feed_mm=self.feed_mm or feed_mm, resolution_mm=self.resolution_mm or resolution_mm)


def _processes(table: dict, where: str = "polish.process") -> tuple[Process, ...]:
    return tuple(
        Process(name=name, label=str(e["label"]), program=parse(Program, e["program"], f"{where}.{name}.program"),
                polish=bool(e["polish"]), **{k: float(e[k]) for k in ("nose_radius_mm", "feed_mm", "resolution_mm",
                                                                       "turned_floor_nm", "polished_floor_nm")})
        for name, e in table.items())


#: [polish.process.*] in the file (a table per preset), Processes in the field.
PROCESSES = Conv(_processes, lambda ps: {p.name: {f.name: getattr(p, f.name) for f in fields(p) if f.name != "name"}
                                          for p in ps})

#: The presets a user weighs: the declared ones (polish.process.*; data/polish.toml).
DEFAULT_PROCESSES = _processes(defaults("polish.process"))


# --------------------------------------------------------------------------------------
# Feed marks


def feed_mark_height(feed_mm: float, nose_radius_mm: float) -> float:
    """Peak-to-valley height (mm) of the grooves a nose of radius nose_radius_mm (mm) leaves
    when fed feed_mm (mm per revolution): the arc's sagitta R - sqrt(R^2 - f^2 / 4), about
    f^2 / (8 R). A sharp nose (R = 0) is given no height (its marks are set by the edge, not
    the feed); a feed of 2 R or more leaves uncut ridges and is refused."""
    if feed_mm <= 0 or nose_radius_mm <= 0:
        return 0.0
    if feed_mm >= 2.0 * nose_radius_mm:
        raise InputError(f"feed {feed_mm:g} mm/rev >= twice the nose radius {nose_radius_mm:g} mm: the "
                         "passes do not overlap")
    r, half = nose_radius_mm, 0.5 * feed_mm
    return float(half * half / (r + math.sqrt(r * r - half * half)))  # = r - sqrt(r^2 - half^2), stably


def feed_mark_profile(feed_mm: float, nose_radius_mm: float, n: int = PERIOD_SAMPLES) -> np.ndarray:
    """Heights (mm) of one feed-mark period at n evenly spaced points, above the groove's
    bottom: the nose's arc R - sqrt(R^2 - x^2), x across the period (centred)."""
    if feed_mm <= 0 or nose_radius_mm <= 0:
        return np.zeros(n)
    x = (np.arange(n) + 0.5) / n * feed_mm - 0.5 * feed_mm
    r = nose_radius_mm
    return x * x / (r + np.sqrt(r * r - x * x))


def feed_mark_rms(feed_mm: float, nose_radius_mm: float) -> float:
    """RMS (mm) of the feed marks about their mean (the arc profile, sampled)."""
    h = feed_mark_profile(feed_mm, nose_radius_mm)
    return float(np.sqrt(np.mean((h - h.mean()) ** 2)))


# --------------------------------------------------------------------------------------
# Roughness


def smoothing_factor(removal_mm: np.ndarray | float, compliance_mm: float) -> np.ndarray:
    """Fraction exp(-removal / l_c) of a short error the pad leaves after removing
    removal_mm (mm) of material with compliance l_c = compliance_mm (mm)."""
    return np.exp(-np.asarray(removal_mm, dtype=float) / compliance_mm)


def roughness_rms(process: Process, smoothing: np.ndarray | float = 1.0) -> np.ndarray:
    """RMS roughness (mm) of a process's surface; `smoothing` the fraction of the turned
    roughness a polish leaves (1: as turned; see smoothing_factor). The process's nose,
    feed must be resolved (Process.resolved)."""
    d2 = np.asarray(smoothing, dtype=float) ** 2
    feed = feed_mark_rms(process.feed_mm, process.nose_radius_mm)
    turned2 = feed**2 + (process.turned_floor_nm * 1e-6) ** 2
    polished2 = (process.polished_floor_nm * 1e-6) ** 2
    return np.sqrt(d2 * turned2 + (1.0 - d2) * polished2)


# --------------------------------------------------------------------------------------
# Scatter


def total_integrated_scatter(sigma_mm: np.ndarray | float, wavelength_mm: float,
                             cos_incidence: np.ndarray | float = 1.0) -> np.ndarray:
    """TIS = (4 pi sigma cos(theta_i) / lambda)^2: the fraction of light a surface of RMS
    roughness sigma_mm (mm) scatters out of the specular direction at wavelength_mm (mm),
    for sigma << lambda (beyond ~lambda / 10 it overstates; see specular_fraction)."""
    return (4.0 * math.pi * np.asarray(sigma_mm, float) * np.asarray(cos_incidence, float) / wavelength_mm) ** 2


def specular_fraction(heights_mm: np.ndarray, wavelength_mm: float,
                      cos_incidence: np.ndarray | float = 1.0) -> np.ndarray:
    """Fraction of the light a periodic height profile (one period, evenly sampled, mm;
    last axis) leaves in the specular order: |<exp(i 4 pi h cos(theta_i) / lambda)>|^2.

    cos_incidence broadcasts against the profile's leading axes (one value per profile)."""
    h = np.asarray(heights_mm, dtype=float)
    k = 4.0 * math.pi * np.asarray(cos_incidence, float)[..., None] / wavelength_mm
    return np.abs(np.mean(np.exp(1j * k * h), axis=-1)) ** 2


def order_spacing(period_mm: float, wavelength_mm: float) -> float:
    """Angle (rad) between neighbouring diffraction orders of a grating of period_mm (mm)
    at normal incidence: asin(lambda / period); pi / 2 when no first order propagates."""
    if period_mm <= 0:
        return math.pi / 2
    s = wavelength_mm / period_mm
    return math.asin(s) if s < 1 else math.pi / 2
