"""Settings: the merged configuration as one frozen, typed object, validated once.

`config.load()` merges the user's TOML over the embedded defaults and checks every key's
name and type (config.py); `from_config` here turns that checked dict into `Settings`, one
typed object per TOML section, and checks every value (ranges, choices, the design itself).
Each rejection is one InputError line naming the key and what is allowed, and all of it
happens before any command does work or writes a file. Below the command layer nothing sees
the dict: every stage takes the typed objects (Camera, Lathe, Tool, PolishParams, ...).

Bounds (issue 14): every key has a documented range (RANGES; README "Ranges of every
key"), and what a key costs where a hard bound would be arbitrary is estimated from the
keys and refused above a limit with the estimate in the message (`check_costs`: render
memory from sensor_px and supersample, Monte Carlo trials x sample rays, polishing steps x
grid points, roughing levels, nose-envelope samples, panorama cells, optimiser designs).
The limits are MEMORY_LIMIT_GIB for any piece of work and TIME_LIMIT_MIN for all of them
together (estimated on the reference machine, 2 cores: benchmarks/bench_bounds.py prints
the estimates beside measured runs); LATHE_MIRROR_MAX_GIB and LATHE_MIRROR_MAX_MINUTES
change them on another machine. A configuration is valid for every command or for none.

Checks that need a planned toolpath or the made surface (the gouge, the stock holding the
mirror, the body holding it, the room holding the camera) stay with the stage that has them.
"""

from __future__ import annotations

import dataclasses
import math
import os
from dataclasses import dataclass, field
from typing import Any

from .body import MAX_LENGTH, BodySpec, CadSettings
from .design import Camera, Lobe, LobeSpec, Mirror, design_lobe, design_mirror, mirror_from_specs
from .enums import (
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
from .errors import ConfigError, DesignError, InputError, num
from .finish import Process
from .lathe import Lathe, Stock, Tool
from .optics.camera import CameraPose
from .optics.ranging.match import MatchParams
from .optics.ranging.stereo import StereoParams
from .optics.scene import BoxSpec, SceneSpec, build_scene
from .optimize.spec import Objective, OptimizeSettings, SearchSpace
from .polishing import PolishParams
from .shop import options_from_settings
from .tolerance.spec import MAX_SAMPLE_RAYS, Spec, ToleranceSettings
from .toolpath import ToolpathSettings

#: Largest supersampling factor of a render (N x N rays per pixel).
MAX_SUPERSAMPLE = 8


@dataclass(frozen=True)
class RenderSettings:
    """The [render] section: supersample N (N x N rays per pixel, N^2 the cost), the made
    surface rendered by default, and the nose radius (mm; > 0: the as-machined surface of
    a tool of that radius along its own program)."""

    supersample: int = 1
    surface: Surface = Surface.PAPER
    nose_radius: float = 0.0


@dataclass(frozen=True)
class StereoSettings:
    """The [stereo] section: the surface ranged by default, the render's supersampling N
    (N x N rays per pixel: the matcher's sub-pixel precision needs anti-aliased edges), how
    an image is ranged (StereoParams), and whether the point cloud is binary PLY."""

    surface: Surface = Surface.EXACT
    supersample: int = 2
    params: StereoParams = field(default_factory=StereoParams)
    ply_binary: bool = True


@dataclass(frozen=True)
class Settings:
    """Every section of a configuration, typed and checked (see the module doc).

    camera, lobes: the design's inputs (pipeline.design builds the Mirror from them).
    machine, tool, stock, toolpath: the lathe, its insert, the bar and the program's knobs.
    body, cad: the mounting body and the CAD export settings. polish: polishing.
    scene, render, pose: the room, how it is rendered, the camera's misalignment.
    stereo: ranging from the image (optics.ranging).
    tolerance: the tolerance analysis (spec, tolerances, Monte Carlo).
    """

    camera: Camera
    lobes: tuple[LobeSpec, LobeSpec]
    machine: Lathe = field(default_factory=Lathe)
    tool: Tool = field(default_factory=Tool)
    stock: Stock = field(default_factory=Stock)
    toolpath: ToolpathSettings = field(default_factory=ToolpathSettings)
    body: BodySpec = field(default_factory=BodySpec)
    cad: CadSettings = field(default_factory=CadSettings)
    polish: PolishParams = field(default_factory=PolishParams)
    scene: SceneSpec | None = None
    render: RenderSettings = field(default_factory=RenderSettings)
    pose: CameraPose = field(default_factory=CameraPose)
    tolerance: ToleranceSettings | None = None
    stereo: StereoSettings = field(default_factory=StereoSettings)
    optimize: OptimizeSettings = field(default_factory=OptimizeSettings)

    def mirror(self) -> Mirror:
        """The designed mirror (design.mirror_from_specs; cheap, the design is closed form)."""
        return mirror_from_specs(self.camera, self.lobes)


def from_config(cfg: dict[str, Any]) -> Settings:
    """Settings from a merged, key-checked configuration dict (config.load does both).

    The design is built once here, so an impossible design fails before anything else.
    """
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
    )
    check_ranges(cfg)                 # every key within its documented range (RANGES)
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
                          rapid_rate=float(t["rapid_rate"]))
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
        cost={k: float(v) for k, v in t["cost"].items()})


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


def _int_at_least(key: str, value: int, lo: int) -> None:
    if value < lo:
        raise InputError(f"{key} = {value!r} must be an integer >= {lo}")


# --------------------------------------------------------------------------------------
# Ranges of every key


