"""Surface texture (ISO 10110-8) from the finish model (finish.py).

The lathe's kinematic roughness of a nose of radius r_n fed f per revolution: Rz ~ f^2 /
(8 r_n) (the feed mark's sagitta, finish.feed_mark_height), Ra ~ f^2 / (31.2 r_n) (the
parabolic arc's mean deviation, 0.257 of Rz) and Rq (finish.feed_mark_rms). The feed marks
are a grating of period f: their first order falls asin(lambda / f) off the specular ray.

The spatial band of the RMS roughness: from the wavelength (shorter periods diffract only
into evanescent orders) to lambda / (one pixel's angle): a longer period turns light by
less than a pixel and is form, not texture (the form tolerance's). The pixel's angle is the
finest of either lobe's (FormTolerance's angular scale), so the band is the same on both.

The specified RMS roughness is what the process leaves after its polish (finish.roughness
_rms with the turned roughness fully smoothed: the polish runs until the feed marks are
gone, the polishing curve's premise) or as turned (a process without polish), rounded up to
a whole nm; TIS at the working wavelength at that roughness (normal incidence: the most a
roughness scatters).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..finish import (Process, feed_mark_height, feed_mark_rms, order_spacing, roughness_rms,
                      total_integrated_scatter)


@dataclass(frozen=True)
class Texture:
    """The finish spec of both lobes. Lengths as their names say."""

    process: str
    feed_mm: float
    nose_radius_mm: float
    kinematic_rz_um: float
    kinematic_ra_um: float
    feed_mark_rq_nm: float
    as_turned_rq_nm: float
    rq_nm: float
    band_mm: tuple[float, float]
    tis: float
    wavelength_nm: float
    grating_period_mm: float
    grating_order_angle_mrad: float
    polished: bool

    @property
    def iso10110_8(self) -> str:
        """ISO 10110-8 texture indication: RMS roughness, then the band's limits (mm)."""
        return f"Rq {self.rq_nm * 1e-3:.4f}; {self.band_mm[0]:.5f}/{self.band_mm[1]:.3f}"

    def to_dict(self) -> dict:
        return {"iso10110_8": self.iso10110_8, "process": self.process, "polished": self.polished,
                "rq_nm": self.rq_nm, "band_mm": list(self.band_mm), "tis": self.tis,
                "wavelength_nm": self.wavelength_nm, "feed_mm": self.feed_mm,
                "nose_radius_mm": self.nose_radius_mm, "kinematic_rz_um": self.kinematic_rz_um,
                "kinematic_ra_um": self.kinematic_ra_um, "feed_mark_rq_nm": self.feed_mark_rq_nm,
                "as_turned_rq_nm": self.as_turned_rq_nm,
                "grating": {"period_mm": self.grating_period_mm,
                            "first_order_angle_mrad": self.grating_order_angle_mrad,
                            "note": "the feed marks are a reflection grating of this period until the "
                                    "polish removes them" if self.polished else
                                    "the feed marks stay: a reflection grating of this period"}}


def texture(process: Process, *, wavelength_nm: float, pixel_angle_rad: float) -> Texture:
    """The Texture of a resolved process (finish.Process.resolved) at wavelength_nm (nm);
    pixel_angle_rad: the finest angle a pixel subtends on the sky (rad)."""
    f, rn = process.feed_mm, process.nose_radius_mm
    lam = wavelength_nm * 1e-6
    turned = float(roughness_rms(process, 1.0))
    final = float(roughness_rms(process, 0.0)) if process.polish else turned
    rq_nm = float(math.ceil(final * 1e6 - 1e-9))
    return Texture(
        process=process.name, feed_mm=f, nose_radius_mm=rn,
        kinematic_rz_um=feed_mark_height(f, rn) * 1e3,
        kinematic_ra_um=(f * f / (31.2 * rn) if rn > 0 else 0.0) * 1e3,
        feed_mark_rq_nm=feed_mark_rms(f, rn) * 1e6, as_turned_rq_nm=turned * 1e6, rq_nm=rq_nm,
        band_mm=(round(lam, 6), round(lam / pixel_angle_rad, 3)),
        tis=float(total_integrated_scatter(rq_nm * 1e-6, lam)), wavelength_nm=wavelength_nm,
        grating_period_mm=f, grating_order_angle_mrad=order_spacing(f, lam) * 1e3, polished=process.polish)
