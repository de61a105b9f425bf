"""One tuner: a search over an engine's space, evaluating a population of candidates at once.

Every fit in the suite — the ball's contact parameters (:mod:`impactbench.tuning.optimize`), the
oblique impact's friction knobs (:mod:`impactbench.tuning.oblique`) and the cube tosses'
contact parameters (:mod:`impactbench.cube_tosses.tune`, and the reference model's fit) — is a
:func:`search` of three parts:

- **a space**: named knobs (:class:`Knob`: bounds, log or linear, a categorical's choices, the
  start), as :class:`KnobSpace` (both in the engine layer, :mod:`impactbench.engines.knobs`,
  beside the engines' spaces; re-exported here); the ball's own
  :class:`impactbench.engines.tuning_spaces.Space` (all log knobs, mapped with numpy) is the
  other :class:`UnitSpace`. Where a knob set lives:
  the engine's :class:`~impactbench.engines.registry.EngineSpec` names it (``tuning``: the
  ball's parameterisations; ``spaces``: the oblique friction knobs and the cube tosses').
- **an objective evaluated on a batch**: :class:`BatchObjective` ``evaluate_batch(candidates)
  -> [J, …]`` takes a population of parameter sets (dicts, knob name → value) at once, so that
  whatever runs the engine sees a whole generation (:class:`ResidualObjective` adds
  ``residuals_batch`` for least squares). Evaluations are counted and budgeted in candidate
  order, so a batch changes no number: the same candidates are evaluated, in the same order,
  with the same best. What batches where:

  - ball (:class:`impactbench.tuning.objective.Objective`): each Sobol-scan slice and each
    finite-difference Jacobian is one batch; its engine runs go to the engine together
    (:func:`impactbench.evaluate.compare_many` → :meth:`Adapter.run_many`): MJX runs them as
    one ``vmap`` over worlds, Newton as one model with a world per run (their
    ``run_ball_batch``: each world driven by its lone run's plan and end rule,
    :func:`impactbench.engines.mujoco_adapter.drive_many`, its record the lone run's bit for
    bit; a 24-run generation 1.5x (MJX) and 14x (Newton) faster than one by one on two CPU
    cores, ``python -m benchmarks bench_engine_mjx`` / ``bench_engine_newton``), the other
    engines one by one; with ``--workers`` the batch is shared out over the Dask workers, a
    slice each.
  - oblique (:mod:`impactbench.tuning.oblique`): each Sobol scan and each Nelder–Mead initial
    simplex is one batch, run one by one (a run is milliseconds).
  - cube tosses (:mod:`impactbench.cube_tosses.tune`): each CMA-ES generation is one batch of
    runs through :func:`impactbench.matrix.run_jobs` (the results store serves what it has; the
    rest run in this process, or on Dask workers with ``workers``); inside each run the MJX and
    Newton builders replay every toss in one call.

- **a method** (:data:`METHODS`), the algorithm each fit has always used:

  - ``least_squares``: scipy ``least_squares`` (trust-region reflective, bounded, forward
    differences), after an optional seeded scrambled Sobol scan (scipy ``qmc``), from the start
    and the best scan points (:func:`least_squares`);
  - ``nelder_mead``: the categorical knobs' combinations in turn, each a seeded Sobol scan and a
    bounded scipy Nelder–Mead from the best point seen (:func:`nelder_mead`);
  - ``nevergrad``: any nevergrad optimiser (``CMA`` by default: the ``cma`` package's CMA-ES),
    asked and told a generation at a time (:func:`nevergrad`).

Budgets: an objective or :class:`Tracker` raises :class:`OutOfBudget` at the first candidate
past its budget; the method stops there, keeping the best so far.
"""

from __future__ import annotations

import math
import time
import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

from impactbench.engines.knobs import Knob, KnobSpace

SEED = 20240607
"""The default seed of every seeded stage (Sobol scans, nevergrad)."""

