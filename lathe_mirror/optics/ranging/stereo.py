"""The whole chain on one image: rectify, match, triangulate; and its figures against the
known room.

The reference is the outer lobe (the finer one; its panorama's pixels are the common
band's pixels): left image = outer panorama, right = inner, both transposed so the
epipolar lines are rows, x = elevation row from the top. The inner panorama carries
num_disparities extra rows above and below the band (the inner lobe sees higher: 8.9 deg
on the paper's mirror, and lower), so reference pixels at the band's top get their full
disparity range and the left-right check reaches the band's bottom; the outer panorama's
rows there (which its lobe cannot see) repeat its edge rows.

Matching equal images matters more than matching sharp ones: the inner lobe spreads the
band over fewer pixels (0.24-0.34 deg/px against 0.11-0.16 on the paper's mirror), so
the outer panorama is blurred to the inner's footprint first (`equalising_blur`); on the
paper's room that halves the disparity error of the matched edges.

mm and radians inside; the figures in metres, degrees, percent and px.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ...declared.section import DEGREES, METRES, nested, setting, zero_none
from ...design import Mirror
from ...errors import InputError
from ...profile import Profile
from ..camera import CameraPose
from ..radial import ideal_radius_px
from ..sampling import AzimuthSectors
from ..scene import BOX_FACE0, CEILING, FLOOR
from ..trace import Fate, trace_pixels
from .match import MatchParams, match
from .rectify import PanoramaGrid, image_points, make_grid, unwrap
from .resolution import angular_resolution, parallax_per_px, r10, range_error_pct
from .triangulate import RangeMap, triangulate
from .truth import TrueRange

#: Range bins (m) of the figures.
RANGE_BINS_M = ((0.5, 1.0), (1.0, 1.5), (1.5, 2.0), (2.0, 3.0))
#: Luma weights of linear RGB (the ones image_difference uses).
LUMA = (0.299, 0.587, 0.114)


@dataclass(frozen=True)
class StereoParams:
    """How an image is ranged.

    match: the matcher's settings (num_disparities is derived from min_range here).
    min_range: the nearest range (mm) the disparity search reaches (cost grows as 1 / it).
    elevation_step: rad, default the finer lobe's resolution (rectify.make_grid).
    n_azimuth: panorama columns, default the outer lobe's circumference at mid band.
    equalise: blur the outer panorama to the inner lobe's footprint before matching.
    """

    match: MatchParams = nested(MatchParams)
    min_range: float = setting("stereo.min_range_m", METRES)
    elevation_step: float | None = setting("stereo.elevation_step_deg", zero_none(DEGREES))
    n_azimuth: int | None = setting("stereo.azimuth_px", zero_none())
    equalise: bool = setting("stereo.equalise")

    def __post_init__(self) -> None:
        if not (self.min_range > 0 and math.isfinite(self.min_range)):
            raise InputError(f"stereo.min_range_m = {self.min_range / 1e3!r}: must be > 0 m")


@dataclass(frozen=True)
class StereoResult:
    """One image ranged: the grid, the reference pixels' disparity (px, NaN unmatched),
    their range and 3-D points, and both panoramas (grey 0..255, (n_el, n_az)) for display."""

    grid: PanoramaGrid
    disparity: np.ndarray
    range_map: RangeMap
    outer_panorama: np.ndarray
    inner_panorama: np.ndarray
    colour: np.ndarray  # the reference panorama in RGB, uint8 (n_el, n_az, 3)
    match: MatchParams

    @property
    def valid(self) -> np.ndarray:
        return self.range_map.valid


def prepare(mirror: Mirror, params: StereoParams = StereoParams()) -> tuple[PanoramaGrid, MatchParams]:
    """The grid and the matcher's settings for a design; InputError if the common band is
    empty or narrower than the matcher's window."""
    grid = make_grid(mirror, elevation_step=params.elevation_step, n_azimuth=params.n_azimuth)
    if not mirror.outer.focus_z - mirror.inner.focus_z > 1e-6:
        # The matcher searches one way along the line: the inner lobe's lower viewpoint sees
        # a point higher. (No design with a common band found puts it the other way.)
        raise InputError(
            f"design: the outer lobe's viewpoint (z = {mirror.outer.focus_z:.4f} mm) must lie above "
            f"the inner lobe's (z = {mirror.inner.focus_z:.4f} mm) for stereo")
    nd = num_disparities(mirror, grid, params.min_range)
    mp = MatchParams(**{**params.match.__dict__, "num_disparities": nd})
    if grid.n_elevation < 2 * mp.block_size:
        lo, hi = (math.degrees(x) for x in grid.band)
        raise InputError(
            f"design: the common band ({lo:.3f} to {hi:.3f} deg, {grid.n_elevation} px of "
            f"{math.degrees(grid.step):.3f} deg) is narrower than twice the matcher's window "
            f"(stereo.block_size = {mp.block_size} px): no stereo"
        )
    return grid, mp


