"""Settings from a merged configuration dict: each TOML section turned into its typed
object, every value checked (ranges, choices, the design, the costs).

`config.load()` merges the user's TOML over the embedded defaults and checks every key's
name and type; `from_config` here builds the typed Settings and checks every value. Each
rejection is one InputError line naming the key and what is allowed, and all of it happens
before any command does work or writes a file.
"""

from __future__ import annotations

import math
from typing import Any

from ..body import BodySpec, CadSettings
from ..declared import check as check_declared
from ..design import Camera, LobeSpec
from ..enums import (
    BEST,
    Distribution,
    Dwell,
    Lap,
    Mount,
    PolishObjective,
    Program,
    StepSchema,
    Strategy,
    Surface,
    parse,
)
from ..errors import ConfigError
from ..finish import Process
from ..lathe import Lathe, Stock, Tool
from ..machine_errors import MachineErrors
from ..optics.camera import CameraPose
from ..optics.ranging.match import MatchParams
from ..optics.ranging.stereo import StereoParams
from ..optics.scene import BoxSpec, SceneSpec
from ..optimize.spec import Objective, OptimizeSettings, SearchSpace
from ..polishing import PolishParams
from ..tolerance.spec import Spec, ToleranceSettings
from ..toolpath import ToolpathSettings
from .keys import check_ranges
from .model import ComputeSettings, RenderSettings, Settings, StereoSettings

def from_config(cfg: dict[str, Any]) -> Settings:
    """Settings from a merged, key-checked configuration dict (config.load does both).

    Every key is held to its declared range first (settings.keys), then each section is
    built (a named choice parsed: its message lists the names), then Settings validates
    the whole (settings.validate: the cross-key rules, the design, the room, the costs).
    """
    check_ranges(cfg)  # every key within its declared range (settings.keys), before any section is built
    camera = Camera(f=float(cfg["camera"]["f"]), t_pixel=float(cfg["camera"]["t_pixel"]),
                    sensor_px=tuple(int(n) for n in cfg["camera"]["sensor_px"]),
                    f_number=float(cfg["camera"]["f_number"]))
    lobes = tuple(_lobe_spec(name, cfg["lobes"][name]) for name in ("inner", "outer"))
    settings = Settings(
        camera=camera,
        lobes=lobes,
        machine=_lathe(cfg["machine"]),
        tool=_tool(cfg["tool"]),
        stock=Stock(diameter=float(cfg["stock"]["diameter"]),
                    face_allowance=float(cfg["stock"]["face_allowance"]),
                    length=float(cfg["stock"]["length"])),
        toolpath=_toolpath(cfg["toolpath"]),
        body=_body(cfg["cad"]),
        cad=CadSettings(schema=parse(StepSchema, cfg["cad"]["step_schema"], "cad.step_schema"),
                        product_name=cfg["cad"]["product_name"],
                        stl_tolerance=cfg["cad"]["stl_tolerance"]),
        polish=_polish(cfg["polish"]),
        scene=_scene(cfg["scene"]),
        render=_render(cfg["render"]),
        pose=_pose(cfg["camera_pose"]),
        tolerance=_tolerance(cfg),
        stereo=_stereo(cfg["stereo"]),
        optimize=_optimize(cfg["optimize"]),
        machine_errors=_machine_errors(cfg["machine"]["errors"]),
        compute=_compute(cfg["compute"]),
    )
    return settings  # Settings.__post_init__ ran settings.validate: the design, the room, the costs


# --------------------------------------------------------------------------------------
# Sections


def _lobe_spec(name: str, lc: dict) -> LobeSpec:
    return LobeSpec(name=name, r_top=float(lc["r_top"]), r_pixel=float(lc["r_pixel"]),
                    alpha_deg=lc.get("alpha_deg"), a_over_b=lc.get("a_over_b"), e=lc.get("e"))


def _lathe(m: dict) -> Lathe:
    return Lathe(
        resolution=float(m["resolution"]),
        max_points=int(m["max_points"]),
        diameter_mode=bool(m["diameter_mode"]),
        travel_x=float(m["travel_x"]),
        travel_z_min=float(m["travel_z_min"]),
        travel_z_max=float(m["travel_z_max"]),
        spindle_max_rpm=int(m["spindle_max_rpm"]),
        surface_speed=float(m["surface_speed"]),
        feed_rough=float(m["feed_rough"]),
        feed_finish=float(m["feed_finish"]),
        arc_radius_tolerance=float(m["arc_radius_tolerance"]),
    )


