"""Calibration files of the mirror's two lobes, for the vision stacks robots use.

  opencv_inner.yaml, opencv_outer.yaml   OpenCV FileStorage: K, D, xi, image size, the
                                         valid annulus; cv2.omnidir takes them as they are
  kalibr_camchain.yaml                   Kalibr's camchain: both lobes as `omni` cameras,
                                         cam1's T_cn_cnm1 the axial shift between viewpoints
  calib_results_inner.txt, ..._outer.txt Scaramuzza's OCamCalib calib_results.txt layout
                                         (its polynomial and inverse polynomial)

Each lobe is the design's unified model (optics.camera_model): exact for the designed
mirror. The text is built here without a YAML library (comments, fixed key order, floats
as Python's shortest round-trip repr), so the same design gives the same bytes.
"""

from __future__ import annotations

import math
import textwrap
from pathlib import Path

from ..design import Mirror
from ..optics.camera_model import UnifiedModel, design_model, valid_annulus_px
from ..optics.ocam import OcamModel, lobe_ocam_model
from .files import write_text
from .numbers import LENGTH_M, LENGTH_MM, PIXEL, RATIO, fmt, polynomial_exponent

#: The precision of one term of an OCamCalib polynomial at the largest value of its variable.
POLYNOMIAL_TERM_PX = -8

#: The files write_calibration writes, in order.
FILE_NAMES = ("opencv_inner.yaml", "opencv_outer.yaml", "kalibr_camchain.yaml",
              "calib_results_inner.txt", "calib_results_outer.txt")

_FRAME = """\
Frame (the lobe frame): X_lobe = diag(1, 1, -1) (X_cam - F1). Origin at the lobe's
viewpoint F1, x and y along the camera's (x along the image columns, y down the rows), z
from F1 down the mirror axis toward the camera. The camera frame has the pinhole at the
origin and +z up the axis; F1 is at z = {f1:.6f} mm. A mirror reverses handedness: this
frame is a reflection of the camera frame, not a rotation of it (a rotation would need a
negative focal length). Map world points into it with that reflection.
Pixels: OpenCV's convention, the centre of the top-left pixel at (0, 0); the principal
point is the sensor centre ({cx:g}, {cy:g}).
Valid image: the annulus {r0:.6f} px <= |pixel - principal point| <= {r1:.6f} px{note}."""


def calibration_texts(mirror: Mirror, zones=None) -> dict[str, str]:
    """The text of every calibration file of the design (FILE_NAMES), by file name.
    zones (optics.zones.Zones): the valid annuli are its used zones (the ring the nose
    cannot reach at the junction masked too)."""
    models = [design_model(mirror, k, zones) for k in (0, 1)]
    texts = {}
    for k, model in enumerate(models):
        texts[f"opencv_{model.name}.yaml"] = opencv_yaml(model, _design_note(mirror, k, zones))
    texts["kalibr_camchain.yaml"] = kalibr_camchain(models, _kalibr_note(mirror))
    for k, model in enumerate(models):
        texts[f"calib_results_{model.name}.txt"] = ocamcalib_text(lobe_ocam_model(mirror, k, zones),
                                                                  _ocam_note(mirror, k, zones))
    return texts


def write_calibration(directory: str | Path, mirror: Mirror, zones=None) -> list[Path]:
    """Write the design's calibration files into an existing directory; their paths.

    Every file's text is built before the first is written (a failure writes nothing).
    """
    texts = calibration_texts(mirror, zones)
    d = Path(directory)
    return [write_text(d / name, texts[name]) for name in FILE_NAMES]


def opencv_yaml(model: UnifiedModel, note: str = "") -> str:
    """OpenCV FileStorage YAML of one lobe: K, D (k1, k2, p1, p2), xi (1 x 1), image_width,
    image_height, the annulus radii (px) and F1's height (mm), with comments."""
    k = model.camera_matrix.ravel()
    lines = ["%YAML:1.0", "---"]
    lines += _comment(
        f"lathe-mirror: the {model.name} lobe of the double-lobed hyperbolic mirror as the unified "
        "(Geyer-Daniilidis / Barreto / Mei) camera model of OpenCV's cv2.omnidir. Load with "
        "cv2.FileStorage: K = fs.getNode('K').mat(), D = fs.getNode('D').mat(), xi = fs.getNode('xi').mat() "
        "(1 x 1, as cv2.omnidir.calibrate returns it). cv2.omnidir.undistortPoints and "
        "initUndistortRectifyMap take them as they are; projectPoints(points_in_lobe_frame, rvec=0, "
        "tvec=0, K, xi[0, 0], D) takes xi as a number.\n"
        + _frame(model, note))
    lines += _matrix("K", 3, 3, k, PIXEL)
    lines += _matrix("D", 1, 4, model.distortion.ravel(), RATIO)
    # xi as a 1 x 1 matrix, as cv::omnidir::calibrate returns it and OpenCV's omnidir sample
    # stores it: fs.getNode("xi").mat() goes to undistortPoints / initUndistortRectifyMap as
    # is; projectPoints' binding takes the number, xi[0, 0].
    lines += _matrix("xi", 1, 1, [model.xi], RATIO)
    lines += [f"image_width: {model.image_size[0]}",
              f"image_height: {model.image_size[1]}",
              f"annulus_inner_radius_px: {fmt(model.annulus_px[0], PIXEL)}",
              f"annulus_outer_radius_px: {fmt(model.annulus_px[1], PIXEL)}",
              f"viewpoint_z_mm: {fmt(model.viewpoint_z, LENGTH_MM)}"]
    return "\n".join(lines) + "\n"


