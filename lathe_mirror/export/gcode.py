"""G-code for the lathe: LinuxCNC and Fanuc-style dialects of the same program.

Machine frame (ARCHITECTURE.md): Z = 0 at the mirror's vertex, part in -Z; X is 2r in
diameter mode (LinuxCNC G7, Fanuc's default) or r (G8). Every coordinate of the
finishing contour is a lattice value and is written exactly (as many decimals as the
resolution needs). The nose compensation is ours: the program moves the nose CENTRE
(the tool's offsets, G43 / T0101, must be set to the nose centre), because controller
compensation over hundreds of very short moves gouges. A program whose as-machined
surface would lie inside the part by more than the gouge tolerance is refused.

Program: header comments (design, machine, tool, strategy, budget, figures); set-up;
roughing passes from the stock (Z levels, then a semi-finishing pass that leaves
`rough_allowance` mm); the finishing contour between the comments "finish contour
begin" / "finish contour end"; retract; M5; M30.
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..errors import InputError
from ..lathe import Stock
from ..path import Arc, Line

if TYPE_CHECKING:
    from ..design import Mirror
    from ..settings import Settings
    from ..toolpath import Toolpath


class Dialect(enum.Enum):
    """G-code dialects: LinuxCNC (checked with its rs274 interpreter) and Fanuc-style."""

    LINUXCNC = "linuxcnc"
    FANUC = "fanuc"


def parse_dialect(name: str) -> Dialect:
    """Dialect by name; InputError names the allowed ones."""
    try:
        return Dialect(name)
    except ValueError:
        raise InputError(
            f"--dialect {name!r}: unknown dialect; allowed: {', '.join(d.value for d in Dialect)}"
        ) from None


@dataclass(frozen=True)
class ProgramOptions:
    """Knobs of a program. Lengths in mm.

    rough_depth: depth of each roughing level (more: fewer passes, heavier cuts).
    rough_allowance: stock left on the profile for the finishing pass.
    clearance: height above the work for rapid moves.
    gouge_tolerance: deepest the as-machined surface may lie inside the exact part.
    """

    rough_depth: float = 1.0
    rough_allowance: float = 0.15
    clearance: float = 2.0
    gouge_tolerance: float = 0.005


def program(toolpath: Toolpath, stock: Stock, dialect: Dialect = Dialect.LINUXCNC, *,
            options: ProgramOptions = ProgramOptions(), name: str = "mirror") -> str:
    """The whole program as text. Raises InputError if it would gouge the part, leave
    the lathe's travel, or the stock cannot hold the mirror."""
    from ..nose_envelope import gouge_depth
    from ..toolpath import check_travel, profile_errors, usable_ranges

    lathe, m = toolpath.lathe, toolpath.mirror
    if stock.radius <= m.r_max:
        raise InputError(f"stock.diameter = {stock.diameter:g} mm: must exceed the mirror's "
                         f"diameter {2 * m.r_max:g} mm")
    rim_depth = -(m.vertex_z - float(m.outer.z(m.r_max)))
    if stock.length < rim_depth + options.clearance:
        raise InputError(f"stock.length = {stock.length:g} mm: the mirror is {rim_depth:.3f} mm deep; "
                         f"allowed >= {rim_depth + options.clearance:.3f} mm")
    depth = gouge_depth(toolpath)
    if depth > options.gouge_tolerance:
        raise InputError(
            f"the {toolpath.strategy.value} toolpath would gouge the part by {depth:.4f} mm "
            f"(toolpath.gouge_tolerance = {options.gouge_tolerance:g} mm); program refused "
            "(more points, a finer machine.resolution or another strategy cut closer)"
        )
    from ..nose_envelope import as_machined

    made = as_machined(toolpath)
    figures = profile_errors(made, m)
    used = profile_errors(made, m, r_ranges=usable_ranges(m))
    rough_paths = _roughing_paths(toolpath, stock, options)
    rough = np.concatenate([np.asarray(p, dtype=float) for p in rough_paths])
    finish_exit = _finish_exit(toolpath, stock, options)
    check_travel(np.concatenate([toolpath.points(), rough, finish_exit]), lathe, what="the program")
    w = _Writer(lathe, dialect)
    w.header(toolpath, stock, options, figures, used, depth, name)
    w.setup()
    w.comment("roughing: Z levels, then a semi-finishing pass")
    w.feed(lathe.feed_rough)
    for path in rough_paths:
        w.rapid(path[0])
        for p in path[1:-1]:
            w.line(p)
        w.rapid(path[-1])
        w.rapid((path[0][0], path[-1][1]))  # back out at the retract height, never diagonal
    w.comment("finish contour approach")
    start = toolpath.segments[0].start
    w.rapid((start[0], _ceil(options.clearance, lathe.resolution)))  # on the lattice
    w.feed(lathe.feed_finish)
    w.comment("finish contour begin")
    w.line(start)
    for seg in toolpath.segments:
        if isinstance(seg, Line):
            w.line(seg.end)
        else:
            w.arc(seg)
    w.comment("finish contour end")
    w.line(tuple(finish_exit[0]))
    w.rapid(tuple(finish_exit[1]))
    w.rapid(tuple(finish_exit[2]))
    w.end()
    return w.text()