def num_disparities(mirror: Mirror, grid: PanoramaGrid, min_range: float) -> int:
    """Disparity search range (px, a multiple of 16, at most 256) reaching min_range (mm):
    the parallax B / min_range over the grid step, plus the block's slack."""
    need = mirror.baseline / min_range / grid.step + 2
    nd = int(math.ceil(need / 16.0)) * 16
    if nd > 256:
        raise InputError(
            f"stereo.min_range_m = {min_range / 1e3:g}: needs a disparity search of {need:.0f} px "
            "on this grid, more than the matcher's 256; raise it"
        )
    return nd


def equalising_blur(mirror: Mirror, grid: PanoramaGrid) -> tuple[float, float]:
    """Gaussian sigma (rows, columns) that brings the outer panorama to the inner one's
    footprint, median over the band. A pixel sampled bilinearly spreads over a box and a
    tent of one image pixel (variance 1/12 + 1/6, sigma 0.5 px); a lobe's image pixel
    spans angular_resolution / step rows and (1 / rho) / azimuth_step columns, so
    sigma = 0.5 sqrt(w_inner^2 - w_outer^2) in each direction."""
    el = grid.elevations()
    cam = mirror.camera
    w = [angular_resolution(lobe, cam, el) / grid.step for lobe in mirror.lobes]
    a = [1.0 / ideal_radius_px(lobe, cam, el) / grid.azimuth_step for lobe in mirror.lobes]
    rows = 0.5 * np.sqrt(np.maximum(w[0] ** 2 - w[1] ** 2, 0.0))
    cols = 0.5 * np.sqrt(np.maximum(a[0] ** 2 - a[1] ** 2, 0.0))
    return float(np.nanmedian(rows)), float(np.nanmedian(cols))


def image_mask(mirror: Mirror, grid: PanoramaGrid, rows_above: int,
               sectors: AzimuthSectors | None = None, margin: int = 0, grow_px: float = 0.0) -> np.ndarray:
    """(H, W) bool: the image pixels the unwrap of either lobe samples (the annuli of
    image radii over the grid's elevations, rows_above rows beyond each end included, with
    two pixels to spare for the bilinear footprint): all a render for stereo needs. With
    sectors: only within their wedges widened by margin panorama columns (and the two
    pixels), all stereo_range(sectors=) samples. grow_px: that many pixels more across
    every edge (a blur's reach: a superset of optics.defocus.grow_mask's)."""
    w, h = mirror.camera.sensor_px
    x = np.arange(w) + 0.5 - w / 2.0
    y = np.arange(h) + 0.5 - h / 2.0
    rho = np.hypot(x[None, :], y[:, None])
    mask = np.zeros((h, w), bool)
    el = grid.elevations(rows_above, rows_above)
    for lobe in mirror.lobes:
        lo, hi = mirror.fov_usable(lobe)
        r = ideal_radius_px(lobe, mirror.camera, el[(el >= lo) & (el <= hi)])
        r = r[np.isfinite(r)]
        if r.size:
            mask |= (rho >= r.min() - 2.0 - grow_px) & (rho <= r.max() + 2.0 + grow_px)
    if sectors is not None:  # a column's centre is in its wedge: half a column more reaches its edge
        mask &= sectors.widened((margin + 0.5) * grid.azimuth_step).pixels((w, h), slack_px=2.0 + grow_px)
    return mask


