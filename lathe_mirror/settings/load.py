"""Settings from a merged configuration dict: each TOML section turned into its typed
object, every value checked (ranges, choices, the design, the costs).

`config.load()` merges the user's TOML over the embedded defaults and checks every key's
name and type; `from_config` here builds the typed Settings and checks every value. Each
rejection is one InputError line naming the key and what is allowed, and all of it happens
before any command does work or writes a file.
"""

from __future__ import annotations

import math
import re
from typing import Any

from ..body import MAX_LENGTH, BodySpec, CadSettings
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
from ..errors import ConfigError, InputError
from ..finish import Process
from ..lathe import Lathe, Stock, Tool
from ..machine_errors import MachineErrors
from ..optics.camera import CameraPose
from ..optics.ranging.match import MatchParams
from ..optics.ranging.stereo import StereoParams
from ..optics.scene import BoxSpec, SceneSpec, build_scene
from ..optimize.spec import Objective, OptimizeSettings, SearchSpace
from ..polishing import PolishParams
from ..shop import options_from_settings
from ..tolerance.spec import MAX_SAMPLE_RAYS, Spec, ToleranceSettings
from ..toolpath import ToolpathSettings
from .costs import check_costs
from .design_checks import check_design
from .keys import check_ranges
from .model import MAX_SUPERSAMPLE, ComputeSettings, RenderSettings, Settings, StereoSettings

