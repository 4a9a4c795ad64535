"""Each lobe as the unified camera model that vision stacks load, designed and as made.

A perspective camera at the outer focus of a hyperbolic lobe is a central catadioptric
camera, exactly the unified model of Geyer-Daniilidis / Barreto / Mei (C. Mei and P. Rives,
"Single view point omnidirectional camera calibration from planar grids", ICRA 2007), which
OpenCV's `cv2.omnidir` and Kalibr's `omni` implement. With e = sqrt(a^2 + b^2) (Eq. 3) and
f_px = f / t_pixel:

    xi = 2 a e / (a^2 + e^2),   gamma = f_px b^2 / (a^2 + e^2)

(Mei's table with the foci 2e apart and the latus rectum 2 b^2 / a, since
sqrt(4 e^2 + b^4 / a^2) = (a^2 + e^2) / a.) A point X of the lobe frame projects to

    X_s = X / |X|,   m = (x_s, y_s) / (z_s + xi),   m_d = m (1 + k1 |m|^2 + k2 |m|^4),
    pixel = (gamma m_d,x + c_x, gamma m_d,y + c_y)

and the design has k1 = k2 = 0. For a world direction at elevation phi above F1's horizon
this gives the image radius gamma cos(phi) / (xi - sin(phi)), which is the exact lobe's
b^2 f_px cos(phi) / (2 a e - (a^2 + e^2) sin(phi)) (optics.radial.ideal_radius_px) term
for term: the design is a calibration, exact.

Frames. The lobe frame has its origin at the lobe's viewpoint F1, x and y along the
camera's (x right along the image columns, y down the rows) and z from F1 down the axis
toward the camera: X_lobe = diag(1, 1, -1) (X_cam - F1). It is a reflection of the camera
frame (a mirror reverses handedness); a right-handed frame would need f_v < 0.
Pixels follow OpenCV: the centre of the top-left pixel is (0, 0), so the sensor centre is
((W - 1) / 2, (H - 1) / 2) and camera.py's image point (u, v) is (u + (W - 1) / 2,
v + (H - 1) / 2).

A made (machined, polished) lobe has no single viewpoint. Its pixel <-> world ray pairs
come from the exact tracer (optics.trace) over the lobe's usable annulus; each ray's world
point is taken at a range R from F1 (a robot sees a room, not infinity; R = inf takes the
ray's direction). The reprojection error (ARCHITECTURE.md) of a model is its pixel for
that world point against the traced pixel. `refit` fits xi, gamma, k1, k2 to the pairs
(scipy least_squares); the principal point stays at the sensor centre for an aligned
camera (a surface of revolution on the axis: the pairs are symmetric about it) and is
fitted too for a misaligned one ([camera_pose]).

Millimetres and radians inside; pixels where a name says so.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from ..design import Mirror
from ..errors import InputError
from ..inputs import check_type, short
from ..profile import Profile
from .camera import ALIGNED, CameraPose
from .radial import RADII_PER_LOBE, ideal_radius_px, in_lobe_range, lobe_pixel_radii, weighted_stats
from .trace import Fate, trace_pixels

#: Range (mm) from F1 at which a made mirror's rays are given world points: 2 m, the
#: report's stereo range.
DEFAULT_RANGE_MM = 2000.0
#: Pixel pitch (px) of the sample grid of a misaligned camera (aligned: every pixel), and
#: the most pixel centres a lobe's grid may sample: a lobe of more pixels than
#: MISALIGNED_SAMPLES x 4^2 is sampled at the wider pitch that keeps it to about that
#: many (misaligned_stride_px), so a 12-megapixel lobe (4.1 million pixel centres; 12 px)
#: costs what the paper's does (491,292 and 248,020 centres: 4 px, as before). Its
#: figures then sample the lobe's facets as the paper's grid does: on the 12-MP design's
#: outer lobe (uniform528, tilted 0.1 deg) halving or doubling MISALIGNED_SAMPLES moved
#: the reprojection errors by 0.6 % at most (measured; not a test: 7 s of CPU).
MISALIGNED_STRIDE_PX = 4
MISALIGNED_SAMPLES = 32_000
#: Fewest usable pixel radii (aligned) or samples (misaligned) a lobe needs for a fit.
MIN_SAMPLES = 16


@dataclass(frozen=True)
class UnifiedModel:
    """The unified (Mei) camera model of one lobe, as OpenCV's omnidir and Kalibr's omni
    take it. Pixels in OpenCV's convention (top-left pixel centre at (0, 0)).

    name: the lobe ("inner", "outer"). xi: mirror parameter (dimensionless). fu, fv:
    generalised focal lengths gamma, px. cx, cy: principal point, px. k1, k2: OpenCV's
    radial distortion of the normalised plane (dimensionless; 0 for the design).
    image_size: (width, height), px. annulus_px: (inner, outer) radius of the valid image
    annulus about the sensor centre, px (the lost ring and the band the step wall blocks
    left out). viewpoint_z: height of the lobe's viewpoint F1 in the camera frame, mm.
    """

    name: str
    xi: float
    fu: float
    fv: float
    cx: float
    cy: float
    image_size: tuple[int, int]
    annulus_px: tuple[float, float]
    viewpoint_z: float
    k1: float = 0.0
    k2: float = 0.0

    @property
    def camera_matrix(self) -> np.ndarray:
        """OpenCV's K (3 x 3), px."""
        return np.array([[self.fu, 0.0, self.cx], [0.0, self.fv, self.cy], [0.0, 0.0, 1.0]])

    @property
    def distortion(self) -> np.ndarray:
        """OpenCV omnidir's D = (k1, k2, p1, p2), shape (1, 4); no tangential terms."""
        return np.array([[self.k1, self.k2, 0.0, 0.0]])

    def project(self, points: np.ndarray) -> np.ndarray:
        """Pixels (..., 2) of points (..., 3) of the lobe frame (mm, or directions).

        NaN where the point lies beyond the model's field (z_s + xi <= 0).
        """
        p = np.asarray(points, dtype=float)
        s = p / np.linalg.norm(p, axis=-1, keepdims=True)
        den = s[..., 2] + self.xi
        with np.errstate(divide="ignore", invalid="ignore"):
            m = s[..., :2] / np.where(den > 0, den, np.nan)[..., None]
        r2 = np.sum(m * m, axis=-1, keepdims=True)
        md = m * (1.0 + self.k1 * r2 + self.k2 * r2 * r2)
        return np.stack([self.fu * md[..., 0] + self.cx, self.fv * md[..., 1] + self.cy], axis=-1)

    def back_project(self, pixels: np.ndarray) -> np.ndarray:
        """Unit directions (..., 3) in the lobe frame of pixels (..., 2) (Mei's lifting)."""
        px = np.asarray(pixels, dtype=float)
        md = np.stack([(px[..., 0] - self.cx) / self.fu, (px[..., 1] - self.cy) / self.fv], axis=-1)
        rd = np.linalg.norm(md, axis=-1)
        ru = rd.copy()
        if self.k1 or self.k2:
            # Invert r_d = r_u (1 + k1 r_u^2 + k2 r_u^4) by Newton from r_u = r_d.
            for _ in range(50):
                g = ru * (1 + self.k1 * ru**2 + self.k2 * ru**4) - rd
                dg = 1 + 3 * self.k1 * ru**2 + 5 * self.k2 * ru**4
                step = g / dg
                ru = ru - step
                if np.all(np.abs(step) < 1e-15):
                    break
        with np.errstate(divide="ignore", invalid="ignore"):
            scale = np.where(rd > 0, ru / rd, 1.0)
        m = md * scale[..., None]
        r2 = ru * ru
        factor = (self.xi + np.sqrt(1.0 + (1.0 - self.xi**2) * r2)) / (1.0 + r2)
        return np.stack([factor * m[..., 0], factor * m[..., 1], factor - self.xi], axis=-1)

    def radius_px(self, elevation: np.ndarray) -> np.ndarray:
        """Image radius (px) of a world direction at this elevation (rad) above F1's horizon
        (fu = fv and no distortion: gamma cos(phi) / (xi - sin(phi)))."""
        phi = np.asarray(elevation, dtype=float)
        return self.fu * np.cos(phi) / (self.xi - np.sin(phi))


