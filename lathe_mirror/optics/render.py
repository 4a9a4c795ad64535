"""Synthetic images of the scene through the mirror, and how two images differ.

Each pixel's ray is traced exactly off the mirror Profile (trace.py), its reflection is
followed into the room (scene.py). Pixels whose ray hits the step wall (the lost ring),
passes the rim, or whose reflection is vignetted by the mirror itself are black. Colours
are linear (no sRGB curve), as POV-Ray writes them with File_Gamma=1.0.
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np

from ..design import Camera, Mirror
from ..errors import InputError
from ..inputs import check_real, check_type
from ..profile import Profile
from .camera import ALIGNED, CameraPose, pixel_centres
from .scene import Scene, pigment_index, pigment_table
from .trace import Fate, meridian_hits, trace_pixels

#: Rays per chunk: bounds memory (a few hundred bytes per ray) and paces the progress bar.
CHUNK_RAYS = 1 << 14  # fits the CPU caches: 1.5x faster than 1 << 18
#: Threads shading chunks at once (the machine's cores, at most 8).
RENDER_THREADS = max(1, min(8, os.cpu_count() or 1))


def render_image(profile: Profile, mirror: Mirror, scene: Scene, camera: Camera | None = None, *,
                 pose: CameraPose | None = ALIGNED, supersample: int = 1,
                 window: tuple[int, int, int, int] | None = None,
                 pixels: np.ndarray | None = None,
                 progress: bool = False) -> np.ndarray:
    """Render the scene through the mirror: (H, W, 3) uint8, linear RGB.

    camera: default the mirror's design camera (full sensor). supersample: n x n rays per
    pixel, averaged (n^2 the cost). window: (col0, row0, width, height) crop of the sensor.
    pixels: (H, W) bool of the (windowed) image, the pixels to render (the rest stays
    black; the cost follows their number). progress: a tqdm bar on stderr. Raises
    InputError if no pixel sees the mirror.
    """
    check_type(profile, "render_image: profile", Profile, "a Profile (made_surface(...).profile, ExactProfile)")
    return next(render_images((profile,), mirror, scene, camera, pose=pose, supersample=supersample,
                              window=window, pixels=pixels, progress=progress))


def render_images(profiles, mirror: Mirror, scene: Scene, camera: Camera | None = None, *,
                  pose: CameraPose | None = ALIGNED, supersample: int = 1,
                  window: tuple[int, int, int, int] | None = None,
                  pixels: np.ndarray | None = None,
                  progress: bool = False) -> Iterator[np.ndarray]:
    """render_image of each of several profiles (an iterable of Profile) over the same
    pixels, one image at a time: the samples (render_sample) are made once for all of
    them, so the images are render_image's to the byte at the cost of their rays alone (a
    12-MP report's four mirrors: the radius tables of 5 M samples made once, not four times)."""
    profiles = list(profiles)
    for profile in profiles:
        check_type(profile, "render_image: profile", Profile, "a Profile (made_surface(...).profile, ExactProfile)")
    check_type(scene, "render_image: scene", Scene, "a Scene (build_scene(settings.scene))")
    sample = render_sample(mirror, camera, pose=pose, supersample=supersample, window=window, pixels=pixels)
    for profile in profiles:
        yield sample.render(profile, scene, progress=progress)


@dataclass(frozen=True)
class RenderSample:
    """The rays of a render, whatever the mirror (render_sample): the samples' image
    coordinates u, v (px, 1-D), the image's (h, w, samples per pixel), the pixels rendered
    (None: all) and, for an aligned camera, the samples' distinct image radii (px) and each
    sample's index into them."""

    camera: Camera
    pose: CameraPose
    u: np.ndarray
    v: np.ndarray
    shape: tuple[int, int, int]
    pixels: np.ndarray | None
    radii: tuple[np.ndarray, np.ndarray] | None

    def render(self, profile: Profile, scene: Scene, *, progress: bool = False) -> np.ndarray:
        """render_image of profile over these rays: (H, W, 3) uint8."""
        check_type(scene, "render_image: scene", Scene, "a Scene (build_scene(settings.scene))")
        return _render_one(profile, self.camera, scene, self.pose, self.u, self.v, self.radii, self.shape,
                           self.pixels, progress)