def band_visibility(profile: Profile, mirror: Mirror, grid: PanoramaGrid,
                    pose: CameraPose | None = None, *, every: int = 8) -> tuple[float, float]:
    """Share of the grid's pixels (every `every`-th column) that the camera sees through the
    inner and the outer lobe of a surface: the image point the design maps each to, traced
    off the surface (optics.trace, with the camera's pose), lands on that lobe and its
    reflection leaves unblocked."""
    out = []
    for k in (0, 1):
        u, v, seen = image_points(mirror, k, grid)
        xy = np.stack([u[:, ::every], v[:, ::every]], axis=-1)
        ok = np.isfinite(xy).all(axis=-1) & seen[:, ::every]
        hits = trace_pixels(profile, mirror.camera, np.where(ok[..., None], xy, 0.0), pose=pose)
        lobe = Fate.INNER if k == 0 else Fate.OUTER
        out.append(float(np.mean(ok & (hits.fate == lobe) & ~hits.blocked)))
    return out[0], out[1]


def stereo_range(image: np.ndarray, mirror: Mirror, params: StereoParams = StereoParams(), *,
                 sectors: AzimuthSectors | None = None) -> StereoResult:
    """Range every reference pixel of a rendered or captured image (H, W, 3) uint8 (or
    (H, W) grey) of an aligned camera through the design's stereo geometry.

    sectors (optics.sampling): only the panorama columns in these wedges, each wedge's
    panoramas matched on their own with sector_margin columns either side (matched, then
    dropped), so a kept column sees what the whole panorama's would; the result's grid
    holds the kept columns (PanoramaGrid.columns). The image needs its pixels only in the
    wedges widened by sector_margin (image_mask with the sectors)."""
    grid, mp = prepare(mirror, params)
    img = np.asarray(image)
    grey = img.astype(np.float32) @ np.asarray(LUMA, np.float32) if img.ndim == 3 else img.astype(np.float32)
    if sectors is None:
        d, outer, inner = _match_columns(grey, mirror, grid, mp, params)
    else:
        margin = sector_margin(mirror, grid, mp, params)
        parts, kept = [], []
        for cols in sectors.columns(grid.n_azimuth, margin):
            part = _match_columns(grey, mirror, grid.with_columns(cols), mp, params)
            parts.append([x[:, margin:cols.size - margin] for x in part])
            kept.append(cols[margin:cols.size - margin])
        grid = grid.with_columns(np.concatenate(kept))
        d, outer, inner = (np.concatenate(x, axis=1) for x in zip(*parts))
    colour = unwrap(img, mirror, 1, grid)[0]
    if colour.ndim == 2:
        colour = np.repeat(colour[..., None], 3, axis=-1)
    return StereoResult(grid=grid, disparity=d, range_map=triangulate(mirror, grid, d),
                        outer_panorama=outer, inner_panorama=inner,
                        colour=np.clip(np.rint(colour), 0, 255).astype(np.uint8), match=mp)


