"""What the optics shop and the inspection room work from: each lobe as an ISO 10110-12
conic with its sag table and clear aperture, its form tolerance (ISO 10110-5) from what
the tolerance spec allows, the surface texture (ISO 10110-8) from the finish model, the
material and the process.

- conic.py    Conic (R, k, vertex, clear aperture), sag(r), slope(r), sag_table
- form.py     FormTolerance from the image / stereo / slope limits (the allocation's rule,
              closed-form responses)
- texture.py  Texture: kinematic Ra / Rz, RMS roughness with its spatial band, TIS, the
              feed-mark grating
- callouts.py the datums (back face, mount) and the runout and perpendicularity to them,
              the step height and vertex separation with their tolerances, ISO 10110-7
              imperfections, the ISO 10110-9 coating, the drawing number, and whether the
              part as turned meets its own form tolerance (polish required)

`part_spec(...)` builds the whole PartSpec from typed objects; `spec_of(settings)` from a
Settings (what `lathe-mirror spec`, `run` and the measured-profile check call). Lengths in
mm unless a name says otherwise.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

from ..enums import Mount
from ..errors import InputError
from ..lathe import DRILL_POINT_DEG, bore_drill_mm
from ..optics.zones import fillet_band
from .callouts import REVISION, AsTurned, Callouts, as_turned, callouts, drawing_number
from ..inputs import check_real, short
from .conic import CONVENTION, SAG_STEP_MM, Conic, lobe_conic, mirror_conics
from .form import FormTolerance, angular_scale, form_tolerances
from .texture import Texture, texture

if TYPE_CHECKING:
    from ..body import BodySpec
    from ..design import Mirror
    from ..job import MachiningJob
    from ..finish import Process
    from ..lathe import Stock
    from ..tolerance.spec import ToleranceSettings

__all__ = ["CONVENTION", "AsTurned", "Callouts", "Conic", "FormTolerance", "LobeSpecSheet", "PartSpec", "Texture",
           "lobe_conic", "mirror_conics", "part_spec", "spec_of"]

#: The blank's material (the lathe's feeds and the polishing model assume aluminium).
MATERIAL = "aluminium alloy EN AW-6061 T6 (AA 6061-T6), drawn bar, EN 755-2"


@dataclass(frozen=True)
class LobeSpecSheet:
    """One lobe: its conic, sag table (rows r_mm, sag_mm, slope_rad) and form tolerance."""

    conic: Conic
    sag_table: tuple[tuple[float, float, float], ...]
    form: FormTolerance

    def to_dict(self) -> dict:
        c = self.conic
        return {"name": c.name, "R_mm": c.R, "curvature_c_per_mm": c.curvature, "k": c.k,
                "vertex_z_mm": c.vertex_z, "vertex_above_pinhole_mm": c.above_pinhole, "clear_aperture_mm": list(c.clear_aperture),
                "focal_distance_2e_mm": c.focal_distance_2e, "a_mm": c.a, "b_mm": c.b,
                "zemax_even_asphere": {"radius_mm": c.R, "curvature_per_mm": c.curvature, "conic": c.k,
                                       "alpha": [0.0] * 8},
                "sag_table": [list(row) for row in self.sag_table],
                "form_tolerance": self.form.to_dict()}


@dataclass(frozen=True)
class PartSpec:
    """The part as the shop is asked to make it (see the module doc). clear_edge_mm: the
    band (mm) inside each lobe's edges outside its clear aperture; drill_point: (diameter
    mm, point deg) of the drill whose point the mount's bore may carry below its floor."""

    lobes: tuple[LobeSpecSheet, LobeSpecSheet]
    finish: Texture
    material: str
    process: str
    step_mm: float
    junction: dict
    notes: tuple[str, ...]
    callouts: Callouts
    as_turned: AsTurned | None = None
    clear_edge_mm: float = 0.0
    drill_point: tuple[float, float] | None = None

    @property
    def number(self) -> str:
        """The drawing number (callouts.drawing_number of the part's optical data)."""
        return drawing_number({"lobes": [lb.to_dict() for lb in self.lobes], "junction": self.junction,
                               "callouts": self.callouts.to_dict(), "material": self.material})

    @property
    def revision(self) -> str:
        return REVISION

    def lobe(self, name: str) -> LobeSpecSheet:
        return next(lb for lb in self.lobes if lb.conic.name == name)

    def __repr__(self) -> str:
        conics = ", ".join(f"{lb.conic.name} R {lb.conic.R:.6g} mm k {lb.conic.k:.6g}" for lb in self.lobes)
        return f"PartSpec({conics}; {self.material}, {self.process}; sag every {self.step_mm:g} mm)"

    def to_dict(self) -> dict:
        return {"convention": CONVENTION,
                "frame": "machine frame: Z = 0 at the mirror's vertex (the inner lobe's), part in -Z; r the radius",
                "sag_step_mm": self.step_mm,
                "lobes": [lb.to_dict() for lb in self.lobes], "junction": dict(self.junction),
                "finish": self.finish.to_dict(), "material": self.material, "process": self.process,
                "notes": list(self.notes), "drawing_number": self.number, "revision": self.revision,
                "callouts": self.callouts.to_dict(),
                "as_turned": None if self.as_turned is None else self.as_turned.to_dict(),
                "clear_edge_mm": self.clear_edge_mm,
                "drill_point": None if self.drill_point is None else {"diameter_mm": self.drill_point[0],
                                                                      "point_deg": self.drill_point[1]}}


