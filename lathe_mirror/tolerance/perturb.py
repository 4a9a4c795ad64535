"""One trial's made mirror and camera pose, evaluated for many trials at once.

What varies from part to part, and how each enters:

- lattice phase (resolution): which of the precomputed rounding realisations was cut;
- nose radius: the as-machined surface with the actual nose, linear between surfaces
  precomputed at the nominal and +/- the tolerance;
- polishing time: linear between snapshots of one polishing run per machined surface
  (nominal +/- tolerance, 5 snapshots);
- tool setting error in X: the turned surface is the program's shifted across the axis,
  z(rho) = z_prog(|rho - dx|); in Z: the whole surface moves along the axis, z + dz;
- camera decentre (x, y), tilt (about x then y, CameraPose's convention) and axial offset.

Precomputing the surfaces that do not vary continuously (the "nodes") and interpolating
is what makes a thousand trials fast; everything else is traced per trial, vectorised
over trials and pixels: a sparse pixel sample (image-radius bins x azimuths, each ray
weighted by the pixel centres it stands for) through the trial's surface in 3-D, the
exact lobe's image point of each reflected direction (closed form), and the stereo
crossing of the two lobes' rays for points at the spec's range.

Camera frame, mm and radians inside.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..design import Mirror
from ..optics.radial import ideal_radius_px, lobe_pixel_radii, used_extent
from ..optics.stereo import band_elevations, capped_abs_error, stereo_centre_z
from ..profile import Profile

#: Fixed-point iterations of the 3-D ray-surface intersection (contraction <= ~0.22).
_MAX_ITER = 40
#: A hit this far (mm) outside its lobe's radial extent landed on the wall or the other lobe.
_LOBE_SLACK = 1e-6
#: Rays x trials per vectorised batch of evaluate (memory: ~0.25 kB each).
_BATCH_RAYS = 200_000


@dataclass(frozen=True)
class NodeSurfaces:
    """Precomputed surfaces per lobe on a uniform r grid: z and slope of shape
    (phases, nose nodes, time nodes, n). nose_mm: nose radius of each nose node, mm;
    time_s: polishing time of each time node, s."""

    r0: tuple[float, float]
    dr: tuple[float, float]
    n: tuple[int, int]
    z: tuple[np.ndarray, np.ndarray]
    s: tuple[np.ndarray, np.ndarray]
    nose_mm: np.ndarray
    time_s: np.ndarray
    phases: np.ndarray
    source: str = ""

    @property
    def shape(self) -> tuple[int, int, int]:
        return self.z[0].shape[:3]


@dataclass
class Trials:
    """Parameters of each trial (arrays of one length). Units in the names; phase is an index
    into NodeSurfaces.phases; tilt in rad."""

    phase: np.ndarray
    nose_mm: np.ndarray
    time_s: np.ndarray
    tool_x_mm: np.ndarray
    tool_z_mm: np.ndarray
    cam_x_mm: np.ndarray
    cam_y_mm: np.ndarray
    cam_z_mm: np.ndarray
    tilt_x: np.ndarray
    tilt_y: np.ndarray

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
                      tilt_y=z.copy())


@dataclass(frozen=True)
class PixelSample:
    """Sparse pixel sample of one lobe: (u, v) px from the principal point, and weights
    (the number of pixel centres each stands for)."""

    u: np.ndarray
    v: np.ndarray
    weight: np.ndarray


@dataclass
class TrialFigures:
    """Figures per trial (arrays over trials; per-lobe ones have shape (trials, 2))."""

    image_displacement_px_rms: np.ndarray
    image_displacement_px_max: np.ndarray
    slope_error_rad_rms: np.ndarray
    normal_deviation_mm_rms: np.ndarray
    depth_error_pct_rms: np.ndarray
    lost_fraction: np.ndarray
    extra: dict = field(default_factory=dict)


# --------------------------------------------------------------------------------------
# Building the nodes and the sample


def build_nodes(mirror: Mirror, machined: list[list[Profile]], nose_mm: np.ndarray, phases: np.ndarray,
                polish_params, time_s: np.ndarray, *, grid_step: float | None = None,
                source: str = "", progress=None) -> NodeSurfaces:
    """Polish every machined surface (machined[phase][nose node]) and sample the snapshots.

    time_s: snapshot times (s, ascending, >= 0). The grid is the polishing grid.
    """
    from ..polishing import polish_series

    step = polish_params.grid_step_mm if grid_step is None else grid_step
    grids = []
    for k in (0, 1):
        lo, hi = (0.0, mirror.r_junction) if k == 0 else (mirror.r_junction, mirror.r_max)
        n = int(math.ceil((hi - lo) / step)) + 1
        grids.append((lo, (hi - lo) / (n - 1), n))
    P, J, T = len(machined), len(machined[0]), len(time_s)
    z = [np.empty((P, J, T, g[2])) for g in grids]
    s = [np.empty((P, J, T, g[2])) for g in grids]
    for p in range(P):
        for j in range(J):
            snaps = polish_series(machined[p][j], polish_params, time_s)
            for i, prof in enumerate(snaps):
                for k, (lo, dr, n) in enumerate(grids):
                    r = lo + dr * np.arange(n)
                    if k == 1:
                        r[0] = np.nextafter(lo, np.inf)
                    z[k][p, j, i] = prof.z(r)
                    s[k][p, j, i] = prof.slope(r)
            if progress is not None:
                progress.update(1)
    return NodeSurfaces(r0=(grids[0][0], grids[1][0]), dr=(grids[0][1], grids[1][1]),
                        n=(grids[0][2], grids[1][2]), z=(z[0], z[1]), s=(s[0], s[1]),
                        nose_mm=np.asarray(nose_mm, float), time_s=np.asarray(time_s, float),
                        phases=np.asarray(phases, float), source=source)


def pixel_sample(mirror: Mirror, k: int, *, bin_px: float, azimuths: int) -> PixelSample:
    """Image-radius bins of lobe k's annulus x `azimuths` evenly spaced azimuths.

    Each ray's weight is its bin's pixel count / azimuths, so weighted sums over the
    sample estimate sums over all the lobe's pixel centres (exactly, for a radial field).
    """
    px = lobe_pixel_radii(mirror, k, bin_px=bin_px)
    psi = (np.arange(azimuths) + 0.5) * (2.0 * math.pi / azimuths)
    rho, ang = np.meshgrid(px.radius_px, psi, indexing="ij")
    w = np.repeat(px.count[:, None] / azimuths, azimuths, axis=1)
    return PixelSample(u=(rho * np.cos(ang)).ravel(), v=(rho * np.sin(ang)).ravel(), weight=w.ravel())


# --------------------------------------------------------------------------------------
# Evaluation


def evaluate(mirror: Mirror, nodes: NodeSurfaces, trials: Trials, samples: tuple[PixelSample, PixelSample], *,
             depth_range_m: float, depth_points: int = 5, chunk: int = 100, progress=None,
             keep_displacements: bool = False) -> TrialFigures:
    """Figures of every trial. depth_range_m: m. chunk: trials per vectorised batch."""
    n = len(trials)
    disp_rms = np.empty((n, 2))
    disp_max = np.empty((n, 2))
    slope = np.empty((n, 2))
    ndev = np.empty((n, 2))
    depth = np.empty(n)
    lost = np.empty(n)
    kept: list = []
    depth_pix = _depth_pixels(mirror, depth_range_m, depth_points)
    # Each batch holds ~10 arrays of (trials, rays, 3) floats: keep it near 2e5 rays x trials.
    chunk = max(1, min(chunk, _BATCH_RAYS // max(samples[0].u.size, samples[1].u.size, 1)))
    for a in range(0, n, chunk):
        sl = slice(a, min(n, a + chunk))
        tr = trials.take(sl)
        surf = [_trial_surface(nodes, k, tr) for k in (0, 1)]
        origin, rot = _poses(tr)
        n_lost = 0.0
        n_all = 0.0
        for k in (0, 1):
            smp = samples[k]
            disp, ok = _displacement(mirror, nodes, k, surf, tr, origin, rot, smp.u, smp.v)
            w = np.where(ok, smp.weight[None, :], 0.0)
            d2 = np.where(ok, disp**2, 0.0)
            disp_rms[sl, k] = np.sqrt(np.sum(w * d2, axis=1) / np.maximum(np.sum(w, axis=1), 1e-300))
            disp_max[sl, k] = np.max(np.where(ok, disp, 0.0), axis=1)
            n_lost += np.sum(np.where(ok, 0.0, smp.weight[None, :]), axis=1)
            n_all += np.sum(smp.weight)
            slope[sl, k], ndev[sl, k] = _surface_errors(mirror, nodes, k, surf[k], tr)
            if keep_displacements:
                kept.append((k, sl, disp, ok))
        lost[sl] = n_lost / n_all
        depth[sl] = _depth_error(mirror, nodes, surf, tr, origin, rot, depth_pix)
        if progress is not None:
            progress.update(sl.stop - sl.start)
    fig = TrialFigures(disp_rms, disp_max, slope, ndev, depth, lost)
    if keep_displacements:
        fig.extra["displacements"] = kept
    return fig


def _interp_weights(x: np.ndarray, nodes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Lower node index and weight of the upper node (linear; extrapolates past the ends)."""
    if nodes.size == 1:
        return np.zeros(x.shape, dtype=np.intp), np.zeros(x.shape)
    j = np.clip(np.searchsorted(nodes, x, side="right") - 1, 0, nodes.size - 2)
    span = nodes[j + 1] - nodes[j]
    w = np.where(span > 0, (x - nodes[j]) / np.where(span > 0, span, 1.0), 0.0)
    return j, w


