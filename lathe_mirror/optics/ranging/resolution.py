"""How far the robot can range: the range error a disparity error causes, and R10.

Two viewpoints on the axis, the baseline B = 2 (e_outer - e_inner) apart, see a point at
range R (from the stereo centre, midway between them) and elevation el under the parallax
gamma = el_inner - el_outer, which to first order in B / R is

    gamma = B cos(el) / R,   so   dR / R = R d(gamma) / (B cos(el)).

A disparity is the difference of two image positions, one per lobe. One pixel of image
radius in lobe k moves the elevation it sees by that lobe's angular resolution
|d elevation / d image radius| (rad/px, `angular_resolution`); one pixel in each lobe,
independent, moves gamma by the root sum of squares of both (`parallax_per_px`). That
gives the range error of a 1-px disparity error against range and elevation
(`range_error_pct`), and R10, the range at which it is 10 % of range:

    R10(el) = 0.1 B cos(el) / parallax_per_px(el),   R10 = median over the band.

On the paper's mirror R10 = 0.222 m (the inner lobe alone would give 0.246 m, the outer
alone 0.523 m). `r10` is the one definition the design optimiser shares: closed form, no
tracing, about 0.1 ms. It is the sharp R10, limited by the pixel alone: a real image is
blurred (the lens's defocus, `optics.focus`, and diffraction, `airy_px`) and a matcher
finds a blurred feature less precisely, so the design's R10 (`design_r10`, what
`optimize` promises) counts the matcher's noise on the nominal part's own blur, and a
made part's (`delivered_r10`) its calibrated disparity error too:

    design R10 = R10 / sqrt(1 + n^2),   delivered R10 = R10 / sqrt(1 + d^2 + n^2),
    n = hypot(matching_noise_px, BLUR_NOISE_PER_PX x b)   (px; b the blur circle, px).

Camera frame, mm and radians; R10 in metres.
"""

from __future__ import annotations

import numpy as np

from ...design import Camera, Lobe, Mirror
from ...errors import InputError
from ...inputs import check_real, check_type, short

#: Elevations the band is sampled at for its median (centres of equal intervals).
BAND_SAMPLES = 513
#: The fraction of range one pixel of disparity may cost at R10.
R10_FRACTION = 0.1
#: The matcher's added disparity noise per px of blur circle (px/px): OpenCV's SGBM at the
#: project's defaults (block 7, contrast 0.25) on a dead-leaves pair (discs of 2-25 px,
#: edges of every orientation) blurred by discs of 5-40 px, with sensor noise of 4 grey
#: levels of 255: the RMS disparity error grows from its sharp 0.24 px as
#: sqrt(0.24^2 + (k b)^2) with k = 0.028 (0.017 at 2 grey levels, 0.043 at 8);
#: tests/test_delivered.py measures it again. Why linear: a block matcher's disparity
#: variance is the noise variance over the window's sum of squared image gradients
#: (Sabater, Morel, Almansa 2011, SIAM J. Imaging Sci. 4(1), "How accurate can block
#: matches be in stereo vision?"), and an edge blurred over b px has its slope cut by b.
BLUR_NOISE_PER_PX = 0.03
#: The wavelength (mm) of the Airy disc: the middle of the visible band, 550 nm.
AIRY_WAVELENGTH_MM = 0.00055


def r10(mirror: Mirror, band: tuple[float, float] | None = None) -> float:
    """R10 (m): the range at which one pixel of disparity costs 10 % of range, median over
    the band (rad, (lowest, highest) elevation; default the mirror's common band).

    Closed form (see the module doc); NaN if a lobe cannot see part of the band. Raises
    InputError if the band is empty.
    """
    check_type(mirror, "r10: mirror", Mirror, "a Mirror (settings.mirror())")
    if band is not None and (not isinstance(band, (tuple, list)) or len(band) != 2):
        raise InputError(f"r10: band = {short(band)}: expected (lowest, highest) elevation in rad")
    if band is not None:
        band = tuple(check_real(b, "r10: band", unit="rad") for b in band)
    el = band_elevations(mirror, band)
    per_px = parallax_per_px(mirror, el)
    return float(np.median(R10_FRACTION * mirror.baseline * np.cos(el) / per_px)) * 1e-3


def blur_noise_px(blur_px: float, matching_noise_px: float) -> float:
    """The matcher's disparity noise (px) on an image blurred into circles blur_px across:
    its noise on a sharp image (matching_noise_px) and BLUR_NOISE_PER_PX of the blur
    circle, in quadrature (module doc)."""
    return float(np.hypot(matching_noise_px, BLUR_NOISE_PER_PX * max(float(blur_px), 0.0)))


def airy_px(f_number: float, t_pixel: float) -> float:
    """The Airy disc's diameter to its first dark ring, 2.44 lambda N (px of t_pixel mm),
    at AIRY_WAVELENGTH_MM: the blur a perfect lens leaves in focus."""
    return 2.44 * AIRY_WAVELENGTH_MM * float(f_number) / float(t_pixel)


def blur_circle_px(defocus_px: float, f_number: float, t_pixel: float) -> float:
    """The blur circle the matcher sees (px): the thin-lens defocus and the Airy disc in
    quadrature (the usual combination of independent blur widths)."""
    return float(np.hypot(defocus_px, airy_px(f_number, t_pixel)))