@dataclass(frozen=True)
class Range:
    """The values a key allows: a number from lo to hi (either end open or closed), in
    `unit`; for a list, `length` (min, max) entries, each in that range; `choices` for a
    named choice (enums.parse checks those). `why` says where the bound comes from."""

    lo: float | None = None
    hi: float | None = None
    unit: str = ""
    lo_open: bool = False
    hi_open: bool = False
    length: tuple[int, int] | None = None
    choices: str = ""
    why: str = ""

    def allows(self, v: float) -> bool:
        if self.lo is not None and not (v > self.lo if self.lo_open else v >= self.lo):
            return False
        return self.hi is None or (v < self.hi if self.hi_open else v <= self.hi)

    def text(self) -> str:
        """The range as the README and the messages print it: "0.1 to 1000 mm"."""
        if self.choices:
            return self.choices
        u = f" {self.unit}" if self.unit else ""
        if self.lo is not None and self.hi is not None and not (self.lo_open or self.hi_open):
            out = f"{num(self.lo)} to {num(self.hi)}{u}"
        else:
            parts = []
            if self.lo is not None:
                parts.append(f"{'>' if self.lo_open else '>='} {num(self.lo)}")
            if self.hi is not None:
                parts.append(f"{'<' if self.hi_open else '<='} {num(self.hi)}")
            out = " and ".join(parts) + u
        if self.length is not None:
            n0, n1 = self.length
            count = f"{n0}" if n0 == n1 else f"{n0} to {n1}"
            out = f"{count} numbers, each {out}"
        return out


def _r(lo=None, hi=None, unit="", *, lo_open=False, hi_open=False, length=None, why=""):
    return Range(lo, hi, unit, lo_open, hi_open, length, "", why)


def _choice(text: str, why: str = "") -> Range:
    return Range(choices=text, why=why)


#: Longest length a body, a room or a travel may be (mm): sanity bounds, not machine limits.
_KM = 1.0e6
#: Largest rim height above the camera h (mm) a design may have, and the smallest.
H_RANGE = (0.1, 10_000.0)
#: Vertex radius of curvature b^2 / a (mm) a lobe may have: a flatter lobe is a plane,
#: whose "arcs" have centres kilometres away (coordinates no controller word holds); a
#: sharper one is a cone's tip no lattice or nose resolves (and near it the closed form
#: loses the rim to rounding: e = 1e-6 mm).
MIN_VERTEX_RADIUS = 0.01
MAX_VERTEX_RADIUS = 10_000.0
#: Most roughing levels (Z passes) one program may have: ~100 bytes of G-code each.
MAX_ROUGH_LEVELS = 20_000

