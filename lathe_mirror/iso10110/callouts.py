"""What the drawing states beyond each lobe's conic and form: the datums on physical
features and the geometric tolerances to them, the vertex separation and the step height
with their tolerances, the surface imperfections (ISO 10110-7), the coating (ISO 10110-9),
the drawing's identity (number, revision, approvals) and whether the part as turned meets
its own form tolerance or must be polished.

Datums are physical: A is the back face (the seat the mirror is mounted on), B the mount's
cylinder (the bore, or the boss, or with no mount the blank's turned outside diameter),
which centres the mirror on the camera's axis. Their tolerances come from the tolerance
analysis' drawn assembly tolerances ([tolerance.params]), of which the part takes a share
(the rest is the camera's mount's):

- Runout of each lobe to A and B (circular, radial): the optical axis off the mount's axis
  is a decentre of the mirror against the camera, drawn at camera_decentre_mm per axis; the
  part takes half of it in squares (1/sqrt 2), so the runout (full indicator movement, twice
  the offset) is sqrt(2) camera_decentre_mm.
- Axial runout of A to B and perpendicularity of B to A: the seat face tilted against the
  mount's axis tilts the mirror, drawn at seat_tilt_deg; the part takes 1/sqrt 2 of it over
  the back face's diameter (runout) and over the mount's length (perpendicularity).
- Step height and vertex separation: a lathe cuts both lobes in one pass, so the tool's Z
  setting moves them together; what changes them is the tool's X setting (tool_x_mm: the
  profile shifted dx in r, dz = -z'(r) dx) and the nose radius (nose_radius_mm: the surface
  offset dn along its normal, dz = dn / cos(theta), theta the slope angle). The step changes
  by the difference of the two lobes' dz at the junction; the vertex separation by the
  difference of their mean dz over the clear apertures (each lobe's vertex fitted with its
  R and k held). Each drawn tolerance's effect added in squares (the Monte Carlo's
  independent draws), never below one step of the lathe's lattice, rounded up to 1 um (the
  drawing asks for what the analysed process delivers, no tighter).
- Surface imperfections (ISO 10110-7): 5/N x A with A the largest grade of the standard's
  series no larger than half the smallest pixel's footprint on either lobe (a defect under
  half a pixel changes no pixel's value by more than its share of the area), N = 3.

Lengths in mm; angles in rad unless a name says deg.
"""

from __future__ import annotations

import hashlib
import json
import math
from dataclasses import dataclass

import numpy as np

from ..design import Mirror
from ..enums import Mount

#: ISO 10110-7's grade numbers (the square root of a defect's area, mm), its R10 series.
IMPERFECTION_GRADES = (0.0025, 0.004, 0.006, 0.01, 0.016, 0.025, 0.04, 0.063, 0.1, 0.16, 0.25, 0.4,
                       0.63, 1.0, 1.6, 2.5, 4.0)
#: Number of defects of the largest grade allowed per lobe (ISO 10110-7's N).
IMPERFECTION_COUNT = 3
#: The coating callout (ISO 10110-9): the reflective layer the design's reflection assumes.
COATING = ("ISO 10110-9: both lobes protected aluminium (Al + SiO2 overcoat), Ravg >= 85 % over "
           "450-650 nm at AOI 0-60 deg, after polishing; no coating elsewhere")
#: The drawing's revision: a new number (drawing_number) is a new design.
REVISION = "A"


@dataclass(frozen=True)
class GeometricTolerance:
    """One feature control frame: `symbol` (runout, axial runout, perpendicularity) of
    `feature`, zone value_mm, relative to `datums`; basis: the rule that set it."""

    symbol: str
    feature: str
    value_mm: float
    datums: str
    basis: str

    @property
    def frame(self) -> str:
        """The feature control frame as text: '<glyph> 0.071 A B'."""
        glyph = {"runout": "\u2197", "axial runout": "\u2197", "perpendicularity": "\u22a5"}[self.symbol]
        return f"{glyph} {self.value_mm:.3f} {self.datums}"

    def to_dict(self) -> dict:
        return {"symbol": self.symbol, "feature": self.feature, "value_mm": self.value_mm,
                "datums": self.datums, "frame": self.frame, "basis": self.basis}


@dataclass(frozen=True)
class LinearTolerance:
    """A dimension with its +/- tolerance (mm) and what set it."""

    name: str
    nominal_mm: float
    plus_minus_mm: float
    contributions_mm: dict
    basis: str

    def to_dict(self) -> dict:
        return {"name": self.name, "nominal_mm": self.nominal_mm, "plus_minus_mm": self.plus_minus_mm,
                "contributions_mm": dict(self.contributions_mm), "basis": self.basis}


