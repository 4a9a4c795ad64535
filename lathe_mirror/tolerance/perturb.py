"""One trial's made mirror and camera pose, evaluated for many trials at once.

What varies from part to part, and how each enters:

- lattice phase, nose radius, polishing time: the trial's own made surface
  (tolerance.surfaces.SurfaceBank: re-machined per phase and per nose drawn);
- tool setting error in X: the turned surface is the program's shifted across the axis,
  z(rho) = z_prog(|rho - dx|); in Z: the whole surface moves along the axis, z + dz;
- camera decentre (x, y), tilt about its pinhole (about x then y, CameraPose's
  convention) and axial offset (the lens's entrance pupil);
- the mirror's seat tilt: the mirror turned rigidly about a pivot on the axis
  seat_pivot_mm above the pinhole, which in the mirror's frame is the camera turned the
  other way about that pivot: a rotation plus a decentre of (pivot x tilt), correlated.

Everything is traced per trial, vectorised over trials and pixels: a sparse pixel sample
(image-radius bins x azimuths, each ray weighted by the pixel centres it stands for)
through the trial's surface in 3-D, in the mirror's frame. Each trial gets two sets of
figures: raw, against the design's own model (the aligned exact mirror), and calibrated,
against the model a calibration of that very camera fits (tolerance.calibration: the
camera's rotation and a smooth radial map per lobe removed). The stereo figures cross
the two lobes' made rays for points of the common band at a range: the depth error and,
the figure users read, the disparity-equivalent error (px) beside the matcher's floor.

Mirror frame (the design's camera frame), mm and radians inside.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..design import Mirror
from ..optics.radial import in_lobe_range, used_extent
from ..optics.stereo import capped_abs_error, triangulate
from ..toolpath.metrics import slope_error
from .calibration import Calibration, fit, lobe_span, model_directions, model_pixels, residuals, sheet_points
from .poses import PoseDraws, poses
from .samples import PixelSample, StereoPoints, stereo_points
from .surfaces import SurfaceBank, off_lobe_cells

#: Newton steps of the 3-D ray-surface intersection (2-3 from the exact sheet's hit).
_MAX_ITER = 8
#: A hit this far (mm) outside its lobe's radial extent landed on the wall or the other lobe.
_LOBE_SLACK = 1e-6
#: Rays x trials per vectorised batch of evaluate (memory: ~1 kB each with the calibration).
_BATCH_RAYS = 150_000


@dataclass
class Trials(PoseDraws):
    """Parameters of each trial (arrays of one length): the camera's and the seat's
    (poses.PoseDraws) and the machining's. Units in the names; phase is an index into the
    bank's phases; camera tilt and seat tilt in rad."""

    phase: np.ndarray
    nose_mm: np.ndarray
    time_s: np.ndarray
    tool_x_mm: np.ndarray
    tool_z_mm: np.ndarray
    # the lathe's set-up errors beyond the configured ones (machine_errors; tolerance.
    # machine_errors): centre height (mm), nose radius error with the tool set on its tip
    # (mm), X slide squareness (rad), and the X shift of the finishing pass (X offset plus
    # the backlash a pass cut in +X loses, mm)
    centre_height_mm: np.ndarray = None
    nose_error_mm: np.ndarray = None
    squareness_rad: np.ndarray = None
    machine_x_mm: np.ndarray = None

    def __post_init__(self) -> None:
        for name in ("centre_height_mm", "nose_error_mm", "squareness_rad", "machine_x_mm"):
            if getattr(self, name) is None:
                setattr(self, name, np.zeros(self.phase.size))

    def __len__(self) -> int:
        return int(self.phase.size)

    def take(self, idx: np.ndarray | slice) -> "Trials":
        return Trials(**{k: v[idx] for k, v in self.__dict__.items()})

    @staticmethod
    def nominal(n: int, nose_mm: float, time_s: float) -> "Trials":
        z = np.zeros(n)
        return Trials(phase=np.zeros(n, dtype=np.intp), nose_mm=np.full(n, nose_mm),
                      time_s=np.full(n, time_s), tool_x_mm=z.copy(), tool_z_mm=z.copy(),
                      cam_x_mm=z.copy(), cam_y_mm=z.copy(), cam_z_mm=z.copy(), tilt_x=z.copy(),
                      tilt_y=z.copy(), seat_x=z.copy(), seat_y=z.copy())

    @staticmethod
    def concat(parts: list["Trials"]) -> "Trials":
        return Trials(**{k: np.concatenate([getattr(p, k) for p in parts]) for k in parts[0].__dict__})


