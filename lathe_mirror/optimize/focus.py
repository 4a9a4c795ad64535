"""The thin-lens defocus model the optimiser's blur constraint uses: it lives in
optics.focus (render and stereo blur their images by it too); its names here."""

from __future__ import annotations

from ..optics.focus import Defocus, defocus, ray_meets_sheet, usable_annuli, virtual_image_distance


def design_blur_px(mirror, settings) -> float:
    """The largest blur circle (px) of the design with the configured lens: [camera]
    f_number, focused at the best compromise for scenes optimize.focus_range_m away (the
    blur the delivered range counts, tolerance.delivered)."""
    return defocus(mirror, settings.camera.f_number, settings.optimize.focus_range_m * 1000.0).blur_px

__all__ = ["Defocus", "defocus", "design_blur_px", "ray_meets_sheet", "usable_annuli", "virtual_image_distance"]
