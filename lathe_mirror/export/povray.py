"""POV-Ray 3.7 scene of the room, the camera and the mirror (the paper's renderer, section 6).

Frames: our camera frame (x, y, z), z up the mirror axis, right-handed, maps to POV-Ray's
left-handed y-up frame as <x, z, y> (swapping two axes flips the handedness, so the scene
is the same scene, not its mirror image). A `lathe` revolves about POV-Ray's y axis,
which is our z axis, and takes points <r, z>.

Camera: a `perspective` camera with explicit vectors reproduces our pinhole exactly:
`direction` = the optical axis times f, `right` = the sensor's width W * t_pixel along
the image's +u (columns), `up` = its height H * t_pixel along the image's -v (rows run
down), all in mm, so POV-Ray's ray through (column, row) is ours (camera.py).

Mirror: the programmed contour as one `lathe { linear_spline ... }` per lobe (the vertices
of a piecewise-linear profile: the programmed G1 points; any other Profile sampled
densely, DENSE_POINTS per lobe), the exact mirror as one
`quadric` per lobe, (z - e)^2 / a^2 - r^2 / b^2 = 1, clipped to its radial range and upper
sheet. The step wall between the lobes is an open black cylinder and a black annulus at
the rim height stands for the mount, so the lost ring and the corners are black as in our
render. Shading: `assumed_gamma 1.0`, finish { ambient A diffuse D }, one distant
shadowless `parallel` light: Lambert plus ambient, as in optics/scene.py. Render with
`povray -D -V +FN +W.. +H.. +I.. +O.. File_Gamma=1.0` for linear PNGs.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..design import Camera, Mirror
from ..optics.camera import ALIGNED, CameraPose
from ..optics.scene import Scene
from ..optics.trace import polyline_vertices
from ..profile import ExactProfile, Profile
from .files import write_text
from .numbers import LENGTH_MM, fmt, fmt_sig

#: Samples per lobe for a Profile that is not a polyline (lathe points are straight segments).
DENSE_POINTS = 2001
#: A piecewise-linear profile with more vertices than this per lobe is resampled instead.
MAX_LATHE_POINTS = 20000
#: Outer radius of the black mount annulus around the rim, mm beyond r_max.
MOUNT_WIDTH_MM = 60.0


def povray_scene(profile: Profile, mirror: Mirror, scene: Scene, camera: Camera | None = None, *,
                 pose: CameraPose = ALIGNED) -> str:
    """The scene description (.pov text) of the room, camera and mirror. Deterministic."""
    camera = camera or mirror.camera
    light_far = 1e7 * np.array(scene.light)
    lines = [
        "// lathe-mirror: the paper's room seen through the double-lobed mirror (POV-Ray 3.7).",
        "// Units mm; our camera frame (x, y, z) is POV-Ray's <x, z, y>.",
        "#version 3.7;",
        "global_settings { assumed_gamma 1.0 ambient_light rgb 1 max_trace_level 5 }",
        povray_camera(camera, pose=pose),
        f"light_source {{ {_v(light_far)} color rgb 1 parallel point_at <0, 0, 0> shadowless }}",
        f"#declare Lit = finish {{ ambient {_f(scene.ambient)} diffuse {_f(scene.diffuse)} }}",
        "#declare Unlit = texture { pigment { rgb 0 } finish { ambient 0 diffuse 0 } }",
        "#declare Mirror = texture { pigment { rgb 0 } finish { ambient 0 diffuse 0 reflection { 1 } } }",
    ]
    x_lo, x_hi, y_lo, y_hi, z_f, z_c = scene.bounds
    lines += [
        _plane((0, 0, 1), z_f, _checker(scene.floor_colours, scene.floor_square)),
        _plane((0, 0, 1), z_c, f"pigment {{ rgb {_rgb(scene.ceiling_colour)} }}"),
        _plane((1, 0, 0), x_lo, _checker(scene.x_wall_colours, scene.wall_square)),
        _plane((1, 0, 0), x_hi, _checker(scene.x_wall_colours, scene.wall_square)),
        _plane((0, 1, 0), y_lo, _checker(scene.y_wall_colours, scene.wall_square)),
        _plane((0, 1, 0), y_hi, _checker(scene.y_wall_colours, scene.wall_square)),
    ]
    for box in scene.boxes:
        lines.append(f"box {{ {_v(box.lo)}, {_v(box.hi)} texture {{ pigment {{ rgb "
                     f"{_rgb(scene.box_colour)} }} finish {{ Lit }} }} }}")
    lines += _mirror(profile, mirror)
    return "\n".join(lines) + "\n"


def povray_camera(camera: Camera, *, pose: CameraPose = ALIGNED) -> str:
    """The `camera { perspective ... }` block whose ray through each pixel is ours (camera.py).

    direction = the optical axis times f, right = the sensor width W * t_pixel along +u,
    up = its height H * t_pixel along -v (rows run down), all mm, turned by the pose.
    """
    w, h = camera.sensor_px
    rot = pose.rotation
    direction = rot @ np.array([0.0, 0.0, camera.f])
    right = rot @ np.array([w * camera.t_pixel, 0.0, 0.0])
    up = rot @ np.array([0.0, -h * camera.t_pixel, 0.0])
    return "\n".join([
        "camera {",
        "  perspective",
        f"  location {_v(pose.origin)}",
        f"  direction {_v(direction)}",
        f"  right {_v(right)}",
        f"  up {_v(up)}",
        "}",
    ])


def write_povray(path: str | Path, profile: Profile, mirror: Mirror, scene: Scene,
                 camera: Camera | None = None, *, pose: CameraPose = ALIGNED) -> Path:
    """Write the .pov scene atomically; returns the path."""
    return write_text(path, povray_scene(profile, mirror, scene, camera, pose=pose))


def povray_command(pov: str | Path, png: str | Path, camera: Camera, *, threads: int | None = None,
                   povray: str = "povray") -> list[str]:
    """The command line rendering a scene to a linear PNG of the camera's sensor size."""
    w, h = camera.sensor_px
    cmd = [povray, "-D", "-V", "+FN", f"+W{w}", f"+H{h}", f"+I{pov}", f"+O{png}", "File_Gamma=1.0"]
    if threads:
        cmd.append(f"+WT{threads}")
    return cmd


