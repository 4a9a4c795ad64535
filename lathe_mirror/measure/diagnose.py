"""The machine's set-up errors read off a fitted trace, each as the correction a machinist
makes (machine_errors.MachineErrors names them).

What is compared: the trace's residual (measured minus design) less what the same
program leaves on a perfect machine (the nominal as-machined surface: the lattice, the
arcs, the nose's fillet), folded about the fitted axis. In it:

- centre height: the pip at the centre. Radii under |h| are never cut; the pip's radius is
  |h|, found by fitting a cone (tool above centre: the flank rubs it to a point) and a
  cylindrical stub (tool below centre) to the points near the axis and keeping the better.
  The h^2 / (2 R)-like change of the rest of the surface is subtracted before the next step.
- the rest, by robust linear least squares over the lobes (the fit's mask, away from the
  pip) on the first-order signatures (Z up, z' the design's slope dz/dr >= 0):
    X offset dx:        z'(r) dx          (the surface moved out in r: an ogive at the centre)
    nose error dr:      dr (1 + sigma z' - sqrt(1 + z'^2)), the tool touched off as its set-up
                        sheet says (TouchOff): Z with the nose's bottom on the face, so the
                        centre sits dr higher than the controller believes; X with the nose's
                        +X side on a bore (sigma = -1: the centre sits dr nearer the axis) or
                        its -X side on an outside diameter (sigma = +1: dr farther out); the
                        edge is dr farther from the centre. The height change is the normal
                        offset dr (sigma cos t + sin t - 1) at the normal's angle t over sin t.
                        Both columns z' and the nose's differ by dr (sqrt(1 + z'^2) - 1) only:
                        the wrong convention turns a nose error into an X offset of -/+ 2 dr
    squareness eps:     eps r
    a piston per lobe   (the fit's piston; the step's height)
    backlash b:         -z'(r) b where the program cut r in +X (measure.backlash: only
                        where the finishing moves reverse X over the trace; a pass all in
                        +X moves as a whole, b is then part of the X offset; one all in -X
                        is untouched by it)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..machine_errors import MachineErrors
from ..profile import ExactProfile, Profile
from .backlash import directions_at, note, observability
from .fit import TraceFit, design_z

#: Radius (mm) about the axis searched for the centre pip.
PIP_SEARCH_MM = 0.5
#: Lowest pip (mm) taken for one: a turned centre pip stands as high as the finishing
#: pass's stock (tens of um); a smooth form error is not one.
MIN_PIP_MM = 0.002
#: A set-up error is named only where its signature carries at least this fraction of the
#: residual's RMS (else it is the part's form, for `compensate`, not a set-up entry).
MIN_SHARE = 0.3
#: ... and only where the signatures together explain at least this fraction of it.
MIN_EXPLAINED = 0.5


@dataclass(frozen=True)
class TouchOff:
    """How the tool's offsets were set (the set-up sheet's convention, shop.setup.Offsets):
    Z with the nose's bottom on the face (entered: the face + the nose radius); X on a
    "bore" with the nose's +X side (entered D - 2 rho) or an "outside" diameter with its -X
    side (D + 2 rho). It decides where a nose radius error puts the nose centre."""

    x_side: str = "bore"

    def __post_init__(self) -> None:
        if self.x_side not in ("bore", "outside"):
            raise ValueError(f"touch-off x_side = {self.x_side!r}: allowed bore, outside")

    @property
    def sigma(self) -> float:
        """Where a nose radius error dr puts the centre in X: sigma dr (-1 bore, +1 outside)."""
        return -1.0 if self.x_side == "bore" else 1.0

    def describe(self) -> str:
        x = ("X on a bore with the nose's +X side (entered D - 2 rho)" if self.x_side == "bore"
             else "X on an outside diameter with the nose's -X side (entered D + 2 rho)")
        return f"touch-off as the set-up sheet says: Z on the face with the nose's bottom (entered face + rho), {x}"

    def to_dict(self) -> dict:
        return {"z": "face, the nose's bottom", "x": ("bore, the nose's +X side" if self.x_side == "bore"
                                                      else "outside diameter, the nose's -X side"),
                "x_side": self.x_side, "text": self.describe()}


@dataclass(frozen=True)
class Diagnosis:
    """Set-up errors found in a trace (mm, rad) with their 1-sigma uncertainties, and the
    corrections (one line each)."""

    centre_height_mm: float
    centre_pip: str | None
    pip_height_um: float
    x_offset_mm: float
    nose_radius_error_mm: float
    nose_radius_mm: float
    squareness_rad: float
    sigma: dict
    corrections: tuple[str, ...]
    programmed_nose_mm: float
    backlash_mm: float | None = None
    backlash_state: str = "unknown"
    touch_off: TouchOff = TouchOff()
    entries: dict | None = None  # what the corrections ask the machinist to enter (_corrections)

    def errors(self) -> MachineErrors:
        """The machine errors found, as the simulation takes them: machine_errors models a
        nose error touched off on an outside diameter (the centre dr farther out); touched
        off on a bore it sits dr nearer the axis, the same centre as an X offset 2 dr less."""
        x_sim = self.x_offset_mm + (self.touch_off.sigma - 1.0) * self.nose_radius_error_mm
        return MachineErrors(centre_height_mm=self.centre_height_mm, x_offset_mm=x_sim,
                             nose_radius_error_mm=self.nose_radius_error_mm, squareness_rad=self.squareness_rad,
                             backlash_mm=max(self.backlash_mm or 0.0, 0.0))

    def to_dict(self) -> dict:
        return {"nose_radius_error_mm": self.nose_radius_error_mm, "nose_radius_mm": self.nose_radius_mm,
                "programmed_nose_radius_mm": self.programmed_nose_mm,
                "centre_height_mm": self.centre_height_mm, "centre_pip": self.centre_pip,
                "pip_height_um": self.pip_height_um, "x_offset_mm": self.x_offset_mm,
                "squareness_rad": self.squareness_rad, "backlash_mm": self.backlash_mm,
                "backlash": self.backlash_state, "backlash_note": note(self.backlash_state),
                "sigma": self.sigma, "corrections": list(self.corrections),
                "touch_off": self.touch_off.to_dict(), "entries": self.entries}


def nose_signature(slope: np.ndarray, sigma: float = 1.0) -> np.ndarray:
    """Height change (mm) per mm of nose radius error at design slope dz/dr, the tool
    touched off in Z on the face and in X on an outside diameter (sigma = +1) or a bore
    (sigma = -1): 1 + sigma z' - sqrt(1 + z'^2) (module doc)."""
    s = np.abs(np.asarray(slope, float))
    return 1.0 + sigma * s - np.sqrt(1.0 + s * s)


def diagnose(fit: TraceFit, nominal: Profile, programmed_nose_mm: float, *,
             resolution_mm: float = 0.005, toolpath=None, touch_off: TouchOff = TouchOff()) -> Diagnosis:
    """The set-up errors in `fit` against the program's nominal as-machined surface
    `nominal` (camera frame) cut with a nose of programmed_nose_mm (module doc).
    resolution_mm: the controller's increment, below which a correction is not worth
    entering. toolpath: the program the part was cut with (its finishing moves' X
    directions: the backlash; None: not judged). touch_off: how the offsets were set (the
    job's set-up sheet): where a nose radius error puts the centre."""
    from scipy.optimize import least_squares

    m = fit.mirror
    zd, dzd = design_z(m)
    exact = ExactProfile(m)
    r = fit.r
    # measured minus the perfect machine's part (both against the design)
    d = fit.resid - (exact.z(r) - nominal.z(r))

    # 1) the centre pip
    h, kind, H = _pip(r, d, fit)
    # 2) what a centre height does to the rest of the surface
    rr = np.sqrt(np.maximum(r * r - h * h, 0.0))
    d = d - (zd(rr) - zd(r))

    sel = fit.used & (r > max(PIP_SEARCH_MM, 3.0 * h))
    rs, ds = r[sel], d[sel]
    slope = -dzd(rs)
    inner = rs <= m.r_junction
    cols = np.stack([inner.astype(float), (~inner).astype(float), slope, rs, nose_signature(slope, touch_off.sigma)], axis=1)
    if not np.any(~inner):
        cols = np.delete(cols, 1, axis=1)
    names = ["p_in", "p_out", "dx", "eps", "dr"] if np.any(~inner) else ["p_in", "dx", "eps", "dr"]
    plus = None if toolpath is None else directions_at(toolpath, rs, slope) > 0
    state = observability(plus)
    if state == "fitted":  # the +X part moved in by b against the -X part
        cols = np.concatenate([cols, (-slope * plus)[:, None]], axis=1)
        names.append("bl")
    scale = np.array([1e-3 if n.startswith("p") or n in ("dx", "dr", "bl") else 1e-6 for n in names])
    A = cols * scale
    q0 = np.linalg.lstsq(A, ds, rcond=None)[0]
    r0 = ds - A @ q0
    f_scale = max(3.0 * 1.4826 * float(np.median(np.abs(r0 - np.median(r0)))), 1e-6)
    sol = least_squares(lambda q: A @ q - ds, q0, loss="soft_l1", f_scale=f_scale, method="trf")
    q = sol.x * scale
    res = ds - cols @ q
    sig2 = float(np.mean(res ** 2))
    try:
        cov = np.linalg.inv(cols.T @ cols) * sig2
        sd = np.sqrt(np.maximum(np.diag(cov), 0.0))
    except np.linalg.LinAlgError:
        sd = np.full(len(names), np.nan)
    got = dict(zip(names, q))
    sigma = {"x_offset_mm": float(sd[names.index("dx")]), "nose_radius_error_mm": float(sd[names.index("dr")]),
             "squareness_rad": float(sd[names.index("eps")]),
             "centre_height_mm": float(max(np.median(np.diff(np.sort(fit.trace.x))), 0.0))}
    dx, dr, eps = float(got["dx"]), float(got["dr"]), float(got["eps"])
    # the residual's form (pistons out) and each signature's share of it
    pist = [n for n in names if n.startswith("p")]
    form = ds - cols[:, :len(pist)] @ q[:len(pist)]
    total = float(np.sqrt(np.mean(form ** 2))) or 1e-12
    fitted = [n for n in ("dx", "dr", "eps", "bl") if n in names]
    share = {n: float(np.sqrt(np.mean((cols[:, names.index(n)] * got[n]) ** 2))) / total for n in fitted}
    explained = 1.0 - float(np.sqrt(np.mean(res ** 2))) / total
    keep = {n: share[n] >= MIN_SHARE and explained >= MIN_EXPLAINED for n in share}
    dx, dr, eps = (dx if keep["dx"] else 0.0), (dr if keep["dr"] else 0.0), (eps if keep["eps"] else 0.0)
    bl, sigma["backlash_mm"] = None, None
    if "bl" in names:
        bl = float(got["bl"]) if keep["bl"] else 0.0
        sigma["backlash_mm"] = float(sd[names.index("bl")])
    sigma["explained_fraction"] = explained
    sigma["unexplained_rms_um"] = float(np.sqrt(np.mean(res ** 2))) * 1e3  # what no set-up error explains
    sigma["share_of_residual"] = {"x_offset": share["dx"], "nose_radius_error": share["dr"], "squareness": share["eps"],
                                  **({"backlash": share["bl"]} if "bl" in share else {})}
    corrections, entries = _corrections(h, kind, dx, dr, eps, programmed_nose_mm, resolution_mm, sigma)
    corrections.append(_backlash_line(bl, state, sigma, resolution_mm))
    if explained < MIN_EXPLAINED:
        corrections.append(f"the set-up signatures explain {100 * max(explained, 0):.0f} % of the residual: it is "
                           "the part's form (compensate or polish), not a set-up error")
    return Diagnosis(centre_height_mm=h if kind != "stub" else -h, centre_pip=kind, pip_height_um=H * 1e3,
                     x_offset_mm=dx, nose_radius_error_mm=dr, nose_radius_mm=programmed_nose_mm + dr,
                     squareness_rad=eps, sigma=sigma, corrections=tuple(corrections),
                     programmed_nose_mm=programmed_nose_mm, backlash_mm=bl, backlash_state=state,
                     touch_off=touch_off, entries=entries)


def _backlash_line(bl: float | None, state: str, sigma: dict, res: float) -> str:
    """The backlash's line: a correction when fitted and significant, else what the part
    can and cannot tell (measure.backlash.note)."""
    if state != "fitted":
        return note(state)
    lim = max(3 * sigma["backlash_mm"], res / 2)
    if bl is not None and abs(bl) >= lim:
        if bl < 0:
            return (f"backlash {bl:+.4f} mm (+/- {sigma['backlash_mm']:.2g}): the +X moves land past the -X "
                    "ones, not short: the zero was not set approaching in -X; re-set it so")
        return (f"backlash {bl:.4f} mm (+/- {sigma['backlash_mm']:.2g}): enter it in the controller's backlash "
                "compensation (LinuxCNC [JOINT_0]BACKLASH, Fanuc parameter 1851)")
    return f"backlash: none beyond +/- {lim:.4f} mm (the finishing moves reverse X: fitted {bl or 0.0:+.4f} mm)"


def centre_pip(fit: TraceFit) -> tuple[float, str | None, float]:
    """The centre pip of a fitted trace against the design alone (no program at hand):
    (radius mm, "cone" | "stub" | None, height mm)."""
    return _pip(fit.r, fit.resid, fit)


def _pip(r: np.ndarray, d: np.ndarray, fit: TraceFit) -> tuple[float, str | None, float]:
    """The centre pip: (radius |h| mm, "cone" | "stub" | None, height mm)."""
    ring = (r > PIP_SEARCH_MM) & (r < 3 * PIP_SEARCH_MM)
    near = r <= PIP_SEARCH_MM
    if np.count_nonzero(near) < 5 or np.count_nonzero(ring) < 5:
        return 0.0, None, 0.0
    # the surface around the pip: a + b r^2 fitted on the ring outside it, carried in
    A = np.stack([np.ones(np.count_nonzero(ring)), r[ring] ** 2], axis=1)
    coef = np.linalg.lstsq(A, d[ring], rcond=None)[0]
    e = d[near] - (coef[0] + coef[1] * r[near] ** 2)
    rn = r[near]
    noise = 1.4826 * float(np.median(np.abs(np.diff(d[ring])))) / np.sqrt(2.0)
    threshold = max(6.0 * noise, MIN_PIP_MM)
    if float(np.max(e)) < threshold:
        return 0.0, None, 0.0
    hs = np.arange(0.0005, PIP_SEARCH_MM, 0.0005)
    best = (np.inf, 0.0, None, 0.0)
    for kind in ("cone", "stub"):
        shape = (np.clip(1.0 - rn[None, :] / hs[:, None], 0.0, None) if kind == "cone"
                 else (rn[None, :] < hs[:, None]).astype(float))
        num = (shape * e[None, :]).sum(axis=1)
        den = (shape * shape).sum(axis=1)
        H = np.where(den > 0, num / np.where(den > 0, den, 1.0), 0.0)
        sse = ((e[None, :] - H[:, None] * shape) ** 2).sum(axis=1)
        i = int(np.argmin(sse))
        if sse[i] < best[0] and H[i] > threshold:
            best = (float(sse[i]), float(hs[i]), kind, float(H[i]))
    if best[2] is None or best[1] > 0.8 * PIP_SEARCH_MM:  # not a pip: the form of the surface
        return 0.0, None, 0.0
    return best[1], best[2], best[3]


def _corrections(h, kind, dx, dr, eps, nose0, res, sigma) -> tuple[list[str], dict]:
    """The lines, and the entries they ask for (mm: the tool's height change, + up; the X
    zero's move, + toward the axis; the nose radius for the tool table)."""
    out = []
    made = {"raise_tool_mm": 0.0, "x_zero_toward_axis_mm": 0.0, "nose_radius_mm": nose0}
    if kind is not None:
        made["raise_tool_mm"] = -h if kind == "cone" else h
        if kind == "cone":
            out.append(f"lower the tool {h:.3f} mm: it cuts {h:.3f} mm above the spindle centre "
                       "(a cone-shaped pip at the centre)")
        else:
            out.append(f"raise the tool {h:.3f} mm: it cuts {h:.3f} mm below the spindle centre "
                       "(a cylindrical stub at the centre)")
    else:
        out.append("centre height: no pip at the centre (within the trace's spacing)")
    nose = nose0 + dr
    if abs(dr) >= max(3 * sigma["nose_radius_error_mm"], 0.0005):
        made["nose_radius_mm"] = nose
        out.append(f"nose radius {nose:.3f} mm (programmed {nose0:g} mm): enter it in the tool table "
                   "and re-plan the program for it")
    else:
        out.append(f"nose radius: as programmed ({nose0:g} mm, within {max(3 * sigma['nose_radius_error_mm'], 0.0005):.4f} mm)")
    if abs(dx) >= max(3 * sigma["x_offset_mm"], res / 2):
        way = "toward the axis" if dx > 0 else "away from the axis"
        made["x_zero_toward_axis_mm"] = dx
        out.append(f"X offset {dx:+.4f} mm: move the tool's X zero {abs(dx):.4f} mm {way} "
                   f"({'an ogive' if dx > 0 else 'a dimple'} at the centre)")
    else:
        out.append(f"X offset: none beyond the lattice ({dx:+.4f} mm)")
    if abs(eps) >= max(3 * sigma["squareness_rad"], 5e-6):
        out.append(f"X slide out of square with the spindle by {eps * 1e6:+.1f} urad: realign the cross slide "
                   "(not a set-up entry)")
    return out, made
