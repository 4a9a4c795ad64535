"""The polishing curve: a made surface's optical and form figures against polishing time.

polishing.py evolves the surface (Preston's law, compliant pad); this module judges each
snapshot with the optics (optics.radial: image displacement over each lobe's usable pixels;
slope error and form change over the radii the image uses) and picks the time that
minimises the image displacement.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from ..design import Mirror
from ..polishing import PolishParams, polish_series
from ..profile import Profile, SampledProfile
from ..progress import bar as progress_bar


def form_change(profile: Profile, mirror: Mirror, *, degree: int = 4, n: int = 2001) -> dict:
    """Per-lobe form change: the low-order part of (profile - design), mm.

    A least-squares Legendre fit of the given degree in r over the extent of each lobe the
    image uses (optics.radial.used_extent: the inner lobe stops where the step wall
    starts to vignette its rays, which also leaves out the tool's corner fillet); returns
    {"rms", "max"} of that fit (all terms, piston included: the lap removes nothing at
    the vertex, so its piston is real removal) under "form_change_mm", plus the fit's
    peak-to-valley "form_pv_mm".
    """
    from .radial import used_extent

    lobes = []
    for k, lobe in enumerate(mirror.lobes):
        lo, hi = used_extent(mirror, k)
        r = np.linspace(lo, hi, n)
        if k == 1:
            r[0] = np.nextafter(lo, hi)
        dz = np.asarray(profile.z(r)) - lobe.z(r)
        x = (2.0 * r - (lo + hi)) / (hi - lo)
        fit = np.polynomial.legendre.Legendre.fit(x, dz, degree, domain=[-1, 1])(x)
        lobes.append({"name": lobe.name,
                      "form_change_mm": {"rms": float(np.sqrt(np.mean(fit**2))),
                                         "max": float(np.max(np.abs(fit)))},
                      "form_pv_mm": float(np.ptp(fit))})
    return {"lobes": lobes}


@dataclass(frozen=True)
class PolishCurve:
    """Figures against polishing time. times_s: s. lobes[k][name] -> array over times.

    combined_displacement_px: RMS image displacement over all pixels of both lobes (px),
    the quantity whose minimum is the optimum time.
    """

    times_s: np.ndarray
    lobes: list[dict]
    combined_displacement_px: np.ndarray
    profiles: list[SampledProfile] = field(repr=False, default_factory=list)

    @property
    def optimum_index(self) -> int:
        """Index of the time with the least combined image displacement."""
        return int(np.nanargmin(self.combined_displacement_px))

    @property
    def optimum_time_s(self) -> float:
        return float(self.times_s[self.optimum_index])

    @property
    def optimum_inside(self) -> bool:
        """True when the optimum is not at either end of the explored range."""
        return 0 < self.optimum_index < self.times_s.size - 1

    def to_dict(self) -> dict:
        """JSON-ready curve (times s; figures in the units their names carry) and its optimum."""
        i = self.optimum_index
        return {
            "times_s": [float(t) for t in self.times_s],
            "combined_image_displacement_px_rms": [float(v) for v in self.combined_displacement_px],
            "lobes": [{"name": lb["name"], **{key: {"rms": [float(v) for v in val["rms"]],
                                                    "max": [float(v) for v in val["max"]]}
                                              for key, val in lb.items() if key != "name"}}
                      for lb in self.lobes],
            "optimum": {
                "time_s": self.optimum_time_s,
                "inside_range": self.optimum_inside,
                "combined_image_displacement_px_rms": float(self.combined_displacement_px[i]),
                "lobes": [{"name": lb["name"], **{key: {"rms": float(val["rms"][i]), "max": float(val["max"][i])}
                                                  for key, val in lb.items() if key != "name"}}
                          for lb in self.lobes],
            },
        }


def polish_curve(profile: Profile, mirror: Mirror, params: PolishParams,
                 times_s: Sequence[float] | np.ndarray | None = None, *,
                 progress: bool = False) -> PolishCurve:
    """Slope error, normal deviation, form change and image displacement against time.

    times_s: s (default params.curve_times). Image displacement is the aligned camera's
    (optics.radial: exact per-pixel RMS over each lobe's usable pixels); slope error and
    normal deviation over the radii the image uses (optics.radial.used_extent).
    """
    from .radial import lobe_pixel_radii, radial_displacement, surface_errors

    times = params.curve_times if times_s is None else np.asarray(times_s, dtype=float)
    profiles = polish_series(profile, params, times)
    keys = ("slope_error_rad", "normal_deviation_mm", "form_change_mm", "image_displacement_px")
    lobes = [{"name": lb.name, **{key: {"rms": [], "max": []} for key in keys}} for lb in mirror.lobes]
    px = [lobe_pixel_radii(mirror, k) for k in (0, 1)]
    combined = []
    bar = progress_bar(len(profiles), "polishing curve", progress)
    for prof in profiles:
        surf = surface_errors(prof, mirror, used=True)
        form = form_change(prof, mirror, degree=params.form_degree)
        sq, cnt = 0.0, 0.0
        for k in (0, 1):
            d = radial_displacement(prof, mirror, k, px[k].radius_px)
            w = px[k].count
            ok = np.isfinite(d)
            rms = float(np.sqrt(np.sum(w[ok] * d[ok] ** 2) / np.sum(w[ok])))
            sq += float(np.sum(w[ok] * d[ok] ** 2))
            cnt += float(np.sum(w[ok]))
            figs = {"slope_error_rad": surf["lobes"][k]["slope_error_rad"],
                    "normal_deviation_mm": surf["lobes"][k]["normal_deviation_mm"],
                    "form_change_mm": form["lobes"][k]["form_change_mm"],
                    "image_displacement_px": {"rms": rms, "max": float(np.max(np.abs(d[ok])))}}
            for key in keys:
                lobes[k][key]["rms"].append(figs[key]["rms"])
                lobes[k][key]["max"].append(figs[key]["max"])
        combined.append(math.sqrt(sq / cnt))
        bar.update(1)
    bar.close()
    for lb in lobes:
        for key in keys:
            lb[key] = {s: np.asarray(v) for s, v in lb[key].items()}
    return PolishCurve(times_s=times, lobes=lobes, combined_displacement_px=np.asarray(combined),
                       profiles=profiles)


# --------------------------------------------------------------------------------------
# The evolution


def polish_summary(curve, program: str) -> dict:
    """The optimum of a polishing curve (s), the image displacement before and at it (px RMS,
    both lobes), the form it costs per lobe (mm) and a sentence stating them (min, um)."""
    i = curve.optimum_index
    d = curve.to_dict()["optimum"]
    form = [lb["form_change_mm"] for lb in d["lobes"]]
    return {
        "program": program,
        "optimum_time_s": curve.optimum_time_s,
        "optimum_inside_range": curve.optimum_inside,
        "range_s": [float(curve.times_s[0]), float(curve.times_s[-1])],
        "image_displacement_px_rms": {"before": float(curve.combined_displacement_px[0]),
                                      "at_optimum": float(curve.combined_displacement_px[i])},
        "form_cost_mm": {lb["name"]: f for lb, f in zip(d["lobes"], form)},
        "statement": (
            f"The {program} program's mirror is best left unpolished: its image displacement, "
            f"{curve.combined_displacement_px[0]:.2f} px RMS over both lobes as machined, only grows with "
            f"polishing (to {curve.combined_displacement_px[-1]:.2f} px after "
            f"{curve.times_s[-1] / 60:.0f} min) as the lap's form change outweighs what it smooths."
        ) if i == 0 else (
            f"Polishing the {program} program's mirror for {curve.optimum_time_s / 60:.0f} min minimises the "
            f"image displacement (RMS over both lobes {curve.combined_displacement_px[0]:.2f} -> "
            f"{curve.combined_displacement_px[i]:.2f} px); it costs a form change of "
            f"{form[0]['rms'] * 1e3:.1f} um RMS ({form[0]['max'] * 1e3:.1f} um max) on the inner lobe and "
            f"{form[1]['rms'] * 1e3:.1f} um RMS ({form[1]['max'] * 1e3:.1f} um max) on the outer lobe."
            + ("" if curve.optimum_inside else
               " The optimum lies at the end of the explored range: widen polish.curve_max_s.")),
    }
