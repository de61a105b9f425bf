"""The tuning objective: weighted squared relative errors of chosen metrics over a velocity set.

    J(p) = Σ_v Σ_m w_m · e_{v,m}(p)²,   e_{v,m} = (metric_m(p, V_v) − ref_{v,m}) / |ref_{v,m}|

with the engine run through its own adapter (``tuned`` mode with the parameters p, or the
space's own run) and the metrics from ``impactbench.reference.metrics.compute`` — the same path as
every
comparison. A run that fails (non-ok status, or a NaN metric) gets the residual
:data:`FAILED_RESIDUAL` (an error of 1000 %) in each metric, so the optimiser backs away; an
``implausible`` run (a ball sunk deeper than the plausibility limit, energy created:
:mod:`impactbench.plausibility`) counts as failed, so every search is constrained to
plausible contacts.

The one tuner's batch objective (:class:`~impactbench.tuning.search.ResidualObjective`):
:meth:`Objective.evaluate_batch` and :meth:`Objective.residuals_batch` take a population of
parameter sets (dicts by the space's parameter names) at once. Their evaluations are sequential
(the search's budget, counting and best-so-far never depend on where runs execute), but their
engine runs need not be: :meth:`Objective.prefetch` runs every run of the batch at once, on a
:class:`impactbench.cluster.Runner` (Dask), and the evaluations that follow read them back; in
this process they run one by one. The search hands over each slice of its Sobol scan and each
finite-difference Jacobian as one batch, so a result on Dask equals the in-process one.

Phases (``phases``, :mod:`impactbench.phases`): at a step not much shorter than the contact the
outcome depends on where the first touch falls inside a step, so each velocity is run at every
phase given and judged at its worst: a phase that fails fails the velocity, else the phase with
the largest weighted squared error is the velocity's (its metrics, errors and status), and
:attr:`Evaluation.spreads` keeps each velocity's restitution over the phases (min, median,
max), its deepest step overlap and contact sinking. The advice is thus chosen on the worst
phase's error, never on a lucky phase.
"""

from __future__ import annotations

import contextlib
import dataclasses
import math
import time
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from impactbench.engines.tuning_spaces import Space
from impactbench.evaluate import compare_many, reference_metrics
from impactbench.reference import validation as check
from impactbench.reference.metrics import BALL_METRICS, relative_error
from impactbench.reference.record import Status
from impactbench.reference.scenarios import BallOnPlate
from impactbench.tuning.names import DEFAULT_TARGETS, TARGETS
from impactbench.tuning.search import OutOfBudget

FAILED_RESIDUAL = 10.0
FLUSH_EVERY_S = 2.0
"""New runs are written to the store at least this often (and at the end)."""
SCAN_SLICE_PER_WORKER = 4
"""Sobol-scan evaluations prefetched per worker at once on Dask."""


@contextlib.contextmanager
def quiet(engine: str) -> Iterator[None]:
    """Silence MuJoCo's warning printer (and its MUJOCO_LOG.TXT) while the search probes
    unstable corners; the adapter still sees the warning counters and reports ``diverged``."""
    if engine not in ("mujoco", "mjx"):
        yield
        return
    import mujoco

    previous = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(lambda _msg: None)
    try:
        yield
    finally:
        mujoco.set_mju_user_warning(previous)


def run_many(items: Sequence[tuple[str, Any, str, Any, dict[str, Any]]]
             ) -> list[dict[str, Any]]:
    """The engine runs of the objective, each ``(engine, scenario, mode, settings,
    reference)`` → its comparison object (``evaluate.compare``'s), in a worker process or
    here; all of one engine, handed to it together (:func:`impactbench.evaluate.compare_many`):
    an engine that batches (MJX's ball: one ``vmap`` over the candidates) runs a generation in
    one call, with the same objects."""
    if not items:
        return []
    engine = items[0][0]
    with quiet(engine):
        return compare_many(engine, [item[1:] for item in items])


def crashed_run(item: tuple, why: str) -> dict[str, Any]:
    """The run object of a run whose worker died: status ``crashed``, NaN metrics."""
    return {"status": str(Status.CRASHED), "message": why,
            **dict.fromkeys(BALL_METRICS, math.nan)}


