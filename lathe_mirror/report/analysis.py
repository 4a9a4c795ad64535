"""The report's analysis: each made mirror's figures, the curves the plots draw, the
toolpath table, the renders and the range from the image."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from ..compute import Executor, active
from ..design import Mirror
from ..enums import BEST, Strategy
from ..job import MachiningJob, scene_for
from ..nose_envelope import contour_profile
from ..optics.defocus import blur_figures, blur_map, defocus_image, grow_mask, lens_for
from ..optics.distortion import image_displacement, usable_annulus
from ..optics.radial import lobe_pixel_radii, radial_displacement, radial_figures, used_extent
from ..optics.ranging.resolution import resolution_table
from ..optics.ranging.stereo import (SECTOR_LEAD_DEG, error_curve, image_mask, matched_sectors, prepare, range_figures,
                                     sector_margin, sector_segments, stereo_range)
from ..optics.ranging.truth import true_range
from ..optics.render import SSIM_RADIUS_PX, image_differences, render_images, render_sample
from ..optics.sampling import PIXELS_PER_LOBE, RANGE_SECTORS, AzimuthSectors, azimuth_sectors, lobe_pixels, pixel_stride
from ..path import Arc, Line
from ..profile import ExactProfile, Profile
from ..results.base import Range, Stat, plain
from ..results.design import DesignFigures
from ..results.made import (EdgeFigures, LobeFigures, MachineFigures, MadeMirror, MirrorFigures, Moves, PixelFigures,
                            SurfaceErrors, ToolFigures, ToolpathFigures, ZoneFigures)
from ..results.optics import DEPTH_REPORT_M  # noqa: F401 (re-exported: the report's range)
from ..results.optics import (CalibrationFigures, DefocusFigures, ErrorCurve, ImageDifference, RangeFigures, RangingFigures,
                              RenderFigures, ResolutionTable, StereoFigures)
from ..results.polishing import PolishingStudy
from ..results.tolerance import ToleranceAnalysis, Verdict
from ..toolpath import profile_errors

if TYPE_CHECKING:
    from ..iso10110 import PartSpec
    from ..settings import Settings

#: report.json's schema
SCHEMA = "lathe-mirror report 1"
#: The mirrors compared throughout the report, in order.
MIRRORS = ("exact", "paper", "best", "polished")
#: Ranges (m) and elevations (deg) of the report's resolution table.
RESOLUTION_RANGES_M = (0.5, 1.0, 1.5, 2.0, 3.0)
RESOLUTION_ELEVATIONS_DEG = (-20.0, -10.0, 0.0)


#: What each shared figure is measured against (report.json's "definitions"): one
#: definition per name, the same in every output (the G-code header says it beside its own).
FIGURE_DEFINITIONS = {
    "normal_deviation_mm": "the made surface against the DESIGN's sheet (never a program's pre-compensated "
                           "target), the distance along the sheet's normal; mirrors and toolpaths: over each "
                           "whole lobe (r 0..r_junction, r_junction..r_max), the junction fillet included",
    "slope_error_rad": "the angle between the made surface's and the design's normals at the same r; over each "
                       "whole lobe, as normal_deviation_mm",
    "image_displacement_px": "where the exact design images the direction the made surface sends a pixel's ray "
                             "(the scene at infinity: directions), minus the pixel; aligned camera, no calibration; "
                             "over each lobe's used zone (zones); a ray the exact lobe would image outside the "
                             "lobe's annulus is lost (pixels_left_range), not a displacement",
    "reprojection_error_px": "calibration: the design's camera model projecting world points on each made ray at "
                             "range_m from the lobe's viewpoint, minus the pixel (at infinity it is "
                             "image_displacement_px)",
    "blur_px": "the thin-lens blur circle's diameter at each pixel (renders and ranging; defocus)",
}


def figure_definitions(mirror: Mirror) -> dict[str, str]:
    """FIGURE_DEFINITIONS, and on a sensor sampled (optics.sampling: a lobe of more than
    PIXELS_PER_LOBE pixel centres) the sample ("sampled_pixels"); the paper's: none."""
    out = dict(FIGURE_DEFINITIONS)
    sectors = azimuth_sectors(mirror)
    ranged = azimuth_sectors(mirror, count=RANGE_SECTORS)
    if sectors is not None and ranged is not None:
        stride = pixel_stride(mirror)
        out["sampled_pixels"] = (
            f"the larger lobe has {lobe_pixels(mirror):,} pixel centres, more than "
            f"optics.sampling.PIXELS_PER_LOBE ({PIXELS_PER_LOBE:,}): the mirrors' per-pixel figures "
            f"(optics_distortion) over every {stride}th row and column; the renders' differences over "
            f"{sectors.count} azimuth sectors and the range from the image over {ranged.count}, evenly round the "
            f"axis, {100.0 * sectors.fraction:.1f} % of the turn, each pixel the camera's own (traced and matched "
            "with its neighbours out to the filters' reach, and the matcher's context along azimuth); the "
            "report's images black outside them")
    return out


