"""The plot of a measured part: measured minus design along the radius (matplotlib Agg,
PNG bytes, no disk)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from .plots import LOBE_COLOURS, png

if TYPE_CHECKING:
    from ..measure.fit import TraceFit


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def residual_plot(fit: TraceFit) -> bytes:
    """The trace's points (folded about the fitted axis) and each lobe's smoothed residual
    over its clear aperture, measured minus design, um against r (mm)."""
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(8, 3.4))
    r, d = fit.r, fit.resid * 1e3
    used = fit.used
    ax.plot(r[used], d[used], ".", ms=0.6, color="0.6", label="trace (folded, used)")
    lo, hi = np.inf, -np.inf
    for lf in fit.lobes:
        g = np.linspace(lf.r_lo, lf.r_hi, 800)
        v = fit.residual_at(g) * 1e3
        ax.plot(g, v, lw=1.2, color=LOBE_COLOURS.get(lf.name), label=f"{lf.name}: PV {lf.pv_um:.2f} um, "
                f"RMS {lf.rms_um:.2f} um")
        lo, hi = min(lo, float(v.min())), max(hi, float(v.max()))
    if np.isfinite(lo):
        pad = max(0.5 * (hi - lo), 0.5)
        ax.set_ylim(lo - pad, hi + pad)
    ax.axvline(fit.mirror.r_junction, color="grey", lw=0.5, ls="--")
    ax.set_xlabel("r (mm)")
    ax.set_ylabel("measured - design (um)")
    ax.set_title(f"{fit.trace.source}: decentre {fit.decentre_mm * 1e3:.2f} um, tilt {fit.tilt_rad * 1e6:.1f} urad")
    ax.legend(loc="best", fontsize=7)
    ax.grid(alpha=0.3)
    return png(fig)