@dataclass(frozen=True)
class Correspondences:
    """Traced pixel <-> world point pairs of one lobe of a made mirror.

    pixels: (N, 2) px, OpenCV convention. points: (N, 3) world points in the lobe frame, mm
    (unit directions when range_mm is inf). weight: pixel centres each pair stands for.
    excluded: pixel centres of the design's usable annulus whose made ray misses the lobe
    or runs into the step wall. in_range: the pairs whose ray stays in the lobe's range
    (optics.radial.in_lobe_range; None: all).
    """

    lobe: int
    pixels: np.ndarray
    points: np.ndarray
    weight: np.ndarray
    excluded: int
    range_mm: float
    aligned: bool
    in_range: np.ndarray | None = None

    def within_range(self) -> "Correspondences":
        """The pairs whose ray stays in the lobe's range; the others counted excluded."""
        if self.in_range is None or self.in_range.all():
            return self
        keep = self.in_range
        return replace(self, pixels=self.pixels[keep], points=self.points[keep], weight=self.weight[keep],
                       excluded=self.excluded + int(round(np.sum(self.weight[~keep]))), in_range=None)


# --------------------------------------------------------------------------------------
# Public entry points


def design_model(mirror: Mirror, k: int, zones=None) -> UnifiedModel:
    """The unified model of lobe k (0 inner, 1 outer) of the design (see the module doc);
    its valid annulus the zones' used zone when given (valid_annulus_px). k: 0, 1 or the
    lobe's name ("inner", "outer")."""
    check_type(mirror, "design_model: mirror", Mirror, "a Mirror (settings.mirror())")
    k = lobe_index(k, "design_model: k")
    lobe = mirror.lobes[k]
    cam = mirror.camera
    f_px = cam.f / cam.t_pixel
    d = lobe.a**2 + lobe.e**2
    gamma = f_px * lobe.b**2 / d
    w, h = (int(n) for n in cam.sensor_px)
    return UnifiedModel(name=lobe.name, xi=2.0 * lobe.a * lobe.e / d, fu=gamma, fv=gamma,
                        cx=(w - 1) / 2.0, cy=(h - 1) / 2.0, image_size=(w, h),
                        annulus_px=valid_annulus_px(mirror, k, zones), viewpoint_z=lobe.focus_z)


