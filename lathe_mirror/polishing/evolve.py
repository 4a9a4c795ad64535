"""Polishing a made surface: the removal evolved in time under the compliant pad
(polish, polish_series), the removal on the design, the pad's local fit (PadFit)."""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence

import numpy as np

from ..design import Mirror
from ..errors import InputError
from ..inputs import check_real, check_type
from ..profile import ExactProfile, LobeSamples, Profile, SampledProfile
from .lap import LapPlan, lap_plan
from .params import ACCURACY, BRIDGE, CONTACT_EVERY, PAD_SIGMAS, PolishParams

# --------------------------------------------------------------------------------------
# The evolution


def polish(profile: Profile, params: PolishParams, time_s: float | None = None) -> SampledProfile:
    """The surface after polishing `profile` for time_s (s per lobe; default params.time_s)."""
    check_type(profile, "polish: profile", Profile, "a Profile (made_surface(...).profile)")
    check_type(params, "polish: params", PolishParams, "a PolishParams (settings.polish)")
    t = params.time_s if time_s is None else check_real(time_s, "polish: time_s", lo=0.0, unit="s")
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


def fast_length(n: int) -> int:
    """The smallest 5-smooth number (2^a 3^b 5^c) >= n: an FFT length pocketfft transforms
    fast (scipy.fft.next_fast_len(n, real=True), without importing scipy.fft on every
    command's start-up path)."""
    best = 1 << max(n - 1, 0).bit_length()
    p5 = 1
    while p5 < best:
        p35 = p5
        while p35 < best:
            best = min(best, p35 << max(-(-n // p35) - 1, 0).bit_length())
            p35 *= 3
        p5 *= 5
    return best


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
        # the correlation's length without wrap-around, rounded up to a 5-smooth length (the
        # FFT's fast sizes: 5625 against 8192 for a 35 mm outer lobe, ~1.4x faster)
        self.size = fast_length(n + 2 * h)
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
