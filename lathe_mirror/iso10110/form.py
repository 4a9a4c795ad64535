"""Form tolerances of each lobe (ISO 10110-5) from what the tolerance spec allows.

The allocation (tolerance.allocation) sizes the machine's and the assembly's tolerances
by tracing thousands of drawn parts (minutes). A drawing needs its form tolerance in a
second, so this module uses the allocation's own first-order rule (inverse_sensitivity:
the margin of each criterion, in squares, split evenly among the toleranced parameters)
with a closed-form response in place of the traced one:

- Response. A slope error d (rad) of the meridian at radius r turns the reflected ray by
  2 d in the meridian plane; the exact lobe images that direction g(r) = |dEl/dr| /
  |drho/dr| rad per pixel away, so the pixel's image displacement is 2 d / g(r) (px).
  El(r) is the elevation seen from the lobe's F1 (Lobe.elevation), rho(r) = f r / (t z)
  the image radius of the mirror point (r, z).
- Budget. The image criterion allows an RMS displacement D = spec.image_displacement_px
  over the lobe's pixels (weights rho drho, uniform over the image's area); the stereo
  criterion allows the disparity-equivalent limit of spec.depth_error_pct at
  spec.depth_range_m (tolerance.montecarlo.disparity_limit_px) at the band's points, the
  two lobes' errors adding in quadrature (a share 1/sqrt(2) each), judged at the band's
  worst radius. Of either margin, the surface's form takes the shares of the drawn
  parameters that make the surface (nose radius, polishing time, tool X and Z) among all
  drawn parameters with a tolerance (tolerance.spec.DRAWN): 4 of 8 by default; the rest
  is left for the camera and the seat. The judged spec.slope_error_rad caps it too.
- Assumptions (stated in the JSON as `basis`): the whole margin of the nominal part is
  given to the form (the form tolerance is the made surface's error against the design,
  the nominal lattice error included); raw figures (a calibration would absorb the smooth
  part of a form error, so this is conservative when spec.calibrated); the target yield
  applies to the assembly's shares: a part inside its form tolerance always meets its
  share (a form tolerance is inspected part by part).

From the RMS slope tolerance d over the clear aperture of radial width W the height
tolerances follow for the two lowest forms a lathe leaves: power (z = p r^2 over the
aperture: PV = sqrt(3) d W / 2, RMS about the mean = sqrt(4/45) PV) and one period of
rotationally symmetric irregularity over W (PV = sqrt(2) d W / pi, RMS = PV / (2 sqrt(2))).
ISO 10110-5: 3/A(B/C) with A the power's PV, B the irregularity's PV, C = B (a turned
surface's irregularity is all rotationally symmetric), in fringe spacings (one fringe =
lambda / 2 of surface height in a double-pass interferometer) at the stated test
wavelength, rounded down (a tolerance is never loosened by rounding); RMSt the larger RMS
and RMSi the irregularity's, in waves (lambda); the slope tolerance per
SLOPE_EVALUATION_MM of radius. The same figures in nm are kept in the JSON
(`iso10110_5_nm`) for a shop that reads heights.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..design import Lobe, Mirror
from ..tolerance.spec import DRAWN

#: Drawn parameters whose error is the surface's form (the rest: camera and seat).
FORM_PARAMETERS = ("nose_radius_mm", "polish_time_s", "tool_x_mm", "tool_z_mm")
#: Evaluation length of the slope tolerance, mm of radius: two sag-table steps, about 20
#: pixels of the inner lobe (0.05 mm of mirror a pixel at its centre on the paper mirror).
SLOPE_EVALUATION_MM = 1.0
#: Radii sampled across a clear aperture for the response.
SAMPLES = 2001


@dataclass(frozen=True)
class FormTolerance:
    """One lobe's form tolerance. pv_um, rms_um: height, um, over the clear aperture;
    slope_urad: RMS slope error, urad, per evaluation_length_mm of radius; power_pv_um,
    irregularity_pv_um, irregularity_rms_um: the ISO 10110-5 parts; wavelength_nm.
    governed_by: which criterion set it ("image", "stereo" or "slope")."""

    pv_um: float
    rms_um: float
    slope_urad: float
    evaluation_length_mm: float
    power_pv_um: float
    irregularity_pv_um: float
    irregularity_rms_um: float
    wavelength_nm: float
    governed_by: str
    slope_by_criterion_urad: dict

    @property
    def iso10110_5(self) -> str:
        """The ISO 10110-5 indication: 3/A(B/C) in fringe spacings (lambda / 2), RMSt and
        RMSi in waves, the test wavelength stated."""
        lam = self.wavelength_nm
        a, b = _count(fringes(self.power_pv_um, lam)), _count(fringes(self.irregularity_pv_um, lam))
        return (f"3/{a}({b}/{b}); RMSt<{_count(waves(self.rms_um, lam))}; "
                f"RMSi<{_count(waves(self.irregularity_rms_um, lam))}; lambda={lam:g} nm")

    @property
    def iso10110_5_nm(self) -> str:
        """The same form tolerance as heights in nm (a note for a shop that reads heights)."""
        a, b = _nm(self.power_pv_um), _nm(self.irregularity_pv_um)
        return (f"3/{a}({b}/{b}); RMSt<{_nm(self.rms_um)}; RMSi<{_nm(self.irregularity_rms_um)} "
                f"(nm of surface height)")

    def to_dict(self) -> dict:
        lam = self.wavelength_nm
        return {"iso10110_5": self.iso10110_5, "iso10110_5_nm": self.iso10110_5_nm,
                "power_fringes": fringes(self.power_pv_um, lam),
                "irregularity_fringes": fringes(self.irregularity_pv_um, lam),
                "test_wavelength_nm": lam, "pv_um": self.pv_um, "rms_um": self.rms_um,
                "slope_urad": self.slope_urad, "evaluation_length_mm": self.evaluation_length_mm,
                "power_pv_um": self.power_pv_um, "irregularity_pv_um": self.irregularity_pv_um,
                "irregularity_rms_um": self.irregularity_rms_um, "wavelength_nm": self.wavelength_nm,
                "governed_by": self.governed_by, "slope_by_criterion_urad": dict(self.slope_by_criterion_urad)}


def angular_scale(mirror: Mirror, lobe: Lobe, r: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(g, rho): rad of elevation per pixel of image radius, and the image radius (px), of
    the lobe's points at radii r (mm)."""
    cam = mirror.camera
    r = np.asarray(r, dtype=float)
    z, dz = lobe.z(r), lobe.slope(r)
    rho = cam.f * r / (cam.t_pixel * z)
    drho = cam.f * (z - r * dz) / (cam.t_pixel * z * z)
    u = z - lobe.focus_z
    del_dr = (r * dz - u) / (r * r + u * u)
    return np.abs(del_dr) / np.abs(drho), rho


