"""Every configuration key and what it allows (README "Ranges of every key").

RANGES maps each dotted key (`*` for each entry of a table, `[]` for each item of a list
of tables) to its Range; check_ranges holds a merged configuration dict to it. The typed
objects check their own invariants too; cross-key bounds and costs are
design_checks' and costs'.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any

from ..body import MAX_LENGTH
from ..errors import InputError, num


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
    "machine.errors.centre_height_mm": _r(-1.0, 1.0, "mm", why="a set-up error: above the axis > 0"),
    "machine.errors.x_offset_mm": _r(-1.0, 1.0, "mm", why="a set-up error"),
    "machine.errors.nose_radius_error_mm": _r(-1.0, 1.0, "mm", why="a set-up error"),
    "machine.errors.squareness_urad": _r(-10_000.0, 10_000.0, "urad", why="a set-up error: 10 mm per m"),
    "machine.errors.backlash_mm": _r(0.0, 1.0, "mm", why="a set-up error"),
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
    "toolpath.path_tolerance_mm": _r(0.0, 0.1, "mm", lo_open=True, why="LinuxCNC's G64 P"),
    "toolpath.max_finish_depth_mm": _r(0.0, 2.0, "mm", lo_open=True, why="one finishing pass"),
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
    "tolerance.machine_errors.centre_height_mm": _r(0.0, 1.0, "mm"),
    "tolerance.machine_errors.x_offset_mm": _r(0.0, 1.0, "mm"),
    "tolerance.machine_errors.nose_radius_error_mm": _r(0.0, 1.0, "mm"),
    "tolerance.machine_errors.squareness_urad": _r(0.0, 10_000.0, "urad"),
    "tolerance.machine_errors.backlash_mm": _r(0.0, 1.0, "mm"),
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
    "optimize.max_diameter_mm": _r(0.0, 20_000.0, "mm", why="0: optimize.r_max_mm holds"),
    "optimize.max_depth_mm": _r(0.0, 10_000.0, "mm", why="0: optimize.rim_max_mm holds"),
    "optimize.blur_limit_um": _r(0.0, 100_000.0, "um", why="0: optimize.blur_max_px holds"),
    "optimize.bound_margin": _r(0.0, 0.25, "", why="of each searched parameter's span"),
    "optimize.search.outer_r_top_fraction": _r(0.0, 1.0, "", lo_open=True, length=(2, 2), why="low <= high"),
    "optimize.search.junction_fraction": _r(0.0, 1.0, "", lo_open=True, hi_open=True, length=(2, 2),
                                            why="low <= high"),
    "optimize.search.outer_r_pixel_fraction": _r(0.0, 1.0, "", lo_open=True, length=(2, 2), why="low <= high"),
    "optimize.search.pixel_fraction": _r(0.0, 1.0, "", lo_open=True, hi_open=True, length=(2, 2),
                                         why="low <= high"),
    "optimize.search.alpha_inner_deg": _r(-89.0, 89.0, "deg", length=(2, 2), why="low <= high"),
    "optimize.search.alpha_outer_deg": _r(-89.0, 89.0, "deg", length=(2, 2), why="low <= high"),
    "compute.workers": _r(0, 1024, "", why="0: all cores"),
    "compute.scheduler": _choice('"" (local processes) or tcp://HOST:PORT (a Dask scheduler)'),
}


def check_ranges(cfg: dict[str, Any]) -> None:
    """InputError (one line: the key, its value, the allowed range) for the first value of
    the merged configuration outside RANGES."""
    for pattern, rng in RANGES.items():
        for key, value in find(cfg, pattern.split("."), ""):
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


def find(node: Any, parts: list[str], prefix: str):
    """(dotted key, value) of every entry of the config that a RANGES pattern names."""
    if not parts:
        yield prefix.rstrip("."), node
        return
    head, rest = parts[0], parts[1:]
    if not isinstance(node, dict):
        return
    if head == "*":
        for k in node:
            yield from find(node[k], rest, f"{prefix}{k}.")
    elif head.endswith("[]"):
        name = head[:-2]
        for i, item in enumerate(node.get(name, []) or []):
            yield from find(item, rest, f"{prefix}{name}[{i}].")
    elif head in node:
        yield from find(node[head], rest, f"{prefix}{head}.")



def key_table_markdown() -> str:
    """The README's "Ranges of every key" table (Markdown: key, allowed, note), one row per
    declared key in declaration order; `lobes.` stands for each lobe."""
    rows = ["| key | allowed | note |", "|---|---|---|"]
    for pattern, rng in RANGES.items():
        name = pattern.replace("lobes.*.", "lobes.")
        rows.append(f"| `{name}` | {rng.text()} | {rng.why} |")
    return "\n".join(rows) + "\n"
