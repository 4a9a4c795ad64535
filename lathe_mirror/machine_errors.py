"""A lathe that is not perfect: the set-up errors a turned part shows, and the surface
such a machine cuts along a program.

The programmed path is the nose centre's (toolpath.Toolpath.segments, machine frame: r
the radius, Z along the spindle, part in -Z, tool above it). The errors, each as the shop
sees it (`MachineErrors`, lengths mm, angles rad):

  centre_height_mm      the cutting edge above (+) or below (-) the spindle centre line:
                        a nose point at slide position x cuts radius sqrt(x^2 + h^2), so
                        radii under |h| are never cut and a pip stays at the centre (the
                        flank rubs it into a cone when the tool is above centre; a
                        cylindrical stub stands when it is below), as high as the stock the
                        finishing pass was to take (pip_height_mm)
  x_offset_mm           the tool's X zero off by this much (+: the nose stops short of the
                        axis): the part is the program's surface moved out in r, with an
                        ogive (a point) at the centre; (-): past the axis, a dimple
  nose_radius_error_mm  the insert's nose radius minus the programmed one, with the tool
                        set on its tip (touched off in X on a diameter and in Z on the face):
                        the nose centre sits dr farther out in X and up in Z than the
                        controller believes, and the edge is dr farther from it; the surface
                        moves by dr (1 - cos t, 1 - sin t) (X, Z) where t is the surface
                        normal's angle from the r axis, a normal offset dr (cos t + sin t - 1)
  squareness_rad        the X slide out of square with the spindle: Z drifts by eps x
  backlash_mm           lost motion of the X screw, the zero set approaching in -X: every
                        move that runs in +X lands backlash_mm short

`machined_with_errors` cuts the program's nose-centre path with these errors: a round
nose swept along the (displaced) centre path, sampled every SAMPLE_MM and evaluated on a
radial grid of GRID_MM (the lower envelope of the nose discs; with no error it is the
envelope nose_envelope.as_machined computes in closed form, to ~1e-6 mm).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from typing import TYPE_CHECKING

import numpy as np

from .declared.section import MICRO, setting
from .nose_envelope import grid_spans
from .profile import TabulatedProfile

if TYPE_CHECKING:
    from .design import Mirror
    from .toolpath import Toolpath

#: Spacing (mm) of the nose-centre samples along the path.
SAMPLE_MM = 0.0005
#: Radial spacing (mm) of the made surface's samples.
GRID_MM = 0.0005


@dataclass(frozen=True)
class MachineErrors:
    """Set-up errors of a lathe (module doc). Lengths mm, angles rad; all zero: a perfect
    machine."""

    centre_height_mm: float = setting("machine.errors.centre_height_mm")
    x_offset_mm: float = setting("machine.errors.x_offset_mm")
    nose_radius_error_mm: float = setting("machine.errors.nose_radius_error_mm")
    squareness_rad: float = setting("machine.errors.squareness_urad", MICRO)
    backlash_mm: float = setting("machine.errors.backlash_mm")

    def __post_init__(self) -> None:
        for f in fields(self):
            v = getattr(self, f.name)
            if not math.isfinite(v):
                raise ValueError(f"machine error {f.name} = {v!r} must be finite")
        if self.backlash_mm < 0:
            raise ValueError(f"backlash_mm = {self.backlash_mm!r} must be >= 0")

    @property
    def is_zero(self) -> bool:
        return all(getattr(self, f.name) == 0.0 for f in fields(self))

    def to_dict(self) -> dict[str, float]:
        return {f.name: float(getattr(self, f.name)) for f in fields(self)}


def centre_path(toolpath: Toolpath, errors: MachineErrors) -> tuple[np.ndarray, np.ndarray]:
    """Where the nose centre really goes (x, Z), mm, sampled every SAMPLE_MM along the
    program's moves in cutting order (displaced_centres)."""
    xs, zs = [], []
    for seg in toolpath.cutting_moves():
        p0, p1 = np.asarray(seg.start, float), np.asarray(seg.end, float)
        length = float(np.hypot(*(p1 - p0)))
        if hasattr(seg, "sweep"):
            length = max(length, abs(seg.sweep) * max(seg.radius, seg.end_radius))
        pts = seg.sample(max(int(math.ceil(length / SAMPLE_MM)) + 1, 2))
        xs.append(pts[:, 0])
        zs.append(pts[:, 1])
    return displaced_centres(np.concatenate(xs), np.concatenate(zs), errors)