def form_share(tolerances: dict[str, float]) -> float:
    """Share of a criterion's margin (in squares) the form takes: the FORM_PARAMETERS with
    a tolerance among the drawn parameters with one."""
    drawn = [k for k in DRAWN if tolerances.get(k, 0.0) > 0]
    form = [k for k in drawn if k in FORM_PARAMETERS]
    return len(form) / len(drawn) if drawn else 1.0


def form_tolerances(mirror: Mirror, clear_apertures, spec, tolerances: dict[str, float], *,
                    wavelength_nm: float, depth_points: int = 17) -> tuple[FormTolerance, FormTolerance]:
    """Each lobe's FormTolerance (see the module doc). spec: tolerance.spec.Spec;
    tolerances: the drawn parameters' tolerances (edge units); clear_apertures: (r_min,
    r_max) per lobe, mm."""
    from ..tolerance.montecarlo import disparity_limit_px  # lazy: tolerance.montecarlo off the CLI's start-up path

    share = math.sqrt(form_share(tolerances))
    disparity = disparity_limit_px(mirror, spec.depth_error_pct, spec.depth_range_m, depth_points)
    band = mirror.common_band
    out = []
    for lobe, (lo, hi) in zip(mirror.lobes, clear_apertures):
        r = np.linspace(lo, hi, SAMPLES)
        g, rho = angular_scale(mirror, lobe, r)
        drho = np.gradient(rho, r)
        w = np.abs(rho * drho)
        inv2 = np.sum(w / g**2) / np.sum(w)
        by = {"image": spec.image_displacement_px * share / (2.0 * math.sqrt(inv2))}
        el = lobe.elevation(r)
        in_band = (el >= band[0]) & (el <= band[1])
        if np.any(in_band):
            by["stereo"] = disparity * share / math.sqrt(2.0) / (2.0 * float(np.max(1.0 / g[in_band])))
        by["slope"] = spec.slope_error_rad
        governed = min(by, key=by.get)
        d = by[governed]
        width = hi - lo
        power_pv = math.sqrt(3.0) * d * width / 2.0
        power_rms = math.sqrt(4.0 / 45.0) * power_pv
        irr_pv = math.sqrt(2.0) * d * width / math.pi
        irr_rms = irr_pv / (2.0 * math.sqrt(2.0))
        out.append(FormTolerance(
            pv_um=_round(max(power_pv, irr_pv) * 1e3), rms_um=_round(max(power_rms, irr_rms) * 1e3),
            slope_urad=_round(d * 1e6), evaluation_length_mm=SLOPE_EVALUATION_MM,
            power_pv_um=_round(power_pv * 1e3), irregularity_pv_um=_round(irr_pv * 1e3),
            irregularity_rms_um=_round(irr_rms * 1e3), wavelength_nm=wavelength_nm, governed_by=governed,
            slope_by_criterion_urad={k: _round(v * 1e6) for k, v in by.items()}))
    return tuple(out)


def _round(v: float) -> float:
    """Three significant figures, rounded down (a tolerance is never loosened by rounding)."""
    if v <= 0 or not math.isfinite(v):
        return float(v)
    e = math.floor(math.log10(v)) - 2
    return round(math.floor(v / 10.0**e + 1e-9) * 10.0**e, max(0, -e))


def fringes(height_um: float, wavelength_nm: float) -> float:
    """A surface height (um) in fringe spacings of a double-pass test at wavelength_nm: one
    fringe is lambda / 2 of height (ISO 10110-5)."""
    return height_um * 1e3 / (wavelength_nm / 2.0)


def waves(height_um: float, wavelength_nm: float) -> float:
    """A surface height (um) in waves (lambda) at wavelength_nm: ISO 10110-5's RMS unit."""
    return height_um * 1e3 / wavelength_nm


def _count(v: float) -> str:
    """A fringe or wave count as drawn, rounded down: integers from 10 up, else 0.1, else
    0.01 (a tolerance is never loosened by rounding)."""
    for step, digits in ((1.0, 0), (0.1, 1), (0.01, 2)):
        if v >= 10 * step or step == 0.01:
            return f"{math.floor(v / step + 1e-9) * step:.{digits}f}"
    raise AssertionError("unreachable")


def _nm(um: float) -> str:
    return f"{um * 1e3:.0f}"