def write_program(path: str | Path, toolpath: Toolpath, stock: Stock, dialect: Dialect = Dialect.LINUXCNC,
                  *, options: ProgramOptions = ProgramOptions(), name: str = "mirror") -> Path:
    """Write the program atomically (nothing is written if it is refused)."""
    from .files import write_text

    return write_text(path, program(toolpath, stock, dialect, options=options, name=name))


def program_options(settings: Settings) -> ProgramOptions:
    """The program knobs of the [toolpath] settings."""
    t = settings.toolpath
    return ProgramOptions(rough_depth=t.rough_depth, rough_allowance=t.rough_allowance,
                          clearance=t.clearance, gouge_tolerance=t.gouge_tolerance)


def reference_programs(settings: Settings, mirror: Mirror) -> dict[str, str]:
    """The mirror's programs: {file name: text} for the paper method and the best
    strategy, in both dialects, with the settings' lathe, tool and stock."""
    from ..enums import BEST, Strategy
    from ..pipeline import plan

    opts = program_options(settings)
    out = {}
    for strategy in (Strategy.PAPER, BEST):
        tp = plan(mirror, settings.machine, settings.tool, strategy)
        for dialect, ext in ((Dialect.LINUXCNC, "ngc"), (Dialect.FANUC, "nc")):
            out[f"mirror_{strategy.value}.{ext}"] = program(tp, settings.stock, dialect, options=opts,
                                                            name=f"mirror_{strategy.value}")
    return out


# --------------------------------------------------------------------------------------
# Roughing


def _part_z(mirror, r: np.ndarray) -> np.ndarray:
    """Machine Z of the exact part's top at radius r (a flat shoulder beyond the rim)."""
    rr = np.minimum(r, mirror.r_max)
    z = np.where(rr <= mirror.r_junction, mirror.inner.z(rr), mirror.outer.z(rr))
    return mirror.vertex_z - z


def _roughing_paths(toolpath, stock: Stock, options: ProgramOptions) -> list[list[tuple]]:
    """Facing passes, level by level from the stock's face, feeding toward the axis, then
    a semi-finishing pass along the profile offset by the allowance. Each path: a rapid
    to its first point, feed moves, a rapid away at its last point."""
    lathe, m = toolpath.lathe, toolpath.mirror
    res = lathe.resolution
    rho = toolpath.nose_radius
    allow = options.rough_allowance + rho
    r_out = math.ceil((stock.radius + options.clearance) / res) * res
    r = np.arange(0.0, stock.radius + res, 0.01)
    # where the nose centre may go at each radius: the part's top + allowance, widened by
    # the nose (a disc of radius allow around the part must stay uncut)
    top = _part_z(m, r) + allow
    # a column's floor is the highest part top within +-allow of it (the wall included)
    k = int(math.ceil(allow / 0.01))
    floor = top.copy()
    for s in range(1, k + 1):
        floor[s:] = np.maximum(floor[s:], top[:-s])
        floor[:-s] = np.maximum(floor[:-s], top[s:])
    z_face = stock.face_allowance
    paths = []
    level = z_face
    prev = z_face + options.clearance
    while True:
        level -= options.rough_depth
        if level <= float(floor.min()):
            break
        free = floor < level
        if not np.any(free):
            prev = level
            continue
        # intervals of free columns
        edges = np.flatnonzero(np.diff(np.concatenate([[0], free.astype(int), [0]])))
        for a, b in zip(edges[::2], edges[1::2]):
            ra, rb = r[a], r[b - 1]
            zl = _ceil(level, res)
            za = _ceil(prev, res)
            outer = r_out if b >= len(r) else _floor(rb, res)
            # out at the previous level's height (cleared), down outside the cut, feed in
            paths.append([(outer, za), (outer, zl), (_ceil(ra, res), zl), (_ceil(ra, res), za)])
        prev = level
    # semi-finish: the profile offset by the allowance, 0.5 mm chords (a convex lobe's
    # chords sag below the offset curve by k L^2 / 8 < 0.002 mm), rounded away from it
    def offset_pts(lobe, rr):
        s = lobe.slope(rr)
        q = np.sqrt(1 + s * s)
        return rr + allow * s / q, m.vertex_z - lobe.z(rr) + allow / q

    pr, pz = offset_pts(m.inner, np.arange(0.0, m.r_junction, 0.5))
    keep = pr < m.r_junction - allow
    r_w = _floor(m.r_junction - allow, res)
    semi = [(_floor(a, res), _ceil(b, res)) for a, b in zip(pr[keep], pz[keep])]
    z_foot = _ceil(float(pz[keep][-1]), res)
    semi.append((r_w, z_foot))
    # up the wall to above the step's top corner by the allowance, then onto the outer lobe
    zt = m.vertex_z - float(m.outer.z(m.r_junction))
    semi.append((r_w, _ceil(zt + 2 * allow, res)))
    pr, pz = offset_pts(m.outer, np.union1d(np.arange(m.r_junction, m.r_max, 0.5), [m.r_max]))
    semi += [(_ceil(a, res), _ceil(b, res)) for a, b in zip(pr, pz)]
    z_top = _ceil(z_face + options.clearance, res)
    paths.append([(0.0, z_top)] + semi + [(r_out, semi[-1][1]), (r_out, z_top)])
    return paths