#: Every key of the configuration and what it allows (README "Ranges of every key" prints
#: this table). `*` stands for each lobe; `boxes[]` for each box. The typed objects check
#: their own invariants too (design, Lathe, Tool, PolishParams, ...); cross-key bounds and
#: costs are check_design's and check_costs'.
RANGES: dict[str, Range] = {
    "camera.f": _r(0.1, 1000.0, "mm", why="focal length"),
    "camera.t_pixel": _r(0.0005, 0.1, "mm", why="pixel pitch"),
    "camera.sensor_px": _r(2, 1_000_000, "px", length=(2, 2),
                           why="width, height; the render's memory estimate bounds the product"),
    "camera.f_number": _r(0.5, 100.0, "", why="the lens's aperture, f / diameter"),
    "lobes.*.r_top": _r(0.1, 1000.0, "mm"),
    "lobes.*.r_pixel": _r(1.0, 32768.0, "px", why="at most half the sensor's smaller side"),
    "lobes.*.alpha_deg": _r(-90.0, 90.0, "deg", lo_open=True, hi_open=True,
                            why="and inside the rim's own range, which the message gives"),
    "lobes.*.a_over_b": _r(0.0, 1000.0, "", lo_open=True, why="below h / R_top, and not degenerate"),
    "lobes.*.e": _r(0.0, H_RANGE[1], "mm", lo_open=True, why="below h, and not degenerate"),
    "machine.resolution": _r(0.0001, 0.1, "mm", why="a multiple of 0.0001 mm: G-code words carry 4 decimals"),
    "machine.max_points": _r(4, 1_000_000, "", why="the nose-envelope estimate bounds it with the nose radius"),
    "machine.diameter_mode": _choice("true or false"),
    "machine.travel_x": _r(0.0, 2000.0, "mm", lo_open=True),
    "machine.travel_z_min": _r(-10_000.0, 0.0, "mm", hi_open=True),
    "machine.travel_z_max": _r(0.0, 10_000.0, "mm", lo_open=True),
    "machine.spindle_max_rpm": _r(1, 99_999, "rev/min", why="a whole number: the cap's word (D, G50 S)"),
    "machine.surface_speed": _r(1.0, 99_999.0, "m/min", why="a whole number: the S word"),
    "machine.feed_rough": _r(0.0001, 500.0, "mm/rev", why="a multiple of 0.0001 mm/rev: the F word"),
    "machine.feed_finish": _r(0.0001, 500.0, "mm/rev", why="a multiple of 0.0001 mm/rev: the F word"),
    "machine.arc_radius_tolerance": _r(0.0, 0.05, "mm", lo_open=True, why="LinuxCNC refuses beyond 0.05 mm"),
    "tool.nose_radius": _r(0.0, 5.0, "mm", why="and small enough for the junction"),
    "tool.included_angle": _r(0.0, 180.0, "deg", lo_open=True, hi_open=True),
    "tool.approach_angle": _r(-90.0, 90.0, "deg", lo_open=True, hi_open=True),
    "stock.diameter": _r(0.0, 4000.0, "mm", lo_open=True, why="and larger than the mirror"),
    "stock.face_allowance": _r(0.0, 100.0, "mm"),
    "stock.length": _r(0.0, 10_000.0, "mm", lo_open=True),
    "toolpath.strategy": _choice("paper, lattice, arcs, best"),
    "toolpath.gouge_tolerance": _r(0.0001, 1.0, "mm"),
    "toolpath.max_deviation": _r(0.0, 10.0, "mm", lo_open=True, why="the point budget must hold it"),
    "toolpath.rough_depth": _r(0.05, 10.0, "mm",
                               why=f"at least machine.resolution, at most {MAX_ROUGH_LEVELS} levels"),
    "toolpath.rough_allowance": _r(0.02, 2.0, "mm",
                                   why="a finishing cut's stock"),
    "toolpath.clearance": _r(0.2, 20.0, "mm"),
    "toolpath.ramp_angle": _r(1.0, 45.0, "deg"),
    "toolpath.spring_pass": _choice("true or false"),
    "toolpath.coolant": _choice("true or false"),
    "toolpath.home_r": _r(0.0, 1000.0, "mm"),
    "toolpath.home_z": _r(0.0, 1000.0, "mm", why="at least the clearance above the stock's face"),
    "toolpath.rapid_rate": _r(100.0, 100_000.0, "mm/min"),
    "cad.blank_diameter": _r(0.0, MAX_LENGTH, "mm", lo_open=True, why="and at least the mirror's diameter"),
    "cad.thickness": _r(0.0, MAX_LENGTH, "mm", lo_open=True, why="the mirror's depth plus min_wall at least"),
    "cad.mount": _choice("bore, boss, none"),
    "cad.mount_diameter": _r(0.0, MAX_LENGTH, "mm", lo_open=True, why="at least 0.01 mm: a STEP feature"),
    "cad.mount_depth": _r(0.0, MAX_LENGTH, "mm", lo_open=True, why="at least 0.01 mm: a STEP feature"),
    "cad.min_wall": _r(0.0, MAX_LENGTH, "mm", lo_open=True, why="at least 0.01 mm: a STEP feature"),
    "cad.step_schema": _choice("AP214, AP242"),
    "cad.product_name": _choice("1 to 80 printable ASCII characters, no quote"),
    "cad.stl_tolerance": _r(0.001, 1.0, "mm", why="the STL estimate bounds it with the mirror's size"),
    "polish.preston_coefficient": _r(1e-16, 1e-9, "1/Pa"),
    "polish.pressure_kpa": _r(0.0, 1000.0, "kPa", lo_open=True),
    "polish.pad_size_mm": _r(0.0, 100.0, "mm", lo_open=True),
    "polish.compliance_mm": _r(0.0, 10.0, "mm", lo_open=True),
    "polish.spindle_rpm": _r(0.0, 10_000.0, "rev/min", lo_open=True),
    "polish.time_s": _r(0.0, 1e6, "s", why="the polishing estimate bounds the steps"),
    "polish.grid_step_mm": _r(0.0005, 0.1, "mm", why="at most pad_size_mm / 8"),
    "polish.curve_max_s": _r(0.0, 1e6, "s", lo_open=True),
    "polish.curve_points": _r(3, 1000, ""),
    "polish.form_degree": _r(0, 12, ""),
    "polish.corner_mm": _r(0.0, 5.0, "mm"),
    "polish.lap": _choice("rotate, stroke, fixed"),
    "polish.lap_rpm": _r(-10_000.0, 10_000.0, "rev/min"),
    "polish.stroke_mm": _r(0.0, 100.0, "mm"),
    "polish.lap_radius_mm": _r(0.0, 100.0, "mm", lo_open=True),
    "polish.overhang": _r(0.0, 1.0, ""),
    "polish.dwell": _choice("uniform, flat"),
    "polish.stroke_points": _r(2, 200, ""),
    "polish.step_edge_mm": _r(0.0, 5.0, "mm"),
    "polish.clear_edge_mm": _r(0.0, 5.0, "mm"),
    "polish.objective": _choice("stereo, image_displacement, slope_error"),
    "polish.objective_range_m": _r(0.2, 100.0, "m"),
    "polish.objective_tolerance": _r(0.0, 1.0, ""),
    "polish.calibration_knot_px": _r(1.0, 10_000.0, "px"),
    "polish.precompensate": _choice("true, false"),
    "polish.wavelength_nm": _r(100.0, 20_000.0, "nm"),
    "polish.process.*": _choice("a table per process: label, program (paper, best), nose_radius_mm, feed_mm, "
                                "resolution_mm (0: the configured one), turned_floor_nm, polish, polished_floor_nm"),
    "scene.room_size": _r(0.0, _KM, "mm", lo_open=True),
    "scene.room_height": _r(0.0, _KM, "mm", lo_open=True),
    "scene.camera_height": _r(0.0, _KM, "mm", lo_open=True, why="the mirror below the ceiling"),
    "scene.room_centre": _r(-_KM, _KM, "mm", length=(2, 2), why="the mirror inside the room"),
    "scene.floor_square": _r(0.0, _KM, "mm", lo_open=True),
    "scene.wall_square": _r(0.0, _KM, "mm", lo_open=True),
    "scene.ambient": _r(0.0, 1.0, ""),
    "scene.diffuse": _r(0.0, 1.0, ""),
    "scene.light_direction": _r(-_KM, _KM, "", length=(3, 3), why="not all zero"),
    "scene.floor_colours": _r(0.0, 1.0, "", length=(6, 6), why="two linear RGB triples"),
    "scene.x_wall_colours": _r(0.0, 1.0, "", length=(6, 6), why="two linear RGB triples"),
    "scene.y_wall_colours": _r(0.0, 1.0, "", length=(6, 6), why="two linear RGB triples"),
    "scene.ceiling_colour": _r(0.0, 1.0, "", length=(3, 3), why="linear RGB"),
    "scene.box_colour": _r(0.0, 1.0, "", length=(3, 3), why="linear RGB"),
    "scene.boxes": Range(length=(0, 100), choices="1 to 100 boxes",
                         why="each ray meets every box: the cost grows with them"),
    "scene.boxes[].centre": _r(-_KM, _KM, "mm", length=(2, 2)),
    "scene.boxes[].size": _r(0.0, _KM, "mm", lo_open=True, length=(3, 3)),
    "render.supersample": _r(1, 8, "", why="N x N rays a pixel; the render estimate bounds it with the sensor"),
    "render.surface": _choice("exact, reference, uniform528, paper, lattice, arcs, best, polished"),
    "render.nose_radius": _r(0.0, 5.0, "mm"),
    "camera_pose.decentre": _r(-1000.0, 1000.0, "mm", length=(2, 2), why="and some pixel must see the mirror"),
    "camera_pose.axial_offset": _r(-1000.0, 1000.0, "mm"),
    "camera_pose.tilt_deg": _r(-45.0, 45.0, "deg", lo_open=True, hi_open=True, length=(2, 2)),
    "tolerance.seed": _r(0, 2**63 - 1, ""),
    "tolerance.trials": _r(1, None, "", why="the Monte Carlo estimate bounds it"),
    "tolerance.programs": Range(length=(1, 2), choices="1 or 2 of paper, best"),
    "tolerance.distribution": _choice("normal, uniform"),
    "tolerance.lattice_phases": _r(1, None, "", why="the tolerance analysis' estimate bounds it"),
    "tolerance.azimuths": _r(1, None, "", why="the Monte Carlo estimate bounds it"),
    "tolerance.bin_px": _r(0.05, 50.0, "px"),
    "tolerance.depth_points": _r(1, 1000, "", why="elevations across the common band: finer than a pixel"),
    "tolerance.nose_step_mm": _r(1e-5, 0.01, "mm", why="the analysis' estimate bounds it with the nose tolerance"),
    "tolerance.seat_pivot_mm": _r(-1000.0, 1000.0, "mm"),
    "tolerance.matching_noise_px": _r(0.0, 10.0, "px"),
    "tolerance.target_yield": _r(0.5, 0.999, ""),
    "tolerance.spec.calibrated": _choice("true or false"),
    "tolerance.spec.outlier_pct": _r(0.0, 100.0, "%", lo_open=True),
    "tolerance.spec.image_displacement_px": _r(0.0, 10_000.0, "px", lo_open=True),
    "tolerance.spec.depth_error_pct": _r(0.0, 100.0, "%", lo_open=True),
    "tolerance.spec.depth_range_m": _r(0.2, 100.0, "m"),
    "tolerance.spec.slope_error_rad": _r(0.0, math.pi / 2, "rad", lo_open=True),
    "tolerance.params.resolution_mm": _r(0.0, 0.1, "mm", why="below machine.resolution"),
    "tolerance.params.nose_radius_mm": _r(0.0, 5.0, "mm", why="at most tool.nose_radius"),
    "tolerance.params.tool_x_mm": _r(0.0, 1.0, "mm"),
    "tolerance.params.tool_z_mm": _r(0.0, 1.0, "mm"),
    "tolerance.params.polish_time_s": _r(0.0, 1e6, "s"),
    "tolerance.params.camera_decentre_mm": _r(0.0, 100.0, "mm", why="each lobe keeps half its pixels"),
    "tolerance.params.camera_tilt_deg": _r(0.0, 45.0, "deg", hi_open=True, why="each lobe keeps half its pixels"),
    "tolerance.params.camera_axial_mm": _r(0.0, 1000.0, "mm", why="each lobe keeps half its pixels"),
    "tolerance.params.seat_tilt_deg": _r(0.0, 45.0, "deg", hi_open=True),
    "tolerance.cost.*": _r(0.0, 1e6, "", lo_open=True, why="relative cost of holding each tolerance"),
    "stereo.surface": _choice("any render.surface name"),
    "stereo.supersample": _r(1, 4, "", why="the render estimate bounds it with the sensor"),
    "stereo.min_range_m": _r(0.05, 100.0, "m", why="its disparity search at most 256 px"),
    "stereo.elevation_step_deg": _r(0.0, 5.0, "deg", why="0: automatic; the panorama estimate bounds it"),
    "stereo.azimuth_px": _r(0, 20_000, "px", why="0: automatic; the panorama estimate bounds it"),
    "stereo.block_size": _r(1, 31, "px", why="odd"),
    "stereo.uniqueness_ratio": _r(0, 100, "%"),
    "stereo.speckle_window": _r(0, 10_000, "px"),
    "stereo.speckle_range": _r(0, 64, "px"),
    "stereo.lr_max_diff": _r(0.0, 16.0, "px", lo_open=True),
    "stereo.texture_threshold": _r(0.0, 255.0, ""),
    "stereo.support_px": _r(0, 100_000, "px"),
    "stereo.contrast": _r(0.0, 1.0, "", lo_open=True),
    "stereo.equalise": _choice("true or false"),
    "stereo.ply_format": _choice("binary, ascii"),
    "optimize.objective": _choice("r10, baseline, band_width, usable_area"),
    "optimize.seed": _r(0, 2**32 - 1, ""),
    "optimize.workers": _r(1, 64, ""),
    "optimize.popsize": _r(5, 100, "", why="the optimiser's estimate bounds it with maxiter"),
    "optimize.maxiter": _r(1, 5000, "", why="the optimiser's estimate bounds it with popsize"),
    "optimize.tol": _r(0.0, 1.0, "", lo_open=True, hi_open=True),
    "optimize.r_max_mm": _r(0.0, 10_000.0, "mm", lo_open=True),
    "optimize.vertex_min_mm": _r(0.0, 10_000.0, "mm", lo_open=True),
    "optimize.rim_max_mm": _r(0.0, 10_000.0, "mm", lo_open=True, why="above vertex_min_mm"),
    "optimize.band_deg": _r(-90.0, 90.0, "deg", length=(2, 2), why="lowest < highest"),
    "optimize.band_width_min_deg": _r(0.0, 180.0, "deg", hi_open=True),
    "optimize.rim_margin_px": _r(0.0, 100_000.0, "px"),
    "optimize.usable_min": _r(0.0, 1.0, ""),
    "optimize.blur_max_px": _r(0.0, 100_000.0, "px", lo_open=True),
    "optimize.focus_range_m": _r(0.05, 1e6, "m"),
    "optimize.search.outer_r_top_fraction": _r(0.0, 1.0, "", lo_open=True, length=(2, 2), why="low <= high"),
    "optimize.search.junction_fraction": _r(0.0, 1.0, "", lo_open=True, hi_open=True, length=(2, 2),
                                            why="low <= high"),
    "optimize.search.outer_r_pixel_fraction": _r(0.0, 1.0, "", lo_open=True, length=(2, 2), why="low <= high"),
    "optimize.search.pixel_fraction": _r(0.0, 1.0, "", lo_open=True, hi_open=True, length=(2, 2),
                                         why="low <= high"),
    "optimize.search.alpha_inner_deg": _r(-89.0, 89.0, "deg", length=(2, 2), why="low <= high"),
    "optimize.search.alpha_outer_deg": _r(-89.0, 89.0, "deg", length=(2, 2), why="low <= high"),
}