def lobe_index(k: object, what: str) -> int:
    """A lobe given as 0 / 1 or by its name, as its index; InputError naming `what`."""
    names = {"inner": 0, "outer": 1}
    if isinstance(k, str) and k.lower() in names:
        return names[k.lower()]
    if not isinstance(k, bool) and isinstance(k, (int, np.integer)) and int(k) in (0, 1):
        return int(k)
    raise InputError(f"{what} = {short(k)}: allowed 0 (inner), 1 (outer) or the name 'inner', 'outer'")


def valid_annulus_px(mirror: Mirror, k: int, zones=None) -> tuple[float, float]:
    """(inner, outer) image radius (px) of lobe k's valid annulus about the sensor centre:
    the inner disc up to where the step wall starts to block its world rays; the outer
    annulus from the lost ring to the outer rim. zones (optics.zones.Zones): the lobe's
    used zone, which also leaves out the ring the nose cannot reach at the junction."""
    if zones is not None:
        lo, hi = zones.lobes[k].used_px
        return (float(lo), float(hi))
    radii = mirror.image_radii_px
    if k == 0:
        return (0.0, float(radii["inner_blocked_by_step"][0]))
    lo, hi = radii["outer_annulus"]
    return (float(lo), float(hi))


def to_lobe_frame(points_cam: np.ndarray, viewpoint_z: float) -> np.ndarray:
    """Camera-frame points (..., 3), mm, to the lobe frame: diag(1, 1, -1) (X - F1)."""
    p = np.array(points_cam, dtype=float, copy=True)
    p[..., 2] = viewpoint_z - p[..., 2]
    return p