@dataclass(frozen=True, slots=True)
class ReportCurves:
    """The curves the plots draw (arrays, not in the JSON): each made mirror's height error
    along the meridian (r mm, dz mm; `used` marks the radii the image uses) and its radial
    image displacement against image radius (rho px, d px; NaN breaks the line)."""

    profile_error: dict[str, tuple[np.ndarray, np.ndarray]]
    used: np.ndarray
    r_junction: float
    displacement: dict[str, tuple[np.ndarray, np.ndarray]]
    lost_ring_px: tuple[float, float]


@dataclass(frozen=True, slots=True)
class RangeMaps:
    """Each mirror's range map (m; NaN where not ranged) over the common band (deg), and
    the panorama columns ranged (a sample of azimuth, optics.sampling; None: all)."""

    maps: dict[str, np.ndarray]
    band_deg: tuple[float, float]
    columns: tuple[int, ...] | None = None


@dataclass
class ReportData:
    """What the report shows: each stage's typed result (lathe_mirror.results; `figures`
    is their JSON, the report.json), the profiles compared (camera frame), renders
    (arrays) and plots (PNG bytes, filled by report.plots). None: a stage not run."""

    design: DesignFigures
    notes: tuple[str, ...] = ()
    definitions: dict[str, str] | None = None
    spec: PartSpec | None = None
    machine: MachineFigures | None = None
    toolpaths: tuple[ToolpathFigures, ...] | None = None
    polishing: PolishingStudy | None = None
    zones: ZoneFigures | None = None
    mirrors: dict[str, MirrorFigures] | None = None
    made_mirror: MadeMirror | None = None
    calibration: CalibrationFigures | None = None
    stereo: StereoFigures | None = None
    renders: RenderFigures | None = None
    ranging: RangingFigures | None = None
    tolerance: ToleranceAnalysis | None = None
    #: `lathe-mirror run`'s additions: the programs simulated against the stock, the files written
    shop: list[dict[str, Any]] | None = None
    outputs: dict[str, Any] | None = None
    made: dict[str, Profile] = dataclasses.field(default_factory=dict)
    images: dict[str, np.ndarray] = dataclasses.field(default_factory=dict)
    curves: ReportCurves | None = None
    range_maps: RangeMaps | None = None
    plots: dict[str, bytes] = dataclasses.field(default_factory=dict)

    def __repr__(self) -> str:
        # one line: the stages it holds (their figures: `figures`; the arrays are megabytes)
        held = ("notes", "definitions", "made", "images", "plots")
        stages = [f.name for f in dataclasses.fields(self) if f.name not in held and getattr(self, f.name) is not None]
        return (f"ReportData({', '.join(stages)}; {len(self.made)} surfaces, {len(self.images)} images, "
                f"{len(self.plots)} plots)")

    #: report.json's sections, in order (None: not computed, left out)
    SECTIONS = ("notes", "definitions", "design", "spec", "machine", "toolpaths", "polishing", "zones", "mirrors", "made_mirror",
                "calibration", "stereo", "renders", "ranging", "tolerance", "verdict", "shop", "outputs")

    @property
    def verdict(self) -> dict[str, Verdict] | None:
        """Each toleranced program's verdict (the tolerance analysis's)."""
        return None if self.tolerance is None else self.tolerance.verdicts

    @property
    def figures(self) -> dict[str, Any]:
        """Every figure, JSON-ready (report.json): each result's to_dict()."""
        out: dict[str, Any] = {"schema": SCHEMA}
        for name in self.SECTIONS:
            v = getattr(self, name)
            if v is not None:
                out[name] = plain(v)
        return out