@dataclass
class Evaluation:
    """One objective evaluation: parameter values, per-velocity metrics and relative errors."""

    values: np.ndarray
    objective: float
    metrics: list[dict[str, float]]
    rel_errors: list[dict[str, float]]
    statuses: list[str]
    penetration_ratios: list[float] = field(default_factory=list)
    """Per velocity: the largest overlap over the ball's radius (NaN where not measured)."""
    spreads: list[dict[str, float]] = field(default_factory=list)
    """Per velocity, over its phases: ``restitution_min``/``_median``/``_max`` (NaN where no
    phase measured one), the largest ``step_overlap_ratio`` and ``penetration_ratio``, and
    ``phases`` (how many were run)."""

    @property
    def max_penetration_ratio(self) -> float:
        finite = [p for p in self.penetration_ratios if math.isfinite(p)]
        return max(finite) if finite else math.nan


@dataclass
class Objective:
    """J(p) for one engine space, scenario, velocity set, targets and weights.

    ``weights`` maps metric keys to w ≥ 0; metrics the space cannot express get weight 0 (the
    caller reports that). Calls are counted; the best evaluation so far is kept, so stopping
    at any point (time budget) loses nothing.
    """

    space: Space
    scenario: BallOnPlate
    velocities_m_s: tuple[float, ...]
    weights: dict[str, float]
    timestep_s: float | None = None
    deadline: float = math.inf
    max_evals: int | None = None
    references: list[dict[str, Any]] = field(default_factory=list)
    evaluations: int = 0
    best: Evaluation | None = None
    best_implausible: Evaluation | None = None
    """The best evaluation among those the plausibility limits ruled out, scored on its
    errors alone: when it beats :attr:`best`, the limits bind (the output says so)."""
    run_wall_s: float = 0.0
    store: Any = None
    fresh: bool = False
    served: int = 0
    stored: int = 0
    runner: Any = None
    """An :class:`impactbench.cluster.Runner` for :meth:`prefetch`; None runs here."""
    phases: tuple[float | None, ...] = (None,)
    """Where in a step the first touch falls (:attr:`RunSettings.phase`), each velocity run at
    every one and judged at its worst (module doc); ``(None,)``: the adapters' one phase."""
    _true_refs: list[dict[str, Any]] = field(default_factory=list, repr=False)
    _ready: dict[tuple[bytes, int], dict[str, Any]] = field(default_factory=dict, repr=False)
    _walls: list[float] = field(default_factory=list, repr=False)
    _stored: dict[str, dict[str, Any]] | None = field(default=None, repr=False)
    _unstored: list[tuple] = field(default_factory=list, repr=False)
    _last_flush: float = field(default_factory=time.monotonic, repr=False)

    def __post_init__(self) -> None:
        if not self.velocities_m_s:
            raise ValueError("velocities = []: must list at least one impact velocity")
        for i, v in enumerate(self.velocities_m_s):
            check.positive(f"velocities[{i}]", v)
        for key, w in self.weights.items():
            check.one_of("target metric", key, BALL_METRICS)
            check.non_negative(f"weights[{key}]", w)
        if not self.phases:
            raise ValueError("phases = []: must list at least one phase of the step")
        if not any(w > 0 for w in self.weights.values()):
            raise ValueError(f"weights = {self.weights!r}: at least one target the engine can "
                             f"express must have weight > 0")
        if not self.references:
            self.references = [reference_metrics(self.scenario.replace(velocity_m_s=v))
                               for v in self.velocities_m_s]
            self._true_refs = list(self.references)

    @property
    def targets(self) -> tuple[str, ...]:
        return tuple(self.weights)

    def _check_budget(self) -> None:
        """:class:`~impactbench.tuning.search.OutOfBudget` when the time or evaluation budget
        is spent."""
        if time.perf_counter() > self.deadline:
            raise OutOfBudget("time budget spent")
        if self.max_evals is not None and self.evaluations >= self.max_evals:
            raise OutOfBudget("evaluation budget spent")

    def evaluate(self, values: np.ndarray, *, count_budget: bool = True) -> Evaluation:
        """Run the engine at every velocity with parameter ``values`` (natural units)."""
        if count_budget:
            self._check_budget()
        t0 = time.perf_counter()
        values = np.asarray(values, dtype=float)
        mets, errs, stats, pens = [], [], [], []
        raw: list[dict[str, float]] = []  # errors whatever the plausibility
        runs = self._runs(values)
        n = len(self.phases)
        spreads = [spread(runs[i * n:(i + 1) * n]) for i in range(len(self.velocities_m_s))]
        worst = [self._worst(runs[i * n:(i + 1) * n], ref)
                 for i, ref in enumerate(self.references)]
        for run, ref in zip(worst, self.references, strict=True):
            ok = run["status"] == str(Status.OK)
            measured = ok or run["status"] == str(Status.IMPLAUSIBLE)
            mets.append({k: float(run[k]) for k in BALL_METRICS})
            raw.append({k: (relative_error(float(run[k]), float(ref[k])) if measured
                            else math.nan) for k in BALL_METRICS})
            errs.append(raw[-1] if ok else dict.fromkeys(BALL_METRICS, math.nan))
            stats.append(run["status"] + (f": {run['message']}" if run["message"] and not ok
                                          else ""))
            pens.append(float((run.get("plausibility") or {}).get("penetration_ratio",
                                                                   math.nan)))
        self.run_wall_s += time.perf_counter() - t0
        ev = Evaluation(values.copy(), 0.0, mets, errs, stats, pens, spreads)
        ev.objective = float(np.sum(self.residuals_of(ev) ** 2))
        self.evaluations += 1
        if self.best is None or ev.objective < self.best.objective:
            self.best = ev
        if any(st.startswith(str(Status.IMPLAUSIBLE)) for st in stats):
            # what the search would have taken without the plausibility limits
            free = Evaluation(values.copy(), 0.0, mets, raw, stats, pens, spreads)
            free.objective = float(np.sum(self.residuals_of(free) ** 2))
            if self.best_implausible is None or free.objective < self.best_implausible.objective:
                self.best_implausible = free
        return ev

    def batch(self, candidates: Sequence[Mapping[str, Any]]) -> list[Evaluation]:
        """Evaluate ``candidates`` (parameter name → value) in order: the engine runs of those
        within the evaluation budget prefetched at once (:meth:`prefetch`), then each scored;
        :class:`~impactbench.tuning.search.OutOfBudget` at the first past a budget."""
        points = [self.space.values_of(c) for c in candidates]
        self._check_budget()
        self.prefetch(points[:int(min(len(points), self.remaining()))])
        return [self.evaluate(values) for values in points]

    def evaluate_batch(self, candidates: Sequence[Mapping[str, Any]]) -> list[float]:
        """J of each candidate (:meth:`batch`)."""
        return [ev.objective for ev in self.batch(candidates)]

    def residuals_batch(self, candidates: Sequence[Mapping[str, Any]]) -> list[np.ndarray]:
        """The residual vector of each candidate (:meth:`batch`, :meth:`residuals_of`)."""
        return [self.residuals_of(ev) for ev in self.batch(candidates)]

    @property
    def batch_size(self) -> int:
        """How many candidates a scan hands over at once (:attr:`parallel`)."""
        return self.parallel

    @property
    def parallel(self) -> int:
        """How many evaluations a scan prefetches at once: 1 when runs execute here, else
        :data:`SCAN_SLICE_PER_WORKER` per worker (the time budget is checked per slice)."""
        if self.runner is None or self.runner.in_process:
            return 1
        return SCAN_SLICE_PER_WORKER * self.runner.size

    def remaining(self) -> float:
        """Evaluations left in the evaluation budget (inf without one)."""
        return math.inf if self.max_evals is None else max(0, self.max_evals - self.evaluations)

    def prefetch(self, points: Sequence[np.ndarray]) -> None:
        """Make the engine runs of every point (natural units) at every velocity ready for
        :meth:`evaluate`: from the results store when it has them (same keys as the run
        matrix; the engine's runs of this impactbench version are read once, at the first
        call), else run on the runner (all at once) and stored (:meth:`flush`). A store
        changes no number: stored floats round-trip exactly; nor does the runner: each run
        is the same call."""
        from impactbench import store as store_mod
        from impactbench.store import CANDIDATE

        wanted: dict[tuple[bytes, int], tuple] = {}
        for values in points:
            values = np.asarray(values, dtype=float)
            for i, (v, phase) in enumerate(self._points()):
                key = (values.tobytes(), i)
                if key not in self._ready and key not in wanted:
                    sc, mode, settings = self.space.run(
                        values, self.scenario.replace(velocity_m_s=v), self.timestep_s)
                    if phase is not None:
                        settings = dataclasses.replace(settings, phase=phase)
                    wanted[key] = (self.space.engine, sc, mode, settings,
                                   self._true_reference(i // len(self.phases)))
        if not wanted:
            return
        keys: dict[tuple[bytes, int], str] = {}
        inputs: dict[tuple[bytes, int], dict[str, Any]] = {}
        if self.store is not None:
            for k, item in wanted.items():
                inputs[k] = store_mod.run_inputs(item[0], self.scenario.name, *item[1:4])
                keys[k] = store_mod.run_key(inputs[k])
            if self._stored is None:  # one query for the whole search, not one per point
                self._stored = {} if self.fresh else self.store.runs_of(
                    self.space.engine, store_mod.impactbench_version())
            for k in list(wanted):
                if keys[k] in self._stored:
                    self._ready[k] = self._stored[keys[k]]
                    self.served += 1
                    del wanted[k]
        todo = list(wanted)
        if self.runner is None or not todo:
            runs = run_many([wanted[k] for k in todo])
        else:
            # one task per worker (a round trip costs about as much as a short run), its runs
            # handed to the engine together
            per_task = math.ceil(len(todo) / self.runner.size)
            tasks = [[wanted[k] for k in todo[i:i + per_task]]
                     for i in range(0, len(todo), per_task)]
            runs = [run for got in self.runner.map(
                run_many, tasks, on_crash=lambda task, why: [crashed_run(i, why) for i in task],
                label="tune", batch_size=1, estimate_s=len(todo) * self._mean_run_s())
                for run in got]
        self._ready.update(zip(todo, runs, strict=True))
        self._walls += [float(r["wall_s"]) for r in runs
                        if math.isfinite(float(r.get("wall_s", math.nan)))]
        if self.store is not None and todo:
            assert self._stored is not None
            self._stored.update((keys[k], run) for k, run in zip(todo, runs, strict=True))
            self._unstored += [
                (keys[k], inputs[k], {"engine": self.space.engine, "mode": wanted[k][2],
                                      "scenario": self.scenario.name, "study": CANDIDATE,
                                      "point": self._point_of(k[1])},
                 run, {})
                for k, run in zip(todo, runs, strict=True)]
            if time.monotonic() - self._last_flush > FLUSH_EVERY_S:
                self.flush()

    def flush(self) -> None:
        """Write the runs not yet stored (done at most every :data:`FLUSH_EVERY_S`, at the
        end of a search and when it is interrupted: a store write costs ~20 ms)."""
        if self.store is not None and self._unstored:
            self.stored += self.store.put(self._unstored)
        self._unstored = []
        self._last_flush = time.monotonic()

    def _mean_run_s(self) -> float:
        """Mean wall time of the engine runs so far (s); 0 before the first."""
        return sum(self._walls) / len(self._walls) if self._walls else 0.0

    def _runs(self, values: np.ndarray) -> list[dict[str, Any]]:
        """The engine's run objects at every velocity for ``values`` (prefetched or run)."""
        self.prefetch([values])
        blob = values.tobytes()
        return [self._ready.pop((blob, i)) for i in range(len(self._points()))]

    def _points(self) -> list[tuple[float, float | None]]:
        """The runs of one evaluation: (velocity, phase), velocity-major."""
        return [(v, ph) for v in self.velocities_m_s for ph in self.phases]

    def _point_of(self, i: int) -> tuple[tuple[str, Any], ...]:
        """Run ``i``'s point as the store records it (its phase only where one was asked)."""
        v, phase = self._points()[i]
        return (("velocity_m_s", v),) + ((("phase", phase),) if phase is not None else ())

    def _worst(self, runs: list[dict[str, Any]], ref: dict[str, Any]) -> dict[str, Any]:
        """A velocity's run at its worst phase (module doc): the first that did not measure
        (crashed, diverged, …), else the first implausible, else the largest weighted
        squared error against ``ref``."""
        if len(runs) == 1:
            return runs[0]
        for bad in (lambda r: r["status"] not in (str(Status.OK), str(Status.IMPLAUSIBLE)),
                    lambda r: r["status"] == str(Status.IMPLAUSIBLE)):
            for run in runs:
                if bad(run):
                    return run

        def cost(run: dict[str, Any]) -> float:
            total = 0.0
            for key, w in self.weights.items():
                e = relative_error(float(run[key]), float(ref[key]))
                total += w * (e * e if math.isfinite(e) else FAILED_RESIDUAL ** 2)
            return total

        return max(runs, key=cost)

    def _true_reference(self, i: int) -> dict[str, Any]:
        """The Hunt–Crossley reference at velocity i (what a stored run is compared with)."""
        while len(self._true_refs) <= i:
            v = self.velocities_m_s[len(self._true_refs)]
            self._true_refs.append(reference_metrics(self.scenario.replace(velocity_m_s=v)))
        return self._true_refs[i]

    def residuals_of(self, ev: Evaluation) -> np.ndarray:
        """√w_m · e_{v,m}, velocity-major; failed entries are :data:`FAILED_RESIDUAL`."""
        out = []
        for errs in ev.rel_errors:
            for key, w in self.weights.items():
                e = errs[key]
                out.append(math.sqrt(w) * (e if math.isfinite(e) else FAILED_RESIDUAL))
        return np.asarray(out)

    def residuals(self, values: np.ndarray) -> np.ndarray:
        return self.residuals_of(self.evaluate(values))


def spread(runs: Sequence[Mapping[str, Any]]) -> dict[str, float]:
    """One velocity's runs over the phases of a step: its restitution's min, median and max
    over the runs that measured one (ok or implausible), the largest step overlap and contact
    sinking over the radius, how many phases ran and how many measured a restitution
    (:attr:`Evaluation.spreads`)."""
    measured = (str(Status.OK), str(Status.IMPLAUSIBLE))
    es = [float(r["restitution"]) for r in runs
          if r["status"] in measured and math.isfinite(float(r["restitution"]))]
    out = {"phases": float(len(runs)), "measured": float(len(es)),
           "restitution_min": min(es) if es else math.nan,
           "restitution_median": float(np.median(es)) if es else math.nan,
           "restitution_max": max(es) if es else math.nan}
    for key in ("step_overlap_ratio", "penetration_ratio"):
        vals = [float((r.get("plausibility") or {}).get(key, math.nan)) for r in runs]
        vals = [v for v in vals if math.isfinite(v)]
        out[key] = max(vals) if vals else math.nan
    return out


def parse_weights(targets: list[str] | tuple[str, ...] | None,
                  weights: list[float] | tuple[float, ...] | None) -> dict[str, float]:
    """CLI target names and weights → {metric key: weight}; one-line ValueError on bad input."""
    targets = list(targets) if targets is not None else list(DEFAULT_TARGETS)
    if not targets:
        raise ValueError("targets = []: must name at least one of "
                         + ", ".join(TARGETS))
    keys = [TARGETS[check.one_of(f"targets[{i}]", t, tuple(TARGETS))]
            for i, t in enumerate(targets)]
    if len(set(keys)) != len(keys):
        raise ValueError(f"targets = {targets!r}: must not repeat a target")
    if weights is None:
        weights = [1.0] * len(keys)
    if len(weights) != len(keys):
        raise ValueError(f"weights = {list(weights)!r}: must give one weight per target "
                         f"({len(keys)}: {', '.join(targets)})")
    ws = [check.non_negative(f"weights[{i}]", w) for i, w in enumerate(weights)]
    if not any(w > 0 for w in ws):
        raise ValueError(f"weights = {ws!r}: at least one must be > 0")
    return dict(zip(keys, ws, strict=True))
