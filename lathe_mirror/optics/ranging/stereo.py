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
               sectors: AzimuthSectors | None = None, grow_px: float = 0.0) -> np.ndarray:
    """(H, W) bool: the image pixels the unwrap of either lobe samples (the annuli of
    image radii over the grid's elevations, rows_above rows beyond each end included, with
    two pixels to spare for the bilinear footprint): all a render for stereo needs. With
    sectors: only within these wedges (and the two pixels; matched_sectors: all
    stereo_range(sectors=) samples). grow_px: that many pixels more across every edge (a
    blur's reach: a superset of optics.defocus.grow_mask's)."""
    w, h = mirror.camera.sensor_px
    x = np.arange(w) + 0.5 - w / 2.0
    y = np.arange(h) + 0.5 - h / 2.0
    el = grid.elevations(rows_above, rows_above)
    rings = []
    for lobe in mirror.lobes:
        lo, hi = mirror.fov_usable(lobe)
        r = ideal_radius_px(lobe, mirror.camera, el[(el >= lo) & (el <= hi)])
        r = r[np.isfinite(r)]
        if r.size:
            rings.append((r.min() - 2.0 - grow_px, r.max() + 2.0 + grow_px))
    if sectors is None:
        rho = np.hypot(x[None, :], y[:, None])
        mask = np.zeros((h, w), bool)
        for lo, hi in rings:
            mask |= (rho >= lo) & (rho <= hi)
        return mask
    # the radii only of the wedges' pixels (a column's centre is in its wedge: half a
    # column more reaches its edge)
    mask = sectors.widened(0.5 * grid.azimuth_step).pixels(
        (w, h), slack_px=2.0 + grow_px, within_px=max((hi for _, hi in rings), default=0.0))
    rr, cc = np.nonzero(mask)
    rho = np.hypot(x[cc], y[rr])
    keep = np.zeros(rho.shape, bool)
    for lo, hi in rings:
        keep |= (rho >= lo) & (rho <= hi)
    mask[rr[~keep], cc[~keep]] = False
    return mask


