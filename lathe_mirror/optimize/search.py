"""The search: seeded differential evolution over the design vector, evaluations batched
over worker processes, every candidate recorded for the Pareto fronts.

scipy.optimize.differential_evolution (best1bin, Latin-hypercube start, `updating=
"deferred"`: a whole generation is proposed, then evaluated) with the configured design
put into the first population (`x0`, when it lies in the search space), so the winner is
never worse than it. Energies (evaluate.evaluate): -objective for a feasible design,
above every feasible one for an infeasible design (by its summed violation), highest for
a vector that designs no mirror. The same seed gives the same winner whatever the number
of workers: the generation is proposed before any of it is evaluated.

No design in the space meets the constraints: `NoFeasibleDesign` (an InputError) names the
binding constraint: the one the least-infeasible candidate breaks most.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from .evaluate import CONSTRAINTS, INFEASIBLE, NO_DESIGN, RECORD, Figures, Problem, design_of, evaluate, figures
from .evaluate import vector_of
from .pareto import pareto_front


class NoFeasibleDesign(InputError):
    """No design in the search space meets every constraint; the message names the
    binding constraint and how close the search came."""


@dataclass(frozen=True)
class History:
    """Every candidate the search evaluated (rows in evaluation order).

    x: design vectors (n, 6); energy: (n,); records: (n, len(RECORD) + len(CONSTRAINTS))
    (evaluate.RECORD's fields, then each constraint's violation; NaN: no design).
    """

    x: np.ndarray
    energy: np.ndarray
    records: np.ndarray

    @property
    def feasible(self) -> np.ndarray:
        return self.energy < INFEASIBLE

    def column(self, name: str) -> np.ndarray:
        return self.records[:, RECORD.index(name)]


@dataclass(frozen=True)
class SearchResult:
    """The winner, the configured design it is compared with, and how the search went.

    best / best_figures: the winner's LobeSpecs (r_top, r_pixel, alpha_deg) and figures.
    reference_figures: the configured design's (None if it designs no mirror on this
    camera); reference_feasible: whether it meets the constraints. gain: winner's
    objective / reference's (None without a reference). evaluations, generations,
    seconds, converged (DE's tolerance met before maxiter). history: every candidate;
    pareto_band / pareto_depth: indices into history of the feasible candidates on the
    fronts (objective vs common-band width, both maximised; objective maximised vs
    mirror depth minimised).
    """

    best: tuple
    best_figures: Figures
    reference_figures: Figures | None
    reference_feasible: bool
    gain: float | None
    evaluations: int
    generations: int
    seconds: float
    converged: bool
    workers: int
    history: History
    pareto_band: np.ndarray
    pareto_depth: np.ndarray

    @property
    def evaluations_per_second(self) -> float:
        return self.evaluations / self.seconds if self.seconds > 0 else float("nan")


def search(problem: Problem, *, workers: int | None = None, progress: bool = False) -> SearchResult:
    """Search the design space of `problem` (module doc). workers: processes evaluating
    each generation (default the settings'); progress: a bar of generations on stderr."""
    from scipy.optimize import differential_evolution

    from ..progress import bar  # lazy: progress off the CLI's start-up path

    s = problem.settings
    workers = s.workers if workers is None else int(workers)
    if not 1 <= workers <= 64:
        raise InputError(f"--workers {workers}: allowed 1 .. 64")
    bounds = np.array(s.margin_bounds(), dtype=float)  # bound_margin clear of the search's bounds
    free = bounds[:, 1] > bounds[:, 0]
    fixed = bounds[:, 0].copy()
    t0 = time.perf_counter()
    batch = _Batch(problem, free, fixed, workers)
    x0 = None
    try:
        ref = vector_of(problem.reference, problem)
        if np.all(ref >= bounds[:, 0] - 1e-12) and np.all(ref <= bounds[:, 1] + 1e-12) \
                and np.allclose(ref[~free], fixed[~free], rtol=0, atol=1e-12):
            x0 = np.clip(ref, bounds[:, 0], bounds[:, 1])[free]
    except (InputError, ValueError):
        pass
    if not np.any(free):
        energy, rec = evaluate(fixed, problem)
        batch.record(fixed[None], np.array([energy]), rec[None])
        generations, converged = 0, True
    else:
        pbar = bar(s.maxiter, "optimize", progress)
        state = {"generations": 0}

        def callback(intermediate_result):
            state["generations"] += 1
            pbar.update(1)
            e = intermediate_result.fun
            if e < INFEASIBLE:
                pbar.set_postfix_str(f"best {s.objective.value} {-e:.4g}")

        try:
            res = differential_evolution(
                batch.energy_one, bounds[free].tolist(), strategy="best1bin", maxiter=s.maxiter,
                popsize=s.popsize, tol=s.tol, mutation=(0.5, 1.0), recombination=0.7, rng=s.seed,
                polish=False, init="latinhypercube", updating="deferred", workers=batch.map,
                x0=x0, callback=callback)
        except BaseException:  # a signal or an error: the workers are killed, not awaited
            pbar.close()
            batch.close(abort=True)
            raise
        pbar.close()
        batch.close()
        generations, converged = state["generations"], bool(res.success)
    seconds = time.perf_counter() - t0
    hist = batch.history()
    best_i = int(np.argmin(hist.energy))
    if hist.energy[best_i] >= INFEASIBLE:
        raise NoFeasibleDesign(_binding_message(hist, problem))
    best = design_of(hist.x[best_i], problem)
    best_fig = figures(best, problem)
    ref_fig, ref_ok, gain = None, False, None
    try:
        ref_fig = figures(problem.reference, problem)
        ref_ok = evaluate(vector_of(problem.reference, problem), problem)[0] < INFEASIBLE
        ref_obj = ref_fig.objective(s.objective)
        gain = best_fig.objective(s.objective) / ref_obj if ref_obj > 0 else None
    except (InputError, ValueError):
        pass
    feas = np.flatnonzero(hist.feasible)
    obj = hist.column("objective")[feas]
    band_front = feas[pareto_front(obj, hist.column("band_width_deg")[feas])]
    depth_front = feas[pareto_front(obj, -hist.column("depth_mm")[feas])]
    return SearchResult(best=best, best_figures=best_fig, reference_figures=ref_fig,
                        reference_feasible=ref_ok, gain=gain, evaluations=len(hist.energy),
                        generations=generations, seconds=seconds, converged=converged, workers=workers,
                        history=hist, pareto_band=band_front, pareto_depth=depth_front)


# --------------------------------------------------------------------------------------
# Evaluation in batches, in this process or in a pool of workers


def _evaluate_chunk(problem: Problem, xs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(energies, records) of a chunk of full design vectors (in a worker: compute)."""
    return _evaluate_all(xs, problem)


def _evaluate_all(xs: np.ndarray, problem: Problem) -> tuple[np.ndarray, np.ndarray]:
    out = [evaluate(x, problem) for x in xs]
    return np.array([e for e, _ in out]), np.array([r for _, r in out])


class _Batch:
    """DE's map-like `workers`: evaluates a generation's vectors in `workers` chunks (on
    compute's executor when workers > 1) and records every candidate in evaluation order."""

    def __init__(self, problem: Problem, free: np.ndarray, fixed: np.ndarray, workers: int) -> None:
        self.problem, self.free, self.fixed, self.workers = problem, free, fixed, workers
        self._x: list[np.ndarray] = []
        self._e: list[np.ndarray] = []
        self._r: list[np.ndarray] = []
        self._bound = self.run = None
        if workers > 1:  # compute's executor: the command's session, or local processes of our own
            from ..compute import active, make  # lazy: compute off the CLI's start-up path

            ex = active()
            if ex.kind != "dask" and ex.workers != workers:
                ex = make(workers)
            self._bound = ex.bound(problem)
            self.run = self._bound.__enter__()

    def full(self, xs: np.ndarray) -> np.ndarray:
        out = np.tile(self.fixed, (len(xs), 1))
        out[:, self.free] = xs
        return out

    def energy_one(self, x: np.ndarray) -> float:
        """One free vector's energy (DE's func; the batch map evaluates whole generations)."""
        xs = self.full(np.asarray(x, dtype=float)[None])
        e, r = _evaluate_all(xs, self.problem)
        self.record(xs, e, r)
        return float(e[0])

    def map(self, func, iterable) -> list[float]:
        xs = self.full(np.array(list(iterable), dtype=float))
        if self.run is None:
            e, r = _evaluate_all(xs, self.problem)
        else:
            chunks = np.array_split(xs, self.workers)
            parts = self.run.map(_evaluate_chunk, [c for c in chunks if len(c)])
            e = np.concatenate([p[0] for p in parts])
            r = np.concatenate([p[1] for p in parts])
        self.record(xs, e, r)
        return e.tolist()

    def record(self, xs: np.ndarray, e: np.ndarray, r: np.ndarray) -> None:
        self._x.append(xs)
        self._e.append(np.asarray(e, dtype=float))
        self._r.append(np.asarray(r, dtype=float))

    def history(self) -> History:
        return History(np.concatenate(self._x), np.concatenate(self._e), np.concatenate(self._r))

    def close(self, abort: bool = False) -> None:
        """End the workers: let them finish, or (abort) kill them at once."""
        if self._bound is not None:
            bound, self._bound, self.run = self._bound, None, None
            if abort:
                import sys

                bound.__exit__(*sys.exc_info())
            else:
                bound.__exit__(None, None, None)


def _binding_message(hist: History, problem: Problem) -> str:
    """One line: the constraint the least-infeasible candidate breaks most, its limit and
    how close the search came."""
    k = len(RECORD)
    designed = np.flatnonzero(hist.energy < NO_DESIGN)
    if designed.size == 0:
        return ("optimize.search: no vector in the search space designs a mirror on this camera "
                "(widen the alpha or fraction ranges)")
    i = designed[int(np.argmin(hist.energy[designed]))]
    v = hist.records[i, k:]
    j = int(np.argmax(v))
    c = CONSTRAINTS[j]
    fig = figures(design_of(hist.x[i], problem), problem)
    got, limit = c.value(fig, problem)
    unit = f" {c.unit}" if c.unit else ""
    others = [CONSTRAINTS[m].key_for(problem) for m in np.flatnonzero(v > 0) if m != j]
    also = f"; it also breaks {', '.join(dict.fromkeys(others))}" if others else ""
    bound = "at most" if c.sense > 0 else "at least"
    return (f"{c.key_for(problem)}: no design in the search space meets every constraint; binding: {c.what} must be "
            f"{bound} {_fmt(limit)}{unit}, the closest design found has {_fmt(got)}{unit}{also}")


def _fmt(v: float) -> str:
    return f"{v:.4g}" if math.isfinite(v) else str(v)


def alternates(result: SearchResult, problem: Problem, n: int = 4, spacing: float = 0.05) -> list[tuple]:
    """Up to n runner-up designs (LobeSpecs), best objective first: feasible candidates of
    the search, each at least `spacing` (a fraction of every searched range, in the largest
    coordinate) from the winner and from one another, so that each is a different design
    and not the winner's neighbour on the same ridge. For a winner that fails a check the
    search does not model (the tolerance verdict on the made part)."""
    h = result.history
    bounds = np.array(problem.settings.margin_bounds(), dtype=float)
    span = np.where(bounds[:, 1] > bounds[:, 0], bounds[:, 1] - bounds[:, 0], 1.0)
    order = np.argsort(h.energy, kind="stable")
    picked = [vector_of(result.best, problem) / span]
    out = []
    for i in order:
        if h.energy[i] >= INFEASIBLE or len(out) >= n:
            break
        x = h.x[i] / span
        if all(np.max(np.abs(x - p)) >= spacing for p in picked):
            picked.append(x)
            out.append(design_of(h.x[i], problem))
    return out