#: Per-lobe figures (arrays (trials, 2)) and stereo figures (arrays (trials, ranges)).
LOBE_FIGURES = ("image_displacement_px_rms", "image_displacement_px_max", "image_displacement_px_median",
                "outlier_pct", "ray_error_deg_rms", "viewpoint_spread_mm_rms")
STEREO_FIGURES = ("disparity_px_median", "disparity_px_p90", "within_5_pct", "within_10_pct", "seen_fraction",
                  "depth_error_pct_rms")


@dataclass
class TrialFigures:
    """Figures per trial. raw / calibrated: name -> array (LOBE_FIGURES: (trials, 2);
    STEREO_FIGURES: (trials, ranges)); slope_error_rad_rms and normal_deviation_mm_rms
    (trials, 2) of the surface; lost_fraction (trials,) of the sample's pixels whose made
    ray misses their lobe or leaves its range; calibration: what was fitted."""

    raw: dict[str, np.ndarray]
    calibrated: dict[str, np.ndarray]
    slope_error_rad_rms: np.ndarray
    normal_deviation_mm_rms: np.ndarray
    lost_fraction: np.ndarray
    calibration: Calibration
    ranges_m: tuple[float, ...]
    extra: dict = field(default_factory=dict)

    def judged(self, calibrated: bool) -> dict[str, np.ndarray]:
        return self.calibrated if calibrated else self.raw


# --------------------------------------------------------------------------------------
# The lathe's set-up errors on a trial's surface


def machine_error_surface(bank: SurfaceBank, k: int, surf: tuple[np.ndarray, np.ndarray], tr: Trials):
    """(z, slope) of lobe k of each trial on the lobe's grid with the trial's set-up errors
    (machine_errors' model, to first order in each; camera frame, z up = machine Z down):
    the centre height h moves every radius r to sqrt(r^2 - h^2) (radii under h are held at
    the vertex: the pip a pixel or less across); a nose radius error dr, the tool set on its
    tip, raises the part by dr (1 + z' - sqrt(1 + z'^2)) in machine Z; squareness eps tilts
    Z by eps r. The X shift is the setting error's (tool_x_mm)."""
    z, s = surf
    r = bank.grid(k)
    h = tr.centre_height_mm[:, None]
    q = np.sqrt(np.maximum(r[None, :] ** 2 - h ** 2, 0.0))
    if np.any(h):
        z = np.stack([np.interp(q[i], r, z[i]) for i in range(z.shape[0])])
        s = np.stack([np.interp(q[i], r, s[i]) for i in range(s.shape[0])])
    dr = tr.nose_error_mm[:, None]
    lift = dr * (1.0 + np.abs(s) - np.sqrt(1.0 + s * s))
    dlift = np.gradient(lift, r, axis=1) if r.size > 1 else np.zeros_like(lift)
    eps = tr.squareness_rad[:, None]
    return z - lift - eps * r[None, :], s - dlift - eps


# --------------------------------------------------------------------------------------
# Evaluation