def render_sample(mirror: Mirror, camera: Camera | None = None, *, pose: CameraPose | None = ALIGNED,
                  supersample: int = 1, window: tuple[int, int, int, int] | None = None,
                  pixels: np.ndarray | None = None) -> RenderSample:
    """The rays render_image traces (its arguments' meaning), made once for any number of
    profiles (RenderSample.render)."""
    check_type(mirror, "render_image: mirror", Mirror, "a Mirror (settings.mirror())")
    if camera is not None:
        check_type(camera, "render_image: camera", Camera, "a Camera")
    check_real(supersample, "render_image: supersample", lo=1, integer=True)
    camera = camera or mirror.camera
    pose = pose or ALIGNED
    u, v = pixel_centres(camera, supersample=supersample, window=window)
    h, w, n = u.shape
    if pixels is not None:
        pixels = np.asarray(pixels, bool)
        if pixels.shape != (h, w):
            raise ValueError(f"render_image: pixels mask {pixels.shape} is not the image's {(h, w)}")
        u, v = u[pixels], v[pixels]  # (m, n): the masked pixels' samples
    u, v = u.reshape(-1), v.reshape(-1)
    # The radius key needs the sub-grid step 1 / (2 supersample), not the n = supersample^2
    # samples per pixel (a key range n times too large: 31 GiB at --supersample 8).
    radii = _sample_radii(u, v, int(supersample)) if pose.aligned else None
    return RenderSample(camera, pose, u, v, (h, w, n), pixels, radii)


def _render_one(profile: Profile, camera: Camera, scene: Scene, pose: CameraPose, u: np.ndarray,
                v: np.ndarray, radii, shape: tuple[int, int, int], pixels: np.ndarray | None,
                progress: bool) -> np.ndarray:
    """One profile's image of the samples (u, v) (render_images)."""
    h, w, n = shape
    # Every hit shows one of the scene's 24 shaded pigments: each ray keeps the index of its
    # pigment (1 byte, not 24 of RGB: a 4-sample render of the paper's sensor held 100 MB of
    # float colours), BLACK where it sees no lobe; the image is looked up at the end.
    colours = pigment_table(scene).reshape(-1, 3)  # row 2 surface + parity
    black = colours.shape[0]
    colours = np.concatenate([colours, np.zeros((1, 3))])
    pigment = np.full(u.size, black, dtype=np.uint8 if black < 256 else np.uint16)
    seen = 0
    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(total=u.size, unit="ray", unit_scale=True, desc="render", leave=False)
    aligned = _aligned_meridian(profile, camera, u, v, radii) if radii is not None else None

    def render_chunk(sl: slice) -> int:
        """Shade one chunk of rays into its own slice of `pigment`; returns rays seeing a lobe."""
        if aligned is not None:
            lit, oc, dc, n_seen = aligned(sl)
        else:
            hits = trace_pixels(profile, camera, np.stack([u[sl], v[sl]], axis=-1), pose=pose)
            lit = (hits.fate <= Fate.OUTER) & ~hits.blocked
            n_seen = int(np.count_nonzero(hits.fate <= Fate.OUTER))
            oc = [np.ascontiguousarray(hits.point[lit, i]) for i in range(3)]
            dc = [np.ascontiguousarray(hits.direction[lit, i]) for i in range(3)]
        if lit.any():
            surface, parity = pigment_index(scene, oc, dc)
            pigment[sl][lit] = 2 * surface + parity
        return n_seen

    # numpy releases the GIL inside its loops: chunks shade in parallel threads, each into
    # its own slice of `pigment`, so the image is the same whatever the thread count.
    from concurrent.futures import ThreadPoolExecutor

    slices = [slice(a, min(a + CHUNK_RAYS, u.size)) for a in range(0, u.size, CHUNK_RAYS)]
    with ThreadPoolExecutor(max_workers=RENDER_THREADS) as pool:
        for sl, n_seen in zip(slices, pool.map(render_chunk, slices)):
            seen += n_seen
            if bar is not None:
                bar.update(sl.stop - sl.start)
    if bar is not None:
        bar.close()
    if seen == 0:
        raise InputError(
            "camera: no pixel sees the mirror (check [camera_pose] decentre / tilt_deg / "
            "axial_offset and the [camera] constants)"
        )
    if n == 1:  # one sample per pixel: the quantised pigments
        out = _to_uint8(colours)[pigment]
    else:  # the mean of each pixel's samples, summed first to last (as numpy's mean), quantised
        samples = pigment.reshape(-1, n)
        total = colours[samples[:, 0]]
        for k in range(1, n):
            total += colours[samples[:, k]]
        total /= n
        out = _to_uint8(total)
    if pixels is None:
        return out.reshape(h, w, 3)
    image = np.zeros((h, w, 3), np.uint8)
    image[pixels] = out
    return image


