"""How densely the figures that go pixel by pixel sample the sensor: a stated number of
pixel centres per lobe, so a 12-megapixel design costs what the paper's 1-megapixel one
does. `render` of the full image stays per pixel; this is for figures.

Two ways, each for the figures it keeps:

* A stride over the real pixel centres (`pixel_stride`): every stride-th row and column,
  the sample's centres the sensor's own (optics.distortion.image_displacement(stride=)).
  A figure that is a statistic of independent pixels (RMS, max, a count's share) is
  estimated from the sample; the figures stay in the design camera's pixels.
* A binned sensor (`sampled_mirror`): the same lobes seen by a camera whose pixels are
  stride x stride of the design's (pitch stride x t_pixel, sensor_px // stride, every
  r_pixel / stride, so Eq. 6's h and every sheet are the same). A figure that needs a
  pixel's neighbours (an image's blur and SSIM, the stereo matcher's window) is taken on
  it: the report's renders and its range from the image. Those are the binned sensor's
  figures, not estimates of the full sensor's: the range from the image is a coarser
  pixel's (its definition in the report says "binned"), the image difference moves a few
  per cent with the binning.

PIXELS_PER_LOBE sets the stride: the paper's lobes (248,000 and 497,000 pixel centres on
1008 x 1018) stay at stride 1, so its figures are exact and its files the same bytes; a
12-megapixel sensor (4000 x 3000 with the outer rim at 1500 px: 4.3 M centres in the
outer lobe) is sampled at stride 3. The strided figures' stated precision against the
density (halving and doubling PIXELS_PER_LOBE: 0.5 %) is tested in tests/test_sampling.py.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ..design import Camera, Mirror
from .radial import sensor_radii

#: The most pixel centres of one lobe a per-pixel figure is taken at: the larger lobe's
#: count over this, square-rooted and rounded up, is the stride. 640,000 keeps the paper's
#: outer lobe (497,000) at stride 1.
PIXELS_PER_LOBE = 640_000


def lobe_pixels(mirror: Mirror) -> int:
    """Pixel centres of the larger lobe's designed image (Mirror.image_radii_px: the inner
    disc, the outer annulus), on the design camera's sensor."""
    rho, cnt = sensor_radii(tuple(int(n) for n in mirror.camera.sensor_px))
    radii = mirror.image_radii_px
    inner = int(np.sum(cnt[rho < radii["inner_disc"][1]]))
    lo, hi = radii["outer_annulus"]
    outer = int(np.sum(cnt[(rho > lo) & (rho <= hi)]))
    return max(inner, outer)


def pixel_stride(mirror: Mirror, pixels_per_lobe: int | None = None) -> int:
    """Rows and columns between the sampled pixel centres: 1 while the larger lobe has at
    most pixels_per_lobe (default PIXELS_PER_LOBE) centres, else ceil(sqrt(its count /
    pixels_per_lobe))."""
    pixels_per_lobe = PIXELS_PER_LOBE if pixels_per_lobe is None else pixels_per_lobe
    n = lobe_pixels(mirror)
    return 1 if n <= pixels_per_lobe else int(math.ceil(math.sqrt(n / pixels_per_lobe)))


def sampled_camera(camera: Camera, stride: int) -> Camera:
    """The camera binned stride x stride: pitch stride x t_pixel, sensor_px // stride (the
    same field of view to within a pixel); the camera itself at stride 1."""
    if stride == 1:
        return camera
    w, h = (max(2, int(n) // stride) for n in camera.sensor_px)
    return dataclasses.replace(camera, t_pixel=camera.t_pixel * stride, sensor_px=(w, h))


def sampled_mirror(mirror: Mirror, stride: int) -> Mirror:
    """The same mirror seen by the binned camera (sampled_camera): each lobe's r_pixel in
    the binned pixels, so Eq. 6's h = f R_top / (T_pixel R_pixel) and every sheet are
    unchanged; the mirror itself at stride 1."""
    if stride == 1:
        return mirror
    return Mirror(sampled_camera(mirror.camera, stride),
                  *(dataclasses.replace(lobe, r_pixel=lobe.r_pixel / stride) for lobe in mirror.lobes))