def delivered_r10(r10_m, disparity_px, blur_px: float, matching_noise_px: float):
    """The R10 (m) a made part delivers (tolerance.delivered): the sharp R10 (`r10`) over
    the disparity error its matcher and part leave, in units of the design's pixel,
    sqrt(1 + d^2 + n^2), n = blur_noise_px(blur_px, matching_noise_px); d (px) the
    part's own disparity error after calibration, blur_px the blur circle's diameter
    (`blur_circle_px`). Broadcasts over r10_m and d."""
    noise = blur_noise_px(blur_px, matching_noise_px)
    d = np.asarray(disparity_px, float)
    return np.asarray(r10_m, float) / np.sqrt(1.0 + d * d + noise * noise)


def design_r10(sharp_r10_m, blur_px: float, matching_noise_px: float):
    """The design's R10 (m): what the nominal part delivers with its own blur and the
    matcher's noise (delivered_r10 with d = 0), the range `optimize` promises."""
    return delivered_r10(sharp_r10_m, 0.0, blur_px, matching_noise_px)


def band_elevations(mirror: Mirror, band: tuple[float, float] | None = None,
                    n: int = BAND_SAMPLES) -> np.ndarray:
    """n elevations (rad), the centres of n equal intervals of the band (default the
    mirror's common band). InputError if the band is empty."""
    lo, hi = mirror.common_band if band is None else (float(band[0]), float(band[1]))
    if not hi > lo:
        raise InputError(
            f"stereo band {np.degrees(lo):.3f} to {np.degrees(hi):.3f} deg elevation is empty: "
            "the two lobes must see a common band of elevations"
        )
    return lo + (np.arange(n) + 0.5) * ((hi - lo) / n)


def angular_resolution(lobe: Lobe, camera: Camera, elevation: np.ndarray | float) -> np.ndarray:
    """|d elevation / d image radius| (rad/px) of the exact lobe at elevations (rad).

    The lobe images the direction phi (from F1) at P = F1 + s (cos phi, sin phi) with
    s = b^2 / (a - e sin phi) (the sheet's focal polar equation) and radius
    rho = (f / t_pixel) r / z, r = s cos phi, z = 2e + s sin phi. With
    s' = e s^2 cos(phi) / b^2: r' z - r z' = 2e (s' cos phi - s sin phi) - s^2, and
    d rho / d phi = (f / t_pixel) (r' z - r z') / z^2. NaN where the lobe cannot see phi.
    """
    phi = np.asarray(elevation, dtype=float)
    a, b, e = lobe.a, lobe.b, lobe.e
    sin, cos = np.sin(phi), np.cos(phi)
    den = a - e * sin
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.where(den > 0, b * b / den, np.nan)
        ds = e * s * s * cos / (b * b)
        z = 2.0 * e + s * sin
        drho = (camera.f / camera.t_pixel) * (2.0 * e * (ds * cos - s * sin) - s * s) / (z * z)
        return 1.0 / np.abs(drho)


def parallax_per_px(mirror: Mirror, elevation: np.ndarray | float) -> np.ndarray:
    """Parallax (rad) that one pixel of disparity stands for at elevations (rad): one pixel
    of image radius in each lobe, independent, root sum of squares."""
    return np.hypot(angular_resolution(mirror.inner, mirror.camera, elevation),
                    angular_resolution(mirror.outer, mirror.camera, elevation))


def range_error_pct(mirror: Mirror, range_mm: np.ndarray | float, elevation: np.ndarray | float,
                    parallax_error: np.ndarray | float | None = None) -> np.ndarray:
    """Range error (% of range) that a parallax error (rad; default one pixel of disparity,
    parallax_per_px) causes at range (mm) and elevation (rad): 100 R d(gamma) / (B cos el).

    First order in the error; broadcasts over its arguments."""
    el = np.asarray(elevation, dtype=float)
    dg = parallax_per_px(mirror, el) if parallax_error is None else np.asarray(parallax_error, float)
    return 100.0 * np.asarray(range_mm, float) * dg / (mirror.baseline * np.cos(el))


def resolution_table(mirror: Mirror, ranges_m: tuple[float, ...], elevations_deg: tuple[float, ...],
                     precision_rad: float | None = None) -> dict:
    """The resolution model as a table: the range error (%) of one pixel of disparity (and
    of a parallax error precision_rad, the matcher's achieved precision, if given) at each
    range (m) and elevation (deg), plus the median over the common band; and R10 (m)."""
    el = np.radians(np.asarray(elevations_deg, float))
    band = band_elevations(mirror)
    rows = []
    for r in ranges_m:
        row = {"range_m": float(r),
               "one_px_pct": [float(x) for x in range_error_pct(mirror, r * 1e3, el)],
               "one_px_band_median_pct": float(np.median(range_error_pct(mirror, r * 1e3, band)))}
        if precision_rad is not None:
            row["matcher_pct"] = [float(x) for x in range_error_pct(mirror, r * 1e3, el, precision_rad)]
            row["matcher_band_median_pct"] = float(np.median(range_error_pct(mirror, r * 1e3, band, precision_rad)))
        rows.append(row)
    return {"elevations_deg": [float(x) for x in elevations_deg],
            "parallax_per_px_deg": [float(x) for x in np.degrees(parallax_per_px(mirror, el))],
            "matcher_precision_deg": None if precision_rad is None else float(np.degrees(precision_rad)),
            "rows": rows, "r10_m": r10(mirror)}
