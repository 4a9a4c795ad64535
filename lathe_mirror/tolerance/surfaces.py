"""The made surfaces the trials are cut with: one program's part, re-machined per trial.

What varies from part to part in the shop, and how each trial gets its own surface:

- the lattice phase (where the work zero falls on the controller's lattice): one of
  `phases` realisations, each a program planned, cut and polished
  (job.made_surface, then the polishing snapshots), drawn uniformly;
- the nose radius: the drawn nose, rounded to `nose_step` (mm), is the nose the part is
  cut with: a machining of its own (made when a trial first draws it), not a blend of
  neighbouring surfaces. A nose larger than the program's moves the step's wall into the
  outer lobe (a groove as wide as the excess) and a smaller one leaves a rim as wide on
  the inner lobe, besides moving the whole cut along the normal: features that appear and
  move with the nose, which interpolating between surfaces cut with other noses smears
  (measured on the best program at 0.205 mm, between nodes 0.2 and 0.21 mm: 1.55 px
  interpolated against 2.41 px re-machined, in the old figures);
- the polishing time: linear between snapshots of each surface's one polishing run.

Polishing a part cut with another nose: the pad polishes the lobes as that nose cut
them (its offset along the normal, its facets' rounding), but not the groove or rim a few
micrometres wide at the step's wall, which it does not reach. So each nose's part is
polished with that junction zone (the samples more than OFF_SURFACE_MM off the design,
and one on either side) filled in from the programmed nose's part moved by the nose's
offset next to it, and the groove or rim is put back afterwards, as cut
(leave_junction=True, the default). Polishing the part as cut (leave_junction=False)
hands polishing.py a groove sample 1.3 mm deep at the outer lobe's edge, which its pad
fit spreads over the 6 mm pad (~8 px of image displacement over 2 mm of the lobe), and
for a smaller nose a rim that flips polishing._recessed_lobe, so the figures jump with
how the wall falls on the 5 um polishing grid (best program, calibrated RMS image
displacement from +5 to +25 um: 0.9, 0.3, 0.9, 1.5, 0.4, 4.5, 0.4, 3.7, 0.4, 8.0 px).
Carrying the cut's change through polishing unpolished instead keeps the paper program's
facets' change unpolished (1.1 -> 3.5 px at -/+ 4 um).

The phase and the nose combine additively (the phase's surface plus the nose's change
on the phase-0 part): the phase moves the program along the axis on the lattice, the
nose moves the cut along the normal and the wall across it, so the two barely interact;
benchmarks/bench_tolerance.py --bias measures it against parts cut with both at once.

Each surface is sampled per lobe on the polishing grid (z and slope, camera frame, mm).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from ..compute import active
from ..design import Mirror
from ..polishing import polish_series
from ..profile import LobeSamples, Profile, SampledProfile

#: Polishing-time snapshots per machined surface, as fractions of the time tolerance.
TIME_NODES = (-1.0, -0.75, -0.5, -0.25, 0.0, 0.25, 0.5, 0.75, 1.0)
#: Height (mm) by which a made surface must miss the design for a sample to be no part of
#: the lobe's surface (the groove or rim at the step; polishing's form change is ~0.04 mm).
OFF_SURFACE_MM = 0.1
#: Slope (dimensionless) by which the chords either side of a sample must differ for the
#: sample to sit at a jump (the step's wall, a groove), and by which a cell's chord must
#: miss the design's for the cell to be no part of the lobe (off_lobe_cells): 0.5 is a
#: kink of ~25 deg, far beyond any facet of a program on the lattice and 25x the slope
#: error the spec allows (0.02 rad).
JUMP_SLOPE = 0.5


class SurfaceBank:
    """Sampled made surfaces of one program's part: per lattice phase (cut with the
    programmed nose, polished at `time_s`) and per nose radius drawn (cut at phase 0).

    machine_at(phase, nose_radius) -> a made surface (attribute `profile`, camera frame):
    the pipeline's builder for the program, cut at that lattice phase (steps) with a nose
    of that radius (mm). Phases are made up front, noses on demand (`ensure`).
    polish_params: the polishing (None: the surfaces are used as cut).
    """

    def __init__(self, mirror: Mirror, machine_at: Callable, polish_params, time_s: np.ndarray,
                 phases: np.ndarray, nose0: float, nose_step: float, *, grid_step_mm: float | None = None,
                 leave_junction: bool = True, progress=None):
        self.mirror = mirror
        self.machine_at = machine_at
        self.polish_params = polish_params
        self.leave_junction = bool(leave_junction)
        self.time_s = np.asarray(time_s, float)
        self.phases = np.asarray(phases, float)
        self.nose0 = float(nose0)
        self.nose_step = float(nose_step)
        step = grid_step_mm if grid_step_mm is not None else polish_params.grid_step_mm
        grids = []
        for k in (0, 1):
            lo, hi = (0.0, mirror.r_junction) if k == 0 else (mirror.r_junction, mirror.r_max)
            n = int(math.ceil((hi - lo) / step)) + 1
            grids.append((lo, (hi - lo) / (n - 1), n))
        self.r0 = (grids[0][0], grids[1][0])
        self.dr = (grids[0][1], grids[1][1])
        self.n = (grids[0][2], grids[1][2])
        T = self.time_s.size
        self.phase_z = [np.empty((self.phases.size, T, n)) for n in self.n]
        self.phase_s = [np.empty((self.phases.size, T, n)) for n in self.n]
        self.source = ""
        self._cut0: list[tuple[np.ndarray, np.ndarray]] = []
        for p, (source, cut0, sampled) in enumerate(_on_executor(self, _cut_phase, list(range(self.phases.size)),
                                                                 progress)):
            if p == 0:
                self.source, self._cut0 = source, cut0
            for k, (z, s) in enumerate(sampled):
                self.phase_z[k][p], self.phase_s[k][p] = z, s
        #: nose offset index m (nose = nose0 + m nose_step) -> row of the nose tables
        self._rows: dict[int, int] = {0: 0}
        self._nose_dz = [[np.zeros((T, n))] for n in self.n]
        self._nose_ds = [[np.zeros((T, n))] for n in self.n]

    @classmethod
    def fixed(cls, mirror: Mirror, profile: Profile, grid_step_mm: float, *, nose_mm: float = 0.2,
              time_s: float = 0.0) -> "SurfaceBank":
        """A bank holding one given surface (its z and slope on the grid, not polished):
        every trial is cut the same, whatever its phase, nose and polishing time (a part
        that exists: tolerance.measured). The nose step is the nose itself, so that a trial
        that draws no nose error keeps nose_mm (the draw's floor is one step)."""
        return cls(mirror, lambda phase, nose: _Given(profile), None, np.array([time_s]), np.array([0.0]),
                   nose_mm, nose_mm if nose_mm > 0 else 1.0, grid_step_mm=grid_step_mm)

    # ----------------------------------------------------------------------------------

    @property
    def nose_mm(self) -> np.ndarray:
        """The nose radii (mm) cut so far, in the order they were cut."""
        return np.array([self.nose0 + m * self.nose_step for m in self._rows])

    def nose_index(self, nose_mm: np.ndarray) -> np.ndarray:
        """Offset index m of each nose radius (mm) on the nose step (rounded)."""
        return np.rint((np.asarray(nose_mm, float) - self.nose0) / self.nose_step).astype(np.int64)

    def snapped(self, nose_mm: np.ndarray) -> np.ndarray:
        """The nose radius each trial is cut with: nose_mm rounded to the step (mm)."""
        return self.nose0 + self.nose_index(nose_mm) * self.nose_step

    def missing(self, nose_mm: np.ndarray) -> np.ndarray:
        """Offset indices of the noses (mm, rounded to the step) not cut yet."""
        m = np.unique(self.nose_index(nose_mm))
        return np.array([int(i) for i in m if int(i) not in self._rows], dtype=np.int64)

    def ensure(self, nose_mm: np.ndarray, progress=None) -> int:
        """Cut (at phase 0) and polish every nose radius (mm, rounded to the step) not cut
        yet; returns how many were cut."""
        todo = [int(m) for m in self.missing(nose_mm)]
        for m in todo:
            nose = self.nose0 + m * self.nose_step
            if not nose > 0:
                raise ValueError(f"nose radius {nose:g} mm: a trial drew a nose <= 0")
        for m, polished in zip(todo, _on_executor(self, _cut_nose, todo, progress)):
            for k, (z, s) in enumerate(polished):
                self._nose_dz[k].append(z - self.phase_z[k][0])
                self._nose_ds[k].append(s - self.phase_s[k][0])
            self._rows[m] = len(self._rows)
        return len(todo)

    def trial_surface(self, k: int, phase: np.ndarray, nose_mm: np.ndarray, time_s: np.ndarray,
                      tool_z_mm: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(z, slope) of lobe k of each trial on the lobe's grid, shape (trials, n): its
        phase's surface plus its nose's change, linear in polishing time between the
        snapshots, the whole surface moved tool_z_mm (mm) along the axis."""
        rows = np.array([self._rows[int(m)] for m in self.nose_index(nose_mm)], dtype=np.intp)
        i, wt = _interp_weights(np.asarray(time_s, float), self.time_s)
        i1 = np.minimum(i + 1, self.time_s.size - 1)
        w0, w1 = (1.0 - wt)[:, None], wt[:, None]
        p = np.asarray(phase, np.intp)
        used = np.unique(rows)
        local = np.searchsorted(used, rows)
        dz = np.stack([self._nose_dz[k][j] for j in used])
        ds = np.stack([self._nose_ds[k][j] for j in used])
        z = w0 * (self.phase_z[k][p, i] + dz[local, i]) + w1 * (self.phase_z[k][p, i1] + dz[local, i1])
        s = w0 * (self.phase_s[k][p, i] + ds[local, i]) + w1 * (self.phase_s[k][p, i1] + ds[local, i1])
        return z + np.asarray(tool_z_mm, float)[:, None], s

    def design_z(self, k: int) -> np.ndarray:
        """The design's z (mm) at lobe k's samples."""
        if not hasattr(self, "_design_z"):
            self._design_z = [self.mirror.lobes[j].z(self.grid(j)) for j in (0, 1)]
        return self._design_z[k]

    def grid(self, k: int) -> np.ndarray:
        """The radii (mm) of lobe k's samples (the outer lobe's first just past the junction),
        each within its lobe's extent: r0 + dr (n - 1) may round one ulp past the lobe's end,
        where a profile is the other sheet (the inner lobe's last sample then took the outer
        sheet's z and slope for every nose cut: gs2mp's winner judged 69.4 % with its lobes
        as optimize found them, 97.2 % as the file rounds them)."""
        r = self.r0[k] + self.dr[k] * np.arange(self.n[k])
        if k == 1:
            r[0] = np.nextafter(r[0], np.inf)
        return np.minimum(r, self.mirror.r_junction if k == 0 else self.mirror.r_max)

    # ----------------------------------------------------------------------------------

    def _polished_nose(self, cut: Profile) -> list[tuple[np.ndarray, np.ndarray]]:
        """A part cut with another nose, polished at every snapshot: (z, slope) per lobe,
        (snapshots, n); the junction zone left as cut (leave_junction, module doc)."""
        if self.polish_params is None:
            return self._sample(cut)
        if not self.leave_junction:
            return self._sample(cut)

        m = self.mirror
        pad, zone, z_cut = [], [], []
        for k in (0, 1):
            r = self.grid(k)
            z = np.asarray(cut.z(r), float)
            off = np.abs(z - m.lobes[k].z(r)) >= OFF_SURFACE_MM
            off = off | np.concatenate([off[1:], [False]]) | np.concatenate([[False], off[:-1]])
            keep = np.flatnonzero(~off)
            fill = z.copy()
            if off.any() and keep.size:
                d = z[keep] - self._cut0[k][0][0][keep]
                fill[off] = self._cut0[k][0][0][off] + np.interp(np.flatnonzero(off), keep, d)
            pad.append(LobeSamples(r, fill))
            zone.append(off)
            z_cut.append(z)
        padded = SampledProfile(pad[0], pad[1], r_junction=m.r_junction, r_max=m.r_max, vertex_z=cut.vertex_z)
        out = []
        for k, (z, _) in enumerate(self._sample(padded)):
            z = np.where(zone[k][None, :], z_cut[k][None, :], z)  # the groove or rim, as cut
            out.append((z, _sample_slopes(self.grid(k), z)))
        return out

    def _sample(self, profile: Profile, *, polished: bool = True) -> list[tuple[np.ndarray, np.ndarray]]:
        """(z, slope) per lobe on the grid, (snapshots, n): polished at every snapshot time
        (or as cut, one row per snapshot)."""
        T = self.time_s.size
        polished = polished and self.polish_params is not None
        snaps = polish_series(profile, self.polish_params, self.time_s) if polished else [profile]
        out = []
        for k in (0, 1):
            r = self.grid(k)
            z = np.stack([p.z(r) for p in snaps])
            if not polished:
                z = np.repeat(z, T, axis=0)
                out.append((z, np.repeat(profile.slope(r)[None], T, axis=0)))
                continue
            # A polished surface is known by its samples (the polishing grid is this grid);
            # its spline's slope rings for ~10 cells past a jump (the groove a larger nose
            # cuts at the step: +/- 2 rad), so take the samples' own differences (accurate
            # to h^2 z''' / 6 ~ 1e-9 rad on a smooth lobe).
            out.append((z, _sample_slopes(r, z)))
        return out


class _Given:
    """A made surface stand-in for SurfaceBank.fixed."""

    def __init__(self, profile: Profile):
        self.profile, self.source = profile, "a given surface"


def time_nodes(nominal_time_s: float, tolerance_s: float) -> np.ndarray:
    """Polishing-time snapshots (s, ascending, >= 0): nominal + TIME_NODES x tolerance."""
    return np.unique(np.clip([nominal_time_s + f * tolerance_s for f in TIME_NODES], 0.0, None))


def off_lobe_cells(z: np.ndarray, design_z: np.ndarray, dr: float) -> np.ndarray:
    """Which cells of a made surface's samples (between samples i and i + 1; z: (..., n) mm,
    design_z: (n,) mm, the grid's step dr mm) are no part of the lobe's surface, (..., n - 1):
    a cell with a sample OFF_SURFACE_MM or more off the design (the step's wall moved into
    the lobe, a groove's floor), or whose chord misses the design's by more than JUMP_SLOPE
    (the cell the wall's foot or the nose's corner falls in: a sample a few micrometres
    down the corner is within OFF_SURFACE_MM, yet the cell's slope is the wall's). The
    samples cannot say where in such a cell the lobe ends, so the whole cell is off: a ray
    landing there hits the wall, and no slope of the lobe is judged there."""
    dev = np.asarray(z, float) - np.asarray(design_z, float)
    off = np.abs(dev) >= OFF_SURFACE_MM
    return off[..., :-1] | off[..., 1:] | (np.abs(np.diff(dev, axis=-1)) > JUMP_SLOPE * dr)


def _sample_slopes(r: np.ndarray, z: np.ndarray) -> np.ndarray:
    """dz/dr at each sample (rows of z): central differences, or the gentler one-sided chord
    where the two chords differ by more than JUMP_SLOPE."""
    chord = np.diff(z, axis=-1) / np.diff(r)
    left = np.concatenate([chord[..., :1], chord], axis=-1)
    right = np.concatenate([chord, chord[..., -1:]], axis=-1)
    central = np.gradient(z, r, axis=-1)
    gentle = np.where(np.abs(left) < np.abs(right), left, right)
    return np.where(np.abs(left - right) > JUMP_SLOPE, gentle, central)


def _interp_weights(x: np.ndarray, nodes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Lower node index and weight of the upper node (linear; extrapolates past the ends)."""
    if nodes.size == 1:
        return np.zeros(x.shape, dtype=np.intp), np.zeros(x.shape)
    j = np.clip(np.searchsorted(nodes, x, side="right") - 1, 0, nodes.size - 2)
    span = nodes[j + 1] - nodes[j]
    w = np.where(span > 0, (x - nodes[j]) / np.where(span > 0, span, 1.0), 0.0)
    return j, w


def _on_executor(bank: SurfaceBank, fn, items: list, progress) -> list:
    """fn(bank, item) for each item, on the command's executor (lathe_mirror.compute:
    each part cut and polished whole by one worker, the results in item order)."""
    ex = active()
    if ex.workers == 1 or len(items) < 2:
        out = []
        for item in items:
            out.append(fn(bank, item))
            if progress is not None:
                progress.update(1)
        return out
    with ex.bound(bank) as run:
        return run.map(fn, items, progress=progress)


def _cut_phase(bank: SurfaceBank, p: int):
    """(source, the part as cut, the part polished at every snapshot) of lattice phase p."""
    made = bank.machine_at(float(bank.phases[p]), bank.nose0)
    cut0 = bank._sample(made.profile, polished=False) if p == 0 else []
    return made.source, cut0, bank._sample(made.profile)


def _cut_nose(bank: SurfaceBank, m: int):
    """Nose offset m's part (phase 0), polished at every snapshot."""
    return bank._polished_nose(bank.machine_at(0.0, bank.nose0 + m * bank.nose_step).profile)
