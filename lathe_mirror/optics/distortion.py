"""What a made mirror does to the image, pixel by pixel, against the exact design.

Figures (ARCHITECTURE.md, "Shared definitions"), per pixel centre of each lobe:

* ray_deviation (reported in deg): angle between the reflected rays of the made and the
  exact surface for the same camera pixel.
* image_displacement (px): the made surface sends the pixel's ray to a world direction
  u; the exact lobe k would image u at the point where the ray from its viewpoint F1
  along u meets its sheet. With F1 the upper focus of (z - e)^2 / a^2 - r^2 / b^2 = 1,
  the focal polar equation of the near branch gives that point in closed form,

      P = F1 + lam u,   lam = (b^2 / a) / (1 - (e / a) u_z) = b^2 / (a - e u_z)

  (lam = e - a toward the vertex, u = -z), and the aligned camera images P at
  (f / t_pixel) (P_x / P_z, P_y / P_z). The displacement is that point minus the pixel;
  for a lathe-turned mirror and an aligned camera it is radial, and `radial_px` keeps
  its sign (+ outward).
* viewpoint_spread (mm): distance of the made reflected ray's line from lobe k's F1.

Pixels count for lobe k where both the exact and the made surface send them to lobe k
and the exact mirror's reflected ray leaves unobstructed: each lobe's usable annulus
(ARCHITECTURE.md). Out are the lost ring, the corners beyond the rim, and the recessed
inner lobe's outer band (image radius above 280.96 px on the paper's mirror, elevations
above 8.94 deg, Mirror.image_radii_px["inner_blocked_by_step"]), whose rays run into the
step wall and see no scene. RMS and max are over those pixel centres, each pixel once;
figures()["lobes"][k]["with_vignetted"] repeats the figures counting the blocked band too.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..design import Camera, Mirror
from ..inputs import check_type
from ..profile import ExactProfile, Profile
from .camera import ALIGNED, CameraPose, pixel_centres
from .radial import edge_mask, in_lobe_range
from .trace import RayHits, trace_pixels

LOBE_NAMES = ("inner", "outer")


@dataclass(frozen=True)
class DistortionMaps:
    """Per-pixel figures of a made mirror against the exact one (arrays of shape (H, W)).

    lobe: the pixel's lobe under the exact mirror (0 inner, 1 outer, -1 none).
    usable: the made mirror sends the pixel to the same lobe. radius_px: image radius of
    the pixel centre, px. ray_deviation_rad: rad. image_displacement_px: magnitude, px.
    radial_px: signed radial component of the displacement, px (+ outward).
    viewpoint_spread_mm: mm. vignetted: the pixel is vignetted by the mirror itself (the
    EXACT mirror's reflected ray runs into the step: a property of the design, so every
    made surface is judged on the same usable pixels); blocked: the vignetted pixels the
    made mirror still sends to their lobe. left_range: the made mirror sends the pixel to
    its lobe, but in a direction the exact lobe images outside its designed annulus
    (optics.radial.in_lobe_range): lost, not usable. hit_radius_mm: where the made ray meets
    the surface (mm from the axis; NaN where it misses). Figures are NaN where not usable.
    """

    camera: Camera
    mirror: Mirror
    lobe: np.ndarray
    usable: np.ndarray
    radius_px: np.ndarray
    ray_deviation_rad: np.ndarray
    image_displacement_px: np.ndarray
    radial_px: np.ndarray
    viewpoint_spread_mm: np.ndarray
    blocked: np.ndarray
    vignetted: np.ndarray
    left_range: np.ndarray
    hit_radius_mm: np.ndarray
    stride: int = 1  # the maps hold every stride-th row and column of the sensor (image_displacement)

    @property
    def annulus(self) -> np.ndarray:
        """The pixels (H, W bool) of the lobes' usable annuli that the step wall does not
        vignette, on the exact design: the pixels every image figure and image difference
        is taken over (the one definition; usable_annulus for the design alone)."""
        return (self.lobe >= 0) & ~self.vignetted

    def lobe_values(self, k: int, name: str) -> np.ndarray:
        """The usable pixels' values of figure `name` for lobe k (1-D)."""
        return getattr(self, name)[(self.lobe == k) & self.usable]

    def figures(self, zones=None, edge_mm: float = 0.0) -> dict:
        """{"lobes": [{"name", "pixels", ..., "<figure>": {"rms", "max"}}, ...]}, inner first.
        A figure some of whose pixels are NaN is given over its finite pixels, with their
        count as "nan_excluded" (absent when there are none).

        zones (optics.zones.Zones): the figures over each lobe's used zone (the pixels whose
        image radius lies in its used_px: the ring the nose cannot reach left out), as
        optics.radial.radial_figures(..., zones=) gives them; "zone_px" states it. edge_mm > 0:
        the pixels whose made ray meets the lobe within edge_mm of its edges (a polished
        part's turned-down edge, optics.radial.edge_mask) on their own under "edge".
        Maps of every stride-th row and column (stride > 1): the pixel counts are the
        sample's times stride^2, the sensor's to within the sample's edge rows."""
        per = self.stride * self.stride
        lobes = []
        for k, name in enumerate(LOBE_NAMES):
            in_lobe = self.lobe == k
            if zones is not None:
                lo, hi = zones.lobes[k].used_px
                in_lobe = in_lobe & (self.radius_px >= lo) & (self.radius_px <= hi)
            use = in_lobe & self.usable
            clear = use & ~self.blocked
            left = in_lobe & self.left_range & ~self.vignetted
            entry = {
                "name": name,
                "pixels": per * int(clear.sum()),
                "pixels_lost": per * int((in_lobe & ~self.usable).sum()),
                "pixels_left_range": per * int(left.sum()),
                "left_range_pct": float(100.0 * left.sum() / max(int((in_lobe & ~self.vignetted).sum()), 1)),
                "pixels_vignetted": per * int((use & self.blocked).sum()),
                "with_vignetted": {"pixels": per * int(use.sum())},
            }
            for key, arr, scale in (
                ("ray_deviation_deg", self.ray_deviation_rad, math.degrees(1.0)),
                ("image_displacement_px", self.image_displacement_px, 1.0),
                ("viewpoint_spread_mm", self.viewpoint_spread_mm, 1.0),
            ):
                entry[key] = _rms_max(arr[clear] * scale)
                entry["with_vignetted"][key] = _rms_max(arr[use] * scale)
            if zones is not None:
                lo, hi = zones.lobes[k].used_px
                entry["zone_px"] = {"min": float(lo), "max": float(hi)}
            if edge_mm > 0:
                with np.errstate(invalid="ignore"):
                    band = in_lobe & ~self.vignetted & edge_mask(self.mirror, k, self.hit_radius_mm, edge_mm)
                entry["edge"] = {"band_mm": float(edge_mm), "pixels": per * int((band & clear).sum()),
                                 "pixels_left_range": per * int((band & self.left_range).sum()),
                                 "image_displacement_px": _rms_max(self.image_displacement_px[band & clear])}
            lobes.append(entry)
        return {"lobes": lobes}