def displaced_centres(x: np.ndarray, z: np.ndarray, errors: MachineErrors) -> tuple[np.ndarray, np.ndarray]:
    """The programmed nose-centre points (x, Z), mm, in cutting order, moved where the
    machine puts them: the X offset, the nose-setting error (dr, dr), backlash on the
    stretches cut in +X (the zero set approaching in -X), squareness (Z + eps x). x may come
    out negative (past the axis)."""
    x = np.asarray(x, float)
    z = np.asarray(z, float)
    step = np.diff(x, prepend=x[0])
    if step.size > 1:
        step[0] = step[1]
    # a point inherits the direction of the last move that changed X
    moving = np.where(np.abs(step) > 1e-12, np.sign(step), 0.0)
    idx = np.where(moving != 0, np.arange(moving.size), 0)
    np.maximum.accumulate(idx, out=idx)
    plus = moving[idx] > 0
    dr = errors.nose_radius_error_mm
    xp = x + errors.x_offset_mm + dr - np.where(plus, errors.backlash_mm, 0.0)
    zp = z + dr + errors.squareness_rad * xp
    return xp, zp


#: Margins that keep each disc's window (disc_windows) a superset of where it can be the
#: lowest: on the chord ratio (dimensionless), on the radii (mm), and the depth (mm) inside
#: a neighbour's disc below which the neighbour does not count as lower (well above the
#: rounding of the discs' heights, ~1e-14 mm: two centres a few ulps apart cover nothing).
WINDOW_K_PAD = 1e-9
WINDOW_X_PAD = 2e-6
ROUNDING_MM = 1e-11
#: Disc samples evaluated at once by disc_envelope.
BLOCK = 1 << 21


def disc_windows(xc: np.ndarray, zc: np.ndarray, rho: float) -> tuple[np.ndarray, np.ndarray]:
    """The radii (lo, hi), mm, between which the disc about each centre (xc, zc) can be the
    lowest of the discs (lo > hi: nowhere).

    A point of disc i's lower half in the direction u (p = c_i + rho u) lies strictly
    inside the disc about another centre c_j when u . d > |d|^2 / (2 rho), d = c_j - c_i,
    by u . d - |d|^2 / (2 rho); then disc j is strictly lower at that radius, and p is not
    the lowest point there. So the lowest disc at any radius is always inside its own
    window: the directions of the lower half that neither of its neighbours in the given
    order covers by more than ROUNDING_MM (any order is correct; the path's order makes the
    windows narrow, about the spacing of the centres).
    """
    n = xc.size
    half = math.pi / 2
    nb_beta = np.full((2, n), np.nan)
    nb_k = np.full((2, n), np.inf)
    for side, (a, b) in enumerate(((slice(1, None), slice(None, -1)), (slice(None, -1), slice(1, None)))):
        dx, dz = xc[b] - xc[a], zc[b] - zc[a]  # side 0: to the previous centre, side 1: to the next
        length = np.hypot(dx, dz)
        nb_beta[side, a] = np.arctan2(dz, dx)
        with np.errstate(divide="ignore"):
            nb_k[side, a] = length / (2 * rho) + WINDOW_K_PAD + ROUNDING_MM / length  # inf: a repeat
    # directions alpha in [-pi/2, pi/2] (u = (sin a, -cos a)); the neighbour covers
    # sin(alpha - beta) > k (u . d / |d| > |d| / (2 rho) and the margins), the open arc
    # beta + (asin k, pi - asin k)
    cuts = [np.full(n, -half), np.full(n, half)]
    for side in (0, 1):
        ok = nb_k[side] < 1
        w = np.arcsin(np.where(ok, nb_k[side], 0.0))
        for edge in (nb_beta[side] + w, nb_beta[side] + math.pi - w):
            e = (edge + math.pi) % (2 * math.pi) - math.pi
            cuts.append(np.where(ok & (e > -half) & (e < half), e, np.nan))
    cuts = np.sort(np.stack(cuts, axis=1), axis=1)  # nan last
    lo_c, hi_c = cuts[:, :-1], cuts[:, 1:]
    mid = 0.5 * (lo_c + hi_c)
    free = np.isfinite(mid)
    for side in (0, 1):
        beta, k = nb_beta[side][:, None], nb_k[side][:, None]
        free &= ~((k < 1) & (np.sin(mid - beta) > k))
    lo = np.where(free, lo_c, np.inf).min(axis=1)
    hi = np.where(free, hi_c, -np.inf).max(axis=1)
    some = lo <= hi
    x_lo = np.where(some, xc + rho * np.sin(np.where(some, lo, 0.0)) - WINDOW_X_PAD, np.inf)
    x_hi = np.where(some, xc + rho * np.sin(np.where(some, hi, 0.0)) + WINDOW_X_PAD, -np.inf)
    return x_lo, x_hi


