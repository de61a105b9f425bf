"""The tuning objective: weighted squared relative errors of chosen metrics over a velocity set.

    J(p) = Σ_v Σ_m w_m · e_{v,m}(p)²,   e_{v,m} = (metric_m(p, V_v) − ref_{v,m}) / |ref_{v,m}|

with the engine run through its own adapter (``tuned`` mode with the parameters p, or the
space's own run) and the metrics from ``impactbench.reference.metrics.compute`` — the same path as
every
comparison. A run that fails (non-ok status, or a NaN metric) gets the residual
:data:`FAILED_RESIDUAL` (an error of 1000 %) in each metric, so the optimiser backs away.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from impactbench.evaluate import compare, reference_metrics
from impactbench.reference import validation as check
from impactbench.reference.metrics import BALL_METRICS, relative_error
from impactbench.reference.record import Status
from impactbench.reference.scenarios import BallOnPlate
from impactbench.tuning.names import DEFAULT_TARGETS, TARGETS
from impactbench.tuning.spaces import Space

FAILED_RESIDUAL = 10.0



class OutOfBudget(Exception):
    """Raised inside the optimiser when the time or evaluation budget is spent."""


@dataclass
class Evaluation:
    """One objective evaluation: parameter values, per-velocity metrics and relative errors."""

    values: np.ndarray
    objective: float
    metrics: list[dict[str, float]]
    rel_errors: list[dict[str, float]]
    statuses: list[str]


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
    run_wall_s: float = 0.0
    store: Any = None
    fresh: bool = False
    served: int = 0
    stored: int = 0
    _true_refs: list[dict[str, Any]] = field(default_factory=list, repr=False)

    def __post_init__(self) -> None:
        if not self.velocities_m_s:
            raise ValueError("velocities = []: must list at least one impact velocity")
        for i, v in enumerate(self.velocities_m_s):
            check.positive(f"velocities[{i}]", v)
        for key, w in self.weights.items():
            check.one_of("target metric", key, BALL_METRICS)
            check.non_negative(f"weights[{key}]", w)
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

    def evaluate(self, values: np.ndarray, *, count_budget: bool = True) -> Evaluation:
        """Run the engine at every velocity with parameter ``values`` (natural units)."""
        if count_budget:
            if time.perf_counter() > self.deadline:
                raise OutOfBudget("time budget spent")
            if self.max_evals is not None and self.evaluations >= self.max_evals:
                raise OutOfBudget("evaluation budget spent")
        t0 = time.perf_counter()
        values = np.asarray(values, dtype=float)
        mets, errs, stats = [], [], []
        for run, ref in zip(self._runs(values), self.references, strict=True):
            ok = run["status"] == str(Status.OK)
            mets.append({k: float(run[k]) for k in BALL_METRICS})
            errs.append({k: (relative_error(float(run[k]), float(ref[k])) if ok else math.nan)
                         for k in BALL_METRICS})
            stats.append(run["status"] + (f": {run['message']}" if run["message"] and not ok
                                          else ""))
        self.run_wall_s += time.perf_counter() - t0
        ev = Evaluation(values.copy(), 0.0, mets, errs, stats)
        ev.objective = float(np.sum(self.residuals_of(ev) ** 2))
        self.evaluations += 1
        if self.best is None or ev.objective < self.best.objective:
            self.best = ev
        return ev

    def _runs(self, values: np.ndarray) -> list[dict[str, Any]]:
        """The engine's run objects (``evaluate.compare``) at every velocity for ``values``:
        from the results store when it has them (same keys as the run matrix), else run and
        stored. A store changes no number: stored floats round-trip exactly."""
        from impactbench import store as store_mod

        jobs = []
        for v in self.velocities_m_s:
            jobs.append(self.space.run(values, self.scenario.replace(velocity_m_s=v),
                                       self.timestep_s))
        if self.store is None:
            return [compare(self.space.engine, *job, self._true_reference(i))[0]
                    for i, job in enumerate(jobs)]
        inputs = [store_mod.run_inputs(self.space.engine, "ball-on-plate", *job)
                  for job in jobs]
        keys = [store_mod.run_key(x) for x in inputs]
        found = {} if self.fresh else self.store.get(keys)
        runs, new = [], []
        for i, (job, key) in enumerate(zip(jobs, keys, strict=True)):
            if key in found:
                runs.append(found[key][0])
                self.served += 1
                continue
            run = compare(self.space.engine, *job, self._true_reference(i))[0]
            runs.append(run)
            new.append((key, inputs[i], {"engine": self.space.engine, "mode": job[1],
                                         "scenario": "ball-on-plate",
                                         "velocity_m_s": self.velocities_m_s[i]}, run, {}))
        if new:
            self.stored += self.store.put(new)
        return runs

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
