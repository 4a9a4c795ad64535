"""The report's plots: plain data in, PNG bytes out (matplotlib, Agg, no disk).

Each helper draws one figure from data the report already holds in its JSON, so a plot
never shows a number the JSON does not. PNGs carry no timestamp or software tag, so the
same data gives the same bytes.
"""

from __future__ import annotations

import io
from typing import TYPE_CHECKING

import numpy as np

from ..compute import active
from ..tolerance.stats import percent_interval
from .range_plots import error_vs_range_png, range_maps_png

if TYPE_CHECKING:
    from ..results.optics import DepthCurve
    from ..results.polishing import Decomposition, LapPlan, PolishCurveFigures
    from .analysis import ReportData

LOBE_COLOURS = {"inner": "tab:blue", "outer": "tab:orange"}
MIRROR_COLOURS = {"exact": "black", "paper": "tab:red", "best": "tab:green", "polished": "tab:purple"}


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    plt.rcParams.update({"font.size": 9, "svg.hashsalt": "lathe-mirror"})
    return plt


def png(fig, *, crop: bool = True) -> bytes:
    """The figure as PNG bytes, without metadata that would change from run to run.
    crop: to the drawn content (a tight bounding box: the figure drawn twice); False for a
    figure laid out already (tight_layout)."""
    buf = io.BytesIO()
    if not crop and _pyplot().rcParams["figure.autolayout"] is False:
        # tight_layout leaves a placeholder layout engine, for which savefig lays the figure
        # out once more (a whole draw with the drawing switched off, a third of the cost of
        # a 2 x 2 figure) to change nothing: the figure is laid out, so none (same pixels)
        fig.set_layout_engine(None)
    fig.savefig(buf, format="png", dpi=100, metadata={"Software": None}, bbox_inches="tight" if crop else None)
    _pyplot().close(fig)
    return buf.getvalue()


def image_png(img: np.ndarray) -> bytes:
    """An RGB uint8 array as PNG bytes (Pillow, no metadata)."""
    from PIL import Image

    buf = io.BytesIO()
    Image.fromarray(np.asarray(img, dtype=np.uint8)).save(buf, format="PNG", optimize=False)
    return buf.getvalue()


#: Pixels on the shorter side a render is drawn from at most ~twice over: each is shown about
#: 300 px wide, so a larger one is first averaged over blocks of whole pixels (the paper's
#: 1008 x 1018 drawn as it is; a 12-MP render over 3 x 3 blocks: matplotlib's resampling of
#: 12 M pixels cost 1.5 s an image).
DRAW_SHORT_PX = 1000


