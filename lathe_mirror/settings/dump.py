"""The typed Settings back to the configuration dict, in the file's units and names
(degrees, m, urad, named choices as their strings): `to_config(settings)`.

It is how a Settings built or varied in Python (`dataclasses.replace`) is held to the same
declared checks as a configuration file (settings.validate), and it writes back any
Settings as the TOML keys it came from.
"""

from __future__ import annotations

import dataclasses
import math
from enum import Enum
from typing import TYPE_CHECKING, Any

from ..design import LobeSpec
from ..optimize.spec import PARAMETERS

if TYPE_CHECKING:
    from .model import Settings


def _plain(v: Any) -> Any:
    if isinstance(v, Enum):
        return v.value
    if isinstance(v, tuple):
        return [_plain(x) for x in v]
    return v


def _fields(obj: Any, skip: tuple[str, ...] = ()) -> dict[str, Any]:
    return {f.name: _plain(getattr(obj, f.name)) for f in dataclasses.fields(obj) if f.name not in skip}


def _lobe(spec: LobeSpec) -> dict[str, Any]:
    out = {"r_top": spec.r_top, "r_pixel": spec.r_pixel}
    for k in ("alpha_deg", "a_over_b", "e"):
        if getattr(spec, k) is not None:
            out[k] = getattr(spec, k)
    return out


def to_config(s: Settings) -> dict[str, Any]:
    """The configuration dict whose from_config gives `s` (angles in degrees, ranges in m,
    squareness in urad as the file has them)."""
    cam = s.camera
    cfg: dict[str, Any] = {
        "camera": {"f": cam.f, "t_pixel": cam.t_pixel, "sensor_px": list(cam.sensor_px), "f_number": cam.f_number},
        "lobes": {spec.name: _lobe(spec) for spec in s.lobes},
    }
    machine = _fields(s.machine)
    me = s.machine_errors
    machine["errors"] = {"centre_height_mm": me.centre_height_mm, "x_offset_mm": me.x_offset_mm,
                         "nose_radius_error_mm": me.nose_radius_error_mm,
                         "squareness_urad": me.squareness_rad * 1e6, "backlash_mm": me.backlash_mm}
    cfg["machine"] = machine
    cfg["tool"] = {"nose_radius": s.tool.nose_radius, "included_angle": math.degrees(s.tool.included_angle),
                   "approach_angle": math.degrees(s.tool.approach_angle)}
    cfg["stock"] = _fields(s.stock)
    tp = _fields(s.toolpath)
    tp["ramp_angle"] = math.degrees(s.toolpath.ramp_angle)
    cfg["toolpath"] = tp
    cad = _fields(s.body)
    cad.update(step_schema=_plain(s.cad.schema), product_name=s.cad.product_name, stl_tolerance=s.cad.stl_tolerance)
    cfg["cad"] = cad
    polish = _fields(s.polish, skip=("processes",))
    polish["process"] = {p.name: _fields(p, skip=("name",)) for p in s.polish.processes}
    cfg["polish"] = polish
    if s.scene is not None:
        scene = _fields(s.scene, skip=("boxes",))
        scene["boxes"] = [{"centre": list(b.centre), "size": list(b.size)} for b in s.scene.boxes]
        cfg["scene"] = scene
    cfg["render"] = _fields(s.render)
    pose = s.pose
    cfg["camera_pose"] = {"decentre": list(pose.decentre), "axial_offset": pose.axial_offset,
                          "tilt_deg": [math.degrees(t) for t in pose.tilt]}
    if s.tolerance is not None:
        t = s.tolerance
        tol = _fields(t, skip=("spec", "tolerances", "cost", "machine_errors"))
        tol.update(spec=_fields(t.spec), params=dict(t.tolerances), cost=dict(t.cost),
                   machine_errors=dict(t.machine_errors))
        cfg["tolerance"] = tol
    st = s.stereo
    stereo = _fields(st.params.match, skip=("num_disparities",))
    stereo.update(surface=_plain(st.surface), supersample=st.supersample, min_range_m=st.params.min_range / 1e3,
                  elevation_step_deg=math.degrees(st.params.elevation_step) if st.params.elevation_step else 0.0,
                  azimuth_px=st.params.n_azimuth or 0, equalise=st.params.equalise,
                  ply_format="binary" if st.ply_binary else "ascii")
    cfg["stereo"] = stereo
    op = _fields(s.optimize, skip=("search",))
    op["search"] = {name: list(getattr(s.optimize.search, name)) for name in PARAMETERS}
    cfg["optimize"] = op
    cfg["compute"] = _fields(s.compute)
    return cfg