def sector_margin(mirror: Mirror, grid: PanoramaGrid, mp: MatchParams, params: StereoParams) -> int:
    """Columns matched beyond a wedge's edge and dropped: the reach along azimuth of the
    equalising blur (3 sigma) and of the matcher's window (its left-right check's and
    speckle filter's neighbours: 3 windows).

    Not the matcher's memory: SGBM_3WAY aggregates its costs along the transposed
    panorama's columns (azimuth), and across flat colour (a wall) a path keeps its
    disparity for tens of degrees, so a wedge starts its paths without that history and
    keeps fewer, better matches there: the sample reads low. Measured on the 12-MP design
    at fast settings, exact mirror, median range error: the whole panorama 6.37 %; wedges
    at phase 0 with 1 (this) / 4.7 / 7 / 9.5 / 14 deg of margin 5.13 / 5.29 / 5.38 / 5.60 /
    5.85 %, each degree costing 2 SECTORS deg of the turn traced and matched, against a
    spread over the wedges' phase of 3.9 to 5.1 % at 1 deg (tests/test_sampling.py)."""
    blur = math.ceil(3.0 * equalising_blur(mirror, grid)[1]) if params.equalise else 0
    return blur + 3 * mp.block_size


def _match_columns(grey: np.ndarray, mirror: Mirror, grid: PanoramaGrid, mp: MatchParams,
                   params: StereoParams) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The reference pixels' disparity (NaN unmatched or unseen by either lobe) and both
    panoramas, on the grid's columns (matched as one image: contiguous in azimuth)."""
    import cv2

    pad = mp.num_disparities
    n = grid.n_elevation
    outer, outer_seen = unwrap(grey, mirror, 1, grid, rows_above=pad, rows_below=pad)
    inner, inner_seen = unwrap(grey, mirror, 0, grid, rows_above=pad, rows_below=pad)
    # Rows beyond the band the outer lobe cannot see repeat its edge rows: no false edge.
    outer[:pad] = outer[pad]
    outer[pad + n:] = outer[pad + n - 1]
    if params.equalise:
        rows, cols = equalising_blur(mirror, grid)
        outer = cv2.GaussianBlur(outer, (0, 0), sigmaX=cols, sigmaY=rows, borderType=cv2.BORDER_REPLICATE)
    d = match(outer.T, inner.T, mp).T[pad:pad + n]
    # A match is kept only where both lobes see what was matched.
    rows = np.arange(n)[:, None] + pad
    hit = np.clip(np.rint(rows - np.nan_to_num(d)).astype(np.intp), 0, n + 2 * pad - 1)
    ok = np.isfinite(d) & outer_seen[pad:pad + n] & inner_seen[hit, np.arange(grid.shape[1])[None, :]]
    return np.where(ok, d, np.nan), outer[pad:pad + n], inner[pad:pad + n]


