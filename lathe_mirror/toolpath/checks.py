"""What a toolpath must respect before it is planned or written: the junction, the travel.

check_junction: the largest nose that can still reach the step wall (whichever lobe is
recessed; junction_margin is the graded form the design optimiser uses); check_reach /
reach_margin: the held tool's flanks against the profile's normals. check_travel: every
point inside the lathe's travel (used for the finishing contour here and for the whole
program by export.gcode). Both raise InputError with the setting to change.
"""

from __future__ import annotations

import math

import numpy as np

from ..design import Mirror
from ..errors import InputError
from ..lathe import Lathe, Tool
from ..sheet import normal_angles
from .metrics import usable_ranges
from .moves import Hand


def check_junction(mirror: Mirror, tool: Tool) -> float:
    """Largest nose radius (mm) the junction allows; raise InputError if the tool's is larger.

    Whichever lobe is recessed: a nose in the inside corner at the wall's foot touches the
    recessed lobe and the wall at once; its centre then sits on the corner's bisector, rho
    / tan(half opening) above the foot. If that is above the top of the step, the nose can
    never touch the wall: it would round the whole step and the recessed lobe's rim with
    it. So rho_max is the radius whose wall contact is the top of the step (found exactly
    on the curved lobe by bisection on junction_margin).
    """
    lo, hi = 0.0, float(abs(mirror.step)) * 2
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if junction_margin(mirror, mid) >= 0.0:
            lo = mid
        else:
            hi = mid
    rho_max = lo
    if tool.nose_radius > rho_max:
        zi, zo = mirror.junction_z
        raise InputError(
            f"tool.nose_radius = {tool.nose_radius:g} mm is too large for the junction: a nose "
            f"touching both the {mirror.recessed} lobe and the step wall (step {abs(zi - zo):.3f} mm) needs "
            f"nose_radius <= {rho_max:.3f} mm, else it cannot reach the wall at all"
        )
    return rho_max


def junction_margin(mirror: Mirror, nose_radius: float) -> float:
    """How far (mm, machine Z) the top of the step lies above the centre of a nose of
    `nose_radius` mm sitting in the step's inside corner (touching the recessed lobe and
    the wall): >= 0 when the nose reaches the wall, whichever lobe is recessed."""
    return corner_nose(mirror, nose_radius)[0]


def corner_nose(mirror: Mirror, nose_radius: float) -> tuple[float, float]:
    """A nose of `nose_radius` mm in the step's inside corner, touching the recessed lobe
    and the wall: (junction margin, mm: the step's top above its centre in machine Z;
    contact radius, mm: where it touches the lobe, the far end of the fillet it leaves).

    The centre is on the recessed lobe's offset curve at the column r_junction -/+ rho
    (the wall faces the axis / the rim); the column is solved by Newton's method on the
    offset curve's radius (a few scalar steps: the design optimiser calls this per design).
    """
    rho = float(nose_radius)
    rj = mirror.r_junction
    zi, zo = mirror.junction_z
    lobe, column = (mirror.inner, rj - rho) if zi > zo else (mirror.outer, rj + rho)

    def slope(r: float) -> tuple[float, float]:
        # the sheet's own (a pre-compensated target's is not the design's hyperbola)
        return float(lobe.slope(r)), float(lobe.second_derivative(r))  # dz/dr, d2z/dr2

    rs = column
    for _ in range(30):
        s, s2 = slope(rs)
        w = math.sqrt(1.0 + s * s)
        g = rs + rho * s / w - column
        dg = 1.0 + rho * s2 / w**3
        step = g / dg
        rs -= step
        if abs(step) < 1e-13:
            break
    s, _ = slope(rs)
    z_centre = mirror.vertex_z - float(lobe.z(rs)) + rho / math.sqrt(1.0 + s * s)  # machine Z
    z_top = mirror.vertex_z - min(zi, zo)
    return z_top - z_centre, rs


def fillet_hidden_margin(mirror: Mirror, nose_radius: float) -> float:
    """How far (mm, in r) the fillet a nose of `nose_radius` leaves in the step's inside
    corner stays out of the camera's sight: >= 0 when the camera sees none of it.

    Inner lobe recessed: the step wall blocks the inner lobe's world rays beyond the
    radius metrics.usable_ranges gives; the fillet must start beyond it. Outer lobe
    recessed: the inner rim hides the outer lobe up to Mirror.r_outer_visible; the
    fillet must end before it."""
    contact = corner_nose(mirror, nose_radius)[1]
    if mirror.step > 0:
        return contact - usable_ranges(mirror)[0][1]
    return mirror.r_outer_visible - contact


def check_reach(mirror: Mirror, tool: Tool, hand: Hand) -> None:
    """Raise InputError unless the tool, held by `hand`, clears every normal of the
    profile (the lobes and the step wall; Tool.check_reach). The message names the hand."""
    try:
        hand.held(tool).check_reach(normal_angles(mirror), what="the mirror's profile")
    except InputError as exc:
        if hand is Hand.AS_CONFIGURED:
            raise
        raise InputError(f"{exc} (in the opposite-hand holder the outer lobe's recessed step "
                         "needs: flanks at 90 - approach - included .. 90 - approach deg)") from None


def reach_margin(mirror: Mirror, tool: Tool, hand: Hand) -> float:
    """Smallest clearance (rad) of the held tool's flanks against the profile's normals
    (Tool.check_reach's two inequalities); >= 0 when the tool can cut the whole profile."""
    lo, hi = hand.held(tool).flank_directions()
    # a lobe's normal turns monotonically from its inner to its outer end (the slope grows
    # with r), so the extremes of sheet.normal_angles are at the lobes' ends and the wall
    ends = [(mirror.inner, 0.0), (mirror.inner, mirror.r_junction), (mirror.outer, mirror.r_junction),
            (mirror.outer, mirror.r_max)]
    n = [math.atan2(1.0, float(lobe.slope(r))) for lobe, r in ends] + [math.pi if mirror.step > 0 else 0.0]
    return float(min(min(n) - (hi - math.pi / 2), (lo + math.pi / 2) - max(n)))


def check_travel(points: np.ndarray, lathe: Lathe, what: str) -> None:
    """Raise InputError if any point (r, Z) lies outside the lathe's travel."""
    pts = np.asarray(points, dtype=float).reshape(-1, 2)
    r_hi = float(pts[:, 0].max())
    if r_hi > lathe.travel_x + 1e-9:
        raise InputError(
            f"machine.travel_x = {lathe.travel_x:g} mm: {what} needs a radius of {r_hi:.3f} mm; "
            "allowed up to travel_x"
        )
    z_lo, z_hi = float(pts[:, 1].min()), float(pts[:, 1].max())
    if z_lo < lathe.travel_z_min - 1e-9 or z_hi > lathe.travel_z_max + 1e-9:
        raise InputError(
            f"machine.travel_z_min/max = {lathe.travel_z_min:g}/{lathe.travel_z_max:g} mm: {what} "
            f"spans Z {z_lo:.3f}..{z_hi:.3f} mm"
        )
