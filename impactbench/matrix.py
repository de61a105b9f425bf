"""The run matrix: plan jobs from a config, run them in worker processes, collect tidy rows.

Each job is one engine run (engine × scenario point × mode × timestep). Jobs run in a pool of
worker processes (spawned, one per core by default), so an engine that segfaults takes down
only its worker: the pool is rebuilt, the unfinished jobs are retried one at a time in fresh
single-worker pools, and the job that kills its worker again becomes a ``crashed`` row. The
results do not depend on scheduling: rows are sorted by job id.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Iterable
from concurrent.futures import ProcessPoolExecutor, as_completed
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass, field
from multiprocessing import get_context
from typing import Any

import numpy as np

from impactbench.config import ReportConfig
from impactbench.evaluate import SCENARIO_METRICS, compare, reference_metrics
from impactbench.params import SCENARIO_CLASSES

HISTORY_POINTS = 1500
"""Histories returned for plots are thinned to about this many samples."""


@dataclass(frozen=True)
class Job:
    """One engine run. ``study`` is ``matrix`` (headline tables) or ``work_precision``."""

    study: str
    engine: str
    scenario: str
    mode: str
    velocity_m_s: float
    timestep_s: float | None
    parameters: tuple[tuple[str, Any], ...] = ()
    local: str = ""
    structure: str = ""
    keep_history: bool = False

    @property
    def id(self) -> str:
        laws = f"/{self.local}/{self.structure}" if self.local else ""
        dt = f"{self.timestep_s:.3e}" if self.timestep_s else "default"
        params = "".join(f"/{k}={v!r}" for k, v in self.parameters)  # ids must be unique
        return (f"{self.study}/{self.scenario}{laws}/v{self.velocity_m_s:09.4f}/"
                f"{self.engine}/{self.mode}/dt{dt}{params}")

    def build_scenario(self):
        kwargs = dict(self.parameters, velocity_m_s=self.velocity_m_s)
        if self.local:
            kwargs.update(local=self.local, structure=self.structure)
        return SCENARIO_CLASSES[self.scenario](**kwargs)

    @property
    def reference_key(self) -> tuple:
        return (self.scenario, self.velocity_m_s, self.local, self.structure, self.parameters)


@dataclass
class JobResult:
    job: Job
    run: dict[str, Any]
    history: dict[str, np.ndarray] = field(default_factory=dict)


def _thin(rec, points: int = HISTORY_POINTS) -> dict[str, np.ndarray]:
    n = len(rec)
    if n == 0:
        return {}
    step = max(1, math.ceil(n / points))
    idx = np.unique(np.r_[np.arange(0, n, step), np.argmax(rec.normal_force_n), n - 1])
    return {
        "time_s": rec.time_s[idx],
        "normal_force_n": rec.normal_force_n[idx],
        "penetration_m": rec.penetration_m[idx],
    }


def execute(job: Job, reference: dict[str, Any] | None = None) -> JobResult:
    """Run one job (in a worker process). Never raises for engine trouble."""
    from impactbench.engines.base import RunSettings
    from impactbench.tuned import load_tuned

    tuned = load_tuned(job.engine, job.scenario) if job.mode == "tuned" else None
    settings = RunSettings(timestep_s=job.timestep_s, tuned=tuned)
    run, rec = compare(job.engine, job.build_scenario(), job.mode, settings, reference)
    return JobResult(job, run, _thin(rec) if job.keep_history else {})


def plan(config: ReportConfig, engines: Iterable[str] | None = None) -> list[Job]:
    """All jobs of a config: the matrix, then the work-precision study."""
    from impactbench.tuned import tuned_path

    engines = tuple(engines if engines is not None else config.engines)
    jobs: list[Job] = []
    for sm in config.scenarios:
        params = tuple(sorted(sm.parameters.items()))
        laws = [(lo, st) for lo in sm.local for st in sm.structure] or [("", "")]
        for engine in engines:
            modes = [m for m in config.modes
                     if m != "tuned" or tuned_path(engine, sm.name).is_file()]
            for mode in modes:
                for v in sm.velocities_m_s:
                    for lo, st in laws:
                        jobs.append(Job("matrix", engine, sm.name, mode, v,
                                        sm.timestep_s.get(engine), params, lo, st,
                                        keep_history=True))
    wp = config.work_precision
    ball = next((s for s in config.scenarios if s.name == "ball-on-plate"), None)
    if wp is not None:
        params = tuple(sorted(ball.parameters.items())) if ball else ()
        for engine in engines:
            for mode in wp.modes:
                for dt in wp.timesteps_s:
                    jobs.append(Job("work_precision", engine, "ball-on-plate", mode,
                                    wp.velocity_m_s, dt, params))
    return jobs


def _crashed(job: Job, why: str, reference: dict[str, Any]) -> JobResult:
    names = SCENARIO_METRICS[job.scenario]
    run = {"status": "crashed", "message": why, "engine": job.engine, "engine_version": "",
           "mode": job.mode, "timestep_s": job.timestep_s, "wall_s": math.nan,
           **{k: math.nan for k in names}, "reference": reference,
           "rel_error": dict.fromkeys(names, math.nan)}
    return JobResult(job, run)


def run_jobs(jobs: list[Job], workers: int | None = None,
             progress: Callable[[int], None] | None = None) -> list[JobResult]:
    """Run ``jobs`` in worker processes; results sorted by job id."""
    references: dict[tuple, dict[str, Any]] = {}
    for job in jobs:
        if job.reference_key not in references:
            references[job.reference_key] = reference_metrics(job.build_scenario())
    workers = workers or os.cpu_count() or 1
    results: dict[str, JobResult] = {}
    pending = sorted(jobs, key=lambda j: (j.scenario != "rigid-flexible", j.id))

    def collect(batch: list[Job], n_workers: int) -> list[Job]:
        """Run a batch in one pool; return the jobs left unfinished if the pool broke."""
        ctx = get_context("spawn")
        with ProcessPoolExecutor(max_workers=n_workers, mp_context=ctx) as pool:
            futures = {pool.submit(execute, j, references[j.reference_key]): j for j in batch}
            try:
                for fut in as_completed(futures):
                    job = futures[fut]
                    try:
                        results[job.id] = fut.result()
                    except BrokenProcessPool:
                        raise
                    except Exception as exc:  # a bug in an adapter must not lose the rest
                        why = f"{type(exc).__name__}: {exc}"
                        results[job.id] = _crashed(job, why, references[job.reference_key])
                    if progress:
                        progress(1)
            except BrokenProcessPool:
                pass
        return [j for j in batch if j.id not in results]

    left = collect(pending, workers) if pending else []
    for job in left:  # isolate: each suspect alone in a fresh worker
        if collect([job], 1):
            results[job.id] = _crashed(job, "the engine's worker process died",
                                       references[job.reference_key])
            if progress:
                progress(1)
    return [results[j.id] for j in sorted(jobs, key=lambda j: j.id)]


def tidy(results: list[JobResult]) -> list[dict[str, Any]]:
    """One row per run and metric (DESIGN.md's columns, plus study and laws)."""
    rows = []
    for r in results:
        j, run = r.job, r.run
        for metric in SCENARIO_METRICS[j.scenario]:
            rows.append({
                "study": j.study,
                "scenario": j.scenario,
                "local": j.local,
                "structure": j.structure,
                "engine": j.engine,
                "mode": j.mode,
                "velocity_m_s": j.velocity_m_s,
                "timestep_s": run.get("timestep_s"),
                "metric": metric,
                "value": run.get(metric),
                "reference": run["reference"].get(metric),
                "rel_error": run["rel_error"].get(metric),
                "status": run["status"],
                "message": run.get("not_comparable", {}).get(metric) or run.get("message", ""),
                "wall_s": run.get("wall_s"),
                "engine_version": run.get("engine_version", ""),
            })
    return rows