def check_ranges(cfg: dict[str, Any]) -> None:
    """InputError (one line: the key, its value, the allowed range) for the first value of
    the merged configuration outside RANGES."""
    for pattern, rng in RANGES.items():
        for key, value in _find(cfg, pattern.split("."), ""):
            if isinstance(value, list):
                if rng.length is not None and not rng.length[0] <= len(value) <= rng.length[1]:
                    n0, n1 = rng.length
                    count = f"{n0}" if n0 == n1 else f"{n0} to {n1}"
                    raise InputError(f"{key} has {len(value)} entries: allowed {count}"
                                     + (f" ({rng.why})" if rng.why else ""))
                items = [(f"{key}[{i}]", v) for i, v in enumerate(value)]
            else:
                items = [(key, value)]
            for where, v in items:
                if rng.choices or isinstance(v, (bool, str, dict)) or not isinstance(v, (int, float)):
                    continue  # named choices: enums.parse; tables: checked entry by entry
                if not rng.allows(v):
                    u = f" {rng.unit}" if rng.unit else ""
                    rng1 = dataclasses.replace(rng, length=None)
                    raise InputError(f"{where} = {num(v)}{u}: allowed {rng1.text()}"
                                     + (f" ({rng.why})" if rng.why else ""))


def _find(node: Any, parts: list[str], prefix: str):
    """(dotted key, value) of every entry of the config that a RANGES pattern names."""
    if not parts:
        yield prefix.rstrip("."), node
        return
    head, rest = parts[0], parts[1:]
    if not isinstance(node, dict):
        return
    if head == "*":
        for k in node:
            yield from _find(node[k], rest, f"{prefix}{k}.")
    elif head.endswith("[]"):
        name = head[:-2]
        for i, item in enumerate(node.get(name, []) or []):
            yield from _find(item, rest, f"{prefix}{name}[{i}].")
    elif head in node:
        yield from _find(node[head], rest, f"{prefix}{head}.")