def from_lobe_frame(points_lobe: np.ndarray, viewpoint_z: float) -> np.ndarray:
    """Lobe-frame points (..., 3), mm, to the camera frame (the map is its own inverse
    up to F1)."""
    return to_lobe_frame(points_lobe, viewpoint_z)


def trace_correspondences(profile: Profile, mirror: Mirror, k: int, *,
                          range_mm: float = DEFAULT_RANGE_MM, pose: CameraPose = ALIGNED, zones=None,
                          max_radii: int = RADII_PER_LOBE) -> Correspondences:
    """Pixel <-> world point pairs of lobe k of a made surface, by the exact tracer.

    Pixels: the design's usable annulus of lobe k (optics.radial.lobe_pixel_radii: the
    pixel centres whose exact ray lands on the lobe unobstructed). Aligned camera: every
    distinct image radius once, along the +u half-row, weighted by the pixel centres that
    share it (exact for a surface of revolution), at most max_radii of them. Misaligned:
    every misaligned_stride_px-th pixel centre in each direction, traced in 3-D. Pairs
    whose made ray misses the lobe or runs into the step wall are left out (counted in
    `excluded`). range_mm: the world point's distance from F1 along the traced ray (mm;
    inf: the ray's direction).
    zones: optics.zones.Zones: the lobe's used zone only (the fillet ring left out).
    max_radii: the most image radii (aligned) a lobe is traced at (radial.RADII_PER_LOBE).
    """
    if not (range_mm > 0):
        raise InputError(f"--range-m {range_mm / 1000.0!r}: must be > 0 (inf: directions)")
    cam = mirror.camera
    lobe = mirror.lobes[k]
    # misaligned: the exact radii, which pick the grid's pixel centres (_grid_samples)
    px = lobe_pixel_radii(mirror, k, zones=zones, max_radii=max_radii if pose.aligned else None)
    if pose.aligned:
        xy = np.stack([px.radius_px, np.zeros_like(px.radius_px)], axis=-1)
        weight = px.count.astype(float)
    else:
        xy = _grid_samples(mirror, px.radius_px, misaligned_stride_px(px))
        weight = np.ones(xy.shape[0])
    hits = trace_pixels(profile, cam, xy, pose=pose)
    use = (hits.fate == (Fate.INNER if k == 0 else Fate.OUTER)) & ~hits.blocked
    # a ray that left the lobe's range has no pixel in the design's model (in_range)
    d = hits.direction[use]
    in_range = in_lobe_range(mirror, k, ideal_radius_px(lobe, cam, np.arctan2(d[:, 2], np.hypot(d[:, 0], d[:, 1]))))
    f1 = np.array([0.0, 0.0, lobe.focus_z])
    p, o = hits.point[use], hits.direction[use]
    if math.isinf(range_mm):
        world = o
        lobe_pts = world * np.array([1.0, 1.0, -1.0])
    else:
        q = p - f1
        b = np.sum(q * o, axis=-1)
        c = np.sum(q * q, axis=-1) - range_mm**2
        lam = -b + np.sqrt(b * b - c)  # the far root: the point ahead of the mirror
        lobe_pts = to_lobe_frame(p + lam[:, None] * o, lobe.focus_z)
    w, h = cam.sensor_px
    pixels = xy[use] + np.array([(w - 1) / 2.0, (h - 1) / 2.0])
    return Correspondences(lobe=k, pixels=pixels, points=lobe_pts, weight=weight[use],
                           excluded=int(round(np.sum(weight[~use]))), range_mm=float(range_mm),
                           aligned=pose.aligned, in_range=in_range)


def reprojection_error(model: UnifiedModel, corr: Correspondences) -> dict:
    """{"rms", "max"} (px) of |model pixel of each world point - traced pixel|, weighted by
    pixel centres."""
    err = np.linalg.norm(model.project(corr.points) - corr.pixels, axis=-1)
    return weighted_stats(err, corr.weight)


#: A refit stalls (stops, Stalled) when its cost fell by at most this fraction over this
#: many iterations.
STALL_FRACTION = 1e-3
STALL_ITERATIONS = 10


