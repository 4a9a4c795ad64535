"""The thin-lens defocus model the optimiser's blur constraint uses: it lives in
optics.focus (render and stereo blur their images by it too); its names here."""

from __future__ import annotations

from ..optics.focus import Defocus, defocus, ray_meets_sheet, usable_annuli, virtual_image_distance
from ..optics.ranging.resolution import blur_circle_px


def design_blur_px(mirror, settings) -> float:
    """The blur circle (px) the delivered range counts (tolerance.delivered): the design's
    largest defocus with the configured lens ([camera] f_number, focused at the best
    compromise for scenes optimize.focus_range_m away) and the lens's Airy disc, in
    quadrature (optics.ranging.resolution.blur_circle_px)."""
    cam = settings.camera
    b = defocus(mirror, cam.f_number, settings.optimize.focus_range_m * 1000.0).blur_px
    return blur_circle_px(b, cam.f_number, cam.t_pixel)

__all__ = ["Defocus", "defocus", "design_blur_px", "ray_meets_sheet", "usable_annuli", "virtual_image_distance"]
