"""POV-Ray 3.7, run for real, renders the exported scene as we do: the same pixel-to-ray
mapping and the same colours, for the exact lobes (quadrics), the 528-point paper program
(a lathe of its points) and a misaligned camera (our 3-D tracer)."""

from __future__ import annotations

import math
import subprocess

import numpy as np
import pytest
from PIL import Image

from conftest import require_program
from lathe_mirror.settings import from_config
from lathe_mirror.config import merge
from lathe_mirror.design import Camera
from lathe_mirror.export.povray import povray_camera, povray_command, povray_scene
from lathe_mirror.optics.camera import CameraPose, pixel_centres, ray_directions
from lathe_mirror.optics.render import render_image
from lathe_mirror.optics.scene import build_scene
from lathe_mirror.enums import Surface
from lathe_mirror.job import named_surface

# A quarter-resolution sensor with the same field of view (4x the pitch): fast to render.
SMALL = Camera(16.0, 0.036, (252, 254))


def _edges(img: np.ndarray) -> np.ndarray:
    """Pixels whose 3 x 3 neighbourhood holds more than one colour."""
    flat = img.astype(np.int32) @ np.array([1, 256, 65536])
    pad = np.pad(flat, 1, mode="edge")
    edge = np.zeros(flat.shape, bool)
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            edge |= pad[1 + dy:1 + dy + flat.shape[0], 1 + dx:1 + dx + flat.shape[1]] != flat
    return edge


def _povray(tmp_path, text: str, camera: Camera) -> np.ndarray:
    exe = require_program("povray")
    pov, png = tmp_path / "scene.pov", tmp_path / "scene.png"
    pov.write_text(text)
    p = subprocess.run(povray_command(pov, png, camera, povray=exe), capture_output=True,
                       text=True, timeout=300, cwd=tmp_path)
    assert p.returncode == 0, p.stderr[-2000:]
    return np.asarray(Image.open(png).convert("RGB"))


def _agreement(ours: np.ndarray, theirs: np.ndarray) -> tuple[float, float]:
    same = np.abs(ours.astype(int) - theirs.astype(int)).max(axis=-1) <= 2
    calm = ~_edges(ours)
    return float(same[calm].mean()), float(same.mean())


@pytest.mark.parametrize("pose", [
    CameraPose(),
    CameraPose(decentre=(0.4, -0.2), axial_offset=0.5, tilt=(math.radians(0.8), math.radians(-0.5))),
], ids=["aligned", "misaligned"])
def test_povray_camera_casts_our_ray_through_every_pixel(tmp_path, pose):
    """The pixel-to-ray mapping itself, pixel by pixel: POV-Ray renders our exported camera
    looking at the plane z = Z0, painted with a linear ramp of x (then of y) in a 16-bit
    grey PNG, so each pixel's value is where POV-Ray's ray through it meets the plane. It
    must be where our ray (camera.ray_directions) meets it, to well under a pixel."""
    exe = require_program("povray")
    z0, span = 100.0, 100.0  # plane height and ramp width, mm: 16 bits = 0.0015 mm steps
    u, v = pixel_centres(SMALL)
    origin, d = ray_directions(SMALL, u[..., 0], v[..., 0], pose)
    s = (z0 - origin[2]) / d[..., 2]
    ours = [origin[i] + s * d[..., i] for i in (0, 1)]
    pixel_on_plane = z0 * SMALL.t_pixel / SMALL.f  # mm per pixel near the axis
    for axis, pov_axis in ((0, "x"), (1, "z")):  # our y is POV-Ray's z
        text = "\n".join([
            "#version 3.7;", "global_settings { assumed_gamma 1.0 }", povray_camera(SMALL, pose=pose),
            f"plane {{ <0, 1, 0>, {z0} texture {{ pigment {{ function {{ ({pov_axis} + {span / 2}) / {span} }} "
            "colour_map { [0 rgb 0] [1 rgb 1] } } finish { ambient 1 diffuse 0 } } }", ""])
        pov, png = tmp_path / f"ramp{axis}.pov", tmp_path / f"ramp{axis}.png"
        pov.write_text(text)
        cmd = povray_command(pov, png, SMALL, povray=exe)
        cmd[cmd.index("+FN")] = "+FN16"
        p = subprocess.run(cmd + ["Grayscale_Output=true"], capture_output=True, text=True,
                           timeout=120, cwd=tmp_path)
        assert p.returncode == 0, p.stderr[-2000:]
        grey = np.asarray(Image.open(png), dtype=float)
        assert grey.shape == u.shape[:2] and np.ptp(grey) > 30000  # 16 bits, a wide ramp
        theirs = grey / 65535.0 * span - span / 2
        assert np.abs(theirs - ours[axis]).max() < 0.02 * pixel_on_plane


