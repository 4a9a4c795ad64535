"""How densely the figures that go pixel by pixel sample the sensor: a stated number of
pixel centres per lobe, so a 12-megapixel design costs what the paper's 1-megapixel one
does. `render` of the full image stays per pixel; this is for figures.

Two ways, each for the figures it keeps; in both every pixel is one of the design
camera's own, at its full resolution:

* A stride over the real pixel centres (`pixel_stride`): every stride-th row and column,
  the sample's centres the sensor's own (optics.distortion.image_displacement(stride=)).
  A figure that is a statistic of independent pixels (RMS, max, a count's share) is
  estimated from the sample.
* Azimuth sectors (`azimuth_sectors`): contiguous wedges of the image (SECTORS for the
  renders, RANGE_SECTORS for the range from the image), spread evenly round the axis,
  holding PIXELS_PER_LOBE pixel centres of the larger lobe between them. A figure that
  needs a pixel's neighbours is taken on the wedges' pixels, each traced with its
  neighbours out to the filters' reach (margins traced but not counted): the report's
  renders (the blur and the SSIM window: each counted pixel's value is the full image's,
  only the statistic over azimuth is sampled) and its range from the image (the matcher
  also remembers along azimuth, for tens of degrees over flat colour: each wedge is
  matched with the whole panorama's context, at most optics.ranging.stereo.SECTOR_LEAD_DEG
  of it, and its figures are the whole panorama's within the bound
  tests/test_sampled_range.py states).

PIXELS_PER_LOBE sets both: the paper's lobes (248,000 and 497,000 pixel centres on
1008 x 1018) are taken whole, so its figures are exact and its files the same bytes; a
12-megapixel sensor (4000 x 3000 with the outer rim at 1500 px: 4.1 M centres in the
outer lobe) is sampled at stride 3 and in wedges of 16 % of the turn. The figures'
stated precision against the density (halving and doubling PIXELS_PER_LOBE) is tested in
tests/test_sampling.py.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..design import Mirror
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


#: Wedges the renders' azimuth sample is cut into: more spread the sample round the room,
#: each costs its margins (the filters' reach, twice).
SECTORS = 8
#: Wedges the range from the image's azimuth sample is cut into. Not a multiple of 4: the
#: room is a box, and wedges every 90 / n deg all see the same part of each wall (8 wedges,
#: the whole panorama's disparities on their columns: the median range error 20 % off the
#: whole panorama's at the worst of 8 phases; 9 wedges, every 40 deg, 8 %; 12, 15 %; 32, 3 %,
#: 12-MP design). Each costs its lead (optics.ranging.stereo.SECTOR_LEAD_DEG).
RANGE_SECTORS = 9
#: Where in its period (0..1 of 2 pi / SECTORS) the first wedge starts: 0, the +x axis.
PHASE = 0.0


@dataclass(frozen=True)
class AzimuthSectors:
    """count wedges of the image, each `width` rad of azimuth, the first starting at
    `start` rad and the rest every 2 pi / count (azimuth in the camera frame: the image's
    atan2(v, u), as optics.ranging.rectify measures it)."""

    count: int
    width: float
    start: float

    @property
    def fraction(self) -> float:
        """Share of the turn the wedges cover."""
        return self.count * self.width / (2.0 * math.pi)

    def widened(self, margin: float) -> AzimuthSectors:
        """The wedges with `margin` rad more on either side (at most the whole period)."""
        width = min(self.width + 2.0 * margin, 2.0 * math.pi / self.count)
        return AzimuthSectors(self.count, width, self.start - 0.5 * (width - self.width))

    def extended(self, before: float, after: float) -> AzimuthSectors:
        """The wedges starting `before` rad earlier and ending `after` rad later (at most
        the whole period)."""
        width = min(self.width + before + after, 2.0 * math.pi / self.count)
        return AzimuthSectors(self.count, width, self.start - before)

    def pixels(self, sensor_px: tuple[int, int], slack_px: float = 0.0, *,
               within_px: float | None = None) -> np.ndarray:
        """(H, W) bool: the pixel centres within a wedge, or within slack_px px of one
        across an edge (each wedge's two edges and its apex moved out by slack_px), and
        (within_px) at most within_px px from the sensor's centre. Side
        tests by cross products with each edge's direction (no angle per pixel: products
        and sums round the same on every machine), made only on each row's run of
        candidates (the edges' crossings of the row, a pixel more either side): the cost
        is the wedges' pixels, not the sensor's."""
        w, h = sensor_px
        x = np.arange(w) + 0.5 - w / 2.0
        y = np.arange(h) + 0.5 - h / 2.0
        out = np.zeros((h, w), bool)
        period = 2.0 * math.pi / self.count
        if self.width > math.pi:  # not convex: no wedge wider than half a turn is cut
            raise ValueError(f"AzimuthSectors.pixels: wedges of {self.width} rad, at most pi")
        if within_px is not None:  # only the rows the circle crosses
            y_in = np.abs(y) <= within_px
        for k in range(self.count):
            a = self.start + k * period
            b, m = a + self.width, a + 0.5 * self.width
            # each test as cx x + cy y <= slack_px: not before edge a, nor past edge b, on the wedge's side
            tests = ((math.sin(a), -math.cos(a)), (-math.sin(b), math.cos(b)), (-math.cos(m), -math.sin(m)))
            lo, hi = np.full(h, -np.inf), np.full(h, np.inf)
            for cx, cy in tests:
                with np.errstate(divide="ignore", invalid="ignore"):
                    bound = (slack_px - cy * y) / cx
                if cx > 1e-12:
                    hi = np.minimum(hi, bound)
                elif cx < -1e-12:
                    lo = np.maximum(lo, bound)
                else:  # an edge along x: the row is in or out as a whole (the exact test below decides)
                    hi = np.where(cy * y <= slack_px + 1.0, hi, -np.inf)
            if within_px is not None:
                half = np.sqrt(np.maximum(within_px * within_px - y * y, 0.0))
                lo, hi = np.maximum(lo, -half), np.where(y_in, np.minimum(hi, half), -np.inf)
            first = np.clip(np.floor(lo + w / 2.0 - 0.5) - 1, 0, w)  # column indices, a pixel to spare
            last = np.clip(np.ceil(hi + w / 2.0 - 0.5) + 1, -1, w - 1)
            n = np.maximum(last - first + 1, 0).astype(np.intp)
            if not n.any():
                continue
            rows = np.repeat(np.arange(h), n)
            cols = np.repeat(first.astype(np.intp), n) + (np.arange(n.sum()) - np.repeat(np.cumsum(n) - n, n))
            xs, ys = x[cols], y[rows]
            inside = ((xs * math.sin(a) - ys * math.cos(a) <= slack_px)
                      & (ys * math.cos(b) - xs * math.sin(b) <= slack_px)
                      & (xs * math.cos(m) + ys * math.sin(m) >= -slack_px))
            if within_px is not None:
                inside &= np.hypot(xs, ys) <= within_px
            out[rows[inside], cols[inside]] = True
        return out

    def columns(self, n_azimuth: int, margin: int = 0) -> list[np.ndarray]:
        """Per wedge, the panorama columns (of n_azimuth over the turn, column i's centre at
        (i + 1/2) 2 pi / n_azimuth) whose centres lie in it, in order round the turn, with
        `margin` more columns either side (indices modulo n_azimuth)."""
        step = 2.0 * math.pi / n_azimuth
        period = 2.0 * math.pi / self.count
        out = []
        for k in range(self.count):
            a = self.start + k * period
            first = int(math.ceil((a - 1e-12) / step - 0.5))  # first centre at or after a
            last = int(math.ceil((a + self.width - 1e-12) / step - 0.5))  # first centre past the end
            out.append(np.mod(np.arange(first - margin, max(last, first) + margin), n_azimuth))
        return out


def azimuth_sectors(mirror: Mirror, pixels_per_lobe: int | None = None, *,
                    phase: float | None = None, count: int | None = None) -> AzimuthSectors | None:
    """The wedges holding pixels_per_lobe (default PIXELS_PER_LOBE) of the larger lobe's
    pixel centres, count (default SECTORS; RANGE_SECTORS for the range from the image) of
    them evenly round the axis; None while the lobe has no more (every pixel is taken).
    phase: where in its period (0..1) the first wedge starts, default PHASE."""
    pixels_per_lobe = PIXELS_PER_LOBE if pixels_per_lobe is None else pixels_per_lobe
    phase = PHASE if phase is None else phase
    count = SECTORS if count is None else int(count)
    n = lobe_pixels(mirror)
    if n <= pixels_per_lobe:
        return None
    period = 2.0 * math.pi / count
    return AzimuthSectors(count, period * pixels_per_lobe / n, period * float(phase))