Candidate = dict[str, Any]
"""One parameter set: knob name → value (a float, or a categorical's choice)."""


class OutOfBudget(Exception):
    """The time or evaluation budget is spent (the search stops, keeping the best)."""


class UnitSpace(Protocol):
    """A space the coordinate-based methods search: its continuous knobs map to the unit box."""

    @property
    def start_candidate(self) -> Candidate: ...

    def to_unit(self, candidate: Mapping[str, Any]) -> np.ndarray: ...

    def from_unit(self, u: Sequence[float], fixed: Mapping[str, Any] | None = None
                  ) -> Candidate: ...


class BatchObjective(Protocol):
    """J of a population of candidates, evaluated in order (a batch is a generation)."""

    def evaluate_batch(self, candidates: Sequence[Mapping[str, Any]]) -> list[float]: ...


class ResidualObjective(BatchObjective, Protocol):
    """A least-squares objective: J = Σ r², the residual vectors r of a batch at once."""

    def residuals_batch(self, candidates: Sequence[Mapping[str, Any]]) -> list[np.ndarray]: ...


class FunctionObjective:
    """A plain function ``run(candidate) -> J`` as a :class:`BatchObjective` (one at a time)."""

    def __init__(self, run: Callable[[Mapping[str, Any]], float]) -> None:
        self.run = run

    def evaluate_batch(self, candidates: Sequence[Mapping[str, Any]]) -> list[float]:
        return [float(self.run(c)) for c in candidates]


def candidate_key(candidate: Mapping[str, Any]) -> tuple[tuple[str, str], ...]:
    """A hashable, exact key of a candidate (values by ``repr``)."""
    return tuple((k, repr(v)) for k, v in candidate.items())


@dataclass
class Tracker:
    """An objective with an evaluation budget, a history and, with ``dedupe``, a memory of
    what it evaluated (a candidate seen before is served, not counted). ``progress`` hears
    (evaluations, budget, J, best J) after each new evaluation. :class:`OutOfBudget` is raised
    at the first new candidate past ``max_evals``, after the ones before it are evaluated."""

    objective: BatchObjective
    max_evals: int | None = None
    dedupe: bool = False
    progress: Callable[[int, int, float, float], None] | None = None
    evaluations: int = 0
    history: list[tuple[Candidate, float]] = field(default_factory=list)
    best: tuple[Candidate, float] | None = None
    _seen: dict[tuple, float] = field(default_factory=dict, repr=False)

    def evaluate_batch(self, candidates: Sequence[Mapping[str, Any]]) -> list[float]:
        keys = [candidate_key(c) for c in candidates]
        new: list[int] = []
        pending: set[tuple] = set()
        spent = False
        for i, key in enumerate(keys):
            if self.dedupe and (key in self._seen or key in pending):
                continue
            if self.max_evals is not None and self.evaluations + len(new) >= self.max_evals:
                spent = True
                break
            new.append(i)
            pending.add(key)
        values = self.objective.evaluate_batch([candidates[i] for i in new]) if new else []
        for i, value in zip(new, values, strict=True):
            value = float(value)
            cand = dict(candidates[i])
            self.evaluations += 1
            self._seen[keys[i]] = value
            self.history.append((cand, value))
            if self.best is None or value < self.best[1]:
                self.best = (cand, value)
            if self.progress is not None:
                self.progress(self.evaluations, int(self.max_evals or 0), value, self.best[1])
        if spent:
            raise OutOfBudget(f"budget of {self.max_evals} evaluations spent")
        if self.dedupe:
            return [self._seen[k] for k in keys]
        return [float(v) for v in values]


# ------------------------------------------------------------------------------ methods


@dataclass
class Outcome:
    """How a search ended: ``stop`` (``converged``, or why it stopped), a line per stage."""

    stop: str
    stages: list[str] = field(default_factory=list)