# --------------------------------------------------------------------------------------


def _mirror(profile: Profile, mirror: Mirror) -> list[str]:
    rj, r_max = profile.r_junction, profile.r_max
    r_out0 = np.nextafter(rj, np.inf)
    zi_j, zo_j, z_rim = (float(profile.z(np.array(x))) for x in (rj, r_out0, r_max))
    out = []
    if isinstance(profile, ExactProfile) and isinstance(profile.mirror, Mirror):  # a design: quadrics
        for k, lobe in enumerate(profile.mirror.lobes):
            a2, b2, e = lobe.a**2, lobe.b**2, lobe.e
            # (y - e)^2 / a^2 - (x^2 + z^2) / b^2 - 1 = 0 in POV-Ray's frame.
            # quadric coefficients (1/mm^2, 1/mm, 1): 12 significant digits (export.numbers)
            coeffs = (f"<{fmt_sig(-1 / b2)}, {fmt_sig(1 / a2)}, {fmt_sig(-1 / b2)}>, <0, 0, 0>, "
                      f"<0, {fmt_sig(-2 * e / a2)}, 0>, {fmt_sig(e * e / a2 - 1)}")
            top = float(lobe.z(profile.lobe_range(k)[1])) + 1.0
            keep = f"cylinder {{ <0, {_f(e)}, 0>, <0, {_f(top)}, 0>, {_f(profile.lobe_range(k)[1])} }}"
            if k == 1:
                keep = (f"intersection {{ {keep} cylinder {{ <0, {_f(e - 1)}, 0>, <0, {_f(top + 1)}, 0>, "
                        f"{_f(rj)} inverse }} }}")
            out.append(f"quadric {{ {coeffs} clipped_by {{ {keep} }} texture {{ Mirror }} }}"
                       f"  // {lobe.name} lobe, exact")
    else:
        for k in (0, 1):
            r, z = _lobe_points(profile, k)
            pts = " ".join(f"<{_f(a)}, {_f(b)}>" for a, b in zip(r, z))
            out.append(f"lathe {{ linear_spline {r.size}, {pts} texture {{ Mirror }} }}"
                       f"  // {('inner', 'outer')[k]} lobe, programmed")
    lo, hi = sorted((zi_j, zo_j))
    if hi > lo:
        out.append(f"cylinder {{ <0, {_f(lo)}, 0>, <0, {_f(hi)}, 0>, {_f(rj)} open texture {{ Unlit }} }}"
                   "  // step wall")
    out.append(f"disc {{ <0, {_f(z_rim)}, 0>, <0, 1, 0>, {_f(r_max + MOUNT_WIDTH_MM)}, {_f(r_max)} "
               "texture { Unlit } no_reflection }  // mount")
    return out


def _lobe_points(profile: Profile, k: int) -> tuple[np.ndarray, np.ndarray]:
    """Lathe points (r, z) of lobe k covering its whole radial range, mm."""
    lo, hi = profile.lobe_range(k)
    lo_eval = np.nextafter(lo, np.inf) if k == 1 else lo
    vertices = polyline_vertices(profile, k)
    if vertices is not None and vertices[0].size <= MAX_LATHE_POINTS:
        rs, zs = vertices
        inside = (rs > lo) & (rs < hi)
        r = np.concatenate([[lo], rs[inside], [hi]])
        z = np.concatenate([[float(profile.z(np.array(lo_eval)))], zs[inside],
                            [float(profile.z(np.array(hi)))]])
        return r, z
    r = np.linspace(lo, hi, DENSE_POINTS)
    if hasattr(profile, "breakpoints"):  # keep the program's kinks (move ends) exact
        b = np.asarray(profile.breakpoints(k), dtype=float)
        r = np.union1d(r, b[(b > lo) & (b < hi)])
    z = profile.z(np.concatenate([[lo_eval], r[1:]]))
    return r, z


def _plane(normal, offset: float, pigment: str) -> str:
    return f"plane {{ {_v(normal)}, {_f(offset)} texture {{ {pigment} finish {{ Lit }} }} }}"


def _checker(colours, square: float) -> str:
    return (f"pigment {{ checker rgb {_rgb(colours[0])}, rgb {_rgb(colours[1])} "
            f"scale {_f(square)} }}")


def _v(p) -> str:
    """Our (x, y, z) as POV-Ray's <x, z, y>."""
    x, y, z = (float(c) for c in p)
    return f"<{_f(x)}, {_f(z)}, {_f(y)}>"


def _rgb(c) -> str:
    return "<" + ", ".join(_f(x) for x in c) + ">"


def _f(x: float) -> str:
    """A scene number (mm; colours and finishes are ratios) to 1e-9 (export.numbers)."""
    return fmt(float(x), LENGTH_MM)
