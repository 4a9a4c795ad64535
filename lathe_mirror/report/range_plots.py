"""Plots of stereo ranging: range panoramas with a colour bar, error against range with the
resolution model. Plain data in, PNG bytes out (matplotlib Agg, no metadata: the same data
gives the same bytes); the caller writes them (export.files)."""

from __future__ import annotations

import math

import numpy as np

#: Colour scale of every range map (m), so maps of several mirrors compare.
RANGE_SCALE_M = (0.5, 3.0)
#: Colour of pixels without a range.
NO_RANGE = "0.8"


def preload():
    """Import matplotlib's pyplot in a background thread and return the thread: a caller
    that will plot after seconds of numpy work (which releases the GIL) overlaps the
    import (about 0.5 s) with it."""
    import threading

    thread = threading.Thread(target=_pyplot, name="preload-matplotlib", daemon=True)
    thread.start()
    return thread


def range_map_png(range_m: np.ndarray, band_deg: tuple[float, float], *, title: str = "") -> bytes:
    """One range panorama (m, (n_el, n_az), NaN where there is no range), azimuth across,
    elevation up, with a colour bar; pixels without a range in light grey."""
    plt = _pyplot()
    fig = plt.figure(figsize=(12, 2.6))
    ax = fig.add_axes((0.055, 0.19, 0.86, 0.68))
    im = _draw_map(ax, plt, range_m, band_deg)
    fig.colorbar(im, cax=fig.add_axes((0.93, 0.19, 0.012, 0.68)), label="range (m)")
    ax.set_title(title or "range from the stereo centre (grey: no range)")
    return png(fig)


def range_maps_png(maps: dict[str, np.ndarray], band_deg: tuple[float, float], *,
                   sampled: np.ndarray | None = None) -> bytes:
    """Range panoramas of several mirrors stacked, titled by name and the share of the
    pixels ranged (map_title), one colour bar. sampled: the panorama columns ranged (a
    sample of azimuth, optics.sampling; None: every column); the others drawn white."""
    plt = _pyplot()
    n = len(maps)
    fig, axes = plt.subplots(n, 1, figsize=(12, 1.9 * n + 0.4), squeeze=False, layout="constrained")
    im = None
    for ax, (name, rng) in zip(axes[:, 0], maps.items()):
        im = _draw_map(ax, plt, rng, band_deg, sampled=sampled)
        ax.set_title(map_title(name, rng, sampled), fontsize=9)
    fig.colorbar(im, ax=axes[:, 0].tolist(), label="range (m)", fraction=0.03, pad=0.01)
    return png(fig)


def map_title(name: str, range_m: np.ndarray, sampled: np.ndarray | None = None) -> str:
    """A range map's title: the share of the pixels it ranged among those it tried, the
    whole band, or with sampled (column indices) the band's pixels in those columns (and
    the share of the turn they are)."""
    rng = np.asarray(range_m)
    if sampled is None:
        share = float(np.isfinite(rng).mean()) if rng.size else 0.0
        return f"{name}: {100 * share:.1f} % of the band ranged"
    cols = np.unique(np.asarray(sampled, np.intp))
    tried = rng[:, cols]
    share = float(np.isfinite(tried).mean()) if tried.size else 0.0
    return (f"{name}: {100 * share:.1f} % of the sampled band ranged "
            f"({100 * cols.size / rng.shape[1]:.1f} % of the turn sampled, white: not sampled)")


def error_vs_range_png(curves: dict[str, dict], *, title: str = "",
                       colours: dict[str, str] | None = None) -> bytes:
    """Median |range error| (%) against true range (m) per mirror (stereo.error_curve's
    lists), with the resolution model at one pixel of disparity and at the matcher's
    precision (dashed, of the first curve: the model is the design's, not the mirror's).
    colours: per mirror name (default black)."""
    plt = _pyplot()
    fig = plt.figure(figsize=(9, 4))
    ax = fig.add_axes((0.085, 0.12, 0.6, 0.8))
    first = True
    for name, c in curves.items():
        if not c["range_m"]:
            continue
        if first:
            ax.plot(c["range_m"], c["model_1px_pct"], "--", color="0.3", label="model, 1 px of disparity")
            ax.plot(c["range_m"], c["model_matcher_pct"], ":", color="0.3",
                    label=f"model, the matcher's precision ({c.get('precision_px', math.nan):.2f} px)")
            first = False
        ax.plot(c["range_m"], c["measured_pct"], "o-", ms=3, color=(colours or {}).get(name, "black"),
                label=f"{name}, measured")
    ax.set_yscale("log")
    ax.set_xlabel("true range (m)")
    ax.set_ylabel("median |range error| (%)")
    ax.set_title(title or "range error against range")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.02, 1.0))
    return png(fig)


def png(fig) -> bytes:
    """The figure as PNG bytes, no metadata; laid out by the figure itself (a tight
    bounding box would draw it twice)."""
    import io

    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=100, metadata={"Software": None})
    _pyplot().close(fig)
    return buf.getvalue()


#: Panorama pixels (columns, rows) a map is drawn from at most ~twice over: the maps are
#: drawn about 1030 x 150 px (nearest neighbour), so a larger one is first cut to every
#: f-th column and row (the paper's 2512 x 236 drawn as it is; the 12-MP design's 7608 x 652
#: every 3rd column and 2nd row: colouring 5 M pixels cost 0.6 s a map).
DRAW_MAP_PX = (2000, 300)


def _draw_map(ax, plt, range_m: np.ndarray, band_deg: tuple[float, float], *, sampled: np.ndarray | None = None):
    cmap = plt.get_cmap("viridis").with_extremes(bad=NO_RANGE)
    lo, hi = band_deg
    extent = (0.0, 360.0, lo, hi)
    # nearest neighbour of a coarser grid: the middle column and row of each f x f block
    fc, fr = (max(1, n // m) for n, m in zip(np.shape(range_m)[::-1], DRAW_MAP_PX))
    cols = np.arange(fc // 2, np.shape(range_m)[1], fc)
    range_m = np.asarray(range_m)[fr // 2::fr, cols]
    if sampled is not None:
        sampled = np.flatnonzero(np.isin(cols, np.asarray(sampled, np.intp)))
    im = ax.imshow(np.ma.masked_invalid(range_m), cmap=cmap, vmin=RANGE_SCALE_M[0], vmax=RANGE_SCALE_M[1],
                   extent=extent, aspect="auto", interpolation="nearest")
    if sampled is not None:  # the columns not sampled in white over the map, so grey is "tried, no range"
        veil = np.ones((1, np.shape(range_m)[1], 4))  # opaque white
        veil[0, np.asarray(sampled, np.intp), 3] = 0.0  # clear over the sampled columns
        ax.imshow(veil, extent=extent, aspect="auto", interpolation="nearest")
    ax.set_xlabel("azimuth (deg)")
    ax.set_ylabel("elevation (deg)")
    ax.set_xticks(np.arange(0, 361, 45))
    return im


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    plt.rcParams.update({"font.size": 9})
    return plt
