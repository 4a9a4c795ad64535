"""What a toolpath must respect before it is planned or written: the junction, the travel.

check_junction: the largest nose that can still reach the step wall. check_travel: every
point inside the lathe's travel (used for the finishing contour here and for the whole
program by export.gcode). Both raise InputError with the setting to change.
"""

from __future__ import annotations

import numpy as np

from ..design import Mirror
from ..errors import InputError
from ..lathe import Lathe, Tool
from ..sheet import nose_centre, solve_rs_for_centre_r


def check_junction(mirror: Mirror, tool: Tool) -> float:
    """Largest nose radius (mm) the junction allows; raise InputError if the tool's is larger.

    A nose in the inside corner at the wall's foot touches the inner lobe and the wall
    at once; its centre then sits on the corner's bisector, rho / tan(half opening)
    above the foot. If that is above the top of the step, the nose can never touch the
    wall: it would round the whole step and the inner lobe's rim with it. So rho_max is
    the radius whose wall contact is the top of the step (found exactly on the curved
    lobe by bisection).
    """
    if mirror.recessed != "inner":
        raise InputError("lobes: this toolpath handles a recessed inner lobe only (the paper's "
                         "design); the outer lobe is recessed in this design")
    rj = mirror.r_junction
    z_top_m = mirror.vertex_z - mirror.outer.z(rj)  # machine Z of the step's top

    def centre_z(rho: float) -> float:
        # nose centre at r = rj - rho touching the inner lobe: on its offset curve
        rs = solve_rs_for_centre_r(mirror.inner, rho, rj - rho)
        return float(nose_centre(mirror.inner, rs, mirror.vertex_z, rho)[1])

    lo, hi = 0.0, float(abs(mirror.step)) * 2
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if centre_z(mid) <= z_top_m:
            lo = mid
        else:
            hi = mid
    rho_max = lo
    if tool.nose_radius > rho_max:
        zi, zo = mirror.junction_z
        raise InputError(
            f"tool.nose_radius = {tool.nose_radius:g} mm is too large for the junction: a nose "
            f"touching both the inner lobe and the step wall (step {abs(zi - zo):.3f} mm) needs "
            f"nose_radius <= {rho_max:.3f} mm, else it cannot reach the wall at all"
        )
    return rho_max


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