def _machine_errors(e: dict) -> MachineErrors:
    """[machine.errors] (squareness in urad in the file, rad inside)."""
    return MachineErrors(centre_height_mm=float(e["centre_height_mm"]), x_offset_mm=float(e["x_offset_mm"]),
                         nose_radius_error_mm=float(e["nose_radius_error_mm"]),
                         squareness_rad=float(e["squareness_urad"]) * 1e-6, backlash_mm=float(e["backlash_mm"]))


def _tool(t: dict) -> Tool:
    # angles in degrees in the file, radians inside
    return Tool(nose_radius=float(t["nose_radius"]),
                included_angle=math.radians(float(t["included_angle"])),
                approach_angle=math.radians(float(t["approach_angle"])))


def _toolpath(t: dict) -> ToolpathSettings:
    strategy = parse(Strategy, t["strategy"], "toolpath.strategy", aliases={"best": BEST})
    ts = ToolpathSettings(strategy=strategy, gouge_tolerance=float(t["gouge_tolerance"]),
                          max_deviation=float(t["max_deviation"]), rough_depth=float(t["rough_depth"]),
                          rough_allowance=float(t["rough_allowance"]), clearance=float(t["clearance"]),
                          ramp_angle=math.radians(float(t["ramp_angle"])), spring_pass=bool(t["spring_pass"]),
                          coolant=bool(t["coolant"]), home_r=float(t["home_r"]), home_z=float(t["home_z"]),
                          rapid_rate=float(t["rapid_rate"]), path_tolerance_mm=float(t["path_tolerance_mm"]),
                          max_finish_depth_mm=float(t["max_finish_depth_mm"]),
                          parting_width_mm=float(t["parting_width_mm"]), parting_feed=float(t["parting_feed"]),
                          back_allowance_mm=float(t["back_allowance_mm"]))
    return ts


def _body(c: dict) -> BodySpec:
    """BodySpec from the [cad] section (validated: the message names the key)."""
    try:
        mount = Mount(c["mount"])
    except ValueError:
        raise ConfigError(
            f"cad.mount = {c['mount']!r}: allowed {', '.join(repr(m.value) for m in Mount)}"
        ) from None
    return BodySpec(
        blank_diameter=float(c["blank_diameter"]), thickness=float(c["thickness"]),
        mount=mount, mount_diameter=float(c["mount_diameter"]),
        mount_depth=float(c["mount_depth"]), min_wall=float(c["min_wall"]),
    )


def _polish(pc: dict) -> PolishParams:
    """PolishParams from [polish] (its presets from [polish.process.*]); PolishParams and
    Process check the values."""
    kinds = {"curve_points": int, "form_degree": int, "stroke_points": int, "precompensate": bool,
             "lap": lambda v: parse(Lap, v, "polish.lap"), "dwell": lambda v: parse(Dwell, v, "polish.dwell"),
             "objective": lambda v: parse(PolishObjective, v, "polish.objective")}
    values = {k: kinds.get(k, float)(v) for k, v in pc.items() if k != "process"}
    processes = tuple(
        Process(name=name, label=str(t["label"]), program=parse(Program, t["program"], f"polish.process.{name}.program"),
                polish=bool(t["polish"]), **{k: float(t[k]) for k in ("nose_radius_mm", "feed_mm", "resolution_mm",
                                                                       "turned_floor_nm", "polished_floor_nm")})
        for name, t in pc.get("process", {}).items())
    return PolishParams(**values, **({"processes": processes} if processes else {}))