def refit(model: UnifiedModel, corr: Correspondences, *, fit_centre: bool | None = None) -> UnifiedModel:
    """The unified model (xi, gamma = fu = fv, k1, k2) refitted to a made lobe's pairs.

    Weighted least squares of the pixel residuals (weights: the pixel centres a pair stands
    for). The parameters trade off along a long flat valley, so xi is first found by variable
    projection (for fixed xi the pixels are linear in gamma, gamma k1, gamma k2 and the
    centre: a bounded scalar search over xi of linear least squares), then
    scipy.optimize.least_squares (dogbox, analytic Jacobian, xi kept where every point
    projects) polishes all parameters together. fit_centre: also fit the principal point
    (default: only for a misaligned camera; an aligned one keeps the sensor centre).
    """
    from scipy.optimize import least_squares

    if corr.pixels.shape[0] < MIN_SAMPLES:
        raise InputError(f"lobe {model.name}: {corr.pixels.shape[0]} usable pixels, too few to refit "
                         f"the camera model (at least {MIN_SAMPLES})")
    centre = (not corr.aligned) if fit_centre is None else fit_centre
    sw = np.sqrt(corr.weight)[:, None]
    s = corr.points / np.linalg.norm(corr.points, axis=-1, keepdims=True)
    n_par = 6 if centre else 4

    def build(x: np.ndarray) -> UnifiedModel:
        cx, cy = (x[4], x[5]) if centre else (model.cx, model.cy)
        return replace(model, xi=float(x[0]), fu=float(x[1]), fv=float(x[1]), k1=float(x[2]),
                       k2=float(x[3]), cx=float(cx), cy=float(cy))

    def normalised(x: np.ndarray):
        den = s[:, 2] + x[0]
        with np.errstate(divide="ignore", invalid="ignore"):
            m = s[:, :2] / np.where(den > 0, den, np.nan)[:, None]
        r2 = np.sum(m * m, axis=-1, keepdims=True)
        return den, m, r2

    def residuals(x: np.ndarray) -> np.ndarray:
        r = (build(x).project(corr.points) - corr.pixels) * sw
        return np.nan_to_num(r, nan=1e6).ravel()

    def jacobian(x: np.ndarray) -> np.ndarray:
        # pixel = gamma m (1 + k1 r2 + k2 r2^2) + c, m = s_xy / (s_z + xi), r2 = |m|^2;
        # d m / d xi = -m / (s_z + xi), so d pixel / d xi = -gamma m (1 + 3 k1 r2 + 5 k2 r2^2) / (s_z + xi).
        den, m, r2 = normalised(x)
        g, k1, k2 = x[1], x[2], x[3]
        jac = np.zeros((m.shape[0], 2, n_par))
        jac[:, :, 0] = -g * m * (1 + 3 * k1 * r2 + 5 * k2 * r2 * r2) / den[:, None]
        jac[:, :, 1] = m * (1 + k1 * r2 + k2 * r2 * r2)
        jac[:, :, 2] = g * m * r2
        jac[:, :, 3] = g * m * r2 * r2
        if centre:
            jac[:, 0, 4] = 1.0
            jac[:, 1, 5] = 1.0
        return np.nan_to_num(jac * sw[:, :, None]).reshape(-1, n_par)

    def linear_part(xi: float) -> tuple[np.ndarray, float]:
        # For a fixed xi the pixel is linear in gamma, gamma k1, gamma k2 (and the centre):
        # variable projection. The valley xi <-> gamma <-> k1, k2 is long and flat (the
        # parameters trade off almost exactly), which plain least squares crawls along.
        den, m, r2 = normalised(np.array([xi]))
        cols = [m, m * r2, m * r2 * r2]
        if centre:
            cols += [np.broadcast_to([1.0, 0.0], m.shape), np.broadcast_to([0.0, 1.0], m.shape)]
        a = np.stack([c * sw for c in cols], axis=-1).reshape(-1, len(cols))
        b = ((corr.pixels - ([0.0, 0.0] if centre else [model.cx, model.cy])) * sw).ravel()
        coef, *_ = np.linalg.lstsq(a, b, rcond=None)
        return coef, float(np.sum((a @ coef - b) ** 2))

    from scipy.optimize import minimize_scalar

    xi_lo = max(1e-6, float(-np.min(s[:, 2]))) + 1e-9  # every point in front: s_z + xi > 0
    best = minimize_scalar(lambda xi: linear_part(xi)[1], bounds=(xi_lo, max(10.0, 4 * model.xi)),
                           method="bounded", options={"xatol": 1e-12})
    candidates = [xi for xi in (model.xi, float(best.x)) if xi >= xi_lo]
    start = min(candidates, key=lambda xi: linear_part(xi)[1])
    coef, _ = linear_part(start)
    x0 = [start, coef[0], coef[1] / coef[0], coef[2] / coef[0]] + (list(coef[3:5]) if centre else [])
    lo = [xi_lo, 1e-6, -np.inf, -np.inf] + ([-np.inf, -np.inf] if centre else [])
    if not x0[1] > lo[1]:  # no camera's gamma (pairs that leave the valley's shape): the design's start
        x0 = [max(model.xi, xi_lo), model.fu, model.k1, model.k2] + ([model.cx, model.cy] if centre else [])
    sol = least_squares(residuals, np.asarray(x0, float), jac=jacobian, bounds=(lo, np.inf),
                        method="dogbox", x_scale="jac", xtol=1e-15, ftol=1e-15, gtol=1e-15, max_nfev=200,
                        callback=Stalled())
    return build(sol.x)