def image_displacement(made: Profile, mirror: Mirror, camera: Camera | None = None, *,
                       pose: CameraPose | None = ALIGNED, progress: bool = False,
                       stride: int = 1) -> DistortionMaps:
    """Per-pixel ray deviation, image displacement (px) and viewpoint spread (mm), made vs exact.

    camera: default the mirror's design camera (full sensor). pose: a misaligned camera
    (traced in 3-D, about 10 s for the full sensor; the aligned case takes well under 1 s
    because every pixel of the same image radius shares its meridian trace).
    progress: tqdm bars on stderr for the 3-D traces. stride: the maps at every
    stride-th row and column only, the middle pixel of each stride x stride block
    (optics.sampling.pixel_stride: a large sensor sampled, figures in its own pixels).
    """
    check_type(made, "image_displacement: made", Profile, "a Profile (made_surface(...).profile, ExactProfile)")
    check_type(mirror, "image_displacement: mirror", Mirror, "a Mirror (settings.mirror())")
    if camera is not None:
        check_type(camera, "image_displacement: camera", Camera, "a Camera")
    camera = camera or mirror.camera
    pose = pose or ALIGNED
    u, v = pixel_centres(camera)
    first = (int(stride) - 1) // 2
    u, v = u[first::stride, first::stride, 0], v[first::stride, first::stride, 0]
    exact = ExactProfile(mirror)
    if pose.aligned:
        uniq, inverse = radius_keys(u[0], v[:, 0])
        radii = np.sqrt(uniq) / 2.0
        hm, he = (trace_pixels(p, camera, radii_px=radii) for p in (made, exact))
        per = _figures_of(mirror, camera, hm, he, np.stack([radii, np.zeros_like(radii)], -1))
        maps = {k: a[inverse] for k, a in per.items()}
    else:
        xy = np.stack([u, v], axis=-1)
        hm, he = (trace_pixels(p, camera, xy, pose=pose, progress=progress) for p in (made, exact))
        maps = _figures_of(mirror, camera, hm, he, xy)
    return DistortionMaps(camera=camera, mirror=mirror, radius_px=np.hypot(u, v), stride=int(stride), **maps)