def matched_sectors(sectors: AzimuthSectors, mirror: Mirror, grid: PanoramaGrid, mp: MatchParams,
                    params: StereoParams) -> AzimuthSectors:
    """The wedges stereo_range(sectors=) matches: each led by sector_lead columns and
    followed by sector_margin (sector_segments: the most it matches)."""
    step = grid.azimuth_step
    return sectors.extended(sector_lead(grid) * step, sector_margin(mirror, grid, mp, params) * step)


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

    sectors (optics.sampling): only the panorama columns in these wedges, each matched
    with the context the whole panorama's matcher gives it (sector_segments: from where
    the whole panorama's aggregation along azimuth starts, at most sector_lead columns
    before, and sector_margin after), so a kept column's disparity is the whole
    panorama's, or close to it where the lead is cut; the result's grid holds the kept
    columns (PanoramaGrid.columns). The image needs its pixels only in matched_sectors."""
    grid, mp = prepare(mirror, params)
    img = np.asarray(image)
    grey = img.astype(np.float32) @ np.asarray(LUMA, np.float32) if img.ndim == 3 else img.astype(np.float32)
    if sectors is None:
        d, outer, inner = _match_columns(grey, mirror, grid, mp, params)
    else:
        segments = sector_segments(sectors, grid, mp, params, mirror)
        parts = _match_segments(grey, mirror, grid, mp, params, segments)
        grid = grid.with_columns(np.concatenate([seg.counted for seg in segments]))
        d, outer, inner = (np.concatenate(x, axis=1) for x in zip(*parts))
    colour = unwrap(img, mirror, 1, grid)[0]
    if colour.ndim == 2:
        colour = np.repeat(colour[..., None], 3, axis=-1)
    return StereoResult(grid=grid, disparity=d, range_map=triangulate(mirror, grid, d),
                        outer_panorama=outer, inner_panorama=inner,
                        colour=np.clip(np.rint(colour), 0, 255).astype(np.uint8), match=mp)


def sector_margin(mirror: Mirror, grid: PanoramaGrid, mp: MatchParams, params: StereoParams) -> int:
    """Columns matched after a wedge's last and dropped: the reach along azimuth of the
    equalising blur (3 sigma) and of the matcher's window (its left-right check's and
    speckle filter's neighbours: 3 windows). The matcher's memory runs the other way
    (sector_lead)."""
    blur = math.ceil(3.0 * equalising_blur(mirror, grid)[1]) if params.equalise else 0
    return blur + 3 * mp.block_size


#: How far (deg of azimuth) before a sampled wedge its matching starts, at most: SGBM_3WAY
#: aggregates its costs down the transposed panorama's rows (azimuth, increasing), and over
#: flat colour a path keeps its disparity for tens of degrees, so a wedge matched from its
#: own edge keeps fewer, better matches than the whole panorama gives the same columns.
#: Measured on the 12-MP design (fast settings, exact mirror, 8 wedges at phase 0 and 1/2,
#: each matched as one stripe): the wedges' median range error against the whole
#: panorama's disparities on the same columns, with SECTOR_LEAD_DEG = 0 / 5 / 10 / 20 / 40:
#: -17 and -21 / -10 and -6 / -3.5 and -1.3 / -1.8 and -0.9 / -0.3 and 0.0 %, matching
#: 0.18 / 0.28 / 0.37 / 0.48 / 0.70 of the turn (phase 0).
SECTOR_LEAD_DEG = 10.0


def sector_lead(grid: PanoramaGrid) -> int:
    """SECTOR_LEAD_DEG in panorama columns."""
    return int(math.ceil(math.radians(SECTOR_LEAD_DEG) / grid.azimuth_step))


#: OpenCV's SGBM_3WAY cuts the matched image's rows into this many stripes (fixed, so its
#: output does not depend on the thread count: calib3d/src/stereosgbm.cpp, num_stripes),
#: stripe k's output rows [k s, (k + 1) s) (s = ceil(rows / CV_STRIPES)) aggregated from
#: row k s - overlap on, overlap = block_size // 2 + 1 + ceil(s / 10), fresh; stripe 0
#: from row 0. On the whole panorama a column's context therefore starts at most a quarter
#: turn and 10 % of it before; a wedge matched as an image of its own would be cut into
#: four stripes of its own (a few degrees of memory), so the segments of all wedges are
#: stacked four to an image, each segment starting where a stripe's aggregation does.
CV_STRIPES = 4


def cv_stripes(rows: int, block_size: int) -> tuple[int, int]:
    """(stripe rows s, overlap) of SGBM_3WAY on an image of `rows` rows (CV_STRIPES)."""
    size = int(math.ceil(rows / CV_STRIPES))
    return size, block_size // 2 + 1 + int(math.ceil(0.1 * size))


@dataclass(frozen=True)
class Segment:
    """Panorama columns matched as one run: `matched` (indices into the turn, contiguous),
    the first `lead` of them context, the last `tail` the filters' reach, the rest counted."""

    matched: np.ndarray
    lead: int
    tail: int

    @property
    def counted(self) -> np.ndarray:
        return self.matched[self.lead:self.matched.size - self.tail]


