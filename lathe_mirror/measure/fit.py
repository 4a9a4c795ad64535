"""A measured trace fitted against the design: where the part's axis is, how it was tilted
and raised on the instrument, and what is left (measured minus design).

Frames. The part's own frame is the machine frame (r along the radius, Z along the axis,
vertex at Z = 0, part face up: Z_design(r) = vertex_z - z_camera(r)). A trace point
(x, z) is the part point (u, w) (u signed along the trace, w its height) turned by the
tilt t and moved by the decentre x0 and the piston p:

    x = x0 + u cos t - w sin t,    z = p + u sin t + w cos t,

so the part's axis crosses the trace at x = x0. The fit (scipy.optimize.least_squares,
soft-L1 loss: a spike or the centre pip does not pull it) finds x0, t, p, and with
conic=True each lobe's best-fit radius R and conic constant k (ISO 10110-12: the lobe's
sag changed by sag(R, k) - sag(R_design, k_design)) and the outer lobe's height. The
residual is w - Z_design(|u|) at every point, in mm; points where the stylus cannot
follow (the design's slope above max_slope_deg), on the step's wall and the nose's
fillet (r_junction +/- wall_mm), and off the part are masked out of the fit.

Per lobe, over its clear aperture (optics.polishing_curve.clear_aperture), the residual
folded about the axis is smoothed by a least-squares cubic spline (knots smooth_mm apart:
the stated spatial band; finer than that is noise to the figures): PV and RMS (piston
removed per lobe) and slope RMS of that curve, and the raw RMS of the points about it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..design import Mirror, conic_sag
from ..errors import InputError
from ..optics.polishing_curve import clear_aperture
from ..profile import ExactProfile
from .readers import AreaMap, Trace

#: Knot spacing (mm) of the residual's smoothing spline: the spatial band of the figures.
SMOOTH_MM = 0.5


@dataclass(frozen=True)
class FitOptions:
    """How a trace is fitted. conic: fit each lobe's R and k too. max_slope_deg: steepest
    design slope the stylus follows (deg). wall_mm: half-width of the band masked about
    the step (mm; None: the tool's nose radius + 0.05). edge_mm: band at the rim masked
    (mm). smooth_mm: knot spacing of the residual's spline (mm)."""

    conic: bool = False
    max_slope_deg: float = 60.0
    wall_mm: float | None = None
    edge_mm: float = 0.05
    smooth_mm: float = SMOOTH_MM


@dataclass(frozen=True)
class LobeFit:
    """One lobe's figures over its clear aperture (r_lo .. r_hi, mm)."""

    name: str
    r_lo: float
    r_hi: float
    pv_um: float
    rms_um: float
    slope_rms_urad: float
    raw_rms_um: float
    mean_um: float
    n_points: int
    radius_mm: float | None = None
    conic: float | None = None

    def to_dict(self) -> dict:
        d = {"name": self.name, "aperture_mm": [self.r_lo, self.r_hi], "pv_um": self.pv_um,
             "rms_um": self.rms_um, "slope_rms_urad": self.slope_rms_urad, "raw_rms_um": self.raw_rms_um,
             "n_points": self.n_points}
        if self.radius_mm is not None:
            d["radius_mm"] = self.radius_mm
            d["conic"] = self.conic
        return d


@dataclass(frozen=True)
class TraceFit:
    """The fitted trace. u: each point's signed radius in the part (mm); resid: measured
    minus design (mm, vertical in the part frame); used: the points the fit used; splines:
    per lobe, the smoothed residual (scipy BSpline of r, mm) or None where the trace does
    not reach the lobe."""

    trace: Trace
    mirror: Mirror
    decentre_mm: float
    tilt_rad: float
    piston_mm: float
    u: np.ndarray
    resid: np.ndarray
    used: np.ndarray
    lobes: tuple[LobeFit, ...]
    splines: tuple = field(repr=False)
    step_error_um: float | None = None
    conic_params: dict | None = None
    options: FitOptions = FitOptions()

    @property
    def r(self) -> np.ndarray:
        return np.abs(self.u)

    def residual_at(self, r: np.ndarray) -> np.ndarray:
        """The smoothed residual (mm) at radii r (mm), per lobe; 0 where no spline."""
        r = np.asarray(r, float)
        out = np.zeros_like(r)
        for k, sp in enumerate(self.splines):
            if sp is None:
                continue
            sel = (r <= self.mirror.r_junction) if k == 0 else (r > self.mirror.r_junction)
            t = sp.t
            out = np.where(sel, sp(np.clip(r, t[0], t[-1])), out)
        return out

    def to_dict(self) -> dict:
        d = {"decentre_mm": self.decentre_mm, "tilt_rad": self.tilt_rad, "piston_mm": self.piston_mm,
             "points": int(self.trace.x.size), "points_used": int(np.count_nonzero(self.used)),
             "smooth_mm": self.options.smooth_mm}
        if self.step_error_um is not None:
            d["step_error_um"] = self.step_error_um
        return d


def design_z(mirror: Mirror):
    """Z_design(r) (machine frame, mm) and its derivative, as functions of r >= 0."""
    exact = ExactProfile(mirror)
    vz = mirror.vertex_z
    return (lambda r: vz - exact.z(r)), (lambda r: -exact.slope(r))


def fit_trace(trace: Trace, mirror: Mirror, *, nose_radius_mm: float = 0.2,
              options: FitOptions = FitOptions()) -> TraceFit:
    """Fit `trace` (machine frame, mm) against `mirror`'s design (module doc)."""
    from scipy.optimize import least_squares

    zd, dzd = design_z(mirror)
    x, z = trace.x, trace.z
    rj, rmax = mirror.r_junction, mirror.r_max
    wall = options.wall_mm if options.wall_mm is not None else nose_radius_mm + 0.05
    conics = [(lobe.vertex_radius, lobe.conic_constant) for lobe in mirror.lobes]  # ISO 10110-12 R, k
    max_slope = math.tan(math.radians(options.max_slope_deg))

    def model(params, u):
        r = np.abs(u)
        base = zd(r)
        if options.conic:
            R0, k0, R1, k1, p1 = params[3:8]
            inner = r <= rj
            d0 = conic_sag(r, R0, k0) - conic_sag(r, *conics[0])
            d1 = conic_sag(r, R1, k1) - conic_sag(r, *conics[1]) - p1
            base = base - np.where(inner, d0, d1)
        return base

    def part_coords(params):
        x0, t, p = params[:3]
        c, s = math.cos(t), math.sin(t)
        u = (x - x0) * c + (z - p) * s
        w = -(x - x0) * s + (z - p) * c
        return u, w

    def usable(u):
        r = np.abs(u)
        ok = (r < rmax - options.edge_mm) & (np.abs(r - rj) > wall)
        return ok & (np.abs(dzd(r)) <= max_slope)

    # start: the axis where the smoothed trace peaks (the vertex is the highest point)
    k = max(int(len(z) // 200), 1)
    zs = np.convolve(z, np.ones(2 * k + 1) / (2 * k + 1), mode="same")
    i0 = int(np.argmax(zs[k:-k] if len(zs) > 2 * k else zs)) + (k if len(zs) > 2 * k else 0)
    p0 = [float(x[i0]), 0.0, float(z[i0] - zd(0.0))]
    if options.conic:
        p0 += [conics[0][0], conics[0][1], conics[1][0], conics[1][1], 0.0]
    params = np.asarray(p0, float)

    # 1) near the vertex, plain least squares: a good start for the whole trace
    core = np.abs(x - params[0]) < min(rj, rmax) * 0.5
    if np.count_nonzero(core) > 20:
        def res_core(q):
            qq = np.concatenate([q, params[3:]])
            u, w = part_coords(qq)
            return (w - model(qq, u))[core]
        params[:3] = least_squares(res_core, params[:3], x_scale=[1.0, 1e-3, 1e-3], method="lm").x

    # 2) the whole trace, robust
    for _ in range(2):
        u, w = part_coords(params)
        mask = usable(u)
        if np.count_nonzero(mask) < max(20, len(params) * 4):
            raise InputError(f"{trace.source}: only {np.count_nonzero(mask)} points lie on the mirror's "
                             "lobes where a stylus can follow; is this a trace of this design (--config)?")
        r0 = (w - model(params, u))[mask]
        scale = max(3.0 * 1.4826 * float(np.median(np.abs(r0 - np.median(r0)))), 1e-5)

        def res(q):
            uu, ww = part_coords(q)
            return (ww - model(q, uu))[mask]

        xs = [1.0, 1e-3, 1e-3] + ([1.0, 0.01, 1.0, 0.01, 1e-3] if options.conic else [])
        params = least_squares(res, params, loss="soft_l1", f_scale=scale, x_scale=xs).x

    u, w = part_coords(params)
    mask = usable(u)
    resid = w - zd(np.abs(u))  # measured minus design (with conic=True too: R, k are reported)
    lobes, splines, means = [], [], []
    for kk in (0, 1):
        lf, sp = lobe_figures(mirror, kk, np.abs(u), resid, mask, options)
        if lf is not None and options.conic:
            R, kc = (params[3], params[4]) if kk == 0 else (params[5], params[6])
            lf = LobeFit(**{**lf.__dict__, "radius_mm": float(R), "conic": float(kc)})
        if lf is not None:
            lobes.append(lf)
            means.append(lf.mean_um)
        splines.append(sp)
    step = (lobes[1].mean_um - lobes[0].mean_um) if len(lobes) == 2 else None
    conic_params = None
    if options.conic:
        conic_params = {"inner": {"radius_mm": float(params[3]), "conic": float(params[4])},
                        "outer": {"radius_mm": float(params[5]), "conic": float(params[6])}}
    return TraceFit(trace, mirror, float(params[0]), float(params[1]), float(params[2]), u, resid, mask,
                    tuple(lobes), tuple(splines), step, conic_params, options)


def lobe_figures(mirror: Mirror, k: int, r: np.ndarray, resid: np.ndarray, mask: np.ndarray,
                  options: FitOptions):
    from scipy.interpolate import make_lsq_spline

    lo, hi = clear_aperture(mirror, k, 0.0)
    sel = mask & (r >= lo) & (r <= hi)
    if np.count_nonzero(sel) < 20:
        return None, None
    rr, vv = r[sel], resid[sel]
    order = np.argsort(rr, kind="stable")
    rr, vv = rr[order], vv[order]
    rr = rr + np.arange(rr.size) * 1e-12  # strictly increasing (both halves of the trace)
    lo, hi = float(rr[0]), float(rr[-1])
    n_in = max(int(round((hi - lo) / options.smooth_mm)) - 1, 0)
    inner_knots = np.linspace(lo, hi, n_in + 2)[1:-1]
    # a knot interval with no point makes the spline singular: keep knots with data between
    if inner_knots.size:
        counts = np.histogram(rr, bins=np.concatenate([[lo], inner_knots, [hi]]))[0]
        keep = np.ones(inner_knots.size, bool)
        for i in range(inner_knots.size):
            if counts[i] < 4 or counts[i + 1] < 4:
                keep[i] = False
        inner_knots = inner_knots[keep]
    t = np.concatenate([[lo] * 4, inner_knots, [hi] * 4])
    sp = make_lsq_spline(rr, vv, t, k=3)
    grid = np.linspace(lo, hi, 2001)
    f = sp(grid)
    mean = float(f.mean())
    g = sp.derivative()(grid)
    raw = vv - sp(rr)
    lf = LobeFit(mirror.lobes[k].name, lo, hi, pv_um=float(np.ptp(f)) * 1e3,
                 rms_um=float(np.sqrt(np.mean((f - mean) ** 2))) * 1e3,
                 slope_rms_urad=float(np.sqrt(np.mean(g ** 2))) * 1e6,
                 raw_rms_um=float(np.sqrt(np.mean(raw ** 2))) * 1e3, mean_um=mean * 1e3,
                 n_points=int(rr.size))
    return lf, sp


# --------------------------------------------------------------------------------------
# Areal maps


def profile_through_axis(area: AreaMap, mirror: Mirror) -> Trace:
    """The trace of a height map through its fitted axis, along x: the axis (x0, y0) from
    a least-squares fit of the design (with piston and tilt) to the map, then the map
    interpolated between rows at y0 for every column."""
    from scipy.optimize import least_squares

    zd, _ = design_z(mirror)
    ny, nx = area.z.shape
    sy, sx = max(ny // 120, 1), max(nx // 120, 1)
    X, Y = np.meshgrid(area.x[::sx], area.y[::sy])
    Z = area.z[::sy, ::sx]
    ok = np.isfinite(Z)
    X, Y, Z = X[ok], Y[ok], Z[ok]
    if X.size < 20:
        raise InputError(f"{area.source}: too few measured points to find the axis")
    rmax = mirror.r_max
    # start: the column and row where the map (a median across spikes) peaks
    zc = np.nanmedian(area.z[::sy], axis=0)
    k = max(nx // 200, 1)
    zc = np.convolve(np.nan_to_num(zc, nan=-np.inf), np.ones(2 * k + 1) / (2 * k + 1), mode="same")
    ic = int(np.argmax(zc[k:-k])) + k if nx > 2 * k else int(np.argmax(zc))
    band = np.abs(area.x - area.x[ic]) < 0.25 * rmax
    zr = np.nanmedian(area.z[:, band], axis=1)
    jr = int(np.nanargmax(zr))
    X0, Y0 = float(area.x[ic]), float(area.y[jr])
    Zc = float(area.z[jr, ic]) if np.isfinite(area.z[jr, ic]) else float(np.nanmax(zr))
    # a tilt across the rows only where the map spans the part (in a strip about the axis it
    # is one with moving the axis)
    tilt_y = float(np.ptp(area.y)) >= rmax
    q0 = np.array([X0, Y0, Zc - zd(0.0), 0.0] + ([0.0] if tilt_y else []))

    def res(q):
        r = np.hypot(X - q[0], Y - q[1])
        model = zd(np.minimum(r, rmax)) + q[2] + q[3] * (X - q[0]) + (q[4] * (Y - q[1]) if tilt_y else 0.0)
        return np.where(r < rmax, Z - model, 0.0)

    q = least_squares(res, q0, loss="soft_l1", f_scale=1e-3, x_scale=[1, 1, 1e-3, 1e-3] + ([1e-3] if tilt_y else [])).x
    y0 = q[1]
    if not (area.y[0] <= y0 <= area.y[-1]):
        raise InputError(f"{area.source}: the fitted axis (y = {y0:.3f} mm) lies outside the map")
    j = int(np.clip(np.searchsorted(area.y, y0) - 1, 0, ny - 2))
    f = (y0 - area.y[j]) / (area.y[j + 1] - area.y[j])
    z = (1 - f) * area.z[j] + f * area.z[j + 1]
    return Trace(np.asarray(area.x, float), z, f"{area.source}, row y = {y0:.4f} mm through the axis")
