"""Defocus in the image: each pixel's thin-lens blur circle, and the image blurred by it.

The camera's lens is focused at one distance; each lobe shows the scene as a virtual
image whose distance from the lens changes with the image radius (optics.focus, the
model the optimiser's blur constraint uses). A pixel's blur circle has the diameter

    c = (f / N) v_f |1/d - 1/d_f| / T_pixel      (px; N the f-number, d_f the focus)

with d the virtual image distance of its lobe at its image radius (the larger of the
tangential and sagittal circles). The lens is focused at the design's best compromise
(optics.focus.defocus: 1/d_f midway between the nearest and farthest virtual images over
both usable annuli) for scene points `object_range` from each viewpoint
([optimize] focus_range_m, the range the optimiser focuses for), and every pixel's blur is
taken at that range whatever its scene point's: the virtual images sit near the mirror's
focal points, so on the paper default a pixel's blur differs by at most 0.45 px (of 6.6)
from 0.5 m to infinity (docs/explanation/monte-carlo.md, "The blur at other ranges").

The blurred image is the sharp one averaged over a uniform disc of each pixel's own
diameter (the geometric blur of a thin lens; diffraction and aberrations left out). A
spatially varying disc is made from a few fixed discs: the image is convolved (OpenCV) with
discs of band diameters that bracket the map's diameters, and each pixel takes the linear
blend of the two bands around its own diameter; no loop per pixel.

Pixels outside both lobes' images (the ring lost on the step wall, the sensor's corners
beyond the rim) take the blur of the nearer lobe's edge. Lengths in mm, blur in px.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..design import Camera, Mirror
from .camera import pixel_centres
from .focus import defocus, lobe_blur_px
from .radial import sensor_radii

#: Disc diameters (px) the varying blur blends between: every pixel up to 4 px, then
#: steps of 25 % (the blend of two discs 25 % apart is within a few percent of the disc
#: between them in its second moment).
FIRST_BANDS = (0.0, 1.0, 2.0, 3.0, 4.0)
BAND_RATIO = 1.25
#: Radial samples (px) of the blur curve the map is interpolated from.
CURVE_STEP_PX = 0.5
#: Sub-samples per pixel side of a disc kernel's coverage.
KERNEL_SUBSAMPLES = 8


@dataclass(frozen=True)
class Lens:
    """The camera's lens as the images see it: f_number; focus_mm, the distance it is
    focused at (mm from the pinhole); object_range_mm, the scene points' distance from
    each lobe's viewpoint the virtual images are taken for (mm)."""

    f_number: float
    focus_mm: float
    object_range_mm: float

    def to_dict(self) -> dict:
        return {"f_number": float(self.f_number), "focus_mm": float(self.focus_mm),
                "object_range_mm": float(self.object_range_mm)}


def lens_for(mirror: Mirror, object_range_mm: float, f_number: float | None = None) -> Lens:
    """The design camera's lens (its [camera] f_number unless given) focused at the
    thin-lens model's best compromise for scene points object_range_mm from the viewpoints."""
    n = float(mirror.camera.f_number if f_number is None else f_number)
    return Lens(n, float(defocus(mirror, n, object_range_mm).focus_mm), float(object_range_mm))


def blur_curve(mirror: Mirror, lens: Lens, radius_px: np.ndarray) -> np.ndarray:
    """Blur circle diameter (px) at image radii (px, of the design camera): the inner
    lobe's up to its image's edge, the outer lobe's from its annulus's start (held at its
    rim beyond), linear across the lost ring between."""
    rho = np.asarray(radius_px, float)
    radii = mirror.image_radii_px
    inner_hi = radii["inner_disc"][1]
    outer_lo, outer_hi = radii["outer_annulus"]
    args = (lens.f_number, lens.focus_mm, lens.object_range_mm)
    inner = lobe_blur_px(mirror, 0, np.clip(rho, 0.0, inner_hi), *args)
    outer = lobe_blur_px(mirror, 1, np.clip(rho, outer_lo, outer_hi), *args)
    if outer_lo > inner_hi:
        t = np.clip((rho - inner_hi) / (outer_lo - inner_hi), 0.0, 1.0)
        ring = float(lobe_blur_px(mirror, 0, np.array([inner_hi]), *args)[0]) * (1 - t) + \
            float(lobe_blur_px(mirror, 1, np.array([outer_lo]), *args)[0]) * t
    else:
        ring = outer
    return np.where(rho <= inner_hi, inner, np.where(rho >= outer_lo, outer, ring))