def evaluate(mirror: Mirror, bank: SurfaceBank, trials: Trials, samples: tuple[PixelSample, PixelSample], *,
             ranges_m=(1.0,), depth_points: int = 9, seat_pivot_mm: float = 125.0, calibrate: bool = True,
             outlier_px: float = np.inf, chunk: int = 100, progress=None,
             keep_displacements: bool = False, zones=None) -> TrialFigures:
    """Figures of every trial (TrialFigures). ranges_m: ranges (m) of the stereo figures.

    Of the pixels whose made ray lands on their lobe, those displaced more than outlier_px
    (px; against the model, raw or calibrated) are outliers: the image displacement's RMS
    and median are over the others, outlier_pct (%) is their share, the max is over all.
    A ring of pixels at a lobe's edge that sees a feature a few micrometres wide (the flank
    of the groove a larger nose cuts at the step: ~200 px off) would otherwise set a lobe's
    RMS alone; a calibration rejects such points, and the robot loses them as it loses the
    step's ring. Pixels whose ray misses the lobe (past the rim of a tilted camera), or
    lands but leaves the lobe's range (the exact lobe would image its direction outside
    its designed annulus: optics.radial.in_lobe_range, the rule render and calib apply),
    count in lost_fraction, never as a displacement.
    calibrate=False skips the calibration fit (the calibrated figures then equal the raw).
    chunk: trials per vectorised batch. The bank must hold every trial's nose (ensure).
    zones: optics.zones.Zones: the slope error and normal deviation over its used zone
    (default radial.used_extent's; the samples carry the pixels' zone)."""
    n = len(trials)
    R = len(ranges_m)
    raw = {k: np.empty((n, 2)) for k in LOBE_FIGURES} | {k: np.empty((n, R)) for k in STEREO_FIGURES}
    cal = {k: np.empty_like(v) for k, v in raw.items()}
    slope, ndev, lost = np.empty((n, 2)), np.empty((n, 2)), np.empty(n)
    rot, coeffs = np.empty((n, 3, 3)), np.empty((n, 2, 4))
    kept: list = []
    sp = stereo_points(mirror, ranges_m, depth_points)
    span = (lobe_span(samples[0].u, samples[0].v), lobe_span(samples[1].u, samples[1].v))
    chunk = batch_trials(samples, chunk)
    for a in range(0, n, chunk):
        sl = slice(a, min(n, a + chunk))
        tr = trials.take(sl)
        m = len(tr)
        surf = [bank.trial_surface(k, tr.phase, tr.nose_mm, tr.time_s, tr.tool_z_mm) for k in (0, 1)]
        if np.any(tr.centre_height_mm) or np.any(tr.nose_error_mm) or np.any(tr.squareness_rad) \
                or np.any(tr.machine_x_mm):
            surf = [machine_error_surface(bank, k, surf[k], tr) for k in (0, 1)]
            tr.tool_x_mm = tr.tool_x_mm + tr.machine_x_mm  # the pass shifted in X, as a setting error
        origin, rotation = poses(tr, seat_pivot_mm)
        # each lobe's cells off its surface, once a batch (every trace and the surface errors read them)
        off = [off_lobe_cells(surf[k][0], bank.design_z(k), bank.dr[k]) for k in (0, 1)]
        traced = [_trace(mirror, bank, k, surf, tr, origin, rotation, samples[k].u, samples[k].v, off[k])
                  for k in (0, 1)]
        # each made direction's point on the exact sheet: the same for the range check, the raw
        # and the calibrated model (calibration.sheet_points)
        points = [sheet_points(mirror, k, traced[k][1]) for k in (0, 1)]
        traced = [_in_range(mirror, k, t, points[k]) for k, t in enumerate(traced)]
        valid = [t[2] for t in traced]
        n_lost = sum(np.sum(np.where(valid[k], 0.0, samples[k].weight[None, :]), axis=1) for k in (0, 1))
        lost[sl] = n_lost / (samples[0].weight.sum() + samples[1].weight.sum())
        ident = Calibration.identity(m, span)
        fitted = fit(mirror, [(s.u, s.v, s.weight) for s in samples], [t[1] for t in traced], valid) \
            if calibrate else ident
        rot[sl], coeffs[sl] = fitted.rotation, fitted.coeffs
        for model, out in ((ident, raw), (fitted, cal)):
            for k in (0, 1):
                smp = samples[k]
                p, o, ok, _ = traced[k]
                disp = residuals(mirror, k, o, model, smp.u[None, :], smp.v[None, :], points[k])
                landed = ok & np.isfinite(disp)
                ok_k = landed & (disp <= outlier_px)
                w = np.where(ok_k, smp.weight[None, :], 0.0)
                out["image_displacement_px_rms"][sl, k] = _wrms(np.where(ok_k, disp, 0.0), w)
                out["image_displacement_px_max"][sl, k] = np.max(np.where(landed, disp, 0.0), axis=1)
                out["image_displacement_px_median"][sl, k] = _wquantile(np.where(ok_k, disp, np.inf), w, 0.5)
                n_landed = np.sum(np.where(landed, smp.weight[None, :], 0.0), axis=1)
                out["outlier_pct"][sl, k] = 100.0 * (1.0 - np.sum(w, axis=1) / np.maximum(n_landed, 1e-300))
                # the ray error on every third pixel of the sample (a secondary figure)
                sub = slice(None, None, 3)
                d_model = model_directions(mirror, k, smp.u[sub], smp.v[sub], model)
                o_s = o[:, sub]
                ang = np.degrees(np.arctan2(np.linalg.norm(np.cross(o_s, d_model), axis=-1), np.sum(o_s * d_model, -1)))
                out["ray_error_deg_rms"][sl, k] = _wrms(np.where(ok_k[:, sub] & np.isfinite(ang), ang, 0.0), w[:, sub])
                f1 = np.array([0.0, 0.0, mirror.lobes[k].focus_z])
                spread = np.linalg.norm(np.cross(f1 - p, o), axis=-1)
                out["viewpoint_spread_mm_rms"][sl, k] = _wrms(np.where(ok_k, spread, 0.0), w)
                if keep_displacements and model is ident:
                    kept.append((k, sl, disp, ok_k))
            stereo = _stereo(mirror, bank, surf, tr, origin, rotation, sp, model, off)
            for key, v in stereo.items():
                out[key][sl] = v
        for k in (0, 1):
            slope[sl, k], ndev[sl, k] = _surface_errors(mirror, bank, k, surf[k], tr, zones=zones, off=off[k])
        if progress is not None:
            progress.update(m)
    if not calibrate:
        cal = {k: v.copy() for k, v in raw.items()}
    fig = TrialFigures(raw, cal, slope, ndev, lost, Calibration(rot, coeffs, span), tuple(float(r) for r in ranges_m))
    if keep_displacements:
        fig.extra["displacements"] = kept
    return fig


