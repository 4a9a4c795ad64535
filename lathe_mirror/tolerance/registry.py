"""One object per toleranced parameter: its key, unit, how it is drawn and how it moves a
trial's made part. The Monte Carlo (montecarlo.draw_trials), the sensitivity scans
(sensitivity.responses) and the allocation (allocation.allocate) all iterate REGISTRY,
after optiland's perturbation objects (one class per perturbation, each knowing how it
is sampled and applied).

Common random numbers: a trial's draw of a parameter is a standard draw (normal with
sigma 1, scaled to t/3, or uniform on [0, 1), mapped onto -t .. t) taken from the seed in a fixed order whatever the
tolerances, scaled by the tolerance. The same seed therefore gives nested samples:
tightening one tolerance by a factor k moves every trial's value of that parameter to k
times its old one and leaves every other parameter's value as it was, so a yield can only
change through the trials that parameter alone flips (the Monte Carlo's noise between
two tolerance sets is that of a paired comparison, not of two independent runs).

Edge units (mm, s, deg, urad) at the edges, the Trials' fields in mm and rad.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..enums import Distribution

_DEG = math.pi / 180.0


@dataclass(frozen=True)
class Toleranced:
    """A toleranced parameter.

    key: its key under [tolerance.<section>]; section: "params" (the part, the tool and
    the assembly) or "machine_errors" (the lathe's set-up errors about [machine.errors]).
    what, unit: the table's text and the edge unit. fields: the Trials fields it moves
    (two for a pair drawn independently in x and y, whose response depends on the
    magnitude). to_trial: edge unit -> field unit (deg -> rad, urad -> rad). one_sided:
    the draw moves its field by -|value| (backlash: a pass cut in +X lands short, whatever
    the sign). rigid: it moves the camera or the mirror as a body (no re-machining).
    """

    key: str
    section: str
    what: str
    unit: str
    fields: tuple[str, ...]
    to_trial: float = 1.0
    one_sided: bool = False

    @property
    def paired(self) -> bool:
        return len(self.fields) == 2

    def standard(self, rng: np.random.Generator, n: int, distribution: Distribution) -> np.ndarray:
        """(len(fields), n) standard draws, taken from rng whatever the tolerance (so the
        draws after it do not depend on it): N(0, 1/3) for a normal tolerance (a 3-sigma
        bound; scale divides by 3), U[0, 1) for a uniform one (scale maps it onto -t .. t)."""
        m = len(self.fields)
        if distribution is Distribution.NORMAL:
            return rng.standard_normal((m, n))
        return rng.random((m, n))

    @staticmethod
    def scale(std: np.ndarray, tolerance: float, distribution: Distribution) -> np.ndarray:
        """The offsets (edge units) of standard draws at a tolerance: linear in it, so the
        offsets at t' are t' / t times those at t (nested samples). The arithmetic is
        numpy's own normal(0, t/3) and uniform(-t, t), bit for bit."""
        t = float(tolerance)
        if distribution is Distribution.NORMAL:
            return (t / 3.0) * std
        return -t + (2.0 * t) * std

    def offsets(self, std: np.ndarray, tolerance: float, distribution: Distribution) -> np.ndarray:
        """The offsets of standard draws at a tolerance (edge units), in the fields' units."""
        return self.scale(std, float(tolerance) * self.to_trial, distribution)

    def add(self, trials, offsets: np.ndarray, rows=slice(None)) -> None:
        """Add offsets (len(fields), n), in the fields' units, to the trials' fields (rows)."""
        for field, off in zip(self.fields, offsets):
            col = getattr(trials, field)
            col[rows] = col[rows] + (-np.abs(off) if self.one_sided else off)
        if self.key == "polish_time_s":
            trials.time_s[rows] = np.maximum(trials.time_s[rows], 0.0)

    def apply(self, trials, i: int, value: float) -> None:
        """Put the parameter at `value` (edge units) on trial i, along x (by the mirror's
        symmetry a pair's response depends on its magnitude only)."""
        off = np.zeros((len(self.fields), 1))
        off[0, 0] = value * self.to_trial
        self.add(trials, off, rows=slice(i, i + 1))

    def magnitude(self, trials, nominal: dict[str, float]) -> np.ndarray:
        """Each trial's value of the parameter (edge units) against the nominal (a pair's
        magnitude, hypot(x, y)); nominal: field -> its nominal value."""
        vals = [(getattr(trials, f) - nominal.get(f, 0.0)) / self.to_trial for f in self.fields]
        if self.one_sided:
            return np.abs(vals[0])
        return np.hypot(vals[0], vals[1]) if self.paired else vals[0]


def _p(key, what, unit, fields, to_trial=1.0, *, section="params", one_sided=False) -> Toleranced:
    return Toleranced(key, section, what, unit, tuple(fields), to_trial, one_sided)


#: Every drawn parameter, in draw order (the part, the assembly, then the lathe's set-up
#: errors, so that a set-up error's tolerance changes no other parameter's draws).
REGISTRY: tuple[Toleranced, ...] = (
    _p("nose_radius_mm", "insert nose radius", "mm", ("nose_mm",)),
    _p("polish_time_s", "polishing time", "s", ("time_s",)),
    _p("tool_x_mm", "tool setting error across the axis (radius)", "mm", ("tool_x_mm",)),
    _p("tool_z_mm", "tool setting error along the axis", "mm", ("tool_z_mm",)),
    _p("camera_decentre_mm", "camera pinhole off the mirror axis (x and y)", "mm", ("cam_x_mm", "cam_y_mm")),
    _p("camera_axial_mm", "lens entrance pupil along the axis", "mm", ("cam_z_mm",)),
    _p("camera_tilt_deg", "camera axis tilt about its pinhole (x and y)", "deg", ("tilt_x", "tilt_y"), _DEG),
    _p("seat_tilt_deg", "mirror seat tilt about the seat pivot (x and y)", "deg", ("seat_x", "seat_y"), _DEG),
    _p("centre_height_mm", "lathe: tool centre height (a pip at the vertex, radii moved)", "mm",
       ("centre_height_mm",), section="machine_errors"),
    _p("x_offset_mm", "lathe: tool X zero (the pass moved out in r: an ogive)", "mm", ("machine_x_mm",),
       section="machine_errors"),
    _p("nose_radius_error_mm", "lathe: nose radius against the programmed one, tool set on its tip", "mm",
       ("nose_error_mm",), section="machine_errors"),
    _p("squareness_urad", "lathe: X slide out of square with the spindle", "urad", ("squareness_rad",), 1e-6,
       section="machine_errors"),
    _p("backlash_mm", "lathe: X backlash (a pass cut in +X lands short)", "mm", ("machine_x_mm",),
       section="machine_errors", one_sided=True),
)

#: Each by its key.
BY_KEY: dict[str, Toleranced] = {p.key: p for p in REGISTRY}


def tolerances_of(settings, tolerances: dict[str, float] | None = None) -> dict[str, float]:
    """Every registered parameter's tolerance (edge units): the settings' params and
    machine errors, with `tolerances` (any of REGISTRY's keys) over them."""
    out = {p.key: float({**settings.tolerances, **settings.machine_errors}.get(p.key, 0.0)) for p in REGISTRY}
    out.update({k: float(v) for k, v in (tolerances or {}).items() if k in BY_KEY})
    return out


def standard_draws(rng: np.random.Generator, n: int, distribution: Distribution) -> dict[str, np.ndarray]:
    """Every parameter's standard draws for n trials, in REGISTRY's order (common random
    numbers: the same rng state gives the same draws whatever the tolerances)."""
    return {p.key: p.standard(rng, n, distribution) for p in REGISTRY}