def disc_envelope(xc: np.ndarray, zc: np.ndarray, rho: float, x: np.ndarray) -> np.ndarray:
    """Lowest point (mm) at each x of discs of radius rho (mm) centred at (xc, zc): the
    surface a round nose leaves. +inf where no disc reaches. x sorted ascending; the
    centres best in the path's order (each disc is evaluated only over its window,
    disc_windows)."""
    xc, zc = np.asarray(xc, float), np.asarray(zc, float)
    out = np.full(x.shape, np.inf)
    if xc.size == 0:
        return out
    keep = np.ones(xc.size, bool)  # a centre repeated (a move's end, the next one's start): one disc
    keep[1:] = (xc[1:] != xc[:-1]) | (zc[1:] != zc[:-1])
    xc, zc = xc[keep], zc[keep]
    x_lo, x_hi = disc_windows(xc, zc, rho)
    i0 = np.searchsorted(x, x_lo)  # beyond the disc's reach (h^2 < 0) it gives inf
    i1 = np.searchsorted(x, x_hi, side="right")
    ends = np.cumsum(np.maximum(i1 - i0, 0))
    # the discs in blocks of about BLOCK samples (a centre order far from the path's gives
    # wide windows: the memory stays bounded)
    cut = np.searchsorted(ends, np.arange(BLOCK, int(ends[-1]) + BLOCK, BLOCK), side="right")
    for a, b in zip(np.concatenate([[0], cut]), np.concatenate([cut, [xc.size]])):
        if b <= a:
            continue
        owner, idx = grid_spans(i0[a:b], i1[a:b], first=a)
        if idx.size == 0:
            continue
        d = x[idx] - xc[owner]
        h2 = rho * rho - d * d
        zz = np.where(h2 >= 0, zc[owner] - np.sqrt(np.maximum(h2, 0.0)), np.inf)
        np.minimum.at(out, idx, zz)
    return out


def machined_with_errors(toolpath: Toolpath, errors: MachineErrors, *, nose_radius: float | None = None,
                         pip_height_mm: float = 0.15) -> TabulatedProfile:
    """The surface (camera frame) the program's nose-centre path cuts on a lathe with
    `errors`: a nose of nose_radius (default toolpath.nose_radius, mm) + nose_radius_error_mm.
    pip_height_mm: the stock the finishing pass was to take (toolpath.rough_allowance),
    what stands at radii the edge never reaches."""
    rho = (toolpath.nose_radius if nose_radius is None else float(nose_radius)) + errors.nose_radius_error_mm
    if not rho > 0:
        raise ValueError(f"nose radius {rho:g} mm (programmed {toolpath.nose_radius:g} + error "
                         f"{errors.nose_radius_error_mm:g}) must be > 0")
    xc, zc = centre_path(toolpath, errors)
    return surface_from_centres(toolpath.mirror, xc, zc, rho, errors.centre_height_mm, pip_height_mm=pip_height_mm)


def surface_from_centres(m: Mirror, xc: np.ndarray, zc: np.ndarray, rho: float, centre_height_mm: float, *,
                         pip_height_mm: float = 0.15) -> TabulatedProfile:
    """The turned surface (camera frame, on mirror m's lobes and machine frame) that a nose
    of radius rho (mm) leaves along the real centre points (xc, zc) (mm, machine frame)
    with the edge centre_height_mm above the spindle centre (module doc)."""
    r = np.arange(0.0, m.r_max + GRID_MM / 2, GRID_MM)
    r[-1] = min(r[-1], m.r_max)
    if m.step <= 0:  # the inner lobe stands proud: its rim just inside the wall's line
        r = np.where(r == m.r_junction, np.nextafter(m.r_junction, 0.0), r)
    h = abs(centre_height_mm)
    # the slide positions that reach radius r: +/- sqrt(r^2 - h^2)
    xr = np.sqrt(np.maximum(r * r - h * h, 0.0))
    grid = np.union1d(-xr, xr)
    env = disc_envelope(xc, zc, rho, grid)
    zpos = np.interp(xr, grid, env)
    zneg = np.interp(-xr, grid, env)
    zm = np.minimum(zpos, zneg)
    reached = (r >= h) & np.isfinite(zm)
    edge = zm[reached][0] if np.any(reached) else 0.0
    top = edge + pip_height_mm
    zm = np.where(np.isfinite(zm), zm, top)
    inside = r < h
    if np.any(inside):
        if centre_height_mm > 0:  # above centre: a cone, the flank rubbing it
            zm = np.where(inside, top - (top - edge) * r / h, zm)
        else:  # below centre: a cylindrical stub
            zm = np.where(inside, top, zm)
    z = m.vertex_z - zm  # camera frame
    lobes = []
    for k in (0, 1):
        sel = (r <= m.r_junction) if k == 0 else (r > m.r_junction)
        rr, zz = r[sel], z[sel]
        s = np.gradient(zz, rr) if rr.size > 1 else np.zeros_like(zz)
        lobes.append((rr, zz, s))
    return TabulatedProfile(lobes[0], lobes[1], r_junction=m.r_junction, r_max=m.r_max, vertex_z=m.vertex_z)
