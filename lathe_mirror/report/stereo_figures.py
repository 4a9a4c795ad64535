"""`lathe-mirror stereo`'s work: the room rendered through a named mirror (blurred by the
lens's defocus), ranged as the robot would (rectify, match, triangulate:
optics.ranging.stereo), measured against the room's true range, and the files: the
range panorama, the error against range, the point cloud and the figures.

`stereo_plan` makes the checks that need no surface (the band, the matcher, the program
of a program's surface); `StereoPlan`'s methods do the work stage by stage, in the order
the command shows its progress.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..design import Mirror
from ..enums import Surface
from ..errors import InputError
from ..export.files import json_text, write_bytes, write_text
from ..export.ply import write_ply
from ..job import MachiningJob, check_program, design, named_surface, scene_for, surface_label
from ..optics.defocus import blur_figures, blur_map, defocus_image, grow_mask, lens_for
from ..optics.ranging.stereo import band_visibility, error_curve, image_mask, prepare, range_figures, stereo_range
from ..optics.ranging.truth import true_range
from ..optics.render import render_image
from ..optics.zones import zones_for
from .range_plots import error_vs_range_png, preload, range_map_png

if TYPE_CHECKING:
    from ..settings import Settings

__all__ = ["StereoPlan", "preload", "stereo_plan", "write_stereo"]


@dataclass
class StereoPlan:
    """The stereo range of the named `surface` (measured: the measured part's file) on the
    panorama `grid` with the matcher `match` (optics.ranging.stereo.prepare)."""

    settings: Settings
    mirror: Mirror
    surface: Surface
    measured: str | None
    grid: Any
    match: Any
    job: MachiningJob | None = None
    made: Any = None
    scene: Any = None
    lens: Any = None

    def check_program(self) -> None:
        """A surface cut by a program: the program checked (job.check_program)."""
        check_program(self.settings, self.mirror, self.surface)

    def made_surface(self) -> None:
        """The made mirror (the job's named surface), refused when the camera sees the
        common band through a lobe on less than half its panorama, and the room around it."""
        s, mirror, pose = self.settings, self.mirror, self.settings.camera_pose
        self.job = MachiningJob.from_settings(s, mirror)  # the made mirror every command describes
        self.made = named_surface(self.surface, mirror, s, measured=self.measured, job=self.job)
        seen = band_visibility(self.made, mirror, self.grid, pose)
        for name, frac in zip(("inner", "outer"), seen):
            if frac < 0.5:
                raise_unseen(self.surface.value, name, frac)
        z_top = float(max(np.max(self.made.z(np.linspace(0, self.made.r_max, 2001))), mirror.outer.h))
        self.scene = scene_for(s, mirror, mirror_top=z_top + abs(pose.axial_offset))

    def image(self) -> np.ndarray:
        """The image the matcher sees, as the camera records it (the lens's defocus); the
        render reaches as far past the matcher's mask as the blur does."""
        s, mirror = self.settings, self.mirror
        self.lens = lens_for(mirror, s.optimize.focus_range_m * 1000.0)
        blur = blur_map(mirror, self.lens)
        return defocus_image(render_image(self.made, mirror, self.scene, pose=s.camera_pose, supersample=s.stereo.supersample,
                                          pixels=grow_mask(image_mask(mirror, self.grid, self.match.num_disparities),
                                                           blur)),
                             blur)

    def range(self, image: np.ndarray):
        """The range from the image (optics.ranging.stereo.stereo_range)."""
        return stereo_range(image, self.mirror, self.settings.stereo.params)

    def figures(self, result) -> tuple[dict, dict]:
        """(the figures against the room's true range, the error against range)."""
        s, mirror = self.settings, self.mirror
        truth = true_range(mirror, self.scene, self.grid)
        figures = {"surface": self.surface.value, "made_mirror": surface_label(self.surface, self.job),
                   "supersample": s.stereo.supersample, "camera_pose_aligned": s.camera_pose.aligned,
                   **range_figures(result, truth, mirror),
                   "defocus": blur_figures(mirror, self.lens, zones_for(s, mirror))}
        precision = figures["disparity_error_px"]["precision"]
        curve = {**error_curve(result, truth, mirror, precision), "precision_px": precision}
        figures["error_curve"] = curve
        return figures, curve


def stereo_plan(settings: Settings, surface: Surface, *, measured: str | None = None) -> StereoPlan:
    """The design's panorama grid and matcher (an empty or too narrow band is refused)."""
    mirror = design(settings)
    grid, match = prepare(mirror, settings.stereo.params)  # an empty or too narrow band stops here
    return StereoPlan(settings, mirror, surface, measured, grid, match)


def raise_unseen(surface: str, lobe: str, frac: float) -> None:
    raise InputError(
        f"--surface {surface}: the camera sees the common band through the {lobe} lobe on only "
        f"{100 * frac:.1f} % of its panorama (at least 50 % needed; check the surface and "
        "[camera_pose]): no stereo")


def write_stereo(out: Path, surface: str, result, figures: dict, curve: dict, binary: bool) -> list[str]:
    """Write the range panorama and the error plot (PNG), the point cloud (PLY) and the
    figures (JSON) into the directory out; returns the paths."""
    band = tuple(math.degrees(x) for x in result.grid.band)
    rng_m = result.range_map.range_mm / 1e3
    valid = result.valid
    files = [str(write_bytes(out / f"range_{surface}.png", range_map_png(
        rng_m, band, title=f"{surface}: range from the stereo centre, {100 * valid.mean():.1f} % of the "
        "common band ranged (grey: no range)")))]
    files.append(str(write_bytes(out / f"error_range_{surface}.png", error_vs_range_png(
        {surface: curve}, title=f"{surface}: median |range error| against range"))))
    pts = result.range_map.points[valid] * 1e-3
    files.append(str(write_ply(out / f"points_{surface}.ply", pts, result.colour[valid], binary=binary,
                               comments=(f"lathe-mirror stereo, surface {surface}",
                                         "units m; camera frame: pinhole at the origin, +z up the mirror axis"))))
    path = out / f"stereo_{surface}.json"
    files.append(str(path))
    write_text(path, json_text({**figures, "files": files}))
    return files