def range_figures(result: StereoResult, truth: TrueRange, mirror: Mirror, *,
                  precision_px: float | None = None) -> dict:
    """The figures of a ranged image against the room's truth (plain data; m, %, px, deg).

    valid_fraction: share of the common band's (reference) pixels with a range.
    range_error_pct: |100 (R - R_true) / R_true| over them (median, RMS; signed_median
    shows a bias); per range bin of the true range, with the resolution model's error at
    one pixel of disparity (model_1px_pct) and at the matcher's achieved precision
    (model_matcher_pct; precision_px, default the median |disparity error| measured here,
    in panorama px of elevation_step), each the median over the bin's valid pixels. valid_by_surface: the
    valid share on the floor, walls, ceiling and boxes (flat colour starves the matcher).
    """
    grid = result.grid
    if truth.range_mm.shape != result.disparity.shape:
        raise ValueError(f"range_figures: the truth's grid {truth.range_mm.shape} is not the result's "
                         f"{result.disparity.shape} (true_range on result.grid)")
    valid = result.valid & np.isfinite(truth.range_mm)
    err = 100.0 * (result.range_map.range_mm - truth.range_mm) / truth.range_mm
    derr = result.disparity - truth.disparity
    measured = float(np.median(np.abs(derr[valid]))) if valid.any() else math.nan
    precision = measured if precision_px is None else float(precision_px)
    r_true = truth.range_mm
    model_1px = truth.model_1px_pct
    model_match = range_error_pct(mirror, r_true, truth.elevation, precision * grid.step)
    bins = []
    for lo, hi in RANGE_BINS_M:
        inside = (r_true >= lo * 1e3) & (r_true < hi * 1e3)
        v = inside & valid
        bins.append({
            "range_m": [lo, hi],
            "pixels": int(inside.sum()),
            "valid_fraction": float(v.sum() / inside.sum()) if inside.any() else math.nan,
            "range_error_pct": _stats(err[v]),
            "model_1px_pct": float(np.median(model_1px[v])) if v.any() else math.nan,
            "model_matcher_pct": float(np.median(model_match[v])) if v.any() else math.nan,
        })
    surf = truth.surface
    classes = {"floor": surf == FLOOR, "ceiling": surf == CEILING,
               "walls": (surf > CEILING) & (surf < BOX_FACE0), "boxes": surf >= BOX_FACE0}
    lo_deg, hi_deg = (math.degrees(x) for x in grid.band)
    return {
        "grid": {"n_elevation": grid.n_elevation, "n_azimuth": grid.n_azimuth,
                 "elevation_step_deg": math.degrees(grid.step), "band_deg": {"min": lo_deg, "max": hi_deg}},
        "matcher": {**result.match.__dict__},
        "baseline_mm": mirror.baseline,
        "r10_m": r10(mirror),
        "parallax_per_px_deg": float(np.degrees(np.median(parallax_per_px(mirror, grid.elevations())))),
        "pixels": int(valid.size),
        "valid_fraction": float(valid.mean()),
        "valid_by_surface": {k: {"pixels": int(m.sum()), "valid_fraction": float((m & valid).sum() / m.sum())
                                 if m.any() else math.nan} for k, m in classes.items()},
        "true_range_m": {"min": float(np.min(r_true)) / 1e3, "max": float(np.max(r_true)) / 1e3},
        "range_error_pct": _stats(err[valid]),
        "disparity_error_px": {**_stats(derr[valid]), "precision": measured},
        "model_precision_px": precision,
        "bins": bins,
    }


#: Fewest ranged pixels a bin of the error curve needs to be drawn (a few pixels on an
#: object's edge say nothing about the matcher).
CURVE_MIN_PIXELS = 200


def error_curve(result: StereoResult, truth: TrueRange, mirror: Mirror, precision_px: float, *,
                edges_m: np.ndarray | None = None) -> dict:
    """Median |range error| (%) of the valid pixels in 0.1 m bins of true range (m), with
    the model's error at one pixel of disparity and at precision_px (panorama px), each
    the median over the bin's pixels: lists for a plot. Bins with fewer than
    CURVE_MIN_PIXELS ranged pixels are left out."""
    edges = np.arange(0.5, 3.01, 0.1) if edges_m is None else np.asarray(edges_m, float)
    valid = result.valid & np.isfinite(truth.range_mm)
    r = truth.range_mm / 1e3
    err = np.abs(100.0 * (result.range_map.range_mm - truth.range_mm) / truth.range_mm)
    m1 = truth.model_1px_pct
    mp = range_error_pct(mirror, truth.range_mm, truth.elevation, precision_px * result.grid.step)
    out = {"range_m": [], "measured_pct": [], "model_1px_pct": [], "model_matcher_pct": [], "pixels": []}
    for lo, hi in zip(edges[:-1], edges[1:]):
        v = valid & (r >= lo) & (r < hi)
        if v.sum() < CURVE_MIN_PIXELS:
            continue
        out["range_m"].append(float(0.5 * (lo + hi)))
        out["measured_pct"].append(float(np.median(err[v])))
        out["model_1px_pct"].append(float(np.median(m1[v])))
        out["model_matcher_pct"].append(float(np.median(mp[v])))
        out["pixels"].append(int(v.sum()))
    return out


def _stats(values: np.ndarray) -> dict:
    """{"median", "rms"} of |values| and their signed median; NaN when empty."""
    v = np.asarray(values, float)
    if v.size == 0:
        return {"median": math.nan, "rms": math.nan, "signed_median": math.nan}
    return {"median": float(np.median(np.abs(v))), "rms": float(np.sqrt(np.mean(v * v))),
            "signed_median": float(np.median(v))}
