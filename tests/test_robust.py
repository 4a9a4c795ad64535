"""optimize.robust's decentre sensitivity S against the trial tracer.

S = (f / t_pixel) |<1/z>_inner - <1/z>_outer| is a closed form the optimiser ranks its
candidates by when the winner's made parts fall short of the yield (the 6 mm lens of the
matrix, benchmarks/bench_designs.py cam6). The independent model here is the tolerance
tracer (3-D rays through the exact lobes from a decentred pinhole, then the calibration a
user's fit makes: tolerance.perturb.evaluate), on four designs the search found for that
camera: the winner and three of its robustness front, lobes as the search gave them.
"""

from __future__ import annotations

import numpy as np
import pytest

from lathe_mirror.design import Camera, LobeSpec, mirror_from_specs
from lathe_mirror.optimize.robust import decentre_sensitivity
from lathe_mirror.profile import ExactProfile
from lathe_mirror.tolerance.perturb import Trials, evaluate
from lathe_mirror.tolerance.samples import pixel_sample
from lathe_mirror.tolerance.surfaces import SurfaceBank

CAMERA = Camera(f=6.0, t_pixel=0.003, sensor_px=(1280, 1024), f_number=8.0)
#: (inner, outer) as (r_top mm, r_pixel px, alpha deg): the winner first, then the front.
DESIGNS = (
    ((5.8071343366521, 355.47783493709954, 0.006607701717509684),
     (13.315716503945602, 511.97982316681157, 0.01163282160303467)),
    ((6.245256676348065, 354.12917064817486, 0.10089402449841245),
     (13.880428000165274, 510.59412591433454, 0.006057718183468808)),
    ((7.548712460265718, 348.2210538568926, 1.050055843201033),
     (15.698239710307094, 509.1565485742522, 0.10963949983158656)),
    ((8.35846978222418, 311.9151522590264, 0.5552693249288261),
     (17.95033758865463, 503.71298002359646, 0.10010614269704092)),
)
DECENTRE_MM = 0.05


def _mirror(design):
    (ri, pi, ai), (ro, po, ao) = design
    return mirror_from_specs(CAMERA, (LobeSpec("inner", r_top=ri, r_pixel=pi, alpha_deg=ai),
                                      LobeSpec("outer", r_top=ro, r_pixel=po, alpha_deg=ao)))


def _decentred_disparity(mirror) -> float:
    """The calibrated disparity error (px, median over the band's points at 1 m) of the
    exact mirror seen by a pinhole decentred DECENTRE_MM along x, the tracer's."""
    bank = SurfaceBank.fixed(mirror, ExactProfile(mirror), 0.005)
    samples = tuple(pixel_sample(mirror, k, bin_px=4.0, azimuths=24) for k in (0, 1))
    tr = Trials.nominal(1, 0.2, 0.0)
    tr.cam_x_mm[:] = DECENTRE_MM
    return float(evaluate(mirror, bank, tr, samples, seat_pivot_mm=0.0).calibrated["disparity_px_median"][0, 0])


def test_hand_value_of_the_winner():
    """S by hand for the winner: the lobes' mean inverse heights (r-weighted, 4001 radii)."""
    m = _mirror(DESIGNS[0])
    inv = []
    for lobe, lo, hi in ((m.inner, 0.0, m.r_junction), (m.outer, m.r_junction, m.r_max)):
        r = np.linspace(lo, hi, 4001)
        inv.append(np.trapezoid(r / lobe.z(r), r) / np.trapezoid(r, r))
    assert decentre_sensitivity(m) == pytest.approx(6.0 / 0.003 * abs(inv[0] - inv[1]), rel=0.01)


def test_sensitivity_ranks_the_decentred_disparity_as_the_tracer_does():
    """Along the front S falls 23.5 -> 9.4 px/mm and the tracer's calibrated disparity of a
    0.05 mm decentre falls with it, in the same order, at 0.08-0.14 x S x e (the mirror's
    own power, which S leaves out, takes the rest of the pinhole's parallax)."""
    s = np.array([decentre_sensitivity(_mirror(d)) for d in DESIGNS])
    d = np.array([_decentred_disparity(_mirror(d)) for d in DESIGNS])
    assert np.all(np.diff(s) < 0) and s[0] / s[-1] > 2.0
    assert np.all(np.diff(d) < 0)
    ratio = d / (s * DECENTRE_MM)
    assert np.all((ratio > 0.08) & (ratio < 0.14)), ratio