def radius_keys(u: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The distinct radii of the grid of pixel centres (u[j], v[i]) (px, 1-D), as the sorted
    integer keys (2u)^2 + (2v)^2 (exact: the centres are half-integers), and each pixel's
    index into them (len(v), len(u)): np.unique(key, return_inverse=True) of the whole grid.
    Built on the grid of the distinct u^2 and v^2 (a pixel and its mirror images across the
    axes share a key, so a quarter of the sensor's keys are sorted), then spread back."""
    su, col = np.unique((2 * np.asarray(u, float)) ** 2, return_inverse=True)
    sv, row = np.unique((2 * np.asarray(v, float)) ** 2, return_inverse=True)
    key = np.rint(sv[:, None] + su[None, :]).astype(np.int64)
    uniq, inverse = np.unique(key, return_inverse=True)
    return uniq, inverse.reshape(key.shape)[row[:, None], col[None, :]]


def usable_annulus(mirror: Mirror, camera: Camera | None = None, *,
                   pose: CameraPose | None = ALIGNED) -> np.ndarray:
    """The pixels (H, W bool) of the lobes' usable annuli that the step wall does not
    vignette: DistortionMaps.annulus, properties of the design alone, so every made mirror
    (and its rendered image) is judged on the same pixels.

    Aligned camera: the exact mirror traced once at each distinct image radius (no made
    mirror to compare, no per-pixel figure), the radii's verdicts spread to the pixels:
    the same pixels as image_displacement(...).annulus at a tenth of its cost on 12 MP."""
    pose = pose or ALIGNED
    if not pose.aligned:
        return image_displacement(ExactProfile(mirror), mirror, camera, pose=pose).annulus
    camera = camera or mirror.camera
    u, v = pixel_centres(camera)
    uniq, inverse = radius_keys(u[0, :, 0], v[:, 0, 0])
    he = trace_pixels(ExactProfile(mirror), camera, radii_px=np.sqrt(uniq) / 2.0)
    return ((he.lobe >= 0) & ~he.blocked)[inverse]


def distortion_figures(made: Profile, mirror: Mirror, camera: Camera | None = None, *,
                       pose: CameraPose | None = ALIGNED) -> dict:
    """The figures of image_displacement as JSON-ready data, lobes inner first.

    {"lobes": [{"name": "inner", "pixels", "pixels_lost", "pixels_vignetted",
    "ray_deviation_deg": {"rms", "max"}, "image_displacement_px": {...},
    "viewpoint_spread_mm": {...}, "with_vignetted": {...}}, {... "outer"}]},
    over each lobe's usable annulus (see the module docstring).
    """
    return image_displacement(made, mirror, camera, pose=pose).figures()


def exact_image_point(mirror: Mirror, k: int, direction: np.ndarray,
                      camera: Camera | None = None) -> np.ndarray:
    """Image point (u, v), px, where exact lobe k and the aligned camera image a world
    direction (..., 3) (unit, pointing away from the mirror). NaN past the asymptote."""
    camera = camera or mirror.camera
    lobe = mirror.lobes[k]
    u = np.asarray(direction, float)
    with np.errstate(divide="ignore", invalid="ignore"):
        denom = lobe.a - lobe.e * u[..., 2]
        lam = np.where(denom > 0, lobe.b**2 / denom, np.nan)
        px, py, pz = lam * u[..., 0], lam * u[..., 1], lobe.focus_z + lam * u[..., 2]
        scale = camera.f / (camera.t_pixel * pz)
    return np.stack([px * scale, py * scale], axis=-1)


def viewpoint_distance(point: np.ndarray, direction: np.ndarray, focus_z: float) -> np.ndarray:
    """Distance (mm) of the lines point + s direction (unit) from the focus (0, 0, focus_z)."""
    q = np.array([0.0, 0.0, focus_z]) - point
    return np.linalg.norm(np.cross(q, direction), axis=-1)


# --------------------------------------------------------------------------------------


def _figures_of(mirror: Mirror, camera: Camera, hm: RayHits, he: RayHits, xy: np.ndarray) -> dict:
    lobe = he.lobe
    usable = (lobe >= 0) & (hm.fate == he.fate)
    # a made ray the exact lobe would image outside its annulus has left the lobe's range
    # (optics.radial.LOBE_RANGE_SLACK_PX): lost, never a displacement beyond the sensor
    left = np.zeros(lobe.shape, bool)
    for k in (0, 1):
        m = usable & (lobe == k)
        img = exact_image_point(mirror, k, hm.direction[m], camera)
        left[m] = ~in_lobe_range(mirror, k, np.hypot(img[:, 0], img[:, 1]), camera)
    usable &= ~left
    cosang = np.clip(np.sum(hm.direction * he.direction, axis=-1), -1.0, 1.0)
    sinang = np.linalg.norm(np.cross(hm.direction, he.direction), axis=-1)
    deviation = np.arctan2(sinang, cosang)
    disp = np.full(lobe.shape, np.nan)
    radial = np.full(lobe.shape, np.nan)
    spread = np.full(lobe.shape, np.nan)
    rho = np.hypot(xy[..., 0], xy[..., 1])
    with np.errstate(invalid="ignore", divide="ignore"):
        ru = np.where(rho > 0, xy[..., 0] / np.where(rho > 0, rho, 1), 1.0)
        rv = np.where(rho > 0, xy[..., 1] / np.where(rho > 0, rho, 1), 0.0)
    for k in (0, 1):
        m = usable & (lobe == k)
        img = exact_image_point(mirror, k, hm.direction[m], camera)
        delta = img - xy[m]
        disp[m] = np.hypot(delta[:, 0], delta[:, 1])
        radial[m] = delta[:, 0] * ru[m] + delta[:, 1] * rv[m]
        spread[m] = viewpoint_distance(hm.point[m], hm.direction[m], mirror.lobes[k].focus_z)
    deviation = np.where(usable, deviation, np.nan)
    return {"lobe": lobe, "usable": usable, "ray_deviation_rad": deviation,
            "image_displacement_px": disp, "radial_px": radial,
            "viewpoint_spread_mm": spread, "blocked": he.blocked & usable, "vignetted": he.blocked,
            "left_range": left,
            "hit_radius_mm": np.where(hm.fate == he.fate, np.hypot(hm.point[..., 0], hm.point[..., 1]), np.nan)}


def _rms_max(x: np.ndarray) -> dict:
    """{"rms", "max"} of |x| over its finite values; where some are NaN (a made ray that
    leaves where the exact mirror images nothing: no image point to compare with), they
    are left out and counted: "nan_excluded"."""
    x = np.asarray(x, float)
    ok = np.isfinite(x)
    out = ({"rms": float(np.sqrt(np.mean(x[ok] * x[ok]))), "max": float(np.max(np.abs(x[ok])))} if ok.any()
           else {"rms": float("nan"), "max": float("nan")})
    if not ok.all():
        out["nan_excluded"] = int(x.size - np.count_nonzero(ok))
    return out