def mirror_figures(profile: Profile, mirror: Mirror, zones=None, *, edge_mm: float = 0.0) -> MirrorFigures:
    """The five figures per lobe (ARCHITECTURE.md), surface and optics.

    Surface figures: toolpath.profile_errors. Optical figures: over the pixels each lobe
    images unobstructed on the exact design (optics.radial: every pixel centre, aligned
    camera; equal to optics.distortion's per-pixel figures over the usable annulus, which
    the tests check); those per-pixel figures (with the pixels the step wall vignettes
    counted too under "with_vignetted") are kept alongside (`optics_distortion`), at every
    pixel of a sensor up to optics.sampling.PIXELS_PER_LOBE a lobe, every stride-th row and
    column of a larger one.
    zones (optics.zones.Zones): the optical figures over each lobe's used zone (the ring
    the nose cannot reach left out), its image radii under "zone_px". edge_mm
    (polish.clear_edge_mm): the edge band's own figures (optics.radial.radial_figures).
    """
    surf = profile_errors(profile, mirror)
    rad = radial_figures(profile, mirror, zones=zones, edge_mm=edge_mm)
    # over the same zones as the radial figures; a large sensor sampled (optics.sampling)
    full = image_displacement(profile, mirror, stride=pixel_stride(mirror)).figures(zones)
    lobes = []
    for s, o, f in zip(surf["lobes"], rad["lobes"], full["lobes"]):
        lobes.append(LobeFigures(
            name=s["name"], slope_error_rad=Stat.from_dict(s["slope_error_rad"]),
            normal_deviation_mm=Stat.from_dict(s["normal_deviation_mm"]),
            ray_deviation_deg=Stat.from_dict(o["ray_deviation_deg"]),
            image_displacement_px=Stat.from_dict(o["image_displacement_px"]),
            viewpoint_spread_mm=Stat.from_dict(o["viewpoint_spread_mm"]),
            pixels=o["pixels"], pixels_excluded=o["pixels_excluded"],
            pixels_left_range=o["pixels_left_range"], left_range_pct=o["left_range_pct"],
            zone_px=Range.from_dict(o["zone_px"]) if "zone_px" in o else None,
            edge=EdgeFigures.from_dict(o["edge"]) if "edge" in o else None,
            optics_distortion=PixelFigures.from_dict(f)))
    return MirrorFigures(lobes=tuple(lobes))


def report_curves(made: dict[str, Profile], mirror: Mirror) -> ReportCurves:
    """The report's curves as arrays: each made mirror's height error along the meridian
    (mm; r mm; `used` marks the radii the image uses) and its radial image displacement
    against image radius (px; NaN breaks the line where a lobe has no usable pixel)."""
    names = ("paper", "best", "polished")
    r = np.concatenate([np.linspace(0.0, mirror.r_junction, 4001),
                        np.linspace(np.nextafter(mirror.r_junction, 99.0), mirror.r_max, 3001)])
    exact_z = ExactProfile(mirror).z(r)
    used = (r <= used_extent(mirror, 0)[1]) | (r > mirror.r_junction)
    profile_error = {n: (r, made[n].z(r) - exact_z) for n in names}
    displacement = {}
    for name in names:
        rho, d = [], []
        for k in (0, 1):
            px = lobe_pixel_radii(mirror, k, bin_px=0.25)
            # NaN where radii are missing (vignetted, the lost ring): the line breaks there.
            gap = np.concatenate([[False], np.diff(px.radius_px) > 1.0])
            r_k = np.insert(px.radius_px, np.flatnonzero(gap), np.nan)
            d_k = np.insert(radial_displacement(made[name], mirror, k, px.radius_px), np.flatnonzero(gap), np.nan)
            rho += [r_k, [np.nan]]
            d += [d_k, [np.nan]]
        displacement[name] = (np.concatenate(rho), np.concatenate(d))
    return ReportCurves(profile_error=profile_error, used=used, r_junction=mirror.r_junction,
                        displacement=displacement, lost_ring_px=tuple(mirror.image_radii_px["lost_ring"]))


