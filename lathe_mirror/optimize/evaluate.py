"""One design's figures, objective and constraints: what the search calls per candidate.

A candidate is a design vector x (spec.PARAMETERS): the outer rim's radius as a fraction of
the radial envelope, the junction as a fraction of it, the outer rim's image radius as a
fraction of the inscribed circle (less the margin), the inner rim's as a fraction of that,
and both lobes' Table 1 alpha (deg). `design_of` turns it into the two LobeSpecs (r_top,
r_pixel, alpha_deg) that a configuration file carries, and `figures` designs the mirror
(design.mirror_from_specs, Eqs. 3-6) and measures it.

The constraints (CONSTRAINTS, each named by the key that sets it):
  envelope   optimize.r_max_mm (outer r_top), optimize.vertex_min_mm (the vertex, the
             nearest point to the pinhole), optimize.rim_max_mm (the farthest point, the
             higher rim)
  band       optimize.band_deg (the common band covers the elevations the robot needs),
             optimize.band_width_min_deg
  image      optimize.rim_margin_px (outer rim inside the inscribed circle),
             optimize.usable_min (share of its pixels that see the scene, after the ring
             lost at the junction and the step's vignetting)
  focus      optimize.blur_max_px (focus.defocus, [camera] f_number)
  lathe      tool.nose_radius (the nose reaches the step wall, whichever lobe is
             recessed, and the fillet it leaves in the step's corner lies where the
             camera does not see it), tool.approach_angle (the held tool's flanks clear
             the profile),
             stock.diameter, stock.length and cad.thickness (the bar and the body hold it;
             the second set-up's soft jaws grip the body's side below the rim's shoulder,
             at least toolpath.min_grip_mm and half the part's stand-out: second_grip_mm),
             cad.mount_depth (the body's bore stays cad.min_wall below the face)
Each violation is normalised by a natural unit (1 mm, 1 deg, 1 px, 1 % of the image,
0.01 rad) so that they add up into one measure of infeasibility.

Units: mm, radians inside; the figures carry their unit in their names.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np

from ..body import BodySpec
from ..design import Camera, LobeSpec, Mirror, mirror_from_specs
from ..enums import Mount
from ..errors import DesignError, InputError
from ..lathe import JAW_GAP, MIN_GRIP, Lathe, Stock, Tool, grip_needed, parting_corner_z
from ..optics.ranging.resolution import blur_circle_px, delivered_r10, design_r10, r10
from ..toolpath.checks import corner_nose, fillet_hidden_margin, reach_margin
from ..toolpath.moves import Hand, ToolpathSettings
from .focus import defocus
from .spec import PARAMETERS, Objective, OptimizeSettings

#: Energy of a vector that designs no mirror at all (DesignError).
NO_DESIGN = 1.0e6
#: Energy offset of a mirror that breaks a constraint: every infeasible candidate scores
#: worse than every feasible one (the objectives are all well below this).
INFEASIBLE = 1.0e3


@dataclass(frozen=True)
class Problem:
    """Everything a candidate is judged by: the camera (fixed), the lathe's tool, the bar,
    the body, the [toolpath] clearance (mm, the bar's length beyond the mirror's depth),
    the [optimize] settings and the configured design (the reference the winner beats).

    made_disparity_px, matching_noise_px: the delivered-R10 objective's surrogate
    (optics.ranging.resolution.delivered_r10): the made parts' disparity error after
    calibration at their 95th percentile (px; a small seeded Monte Carlo of the configured
    design, tolerance.runs.made_disparity), and the matcher's noise on a one-pixel feature.
    grip_mm: what the second set-up needs of the body's side below the rim's shoulder
    (second_grip_mm of the configured body, [toolpath] and lathe; the default is the
    default configuration's, JAW_GAP + MIN_GRIP)."""

    camera: Camera
    tool: Tool
    stock: Stock
    body: BodySpec
    clearance: float
    settings: OptimizeSettings
    reference: tuple[LobeSpec, LobeSpec]
    made_disparity_px: float = 0.0
    matching_noise_px: float = 0.1
    grip_mm: float = JAW_GAP + MIN_GRIP


@dataclass(frozen=True)
class Figures:
    """A design's figures (the table beside the paper's; the constraints' inputs).

    r10_m: the sharp R10 over the required band (optics.ranging.resolution.r10; the JSON's
    sharp_r10_m); design_r10_m: the nominal part's R10 with its own blur and the matcher's
    noise (resolution.design_r10: what optimize promises); delivered_r10_m: the surrogate of
    the made parts' 5th percentile (resolution.delivered_r10). baseline_mm: F1
    to F1. band_deg: the common band (lowest, highest elevation). band_width_deg.
    usable_share: share of the inscribed circle's pixels that see the scene. blur_px,
    focus_mm: the thin-lens model's largest blur and focus distance. step_mm, recessed:
    the junction. vertex_mm, far_mm: nearest (the vertex) and farthest point (the higher
    rim) from the pinhole; depth_mm = far - vertex. junction_margin_mm: the step's top
    above the nose centre in its inside corner (>= 0: the nose reaches the wall);
    fillet_hidden_mm: how far (in r) the fillet the nose leaves there stays out of the
    camera's sight (>= 0: unseen); reach_margin_deg: the held tool's flanks' least clearance of the profile's normals.
    hand: how the tool is held (toolpath.Hand).
    """

    lobes: tuple[LobeSpec, LobeSpec]
    r10_m: float
    baseline_mm: float
    band_deg: tuple[float, float]
    band_width_deg: float
    usable_share: float
    blur_px: float
    focus_mm: float
    step_mm: float
    recessed: str
    vertex_mm: float
    far_mm: float
    depth_mm: float
    junction_margin_mm: float
    fillet_hidden_mm: float
    reach_margin_deg: float
    hand: str
    r_pixel_outer: float = field(default=0.0)
    bore_face_mm: float = field(default=0.0)  # the face's depth below the vertex over the mount bore's radius
    rim_depth_mm: float = field(default=0.0)  # the outer rim's depth below the vertex (the shoulder)
    delivered_r10_m: float = field(default=math.nan)  # the surrogate of the made parts' 5th percentile
    design_r10_m: float = field(default=math.nan)  # the nominal part's, blur and matcher noise counted

    def objective(self, objective: Objective) -> float:
        """The value of `objective` (larger is better)."""
        return {Objective.DELIVERED: self.delivered_r10_m, Objective.R10: self.r10_m, Objective.BASELINE: self.baseline_mm,
                Objective.BAND_WIDTH: self.band_width_deg,
                Objective.USABLE_AREA: self.usable_share}[objective]

    def to_dict(self) -> dict:
        """Plain data (JSON): the lobes under the configuration's keys, then the figures."""
        out = {"lobes": [{"name": s.name, "r_top": s.r_top, "r_pixel": s.r_pixel, "alpha_deg": s.alpha_deg}
                         for s in self.lobes]}
        out["design_r10_m"], out["sharp_r10_m"] = self.design_r10_m, self.r10_m
        for k in ("delivered_r10_m", "baseline_mm", "band_width_deg", "usable_share", "blur_px", "focus_mm",
                  "step_mm", "recessed", "vertex_mm", "far_mm", "depth_mm", "junction_margin_mm",
                  "fillet_hidden_mm", "reach_margin_deg", "hand"):
            out[k] = getattr(self, k)
        out["band_deg"] = {"min": self.band_deg[0], "max": self.band_deg[1]}
        return out


@dataclass(frozen=True)
class Constraint:
    """One constraint: the key that sets it, what it holds, its unit and normalising scale.

    value(fig, problem) -> (measured, limit); the violation is (measured - limit) / scale
    for an upper bound (sense +1), (limit - measured) / scale for a lower one (-1).
    """

    key: str
    what: str
    unit: str
    sense: int
    scale: float
    value: object

    def key_for(self, problem: Problem) -> str:
        """The key that sets this constraint for `problem` (the user's terms when given)."""
        s = problem.settings
        if self.key == "optimize.r_max_mm":
            return s.radial_key
        if self.key == "optimize.rim_max_mm" and s.max_depth_mm > 0:
            return "optimize.max_depth_mm"
        if self.key == "optimize.blur_max_px":
            return s.blur_key
        return self.key

    def violation(self, fig: Figures, problem: Problem) -> float:
        got, limit = self.value(fig, problem)
        return max(0.0, self.sense * (got - limit) / self.scale)


def _margin(p: Problem) -> float:
    return p.settings.bound_margin


def _radial(f: Figures, p: Problem):
    return f.lobes[1].r_top, p.settings.radial_limit_mm


def _far(f: Figures, p: Problem):
    # max_depth_mm: the higher rim at most that far beyond the vertex (the heights above
    # the pinhole follow from the vertex the design has); else rim_max_mm above the pinhole
    s = p.settings
    if s.max_depth_mm > 0:
        return f.far_mm, f.vertex_mm + s.max_depth_mm
    return f.far_mm, s.rim_max_mm


def _band_low(fig: Figures, p: Problem):
    return fig.band_deg[0], p.settings.band_deg[0]


def _band_high(fig: Figures, p: Problem):
    return fig.band_deg[1], p.settings.band_deg[1]


def _blur(f: Figures, p: Problem):
    return f.blur_px, p.settings.blur_limit_px(p.camera.t_pixel) * (1.0 - _margin(p))


CONSTRAINTS: tuple[Constraint, ...] = (
    Constraint("optimize.r_max_mm", "outer r_top (the radial envelope)", "mm", +1, 1.0, _radial),
    Constraint("optimize.vertex_min_mm", "the vertex's height above the pinhole", "mm", -1, 1.0,
               lambda f, p: (f.vertex_mm, p.settings.vertex_limit_mm)),
    Constraint("optimize.rim_max_mm", "the farthest point's height above the pinhole", "mm", +1,
               1.0, _far),
    Constraint("optimize.band_deg", "the common band's lowest elevation", "deg", +1, 1.0,
               _band_low),
    Constraint("optimize.band_deg", "the common band's highest elevation", "deg", -1, 1.0,
               _band_high),
    Constraint("optimize.band_width_min_deg", "the common band's width", "deg", -1, 1.0,
               lambda f, p: (f.band_width_deg, p.settings.band_width_min_deg)),
    Constraint("optimize.rim_margin_px", "the outer rim's image radius", "px", +1, 1.0,
               lambda f, p: (f.r_pixel_outer, p.camera.r_pixel_max - p.settings.rim_margin_px)),
    Constraint("optimize.usable_min", "the usable share of the image", "", -1, 0.01,
               lambda f, p: (f.usable_share, p.settings.usable_min)),
    Constraint("optimize.blur_max_px", "the largest defocus blur (less the margin)", "px", +1, 1.0, _blur),
    Constraint("tool.nose_radius", "the step's top above the nose centre in its inside corner", "mm", -1, 0.01,
               lambda f, p: (f.junction_margin_mm, 0.0)),
    Constraint("tool.nose_radius", "the nose's corner fillet's distance (in r) from the camera's sight", "mm", -1, 0.01, lambda f, p: (f.fillet_hidden_mm, 0.0)),
    Constraint("tool.approach_angle", "the held tool's flank clearance of the profile", "deg", -1, 0.5,
               lambda f, p: (f.reach_margin_deg, 0.0)),
    Constraint("stock.diameter", "the mirror's diameter", "mm", +1, 1.0,
               lambda f, p: (2.0 * f.lobes[1].r_top, p.stock.diameter)),
    Constraint("cad.blank_diameter", "the mirror's diameter", "mm", +1, 1.0,
               lambda f, p: (2.0 * f.lobes[1].r_top, p.body.blank_diameter)),
    Constraint("stock.length", "the mirror's depth plus toolpath.clearance", "mm", +1, 1.0,
               lambda f, p: (f.depth_mm + p.clearance, p.stock.length)),
    Constraint("cad.thickness", "the mirror's depth plus cad.min_wall", "mm", +1, 1.0,
               lambda f, p: (f.depth_mm + p.body.min_wall, p.body.thickness)),
    Constraint("cad.thickness", "the outer rim's depth plus the second set-up's grip (jaw gap and least grip: "
               "toolpath.min_grip_mm, half the stand-out)",
               "mm", +1, 1.0, lambda f, p: (f.rim_depth_mm + p.grip_mm, p.body.thickness)),
    Constraint("cad.mount_depth", "the face's depth over the mount bore plus cad.min_wall and the bore's depth", "mm",
               +1, 1.0, lambda f, p: (f.bore_face_mm + p.body.min_wall + _bore_depth(p), p.body.thickness)),
)


def design_of(x: np.ndarray, problem: Problem) -> tuple[LobeSpec, LobeSpec]:
    """The two LobeSpecs (inner, outer) of a design vector (spec.PARAMETERS order)."""
    s = problem.settings
    r_top_outer = float(x[0]) * s.radial_limit_mm
    r_pixel_outer = float(x[2]) * (problem.camera.r_pixel_max - s.rim_margin_px)
    return (LobeSpec("inner", r_top=float(x[1]) * r_top_outer, r_pixel=float(x[3]) * r_pixel_outer,
                     alpha_deg=float(x[4])),
            LobeSpec("outer", r_top=r_top_outer, r_pixel=r_pixel_outer, alpha_deg=float(x[5])))


def vector_of(lobes: tuple[LobeSpec, LobeSpec], problem: Problem) -> np.ndarray:
    """The design vector of two LobeSpecs (alpha from the designed lobes when a spec gives
    a/b or e instead). Raises DesignError if they design no mirror."""
    mirror = mirror_from_specs(problem.camera, lobes)
    s = problem.settings
    inner, outer = mirror.inner, mirror.outer
    return np.array([outer.r_top / s.radial_limit_mm, inner.r_top / outer.r_top,
                     outer.r_pixel / (problem.camera.r_pixel_max - s.rim_margin_px),
                     inner.r_pixel / outer.r_pixel, math.degrees(inner.alpha), math.degrees(outer.alpha)])


def figures(lobes: tuple[LobeSpec, LobeSpec], problem: Problem) -> Figures:
    """Design the mirror of `lobes` on the problem's camera and measure it (module doc).
    Raises DesignError if the lobes design no mirror."""
    mirror = mirror_from_specs(problem.camera, lobes)
    return measure(mirror, problem, lobes)


def measure(mirror: Mirror, problem: Problem, lobes: tuple[LobeSpec, LobeSpec], *,
            with_r10: bool = True) -> Figures:
    """The Figures of a designed mirror (with_r10=False: r10_m is NaN, left out because
    the search only needs it for a feasible design; it is a third of the cost)."""
    s = problem.settings
    band = mirror.common_band
    radii = mirror.image_radii_px
    r_max_px = problem.camera.r_pixel_max
    inner_used = radii["inner_blocked_by_step"][0]
    o_lo, o_hi = radii["outer_annulus"]
    usable = (inner_used**2 + max(0.0, o_hi**2 - o_lo**2)) / r_max_px**2
    blur = defocus(mirror, problem.camera.f_number, s.focus_range_m * 1000.0, radii=radii)
    r10_m = r10(mirror, s.band) if with_r10 else math.nan
    zi, zo = mirror.junction_z
    vertex = mirror.vertex_z
    far = mirror.far_z  # Mirror.depth's definition (far - vertex)
    hand = Hand.for_mirror(mirror)
    return Figures(
        lobes=lobes,
        r10_m=r10_m,
        **_ranges(r10_m, blur.blur_px, problem),
        baseline_mm=mirror.baseline,
        band_deg=(math.degrees(band[0]), math.degrees(band[1])),
        band_width_deg=max(0.0, math.degrees(band[1] - band[0])),
        usable_share=usable,
        blur_px=blur.blur_px,
        focus_mm=blur.focus_mm,
        step_mm=abs(zi - zo),
        recessed=mirror.recessed,
        vertex_mm=vertex,
        far_mm=far,
        depth_mm=far - vertex,
        junction_margin_mm=corner_nose(mirror, problem.tool.nose_radius)[0],
        fillet_hidden_mm=fillet_hidden_margin(mirror, problem.tool.nose_radius),
        reach_margin_deg=math.degrees(reach_margin(mirror, problem.tool, hand)),
        hand=hand.value,
        r_pixel_outer=mirror.outer.r_pixel,
        bore_face_mm=_bore_face(mirror, problem),
        rim_depth_mm=float(mirror.outer.z(mirror.r_max)) - vertex,
    )


def _ranges(r10_m: float, defocus_px: float, problem: Problem) -> dict[str, float]:
    """design_r10_m and delivered_r10_m (m) of a design whose sharp R10 is r10_m and whose
    defocus is defocus_px: the blur circle adds the lens's Airy disc
    (optics.ranging.resolution.blur_circle_px); the design's R10 is the nominal part's
    (design_r10), the delivered surrogate adds the problem's made parts' disparity error
    (delivered_r10)."""
    cam = problem.camera
    b = blur_circle_px(defocus_px, cam.f_number, cam.t_pixel)
    return {"design_r10_m": float(design_r10(r10_m, b, problem.matching_noise_px)),
            "delivered_r10_m": float(delivered_r10(r10_m, problem.made_disparity_px, b, problem.matching_noise_px))}


def stand_out_mm(body: BodySpec, options: ToolpathSettings, lathe: Lathe) -> float:
    """How far (mm) the parted face stands above the finished back face before the second
    set-up faces it: the part-off's slot (lathe.parting_corner_z, where shop.partoff puts
    the blade) below the body's length, toolpath.back_allowance_mm and the lattice's
    rounding, plus the boss's length for a boss (the body's end is then the boss's)."""
    z = parting_corner_z(body.length, options.back_allowance_mm, options.parting_width_mm, lathe.resolution)
    return -(z + options.parting_width_mm) - body.thickness


def second_grip_mm(body: BodySpec, options: ToolpathSettings, lathe: Lathe) -> float:
    """What the second set-up's soft jaws need of the body's side below the rim's shoulder
    (mm): shop.second's gap at the back (JAW_GAP) plus its least grip, the larger of the
    configured toolpath.min_grip_mm and half the part's stand-out out of the jaws
    (lathe.grip_needed, the rule plan_second refuses by)."""
    return JAW_GAP + grip_needed(stand_out_mm(body, options, lathe), options.min_grip_mm)


def check_grip_room(body: BodySpec, options: ToolpathSettings, lathe: Lathe) -> None:
    """InputError (one line naming the binding key) when the second set-up's grip leaves
    no room for any mirror: the jaws need second_grip_mm of the body's side below the rim's
    shoulder, and the shoulder is at or below the vertex plane for every body a lathe can
    make (the first set-up faces the bar through the axis down to the vertex, so nothing
    of the face stands above it: rim depth >= 0), so a cad.thickness at most that long
    holds no design at all, and the search need not start."""
    need = second_grip_mm(body, options, lathe)
    T = body.thickness
    if need < T:
        return
    top = stand_out_mm(body, options, lathe)
    if options.min_grip_mm >= grip_needed(top, 0.0):
        what = f"toolpath.min_grip_mm = {options.min_grip_mm:g} mm"
        allowed = f"allowed < {T - JAW_GAP:g} mm (cad.thickness less the jaws' {JAW_GAP:g} mm gap at the back)"
    else:
        what = (f"cad.mount_depth = {body.mount_depth:g} mm" if body.length > T
                else f"toolpath.back_allowance_mm = {options.back_allowance_mm:g} mm")
        allowed = (f"allowed a stand-out under {2 * (T - JAW_GAP) - JAW_GAP:.3f} mm above the back face "
                   f"(now {top:.3f} mm)")
    raise InputError(f"{what}: the second set-up's soft jaws need {need - JAW_GAP:.3f} mm of the body's side "
                     f"(the larger of toolpath.min_grip_mm and half the {top + JAW_GAP:.3f} mm the parted part stands out of "
                     f"them) plus their {JAW_GAP:g} mm gap at the back, {need:.3f} mm, and cad.thickness = {T:g} mm "
                     f"leaves no mirror any room below its vertex; {allowed}, or cad.thickness > {need:.3f} mm")


def _bore_depth(p: Problem) -> float:
    return p.body.mount_depth if p.body.mount is Mount.BORE else 0.0


def _bore_face(mirror: Mirror, p: Problem) -> float:
    """The face's deepest point below the vertex within the mount bore's radius (mm; the
    body's bore must stay cad.min_wall below it: body.meridian's check)."""
    rm = p.body.mount_diameter / 2.0
    r = np.linspace(0.0, min(rm, mirror.r_max), 64)
    z = np.where(r <= mirror.r_junction, mirror.inner.z(r), mirror.outer.z(r))
    zj = mirror.junction_z
    deepest = float(np.max(z))
    if rm > mirror.r_junction:
        deepest = max(deepest, max(zj))
    return deepest - mirror.vertex_z


def violations(fig: Figures, problem: Problem) -> np.ndarray:
    """Each constraint's normalised violation (>= 0; 0 when it holds), CONSTRAINTS order."""
    return np.array([c.violation(fig, problem) for c in CONSTRAINTS])


def constraint_table(fig: Figures, problem: Problem, *, active: float = 0.02) -> list[dict]:
    """Each constraint at a design: key, what it holds, unit, the design's value, the
    limit, "bound" ("max" / "min"), the normalised slack (>= 0 when it holds) and whether
    it is active (slack below `active`, in the constraint's normalising units)."""
    rows = []
    for c in CONSTRAINTS:
        got, limit = c.value(fig, problem)
        slack = -c.sense * (got - limit) / c.scale
        rows.append({"key": c.key_for(problem), "what": c.what, "unit": c.unit, "value": float(got), "limit": float(limit),
                     "bound": "max" if c.sense > 0 else "min", "slack": float(slack),
                     "active": bool(slack < active)})
    return rows


#: What a candidate's record holds (search.History): the objective, the two Pareto axes,
#: the total violation, then each constraint's.
RECORD = ("objective", "band_width_deg", "depth_mm", "violation")


def evaluate(x: np.ndarray, problem: Problem) -> tuple[float, np.ndarray]:
    """(energy, record) of a design vector: energy = -objective when every constraint
    holds, INFEASIBLE + the summed violations when one does not, NO_DESIGN when the vector
    designs no mirror (DE minimises energy). record: RECORD's fields then each
    constraint's violation (NaN when there is no design)."""
    n = len(RECORD) + len(CONSTRAINTS)
    objective = problem.settings.objective
    try:
        with np.errstate(all="ignore"):
            lobes = design_of(x, problem)
            mirror = mirror_from_specs(problem.camera, lobes)
            late = objective in (Objective.R10, Objective.DELIVERED)  # R10 only for a feasible design
            fig = measure(mirror, problem, lobes, with_r10=not late)
            v = violations(fig, problem)
            if late and not v.any():
                r = r10(mirror, problem.settings.band)
                fig = dataclasses.replace(fig, r10_m=r, **_ranges(r, fig.blur_px, problem))
    except (DesignError, ValueError, ZeroDivisionError, OverflowError):
        # no mirror (the design's own checks), or one whose geometry degenerates (no ray
        # meets a lobe): no design either
        return NO_DESIGN, np.full(n, np.nan)
    obj = fig.objective(objective)
    if not np.all(np.isfinite(v)) or (not v.any() and not math.isfinite(obj)):
        return NO_DESIGN, np.full(n, np.nan)
    total = float(v.sum())
    rec = np.concatenate([[obj, fig.band_width_deg, fig.depth_mm, total], v])
    return (INFEASIBLE + total if total > 0.0 else -obj), rec


__all__ = ["CONSTRAINTS", "Constraint", "Figures", "PARAMETERS", "Problem", "check_grip_room", "constraint_table",
           "design_of", "evaluate", "figures", "measure", "second_grip_mm", "stand_out_mm", "vector_of", "violations"]