def kalibr_camchain(models: list[UnifiedModel], note: str = "") -> str:
    """Kalibr camchain YAML: cam0 the inner lobe, cam1 the outer, `omni` with no distortion.

    cam1's T_cn_cnm1 takes lobe-0-frame points to the lobe-1 frame (Kalibr's convention,
    metres): with both frames diag(1, 1, -1) (X_cam - F1_k), X_1 = X_0 + (0, 0, z_F1,1 -
    z_F1,0), a pure translation along the axis.
    """
    dz_m = (models[1].viewpoint_z - models[0].viewpoint_z) / 1000.0
    lines = _comment(
        "lathe-mirror: both lobes of the double-lobed hyperbolic mirror as Kalibr cameras "
        "(camera_model omni: the unified model, intrinsics [xi, fu, fv, pu, pv] in pixels). cam0 is "
        "the inner lobe, cam1 the outer; both see the same image, each through its own annulus "
        "(annulus_px below is a comment for the user: Kalibr has no such key).\n"
        "Each camera's frame is its lobe frame: diag(1, 1, -1) (X_cam - F1), origin at the lobe's "
        "viewpoint F1, z down the mirror axis toward the camera; a reflection of the camera frame "
        "(a mirror reverses handedness). cam1's T_cn_cnm1 (metres) is then the pure translation "
        f"(0, 0, {dz_m:.9f}) along the axis: the viewpoints are {dz_m * 1000:.6f} mm apart.\n"
        "Pixels: the centre of the top-left pixel at (0, 0); the principal point is the sensor centre."
        + (f"\n{note}" if note else ""))
    for i, m in enumerate(models):
        lines.append(f"cam{i}:")
        if i > 0:
            t = [[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, dz_m], [0.0, 0.0, 0.0, 1.0]]
            lines.append("  T_cn_cnm1:")
            # rotation entries are ratios, the translation column metres.
            lines += [f"  - [{', '.join(fmt(x, LENGTH_M if j == 3 else RATIO) for j, x in enumerate(row))}]"
                      for row in t]
        lines += [f"  # {m.name} lobe; valid annulus {m.annulus_px[0]:.6f} to {m.annulus_px[1]:.6f} px "
                  f"about (pu, pv); F1 at z = {m.viewpoint_z:.6f} mm in the camera frame",
                  f"  cam_overlaps: [{1 - i}]",
                  "  camera_model: omni",
                  f"  intrinsics: [{', '.join([fmt(m.xi, RATIO)] + [fmt(x, PIXEL) for x in (m.fu, m.fv, m.cx, m.cy)])}]",
                  "  distortion_model: none",
                  "  distortion_coeffs: []",
                  f"  resolution: [{m.image_size[0]}, {m.image_size[1]}]",
                  "  rostopic: /camera/image_raw"]
    return "\n".join(lines) + "\n"


def ocamcalib_text(ocam: OcamModel, note: str = "") -> str:
    """calib_results.txt of Scaramuzza's OCamCalib toolbox (export_data.m's layout, read by
    its C get_ocam_model and the Python ports): the direct polynomial (ascending, for
    cam2world), the inverse polynomial (ascending, for world2cam), the centre (row, column
    from 0), the affine c, d, e (1, 0, 0) and the image height and width. Each coefficient
    is written so its term is exact to 1e-8 px at the variable's largest value, the centre
    to 1e-6 px (export.numbers; the toolbox prints %e / %f; fscanf's %lf reads both). Notes on
    the frame follow the last field, where the readers stop."""
    lines = [
        "#polynomial coefficients for the DIRECT mapping function (ocam_model.ss in MATLAB). "
        "These are used by cam2world",
        "",
        f"{ocam.pol.size} " + _polynomial(ocam.pol, ocam.rho_max_px),
        "",
        "#polynomial coefficients for the inverse mapping function (ocam_model.invpol in MATLAB). "
        "These are used by world2cam",
        "",
        f"{ocam.invpol.size} " + _polynomial(ocam.invpol, math.pi / 2),
        "",
        '#center: "row" and "column", starting from 0 (C convention)',
        "",
        f"{fmt(ocam.xc, PIXEL)} {fmt(ocam.yc, PIXEL)}",
        "",
        '#affine parameters "c", "d", "e"',
        "",
        f"{1.0:f} {0.0:f} {0.0:f}",
        "",
        '#image size: "height" and "width"',
        "",
        f"{ocam.height} {ocam.width}",
        "",
    ]
    lines += _comment(
        f"lathe-mirror: the {ocam.name} lobe of the double-lobed hyperbolic mirror, fitted to the "
        "design's exact map (the unified model with xi and gamma of the OpenCV and Kalibr files) "
        f"over image radii 0 to {ocam.rho_max_px:.6f} px; largest departure from it: "
        f"{ocam.max_error_px['pol']:.2e} px (direct), {ocam.max_error_px['invpol']:.2e} px (inverse).\n"
        "Frame: origin at the lobe's viewpoint F1, x along the image rows (the camera's y), y along "
        "the columns (the camera's x), z up the mirror axis away from the camera: OCamCalib's "
        "convention (f(0) < 0: the image centre looks down the axis). Like the lobe frame of the "
        "OpenCV and Kalibr files (of which it is a rotation: x and y swapped, z reversed) it is a "
        "reflection of the camera frame, since a mirror reverses handedness.\n"
        "world2cam: theta = atan(z / sqrt(x^2 + y^2)) is the elevation above F1's horizon."
        + (f"\n{note}" if note else ""))
    return "\n".join(lines) + "\n"