def drawn_image(img: np.ndarray) -> np.ndarray:
    """An RGB uint8 image as drawn: the mean over f x f blocks (f = its shorter side //
    DRAW_SHORT_PX, rounded; the rows and columns past the last whole block dropped), or the
    image itself where f is 1."""
    img = np.asarray(img)
    f = min(img.shape[:2]) // DRAW_SHORT_PX
    if f <= 1:
        return img
    h, w = img.shape[0] // f * f, img.shape[1] // f * f
    rows = sum(img[i:h:f, :w].astype(np.uint32) for i in range(f))  # f strided adds, not a reshape's sum
    blocks = sum(rows[:, j::f] for j in range(f))
    return ((blocks + (f * f) // 2) // (f * f)).astype(np.uint8)


def images_side_by_side(images: dict[str, np.ndarray]) -> bytes:
    """Renders in a row, titled by their names (drawn_image of each)."""
    plt = _pyplot()
    n = len(images)
    fig, axes = plt.subplots(1, n, figsize=(3.2 * n, 3.4))
    for ax, (name, img) in zip(np.atleast_1d(axes), images.items()):
        ax.imshow(drawn_image(img))
        ax.set_title(name)
        ax.set_axis_off()
    return png(fig)


def profile_deviation_plot(curves: dict[str, tuple[np.ndarray, np.ndarray]], r_junction: float,
                           used: np.ndarray | None = None) -> bytes:
    """Signed height error (um) of each made surface against r (mm).

    used: mask of the radii the image uses; the y range is fitted to them, so the tool's
    fillet in the inside corner (hundreds of um, unused) runs off the scale.
    """
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(8, 3.2))
    lo, hi = np.inf, -np.inf
    for name, (r, dz) in curves.items():
        ax.plot(r, dz * 1e3, lw=0.7, label=name, color=MIRROR_COLOURS.get(name))
        sel = dz[used] if used is not None else dz
        lo, hi = min(lo, float(np.nanmin(sel))), max(hi, float(np.nanmax(sel)))
    if used is not None and np.isfinite(lo):
        pad = 0.1 * (hi - lo) + 1e-4
        ax.set_ylim((lo - pad) * 1e3, (hi + pad) * 1e3)
    ax.axvline(r_junction, color="grey", lw=0.5, ls="--")
    ax.set_xlabel("r (mm)")
    ax.set_ylabel("z made - z exact (um)")
    ax.set_title("as-machined / polished height error along the meridian (camera frame)")
    ax.legend(loc="best")
    ax.grid(alpha=0.3)
    return png(fig)


def displacement_plot(curves: dict[str, tuple[np.ndarray, np.ndarray]], lost_ring: tuple[float, float]) -> bytes:
    """Radial image displacement (px) against image radius (px), one line per mirror."""
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(8, 3.2))
    for name, (rho, d) in curves.items():
        ax.plot(rho, d, lw=0.6, label=name, color=MIRROR_COLOURS.get(name))
    ax.axvspan(*lost_ring, color="grey", alpha=0.3, label="lost ring (step wall)")
    ax.set_xlabel("image radius (px)")
    ax.set_ylabel("radial image displacement (px)")
    ax.set_yscale("symlog", linthresh=0.1)
    ax.legend(loc="best")
    ax.grid(alpha=0.3)
    return png(fig)


def polishing_curve_plot(curve: PolishCurveFigures, title: str) -> bytes:
    """Against polishing time: image displacement, the calibrated stereo residual and the
    depth error, slope error over the clear aperture, roughness and haze; a dashed line at
    the time each objective chooses (the curve's own in purple)."""
    plt = _pyplot()
    t = np.asarray(curve.times_s) / 60.0
    fig, axes = plt.subplots(2, 2, figsize=(11, 6.4))
    ax_d, ax_s, ax_sl, ax_r = axes.ravel()
    comb = curve.combined
    for lb in curve.lobes:
        c = LOBE_COLOURS[lb.name]
        ax_d.plot(t, lb.image_displacement_px.rms, color=c, label=f"{lb.name} RMS")
        ax_sl.plot(t, lb.slope_error_rad.rms, color=c, label=lb.name)
        if lb.roughness_nm is not None:
            ax_r.plot(t, lb.roughness_nm.rms, color=c, label=f"{lb.name} roughness (nm RMS)")
            ax_r.plot(t, 100.0 * np.asarray(lb.haze.mean), color=c, ls=":", label=f"{lb.name} haze (%)")
    ax_d.plot(t, comb.image_displacement_px, color="black", label="both lobes")
    rng = curve.range_m
    ax_s.plot(t, np.maximum(comb.stereo_residual_pct, 1e-3), color="tab:purple",
              label=f"calibrated stereo residual at {rng:g} m")
    ax_s.plot(t, np.maximum(comb.depth_error_pct, 1e-3), color="grey", label=f"depth error at {rng:g} m (design assumed)")
    styles = {"stereo": "tab:purple", "image_displacement": "black", "slope_error": "tab:green"}
    for ax in axes.ravel():
        for obj, ts in curve.chosen_time_s.items():
            ax.axvline(ts / 60.0, color=styles.get(obj, "grey"), ls="--", lw=1.2 if obj == curve.objective else 0.6)
        ax.set_xlabel("polishing time per lobe (min)")
        ax.grid(alpha=0.3)
        ax.legend(loc="best", fontsize=7)
    ax_d.set_ylabel("image displacement (px)")
    ax_s.set_ylabel("RMS |depth error| (%)")
    ax_sl.set_ylabel("slope error RMS, clear aperture (rad)")
    ax_r.set_ylabel("roughness (nm) / haze (%)")
    for ax in (ax_d, ax_s, ax_sl, ax_r):
        ax.set_yscale("log")
    fig.suptitle(f"{title} (dashed: the time each objective chooses; purple: stereo, black: image "
                 f"displacement, green: slope)")
    fig.tight_layout()
    return png(fig, crop=False)


