"""Dense disparity along the epipolar lines: OpenCV's semi-global block matcher.

StereoSGBM (Hirschmueller 2008, IEEE PAMI 30(2)) matches along image rows: a left pixel x
matches the right pixel x - d, d in [0, num_disparities). The panoramas' epipolar lines
are columns, so the matcher gets them transposed (rows = azimuths, x = elevation index
from the top). It returns d in 1/16 px after its own parabola fit of the matching cost
(sub-pixel); a pixel it cannot match (uniqueness, speckle filter) is invalid.

Left-right consistency is checked here, not inside the matcher: the right image's
disparity is the matcher's on both images mirrored and swapped, and a left pixel keeps
its match only where the right disparity at x - d agrees within lr_max_diff px. Every
rejected pixel is NaN.

cv2 (opencv-contrib-python-headless) is imported on use.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...declared.section import check_fields, setting
from ...errors import InputError


@dataclass(frozen=True)
class MatchParams:
    """StereoSGBM's settings (px of the matched images).

    block_size: odd side of the matching window; larger is smoother and starves less on
    flat colour, but blurs range edges. num_disparities: search range, a multiple of 16
    (cost and memory grow with it). uniqueness_ratio (%): margin by which the best cost
    must beat the second. speckle_window (px) / speckle_range (px): regions of fewer
    pixels whose disparity varies by less are removed (0: no filter). lr_max_diff (px):
    left-right consistency tolerance. p1, p2: smoothness penalties per channel and window
    pixel (OpenCV's suggestion 8 and 32). texture_threshold (grey levels per px of the
    left image as given) and support_px: a left pixel keeps its disparity only if a pixel
    whose gradient along the line exceeds the threshold lies within support_px of it on
    its line (`supported`); farther into a flat region the matcher's value is a guess.
    contrast: the grey levels are scaled by it into the matcher's 8 bits, so that its
    prefilter (a horizontal Sobel clipped at +-63) does not saturate on hard edges, where
    a clipped plateau leaves the match position loose (0.25 halves the disparity error
    on the paper's room against 1.0).
    """

    block_size: int = setting("stereo.block_size")
    num_disparities: int = 16
    uniqueness_ratio: int = setting("stereo.uniqueness_ratio")
    speckle_window: int = setting("stereo.speckle_window")
    speckle_range: int = setting("stereo.speckle_range")
    lr_max_diff: float = setting("stereo.lr_max_diff")
    p1: int = 8
    p2: int = 32
    texture_threshold: float = setting("stereo.texture_threshold")
    support_px: int = setting("stereo.support_px")
    contrast: float = setting("stereo.contrast")

    def __post_init__(self) -> None:
        check_fields(self)  # each [stereo] key's declared range: the line load() gives
        if self.block_size % 2 != 1:
            raise InputError(f"stereo.block_size = {self.block_size!r}: an odd integer from 1 to 31 px")
        if not (isinstance(self.num_disparities, int) and self.num_disparities >= 16
                and self.num_disparities % 16 == 0 and self.num_disparities <= 256):
            raise InputError(f"stereo.num_disparities = {self.num_disparities!r}: a multiple of 16 "
                             "from 16 to 256 px")
        for key, lo, hi in (("p1", 0, 1000), ("p2", 0, 10000)):
            val = getattr(self, key)
            if not (isinstance(val, int) and lo <= val <= hi):
                raise InputError(f"stereo.{key} = {val!r}: an integer from {lo} to {hi}")
        if self.p2 <= self.p1:
            raise InputError(f"stereo.p2 = {self.p2} must exceed stereo.p1 = {self.p1}")

def match(left: np.ndarray, right: np.ndarray, params: MatchParams = MatchParams()) -> np.ndarray:
    """Disparity (px, float64) of every left pixel: left x matches right x - d; NaN where
    unmatched, inconsistent or unsupported. left, right: (rows, cols) grey images, 0..255,
    rows the epipolar lines."""
    if np.shape(left) != np.shape(right) or np.ndim(left) != 2:
        raise ValueError(f"match: two 2-D images of one shape, got {left.shape} and {right.shape}")
    if left.shape[1] <= params.num_disparities + params.block_size:
        raise InputError(
            f"stereo: the matched lines are {left.shape[1]} px long, no longer than the matcher's "
            f"window (num_disparities {params.num_disparities} + block_size {params.block_size} px)"
        )
    a, b = (np.clip(np.rint(np.asarray(x, np.float32) * params.contrast), 0, 255).astype(np.uint8)
            for x in (left, right))
    sgbm = _matcher(params)
    d_left = _disparity(sgbm, a, b)
    d_right = _disparity(sgbm, np.ascontiguousarray(b[:, ::-1]), np.ascontiguousarray(a[:, ::-1]))[:, ::-1]
    d = consistent(d_left, d_right, params.lr_max_diff)  # d_right: right x matches left x + d
    return np.where(supported(left, params.texture_threshold, params.support_px), d, np.nan)


def supported(image: np.ndarray, threshold: float, distance: int) -> np.ndarray:
    """Pixels of an image (rows the epipolar lines) within `distance` px along their row
    of a textured pixel: one whose central difference (I[x+1] - I[x-1]) / 2 exceeds
    `threshold` in magnitude."""
    img = np.asarray(image, dtype=np.float32)
    grad = np.zeros_like(img)
    grad[:, 1:-1] = 0.5 * np.abs(img[:, 2:] - img[:, :-2])
    textured = grad > threshold
    x = np.arange(img.shape[1])
    big = img.shape[1] + distance + 1
    before = np.maximum.accumulate(np.where(textured, x, -big), axis=1)   # nearest textured x at or before
    after = np.minimum.accumulate(np.where(textured, x, 2 * big)[:, ::-1], axis=1)[:, ::-1]
    return np.minimum(x - before, after - x) <= distance


def consistent(d_left: np.ndarray, d_right: np.ndarray, max_diff: float) -> np.ndarray:
    """Left disparities (px) whose right disparity at x - d agrees within max_diff px; NaN
    elsewhere (and where either is NaN)."""
    rows, cols = d_left.shape
    x = np.arange(cols)[None, :] - d_left
    ok = np.isfinite(d_left)
    xr = np.clip(np.rint(np.where(ok, x, 0)).astype(np.intp), 0, cols - 1)
    back = d_right[np.arange(rows)[:, None], xr]
    with np.errstate(invalid="ignore"):
        ok &= (x > -0.5) & (np.abs(back - d_left) <= max_diff)
    return np.where(ok, d_left, np.nan)


def _matcher(params: MatchParams):
    import cv2

    bs = params.block_size
    return cv2.StereoSGBM_create(
        minDisparity=0, numDisparities=params.num_disparities, blockSize=bs,
        P1=params.p1 * bs * bs, P2=params.p2 * bs * bs, disp12MaxDiff=-1,
        uniquenessRatio=params.uniqueness_ratio, speckleWindowSize=params.speckle_window,
        speckleRange=params.speckle_range, preFilterCap=63, mode=cv2.STEREO_SGBM_MODE_SGBM_3WAY)


def _disparity(sgbm, left: np.ndarray, right: np.ndarray) -> np.ndarray:
    """The matcher's disparity (px) of the left image; NaN where it found none."""
    raw = sgbm.compute(left, right)  # int16, 16 x disparity; -16 (minDisparity - 1) invalid
    return np.where(raw >= 0, raw / 16.0, np.nan)