# --------------------------------------------------------------------------------------
# Helpers


def _frame(model: UnifiedModel, note: str) -> str:
    return _FRAME.format(f1=model.viewpoint_z, cx=model.cx, cy=model.cy, r0=model.annulus_px[0],
                         r1=model.annulus_px[1], note=note)


def _fillet_note(zones, k: int) -> str:
    if zones is None or zones.lobes[k].fillet_px is None:
        return ""
    z = zones.lobes[k]
    return (f"; the ring {z.fillet_px[0]:.6f} to {z.fillet_px[1]:.6f} px sees the fillet a "
            f"{zones.nose_mm:g} mm nose leaves at the junction (r {z.fillet_mm[0]:.4f} to {z.fillet_mm[1]:.4f} mm), "
            f"not the designed lobe: masked ({z.fillet_pixels} pixels)")


def _design_note(mirror: Mirror, k: int, zones=None) -> str:
    lobe, cam = mirror.lobes[k], mirror.camera
    radii = mirror.image_radii_px
    band = ""
    if k == 0 and radii["inner_blocked_by_step"][1] > radii["inner_blocked_by_step"][0]:
        lo, hi = radii["inner_blocked_by_step"]
        band = f" (from {lo:.6f} px to the rim at {hi:.6f} px the step wall blocks this lobe's world rays)"
    elif k == 1:
        lo, hi = radii["lost_ring"]
        band = f" (inside it: the ring {lo:.6f} to {hi:.6f} px lost on the step wall, and the inner lobe)"
    band += _fillet_note(zones, k)
    return (band + ".\n"
            f"Design: a = {lobe.a:.9f} mm, b = {lobe.b:.9f} mm, e = sqrt(a^2 + b^2) = {lobe.e:.9f} mm, "
            f"f = {cam.f:g} mm, t_pixel = {cam.t_pixel:g} mm: xi = 2 a e / (a^2 + e^2), "
            f"gamma = fu = fv = (f / t_pixel) b^2 / (a^2 + e^2), no distortion. Exact for the designed "
            f"mirror on an aligned camera; a machined mirror departs from it (lathe-mirror calib --json)")


def _kalibr_note(mirror: Mirror) -> str:
    lo, hi = mirror.common_band
    return (f"Stereo: the lobes see the common band {math.degrees(lo):.3f} to {math.degrees(hi):.3f} deg "
            "elevation; the exact design is the calibration (no distortion).")


def _ocam_note(mirror: Mirror, k: int, zones=None) -> str:
    r0, r1 = valid_annulus_px(mirror, k, zones)
    return (f"Valid image: the annulus {r0:.6f} px <= rho <= {r1:.6f} px about the centre (the lost ring "
            f"and the band the step wall blocks left out{_fillet_note(zones, k)}).")


def _comment(text: str, width: int = 92) -> list[str]:
    """Lines of '# ' comments, each paragraph of text wrapped to width."""
    out = []
    for para in text.split("\n"):
        out += ["# " + line for line in textwrap.wrap(para, width - 2, break_on_hyphens=False)] or ["#"]
    return out


def _matrix(name: str, rows: int, cols: int, data, exp: int) -> list[str]:
    """An OpenCV matrix with its entries at the precision 10**exp (export.numbers)."""
    return [f"{name}: !!opencv-matrix", f"   rows: {rows}", f"   cols: {cols}", "   dt: d",
            f"   data: [ {', '.join(fmt(x, exp) for x in data)} ]"]


def _polynomial(coefficients, variable_max: float) -> str:
    """OCamCalib's ascending coefficients, each term c_i x^i to POLYNOMIAL_TERM_PX (1e-8 px)
    at the variable's largest value (rho_max px for the direct map, pi/2 rad of elevation for
    the inverse): 1000 times below the fit's own departure from the exact map (~1e-5 px)."""
    return "".join(fmt(c, polynomial_exponent(i, variable_max, POLYNOMIAL_TERM_PX)) + " "
                   for i, c in enumerate(coefficients))