def decomposition_plot(decomposition: dict[str, Decomposition]) -> bytes:
    """Depth error (RMS over the band, %) of a polished mirror, of the design carrying only its
    form, only its facets, and only the lap's removal: uncalibrated and calibrated, for each
    polishing in the decomposition (first model, this plan)."""
    plt = _pyplot()
    names = list(decomposition)
    parts = ("made", "form", "facets", "removal_only")
    labels = {"made": "polished mirror", "form": "design + its form", "facets": "design + its facets",
              "removal_only": "design + the lap's removal"}
    fig, axes = plt.subplots(1, len(names), figsize=(5.5 * len(names), 3.6), squeeze=False)
    for ax, name in zip(axes[0], names):
        d = decomposition[name]
        x = np.arange(len(parts))
        raw = [max(d.depth_error_pct[p].rms, 1e-3) for p in parts]
        cal = [max(d.stereo_residual_pct[p].rms, 1e-3) for p in parts]
        ax.bar(x - 0.2, raw, 0.4, color="tab:red", label="design assumed")
        ax.bar(x + 0.2, cal, 0.4, color="tab:purple", label="calibrated")
        for xi, v in zip(x, raw):
            ax.text(xi - 0.2, v, f"{v:.2g}", ha="center", va="bottom", fontsize=7)
        for xi, v in zip(x, cal):
            ax.text(xi + 0.2, v, f"{v:.2g}", ha="center", va="bottom", fontsize=7)
        ax.set_xticks(x, [labels[p] for p in parts], rotation=15, fontsize=8)
        ax.set_yscale("log")
        ax.set_ylabel(f"RMS |depth error| at {d.range_m:g} m (%)")
        what = "first model: fixed lap" if name == "first_model" else f"this plan: {d.lap} lap"
        ax.set_title(f"{what}, {d.time_s / 60:.0f} min")
        ax.grid(alpha=0.3, axis="y")
        ax.legend(loc="best", fontsize=7)
    fig.suptitle("Form against facets: the depth error of each part of the polished paper mirror alone")
    fig.tight_layout()
    return png(fig, crop=False)


def lap_plot(plan: LapPlan) -> bytes:
    """The lap's removal rate (um/h) along r on a smooth surface, per lobe."""
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(8, 2.8))
    for lb, name in zip(plan.lobes, ("inner", "outer")):
        ax.plot(lb.r_mm, lb.removal_rate_um_per_h, color=LOBE_COLOURS[name], label=f"{name} lobe")
    ax.set_xlabel("r (mm)")
    ax.set_ylabel("removal rate (um/h)")
    ax.set_title("the lap's removal along r (dwell-time profile included; zero where the pad does not reach)")
    ax.grid(alpha=0.3)
    ax.legend(loc="best")
    return png(fig)


def depth_error_plot(curves: dict[str, DepthCurve]) -> bytes:
    """RMS |depth error| (%, each point capped at 100) over the common band against range (m),
    one line per mirror."""
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(6, 3.4))
    for name, c in curves.items():
        y = np.maximum(np.asarray(c.depth_error_pct.rms), 1e-12)
        ax.plot(c.ranges_m, y, marker=".", label=name, color=MIRROR_COLOURS.get(name))
    ax.set_xlabel("range (m)")
    ax.set_ylabel("RMS |depth error| (%, each point capped at 100)")
    ax.set_yscale("log")
    ax.grid(alpha=0.3, which="both")
    ax.legend(loc="best")
    return png(fig)


