"""The Monte Carlo's sample grid stays on its lobe, whatever the junction's last bits.

gs2mp's optimizer winner (benchmarks/bench_designs.py; inner r_top 22.200376436997278 mm as
the search found it) gave 69.4 % yield inside `optimize` and 97.2 % from `tolerance` on the
written file, whose r_top is rounded to 22.200376437: with the exact value the inner lobe's
last sample, r0 + dr (n - 1), rounds one ulp past the junction, where every profile is the
outer sheet, and each nose the trials cut carried the outer sheet's slope there (4 rad at one
sample: 0.06 rad RMS, against a 0.02 rad limit). The reference here is the hyperbola's own
closed-form slope (design.Lobe.slope), not the bank's sampling.
"""

from __future__ import annotations

import numpy as np
import pytest

from lathe_mirror.design import Camera, LobeSpec, mirror_from_specs
from lathe_mirror.profile import ExactProfile
from lathe_mirror.tolerance.surfaces import SurfaceBank

#: gs2mp's camera (a 2-MP global shutter sensor behind a 25 mm lens) and its winner's lobes
#: as the search returned them (before the design file rounds them).
CAMERA = Camera(f=25.0, t_pixel=0.005, sensor_px=(1920, 1080), f_number=4.0)
EXACT = (LobeSpec("inner", r_top=22.200376436997278, r_pixel=377.2726021726505, alpha_deg=0.013780162588851397),
         LobeSpec("outer", r_top=36.01984079183378, r_pixel=539.9750696432441, alpha_deg=0.0014745929836358586))
STEP_MM = 0.005  # the polishing grid's default step


def test_the_trigger_is_real():
    """The case the fix is for: the plain grid's last inner sample lies past the junction."""
    m = mirror_from_specs(CAMERA, EXACT)
    n = int(np.ceil(m.r_junction / STEP_MM)) + 1
    dr = m.r_junction / (n - 1)
    assert dr * (n - 1) > m.r_junction


def test_inner_samples_carry_the_inner_sheet():
    """Every inner sample of a bank holding the designed surface has the inner hyperbola's z
    and slope (closed form), the last one at the junction included; the outer likewise."""
    m = mirror_from_specs(CAMERA, EXACT)
    bank = SurfaceBank.fixed(m, ExactProfile(m), STEP_MM)
    for k in (0, 1):
        r = bank.grid(k)
        lo, hi = (0.0, m.r_junction) if k == 0 else (m.r_junction, m.r_max)
        assert r[0] >= lo and r[-1] <= hi and (k == 0 or r[0] > lo)
        z, s = bank.trial_surface(k, np.zeros(1, np.intp), np.array([bank.nose0]), np.zeros(1), np.zeros(1))
        lobe = m.lobes[k]
        assert np.max(np.abs(z[0] - lobe.z(r))) < 1e-9
        assert np.max(np.abs(s[0] - lobe.slope(r))) < 1e-9


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_grids_stay_inside_their_lobes(seed):
    """For junctions and rims whose last bits vary (the search's values are any floats), no
    sample of either lobe falls past its end."""
    rng = np.random.default_rng(seed)
    base = mirror_from_specs(CAMERA, EXACT)
    for _ in range(20):
        f = 1.0 + 1e-9 * rng.uniform(-1.0, 1.0)
        lobes = (LobeSpec("inner", r_top=EXACT[0].r_top * f, r_pixel=EXACT[0].r_pixel, alpha_deg=EXACT[0].alpha_deg),
                 LobeSpec("outer", r_top=EXACT[1].r_top * f, r_pixel=EXACT[1].r_pixel, alpha_deg=EXACT[1].alpha_deg))
        m = mirror_from_specs(CAMERA, lobes)
        bank = SurfaceBank.fixed(m, ExactProfile(base), STEP_MM)
        assert bank.grid(0)[-1] <= m.r_junction
        assert bank.grid(1)[0] > m.r_junction and bank.grid(1)[-1] <= m.r_max