def blur_map(mirror: Mirror, lens: Lens, camera: Camera | None = None, *,
             window: tuple[int, int, int, int] | None = None) -> np.ndarray:
    """(H, W) blur circle diameter (px) of every pixel of the sensor (or window, as
    optics.camera.pixel_centres), by its image radius (an aligned camera's; a tilted or
    decentred camera's blur is taken the same)."""
    camera = camera or mirror.camera
    u, v = pixel_centres(camera, window=window)
    # on the grid of the distinct |u| and |v| (a quarter of the sensor's centres), spread
    # back: the same values as pixel by pixel, a quarter of the work
    x, col = np.unique(np.abs(u[0, :, 0]), return_inverse=True)
    y, row = np.unique(np.abs(v[:, 0, 0]), return_inverse=True)
    rho = np.hypot(x[None, :], y[:, None])
    # the same angles in the design camera's pixels
    rho = rho * (mirror.camera.f / mirror.camera.t_pixel) / (camera.f / camera.t_pixel)
    grid = np.arange(0.0, float(rho.max()) + 2 * CURVE_STEP_PX, CURVE_STEP_PX)
    blur = np.interp(rho, grid, blur_curve(mirror, lens, grid)) * \
        ((camera.f / camera.t_pixel) / (mirror.camera.f / mirror.camera.t_pixel))
    return blur[row[:, None], col[None, :]]


def blur_figures(mirror: Mirror, lens: Lens, zones=None) -> dict:
    """The blur per lobe, JSON-ready: {"lens": Lens, "lobes": [{"name", "blur_px": {"min",
    "max", "mean"}}]}, over each lobe's pixel centres of its used zone (zones:
    optics.zones.Zones) or designed annulus, each pixel once."""
    rho, cnt = sensor_radii(tuple(int(n) for n in mirror.camera.sensor_px))
    radii = mirror.image_radii_px
    lobes = []
    for k, name in enumerate(("inner", "outer")):
        lo, hi = (zones.lobes[k].used_px if zones is not None else
                  radii["inner_disc"] if k == 0 else radii["outer_annulus"])
        m = (rho >= lo) & (rho <= hi) if k == 0 else (rho > lo) & (rho <= hi)
        c = lobe_blur_px(mirror, k, rho[m], lens.f_number, lens.focus_mm, lens.object_range_mm)
        w = cnt[m]
        stat = ({"min": float(c.min()), "max": float(c.max()), "mean": float(np.sum(c * w) / np.sum(w))}
                if c.size else {"min": math.nan, "max": math.nan, "mean": math.nan})
        lobes.append({"name": name, "blur_px": stat})
    return {"lens": lens.to_dict(), "lobes": lobes,
            "definition": "thin-lens blur circle diameter (px) of each pixel: (f / N) v_f |1/d - 1/d_f| / "
                          "T_pixel, d the lobe's virtual image distance at the pixel's image radius "
                          "(larger of tangential and sagittal), d_f the focus; over each lobe's used zone"}


def grow_mask(mask: np.ndarray, diameter_px: np.ndarray | float) -> np.ndarray:
    """The pixels (H, W bool) a blur of these diameters (px) reaches from `mask`: the
    pixels a render must trace so that the blurred masked pixels see their neighbours."""
    from scipy.ndimage import distance_transform_edt

    reach = math.ceil(float(np.max(diameter_px)) / 2.0) + 1
    mask = np.asarray(mask, bool)
    if not mask.any():
        return mask
    return distance_transform_edt(~mask) <= reach