def least_squares(space: UnitSpace, objective: ResidualObjective, *, scan_points: int = 0,
                  seed: int = SEED, polish_starts: int = 2, diff_step: float = 1e-4,
                  max_nfev: int = 400, slice_size: int = 1) -> Outcome:
    """Bounded least squares in the unit box (the ball's search).

    1. with ``scan_points`` > 0, a scrambled Sobol scan (``seed``) of that many points,
       evaluated ``slice_size`` at a time (one batch each);
    2. ``scipy.optimize.least_squares`` (trf, bounds [0, 1], forward differences of step
       ``diff_step``, xtol 1e-8, ftol = gtol = 1e-10, ``max_nfev``) from the start and then
       from the ``polish_starts`` best scan points; each finite-difference Jacobian is one
       batch (scipy's ``workers`` map), its columns then read back in scipy's order.
    """
    from scipy import optimize

    done = 0
    ready: dict[bytes, list[np.ndarray]] = {}

    def residuals(us: Sequence[np.ndarray]) -> list[np.ndarray]:
        nonlocal done
        got = objective.residuals_batch([space.from_unit(u) for u in us])
        done += len(got)
        return got

    def fun(u: np.ndarray) -> np.ndarray:
        queued = ready.get(np.asarray(u, dtype=float).tobytes())
        return queued.pop(0) if queued else residuals([u])[0]

    def batched(f: Callable, points: Any) -> list:
        points = list(points)
        for u, r in zip(points, residuals(points), strict=True):
            ready.setdefault(np.asarray(u, dtype=float).tobytes(), []).append(r)
        return [f(u) for u in points]

    stages: list[str] = []
    starts = [space.to_unit(space.start_candidate)]
    dim = len(starts[0])
    try:
        if scan_points > 0:
            from scipy.stats import qmc  # scipy.stats costs ~0.5 s: only when tuning

            pts = qmc.Sobol(dim, scramble=True, seed=seed).random(scan_points)
            scored: list[tuple[float, tuple[float, ...]]] = []
            for i in range(0, len(pts), slice_size):
                chunk = pts[i:i + slice_size]
                values = objective.evaluate_batch([space.from_unit(u) for u in chunk])
                done += len(values)
                scored += [(j, tuple(u)) for j, u in zip(values, chunk, strict=True)]
            scored.sort()
            starts += [np.array(u) for _, u in scored[:polish_starts]]
            stages.append(f"Sobol scan: {scan_points} points, best J = {scored[0][0]:.6g}")
        for i, u0 in enumerate(starts):
            n0 = done
            res = optimize.least_squares(
                fun, u0, bounds=(0.0, 1.0), method="trf", diff_step=diff_step, x_scale=1.0,
                xtol=1e-8, ftol=1e-10, gtol=1e-10, max_nfev=max_nfev, workers=batched)
            stages.append(f"least_squares from {'start' if i == 0 else f'scan #{i}'}: "
                          f"J = {2.0 * res.cost:.6g} after {done - n0} evaluations "
                          f"({res.message})")
    except OutOfBudget as exc:
        stages.append(f"stopped: {exc}")
        return Outcome(str(exc), stages)
    return Outcome("converged", stages)