class Stalled:
    """least_squares' callback: stop a fit whose cost fell by at most STALL_FRACTION over
    its last STALL_ITERATIONS iterations. A lobe the model fits converges from the variable
    projection's start in a few (the paper's: 2) or keeps gaining (another hyperbola's
    outer lobe: 98 evaluations to its closed form to 1e-8); one it cannot fit (the 6 mm
    lens's recessed outer lobe, ~30 px RMS) crawls along the model's flat valley instead:
    0.2 % of its cost over 150 evaluations and ~5 s of CPU, xi drifting from 12 to 20."""

    def __init__(self) -> None:
        self.costs: list[float] = []

    def __call__(self, intermediate_result) -> None:
        self.costs.append(float(intermediate_result.cost))
        if len(self.costs) > STALL_ITERATIONS:
            old, new = self.costs[-1 - STALL_ITERATIONS], self.costs[-1]
            if old - new <= STALL_FRACTION * old:
                raise StopIteration


def made_lobe_figures(profile: Profile, mirror: Mirror, k: int, *, range_mm: float = DEFAULT_RANGE_MM,
                      pose: CameraPose = ALIGNED, zones=None, max_radii: int = RADII_PER_LOBE) -> dict:
    """One lobe of a made surface: the design model's reprojection error and the refit.

    The design model's figure and the pixel counts leave out the pairs whose ray left the
    lobe's range (lost, never a reprojection error past the annulus: optics.radial); the
    refit, what a calibration of the made part recovers, is fitted to and judged on every
    pair that lands, as the tolerance analysis's calibration is.
    Returns {"name", "pixels", "pixels_excluded", "design": {"reprojection_error_px"},
    "refit": {model parameters, "principal_point", "reprojection_error_px"}}. Raises
    InputError when no camera pixel of the lobe's annulus sees the lobe of this surface.
    max_radii: see trace_correspondences.
    """
    design = design_model(mirror, k, zones)
    landed = trace_correspondences(profile, mirror, k, range_mm=range_mm, pose=pose, zones=zones, max_radii=max_radii)
    corr = landed.within_range()
    n = int(round(np.sum(corr.weight)))
    if corr.pixels.shape[0] < MIN_SAMPLES:
        what = "pixels" if corr.aligned else "pixels of the misaligned camera's sample grid"
        raise InputError(
            f"no camera pixel sees its {design.name} lobe ({n} of {n + corr.excluded} {what} of the "
            "lobe's annulus land on it unobstructed): the surface or [camera_pose] is off the design")
    fitted = refit(design, landed)
    return {
        "name": design.name,
        "pixels": n,
        "pixels_excluded": corr.excluded,
        "design": {"reprojection_error_px": reprojection_error(design, corr)},
        "refit": {**model_dict(fitted),
                  "principal_point": "fixed at the sensor centre" if corr.aligned else "fitted",
                  "reprojection_error_px": reprojection_error(fitted, landed)},
    }