# --------------------------------------------------------------------------------------
# The design: a lobe that is a hyperbola, not a degenerate conic


def check_design(settings: Settings) -> Mirror:
    """The designed mirror (Settings.mirror()), each lobe checked first: its rim height h
    (Eq. 6) within H_RANGE, and its given parameter (alpha_deg, a_over_b or e) where the
    lobe is a proper hyperbola: a DesignError names the parameter's allowed range. A
    mirror whose lobes share no stereo band (Mirror.common_band empty) is refused too."""
    camera = settings.camera
    lobes = [_checked_lobe(camera, spec) for spec in settings.lobes]
    mirror = design_mirror(camera, *lobes)
    lo, hi = mirror.common_band
    if not lo < hi:  # a stereo camera whose lobes see no elevation in common
        (_, top), (bottom, _) = mirror.fov_usable(mirror.inner), mirror.fov_usable(mirror.outer)
        raise DesignError(
            f"lobes: no common stereo band: the inner lobe sees up to {math.degrees(top):.3f} deg elevation "
            f"(lobes.inner.alpha_deg, less the step wall), the outer lobe from {math.degrees(bottom):.3f} deg "
            f"(up to lobes.outer.alpha_deg): raise lobes.inner.alpha_deg")
    return mirror


def _checked_lobe(camera: Camera, spec: LobeSpec) -> Lobe:
    key = f"lobes.{spec.name}"
    given = [(k, v) for k, v in (("alpha_deg", spec.alpha_deg), ("a_over_b", spec.a_over_b), ("e", spec.e))
             if v is not None]
    if len(given) != 1 or not (spec.r_top > 0 and spec.r_pixel > 0):
        return _design(camera, spec)  # its own message (exactly one of ...; r_top > 0)
    h = camera.f * spec.r_top / (camera.t_pixel * spec.r_pixel)  # Eq. 6
    if not H_RANGE[0] <= h <= H_RANGE[1]:
        raise DesignError(
            f"{key}: the rim height h = f R_top / (T_pixel R_pixel) = {num(h)} mm (Eq. 6, from camera.f, "
            f"{key}.r_top, camera.t_pixel, {key}.r_pixel): allowed {num(H_RANGE[0])} to {num(H_RANGE[1])} mm")
    param, value = given[0]
    lo, hi = _parameter_bounds(param, h, spec.r_top)
    if not lo < value < hi:
        return _design(camera, spec)  # outside the conic's own range: design_lobe says so
    lobe = _proper(camera, spec, param, value)
    if lobe is not None:
        return lobe
    good_lo, good_hi = _proper_interval(camera, spec, param, lo, hi)
    unit = {"alpha_deg": " deg", "a_over_b": "", "e": " mm"}[param]
    raise DesignError(
        f"{key}.{param} = {num(value)}{unit}: allowed {_round_in(good_lo, up=True)} to "
        f"{_round_in(good_hi, up=False)}{unit} for this rim (R_top = {num(spec.r_top)} mm, h = {num(h)} mm); "
        f"beyond that the lobe degenerates: its vertex radius of curvature b^2/a leaves "
        f"{num(MIN_VERTEX_RADIUS)} to {num(MAX_VERTEX_RADIUS)} mm (a cone's tip, a plane)")


def _design(camera: Camera, spec: LobeSpec) -> Lobe:
    return design_lobe(spec.name, camera, spec.r_top, spec.r_pixel,
                       alpha_deg=spec.alpha_deg, a_over_b=spec.a_over_b, e=spec.e)


def _parameter_bounds(param: str, h: float, r_top: float) -> tuple[float, float]:
    """The open interval of the parameter over which the conic through the rim exists."""
    if param == "alpha_deg":
        limit = math.degrees(math.atan(h / r_top))
        return -limit, limit
    if param == "a_over_b":
        return 0.0, h / r_top
    return 0.0, h


def _proper(camera: Camera, spec: LobeSpec, param: str, value: float) -> Lobe | None:
    """The lobe with `param` = value, or None if it is degenerate (see check_design)."""
    choice = {"alpha_deg": None, "a_over_b": None, "e": None, param: float(value)}
    trial = dataclasses.replace(spec, **choice)
    try:
        lobe = _design(camera, trial)
    except (DesignError, ValueError, ArithmeticError):
        return None
    ok = (lobe.a > 0 and lobe.b > 0 and math.isfinite(lobe.b)
          and MIN_VERTEX_RADIUS <= lobe.b * lobe.b / lobe.a <= MAX_VERTEX_RADIUS)
    return lobe if ok else None