def _trial_surface(nodes: NodeSurfaces, k: int, tr: Trials) -> tuple[np.ndarray, np.ndarray]:
    """(z, slope) of lobe k of each trial on the node grid (trials, n): bilinear in nose and time."""
    j, wj = _interp_weights(tr.nose_mm, nodes.nose_mm)
    i, wt = _interp_weights(tr.time_s, nodes.time_s)
    J, T = nodes.shape[1], nodes.shape[2]
    j1 = np.minimum(j + 1, J - 1)
    i1 = np.minimum(i + 1, T - 1)
    p = tr.phase
    out = []
    for arr in (nodes.z[k], nodes.s[k]):
        v = ((1 - wj) * (1 - wt))[:, None] * arr[p, j, i] + (wj * (1 - wt))[:, None] * arr[p, j1, i] \
            + ((1 - wj) * wt)[:, None] * arr[p, j, i1] + (wj * wt)[:, None] * arr[p, j1, i1]
        out.append(v)
    z, s = out
    return z + tr.tool_z_mm[:, None], s


def _lookup(nodes: NodeSurfaces, k: int, grid: np.ndarray, rows: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Linear interpolation of per-trial grid values (trials, n) at radii q (trials, m)."""
    g = (q - nodes.r0[k]) / nodes.dr[k]
    i0 = np.clip(np.floor(g).astype(np.intp), 0, nodes.n[k] - 2)
    f = g - i0
    return grid[rows, i0] * (1.0 - f) + grid[rows, i0 + 1] * f


def _poses(tr: Trials) -> tuple[np.ndarray, np.ndarray]:
    """Pinhole positions (trials, 3) and rotations R = R_y(ty) R_x(tx) (trials, 3, 3)."""
    origin = np.stack([tr.cam_x_mm, tr.cam_y_mm, tr.cam_z_mm], axis=1)
    cx, sx, cy, sy = np.cos(tr.tilt_x), np.sin(tr.tilt_x), np.cos(tr.tilt_y), np.sin(tr.tilt_y)
    zero, one = np.zeros_like(cx), np.ones_like(cx)
    rx = np.stack([np.stack([one, zero, zero], -1), np.stack([zero, cx, -sx], -1),
                   np.stack([zero, sx, cx], -1)], axis=1)
    ry = np.stack([np.stack([cy, zero, sy], -1), np.stack([zero, one, zero], -1),
                   np.stack([-sy, zero, cy], -1)], axis=1)
    return origin, ry @ rx


def _trace(mirror: Mirror, nodes: NodeSurfaces, k: int, surfs, tr: Trials, origin, rot, u, v):
    """Hit points, reflected unit directions (trials, m, 3), and masks (trials, m): ok, the
    ray lands on lobe k (not the wall, the other lobe, past the rim); blocked, leaving the
    recessed inner lobe it runs into the step wall (vignetted).
    """
    surf = surfs[k]
    cam = mirror.camera
    dc = np.stack([u * cam.t_pixel, v * cam.t_pixel, np.full_like(u, cam.f)], axis=-1)
    dc = dc / np.linalg.norm(dc, axis=-1, keepdims=True)
    d = np.einsum("tij,mj->tmi", rot, dc)  # (trials, m, 3)
    o = origin[:, None, :]
    z_grid, s_grid = surf
    rows = np.arange(len(tr))[:, None]
    lo, hi = (0.0, mirror.r_junction) if k == 0 else (mirror.r_junction, mirror.r_max)
    dx = tr.tool_x_mm[:, None]
    # Start on the vertex height of the lobe; iterate s = (Z(rho(s)) - o_z) / d_z.
    s = (mirror.lobes[k].vertex_z - o[..., 2]) / d[..., 2]
    for _ in range(_MAX_ITER):
        x = o[..., 0] + s * d[..., 0]
        y = o[..., 1] + s * d[..., 1]
        q = np.clip(np.abs(np.hypot(x, y) - dx), lo, hi)
        s_new = (_lookup(nodes, k, z_grid, rows, q) - o[..., 2]) / d[..., 2]
        done = np.max(np.abs(s_new - s)) < 1e-11
        s = s_new
        if done:
            break
    p = o + s[..., None] * d
    rho = np.hypot(p[..., 0], p[..., 1])
    q_raw = rho - dx
    ok = (np.abs(q_raw) >= lo - _LOBE_SLACK) & (np.abs(q_raw) <= hi + _LOBE_SLACK)
    if k == 1:
        ok &= np.abs(q_raw) > lo
    q = np.clip(np.abs(q_raw), lo, hi)
    slope = _lookup(nodes, k, s_grid, rows, q) * np.sign(np.where(q_raw == 0, 1.0, q_raw))
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
        z_top = _lookup(nodes, 1, surfs[1][0], np.arange(len(tr)), q_top)
        blocked = z_cross > z_top[:, None]
    else:
        blocked = np.zeros(ok.shape, bool)
    return p, out, ok, blocked


def _displacement(mirror, nodes, k, surfs, tr, origin, rot, u, v):
    """|image displacement| (px) of each sample pixel of each trial, and validity."""
    # Image figures on the sample's pixels (the exact design's unvignetted ones) wherever the
    # made ray lands on the lobe: the rule of radial.radial_figures and optics.distortion.
    _, out, ok, _ = _trace(mirror, nodes, k, surfs, tr, origin, rot, u, v)
    horiz = np.hypot(out[..., 0], out[..., 1])
    rho_id = ideal_radius_px(mirror.lobes[k], mirror.camera, np.arctan2(out[..., 2], horiz))
    with np.errstate(invalid="ignore"):
        cu, cv = out[..., 0] / horiz, out[..., 1] / horiz
    disp = np.hypot(rho_id * cu - u[None, :], rho_id * cv - v[None, :])
    ok = ok & np.isfinite(disp)
    return np.where(ok, disp, np.nan), ok


def _surface_errors(mirror, nodes, k, surf, tr, stride: int = 4):
    """RMS slope error (rad) and RMS normal deviation (mm) of lobe k per trial, uniform in r
    over the extent the image uses (radial.used_extent)."""
    lobe = mirror.lobes[k]
    r = nodes.r0[k] + nodes.dr[k] * np.arange(0, nodes.n[k], stride)
    if k == 1:
        r[0] = np.nextafter(r[0], np.inf)
    u_lo, u_hi = used_extent(mirror, k)
    r = r[(r >= u_lo) & (r <= u_hi)]
    lo, hi = (0.0, mirror.r_junction) if k == 0 else (mirror.r_junction, mirror.r_max)
    rows = np.arange(len(tr))[:, None]
    q_raw = r[None, :] - tr.tool_x_mm[:, None]
    q = np.clip(np.abs(q_raw), lo, hi)
    z = _lookup(nodes, k, surf[0], rows, q)
    s = _lookup(nodes, k, surf[1], rows, q) * np.sign(np.where(q_raw == 0, 1.0, q_raw))
    s_ex = lobe.slope(r)[None, :]
    slope_err = np.arctan(s) - np.arctan(s_ex)
    ndev = (z - lobe.z(r)[None, :]) / np.sqrt(1.0 + s_ex**2)
    return np.sqrt(np.mean(slope_err**2, axis=1)), np.sqrt(np.mean(ndev**2, axis=1))


def _depth_pixels(mirror: Mirror, range_m: float, n_elev: int, n_azimuth: int = 4):
    """World points at range_m from the stereo centre and the exact pixels (u, v) of each lobe."""
    elev = band_elevations(mirror, n_elev) if n_elev > 1 else np.array([np.mean(mirror.common_band)])
    psi = np.arange(n_azimuth) * (2.0 * math.pi / n_azimuth)
    e, a = np.meshgrid(elev, psi, indexing="ij")
    e, a = e.ravel(), a.ravel()
    rng = range_m * 1e3
    zc = stereo_centre_z(mirror)
    w = np.stack([rng * np.cos(e) * np.cos(a), rng * np.cos(e) * np.sin(a), zc + rng * np.sin(e)], -1)
    pix = []
    for lobe in mirror.lobes:
        phi = np.arctan2(w[:, 2] - lobe.focus_z, rng * np.cos(e))
        rho = ideal_radius_px(lobe, mirror.camera, phi)
        pix.append((rho * np.cos(a), rho * np.sin(a)))
    unit = np.stack([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)], -1)
    return {"w": w, "unit": unit, "range": rng, "zc": zc, "pix": pix}


def _depth_error(mirror, nodes, surf, tr, origin, rot, dp) -> np.ndarray:
    """RMS over the depth points of |depth error| (%) of each trial, each point capped at
    optics.stereo.FAILED_PCT (a lost point counts at the cap)."""
    from ..optics.stereo import triangulate

    rays = []
    for k in (0, 1):
        u, v = dp["pix"][k]
        p, o, ok, blocked = _trace(mirror, nodes, k, surf, tr, origin, rot, u, v)
        rays.append((p, o, ok & ~blocked))  # a vignetted ray sees no point
    x = triangulate(rays[0][0], rays[0][1], rays[1][0], rays[1][1])
    r_made = np.sum((x - np.array([0.0, 0.0, dp["zc"]])) * dp["unit"][None], axis=-1)
    err = 100.0 * (r_made - dp["range"]) / dp["range"]
    # A point a lobe cannot see counts as a total failure, not as a success; so does one whose
    # rays cross (nearly) parallel or behind, where the error diverges: optics.stereo's cap.
    err = np.where(rays[0][2] & rays[1][2], err, np.nan)
    return np.sqrt(np.mean(capped_abs_error(err) ** 2, axis=1))