def _scene(sc: dict) -> SceneSpec:
    """The [scene] section as typed data; optics.scene.build_scene checks it against the
    mirror and builds the Scene."""
    return SceneSpec(
        room_size=sc["room_size"], room_height=sc["room_height"], camera_height=sc["camera_height"],
        room_centre=tuple(sc["room_centre"]), floor_square=sc["floor_square"], wall_square=sc["wall_square"],
        ambient=sc["ambient"], diffuse=sc["diffuse"], light_direction=tuple(sc["light_direction"]),
        floor_colours=tuple(sc["floor_colours"]), x_wall_colours=tuple(sc["x_wall_colours"]),
        y_wall_colours=tuple(sc["y_wall_colours"]), ceiling_colour=tuple(sc["ceiling_colour"]),
        box_colour=tuple(sc["box_colour"]),
        boxes=tuple(BoxSpec(centre=tuple(b["centre"]), size=tuple(b["size"])) for b in sc["boxes"]),
    )


def _render(rc: dict) -> RenderSettings:
    return RenderSettings(supersample=int(rc["supersample"]), surface=parse(Surface, rc["surface"], "render.surface"),
                          nose_radius=float(rc["nose_radius"]))


def _pose(pc: dict) -> CameraPose:
    return CameraPose(decentre=(float(pc["decentre"][0]), float(pc["decentre"][1])),
                      axial_offset=float(pc["axial_offset"]),
                      tilt=tuple(math.radians(float(t)) for t in pc["tilt_deg"]))


def _stereo(sc: dict) -> StereoSettings:
    step = sc["elevation_step_deg"]
    match = MatchParams(block_size=sc["block_size"], uniqueness_ratio=sc["uniqueness_ratio"],
                        speckle_window=sc["speckle_window"], speckle_range=sc["speckle_range"],
                        lr_max_diff=sc["lr_max_diff"], texture_threshold=sc["texture_threshold"],
                        support_px=sc["support_px"], contrast=sc["contrast"])
    params = StereoParams(match=match, min_range=sc["min_range_m"] * 1e3,
                          elevation_step=math.radians(step) if step > 0 else None,
                          n_azimuth=sc["azimuth_px"] or None, equalise=sc["equalise"])
    return StereoSettings(surface=parse(Surface, sc["surface"], "stereo.surface"), supersample=int(sc["supersample"]),
                          params=params, ply_binary=sc["ply_format"] == "binary")


def _tolerance(cfg: dict) -> ToleranceSettings:
    """ToleranceSettings from [tolerance]. (Their bounds against [tool] and [machine] are job.check_programs', where the
    tolerance analysis runs: `toolpath --nose-radius 0` must not trip over them.)"""
    t = cfg["tolerance"]
    programs = tuple(parse(Program, v, f"tolerance.programs[{i}]") for i, v in enumerate(t["programs"]))
    dist = parse(Distribution, t["distribution"], "tolerance.distribution")
    s = t["spec"]
    tol = {key: float(value) for key, value in t["params"].items()}
    check_declared("tolerance.shop", t["shop"])  # a name among the shop classes
    return ToleranceSettings(
        seed=int(t["seed"]), trials=int(t["trials"]), programs=programs, distribution=dist,
        lattice_phases=int(t["lattice_phases"]), azimuths=int(t["azimuths"]),
        bin_px=float(t["bin_px"]), depth_points=int(t["depth_points"]),
        spec=Spec(calibrated=bool(s["calibrated"]),
                  **{k: float(v) for k, v in s.items() if k != "calibrated"}), tolerances=tol,
        seat_pivot_mm=float(t["seat_pivot_mm"]), nose_step_mm=float(t["nose_step_mm"]),
        matching_noise_px=float(t["matching_noise_px"]), target_yield=float(t["target_yield"]),
        cost={k: float(v) for k, v in t["cost"].items()},
        machine_errors={k: float(v) for k, v in t["machine_errors"].items()}, shop=str(t["shop"]))


def _optimize(o: dict) -> OptimizeSettings:
    """The [optimize] section (OptimizeSettings checks the values, naming each key)."""
    pairs = {key: (float(value[0]), float(value[1])) for key, value in o["search"].items()}
    scalars = {k: v for k, v in o.items() if k not in ("objective", "search", "band_deg")}
    return OptimizeSettings(objective=parse(Objective, o["objective"], "optimize.objective"),
                            band_deg=(float(o["band_deg"][0]), float(o["band_deg"][1])),
                            search=SearchSpace(**pairs), **scalars)


def _compute(c: dict) -> ComputeSettings:
    return ComputeSettings(workers=int(c["workers"]), scheduler=str(c["scheduler"]))
