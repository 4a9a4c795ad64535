"""The ideal profile: a design optimiser under the camera, the envelope, the focus and the lathe.

The paper found its parameters "empirically"; this searches them. With the camera fixed it
varies both lobes' r_top, r_pixel and Table 1 alpha (as fractions that keep the inner lobe
inside the outer one) and maximises the objective of [optimize] (R10, the baseline, the
common band's width or the usable share of the image) under the constraints: the radial
and axial envelope, the elevation band the robot needs, the image (rim inside the
inscribed circle, usable pixels), the focus (a thin-lens blur limit) and the lathe (the
configured tool cuts the step, whichever lobe is recessed; the bar and the body hold the
mirror).

Modules:
  spec      OptimizeSettings, SearchSpace, Objective: the [optimize] section
  focus     the thin-lens defocus model (Defocus, defocus)
  evaluate  Problem, Figures, CONSTRAINTS; one candidate's figures, violations and energy
  search    search(problem) -> SearchResult: seeded differential evolution over processes
  pareto    pareto_front
  winner    the search and the winner's tolerance check as `lathe-mirror optimize` gives them
  robust    a winner whose made parts fall short of the yield gives way to the most-ranging
            candidate whose parts reach it (the decentre sensitivity front, small Monte Carlos)
"""

from .evaluate import CONSTRAINTS, Figures, Problem, figures
from .search import NoFeasibleDesign, SearchResult, search
from .spec import Objective, OptimizeSettings, SearchSpace

__all__ = ["CONSTRAINTS", "Figures", "NoFeasibleDesign", "Objective", "OptimizeSettings", "Problem",
           "SearchResult", "SearchSpace", "figures", "search"]
