"""The zones of the image and of the lobes: which pixels and radii every figure covers.

ARCHITECTURE.md's shared definition, computed in one place so that every command judges
the same pixels:

- the designed annulus of each lobe (Mirror.image_radii_px: the inner disc, the outer
  annulus up to the outer lobe's R_pixel);
- the step wall's shadow: the inner pixels whose world ray the step wall blocks (inner
  lobe recessed), the ring of pixels that see the wall itself (Mirror.image_radii_px's
  lost ring), and the outer lobe's radii hidden behind the inner lobe's rim (outer lobe
  recessed: no pixel sees them);
- the ring the nose cannot reach: the fillet a nose of radius rho leaves in the junction's
  inside corner, on the recessed lobe (the inner lobe's rim, or the outer lobe's inner
  edge). With the nose centre touching the wall (r = r_junction -/+ rho) and the sheet,
  the fillet leaves the sheet where the sheet's normal through the nose centre meets it:
  r_junction - rho (1 + sin t) on a recessed inner lobe, r_junction + rho (1 - sin t) on a
  recessed outer lobe, t = atan |dz/dr| at the junction (within a few um of the as-machined
  envelope's own fillet, nose_envelope.junction_fillet; the tests check it). It is in view
  when it reaches past the shadow; its pixels are then lost;
- the used zone: the designed annulus less the shadow and less the fillet ring. Criteria
  (the tolerance verdict, the calibration files' valid annulus, the report's image
  displacement) judge the used zone; the fillet ring is reported on its own (width in mm
  and px, pixels lost).

The ring is computed for the nose the part is cut with plus a guard (mm; the callers pass
the nose radius's tolerance, so a nose at the edge of its tolerance stays inside the ring).
Camera frame (ARCHITECTURE.md), mm; pixels where a name says `_px`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..design import Mirror
from ..inputs import check_real, check_type
from .radial import sensor_radii, used_extent

if TYPE_CHECKING:  # pragma: no cover
    from ..settings import Settings


@dataclass(frozen=True)
class LobeZone:
    """One lobe's zones. Radii in mm on the lobe, image radii in px from the principal point.

    designed_px: the lobe's designed annulus; seen_mm: the radii the camera can see
    unobstructed (the step's shadow removed); fillet_mm: the ring the nose cannot reach on
    this lobe (None when this lobe is not the recessed one or the nose is sharp);
    fillet_px: its image, where in view (None when the shadow hides it); used_mm / used_px:
    what the criteria judge; *_pixels: counts of pixel centres of the sensor."""

    name: str
    designed_px: tuple[float, float]
    seen_mm: tuple[float, float]
    used_mm: tuple[float, float]
    used_px: tuple[float, float]
    fillet_mm: tuple[float, float] | None
    fillet_px: tuple[float, float] | None
    used_pixels: int
    fillet_pixels: int

    @property
    def fillet_width_mm(self) -> float:
        return 0.0 if self.fillet_mm is None else self.fillet_mm[1] - self.fillet_mm[0]

    @property
    def fillet_width_px(self) -> float:
        return 0.0 if self.fillet_px is None else self.fillet_px[1] - self.fillet_px[0]

    def as_dict(self) -> dict:
        def pair(p):
            return None if p is None else {"min": float(p[0]), "max": float(p[1])}
        return {"name": self.name, "designed_px": pair(self.designed_px), "seen_mm": pair(self.seen_mm),
                "used_mm": pair(self.used_mm), "used_px": pair(self.used_px),
                "fillet_mm": pair(self.fillet_mm), "fillet_px": pair(self.fillet_px),
                "fillet_width_mm": float(self.fillet_width_mm), "fillet_width_px": float(self.fillet_width_px),
                "used_pixels": int(self.used_pixels), "fillet_pixels_lost": int(self.fillet_pixels)}


@dataclass(frozen=True)
class Zones:
    """Both lobes' zones (inner first) for a nose of nose_mm (+ guard_mm)."""

    nose_mm: float
    guard_mm: float
    recessed: str
    lobes: tuple[LobeZone, LobeZone]
    step_shadow_px: tuple[float, float]

    def __repr__(self) -> str:
        used = ", ".join(f"{z.name} {z.used_px[0]:.1f}-{z.used_px[1]:.1f} px" for z in self.lobes)
        return (f"Zones(nose {self.nose_mm:g} mm + guard {self.guard_mm:g} mm, {self.recessed} recessed; used "
                f"{used})")

    def as_dict(self) -> dict:
        return {"nose_radius_mm": float(self.nose_mm), "guard_mm": float(self.guard_mm),
                "recessed_lobe": self.recessed,
                "step_shadow_px": {"min": float(self.step_shadow_px[0]), "max": float(self.step_shadow_px[1])},
                "lobes": [lb.as_dict() for lb in self.lobes]}

    @property
    def fillet(self) -> LobeZone:
        """The recessed lobe's zone (the one that carries the fillet)."""
        return self.lobes[0 if self.recessed == "inner" else 1]

    def describe(self) -> str:
        """One line: the zone the criteria judge and the fillet ring on its own."""
        used = "; ".join(f"{lb.name} r {lb.used_mm[0]:.3f}..{lb.used_mm[1]:.3f} mm "
                         f"(image radius {lb.used_px[0]:.1f}..{lb.used_px[1]:.1f} px)" for lb in self.lobes)
        f = self.fillet
        nose = f"{self.nose_mm:g} mm nose" + (f" + {self.guard_mm:g} mm tolerance" if self.guard_mm else "")
        if f.fillet_mm is None:
            ring = f"no fillet ring ({nose})"
        elif f.fillet_px is None:
            ring = (f"the fillet ring ({nose}) on the {f.name} lobe, r {f.fillet_mm[0]:.3f}..{f.fillet_mm[1]:.3f} mm "
                    f"({f.fillet_width_mm:.3f} mm), lies in the step's shadow: 0 px, no pixel lost")
        else:
            ring = (f"the fillet ring ({nose}) on the {f.name} lobe, r {f.fillet_mm[0]:.3f}..{f.fillet_mm[1]:.3f} mm "
                    f"({f.fillet_width_mm:.3f} mm), is in view at image radius {f.fillet_px[0]:.1f}.."
                    f"{f.fillet_px[1]:.1f} px ({f.fillet_width_px:.1f} px): {f.fillet_pixels} pixels lost")
        return f"zones: criteria judge {used}; {ring}"


def describe_dict(d: dict) -> str:
    """Zones.describe of a Zones.as_dict (a result read back from JSON)."""
    def pair(p):
        return None if p is None else (p["min"], p["max"])
    lobes = tuple(LobeZone(lb["name"], pair(lb["designed_px"]), pair(lb["seen_mm"]), pair(lb["used_mm"]),
                           pair(lb["used_px"]), pair(lb["fillet_mm"]), pair(lb["fillet_px"]), lb["used_pixels"],
                           lb["fillet_pixels_lost"]) for lb in d["lobes"])
    return Zones(d["nose_radius_mm"], d["guard_mm"], d["recessed_lobe"], lobes, pair(d["step_shadow_px"])).describe()


def image_radius_px(mirror: Mirror, k: int, r: float) -> float:
    """Image radius (px) of the exact lobe k's point at radius r (mm)."""
    lobe = mirror.lobes[k]
    return float(mirror.camera.image_radius_px(r / float(lobe.z(np.array([r]))[0])))


def fillet_band(mirror: Mirror, nose_mm: float) -> tuple[str, tuple[float, float] | None]:
    """(recessed lobe's name, radii (mm) of the ring a nose of nose_mm cannot reach, or None
    for a sharp nose). The closed form of the module's docstring."""
    rj = mirror.r_junction
    recessed = "inner" if mirror.step > 0 else "outer"
    if nose_mm <= 0.0:
        return recessed, None
    k = 0 if recessed == "inner" else 1
    t = math.atan(abs(float(mirror.lobes[k].slope(np.array([rj]))[0])))
    if k == 0:
        return recessed, (max(rj - nose_mm * (1.0 + math.sin(t)), 0.0), rj)
    return recessed, (rj, min(rj + nose_mm * (1.0 - math.sin(t)), mirror.r_max))


def _count(rho: np.ndarray, cnt: np.ndarray, lo: float, hi: float, *, closed_lo: bool) -> int:
    m = ((rho >= lo) if closed_lo else (rho > lo)) & (rho <= hi)
    return int(cnt[m].sum())


def zones(mirror: Mirror, nose_mm: float, guard_mm: float = 0.0, lattice_mm: float = 0.0) -> Zones:
    """The zones of `mirror` cut with a nose of nose_mm (mm), the fillet ring widened for a
    nose of nose_mm + guard_mm. lattice_mm: the controller's resolution; the made junction
    stands on the lattice, up to a step from the design's r_junction, so the pixels whose
    ray passes within lattice_mm of the junction (the made rim of one lobe where the design
    has the other) are in neither lobe's used zone."""
    check_type(mirror, "zones: mirror", Mirror, "a Mirror (settings.mirror())")
    for name, value in (("nose_mm", nose_mm), ("guard_mm", guard_mm), ("lattice_mm", lattice_mm)):
        check_real(value, f"zones: {name}", lo=0.0, unit="mm")
    radii = mirror.image_radii_px
    rj = mirror.r_junction
    recessed, band = fillet_band(mirror, nose_mm + guard_mm if nose_mm > 0 else 0.0)
    rho, cnt = sensor_radii(tuple(int(n) for n in mirror.camera.sensor_px))
    # inner lobe: seen up to where the step wall starts to block its world rays
    seen_hi = min(used_extent(mirror, 0)[1], rj - lattice_mm)
    designed0 = radii["inner_disc"]
    shadow_lo = min(radii["inner_blocked_by_step"][0], designed0[1])
    used_hi, used_hi_px = seen_hi, min(shadow_lo, designed0[1], image_radius_px(mirror, 0, seen_hi))
    f_mm = f_px = None
    f_pix = 0
    if recessed == "inner" and band is not None:
        f_mm = band
        if band[0] < seen_hi:
            used_hi = band[0]
            f_lo_px = image_radius_px(mirror, 0, band[0])
            f_px = (f_lo_px, used_hi_px)
            f_pix = _count(rho, cnt, f_lo_px, used_hi_px, closed_lo=True)
            used_hi_px = f_lo_px
    inner = LobeZone("inner", designed0, (0.0, seen_hi), (0.0, used_hi), (0.0, used_hi_px), f_mm, f_px,
                     _count(rho, cnt, -1.0, np.nextafter(used_hi_px, -np.inf), closed_lo=False), f_pix)
    # outer lobe: seen from r_outer_visible (the inner rim hides the rest) to the rim
    designed1 = radii["outer_annulus"]
    seen_lo = max(float(mirror.r_outer_visible), rj + lattice_mm)
    used_lo, used_lo_px = seen_lo, designed1[0]
    if lattice_mm > 0:
        # the ray that passes the junction lattice_mm out: over the inner lobe's rim (outer
        # lobe recessed) or onto the outer lobe's edge
        zj = float(mirror.inner.z(np.array([rj]))[0]) if mirror.step <= 0 else \
            float(mirror.outer.z(np.array([rj + lattice_mm]))[0])
        used_lo_px = max(used_lo_px, float(mirror.camera.image_radius_px((rj + lattice_mm) / zj)))
    f_mm = f_px = None
    f_pix = 0
    if recessed == "outer" and band is not None:
        f_mm = band
        if band[1] > seen_lo:
            used_lo = band[1]
            f_hi_px = image_radius_px(mirror, 1, band[1])
            f_px = (used_lo_px, f_hi_px)
            f_pix = _count(rho, cnt, used_lo_px, f_hi_px, closed_lo=False)
            used_lo_px = max(used_lo_px, f_hi_px)
    outer = LobeZone("outer", designed1, (seen_lo, float(mirror.r_max)), (used_lo, float(mirror.r_max)),
                     (used_lo_px, designed1[1]), f_mm, f_px,
                     _count(rho, cnt, used_lo_px, designed1[1], closed_lo=False), f_pix)
    shadow = (shadow_lo, designed1[0])
    return Zones(float(nose_mm), float(guard_mm), recessed, (inner, outer), shadow)


def zones_for(settings: "Settings", mirror: Mirror, nose_mm: float | None = None) -> Zones:
    """The zones every command uses for `settings`' made mirror: the configured tool's nose,
    guarded by the nose radius's tolerance ([tolerance] nose_radius_mm), the junction by one
    step of the coarsest lattice cut ([machine] resolution + [tolerance.params]
    resolution_mm). nose_mm: another nose than the [tool]'s (a command's --nose-radius)."""
    tol = settings.tolerance
    tols = tol.tolerances if tol is not None else {}
    guard = float(tols.get("nose_radius_mm", 0.0))
    # the coarsest lattice the analysis cuts (the resolution row re-plans at + its tolerance)
    lattice = float(settings.machine.resolution) + float(tols.get("resolution_mm", 0.0))
    nose = float(settings.tool.nose_radius) if nose_mm is None else float(nose_mm)
    return zones(mirror, nose, guard if nose > 0 else 0.0, lattice)