def made_figures(profile: Profile, mirror: Mirror, *, range_mm: float = DEFAULT_RANGE_MM,
                 pose: CameraPose = ALIGNED, zones=None) -> dict:
    """made_lobe_figures of both lobes, inner first: {"range_m", "lobes": [...]} (and
    "zones" when given: the pixels the figures cover)."""
    out = {"range_m": range_mm / 1000.0,
           "lobes": [made_lobe_figures(profile, mirror, k, range_mm=range_mm, pose=pose, zones=zones)
                     for k in (0, 1)]}
    if zones is not None:
        out["zones"] = zones.as_dict()
    return out


def calibration_figures(mirror: Mirror, made: dict[str, Profile], *,
                        range_mm: float = DEFAULT_RANGE_MM, zones=None) -> dict:
    """The report's calibration section: the design models (design_model_figures) and, for each
    made mirror (name -> profile; aligned camera), made_figures, over the zones' used zone."""
    return {"design": design_model_figures(mirror, zones),
            "made": {name: made_figures(p, mirror, range_mm=range_mm, zones=zones) for name, p in made.items()}}


def model_dict(model: UnifiedModel) -> dict:
    """The model's parameters as plain data (px, dimensionless)."""
    return {"xi": model.xi, "gamma_px": model.fu, "fu_px": model.fu, "fv_px": model.fv,
            "cx_px": model.cx, "cy_px": model.cy, "k1": model.k1, "k2": model.k2}


def design_model_figures(mirror: Mirror, zones=None) -> dict:
    """Both lobes' design models, annuli and the viewpoints' axial offset (for --json and
    the report): {"frame", "lobes": [...], "t_cn_cnm1_mm"}."""
    lobes = []
    for k in (0, 1):
        m = design_model(mirror, k, zones)
        lobes.append({"name": m.name, **model_dict(m),
                      "annulus_px": {"min": m.annulus_px[0], "max": m.annulus_px[1]},
                      "viewpoint_z_mm": m.viewpoint_z,
                      "image_size_px": list(m.image_size)})
    return {"frame": "X_lobe = diag(1, 1, -1) (X_cam - F1): origin at the lobe's viewpoint F1, "
                     "z down the axis toward the camera (a reflection of the camera frame); "
                     "pixels in OpenCV's convention (top-left pixel centre at (0, 0))",
            "lobes": lobes,
            "t_cn_cnm1_mm": [0.0, 0.0, mirror.outer.focus_z - mirror.inner.focus_z]}


def misaligned_stride_px(px) -> int:
    """The misaligned grid's pitch (px) for a lobe of these pixel radii (PixelRadii): at
    least MISALIGNED_STRIDE_PX, wide enough to sample about MISALIGNED_SAMPLES centres."""
    return max(MISALIGNED_STRIDE_PX, math.ceil(math.sqrt(float(np.sum(px.count)) / MISALIGNED_SAMPLES)))


def _grid_samples(mirror: Mirror, radii_px: np.ndarray, stride: int) -> np.ndarray:
    """Image points (N, 2) (u, v px from the sensor centre) of every stride-th pixel centre
    whose radius is one of radii_px (a lobe's usable radii)."""
    w, h = (int(n) for n in mirror.camera.sensor_px)
    u = np.arange(0, w, stride) + 0.5 - w / 2.0
    v = np.arange(0, h, stride) + 0.5 - h / 2.0
    uu, vv = np.meshgrid(u, v, indexing="xy")
    # 4 (u^2 + v^2) is an integer for pixel centres: exact membership (as radial does).
    q = np.rint(4.0 * (uu**2 + vv**2)).astype(np.int64).ravel()
    keys = np.rint(4.0 * np.asarray(radii_px) ** 2).astype(np.int64)
    keep = np.isin(q, keys)
    return np.stack([uu.ravel()[keep], vv.ravel()[keep]], axis=-1)