def part_spec(mirror: Mirror, tolerance: ToleranceSettings, process: Process, *, wavelength_nm: float,
              body: BodySpec, resolution_mm: float, step: float = SAG_STEP_MM, material: str = MATERIAL,
              job: MachiningJob | None = None, clear_edge_mm: float = 0.0,
              drill_point: tuple[float, float] | None = None) -> PartSpec:
    """The PartSpec of `mirror` on the mounting `body`: conics over the radii the camera
    uses, sag tables every `step` mm, form tolerances from `tolerance`'s spec and drawn
    tolerances, the texture of the resolved `process` (finish.Process.resolved) at
    wavelength_nm (nm), the callouts (datums, runout, step and vertex tolerances at the
    lathe's resolution_mm, mm); with `job`, its part as turned against the form tolerance.
    clear_edge_mm: the band (mm) at each lobe's edges (the step, the rim) outside its clear
    aperture (polish.clear_edge_mm: the band a polish turns down). drill_point: (diameter mm,
    point deg) of the drill whose point the bore may carry below its floor (shop.boring)."""
    if not (isinstance(step, (int, float)) and math.isfinite(step) and 0.001 <= step <= 5.0):
        raise InputError(f"--step = {step!r} mm: allowed 0.001 to 5 mm")
    conics = mirror_conics(mirror, clear_edge_mm)
    cas = [c.clear_aperture for c in conics]
    forms = form_tolerances(mirror, cas, tolerance.spec, tolerance.tolerances, wavelength_nm=wavelength_nm,
                            depth_points=tolerance.depth_points)
    pixel = min(float(angular_scale(mirror, lobe, [0.5 * (lo + hi)])[0][0])
                for lobe, (lo, hi) in zip(mirror.lobes, cas))
    tex = texture(process, wavelength_nm=wavelength_nm, pixel_angle_rad=pixel)
    lobes = tuple(LobeSpecSheet(conic=c, sag_table=tuple(tuple(float(v) for v in row) for row in c.sag_table(step)),
                                form=f) for c, f in zip(conics, forms))
    zi, zo = mirror.junction_z
    _, fillet = fillet_band(mirror, tex.nose_radius_mm)
    junction = {"r_mm": mirror.r_junction, "step_mm": abs(mirror.step), "recessed": mirror.recessed,
                "z_inner_rim_mm": mirror.vertex_z - zi, "z_outer_edge_mm": mirror.vertex_z - zo,
                "fillet_radius_mm": tex.nose_radius_mm, "fillet_r_mm": None if fillet is None else list(fillet)}
    notes = (
        "Form tolerances: the allocation's rule (tolerance.allocation.inverse_sensitivity: each "
        "criterion's margin in squares split evenly among the drawn tolerances) with closed-form "
        "responses (a slope error d turns the image 2 d / g px, g the lobe's rad per pixel), not the "
        "traced Monte Carlo; the surface takes the shares of nose, polish time, tool X and Z; raw "
        "figures (conservative when the spec is judged after calibration).",
        "The paper's Table 1 'c' is the focal distance 2e (focal_distance_2e_mm); c here is 1/R.",
    )
    calls = callouts(mirror, conics, body, tolerance.tolerances, resolution_mm=resolution_mm)
    turned = None if job is None else as_turned(job, conics, forms, evaluation_length_mm=forms[0].evaluation_length_mm)
    return PartSpec(lobes=lobes, finish=tex, material=material, process=process.label, step_mm=float(step),
                    junction=junction, notes=notes, callouts=calls, as_turned=turned, clear_edge_mm=clear_edge_mm,
                    drill_point=drill_point)


def spec_of(settings, *, step: float = SAG_STEP_MM, process: str | None = None,
            as_turned: bool = False) -> PartSpec:
    """The PartSpec of a Settings (typed; the [tolerance], [polish], [tool], [machine],
    [cad] sections): the process named (default the first of [polish.process], the
    configured lathe and tool), resolved with the configured nose, finishing feed and
    resolution. as_turned: also cut the configured job's part (~1 s) and judge it against
    its form tolerance (the drawing's polish-required note)."""
    if not all(hasattr(settings, k) for k in ("polish", "tolerance", "tool", "machine", "mirror")):
        raise InputError(f"spec_of: settings = {short(settings)} ({type(settings).__name__}): expected a Settings "
                         "(lm.load())")
    check_real(step, "spec_of: step", unit="mm", above=0.0)
    procs = settings.polish.processes
    if process is None:
        proc = procs[0]
    else:
        found = [p for p in procs if p.name == process]
        if not found:
            raise InputError(f"--process = {process!r}: allowed {', '.join(p.name for p in procs)}")
        proc = found[0]
    proc = proc.resolved(nose_radius_mm=settings.tool.nose_radius, feed_mm=settings.machine.feed_finish,
                         resolution_mm=settings.machine.resolution)
    mirror = settings.mirror()
    drill_point = None
    if settings.body.mount is Mount.BORE:  # drilled for the boring bar, then bored (shop.boring)
        drill_point = (bore_drill_mm(settings.toolpath.boring_bar_min_bore_mm), DRILL_POINT_DEG)
    job = None
    if as_turned:
        from ..job import MachiningJob  # lazy: the planner and the envelope only when the part is cut

        job = MachiningJob.from_settings(settings, mirror)
    return part_spec(mirror, settings.tolerance, proc, wavelength_nm=settings.polish.wavelength_nm,
                     body=settings.body, resolution_mm=settings.machine.resolution, step=step, job=job,
                     clear_edge_mm=settings.polish.clear_edge_mm, drill_point=drill_point)