def monte_carlo_histograms(per_trial: dict, limits: dict, *, calibrated: bool, passed: int, title: str = "",
                           delivered: dict | None = None) -> bytes:
    """Histograms of the trials' judged figures (image displacement per lobe, disparity
    90th percentile, slope error per lobe) with the limits; the yield with its Wilson
    95 % interval in the title; with `delivered` ({design, p5, median}, m) and the trials'
    delivered_r10_m, a fourth panel: the delivered R10 beside the design's."""
    plt = _pyplot()
    disp = np.asarray(per_trial["image_displacement_px_rms"])
    slope = np.asarray(per_trial["slope_error_rad_rms"])
    disparity = np.asarray(per_trial["disparity_px_p90"], dtype=float)
    r10 = per_trial.get("delivered_r10_m") if delivered else None
    fig, axes = plt.subplots(1, 4 if r10 is not None else 3, figsize=(14.5 if r10 is not None else 11, 3.2))
    if r10 is not None:
        r10 = 1e3 * np.asarray(r10, dtype=float)
        axes[3].hist(np.nan_to_num(r10, nan=0.0), bins=40, color="grey", label="made parts", histtype="stepfilled")
        axes[3].axvline(1e3 * delivered["design"], color="black", ls="-", label="design")
        axes[3].axvline(1e3 * delivered["p5"], color="red", ls="--", label="5th percentile")
        axes[3].set_xlabel("delivered R10 (mm)")
    for k, name in enumerate(("inner", "outer")):
        axes[0].hist(np.clip(disp[:, k], 0, 5 * limits["image_displacement_px"]), bins=40, alpha=0.6,
                     color=LOBE_COLOURS[name], label=name, histtype="stepfilled")
        axes[2].hist(slope[:, k], bins=40, alpha=0.6, color=LOBE_COLOURS[name], label=name, histtype="stepfilled")
    cap = 5 * limits["disparity_px"]
    axes[1].hist(np.clip(np.nan_to_num(disparity, nan=cap, posinf=cap), 0, cap), bins=40, color="grey",
                 label="90 % of the band", histtype="stepfilled")
    axes[0].axvline(limits["image_displacement_px"], color="red", ls="--", label="limit")
    axes[1].axvline(limits["disparity_px"], color="red", ls="--", label="limit")
    axes[2].axvline(limits["slope_error_rad"], color="red", ls="--", label="limit")
    which = "calibrated" if calibrated else "raw"
    axes[0].set_xlabel(f"RMS image displacement, {which} (px)")
    axes[1].set_xlabel(f"disparity error (90 %), {which} (px)")
    axes[2].set_xlabel("RMS slope error (rad)")
    for ax in axes:
        ax.set_ylabel("trials")
        ax.legend(loc="best")
        ax.grid(alpha=0.3)
    fig.suptitle(f"Monte Carlo{', ' + title if title else ''}: yield {percent_interval(passed, disp.shape[0])}"
                 " (image and disparity clipped at 5x their limits)")
    fig.tight_layout()
    return png(fig, crop=False)


def report_plots(data: ReportData) -> dict[str, bytes]:
    """Every plot of the report, from what the pipeline handed it (figures, curves, renders):
    drawn on the command's executor (lathe_mirror.compute: the plots are independent, each
    worker draws whole plots), in the order of plot_jobs; the same bytes as one by one.
    The plots already in data.plots (drawn earlier, e.g. while the tolerance analysis
    ran) are kept, not drawn again."""
    jobs = plot_jobs(data)
    names = [name for name, _ in jobs if name not in data.plots]
    ex = active()
    if ex.workers == 1 or len(names) < 2:
        drawn = {name: draw() for name, draw in jobs if name in names}
    else:
        _pyplot()  # imported once here: the forked workers inherit it
        with ex.bound(data) as run:
            drawn = dict(zip(names, run.map(_draw_one, names)))
    return {name: data.plots[name] if name in data.plots else drawn[name] for name, _ in jobs}