def _finish_exit(toolpath, stock: Stock, options: ProgramOptions) -> np.ndarray:
    """After the rim: feed out past the stock at the rim's height (facing the shoulder),
    then retract in Z and back toward the axis."""
    res = toolpath.lathe.resolution
    end = toolpath.segments[-1].end
    r_out = math.ceil((stock.radius + options.clearance) / res) * res
    z_up = math.ceil((stock.face_allowance + options.clearance) / res) * res
    return np.array([[r_out, end[1]], [r_out, z_up], [0.0, z_up]])


def _ceil(v: float, res: float) -> float:
    return math.ceil(v / res - 1e-9) * res


def _floor(v: float, res: float) -> float:
    return math.floor(v / res + 1e-9) * res


# --------------------------------------------------------------------------------------
# Writing


class _Writer:
    def __init__(self, lathe, dialect: Dialect) -> None:
        self.lathe, self.dialect = lathe, dialect
        self.lines: list[str] = []
        self.res = lathe.resolution
        self.dec = lathe.decimals
        self.mode = None

    def num(self, v: float) -> str:
        k = int(round(v / self.res))
        if abs(k * self.res - v) > 1e-7:
            raise RuntimeError(f"coordinate {v!r} is not on the lattice")
        s = f"{k * self.res:.{self.dec}f}"
        return "0." + "0" * self.dec if s.startswith("-0.") and float(s) == 0 else s

    def xword(self, r: float) -> str:
        k = int(round(r / self.res))
        if abs(k * self.res - r) > 1e-7:
            raise RuntimeError(f"radius {r!r} is not on the lattice")
        x = k * self.res * (2 if self.lathe.diameter_mode else 1)
        return f"X{x:.{self.dec}f}"

    def emit(self, s: str) -> None:
        self.lines.append(s)

    def comment(self, text: str) -> None:
        # neither dialect allows parentheses inside a comment
        self.emit("(" + text.replace("(", "[").replace(")", "]") + ")")

    def header(self, tp, stock, options, figures, used, depth, name) -> None:
        lathe, tool, m = tp.lathe, tp.tool, tp.mirror
        if self.dialect is Dialect.FANUC:
            self.emit("%")
            self.emit("O1000 (" + name.upper().replace("(", "").replace(")", "") + ")")
        else:
            self.emit("%")
        c = self.comment
        c(f"lathe-mirror {name}: double-lobed hyperbolic mirror, {self.dialect.value} dialect")
        c("machine frame: Z = 0 at the vertex, part in -Z; X = "
          + ("diameter" if lathe.diameter_mode else "radius") + "; mm")
        for lobe in m.lobes:
            c(f"design {lobe.name}: r_top {lobe.r_top:g} a {lobe.a:.4f} b {lobe.b:.4f} e {lobe.e:.4f} "
              f"c {lobe.c:.4f} h {lobe.h:.4f} mm alpha {math.degrees(lobe.alpha):.3f} deg")
        c(f"junction r {m.r_junction:g} mm, step {abs(m.step):.4f} mm, {m.recessed} lobe recessed")
        c(f"machine: resolution {lathe.resolution:g} mm, budget {lathe.max_points} points, "
          f"spindle cap {lathe.spindle_max_rpm} rpm, {lathe.surface_speed:g} m/min, "
          f"feeds {lathe.feed_rough:g}/{lathe.feed_finish:g} mm/rev")
        c(f"tool T1: nose radius {tool.nose_radius:g} mm, included {math.degrees(tool.included_angle):g} deg, "
          f"approach {math.degrees(tool.approach_angle):g} deg; offsets set to the NOSE CENTRE")
        c(f"stock: diameter {stock.diameter:g} mm, face allowance {stock.face_allowance:g} mm")
        n_arcs = sum(1 for s in tp.segments if isinstance(s, Arc))
        c(f"strategy {tp.strategy.value}: {len(tp.segments)} moves, {n_arcs} arcs, "
          f"{tp.n_points} of {lathe.max_points} points used")
        c(f"gouge check: deepest point inside the part {depth:.4f} mm, tolerance {options.gouge_tolerance:g} mm")
        from ..nose_envelope import junction_fillet

        fillet = junction_fillet(tp)
        if fillet is not None:
            c(f"junction fillet: the nose cannot reach the inside corner; the inner lobe is "
              f"filleted from r {fillet['r_start_mm']:.3f} to {fillet['r_end_mm']:g} mm, "
              f"{fillet['height_mm']:.3f} mm up the wall; the whole-lobe figures include it")
        for lobe in figures["lobes"]:
            nd, se = lobe["normal_deviation_mm"], lobe["slope_error_rad"]
            c(f"as machined {lobe['name']}, whole lobe: normal deviation rms {nd['rms']:.2e} max "
              f"{nd['max']:.2e} mm, slope error rms {se['rms']:.2e} max {se['max']:.2e} rad")
        inner_hi = used["lobes"][0]["r_range_mm"]["max"]
        hidden = fillet is not None and fillet["r_start_mm"] >= inner_hi
        c(f"used zone: the step wall blocks the camera's view of the inner lobe beyond r {inner_hi:.3f} mm"
          + ("; the fillet lies there, out of the image" if hidden else ""))
        for lobe in used["lobes"]:
            nd, se, rr = lobe["normal_deviation_mm"], lobe["slope_error_rad"], lobe["r_range_mm"]
            c(f"as machined {lobe['name']}, used r {rr['min']:.3f}..{rr['max']:.3f} mm: normal deviation "
              f"rms {nd['rms']:.2e} max {nd['max']:.2e} mm, slope error rms {se['rms']:.2e} max {se['max']:.2e} rad")

    def setup(self) -> None:
        lathe = self.lathe
        if self.dialect is Dialect.LINUXCNC:
            self.emit("G18 " + ("G7" if lathe.diameter_mode else "G8") + " G21 G90 G40 G49 G94")
            self.emit("G91.1")  # I, K relative to the arc's start
            self.emit("T1 M6 G43")
            self.emit(f"G96 D{lathe.spindle_max_rpm} S{lathe.surface_speed:g} M3")
            self.emit("G95")
        else:
            self.emit("G18 G21 G40 G97 G99")
            self.emit(f"G50 S{lathe.spindle_max_rpm}")
            self.emit("T0101")
            self.emit(f"G96 S{lathe.surface_speed:g} M03")

    def feed(self, f: float) -> None:
        self.emit(f"F{f:g}")

    def rapid(self, p) -> None:
        self.emit(f"G0 {self.xword(p[0])} Z{self.num(p[1])}")

    def line(self, p) -> None:
        self.emit(f"G1 {self.xword(p[0])} Z{self.num(p[1])}")

    def arc(self, seg) -> None:
        g = "G2" if seg.clockwise else "G3"
        i = seg.centre[0] - seg.start[0]  # radius in both dialects
        k = seg.centre[1] - seg.start[1]
        self.emit(f"{g} {self.xword(seg.end[0])} Z{self.num(seg.end[1])} I{self.num(i)} K{self.num(k)}")

    def end(self) -> None:
        self.emit("M5")
        self.emit("M30")
        self.emit("%")

    def text(self) -> str:
        return "\n".join(self.lines) + "\n"