def _proper_interval(camera: Camera, spec: LobeSpec, param: str, lo: float, hi: float) -> tuple[float, float]:
    """Where the parameter gives a proper lobe: bisection from the middle of the conic's
    range (alpha = 0: F1 at half the rim height) toward each end (~120 closed-form designs)."""
    mid = {"alpha_deg": 0.0, "e": 0.5 * (lo + hi)}.get(param)
    if mid is None:  # a_over_b at alpha = 0
        half = _proper(camera, spec, "alpha_deg", 0.0)
        mid = half.a_over_b if half is not None else 0.5 * (lo + hi)
    if _proper(camera, spec, param, mid) is None:
        return lo, hi

    def edge(bad: float, good: float) -> float:
        for _ in range(64):
            m = 0.5 * (bad + good)
            if _proper(camera, spec, param, m) is None:
                bad = m
            else:
                good = m
        return good

    return edge(lo, mid), edge(hi, mid)


def _round_in(x: float, *, up: bool) -> str:
    """x to 4 significant digits, rounded toward the inside of an allowed interval."""
    if x == 0 or not math.isfinite(x):
        return num(x)
    scale = 10 ** (math.floor(math.log10(abs(x))) - 3)
    q = (math.ceil if up else math.floor)(x / scale) * scale
    return num(float(f"{q:.4g}"))


# --------------------------------------------------------------------------------------
# What the keys cost


#: Limits the estimates are held to: each piece of work's peak memory (GiB), and the time
#: of all of them together (minutes, estimated for the reference machine, 2 cores: what
#: `run`, which does every piece, would take). Environment variables LATHE_MIRROR_MAX_GIB
#: and LATHE_MIRROR_MAX_MINUTES raise (or lower) them on another machine.
MEMORY_LIMIT_GIB = 8.0
TIME_LIMIT_MIN = 10.0

# Cost constants, measured on the reference machine (benchmarks/bench_bounds.py prints
# each estimate beside the measured run). Bytes are peak resident memory.
_BASE_BYTES = 160 * 2**20         # the interpreter, numpy and the stage's modules
_RENDER_PX_BYTES = 190.0          # a pixel of the render (its image and distortion maps)
_RENDER_SAMPLE_BYTES = 60.0       # each further supersample of a pixel
_RENDER_PX_S = 0.66e-6            # render: per pixel, plus per sample below
_RENDER_SAMPLE_S = 0.68e-6
_REPORT_S = 8.0                   # report/run without the tolerance analysis: 8 s, plus a pixel's
_REPORT_PX_S = 3.7e-6             # four images and distortion maps
_MC_TRIAL_S = 4.5e-4              # Monte Carlo: per trial and program, plus per ray below
_MC_RAY_S = 1.6e-6                # per sample ray (both lobes)
_MC_DEPTH_RAY_S = 1.9e-6          # per depth ray (two lobes x 4 azimuths x depth_points)
_TIME_NODES = 9                   # polishing snapshots of each surface of the tolerance analysis
_MC_TRIAL_BYTES = 3000.0          # a trial's parameters, figures and JSON, per program
_POLISH_S = 3.0                   # polishing: the curves' optics, plus per grid point and time step
_POLISH_STEP_S = 1.5e-7
_POLISH_POINT_BYTES = 32.0        # a polished snapshot, per grid point
_ENVELOPE_S = 0.37e-6             # a nose-envelope sample (vertex disc), one envelope
_ENVELOPE_USES = 7                # envelopes `toolpath` computes (as machined, gouge, fillet, G-code header)
_ENVELOPE_BYTES = 62.0
_PANORAMA_CELL_S = 2.5e-6        # ranging: a panorama cell's render, match and triangulation
_PANORAMA_CELL_BYTES = 210.0
MIRRORS_RANGED = ("exact", "paper", "best", "polished")  # the report ranges each
_DESIGN_S = 1.0e-3                # the optimiser: one design's figures and constraints
_STL_TRIANGLES = 26_000.0         # triangles of the paper mirror's STL at 0.01 mm (r_max 35 mm)
_STL_TRIANGLE_S = 1.5e-5
_STL_TRIANGLE_BYTES = 1000.0      # OCC's mesh and the STL's bytes


@dataclass(frozen=True)
class Cost:
    """An estimate of one piece of work: what it is, the keys that set it (with their
    values), its time (s, reference machine) and peak memory (bytes), and the remedy."""

    work: str
    keys: str
    seconds: float
    bytes: float
    advice: str
    alone: bool = False  # a command of its own (optimize), not part of `run`: its time alone counts


def limits() -> tuple[float, float]:
    """(memory bytes, seconds) every estimate must stay within (see MEMORY_LIMIT_GIB)."""
    out = []
    for var, default, scale in (("LATHE_MIRROR_MAX_GIB", MEMORY_LIMIT_GIB, 2.0**30),
                                ("LATHE_MIRROR_MAX_MINUTES", TIME_LIMIT_MIN, 60.0)):
        text = os.environ.get(var, "")
        try:
            value = float(text) if text else default
        except ValueError:
            value = math.nan
        if not (math.isfinite(value) and value > 0):
            raise InputError(f"environment {var} = {text!r}: allowed a number > 0")
        out.append(value * scale)
    return out[0], out[1]


def check_costs(settings: Settings, mirror: Mirror) -> None:
    """Refuse (one InputError line with the estimate) keys whose work cannot end in the
    limits, before any command starts it: the roughing program's levels, the polishing's
    time steps, each piece of work's estimated memory and time (estimate_costs), and
    assembly tolerances under which a lobe no longer sees its pixels."""
    _check_roughing(settings, mirror)
    params = settings.polish
    tol = settings.tolerance.tolerances if settings.tolerance else {}
    params.check_time(mirror.r_max, max(params.time_s, params.curve_max_s) + tol.get("polish_time_s", 0.0))
    memory, seconds = limits()
    costs = estimate_costs(settings, mirror)
    for c in costs:
        if c.bytes > memory:
            raise InputError(f"{c.keys}: {c.work} needs about {_bytes(c.bytes)} of memory, limit "
                             f"{_bytes(memory)} (LATHE_MIRROR_MAX_GIB); {c.advice}")
    # Time adds up: `run` does every piece of work, so their sum is what a command can take.
    in_run = [c for c in costs if not c.alone]
    total = sum(c.seconds for c in in_run)
    for c in costs:
        if c.alone and c.seconds > seconds:
            raise InputError(f"{c.keys}: {c.work} takes about {_duration(c.seconds)} (estimate, 2 cores), "
                             f"limit {_duration(seconds)} (LATHE_MIRROR_MAX_MINUTES); {c.advice}")
    if total > seconds:
        c = max(in_run, key=lambda c: c.seconds)
        raise InputError(f"{c.keys}: {c.work} takes about {_duration(c.seconds)} (estimate, 2 cores; "
                         f"{_duration(total)} with the other stages), limit {_duration(seconds)} "
                         f"(LATHE_MIRROR_MAX_MINUTES); {c.advice}")
    if settings.tolerance is not None:
        check_assembly_tolerances(mirror, tol)


