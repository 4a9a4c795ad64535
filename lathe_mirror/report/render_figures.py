"""`lathe-mirror render`'s work: the room rendered through the exact and a named made
mirror (blurred by the lens's defocus, optics.defocus), the made one's per-pixel
distortion and its figures, and the files: PNGs, plots, POV-Ray scenes, the figures' JSON.

`render_plan` makes every check before any work (the render's nose, the program of a
program's surface, the room, a camera that sees the mirror); `RenderPlan`'s methods do
the work in the order the command reports it.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..design import Mirror
from ..enums import Surface
from ..errors import InputError
from ..export.files import json_text, write_bytes, write_text
from ..export.png import png_bytes
from ..export.povray import write_povray
from ..job import (MachiningJob, check_program, check_render_nose, design, named_surface, scene_for,
                   surface_label)
from ..optics.camera import pixel_centres
from ..optics.defocus import blur_figures, blur_map, defocus_image, lens_for
from ..optics.distortion import image_displacement
from ..optics.plots import displacement_map_png, displacement_vs_radius_png
from ..optics.render import difference_image, image_difference, render_image
from ..optics.trace import Fate, trace_pixels
from ..optics.zones import zones_for
from ..profile import ExactProfile, Profile

if TYPE_CHECKING:
    from ..settings import Settings


@dataclass
class RenderPlan:
    """A checked render of the named `surface` (`made`, cut with `nose` mm when > 0) beside
    the exact mirror, its label, zones and room."""

    settings: Settings
    mirror: Mirror
    surface: Surface
    nose: float
    made: Profile
    label: str
    zones: Any
    scene: Any
    progress: bool = True
    exact: Profile = field(init=False)
    lens: Any = field(init=False)  # the lens's defocus model (optics.defocus.lens_for)
    blur: Any = field(init=False, default=None)  # its blur map, made with the first image

    def __post_init__(self) -> None:
        self.exact = ExactProfile(self.mirror)
        self.lens = lens_for(self.mirror, self.settings.optimize.focus_range_m * 1000.0)

    @property
    def same(self) -> bool:
        """The made mirror is the exact one."""
        return self.surface is Surface.EXACT and not self.nose

    def made_image(self) -> np.ndarray:
        """The made mirror's image as the camera records it (the lens's defocus)."""
        return self._image(self.made)

    def _image(self, profile: Profile) -> np.ndarray:
        if self.blur is None:
            self.blur = blur_map(self.mirror, self.lens)
        s = self.settings
        return defocus_image(render_image(profile, self.mirror, self.scene, pose=s.camera_pose,
                                          supersample=s.render.supersample, progress=self.progress), self.blur)

    def distortion(self, made_img: np.ndarray):
        """(the made mirror's displacement maps, the exact mirror's image, the figures)."""
        s, mirror, pose = self.settings, self.mirror, self.settings.camera_pose
        maps = image_displacement(self.made, mirror, pose=pose, progress=self.progress)
        exact_img = made_img if self.surface is Surface.EXACT and self.nose == 0 else self._image(self.exact)
        # Over the lobes' usable annuli, as the distortion figures: the step-vignetted band is
        # black in both images and would only dilute the difference.
        # maps.annulus: the design's own pixels (optics.distortion.usable_annulus, the report's)
        diff = image_difference(exact_img, made_img, mask=maps.annulus)
        figures = {
            "surface": self.surface.value,
            "made_mirror": self.label,
            "nose_radius_mm": float(self.nose),
            "supersample": s.render.supersample,
            "pose": {"decentre_mm": list(pose.decentre), "axial_offset_mm": pose.axial_offset,
                     "tilt_deg": [math.degrees(t) for t in pose.tilt]},
            **maps.figures(self.zones, edge_mm=s.polish.clear_edge_mm),
            "zones": self.zones.as_dict(),
            "image_difference": diff,
            "defocus": blur_figures(mirror, self.lens, self.zones),
            "image_radii_px": {k: {"min": v[0], "max": v[1]} for k, v in mirror.image_radii_px.items()},
        }
        return maps, exact_img, figures

    def write(self, out: Path, made_img: np.ndarray, exact_img: np.ndarray, maps, figures: dict) -> list[str]:
        """The images, their difference, the displacement plots, the POV-Ray scenes and the
        figures (with the files' paths) into `out`; the paths."""
        surface, mirror, pose = self.surface.value, self.mirror, self.settings.camera_pose
        files = [write_png(out / "exact.png", exact_img)]
        if not self.same:
            files.append(write_png(out / f"{surface}.png", made_img))
            files.append(write_png(out / f"difference_{surface}.png", difference_image(exact_img, made_img)))
        title = self.label
        files.append(str(write_bytes(out / f"displacement_radius_{surface}.png",
                                     displacement_vs_radius_png(maps, title=title))))
        files.append(str(write_bytes(out / f"displacement_map_{surface}.png",
                                     displacement_map_png(maps, title=title))))
        files.append(str(write_povray(out / "exact.pov", self.exact, mirror, self.scene, pose=pose)))
        if not self.same:
            files.append(str(write_povray(out / f"{surface}.pov", self.made, mirror, self.scene, pose=pose)))
        figures["files"] = files
        write_text(out / f"figures_{surface}.json", json_text(figures))
        return files


def render_plan(settings: Settings, surface: Surface, *, measured: str | None = None,
                progress: bool = True) -> RenderPlan:
    """The render of `surface` ([render] nose_radius and supersample; measured: the
    measured part's file), every check made: the render's nose, the program a program's
    surface is cut by, the room around the made mirror, a camera that sees it."""
    rc = settings.render
    nose = rc.nose_radius
    mirror = design(settings)
    pose = settings.camera_pose
    tool = dataclasses.replace(settings.tool, nose_radius=nose) if nose > 0 else None
    check_render_nose(settings, mirror)  # the render's own nose, named as render.nose_radius
    check_program(settings, mirror, surface, tool=tool)  # a program's surface: its program checked
    job = MachiningJob.from_settings(settings, mirror)  # the made mirror every command describes by default
    made = named_surface(surface, mirror, settings, nose_radius=float(nose), measured=measured, job=job)
    label = surface_label(surface, job, nose_radius=float(nose))
    # The zones of the nose that cut this surface (a program's contour: none), as every
    # command states its figures over them (optics.zones.zones_for).
    cut_nose = float(nose) if nose > 0 else (job.cutting_nose if surface in (Surface.MADE, Surface.POLISHED) else 0.0)
    zn = zones_for(dataclasses.replace(settings, tool=dataclasses.replace(settings.tool, nose_radius=cut_nose)),
                   mirror)
    z_top = float(max(np.max(made.z(np.linspace(0, made.r_max, 2001))), mirror.outer.h))
    scene = scene_for(settings, mirror, mirror_top=z_top + abs(pose.axial_offset))
    check_sees_mirror(made, mirror, pose)
    return RenderPlan(settings, mirror, surface, nose, made, label, zn, scene, progress)


def check_sees_mirror(profile: Profile, mirror: Mirror, pose) -> None:
    """InputError unless some pixel of a coarse grid sees a lobe of the mirror."""
    cam = mirror.camera
    u, v = pixel_centres(cam)
    step = max(1, min(cam.sensor_px) // 64)
    xy = np.stack([u[::step, ::step, 0], v[::step, ::step, 0]], axis=-1).reshape(-1, 2)
    hits = trace_pixels(profile, cam, xy, pose=pose)
    if not np.any(hits.fate <= Fate.OUTER):
        raise InputError(
            f"camera: no pixel sees the mirror (camera_pose decentre {list(pose.decentre)} mm, "
            f"axial_offset {pose.axial_offset:g} mm, tilt {[round(math.degrees(t), 3) for t in pose.tilt]} deg); "
            "the camera must look up the mirror axis"
        )


def write_png(path: str | Path, img: np.ndarray) -> str:
    """An image as PNG (export.png); its path."""
    return str(write_bytes(path, png_bytes(img)))