@dataclass(frozen=True)
class Callouts:
    """Everything of the module doc for one part."""

    datums: dict
    geometric: tuple[GeometricTolerance, ...]
    step_height: LinearTolerance
    vertex_separation: LinearTolerance
    imperfections: str
    imperfection_basis: str
    coating: str

    def to_dict(self) -> dict:
        return {"datums": dict(self.datums), "geometric": [g.to_dict() for g in self.geometric],
                "step_height": self.step_height.to_dict(), "vertex_separation": self.vertex_separation.to_dict(),
                "iso10110_7": self.imperfections, "iso10110_7_basis": self.imperfection_basis,
                "coating": self.coating}


@dataclass(frozen=True)
class AsTurned:
    """The part as turned (no polish) against its own form tolerance: per lobe the RMS
    slope error over the evaluation length (urad) and its limit; `part`: which part."""

    part: str
    slope_urad: tuple[float, float]
    limit_urad: tuple[float, float]
    evaluation_length_mm: float

    @property
    def passes(self) -> bool:
        return all(s <= lim for s, lim in zip(self.slope_urad, self.limit_urad))

    @property
    def note(self) -> str:
        """The drawing's line: polish required (with the figure), or not."""
        figs = "; ".join(f"lobe {k + 1} {s:.0f} urad RMS against {lim:g}"
                         for k, (s, lim) in enumerate(zip(self.slope_urad, self.limit_urad)))
        if self.passes:
            return f"As turned ({self.part}) the part meets its form tolerance: {figs}. Polishing optional."
        return (f"POLISH REQUIRED: as turned ({self.part}) the slope error per {self.evaluation_length_mm:g} mm "
                f"exceeds the form tolerance: {figs}.")

    def to_dict(self) -> dict:
        return {"part": self.part, "slope_urad": list(self.slope_urad), "limit_urad": list(self.limit_urad),
                "evaluation_length_mm": self.evaluation_length_mm, "passes": self.passes,
                "polish_required": not self.passes, "note": self.note}


def callouts(mirror: Mirror, conics, body, tolerances: dict[str, float], *, resolution_mm: float) -> Callouts:
    """The Callouts of `mirror` on the mounting `body` (body.BodySpec), with the drawn
    tolerances `tolerances` ([tolerance.params], edge units) and the lathe's lattice
    resolution_mm. conics: the lobes' iso10110 Conics (their clear apertures)."""
    mount = {Mount.BORE: f"the bore \u00d8{body.mount_diameter:g}",
             Mount.BOSS: f"the boss \u00d8{body.mount_diameter:g}",
             Mount.NONE: f"the outside diameter \u00d8{body.blank_diameter:g}"}[body.mount]
    datums = {"A": "the back face (the seat)", "B": f"{mount} (centring)"}
    share = 1.0 / math.sqrt(2.0)
    decentre = float(tolerances.get("camera_decentre_mm", 0.0))
    tilt = math.radians(float(tolerances.get("seat_tilt_deg", 0.0))) * share
    length = body.mount_depth if body.mount is not Mount.NONE else body.thickness
    geometric = tuple(
        [GeometricTolerance("runout", f"lobe {k + 1} ({c.name})", _down(math.sqrt(2.0) * decentre), "A B",
                            "sqrt(2) x tolerance.params.camera_decentre_mm (the part's half share, as runout)")
         for k, c in enumerate(conics)]
        + [GeometricTolerance("axial runout", "A (the back face)", _down(body.blank_diameter * math.tan(tilt)), "B",
                              "back face diameter x tan(seat_tilt_deg / sqrt 2)"),
           GeometricTolerance("perpendicularity", "B (the mount)", _down(length * math.tan(tilt)), "A",
                              "mount length x tan(seat_tilt_deg / sqrt 2)")])
    step, separation = _piston_tolerances(mirror, conics, tolerances, resolution_mm)
    grade, basis = _imperfection_grade(mirror, conics)
    return Callouts(datums=datums, geometric=geometric, step_height=step, vertex_separation=separation,
                    imperfections=f"5/{IMPERFECTION_COUNT}x{grade:g}", imperfection_basis=basis, coating=COATING)