@pytest.fixture(scope="module")
def scene(paper_config, paper_mirror):
    return build_scene(from_config(paper_config).scene, mirror_top=paper_mirror.outer.h, mirror_radius=35.0)


@pytest.mark.parametrize("surface", ["exact", "paper", "best"])
def test_povray_agrees_with_our_render(tmp_path, paper_config, paper_mirror, scene, surface):
    # The paper's own simulation: its programmed points as the surface (a sharp tool).
    cfg = merge(paper_config, {"tool": {"nose_radius": 0.0}})
    made = named_surface(Surface(surface), paper_mirror, from_config(cfg))
    text = povray_scene(made, paper_mirror, scene, SMALL)
    assert ("quadric {" in text) == (surface == "exact") and ("lathe {" in text) == (surface != "exact")
    if surface == "paper":
        assert "linear_spline 302," in text and "linear_spline 226," in text  # 528 points
    theirs = _povray(tmp_path, text, SMALL)
    ours = render_image(made, paper_mirror, scene, SMALL)
    calm, every = _agreement(ours, theirs)
    assert calm >= 0.99   # the criterion
    assert every >= 0.99  # and edges too: the same pixel-to-ray mapping
    # The check would see a mapping one pixel off: shifted, far fewer pixels agree.
    shifted = np.roll(ours, 1, axis=1)
    assert _agreement(shifted, theirs)[1] < every - 0.02
    flipped = ours[::-1]
    assert _agreement(flipped, theirs)[1] < 0.9


def test_povray_agrees_with_our_3d_tracer_for_a_misaligned_camera(tmp_path, paper_mirror, paper_config, scene):
    exact = named_surface(Surface("exact"), paper_mirror, from_config(paper_config))
    pose = CameraPose(decentre=(0.4, -0.2), axial_offset=0.5, tilt=(math.radians(0.8), math.radians(-0.5)))
    theirs = _povray(tmp_path, povray_scene(exact, paper_mirror, scene, SMALL, pose=pose), SMALL)
    ours = render_image(exact, paper_mirror, scene, SMALL, pose=pose)
    aligned = render_image(exact, paper_mirror, scene, SMALL)
    calm, every = _agreement(ours, theirs)
    assert calm >= 0.99 and every >= 0.98
    assert _agreement(aligned, theirs)[1] < every - 0.05  # the pose matters and is matched


def test_povray_export_is_the_same_text_in_another_process(paper_mirror, paper_config, scene):
    """Same inputs, same bytes: a fresh interpreter (another hash seed) writes the same .pov."""
    import os
    import sys

    code = (
        "import sys\n"
        "from lathe_mirror.config import load\n"
        "from lathe_mirror.enums import Surface\n"
        "from lathe_mirror.export.povray import povray_scene\n"
        "from lathe_mirror.optics.scene import build_scene\n"
        "from lathe_mirror.job import named_surface\n"
        "s = load(); m = s.mirror()\n"
        "sc = build_scene(s.scene, mirror_top=m.outer.h, mirror_radius=35.0)\n"
        "sys.stdout.write(''.join(povray_scene(named_surface(Surface(n), m, s), m, sc) for n in ('exact', 'paper')))\n"
    )
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120,
                       env={**os.environ, "PYTHONHASHSEED": "12345"})
    assert p.returncode == 0, p.stderr[-2000:]
    here = "".join(povray_scene(named_surface(Surface(n), paper_mirror, from_config(paper_config)), paper_mirror, scene)
                   for n in ("exact", "paper"))
    assert p.stdout == here