def sector_segments(sectors: AzimuthSectors, grid: PanoramaGrid, mp: MatchParams, params: StereoParams,
                    mirror: Mirror) -> list[Segment]:
    """The runs the wedges' columns are matched in: each wedge cut where the whole
    panorama's matcher changes stripe (cv_stripes on its n_azimuth rows) or the turn
    wraps, each run led by the columns back to where that stripe's aggregation starts
    (at most sector_lead) and followed by sector_margin columns (not past the turn's end,
    as on the whole panorama)."""
    n = grid.n_azimuth
    size, overlap = cv_stripes(n, mp.block_size)
    lead_max, tail = sector_lead(grid), sector_margin(mirror, grid, mp, params)
    out = []
    for cols in sectors.columns(n):
        cols = np.mod(cols, n)
        stripe = np.minimum(cols // size, CV_STRIPES - 1)
        cuts = np.flatnonzero((np.diff(stripe) != 0) | (np.diff(cols) != 1)) + 1
        for run in np.split(cols, cuts):
            first, last = int(run[0]), int(run[-1])
            k = int(stripe[cols == first][0])
            context = 0 if k == 0 else k * size - overlap
            lead = min(lead_max, first - context)
            after = min(tail, n - 1 - last)
            out.append(Segment(np.arange(first - lead, last + 1 + after), lead, after))
    return out


def _match_columns(grey: np.ndarray, mirror: Mirror, grid: PanoramaGrid, mp: MatchParams,
                   params: StereoParams) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The reference pixels' disparity (NaN unmatched or unseen by either lobe) and both
    panoramas, on the grid's columns (matched as one image: contiguous in azimuth)."""
    pano = _panoramas(grey, mirror, grid, mp, params)
    return _kept(match(pano[0].T, pano[1].T, mp).T, pano, grid.n_elevation, mp.num_disparities)


def _panoramas(grey: np.ndarray, mirror: Mirror, grid: PanoramaGrid, mp: MatchParams,
               params: StereoParams) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Both lobes' panoramas as matched (num_disparities rows beyond the band each way;
    the outer equalised) and where each lobe sees."""
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
    return outer, inner, outer_seen, inner_seen


def _kept(d: np.ndarray, pano, n: int, pad: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The band's disparities (d: the matcher's on the padded panoramas) kept where both
    lobes see what was matched, and the band's panoramas."""
    outer, inner, outer_seen, inner_seen = pano
    d = d[pad:pad + n]
    rows = np.arange(n)[:, None] + pad
    hit = np.clip(np.rint(rows - np.nan_to_num(d)).astype(np.intp), 0, n + 2 * pad - 1)
    ok = np.isfinite(d) & outer_seen[pad:pad + n] & inner_seen[hit, np.arange(d.shape[1])[None, :]]
    return np.where(ok, d, np.nan), outer[pad:pad + n], inner[pad:pad + n]


def _match_segments(grey: np.ndarray, mirror: Mirror, grid: PanoramaGrid, mp: MatchParams,
                    params: StereoParams, segments: list[Segment]) -> list[tuple[np.ndarray, ...]]:
    """Each segment's counted columns (disparity, outer and inner panorama), every segment
    aggregated from its own first column as one of SGBM_3WAY's stripes: stacked four to an
    image (CV_STRIPES), segment k from the row where stripe k's aggregation starts, its
    first `overlap` rows (output by stripe k - 1) within its lead. A segment whose lead is
    shorter starts an image (stripe 0 has no overlap)."""
    panos = [_panoramas(grey, mirror, grid.with_columns(seg.matched), mp, params) for seg in segments]
    longest = max(seg.matched.size for seg in segments)
    size = longest
    while size - cv_stripes(CV_STRIPES * size, mp.block_size)[1] < longest:  # segment k ends before k + 1 starts
        size += 1
    overlap = cv_stripes(CV_STRIPES * size, mp.block_size)[1]
    # a counted column needs its own stripe's rows and their median filter's neighbour
    # (OpenCV filters the stacked disparities 3 x 3)
    images = [[i] for i, seg in enumerate(segments) if seg.lead < overlap + 1]
    for i, seg in enumerate(segments):
        if seg.lead < overlap + 1:
            continue
        free = next((im for im in images if len(im) < CV_STRIPES), None)
        if free is None:
            images.append([i])
        else:
            free.append(i)
    out: list = [None] * len(segments)
    width = panos[0][0].shape[0]
    for members in images:
        left = np.zeros((CV_STRIPES * size, width), np.float32)
        right = np.zeros_like(left)
        starts = [0 if k == 0 else k * size - overlap for k in range(len(members))]
        for start, i in zip(starts, members):
            m = segments[i].matched.size
            left[start:start + m] = panos[i][0].T
            right[start:start + m] = panos[i][1].T
        d = match(left, right, mp)
        for start, i in zip(starts, members):
            seg = segments[i]
            part = _kept(d[start:start + seg.matched.size].T, panos[i], grid.n_elevation, mp.num_disparities)
            out[i] = tuple(x[:, seg.lead:seg.matched.size - seg.tail] for x in part)
    return out


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