def strategy_table(job: MachiningJob):
    """As-machined profile per strategy (the job's program of each strategy: with
    polish.precompensate the programs' parts); machine/tool table; toolpath figures per strategy."""
    mirror = job.mirror
    lathe, tool = job.lathe, job.tool
    machine_table = MachineFigures(lathe=dict(lathe.__dict__),
                                   tool=ToolFigures(nose_radius=tool.nose_radius,
                                                    included_angle_deg=math.degrees(tool.included_angle),
                                                    approach_angle_deg=math.degrees(tool.approach_angle)))
    made, table = {}, []
    for strategy in Strategy:
        m = job.but(strategy=strategy).made()
        tp = m.toolpath
        table.append(ToolpathFigures(
            strategy=strategy.value, best=strategy is BEST, n_points=int(tp.n_points),
            moves=Moves(g1=sum(1 for s in tp.segments if isinstance(s, Line)),
                        g2_g3=sum(1 for s in tp.segments if isinstance(s, Arc))),
            programmed=SurfaceErrors.from_dict(profile_errors(contour_profile(tp), mirror)),
            as_machined=SurfaceErrors.from_dict(profile_errors(m.profile, mirror))))
        if strategy is Strategy.PAPER:
            made["paper"] = m.profile
        if strategy is BEST:
            made["best"] = m.profile
    return made, machine_table, tuple(table)


def report_lens(mirror: Mirror, settings: Settings):
    """The lens the report's images are blurred by, and each pixel's blur circle (px):
    optics.defocus, as `render` and `stereo` blur theirs."""
    lens = lens_for(mirror, settings.optimize.focus_range_m * 1000.0)
    return lens, blur_map(mirror, lens, mirror.camera)


#: How far (px) a sampled render traces beyond the counted pixels: the SSIM window's reach
#: (optics.render.SSIM_RADIUS_PX, 5 px) and one pixel of margin.
SSIM_REACH_PX = SSIM_RADIUS_PX + 1


#: The blocks (px) a sampled render is blurred in (optics.defocus_image's tile): its eight
#: narrow wedges fill 128 px blocks better than 256 (12 MP: 1.4 -> 0.9 s an image; the
#: range from the image's wider wedges keep 256).
RENDER_BLUR_TILE = 128


def render_mirrors(made: dict, mirror: Mirror, settings: Settings, zones=None, *,
                   names: tuple[str, ...] = MIRRORS):
    """Each mirror's image of the paper's room (blurred by the lens, optics.defocus), and
    each made image's difference to the exact, over the lobes' usable annuli: every pixel
    while the larger lobe has at most optics.sampling.PIXELS_PER_LOBE (the paper's), else
    the pixels in the azimuth sectors that hold that many (optics.sampling.azimuth_sectors:
    traced out to the blur's and the SSIM window's reach, so each counted pixel's value is
    the full image's; the images black outside them). names: the mirrors, "exact" first."""
    scene = scene_for(settings, mirror)
    lens, blur = report_lens(mirror, settings)
    # Over the lobes' usable annuli, as `lathe-mirror render` states it (the one definition):
    # the step-vignetted band and the frame outside the mirror only dilute the difference.
    mask = usable_annulus(mirror)
    sectors = azimuth_sectors(mirror)
    traced = None
    if sectors is not None:
        mask &= sectors.pixels(mirror.camera.sensor_px)
        traced = traced_pixels(mask, sectors, blur, mirror.camera.sensor_px)
    # blurred only where traced (optics.defocus: the tiles holding them), the rest black
    images = {name: defocus_image(image, blur, pixels=traced, tile=RENDER_BLUR_TILE)
              for name, image in zip(names, render_images([made[n] for n in names], mirror, scene, pixels=traced))}
    diffs = image_differences(images["exact"], {name: images[name] for name in names if name != "exact"}, mask=mask)
    stats = {name: ImageDifference.from_dict(d) for name, d in diffs.items()}
    return images, RenderFigures(against_exact=stats,
                                 defocus=DefocusFigures.from_dict(blur_figures(mirror, lens, zones)))