def surface_shift_coefficients(lobe, r: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(d z / d dx, d z / d dn) of the lobe's turned surface at radii r: the profile moved
    dx across the axis (-z'(r)) and a nose larger by dn (1 / cos theta, theta = atan z')."""
    s = lobe.slope(np.asarray(r, dtype=float))
    return -s, np.sqrt(1.0 + s * s)


def as_turned(job, conics, forms, *, evaluation_length_mm: float, samples_per_mm: int = 200) -> AsTurned:
    """The job's part as turned (job.made(), no polish) against the form tolerances
    `forms`: per lobe the RMS over its clear aperture of the slope of the height error
    across evaluation_length_mm (the drawing's definition of the slope tolerance)."""
    made = job.made().profile
    slopes = []
    for lobe, c in zip(job.mirror.lobes, conics):
        lo, hi = c.clear_aperture
        half = 0.5 * evaluation_length_mm
        n = max(int((hi - lo) * samples_per_mm), 8)
        r = np.linspace(lo + half, hi - half, n) if hi - lo > evaluation_length_mm else np.array([0.5 * (lo + hi)])
        # just inside the aperture: at r = r_junction exactly a profile answers for the inner lobe
        ra, rb = np.maximum(r - half, np.nextafter(lo, hi)), np.minimum(r + half, hi)
        err_a = made.z(ra) - lobe.z(ra)
        err_b = made.z(rb) - lobe.z(rb)
        slope = (err_b - err_a) / (rb - ra)
        slopes.append(float(np.sqrt(np.mean(slope[np.isfinite(slope)] ** 2))) * 1e6)
    return AsTurned(part=job.label, slope_urad=tuple(slopes), limit_urad=tuple(f.slope_urad for f in forms),
                    evaluation_length_mm=evaluation_length_mm)


def drawing_number(spec: dict) -> str:
    """The drawing's number: 'LM-' and 8 hex digits of the SHA-256 of the part's spec
    (its JSON with sorted keys), so one design has one number and another design another."""
    digest = hashlib.sha256(json.dumps(spec, sort_keys=True, separators=(",", ":")).encode()).hexdigest()
    return f"LM-{digest[:8].upper()}"


# --------------------------------------------------------------------------------------


def _piston_tolerances(mirror: Mirror, conics, tolerances: dict[str, float], resolution_mm: float):
    dx = float(tolerances.get("tool_x_mm", 0.0))
    dn = float(tolerances.get("nose_radius_mm", 0.0))
    rj = np.array([mirror.r_junction])
    (xi, ni), (xo, no) = (surface_shift_coefficients(lb, rj) for lb in mirror.lobes)
    step_parts = {"tool_x_mm": abs(float(xo[0] - xi[0])) * dx, "nose_radius_mm": abs(float(no[0] - ni[0])) * dn}
    means = []
    for lobe, c in zip(mirror.lobes, conics):
        r = np.linspace(*c.clear_aperture, 2001)
        cx, cn = surface_shift_coefficients(lobe, r)
        means.append((float(np.mean(cx)), float(np.mean(cn))))
    sep_parts = {"tool_x_mm": abs(means[1][0] - means[0][0]) * dx, "nose_radius_mm": abs(means[1][1] - means[0][1]) * dn}
    basis = ("the drawn tool_x_mm and nose_radius_mm tolerances' effects added in squares (the tool's Z "
             "setting moves both lobes together), at least one lattice step, rounded up to 1 um")
    out = []
    for name, nominal, parts in (("step height at the junction", abs(mirror.step), step_parts),
                                 ("vertex separation V1-V2", abs(conics[1].vertex_z - conics[0].vertex_z), sep_parts)):
        rss = math.sqrt(sum(v * v for v in parts.values()))
        out.append(LinearTolerance(name=name, nominal_mm=float(nominal), plus_minus_mm=_up(max(rss, resolution_mm)),
                                   contributions_mm={k: float(v) for k, v in parts.items()}, basis=basis))
    return tuple(out)


def _imperfection_grade(mirror: Mirror, conics) -> tuple[float, str]:
    cam = mirror.camera
    footprints = []
    for lobe, c in zip(mirror.lobes, conics):
        r = np.linspace(*c.clear_aperture, 501)
        r = r[r > 0]
        z = lobe.z(r)
        # one pixel's width on the mirror: the pixel's angle (t / f, at the pinhole) times
        # the distance to the mirror point, stretched by the surface's tilt to the ray
        dist = np.hypot(r, z)
        s = lobe.slope(r)
        # |sin| of the angle between the ray (r, z) / dist and the tangent (1, s) / |(1, s)|
        grazing = np.abs(r * s - z) / (dist * np.hypot(1.0, s))
        footprints.append(float(np.min(cam.t_pixel / cam.f * dist / grazing)))
    half = 0.5 * min(footprints)
    grade = max([g for g in IMPERFECTION_GRADES if g <= half], default=IMPERFECTION_GRADES[0])
    return grade, (f"the largest ISO 10110-7 grade <= half the smallest pixel footprint on the mirror "
                   f"({min(footprints):.4f} mm), {IMPERFECTION_COUNT} allowed per lobe")


def _down(v: float) -> float:
    """Rounded down to 1 um, at least 1 um (a tolerance is never loosened by rounding)."""
    return max(math.floor(v * 1e3 + 1e-9) / 1e3, 0.001)


def _up(v: float) -> float:
    """Rounded up to 1 um (what the analysed process delivers, asked no tighter)."""
    return math.ceil(v * 1e3 - 1e-9) / 1e3
