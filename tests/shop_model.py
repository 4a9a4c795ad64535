"""A shop's own model of the lathe, written independently of lathe_mirror's machining code
(numpy only): it reads the WRITTEN program and set-up sheet as a machinist does and cuts
the part a real set-up makes.

- the finishing pass: the blocks from the "(finish:" comment to the next tool change,
  G0/G1/G2/G3 in the G18 plane, X a diameter (G7) or a radius (G8), arc centres by I/K
  (incremental, G91.1, or absolute, G90.1) or by R; G3 turns counterclockwise in the
  (Z, X) plane, as LinuxCNC's G18. Tool nose compensation (G41/G42) is refused: the
  programs move the nose centre.
- the set-up: the operator touches off as the sheet says, with the nose radius of the tool
  table: Z with the nose's bottom on the face (entered face + rho), X on a bore with the
  nose's +X side (entered D - 2 rho) or on an outside diameter with its -X side (D + 2
  rho). An insert whose true radius is rho + d then puts its centre d higher in Z and d
  nearer the axis (bore) or farther out (outside diameter) than the controller believes.
  An X zero error moves every centre out by x_offset; a cutting edge h above the centre
  line cuts radius sqrt(x^2 + h^2) at slide position x, so radii under |h| are never cut
  (a pip stands there: a cone rubbed by the flank above centre, a stub below).
- the cut: the lowest point of the nose discs along the real centre path, at each radius.
"""

from __future__ import annotations

import math
import re

import numpy as np

#: Spacing (mm) of the nose-centre samples along the path: the envelope's sampling error
#: is spacing^2 / (8 rho), 0.6 nm for a 0.2 mm nose.
SAMPLE_MM = 0.001
#: The pip's height (mm): the stock the last finishing pass was to take at the centre.
PIP_MM = 0.0375

_WORD = re.compile(r"([A-Z])\s*([-+]?\d*\.?\d+)")


def finish_path(gcode: str) -> tuple[np.ndarray, np.ndarray]:
    """The finishing pass's programmed nose-centre points (r, Z), mm, in cutting order."""
    text = gcode.upper()
    if re.search(r"\bG4[12]\b", re.sub(r"\(.*?\)", "", text)):
        raise ValueError("tool nose compensation in the program: this model takes nose-centre programs")
    lines = text.splitlines()
    start = max(i for i, ln in enumerate(lines) if ln.startswith("(FINISH:"))
    diameter, incremental_ijk = True, True
    for ln in lines[:start]:  # the modal state set in the preamble
        code = re.sub(r"\(.*?\)", "", ln)
        for w, v in _WORD.findall(code):
            if w == "G" and float(v) == 7:
                diameter = True
            elif w == "G" and float(v) == 8:
                diameter = False
            elif w == "G" and abs(float(v) - 90.1) < 1e-9:
                incremental_ijk = False
            elif w == "G" and abs(float(v) - 91.1) < 1e-9:
                incremental_ijk = True
    r = z = None
    motion = 0
    rs, zs = [], []
    for ln in lines[start + 1:]:
        code = re.sub(r"\(.*?\)|;.*", "", ln)
        words = _WORD.findall(code)
        if rs and any(w == "T" or (w == "M" and int(float(v)) == 6) for w, v in words):
            break
        if any(w == "M" and int(float(v)) in (30, 2) for w, v in words):
            break
        vals = {}
        for w, v in words:
            if w == "G" and float(v) in (0, 1, 2, 3):
                motion = int(float(v))
            elif w in "XZIKR":
                vals[w] = float(v)
        if "X" not in vals and "Z" not in vals:
            continue
        nr = vals["X"] / 2 if ("X" in vals and diameter) else vals.get("X", r)
        nz = vals.get("Z", z)
        if r is None or motion == 0:
            r, z = nr, nz
            continue
        if motion == 1:
            n = max(int(math.ceil(math.hypot(nr - r, nz - z) / SAMPLE_MM)), 1)
            t = np.arange(1, n + 1) / n
            rs.append(r + (nr - r) * t)
            zs.append(z + (nz - z) * t)
        else:
            cr, cz = _arc_centre(r, z, nr, nz, vals, motion, incremental_ijk)
            # angles in the (Z, X) plane: G3 counterclockwise
            a0 = math.atan2(r - cr, z - cz)
            a1 = math.atan2(nr - cr, nz - cz)
            sweep = a1 - a0
            if motion == 3:
                sweep = sweep % (2 * math.pi)
            else:
                sweep = -((-sweep) % (2 * math.pi))
            rad = math.hypot(r - cr, z - cz)
            n = max(int(math.ceil(abs(sweep) * rad / SAMPLE_MM)), 1)
            a = a0 + sweep * np.arange(1, n + 1) / n
            rs.append(cr + rad * np.sin(a))
            zs.append(cz + rad * np.cos(a))
        r, z = nr, nz
    return np.concatenate(rs), np.concatenate(zs)


