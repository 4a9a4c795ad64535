"""Plots of the distortion figures, as PNG bytes (matplotlib Agg; the caller writes them)."""

from __future__ import annotations

import io

import numpy as np

from .distortion import LOBE_NAMES, DistortionMaps


def displacement_vs_radius_png(maps: DistortionMaps, *, title: str = "") -> bytes:
    """Signed radial image displacement (px) against image radius (px), one colour per lobe."""
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(7, 4), dpi=120)
    for k, name in enumerate(LOBE_NAMES):
        # Every pixel of one image radius has the same displacement on an aligned camera:
        # plot each distinct radius once.
        rho, idx = np.unique(np.round(maps.lobe_values(k, "radius_px"), 6), return_index=True)
        ax.plot(rho, maps.lobe_values(k, "radial_px")[idx], ".", ms=1.5, label=f"{name} lobe")
    vig = maps.blocked & (maps.lobe >= 0)
    if vig.any():  # the exact design's pixels whose view the step wall blocks
        ax.axvspan(float(maps.radius_px[vig].min()), float(maps.radius_px[vig].max()),
                   color="0.85", zorder=0, label="vignetted by the step")
    ax.axhline(0.0, color="0.5", lw=0.6)
    ax.set_xlabel("image radius (px)")
    ax.set_ylabel("radial image displacement (px)")
    ax.set_title(title or "made mirror against the exact design")
    ax.legend(markerscale=6)
    ax.grid(alpha=0.3)
    return _png(fig)


def displacement_map_png(maps: DistortionMaps, *, title: str = "") -> bytes:
    """The sensor coloured by signed radial image displacement (px); grey where unusable."""
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(6, 6), dpi=120)
    data = np.ma.masked_invalid(np.where(maps.usable, maps.radial_px, np.nan))
    lim = float(np.nanmax(np.abs(data))) if data.count() else 1.0
    cmap = plt.get_cmap("coolwarm").with_extremes(bad="0.75")
    im = ax.imshow(data, cmap=cmap, vmin=-lim, vmax=lim, interpolation="antialiased")
    fig.colorbar(im, ax=ax, shrink=0.8, label="radial image displacement (px)")
    ax.set_title(title or "image displacement map")
    ax.set_xlabel("column (px)")
    ax.set_ylabel("row (px)")
    return _png(fig)


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _png(fig) -> bytes:
    buf = io.BytesIO()
    # No software/date metadata: the same figures give the same bytes.
    fig.savefig(buf, format="png", metadata={"Software": None})
    import matplotlib.pyplot as plt

    plt.close(fig)
    return buf.getvalue()
