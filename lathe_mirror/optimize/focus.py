"""The thin-lens defocus model the optimiser's blur constraint uses: it lives in
optics.focus (render and stereo blur their images by it too); its names here."""

from __future__ import annotations

from ..optics.focus import Defocus, defocus, ray_meets_sheet, usable_annuli, virtual_image_distance

__all__ = ["Defocus", "defocus", "ray_meets_sheet", "usable_annuli", "virtual_image_distance"]