def traced_pixels(counted: np.ndarray, sectors: AzimuthSectors, blur_px: np.ndarray,
                  sensor_px: tuple[int, int]) -> np.ndarray:
    """The pixels a sampled render traces (H, W bool): every pixel within the blur's and
    the SSIM window's reach (optics.defocus.grow_mask's of blur + 2 SSIM_REACH_PX) of a
    counted pixel, so each counted pixel's value is the full image's. Built from the
    wedges (their edges moved out by the reach) and a circle the reach beyond the farthest
    counted pixel, which hold every disc of that reach about a counted pixel (no distance
    transform of the sensor; a few more pixels than the discs')."""
    reach = math.ceil(float(np.max(blur_px)) / 2.0 + SSIM_REACH_PX) + 1
    w, h = sensor_px
    rr, cc = np.nonzero(counted)
    if rr.size == 0:
        return np.zeros((h, w), bool)
    farthest = float(np.max(np.hypot(cc + 0.5 - w / 2.0, rr + 0.5 - h / 2.0)))
    return sectors.pixels(sensor_px, slack_px=reach, within_px=farthest + reach)


def ranging_figures(made: dict[str, Profile], mirror: Mirror, settings: Settings,
                    zones=None, *, names: tuple[str, ...] = MIRRORS) -> tuple[RangingFigures, RangeMaps]:
    """Range from the image for each of names (default MIRRORS, exact first; optics.ranging,
    the [stereo] settings, aligned camera): figures per mirror against the room's true
    range, the resolution table at the exact mirror's achieved disparity precision, and the
    range maps (m, arrays for the plots; NaN outside the sampled columns). Every column of
    the panorama while the larger lobe has at most optics.sampling.PIXELS_PER_LOBE pixels,
    else the columns in its azimuth sectors (stereo_range(sectors=))."""
    st = settings.stereo
    sectors = azimuth_sectors(mirror, count=RANGE_SECTORS)
    grid, match = prepare(mirror, st.params)
    scene = scene_for(settings, mirror)
    counted = grid if sectors is None else grid.with_columns(np.concatenate(
        [seg.counted for seg in sector_segments(sectors, grid, match, st.params, mirror)]))
    truth = true_range(mirror, scene, counted)
    lens, blur = report_lens(mirror, settings)
    lead = None  # the pixels only the matcher's memory sees (sampled), rendered one ray a pixel
    if sectors is None:
        mask = grow_mask(image_mask(mirror, grid, match.num_disparities), blur)
    else:  # the blur's reach added to the annuli and the wedges (no distance transform of 12 MP)
        reach = math.ceil(float(np.max(blur)) / 2.0) + 1
        mask = image_mask(mirror, grid, match.num_disparities, matched_sectors(sectors, mirror, grid, match, st.params),
                          grow_px=reach)
        if st.supersample > 1:  # the counted columns with the filters' reach either side at full supersample
            side = sector_margin(mirror, grid, match, st.params) * grid.azimuth_step
            lead = mask & ~image_mask(mirror, grid, match.num_disparities, sectors.extended(side, side), grow_px=reach)
    blurred = None if sectors is None else mask
    mirrors, maps = {}, {}
    precision = math.nan
    # Each mirror's image ranged on the command's workers (its rays made here once, the
    # forked workers inherit them): the one stage of a large sensor's report long enough to
    # leave a core idle beside the tolerance analysis; the same results in any order.
    shared = _RangingRays(
        made={name: made[name] for name in names}, mirror=mirror, scene=scene, params=st.params, sectors=sectors,
        blur=blur, blurred=blurred, lead=lead,
        sharp=render_sample(mirror, supersample=st.supersample, pixels=mask if lead is None else mask & ~lead),
        lead_rays=None if lead is None else render_sample(mirror, pixels=lead))
    ex = active()
    with (ex if ex.kind == "processes" else Executor()).bound(shared) as run:  # a cluster: here
        results = dict(zip(names, run.map(_ranged, list(names))))
    for name in names:  # exact first: its disparity error is the matcher's precision
        result = results[name]
        fig = RangeFigures.from_dict(range_figures(result, truth, mirror,
                                                   precision_px=None if name == "exact" else precision))
        if name == "exact":
            precision = fig.disparity_error_px.precision
        curve = ErrorCurve.from_dict({**error_curve(result, truth, mirror, precision), "precision_px": precision})
        mirrors[name] = dataclasses.replace(fig, error_curve=curve)
        rng = result.range_map.range_mm / 1e3
        if sectors is not None:  # the map over the turn, the columns not sampled without a range
            full = np.full(grid.shape, np.nan)
            full[:, np.asarray(counted.columns)] = rng
            rng = full
        maps[name] = rng
    table = resolution_table(mirror, RESOLUTION_RANGES_M, RESOLUTION_ELEVATIONS_DEG, precision * grid.step)
    figures = RangingFigures(
        definition="range error = 100 (R - R_true) / R_true, R from the stereo centre triangulated from "
                   "StereoSGBM disparities of the two lobes' panoramas (rendered at supersample "
                   f"{st.supersample}, blurred by the lens's defocus: `defocus`), R_true the room along the "
                   "outer lobe's pixel ray; over the common band's pixels with a range (valid_fraction of them)"
                   + ("" if sectors is None else
                      f"; sampled: the panorama columns in {sectors.count} azimuth sectors evenly round the axis, "
                      f"{100.0 * sectors.fraction:.1f} % of the turn (optics.sampling.PIXELS_PER_LOBE pixels of the "
                      f"larger lobe), each matched at full resolution with the whole panorama's context along "
                      f"azimuth, at most {SECTOR_LEAD_DEG:g} deg of it (optics.ranging.stereo.sector_segments; "
                      "rendered one ray a pixel where only the matcher's memory sees it)"),
        supersample=st.supersample,
        matcher_precision_px=precision,
        resolution=ResolutionTable.from_dict(table),
        mirrors=mirrors,
        defocus=DefocusFigures.from_dict(blur_figures(mirror, lens, zones)),
    )
    return figures, RangeMaps(maps=maps, band_deg=tuple(math.degrees(x) for x in grid.band), columns=counted.columns)


@dataclass(frozen=True)
class _RangingRays:
    """What ranging_figures' workers share: the mirrors, the rays (optics.render.RenderSample)
    of the supersampled pixels and of the lead rendered one ray a pixel, the blur."""

    made: dict
    mirror: Mirror
    scene: object
    params: object
    sectors: object
    blur: np.ndarray
    blurred: np.ndarray | None
    lead: np.ndarray | None
    sharp: object
    lead_rays: object


def _ranged(shared: _RangingRays, name: str):
    """One mirror's image rendered, blurred by the lens and ranged (optics.ranging.stereo_range)."""
    profile = shared.made[name]
    image = shared.sharp.render(profile, shared.scene)
    if shared.lead is not None:
        image[shared.lead] = shared.lead_rays.render(profile, shared.scene)[shared.lead]
    image = defocus_image(image, shared.blur, pixels=shared.blurred)
    return stereo_range(image, shared.mirror, shared.params, sectors=shared.sectors)
