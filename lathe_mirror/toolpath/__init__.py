"""Finishing toolpaths on the lathe's lattice, within its point budget; profile errors.

Machine frame (ARCHITECTURE.md): Z = vertex_z - z (vertex at Z = 0, part in -Z), r the
radius; every programmed coordinate is a multiple of `Lathe.resolution` in r and Z.

The programmed path is the path of the tool nose's CENTRE: the exact lobe offset
outward along its normal by the nose radius (0 for the ideal sharp tool, when the path
is the contour itself). Each strategy puts that path on the lattice:

- `Strategy.PAPER`: the paper's method (section 6): points spread evenly along the
  profile, each coordinate rounded to the lattice, joined by G1 lines.
- `Strategy.LATTICE`: G1 lines through the same number of points, each vertex chosen
  among the lattice points near its place on the curve by dynamic programming so
  that the chords' slope errors and offsets are smallest (an optimisation over the
  lattice, not rounding): 4-8x less RMS slope error than rounding.
- `Strategy.ARCS` (BEST, the default): G2/G3 arcs whose end points are the lattice
  points nearest the curve and whose centres are the lattice points that make the arc
  the controller actually cuts (LinuxCNC's spiral when the two radii differ) follow
  the curve's slope best. An arc follows a smooth curve's turning tangent, a chord
  cannot: on the paper's machine the max slope error falls ~80x, and the lattice,
  not the budget, is then the limit (about 80 of the 528 points are used). Where no
  lattice centre cuts an arc within `Lathe.arc_radius_tolerance` (a very coarse
  lattice) the move is a G1 chord, and the gouge check judges it.

The junction, whichever lobe is recessed. Inner lobe recessed (the paper's design): the
contour runs out along the inner lobe, up the step wall (r = r_junction, facing the axis),
then out along the outer lobe, cut by the [tool] as configured from the axis out. A nose
of radius rho touches the wall at r = r_junction - rho and cannot reach the inside corner
at the wall's foot: it leaves a fillet there (see nose_envelope.as_machined). The fillet
lies where the step wall already hides the inner lobe from the camera (usable_ranges), so
the G-code header and `--json` give the figures over those radii beside the whole lobe's.
Outer lobe recessed: the mirror image. The wall faces the rim; the contour runs along the
inner lobe, over the step's top on the inner lobe's end tangent, down the wall at
r_junction + rho and out along the outer lobe, and the same insert in an opposite-hand
holder cuts it from the rim in (Hand.OPPOSITE, Toolpath.cutting_moves); the fillet is on
the outer lobe, where the inner rim hides it from the camera if the design keeps it so
(the optimiser's constraint). `segments` always run from the axis out.

Modules:

- moves.py     Strategy, BEST, Line, Arc, Toolpath, Hand: the data
- plan.py      plan_toolpath: checks, then one strategy
- paper.py, lattice.py, arcs.py   the three strategies
- layout.py    what they share: lobe end columns, junction moves, budget split, lattice
               candidates near the curve
- (lathe_mirror.sheet, below this package: a lobe's sheet in the machine frame,
  foot_on_sheet, normal_angles, and the nose-centre curve)
- checks.py    check_junction, junction_margin / corner_nose / fillet_hidden_margin,
               check_reach / reach_margin (the held tool's flanks), check_travel
- metrics.py   profile_errors (normal deviation, slope error), usable_ranges (the
               radii the camera uses: the step wall blocks the inner lobe's rim)
"""

from ..path import Arc, Line, Move
from ..sheet import foot_on_sheet
from .checks import check_junction, check_travel
from .metrics import profile_errors, usable_ranges
from .moves import BEST, Hand, Strategy, Toolpath, ToolpathSettings
from .plan import plan_toolpath

__all__ = [
    "BEST", "Arc", "Hand", "Line", "Move", "Strategy", "Toolpath", "ToolpathSettings",
    "check_junction", "check_travel", "foot_on_sheet", "plan_toolpath", "profile_errors",
    "usable_ranges",
]