def defocus_image(image: np.ndarray, diameter_px: np.ndarray, *, pixels: np.ndarray | None = None,
                  tile: int = 256) -> np.ndarray:
    """The image (H, W, 3) uint8 averaged over a uniform disc of each pixel's diameter
    (diameter_px, (H, W) px): the bands' disc convolutions blended linearly in diameter
    (module doc; zero beyond the image's border). Same shape and dtype; the same input
    gives the same bytes.

    pixels: (H, W) bool, the pixels wanted (the rest 0): only the tile x tile blocks that
    hold any are blurred, each with a margin of the largest disc's reach, so a wanted
    pixel is the whole image's (the bands are the whole map's; OpenCV's direct filter on
    the small discs here, tested against the whole image in tests/test_sampling.py)."""
    d = np.asarray(diameter_px, float)
    if d.shape != np.shape(image)[:2]:
        raise ValueError(f"defocus_image: diameters {d.shape} are not the image's {np.shape(image)[:2]}")
    if not float(d.max()) > 1.0:  # every disc within its pixel: the image as traced
        out = np.asarray(image, np.uint8).copy()
        if pixels is not None:
            out[~np.asarray(pixels, bool)] = 0
        return out
    bands = band_diameters(float(d.max()))
    if pixels is None:
        return _blend(image, d, bands)
    pixels = np.asarray(pixels, bool)
    h, w = pixels.shape
    reach = int(math.ceil(bands[-1] / 2.0)) + 1
    out = np.zeros(np.shape(image), np.uint8)
    rows = np.flatnonzero(np.add.reduceat(np.add.reduceat(pixels, np.arange(0, h, tile), axis=0),
                                          np.arange(0, w, tile), axis=1).ravel())
    n_cols = (w + tile - 1) // tile
    for i in rows:  # one block a tile (a few hundred), not a pixel
        r0, c0 = (i // n_cols) * tile, (i % n_cols) * tile
        r1, c1 = min(r0 + tile, h), min(c0 + tile, w)
        a0, b0, a1, b1 = max(r0 - reach, 0), max(c0 - reach, 0), min(r1 + reach, h), min(c1 + reach, w)
        part = _blend(image[a0:a1, b0:b1], d[a0:a1, b0:b1], bands)[r0 - a0:r1 - a0, c0 - b0:c1 - b0]
        part[~pixels[r0:r1, c0:c1]] = 0  # the tiles' unwanted pixels; the tiles not blurred stay 0
        out[r0:r1, c0:c1] = part
    return out


def _blend(image: np.ndarray, d: np.ndarray, bands: list[float]) -> np.ndarray:
    """defocus_image's blend of the bands' disc convolutions (uint8 out)."""
    import cv2  # lazy: OpenCV only where an image is blurred (render, stereo, the report)

    img = np.ascontiguousarray(image, np.float32)
    d32 = d.astype(np.float32)
    lo, hi = float(d32.min()), float(d32.max())
    out = np.zeros_like(img)
    for b, db in enumerate(bands):
        if (b > 0 and hi <= bands[b - 1]) or (b < len(bands) - 1 and lo >= bands[b + 1]):
            continue  # its hat is 0 outside (bands[b - 1], bands[b + 1]): on every diameter here
        # band b's hat: 1 at its diameter, 0 at its neighbours' (a linear blend in diameter)
        rise = np.float32(1.0) if b == 0 else (d32 - bands[b - 1]) / np.float32(db - bands[b - 1])
        fall = np.float32(1.0) if b == len(bands) - 1 else (bands[b + 1] - d32) / np.float32(bands[b + 1] - db)
        weight = np.clip(np.minimum(rise, fall), 0.0, 1.0)
        if not weight.any():
            continue
        # a disc within the pixel is the pixel itself; the disc is symmetric, so OpenCV's
        # correlation is the convolution (zero beyond the border, as the sensor's edge)
        blurred = img if db < 1.0 else cv2.filter2D(img, -1, disc_kernel(db).astype(np.float32),
                                                   borderType=cv2.BORDER_CONSTANT)
        out += weight[..., None] * blurred
    return np.clip(np.rint(out), 0, 255).astype(np.uint8)


def band_diameters(largest: float) -> list[float]:
    """The disc diameters (px) the blend uses, up to the first at or above `largest`."""
    bands = [b for b in FIRST_BANDS]
    while bands[-1] < largest:
        bands.append(bands[-1] * BAND_RATIO)
    return [b for i, b in enumerate(bands) if i == 0 or bands[i - 1] < largest]


def disc_kernel(diameter_px: float) -> np.ndarray:
    """A uniform disc of this diameter (px) on the pixel grid, each pixel weighted by the
    share of it the disc covers (KERNEL_SUBSAMPLES^2 samples), summing to 1."""
    r = diameter_px / 2.0
    n = int(math.ceil(r - 0.5)) if r > 0.5 else 0
    s = (np.arange(KERNEL_SUBSAMPLES) + 0.5) / KERNEL_SUBSAMPLES - 0.5
    x = np.arange(-n, n + 1, dtype=float)
    xs = (x[:, None] + s[None, :]).ravel()  # sub-sample positions along one axis
    inside = (xs[:, None] ** 2 + xs[None, :] ** 2) <= r * r
    k = inside.reshape(2 * n + 1, KERNEL_SUBSAMPLES, 2 * n + 1, KERNEL_SUBSAMPLES).mean(axis=(1, 3))
    if k.sum() == 0:  # a disc that covers no sub-sample: the pixel itself
        k[n, n] = 1.0
    return k / k.sum()
