"""The slope criterion judges the lobe, not the step's wall: a made surface whose wall has
moved into the lobe (a nose larger than the program's, cam6's winner: 62 of 1000 trials
failed the slope limit on the inner lobe's last cell) against a hand model.

The made inner lobe here is the design plus a ripple of amplitude A and wavelength L,
z = z_d + A sin(2 pi r / L), cut off at r_c by a wall of slope -W that falls to a floor
0.5 mm below the design. On the lobe the slope error is, in closed form,
atan(z_d' + A k cos(k r)) - atan(z_d'), k = 2 pi / L; its RMS over the judged radii short
of the wall is the hand figure. The grid sample just past r_c lies a few micrometres down
the wall, well within the 0.1 mm that marks the wall's samples as off the surface, so
only the cell's chord (W, against the lobe's < 1) tells it is the wall: the old rule
interpolated the wall's slope into the lobe's last half-cell (0.4 of 20 rad at a trial
whose tool setting shifts the part by 0.4 of a cell) and failed the part.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from lathe_mirror.optics.radial import used_extent
from lathe_mirror.tolerance.perturb import Trials, evaluate
from lathe_mirror.tolerance.samples import pixel_sample
from lathe_mirror.tolerance.surfaces import JUMP_SLOPE, OFF_SURFACE_MM, SurfaceBank

STEP_MM = 0.005  # the polishing grid's default step
WALL_SLOPE = 20.0  # the wall's dz/dr (87 deg): a nose's corner, steeper than JUMP_SLOPE
FLOOR_MM = 0.5  # how far below the design the wall ends
STRIDE = 4  # the slope criterion's stride over the grid (perturb's)


class _Made:
    """An inner lobe with a ripple, cut off at r_c by the wall (module doc); the outer lobe
    as designed. z and slope in the camera frame (mm)."""

    def __init__(self, mirror, amp_mm: float, wave_mm: float, r_c: float | None):
        self.m, self.amp, self.k, self.r_c = mirror, amp_mm, 2 * math.pi / wave_mm, r_c

    def _drop(self, r):
        if self.r_c is None:
            return np.zeros_like(r), np.zeros_like(r)
        h = np.clip(WALL_SLOPE * (r - self.r_c), 0.0, FLOOR_MM)
        on_wall = (r > self.r_c) & (h < FLOOR_MM)
        return h, np.where(on_wall, WALL_SLOPE, 0.0)

    def z(self, r):
        r = np.asarray(r, float)
        inner = self.m.inner.z(r) + self.amp * np.sin(self.k * r) - self._drop(r)[0]
        return np.where(r <= self.m.r_junction, inner, self.m.outer.z(r))

    def slope(self, r):
        r = np.asarray(r, float)
        inner = self.m.inner.slope(r) + self.amp * self.k * np.cos(self.k * r) - self._drop(r)[1]
        return np.where(r <= self.m.r_junction, inner, self.m.outer.slope(r))


def _case(paper_mirror):
    """The wall's foot r_c: 2 um past a grid sample on the criterion's stride, 70 % of the
    way out the inner lobe's used zone; the tool setting shifts the part by 0.4 of a cell
    outward, so the criterion's point at the sample before it reads 0.4 into its cell."""
    bank = SurfaceBank.fixed(paper_mirror, _Made(paper_mirror, 0.0, 1.0, None), STEP_MM)
    lo, hi = used_extent(paper_mirror, 0)
    i = int(round((lo + 0.7 * (hi - lo)) / bank.dr[0])) // STRIDE * STRIDE
    return bank.r0[0] + (i + 1) * bank.dr[0] - 0.002, i, -0.4 * bank.dr[0]


def _slope_rms(paper_mirror, made, tool_x_mm):
    bank = SurfaceBank.fixed(paper_mirror, made, STEP_MM)
    tr = Trials.nominal(1, 0.2, 0.0)
    tr.tool_x_mm[:] = tool_x_mm
    samples = tuple(pixel_sample(paper_mirror, k, bin_px=20.0, azimuths=6) for k in (0, 1))
    fig = evaluate(paper_mirror, bank, tr, samples, calibrate=False)
    return bank, fig


def _hand_rms(paper_mirror, bank, amp, wave, tool_x_mm, r_end):
    """RMS slope error (rad), closed form, at the criterion's radii r (the grid's stride
    within the used zone) whose part point q = r - tool_x (the part shifted by the tool
    setting) lies on the lobe, short of the wall's cell: the made slope there, the design's
    at q plus the ripple's, against the design's at r."""
    r = bank.r0[0] + bank.dr[0] * np.arange(0, bank.n[0], STRIDE)
    lo, hi = used_extent(paper_mirror, 0)
    r = r[(r >= lo) & (r <= hi)]
    q = r - tool_x_mm
    r, q = r[q < r_end], q[q < r_end]
    k = 2 * math.pi / wave
    made = paper_mirror.inner.slope(q) + amp * k * np.cos(k * q)
    err = np.arctan(made) - np.arctan(paper_mirror.inner.slope(r))
    return float(np.sqrt(np.mean(err**2)))


def test_the_case_is_the_one_the_mask_missed(paper_mirror):
    """The sample past the wall's foot is within OFF_SURFACE_MM of the design (the height
    rule alone keeps it), and its cell's chord is the wall's."""
    r_c, i, _ = _case(paper_mirror)
    made = _Made(paper_mirror, 0.0, 1.0, r_c)
    bank = SurfaceBank.fixed(paper_mirror, made, STEP_MM)
    r = bank.grid(0)[i:i + 3]
    dev = made.z(r) - paper_mirror.inner.z(r)
    assert dev[0] == pytest.approx(0.0, abs=1e-12)
    assert 0.0 < -dev[1] < OFF_SURFACE_MM  # 2 um down the wall: 0.04 mm
    assert -dev[2] >= OFF_SURFACE_MM
    assert abs(dev[1] - dev[0]) / bank.dr[0] > JUMP_SLOPE


@pytest.mark.parametrize("amp_mm, judged_fails", [(0.0, False), (2e-4, False), (3e-3, True)])
def test_a_wall_in_the_lobe_is_no_slope_error_and_a_real_one_still_is(paper_mirror, amp_mm, judged_fails):
    """The inner lobe's RMS slope error with the wall moved into it equals the hand model's
    over the lobe short of the wall's cell (to 2 %): the wall adds nothing. With no ripple
    the figure is the tool setting's shift alone (0.13 mrad); a ripple of 0.2 um over
    0.5 mm (2.5 mrad peak) passes the 0.02 rad limit; one of 3 um (38 mrad peak, 27 RMS)
    still fails it, wall or no wall."""
    wave = 0.5
    r_c, _, tool_x = _case(paper_mirror)
    bank, fig = _slope_rms(paper_mirror, _Made(paper_mirror, amp_mm, wave, r_c), tool_x)
    hand = _hand_rms(paper_mirror, bank, amp_mm, wave, tool_x, r_end=r_c - bank.dr[0])
    got = float(fig.slope_error_rad_rms[0, 0])
    assert got == pytest.approx(hand, rel=0.02)
    assert (got > 0.02) is judged_fails
    # without the wall the same lobe's figure is the hand model's over the whole used zone
    _, whole = _slope_rms(paper_mirror, _Made(paper_mirror, amp_mm, wave, None), tool_x)
    assert float(whole.slope_error_rad_rms[0, 0]) == pytest.approx(
        _hand_rms(paper_mirror, bank, amp_mm, wave, tool_x, r_end=np.inf), rel=0.02)