def nelder_mead(space: KnobSpace, objective: Tracker, *, seed: int = SEED,
                scan_max: int = 16, simplex_step: float = 0.25, xatol: float = 1e-4,
                fatol: float = 1e-12) -> Outcome:
    """The categorical knobs' combinations in turn (the start's first), the evaluation budget
    (``objective.max_evals``, the start included) shared out evenly; per combination its
    point at the start's coordinates, a scrambled Sobol scan (seed ``seed`` + the combination's
    index; 2^m points, m = min(log2(share/4), log2(``scan_max``)), when its share is ≥ 8) of
    the continuous knobs' box as one batch, and a bounded scipy Nelder–Mead from the best point
    seen (initial simplex: ``simplex_step`` along each coordinate, reflected inside; evaluated
    as one batch). ``objective`` dedupes, so a point seen before costs nothing. The start
    itself is evaluated first."""
    from scipy import optimize

    budget = objective.max_evals
    if budget is None:
        raise ValueError("max_evals = None: the Nelder-Mead search needs an evaluation budget")
    start = space.start_candidate
    cont = space.continuous
    u0 = space.to_unit(start)

    def one(candidate: Candidate) -> float:
        return objective.evaluate_batch([candidate])[0]

    stages: list[str] = []
    stop = "converged"
    try:
        one(dict(start))
        combos = space.combos()
        for ci, combo in enumerate(combos):
            last = ci == len(combos) - 1
            cap = budget if last else 1 + (budget - 1) * (ci + 1) // len(combos)
            n0 = objective.evaluations
            share = cap - n0
            seen = [(one(space.from_unit(u0, combo)), tuple(u0))]
            if cont and share >= 8:
                from scipy.stats import qmc  # scipy.stats costs ~0.5 s: only when fitting

                m = min(int(math.log2(max(1, share // 4))), int(math.log2(scan_max)))
                pts_u = qmc.Sobol(len(cont), scramble=True, seed=seed + ci).random_base2(m)
                values = objective.evaluate_batch([space.from_unit(u, combo) for u in pts_u])
                seen += [(j, tuple(u)) for j, u in zip(values, pts_u, strict=True)]
            seen.sort(key=lambda x: x[0])
            best_u = np.array(seen[0][1])
            line = f"{_combo_text(combo)}: scan of {len(seen) - 1}, best J = {seen[0][0]:.6g}"
            if cont:
                simplex = [best_u]
                for i in range(len(cont)):
                    u = best_u.copy()
                    u[i] = u[i] + simplex_step if u[i] + simplex_step <= 1.0 \
                        else u[i] - simplex_step
                    simplex.append(u)
                maxfev = max(0, cap - objective.evaluations) + 1  # x0: seen
                # the vertices scipy evaluates first (at most maxfev), as one batch
                objective.evaluate_batch([space.from_unit(u, combo)
                                          for u in simplex[:maxfev]])
                res = optimize.minimize(
                    lambda u, c=combo: one(space.from_unit(u, c)), best_u,
                    method="Nelder-Mead", bounds=[(0.0, 1.0)] * len(cont),
                    options={"initial_simplex": np.array(simplex), "xatol": xatol,
                             "fatol": fatol, "maxfev": maxfev})
                line += f"; Nelder-Mead: J = {float(res.fun):.6g} ({res.message.strip('.')})"
                if not res.success:
                    stop = "budget"
            stages.append(f"{line}; {objective.evaluations - n0} evaluations")
    except OutOfBudget as exc:
        stages.append(f"stopped: {exc}")
        stop = "budget"
    return Outcome(stop, stages)


def _combo_text(combo: Mapping[str, Any]) -> str:
    return ", ".join(f"{k} = {v!r}" for k, v in combo.items()) or "continuous knobs"


def parametrization(knobs: Sequence[Knob], seed: int) -> Any:
    """The knobs as a seeded nevergrad ``Dict`` parametrization (``Log``, ``Scalar`` or a
    deterministic ``Choice`` each, initialised at the knob's start)."""
    import nevergrad as ng

    entries = {}
    for k in knobs:
        if k.choices:
            entries[k.name] = ng.p.Choice(list(k.choices), deterministic=True)
        elif k.log:
            entries[k.name] = ng.p.Log(init=k.start, lower=k.low, upper=k.high)
        else:
            entries[k.name] = ng.p.Scalar(init=k.start, lower=k.low, upper=k.high)
    p = ng.p.Dict(**entries)
    p.random_state = np.random.RandomState(seed)
    return p


def generation_left(optimizer: Any) -> int:
    """Candidates left in the optimiser's current generation: for nevergrad's CMA family
    (``_CMA``, popsize λ: its candidates come from one ``es.ask()`` of λ points and the tells
    reach CMA-ES all together at the λ-th), λ − (asks mod λ); 1 for any other optimiser, whose
    next candidate may depend on the last tell. A chooser (``CMA`` is ``MetaCMA``, ``NGOpt``)
    is looked through to the optimiser it chose, which it makes at its first ask (so the first
    ask goes alone). Asking a whole generation before telling it gives the same candidates as
    asking and telling one at a time (nevergrad 1.0.12; tests/impactbench/
    test_cube_toss_tuning.py)."""
    inner = optimizer
    while getattr(inner, "_optim", None) is not None:  # ChoiceBase: the chosen optimiser
        inner = inner._optim
    popsize = getattr(inner, "_popsize", None)
    if not isinstance(popsize, int) or popsize < 1 or not hasattr(inner, "_to_be_asked"):
        return 1
    return popsize - inner.num_ask % popsize


def nevergrad(knobs: Sequence[Knob], objective: BatchObjective, budget: int, *,
              seed: int = SEED, optimizer: str = "CMA", batch: bool = True) -> float:
    """The start (each knob's ``start``), then ``budget − 1`` candidates of the nevergrad
    ``optimizer`` (``num_workers = 1``, its parametrization seeded with ``seed``): asked a
    generation at a time (:func:`generation_left`; one at a time without ``batch``), evaluated
    as one batch, told in order. Returns the start's J."""
    import nevergrad as ng

    j0 = objective.evaluate_batch([{k.name: k.start for k in knobs}])[0]
    opt = ng.optimizers.registry[optimizer](parametrization=parametrization(knobs, seed),
                                            budget=budget - 1, num_workers=1)
    left = budget - 1
    with warnings.catch_warnings():
        # cma's "orphanated injected solution": nevergrad injects its candidates; harmless
        warnings.filterwarnings("ignore", message=".*orphanated injected solution")
        while left > 0:
            n = min(left, generation_left(opt) if batch else 1)
            asked = [opt.ask() for _ in range(n)]
            for cand, value in zip(asked, objective.evaluate_batch([c.value for c in asked]),
                                   strict=True):
                opt.tell(cand, value)
            left -= n
    return j0


METHODS: dict[str, str] = {
    "least_squares": "scipy.optimize.least_squares (trf, bounded, forward differences) after "
                     "an optional seeded Sobol scan",
    "nelder_mead": "categorical combinations in turn, each a seeded Sobol scan and a bounded "
                   "scipy Nelder-Mead",
    "nevergrad": "a nevergrad optimiser (CMA: cma's CMA-ES), a generation per batch",
}
"""The search methods and their libraries."""


def search(space: Any, objective: Any, method: str, **options: Any) -> Any:
    """Run ``method`` (a key of :data:`METHODS`) on ``space`` and ``objective`` with its
    ``options``: :func:`least_squares` and :func:`nelder_mead` return an :class:`Outcome`,
    :func:`nevergrad` (``space``: its knobs; ``budget`` required) the start's J."""
    if method == "least_squares":
        return least_squares(space, objective, **options)
    if method == "nelder_mead":
        return nelder_mead(space, objective, **options)
    if method == "nevergrad":
        knobs = space.knobs if isinstance(space, KnobSpace) else tuple(space)
        return nevergrad(knobs, objective, **options)
    raise ValueError(f"method = {method!r}: must be one of {', '.join(METHODS)}")


def deadline_after(budget_s: float) -> float:
    """The ``time.perf_counter()`` at which a wall-time budget of ``budget_s`` seconds ends."""
    return time.perf_counter() + budget_s


__all__ = ["METHODS", "SEED", "BatchObjective", "Candidate", "FunctionObjective", "Knob",
           "KnobSpace", "OutOfBudget", "Outcome", "ResidualObjective", "Tracker", "UnitSpace",
           "candidate_key", "generation_left", "least_squares", "nelder_mead", "nevergrad",
           "parametrization", "search"]