def estimate_costs(settings: Settings, mirror: Mirror) -> list[Cost]:
    """The estimated time and memory of the work the keys set (see Cost; constants above)."""
    from .nose_envelope import GRID

    costs = []
    cam, rs, st = settings.camera, settings.render, settings.stereo
    px = float(cam.sensor_px[0]) * float(cam.sensor_px[1])
    # stereo renders the common band's pixels only (image_mask): at most about half the sensor
    n2 = max(float(rs.supersample) ** 2, 1.0 + 0.5 * (float(st.supersample) ** 2 - 1.0))
    which, n = (("render.supersample", rs.supersample) if rs.supersample ** 2 >= n2 else
                ("stereo.supersample", st.supersample))
    costs.append(Cost(
        "rendering", f"camera.sensor_px = {list(cam.sensor_px)} with {which} = {n}",
        max(5.0 + px * (_RENDER_PX_S + _RENDER_SAMPLE_S * n2), _REPORT_S + px * _REPORT_PX_S),
        _BASE_BYTES + px * (_RENDER_PX_BYTES + _RENDER_SAMPLE_BYTES * (n2 - 1.0)),
        "a smaller sensor or supersample"))

    # Ranging: each of the report's four mirrors matched on the common band's panoramas.
    from .optics.ranging.rectify import make_grid

    grid = make_grid(mirror, elevation_step=st.params.elevation_step, n_azimuth=st.params.n_azimuth)
    cells = float(grid.n_elevation) * float(grid.n_azimuth)
    costs.append(Cost(
        "ranging", f"a panorama of {grid.n_elevation} x {grid.n_azimuth} px (stereo.elevation_step_deg, "
        f"stereo.azimuth_px)", len(MIRRORS_RANGED) * cells * _PANORAMA_CELL_S,
        _BASE_BYTES + cells * _PANORAMA_CELL_BYTES, "a coarser stereo.elevation_step_deg or fewer azimuth_px"))

    # The optimiser: popsize x 6 designs a generation, at most maxiter + 1 generations.
    op = settings.optimize
    designs = float(op.popsize) * 6.0 * (op.maxiter + 1)
    costs.append(Cost(
        "the optimiser", f"optimize.popsize = {op.popsize} x 6 parameters x (optimize.maxiter = {op.maxiter} + 1) "
        f"designs over {min(op.workers, os.cpu_count() or 1)} worker(s)",
        designs * _DESIGN_S / max(1, min(op.workers, os.cpu_count() or 1)), _BASE_BYTES,
        "a smaller popsize or maxiter (or more workers on more cores)", alone=True))

    # The made surfaces: the nose envelope samples each programmed vertex's disc.
    ts = settings.tolerance
    tol = ts.tolerances if ts else {}
    rho = max(settings.tool.nose_radius + tol.get("nose_radius_mm", 0.0), rs.nose_radius)
    vertices = float(settings.machine.max_points)
    samples = vertices * (1.0 + 2.0 * rho / GRID) + mirror.r_max / GRID
    costs.append(Cost(
        "the as-machined surface (nose envelope)",
        f"machine.max_points = {settings.machine.max_points} with a nose radius of {num(rho)} mm",
        samples * _ENVELOPE_S * _ENVELOPE_USES, _BASE_BYTES + samples * _ENVELOPE_BYTES,
        "fewer points (machine.max_points) or a smaller nose"))
    machining_s = 0.05 + samples * _ENVELOPE_S  # one made surface: plan and cut

    # Polishing: the curve of both programs (report), each of its snapshots kept.
    pp = settings.polish
    grid = mirror.r_max / pp.grid_step_mm + 2.0
    steps = pp.time_steps(mirror.r_max, max(pp.time_s, pp.curve_max_s))
    costs.append(Cost(
        "polishing", f"polish.grid_step_mm = {num(pp.grid_step_mm)} mm over r_max = {num(mirror.r_max)} mm "
        f"({grid:.3g} points) x {steps:.3g} time steps, polish.curve_points = {pp.curve_points}",
        _POLISH_S + 2.0 * steps * grid * _POLISH_STEP_S,
        _BASE_BYTES + 2.0 * pp.curve_points * grid * _POLISH_POINT_BYTES,
        "a coarser polish.grid_step_mm, fewer curve_points or a shorter curve_max_s"))

    if ts is not None:
        from .tolerance.perturb import DEPTH_AZIMUTHS

        programs = len(ts.programs)
        # report allocates the best program's tolerances: its scans and confirming run cost
        # about two more runs (measured: 729 s against 339 s for `tolerance` at 55276 trials)
        runs = programs + (2 if Program.BEST in ts.programs else 0)
        rays = ts.azimuths * mirror.outer.r_pixel / ts.bin_px
        depth_rays = 2.0 * DEPTH_AZIMUTHS * ts.depth_points
        per_trial = _MC_TRIAL_S + _MC_RAY_S * rays + _MC_DEPTH_RAY_S * depth_rays
        costs.append(Cost(
            "the Monte Carlo",
            f"tolerance.trials = {ts.trials} x {runs} runs ({programs} programs, the best's allocation) x "
            f"({rays:.3g} sample rays (tolerance.azimuths, bin_px) + {depth_rays:.3g} depth rays "
            f"(tolerance.depth_points))",
            runs * ts.trials * per_trial, _BASE_BYTES + runs * ts.trials * _MC_TRIAL_BYTES,
            "fewer trials, azimuths or depth_points, or wider bin_px"))
        # Each lattice phase cut with the programmed nose, and each distinct nose the trials
        # draw (rounded to nose_step_mm; a normal draw stays within about -/+ 1.5 tolerances).
        dn = tol.get("nose_radius_mm", 0.0)
        span = 1.5 * dn + min(1.5 * dn, settings.tool.nose_radius)  # a drawn nose is at least 0
        noses = min(float(ts.trials), span / ts.nose_step_mm + 1.0)
        surfaces = ts.lattice_phases + noses
        node_steps = pp.time_steps(mirror.r_max, pp.curve_max_s + tol.get("polish_time_s", 0.0))
        per_surface = machining_s + node_steps * grid * _POLISH_STEP_S
        costs.append(Cost(
            "the tolerance analysis' machined and polished surfaces",
            f"(tolerance.lattice_phases = {ts.lattice_phases} + {noses:.3g} noses (tolerance.params.nose_radius_mm "
            f"/ tolerance.nose_step_mm)) x {programs} programs",
            programs * surfaces * per_surface,
            _BASE_BYTES + surfaces * _TIME_NODES * grid * 16.0,
            "fewer lattice_phases, a coarser nose_step_mm or polish.grid_step_mm"))

    tri = _STL_TRIANGLES * (0.01 / settings.cad.stl_tolerance) * (mirror.r_max / 35.0)
    costs.append(Cost(
        "the STL mesh", f"cad.stl_tolerance = {num(settings.cad.stl_tolerance)} mm on a mirror of r_max = "
        f"{num(mirror.r_max)} mm ({tri:.3g} triangles)",
        1.0 + tri * _STL_TRIANGLE_S, _BASE_BYTES + tri * _STL_TRIANGLE_BYTES, "a larger cad.stl_tolerance"))
    return costs