def _arc_centre(r, z, nr, nz, vals, motion, incremental):
    if "R" in vals:
        R = vals["R"]
        # in the (Z, X) plane: the centre on the chord's bisector, to the left for G3 with
        # R > 0 (an arc under 180 deg)
        mz, mr = (z + nz) / 2, (r + nr) / 2
        dz, dr = nz - z, nr - r
        c = math.hypot(dz, dr)
        h = math.sqrt(max(R * R - c * c / 4, 0.0))
        left = (motion == 3) == (R > 0)
        s = 1.0 if left else -1.0
        return mr + s * h * dz / c, mz - s * h * dr / c
    i, k = vals.get("I", 0.0), vals.get("K", 0.0)  # I is a radius in G7 too (LinuxCNC)
    return (r + i, z + k) if incremental else (i, k)


def nose_radius(gcode: str, tool_table: str | None = None) -> float:
    """The nose radius the controller knows (mm): the finishing tool's D word / 2 in the
    tool table, else the program header's "nose radius N mm"."""
    if tool_table:
        lines = gcode.upper().splitlines()
        start = max(i for i, ln in enumerate(lines) if ln.startswith("(FINISH:"))
        t = next(int(m.group(1)) for ln in lines[start:] if (m := re.search(r"\bT(\d+)\s*M6", ln)))
        for ln in tool_table.upper().splitlines():
            m = re.match(rf"T{t}\b.*?\bD([-+]?\d*\.?\d+)", ln)
            if m:
                return float(m.group(1)) / 2
    m = re.search(r"nose radius ([0-9.]+) mm", gcode)
    return float(m.group(1))


def touch_off_side(sheet_html: str) -> str:
    """"bore" or "outside": what the sheet has X touched on (its entry X = D -/+ 2 rho)."""
    m = re.search(r"X = D ([-+]) ", sheet_html)
    return "bore" if m.group(1) == "-" else "outside"


def cut(r_prog, z_prog, rho_prog: float, *, nose_error=0.0, centre_height=0.0, x_offset=0.0,
        side="bore"):
    """The part (a function of radius r, mm -> machine Z, mm) the programmed centres cut
    with the set-up errors (module doc)."""
    d = nose_error
    rho = rho_prog + d
    xc = np.asarray(r_prog) + x_offset + (-d if side == "bore" else d)
    zc = np.asarray(z_prog) + d
    order = np.argsort(xc, kind="stable")
    xc, zc = xc[order], zc[order]
    h = abs(centre_height)

    def envelope(x):
        x = np.asarray(x, float)
        out = np.full(x.size, np.inf)
        lo = np.searchsorted(xc, x - rho)
        hi = np.searchsorted(xc, x + rho, side="right")
        for a in range(0, x.size, 2000):
            b = min(a + 2000, x.size)
            n = hi[a:b] - lo[a:b]
            owner = np.repeat(np.arange(a, b), n)
            first = np.repeat(lo[a:b] - np.concatenate([[0], np.cumsum(n)[:-1]]), n)
            j = first + np.arange(owner.size)
            zz = zc[j] - np.sqrt(np.maximum(rho * rho - (x[owner] - xc[j]) ** 2, 0.0))
            np.minimum.at(out, owner, zz)
        return out

    def part(r):
        r = np.asarray(r, float)
        s = np.sqrt(np.maximum(r * r - h * h, 0.0))
        z = np.minimum(envelope(s), envelope(-s))
        if h > 0:
            edge = float(np.minimum(envelope(np.array([0.0])), envelope(np.array([-0.0])))[0])
            top = edge + PIP_MM
            inside = r < h
            z = np.where(inside, (top - PIP_MM * r / h) if centre_height > 0 else top, z)
        return z

    return part


def design_z(mirror, r):
    """The design in the machine frame from each lobe's hyperbola in closed form."""
    i, o = mirror.inner, mirror.outer
    zi = i.e + i.a * np.sqrt(1 + r ** 2 / i.b ** 2)
    zo = o.e + o.a * np.sqrt(1 + r ** 2 / o.b ** 2)
    return (i.e + i.a) - np.where(r <= mirror.r_junction, zi, zo)


def trace_csv(part, r_max: float, *, spacing=0.002, noise=2e-5, decentre=0.03, seed=0) -> str:
    """A stylus trace through the axis (x across the diameter, part face up), mm, as CSV:
    the part set down `decentre` off the instrument's origin, seeded Gaussian noise."""
    x = np.arange(-r_max + 0.01, r_max - 0.01, spacing)
    z = part(np.abs(x)) + np.random.default_rng(seed).normal(0.0, noise, x.size)
    rows = "\n".join(f"{a + decentre:.6f},{b:.7f}" for a, b in zip(x, z))
    return "x [mm],z [mm]\n" + rows + "\n"