def from_config(cfg: dict[str, Any]) -> Settings:
    """Settings from a merged, key-checked configuration dict (config.load does both).

    The design is built once here, so an impossible design fails before anything else.
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
    mirror = check_design(settings)   # the design's own checks, and a lobe that is no degenerate conic
    build_scene(settings.scene, mirror_top=float(mirror.outer.z(mirror.r_max)), mirror_radius=mirror.r_max)
    check_costs(settings, mirror)     # what the keys cost: estimated, refused above the limits
    return settings


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
    for key in ("rough_depth", "rough_allowance", "clearance", "gouge_tolerance"):
        if not t[key] > 0:
            raise InputError(f"toolpath.{key} = {t[key]!r} mm must be > 0")
    ts = ToolpathSettings(strategy=strategy, gouge_tolerance=float(t["gouge_tolerance"]),
                          max_deviation=float(t["max_deviation"]), rough_depth=float(t["rough_depth"]),
                          rough_allowance=float(t["rough_allowance"]), clearance=float(t["clearance"]),
                          ramp_angle=math.radians(float(t["ramp_angle"])), spring_pass=bool(t["spring_pass"]),
                          coolant=bool(t["coolant"]), home_r=float(t["home_r"]), home_z=float(t["home_z"]),
                          rapid_rate=float(t["rapid_rate"]), path_tolerance_mm=float(t["path_tolerance_mm"]),
                          max_finish_depth_mm=float(t["max_finish_depth_mm"]))
    options_from_settings(ts)  # the program's bounds, checked with everything else
    return ts


def _body(c: dict) -> BodySpec:
    """BodySpec from the [cad] section (validated: the message names the key)."""
    try:
        mount = Mount(c["mount"])
    except ValueError:
        raise ConfigError(
            f"cad.mount = {c['mount']!r}: allowed {', '.join(repr(m.value) for m in Mount)}"
        ) from None
    for key in ("blank_diameter", "thickness", "mount_diameter", "mount_depth", "min_wall"):
        if not 0 < c[key] <= MAX_LENGTH:
            raise ConfigError(f"cad.{key} = {c[key]:g} mm: allowed > 0 and <= {MAX_LENGTH:g} mm")
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
    n = rc["supersample"]
    if not 1 <= n <= MAX_SUPERSAMPLE:
        raise InputError(f"render.supersample = {n}: allowed 1..{MAX_SUPERSAMPLE} (N x N rays per pixel)")
    nose = rc["nose_radius"]
    if not nose >= 0:
        raise InputError(f"render.nose_radius = {nose!r}: must be a finite number >= 0 mm")
    return RenderSettings(supersample=int(n), surface=parse(Surface, rc["surface"], "render.surface"),
                          nose_radius=float(nose))


def _pose(pc: dict) -> CameraPose:
    if len(pc["decentre"]) != 2 or len(pc["tilt_deg"]) != 2:
        raise InputError("camera_pose: decentre and tilt_deg take two numbers each (mm, degrees)")
    if max(abs(t) for t in pc["tilt_deg"]) >= 45:
        raise InputError(f"camera_pose.tilt_deg = {pc['tilt_deg']}: allowed |tilt| < 45 degrees")
    return CameraPose(decentre=(float(pc["decentre"][0]), float(pc["decentre"][1])),
                      axial_offset=float(pc["axial_offset"]),
                      tilt=tuple(math.radians(float(t)) for t in pc["tilt_deg"]))


def _stereo(sc: dict) -> StereoSettings:
    n = sc["supersample"]
    if not 1 <= n <= 4:
        raise InputError(f"stereo.supersample = {n}: allowed 1..4 (N x N rays per pixel)")
    ply = sc["ply_format"]
    if ply not in ("binary", "ascii"):
        raise InputError(f"stereo.ply_format = {ply!r}: allowed 'binary', 'ascii'")
    step = sc["elevation_step_deg"]
    if not 0.0 <= step <= 5.0:
        raise InputError(f"stereo.elevation_step_deg = {step:g}: allowed 0 (the finer lobe's resolution) to 5 deg")
    if not 0 <= sc["azimuth_px"] <= 20000:
        raise InputError(f"stereo.azimuth_px = {sc['azimuth_px']}: allowed 0 (the outer lobe's circumference) to 20000")
    if not 0.05 <= sc["min_range_m"] <= 100.0:
        raise InputError(f"stereo.min_range_m = {sc['min_range_m']:g}: allowed 0.05 to 100 m")
    match = MatchParams(block_size=sc["block_size"], uniqueness_ratio=sc["uniqueness_ratio"],
                        speckle_window=sc["speckle_window"], speckle_range=sc["speckle_range"],
                        lr_max_diff=sc["lr_max_diff"], texture_threshold=sc["texture_threshold"],
                        support_px=sc["support_px"], contrast=sc["contrast"])
    params = StereoParams(match=match, min_range=sc["min_range_m"] * 1e3,
                          elevation_step=math.radians(step) if step > 0 else None,
                          n_azimuth=sc["azimuth_px"] or None, equalise=sc["equalise"])
    return StereoSettings(surface=parse(Surface, sc["surface"], "stereo.surface"), supersample=int(n),
                          params=params, ply_binary=ply == "binary")


def _tolerance(cfg: dict) -> ToleranceSettings:
    """Validated ToleranceSettings from [tolerance]; an InputError names the offending key.
    (Their bounds against [tool] and [machine] are pipeline.check_programs', where the
    tolerance analysis runs: `toolpath --nose-radius 0` must not trip over them.)"""
    t = cfg["tolerance"]
    _int_at_least("tolerance.trials", t["trials"], 1)
    _int_at_least("tolerance.lattice_phases", t["lattice_phases"], 1)
    _int_at_least("tolerance.azimuths", t["azimuths"], 1)
    _int_at_least("tolerance.depth_points", t["depth_points"], 1)
    _int_at_least("tolerance.seed", t["seed"], 0)
    if not (math.isfinite(t["bin_px"]) and 0.05 <= t["bin_px"] <= 50):
        raise InputError(f"tolerance.bin_px = {t['bin_px']!r} must be 0.05 .. 50 px")
    # The sparse pixel sample is image-radius bins x azimuths per lobe: bound its size so a
    # trial's rays fit in memory (the default, 504 / 4 px x 12, is ~1500).
    r_pixel = max((float(lb.get("r_pixel", 0.0)) for lb in cfg.get("lobes", {}).values()), default=504.0)
    rays = t["azimuths"] * r_pixel / t["bin_px"]
    if rays > MAX_SAMPLE_RAYS:
        raise InputError(f"tolerance.azimuths = {t['azimuths']} with tolerance.bin_px = {t['bin_px']:g} px gives "
                         f"{rays:.3g} sample rays per lobe, at most {MAX_SAMPLE_RAYS} allowed: fewer azimuths or "
                         f"wider bins")
    programs = tuple(parse(Program, v, f"tolerance.programs[{i}]") for i, v in enumerate(t["programs"]))
    if not programs:
        raise InputError("tolerance.programs = []: name at least one of \"paper\", \"best\"")
    dist = parse(Distribution, t["distribution"], "tolerance.distribution")
    s = t["spec"]
    for key in ("image_displacement_px", "depth_error_pct", "slope_error_rad", "outlier_pct"):
        if not (math.isfinite(s[key]) and s[key] > 0):
            raise InputError(f"tolerance.spec.{key} = {s[key]!r} must be a finite number > 0")
    if not (math.isfinite(s["depth_range_m"]) and 0.2 <= s["depth_range_m"] <= 100.0):
        raise InputError(f"tolerance.spec.depth_range_m = {s['depth_range_m']!r} must be 0.2 .. 100 m")
    tol = {}
    for key, value in t["params"].items():
        if not (math.isfinite(value) and value >= 0):
            raise InputError(f"tolerance.params.{key} = {value!r} must be a finite number >= 0")
        tol[key] = float(value)
    for key, lo, hi in (("seat_pivot_mm", -1000.0, 1000.0), ("nose_step_mm", 1e-5, 0.01),
                        ("matching_noise_px", 0.0, 10.0), ("target_yield", 0.5, 0.999)):
        if not lo <= t[key] <= hi:
            raise InputError(f"tolerance.{key} = {t[key]!r} must be {lo:g} .. {hi:g}")
    for key, value in t["cost"].items():
        if not value > 0:
            raise InputError(f"tolerance.cost.{key} = {value!r} must be a finite number > 0")
    return ToleranceSettings(
        seed=int(t["seed"]), trials=int(t["trials"]), programs=programs, distribution=dist,
        lattice_phases=int(t["lattice_phases"]), azimuths=int(t["azimuths"]),
        bin_px=float(t["bin_px"]), depth_points=int(t["depth_points"]),
        spec=Spec(calibrated=bool(s["calibrated"]),
                  **{k: float(v) for k, v in s.items() if k != "calibrated"}), tolerances=tol,
        seat_pivot_mm=float(t["seat_pivot_mm"]), nose_step_mm=float(t["nose_step_mm"]),
        matching_noise_px=float(t["matching_noise_px"]), target_yield=float(t["target_yield"]),
        cost={k: float(v) for k, v in t["cost"].items()},
        machine_errors={k: float(v) for k, v in t["machine_errors"].items()})


def _optimize(o: dict) -> OptimizeSettings:
    """The [optimize] section (OptimizeSettings checks the values, naming each key)."""
    pairs = {}
    for key, value in o["search"].items():
        if len(value) != 2:
            raise InputError(f"optimize.search.{key} = {value!r}: give [low, high]")
        pairs[key] = (float(value[0]), float(value[1]))
    if len(o["band_deg"]) != 2:
        raise InputError(f"optimize.band_deg = {o['band_deg']!r}: give [lowest, highest] elevation in deg")
    scalars = {k: v for k, v in o.items() if k not in ("objective", "search", "band_deg")}
    return OptimizeSettings(objective=parse(Objective, o["objective"], "optimize.objective"),
                            band_deg=(float(o["band_deg"][0]), float(o["band_deg"][1])),
                            search=SearchSpace(**pairs), **scalars)


def _compute(c: dict) -> ComputeSettings:
    scheduler = c["scheduler"]
    if scheduler and not re.fullmatch(r"tcp://[A-Za-z0-9._\-\[\]:]+:[0-9]{1,5}", scheduler):
        raise InputError(f"compute.scheduler = {scheduler!r}: allowed \"\" (local processes) or a Dask "
                         "scheduler's address tcp://HOST:PORT")
    return ComputeSettings(workers=int(c["workers"]), scheduler=str(scheduler))


def _int_at_least(key: str, value: int, lo: int) -> None:
    if value < lo:
        raise InputError(f"{key} = {value!r} must be an integer >= {lo}")