def _to_uint8(rgb: np.ndarray) -> np.ndarray:
    """Linear 0..1 to 0..255, rounded to nearest."""
    return np.clip(np.rint(rgb * 255.0), 0, 255).astype(np.uint8)


def _sample_radii(u: np.ndarray, v: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """The distinct image radii (px) of the samples (u, v) and each sample's index into
    them: an aligned camera's rays depend on the radius only, and about 8 pixels share each.

    n is the supersampling factor (n x n samples per pixel): sample points sit at integer
    multiples of 1 / (2n) px from the principal point, so (2n u)^2 + (2n v)^2 is an exact
    integer key of the radius.
    """
    key = np.rint((2 * n * u) ** 2 + (2 * n * v) ** 2).astype(np.int64)
    present = np.zeros(int(key.max()) + 1, dtype=bool)
    present[key] = True
    uniq = np.flatnonzero(present)
    index = np.empty(present.size, dtype=np.int32)  # key -> position in uniq
    index[uniq] = np.arange(uniq.size, dtype=np.int32)
    return np.sqrt(uniq) / (2 * n), index[key]


def _aligned_meridian(profile: Profile, camera: Camera, u: np.ndarray, v: np.ndarray, radii):
    """Trace each distinct image radius once (radii: _sample_radii's); returns
    chunk(slice) -> (lit mask, hit point columns x, y, z (mm), reflected direction columns,
    rays seeing a lobe)."""
    rho_u, index = radii
    m = meridian_hits(profile, rho_u * (camera.t_pixel / camera.f))

    seen_u = m.fate <= Fate.OUTER
    lit_u = seen_u & ~m.blocked
    # On the axis (an odd sensor's centre pixel) any meridian will do: cos = sin = 0.
    rho_safe = np.where(rho_u > 0, rho_u, np.inf)

    def chunk(sl: slice):
        i = index[sl]
        lit = lit_u[i]
        n_seen = int(np.count_nonzero(seen_u[i]))
        j = i[lit]
        rho = rho_safe[j]
        cos, sin = u[sl][lit] / rho, v[sl][lit] / rho
        r, orr = m.r[j], m.out_r[j]
        return lit, [r * cos, r * sin, m.z[j]], [orr * cos, orr * sin, m.out_z[j]], n_seen

    return chunk


def image_difference(a: np.ndarray, b: np.ndarray, *, mask: np.ndarray | None = None) -> dict:
    """How much image b differs from a (uint8 (H, W, 3)): {"rms": grey levels 0..255, "ssim"}.

    RMS over all channels (and the masked pixels, if a mask is given). SSIM (Wang et al.
    2004, IEEE TIP 13(4)) on the luma Y = 0.299 R + 0.587 G + 0.114 B with their constants:
    Gaussian window sigma = 1.5 px, K1 = 0.01, K2 = 0.03, L = 255; mean over the mask.
    """
    return image_differences(a, {"b": b}, mask=mask)["b"]


#: The SSIM's Gaussian window: sigma (px) and where it is cut (sigmas), so it reaches
#: int(3.5 * 1.5 + 0.5) = 5 px from a pixel (scipy.ndimage.gaussian_filter's radius).
SSIM_SIGMA, SSIM_TRUNCATE = 1.5, 3.5
SSIM_RADIUS_PX = int(SSIM_TRUNCATE * SSIM_SIGMA + 0.5)
#: Rows (and columns) of the blocks image_differences filters in (each box padded by the
#: window's reach, 2 x 5 rows and columns): 64 fits a large sensor's azimuth wedges closer
#: than 256 (12 MP, three images: 1.5-2.1 -> 1.0-1.3 s) at the paper's cost (0.4 s).
SSIM_BAND_ROWS = 64


def image_differences(a: np.ndarray, others: dict, *, mask: np.ndarray | None = None) -> dict:
    """image_difference(a, b) of each named image b in `others`, {name: {"rms", "ssim"}}:
    a's luma and its window sums made once (two of SSIM's five Gaussian filters a pair).
    The filters run only on boxes round the masked pixels (per band of SSIM_BAND_ROWS rows,
    each run of band-wide columns holding masked pixels), padded by the window's reach:
    a separable filter's value at a pixel depends only on the pixels within that reach
    (the frame's edges reflected as on the whole frame), so the figures are the whole
    frame's to the last bit, at the cost of the masked pixels (a sampled large sensor's
    sectors), not the frame's."""
    from scipy.ndimage import gaussian_filter

    a = np.asarray(a)
    h, w = a.shape[:2]
    m = np.ones((h, w), bool) if mask is None else np.asarray(mask, bool)
    for b in others.values():
        if a.shape != np.shape(b):
            raise ValueError(f"image_difference: shapes differ {a.shape} vs {np.shape(b)}")
    luma = np.array([0.299, 0.587, 0.114])
    c1, c2 = (0.01 * 255) ** 2, (0.03 * 255) ** 2
    g = lambda img: gaussian_filter(img, SSIM_SIGMA, truncate=SSIM_TRUNCATE)  # noqa: E731  (11 x 11 window)
    maps = {name: np.zeros((h, w)) for name in others}
    pad = SSIM_RADIUS_PX
    for top, bottom, left, right in _boxes(m, SSIM_BAND_ROWS):
        # the box padded by the reach (clipped to the frame), the values kept only in the box
        pr0, pr1, pc0, pc1 = max(top - pad, 0), min(bottom + pad, h), max(left - pad, 0), min(right + pad, w)
        inner = (slice(top - pr0, bottom - pr0), slice(left - pc0, right - pc0))
        x = np.asarray(a[pr0:pr1, pc0:pc1], float) @ luma
        mx = g(x)
        sxx = g(x * x) - mx * mx
        for name, b in others.items():
            y = np.asarray(b[pr0:pr1, pc0:pc1], float) @ luma
            my = g(y)
            syy = g(y * y) - my * my
            sxy = g(x * y) - mx * my
            ssim_map = ((2 * mx * my + c1) * (2 * sxy + c2)) / ((mx * mx + my * my + c1) * (sxx + syy + c2))
            maps[name][top:bottom, left:right] = ssim_map[inner]
    out = {}
    a_m = np.asarray(a[m], float)
    for name, b in others.items():
        diff = a_m - np.asarray(np.asarray(b)[m], float)
        rms = float(np.sqrt(np.mean(diff * diff))) if diff.size else float("nan")
        out[name] = {"rms": rms, "ssim": float(maps[name][m].mean()) if m.any() else float("nan")}
    return out


def _boxes(mask: np.ndarray, band_rows: int) -> list[tuple[int, int, int, int]]:
    """(row0, row1, col0, col1) boxes that together hold every True pixel of mask: per band
    of band_rows rows, each run of adjacent band_rows-wide column blocks holding one."""
    h, w = mask.shape
    out = []
    for r0 in range(0, h, band_rows):
        r1 = min(r0 + band_rows, h)
        cols = mask[r0:r1].any(axis=0)
        n = -(-w // band_rows)
        used = np.zeros(n + 2, bool)
        used[1:-1] = np.add.reduceat(cols, np.arange(0, w, band_rows)) > 0
        edges = np.flatnonzero(np.diff(used.astype(np.int8)))  # run starts and ends, in blocks
        for s, e in zip(edges[::2], edges[1::2]):
            out.append((r0, r1, int(s) * band_rows, min(int(e) * band_rows, w)))
    return out


def difference_image(a: np.ndarray, b: np.ndarray, *, gain: float = 1.0) -> np.ndarray:
    """|a - b| per channel as uint8 (H, W, 3), times gain (clipped): a picture of where they differ."""
    d = np.abs(np.asarray(a, np.int16) - np.asarray(b, np.int16)) * gain
    return np.clip(d, 0, 255).astype(np.uint8)
