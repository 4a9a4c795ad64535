"""The lap's kinematics: the time-averaged removal rate at each radius (LapPlan), the
tool influence function, the dwell-time profile, and the radii a lap can reach."""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from ..design import Mirror
from ..enums import Dwell, Lap
from ..profile import Profile
from .params import AZIMUTH_NODES, RATE_STEP_MM, STROKE_STEP_MM, SMOOTHING, PolishParams

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
    from scipy.optimize import nnls  # scipy.optimize: only for a dwell plan

    n = tif.shape[1]
    if params.dwell is Dwell.UNIFORM or n == 1:
        return np.full(n, 1.0 / n)

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
    # Each lobe's height at the junction extrapolated (quadratic) from three of its points
    # 1 mm apart (closer on a narrow lobe), not read at the junction itself: a made part's
    # fillet (as deep as the nose, as wide) lowers the recessed lobe's edge and a sliver of
    # the step's wall can end the proud lobe's samples, which flips the comparison for some
    # lattice phases (an outer-recessed part polished as if its inner lobe were recessed).
    d = min(1.0, rj / 4.0, (frame.r_max - rj) / 4.0)
    if d <= 0:
        return 0 if float(frame.z(np.array([rj]))[0]) > float(frame.z(np.array([np.nextafter(rj, np.inf)]))[0]) else 1
    u = np.array([1.0, 2.0, 3.0])
    z_in = frame.z(rj - d * u)
    z_out = frame.z(rj + d * u)
    # the quadratic through the three values at u = 1, 2, 3, at u = 0: 3 f1 - 3 f2 + f3
    at = np.array([3.0, -3.0, 1.0])
    return 0 if float(at @ z_in) > float(at @ z_out) else 1


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