def _check_roughing(settings: Settings, mirror: Mirror) -> None:
    """The roughing program's levels (shop.roughing plans them): a level finer than the
    lattice repeats the one before, and MAX_ROUGH_LEVELS bounds the program."""
    tp, res = settings.toolpath, settings.machine.resolution
    if tp.rough_depth < res:
        raise InputError(f"toolpath.rough_depth = {num(tp.rough_depth)} mm: allowed >= machine.resolution = "
                         f"{num(res)} mm (levels are on the lattice; a finer one repeats the one before)")
    depth = float(mirror.outer.z(mirror.r_max)) - mirror.vertex_z
    height = settings.stock.face_allowance + depth
    levels = height / tp.rough_depth
    if levels > MAX_ROUGH_LEVELS:
        raise InputError(
            f"toolpath.rough_depth = {num(tp.rough_depth)} mm gives {levels:.3g} roughing levels from the stock's "
            f"face ({num(settings.stock.face_allowance)} mm above the vertex) to the rim ({depth:.3f} mm below), "
            f"about {_bytes(100.0 * levels)} of G-code; allowed at most {MAX_ROUGH_LEVELS} levels "
            f"(rough_depth >= {_round_up(height / MAX_ROUGH_LEVELS)} mm here)")


def check_assembly_tolerances(mirror: Mirror, tolerances: dict[str, float]) -> None:
    """The camera's assembly tolerances (tolerance.params.camera_*) must leave each lobe
    at least MIN_SEEN of its pixels: beyond that the sample no longer sees the lobe and its
    figures (RMS over the pixels still seen) mean nothing. Traces ~400 pixels per lobe off
    the exact mirror with the camera at each tolerance alone, as the sensitivity table
    moves it; a refusal names the largest tolerance that passes."""
    for key in ("camera_tilt_deg", "camera_decentre_mm", "camera_axial_mm"):
        t = tolerances.get(key, 0.0)
        if t <= 0:
            continue
        seen = _seen_fraction(mirror, key, t)
        if seen >= MIN_SEEN:
            continue
        lo, hi = 0.0, t
        for _ in range(14):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if _seen_fraction(mirror, key, mid) >= MIN_SEEN else (lo, mid)
        unit = "deg" if key.endswith("deg") else "mm"
        raise InputError(
            f"tolerance.params.{key} = {num(t)} {unit}: a camera that far off sees only "
            f"{100.0 * seen:.0f} % of a lobe's pixels on that lobe (its figures would mean nothing); allowed "
            f"while each lobe keeps {100 * MIN_SEEN:.0f} %: up to about {_round_in(lo, up=False)} {unit} here")


#: Share of each lobe's pixels a camera moved by an assembly tolerance must still see on
#: that lobe (check_assembly_tolerances).
MIN_SEEN = 0.5


def _seen_fraction(mirror: Mirror, key: str, t: float) -> float:
    """Smallest share (both lobes, both signs of an axial offset) of the lobe's sample
    pixels that still see that lobe with the camera moved by t along `key`."""
    import numpy as np

    from .optics.trace import trace_pixels
    from .profile import ExactProfile

    radii = mirror.image_radii_px
    if key == "camera_tilt_deg":
        poses = [CameraPose(tilt=(math.radians(t), 0.0))]
    elif key == "camera_decentre_mm":
        poses = [CameraPose(decentre=(t, 0.0))]
    else:
        poses = [CameraPose(axial_offset=t), CameraPose(axial_offset=-t)]
    profile = ExactProfile(mirror)
    psi = (np.arange(24) + 0.5) * (2.0 * math.pi / 24)
    worst = 1.0
    for k, (lo, hi) in enumerate((radii["inner_disc"], radii["outer_annulus"])):
        rho = lo + (hi - lo) * (np.arange(16) + 0.5) / 16
        r, a = np.meshgrid(rho, psi, indexing="ij")
        xy = np.stack([r * np.cos(a), r * np.sin(a)], axis=-1).reshape(-1, 2)
        for pose in poses:
            hits = trace_pixels(profile, mirror.camera, xy, pose=pose)
            worst = min(worst, float(np.mean(hits.fate == k)))
    return worst


def _bytes(b: float) -> str:
    for unit, scale in (("TiB", 2.0**40), ("GiB", 2.0**30), ("MiB", 2.0**20), ("KiB", 2.0**10)):
        if b >= scale:
            return f"{b / scale:.3g} {unit}"
    return f"{b:.0f} bytes"


def _duration(s: float) -> str:
    for unit, scale in (("days", 86400.0), ("h", 3600.0), ("min", 60.0)):
        if s >= scale:
            return f"{s / scale:.3g} {unit}"
    return f"{s:.3g} s"


def _round_up(x: float) -> str:
    return _round_in(x, up=True)
