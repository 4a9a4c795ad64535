"""The design's keys: the camera, the two lobes (Table 1), the camera's misalignment.

Declared once here (declared.key.Key): type (from the default), unit, default, range,
the reason for the limit, help text. lathe_mirror.declared gathers every module's KEYS.
"""

from __future__ import annotations

from .key import Key

#: Sections declared here: camera, lobes, camera_pose.
KEYS: tuple[Key, ...] = (
    Key('camera.f', 16.0, 'mm', 0.1, 1000.0, why='focal length', help='focal length, mm',
        lo_depends=True,
        hi_depends=True,
        depends='the design: lobes.inner and lobes.outer through h = f R_top / (T_pixel R_pixel) (Eq. 6); the room (scene.room_height)'),
    Key('camera.t_pixel', 0.009, 'mm', 0.0005, 0.1, why='pixel pitch', help='pixel pitch, mm',
        lo_depends=True,
        hi_depends=True,
        depends='the design: lobes.inner and lobes.outer through h = f R_top / (T_pixel R_pixel) (Eq. 6); the room (scene.room_height)'),
    Key('camera.sensor_px', [1008, 1018], 'px', 2, 1000000,
        length=(2, 2),
        why='width, height',
        help='width, height in pixels; principal point at the centre',
        lo_depends=True,
        hi_depends=True,
        depends="lobes.inner.r_pixel and lobes.outer.r_pixel inside the sensor's inscribed circle; the render's memory estimate (camera.sensor_px with render.supersample, stereo.supersample)"),
    Key('camera.f_number', 8.0, "", 0.5, 100.0,
        why="the lens's aperture, f / diameter",
        help="aperture (f / diameter); only the optimiser's focus model uses it"),
    *(k for lobe, r_top, r_pixel, alpha, table in (
        ("inner", 20.0, 307.555, 13.948, "Table 1, mirror 01"), ("outer", 35.0, 504.0, 0.028, "Table 1, mirror 02"))
      for k in (
        Key(f"lobes.{lobe}.r_top", r_top, "mm", 0.1, 1000.0, depends=f"the design: lobes.{lobe}.alpha_deg inside the rim's range, the outer rim outside the inner; "
                    "the room (scene.room_height); tolerance.params.camera_tilt_deg, tolerance.params.camera_decentre_mm, "
                    "tolerance.params.camera_axial_mm (each lobe keeps half its pixels)",
            lo_depends=True, hi_depends=True, help=f"the rim's radius R_top, mm ({table})"),
        Key(f"lobes.{lobe}.r_pixel", r_pixel, "px", 1.0, 32768.0, why="at most half the sensor's smaller side",
            depends=f"the design: inside the sensor (camera.sensor_px), lobes.{lobe}.alpha_deg inside the rim's "
                    "range through h (Eq. 6)", lo_depends=True,
            hi_depends=True, help=f"the rim's image radius R_pixel, px ({table})"),
        Key(f"lobes.{lobe}.alpha_deg", alpha, "deg", -90.0, 90.0, lo_open=True, hi_open=True,
            depends="the rim's own range (R_top, h), which the message gives", lo_depends=True, hi_depends=True,
            help="the rim's angle above the lobe focus's horizon, deg (Table 1's alpha; exactly one of "
                 "alpha_deg, a_over_b, e)"),
        Key(f"lobes.{lobe}.a_over_b", None, "", 0.0, 1000.0, lo_open=True, kind="float",
            depends="h / R_top, and not degenerate", lo_depends=True, hi_depends=True,
            help="the hyperbola's a / b (instead of alpha_deg)"),
        Key(f"lobes.{lobe}.e", None, "mm", 0.0, 10000.0, lo_open=True, kind="float",
            depends="h, and not degenerate", lo_depends=True, hi_depends=True,
            help="the hyperbola's e, mm: F1 at 2e above the pinhole (instead of alpha_deg)"),
      )),
    Key('camera_pose.decentre', [0.0, 0.0], 'mm', -1000.0, 1000.0,
        length=(2, 2),
        why='and some pixel must see the mirror',
        help='pinhole (x, y) off the axis, mm'),
    Key('camera_pose.axial_offset', 0.0, 'mm', -1000.0, 1000.0,
        help='pinhole along the axis, mm (+ toward the mirror)'),
    Key('camera_pose.tilt_deg', [0.0, 0.0], 'deg', -45.0, 45.0,
        lo_open=True,
        hi_open=True,
        length=(2, 2),
        help='rotation of the optical axis about x, then y, degrees'),
)