def batch_trials(samples: tuple[PixelSample, PixelSample], chunk: int = 100) -> int:
    """Trials per batch of evaluate; blocks at multiples of it give the serial figures."""
    return max(1, min(chunk, _BATCH_RAYS // max(samples[0].u.size, samples[1].u.size, 1)))


def _wrms(x: np.ndarray, w: np.ndarray) -> np.ndarray:
    return np.sqrt(np.sum(w * x**2, axis=1) / np.maximum(np.sum(w, axis=1), 1e-300))


def _wquantile(x: np.ndarray, w: np.ndarray, q: float) -> np.ndarray:
    """Weighted quantile per row (the smallest value with at least q of the weight at or
    below it); weights 0 are ignored (x may be inf there)."""
    order = np.argsort(x, axis=1)
    xs = np.take_along_axis(x, order, axis=1)
    ws = np.take_along_axis(w, order, axis=1)
    cw = np.cumsum(ws, axis=1)
    tot = cw[:, -1:]
    idx = np.argmax(cw >= q * tot, axis=1)
    return xs[np.arange(x.shape[0]), idx]


def _lookup(bank: SurfaceBank, k: int, grid: np.ndarray, rows: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Linear interpolation of per-trial grid values (trials, n) at radii q (trials, m)."""
    g = (q - bank.r0[k]) / bank.dr[k]
    i0 = np.clip(np.floor(g).astype(np.intp), 0, bank.n[k] - 2)
    f = g - i0
    return _gather(grid, rows, i0) * (1.0 - f) + _gather(grid, rows, i0 + 1) * f


def _gather(grid: np.ndarray, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
    """grid[rows, cols] (rows broadcast against cols) as one flat take: the same values,
    ~3x faster than numpy's two-array fancy indexing on the trials' (trials, n) tables."""
    return np.take(grid.reshape(-1), rows * grid.shape[1] + cols)


def _sheet_hit(lobe, o: np.ndarray, d: np.ndarray) -> np.ndarray:
    """Ray parameter s where o + s d meets the lobe's exact upper sheet
    (z - e)^2 / a^2 - (x^2 + y^2) / b^2 = 1, z > e (the vertex plane where it misses)."""
    a2, b2, e = lobe.a**2, lobe.b**2, lobe.e
    oz = o[..., 2] - e
    A = d[..., 2] ** 2 / a2 - (d[..., 0] ** 2 + d[..., 1] ** 2) / b2
    B = 2.0 * (oz * d[..., 2] / a2 - (o[..., 0] * d[..., 0] + o[..., 1] * d[..., 1]) / b2)
    C = oz**2 / a2 - (o[..., 0] ** 2 + o[..., 1] ** 2) / b2 - 1.0
    disc = np.sqrt(np.maximum(B * B - 4.0 * A * C, 0.0))
    with np.errstate(invalid="ignore", divide="ignore"):
        r1, r2 = (-B + disc) / (2 * A), (-B - disc) / (2 * A)
    best = np.full(np.broadcast(A, oz).shape, np.inf)
    for r in (r1, r2):
        up = np.isfinite(r) & (r > 0) & (oz + r * d[..., 2] > 0)
        best = np.where(up & (r < best), r, best)
    plane = (lobe.vertex_z - o[..., 2]) / d[..., 2]
    return np.where(np.isfinite(best), best, plane)


def _lookup_with_slope(bank: SurfaceBank, k: int, grid: np.ndarray, rows: np.ndarray, q: np.ndarray):
    """_lookup and the slope of the interpolant (the cell's chord) at q."""
    g = (q - bank.r0[k]) / bank.dr[k]
    i0 = np.clip(np.floor(g).astype(np.intp), 0, bank.n[k] - 2)
    f = g - i0
    a, b = _gather(grid, rows, i0), _gather(grid, rows, i0 + 1)
    return a * (1.0 - f) + b * f, (b - a) / bank.dr[k]


def _in_range(mirror: Mirror, k: int, traced: tuple, points: np.ndarray | None = None) -> tuple:
    """_trace's result with `ok` cleared where the made direction has left lobe k's range:
    the design's own model (no calibration) images it outside the lobe's annulus. points:
    the directions' sheet points (calibration.sheet_points), if made already."""
    p, o, ok, blocked = traced
    n = o.shape[0]
    design = Calibration.identity(n, ((0.0, 1.0), (0.0, 1.0)))  # no radial terms: the span is unused
    mu, mv = model_pixels(mirror, k, o, design, points)
    return p, o, ok & in_lobe_range(mirror, k, np.hypot(mu, mv)), blocked


def _trace(mirror: Mirror, bank: SurfaceBank, k: int, surfs, tr: Trials, origin, rot, u, v, off: np.ndarray):
    """Hit points, reflected unit directions (trials, m, 3), and masks (trials, m): ok, the
    ray lands on lobe k (not the wall, the other lobe, past the rim); blocked, leaving the
    recessed inner lobe it runs into the step wall (vignetted). u, v: px, (m,) shared by
    the trials or (trials, m) each its own. off: the trials' cells off lobe k's surface
    (surfaces.off_lobe_cells of its z table)."""
    surf = surfs[k]
    cam = mirror.camera
    dc = np.stack(np.broadcast_arrays(u * cam.t_pixel, v * cam.t_pixel, cam.f), axis=-1).astype(float)
    dc = dc / np.linalg.norm(dc, axis=-1, keepdims=True)
    d = dc @ np.transpose(rot, (0, 2, 1))  # (trials, m, 3): each row R dc
    o = origin[:, None, :]
    z_grid, s_grid = surf
    rows = np.arange(len(tr))[:, None]
    lo, hi = (0.0, mirror.r_junction) if k == 0 else (mirror.r_junction, mirror.r_max)
    dx = tr.tool_x_mm[:, None]
    # Start where the ray meets the exact sheet; Newton on g(s) = Z(q(s)) - o_z - s d_z,
    # q = |rho(s) - dx|, with Z' the interpolant's own slope (exact on its linear pieces):
    # two or three steps where the plain fixed point s = (Z - o_z) / d_z, contracting by
    # ~0.22, takes ~16.
    s = _sheet_hit(mirror.lobes[k], o, d)
    for _ in range(_MAX_ITER):
        x = o[..., 0] + s * d[..., 0]
        y = o[..., 1] + s * d[..., 1]
        rho = np.hypot(x, y)
        q_raw = rho - dx
        q = np.clip(np.abs(q_raw), lo, hi)
        z, chord = _lookup_with_slope(bank, k, z_grid, rows, q)
        g = z - o[..., 2] - s * d[..., 2]
        with np.errstate(invalid="ignore", divide="ignore"):
            dq = np.sign(q_raw) * np.where(rho > 0, (x * d[..., 0] + y * d[..., 1]) / rho, 0.0)
        inside = (np.abs(q_raw) > lo) & (np.abs(q_raw) < hi)
        dg = np.where(inside, chord * dq, 0.0) - d[..., 2]
        step = g / dg
        s = s - step
        if np.max(np.abs(step)) < 1e-11:
            break
    # A ray that does not settle (it meets a near-vertical cell: the step's wall, a groove
    # the nose cut into the lobe's edge) has no hit on the lobe's surface.
    settled = np.abs(step) < 1e-9
    p = o + s[..., None] * d
    rho = np.hypot(p[..., 0], p[..., 1])
    q_raw = rho - dx
    ok = (np.abs(q_raw) >= lo - _LOBE_SLACK) & (np.abs(q_raw) <= hi + _LOBE_SLACK)
    if k == 1:
        ok &= np.abs(q_raw) > lo
    q = np.clip(np.abs(q_raw), lo, hi)
    # Off the lobe's surface (surfaces.off_lobe_cells: the step's wall, the groove a larger
    # nose cuts into the outer lobe's edge, the rim a smaller one leaves on the inner lobe,
    # the cell the nose's corner turns down in): a hit in such a cell hit the wall, not the
    # lobe; the samples cannot say where in the cell the wall stands (5 um, 0.06 px).
    i0 = np.clip(np.floor((q - bank.r0[k]) / bank.dr[k]).astype(np.intp), 0, bank.n[k] - 2)
    ok &= settled & ~_gather(off, rows, i0)
    slope = _lookup(bank, k, s_grid, rows, q) * np.sign(np.where(q_raw == 0, 1.0, q_raw))
    # Normal (toward the camera) of z = Z(rho): (s x/rho, s y/rho, -1) / sqrt(1 + s^2).
    with np.errstate(invalid="ignore", divide="ignore"):
        er_x = np.where(rho > 0, p[..., 0] / rho, 1.0)
        er_y = np.where(rho > 0, p[..., 1] / rho, 0.0)
    nn = np.sqrt(1.0 + slope**2)
    n = np.stack([slope * er_x / nn, slope * er_y / nn, -1.0 / nn], axis=-1)
    out = d - 2.0 * np.sum(d * n, axis=-1, keepdims=True) * n
    if k == 0 and mirror.step > 0:
        # Where the reflected ray crosses the cylinder r = r_junction, outward.
        rj = mirror.r_junction
        a = out[..., 0] ** 2 + out[..., 1] ** 2
        b = 2.0 * (p[..., 0] * out[..., 0] + p[..., 1] * out[..., 1])
        c = p[..., 0] ** 2 + p[..., 1] ** 2 - rj**2
        with np.errstate(invalid="ignore", divide="ignore"):
            s_wall = (-b + np.sqrt(np.maximum(b * b - 4 * a * c, 0.0))) / (2 * a)
        z_cross = p[..., 2] + s_wall * out[..., 2]
        q_top = np.clip(np.abs(rj - tr.tool_x_mm), mirror.r_junction, mirror.r_max)
        z_top = _lookup(bank, 1, surfs[1][0], np.arange(len(tr)), q_top)
        blocked = z_cross > z_top[:, None]
    else:
        blocked = np.zeros(ok.shape, bool)
    return p, out, ok, blocked


def _surface_errors(mirror: Mirror, bank: SurfaceBank, k: int, surf, tr: Trials, stride: int = 4, zones=None,
                    off: np.ndarray | None = None):
    """RMS slope error (rad) and RMS normal deviation (mm) of lobe k per trial, uniform in r
    over the extent the image uses (radial.used_extent: the zones' used zone if given).
    off: the cells off the lobe's surface (default off_lobe_cells of surf's z)."""
    lobe = mirror.lobes[k]
    r = bank.r0[k] + bank.dr[k] * np.arange(0, bank.n[k], stride)
    if k == 1:
        r[0] = np.nextafter(r[0], np.inf)
    u_lo, u_hi = used_extent(mirror, k, zones)
    r = r[(r >= u_lo) & (r <= u_hi)]
    lo, hi = (0.0, mirror.r_junction) if k == 0 else (mirror.r_junction, mirror.r_max)
    rows = np.arange(len(tr))[:, None]
    q_raw = r[None, :] - tr.tool_x_mm[:, None]
    q = np.clip(np.abs(q_raw), lo, hi)
    z = _lookup(bank, k, surf[0], rows, q)
    s = _lookup(bank, k, surf[1], rows, q) * np.sign(np.where(q_raw == 0, 1.0, q_raw))
    s_ex = lobe.slope(r)[None, :]
    slope_err = slope_error(s, s_ex)
    ndev = (z - lobe.z(r)[None, :]) / np.sqrt(1.0 + s_ex**2)
    # A point in a cell off the lobe's surface (_trace's rule, surfaces.off_lobe_cells: the
    # wall moved into the lobe, the groove's flank, the nose's corner) is no slope of the
    # lobe; its pixels are lost. The interpolated slope at a point is its cell's two
    # samples', so the cell decides: a sample next to the corner's cell keeps its own slope
    # (one-sided where the chords jump, _sample_slopes) and is judged.
    if off is None:
        off = off_lobe_cells(surf[0], bank.design_z(k), bank.dr[k])
    i0 = np.clip(np.floor((q - bank.r0[k]) / bank.dr[k]).astype(np.intp), 0, bank.n[k] - 2)
    on = ~_gather(off, rows, i0)
    cnt = np.maximum(np.sum(on, axis=1), 1)
    return (np.sqrt(np.sum(np.where(on, slope_err**2, 0.0), axis=1) / cnt),
            np.sqrt(np.sum(np.where(on, ndev**2, 0.0), axis=1) / cnt))


def _stereo(mirror: Mirror, bank: SurfaceBank, surf, tr: Trials, origin, rot, sp: StereoPoints,
            model: Calibration, off: list[np.ndarray]) -> dict[str, np.ndarray]:
    """Stereo figures of each trial at each range, against `model`.

    The model believes a pixel pair shows the point W where its two model rays cross;
    take the pair the model assigns to W (model_pixels of the directions from each F1 to
    W), trace the two pixels through the trial's made mirror and camera, and cross the
    made rays at X: the point the robot actually sees there. Depth error = 100 (R_X - R)
    / R, R_X the signed range of X along W's direction; parallax error delta =
    B cos(elevation) (1 / R - 1 / R_X) (first order; finite where the depth error
    diverges), in px: |delta| / px_scale. A point either lobe does not show (ray off its
    lobe, vignetted, or leaving the lobe's range: _in_range) is not seen.
    """
    n = len(tr)
    R, M = sp.w.shape[:2]
    w_all = sp.w.reshape(-1, 3)
    rays = []
    for k, lobe in enumerate(mirror.lobes):
        dirs = w_all - np.array([0.0, 0.0, lobe.focus_z])
        dirs = dirs / np.linalg.norm(dirs, axis=-1, keepdims=True)
        u, v = model_pixels(mirror, k, np.broadcast_to(dirs, (n,) + dirs.shape), model)
        bad = ~(np.isfinite(u) & np.isfinite(v))
        u, v = np.where(bad, 0.0, u), np.where(bad, 0.0, v)
        p, o, ok, blocked = _in_range(mirror, k, _trace(mirror, bank, k, surf, tr, origin, rot, u, v, off[k]))
        rays.append((p, o, ok & ~blocked & ~bad))
    x = triangulate(rays[0][0], rays[0][1], rays[1][0], rays[1][1])
    unit = np.tile(sp.unit, (R, 1))
    rng = np.repeat(sp.range_mm, M)
    r_made = np.sum((x - np.array([0.0, 0.0, sp.centre_z])) * unit[None], axis=-1)
    seen = rays[0][2] & rays[1][2] & np.isfinite(r_made)
    err = np.where(seen, 100.0 * (r_made - rng) / rng, np.nan)
    with np.errstate(divide="ignore", invalid="ignore"):
        delta = np.tile(sp.parallax_base, R) * (1.0 / rng - 1.0 / r_made)
    px = np.where(seen, np.abs(delta) / np.tile(sp.px_scale, R), np.inf)
    out = {key: np.empty((n, R)) for key in STEREO_FIGURES}
    for i in range(R):
        cols = slice(i * M, (i + 1) * M)
        e, d, s = err[:, cols], px[:, cols], seen[:, cols]
        # Over the points both lobes see (finite); the unseen ones are counted in
        # seen_fraction (monte carlo's judge fails a trial that sees less than the
        # quantile's share), 0 where none is seen.
        w_seen = s.astype(float)
        none = ~np.any(s, axis=1)
        out["disparity_px_median"][:, i] = np.where(none, 0.0, _wquantile(np.where(s, d, 0.0), w_seen, 0.5))
        out["disparity_px_p90"][:, i] = np.where(none, 0.0, _wquantile(np.where(s, d, 0.0), w_seen, 0.9))
        out["within_5_pct"][:, i] = np.mean(s & (np.abs(np.nan_to_num(e, nan=np.inf)) <= 5.0), axis=1)
        out["within_10_pct"][:, i] = np.mean(s & (np.abs(np.nan_to_num(e, nan=np.inf)) <= 10.0), axis=1)
        out["seen_fraction"][:, i] = np.mean(s, axis=1)
        out["depth_error_pct_rms"][:, i] = np.sqrt(np.mean(capped_abs_error(e) ** 2, axis=1))
    return out