def _draw_one(data: ReportData, name: str) -> bytes:
    return dict(plot_jobs(data))[name]()


def plot_jobs(data: ReportData) -> list[tuple[str, object]]:
    """(name, a function of no arguments drawing it) of every plot of the report, in order."""
    curves = data.curves
    jobs = [("profile_error", lambda: profile_deviation_plot(curves.profile_error, curves.r_junction, curves.used)),
            ("displacement", lambda: displacement_plot(curves.displacement, curves.lost_ring_px))]
    pol = data.polishing
    jobs += [("polishing_paper", lambda: polishing_curve_plot(pol.paper_program,
                                                              "polishing the paper program's mirror")),
             ("polishing_best", lambda: polishing_curve_plot(pol.best_program, "polishing the best program's mirror")),
             ("polishing_decomposition", lambda: decomposition_plot(pol.decomposition)),
             ("polishing_lap", lambda: lap_plot(pol.lap_plan)),
             ("depth_error", lambda: depth_error_plot(data.stereo.curves))]
    if data.images:
        jobs.append(("images", lambda: images_side_by_side(data.images)))
    if data.range_maps is not None:
        rm = data.range_maps
        jobs.append(("range_maps", lambda: range_maps_png(rm.maps, rm.band_deg, sampled=rm.columns)))
        jobs.append(("range_error", lambda: error_vs_range_png(
            {n: m.error_curve.to_dict() for n, m in data.ranging.mirrors.items()},
            title="median |range error| against range, each mirror, with the resolution model",
            colours=MIRROR_COLOURS)))
    for name, t in (data.tolerance.programs if data.tolerance else {}).items():
        mc = t.monte_carlo
        jobs.append((f"monte_carlo_{name}", lambda mc=mc, name=name: monte_carlo_histograms(
            mc.per_trial, mc.limits, calibrated=mc.calibrated, passed=mc.passed, title=f"{name} program",
            delivered=mc.delivered_r10_m)))
    return jobs


def pareto_plot(label: str, candidates: dict[str, np.ndarray], fronts: dict[str, np.ndarray],
                marks: dict[str, dict[str, float]]) -> bytes:
    """The design optimiser's Pareto plot: the objective (`label`) against the common band's
    width and against the mirror's depth, two panels.

    candidates: "objective", "band_width_deg", "depth_mm" of every feasible design the
    search evaluated; fronts: "band" and "depth", indices into them of each front (more
    objective for more band; more objective for less depth); marks: named designs (the
    paper's, the winner) with the same three keys.
    """
    plt = _pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(10.0, 4.0))
    styles = {0: dict(marker="*", s=160, color="tab:red", zorder=5),
              1: dict(marker="D", s=60, color="tab:green", zorder=5)}
    for ax, (xkey, xlabel, front) in zip(axes, (("band_width_deg", "common band width [deg]", "band"),
                                                ("depth_mm", "mirror depth [mm]", "depth"))):
        ax.scatter(candidates[xkey], candidates["objective"], s=4, color="0.75", label="feasible designs",
                   rasterized=True)
        f = np.asarray(fronts[front], dtype=int)
        if f.size:
            order = np.argsort(candidates[xkey][f])
            ax.plot(candidates[xkey][f][order], candidates["objective"][f][order], "-o", ms=3,
                    color="tab:blue", label="Pareto front")
        for i, (name, m) in enumerate(marks.items()):
            ax.scatter([m[xkey]], [m["objective"]], label=name, **styles[i % 2])
        ax.set_xlabel(xlabel)
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
    axes[0].legend(loc="best", fontsize=8)
    fig.suptitle("design optimiser: the objective against the band and the depth")
    return png(fig)
