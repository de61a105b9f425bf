"""The run matrix: plan jobs from a config, run what the store lacks on Dask, collect rows.

Each job is one engine run (engine × scenario point × mode × timestep). :func:`run_jobs` first
looks every job up in the results store (:mod:`impactbench.store`) and runs only the missing
ones, on ``dask.distributed`` (:mod:`impactbench.cluster`): a local cluster of worker processes
by default, or a user's scheduler. An engine that segfaults takes down only its worker; Dask
retries its run once on a fresh worker and the run that kills a worker again becomes a
``crashed`` row. Finished runs are stored as they arrive, so an interrupted matrix resumes.
The results do not depend on scheduling or on the store: rows are sorted by job id.
"""

from __future__ import annotations

import contextlib
import functools
import json
import math
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from impactbench import scenarios
from impactbench.config import ReportConfig
from impactbench.evaluate import compare, reference_metrics
from impactbench.scenarios import Point


@dataclass(frozen=True, order=True)
class RunKey:
    """One engine run: everything that determines its record (the matrix's, the gates', the
    store's and the tuner's one key).

    Attributes:
        engine, scenario, mode: registry names.
        point: the scenario's axes for this run (``(("velocity_m_s", 2.0),)``).
        timestep_s: the step (s); None: the adapter's default for the scenario.
        parameters: scenario fields that differ from the scenario's defaults, sorted by name.
        params: ``custom``: the user's engine parameters; ``tuned``: the fixed settings
            (variant) that select the packaged tuned file (e.g. Drake's discrete approximation).
        tuned_file: ``tuned``: a user's tuned file instead of the packaged one.
        phases: how many phases of the step the head-on ball's run is measured at
            (:mod:`impactbench.phases`: at a step not much shorter than the contact, the
            run is repeated with the first touch at k/phases of a step and merged, judged at
            the worst); 1: the adapters' one phase.
    """

    engine: str
    scenario: str
    point: Point
    mode: str
    timestep_s: float | None
    parameters: tuple[tuple[str, Any], ...] = ()
    params: tuple[tuple[str, Any], ...] = ()
    tuned_file: str = ""
    phases: int = 1

    @property
    def spec(self) -> scenarios.ScenarioSpec:
        return scenarios.get(self.scenario)

    def get(self, axis: str, default: Any = None) -> Any:
        """The value of one axis of the point (``velocity_m_s``)."""
        return dict(self.point).get(axis, default)

    @property
    def velocity_m_s(self) -> float:
        """The impact velocity of the point (m/s; NaN for a scenario without one)."""
        return float(self.get("velocity_m_s", math.nan))

    @property
    def variant(self) -> str:
        """The engine parameters as text (``solref=[0.02, 1.0]``), '' when none."""
        from impactbench.config import thawed

        return ", ".join(f"{k}={v}" for k, v in thawed(self.params).items())

    @property
    def label(self) -> str:
        """``mujoco-injected-ball-on-plate-v1-dt1e-06`` (gate names, baseline keys)."""
        spec = self.spec
        params = "".join(f"-{k}{v:g}" if isinstance(v, int | float) and not isinstance(v, bool)
                         else f"-{k}{v}" for k, v in self.parameters)
        dt = "default" if self.timestep_s is None else f"{self.timestep_s:g}"
        ph = f"-ph{self.phases}" if self.phases > 1 else ""
        return (f"{self.engine}-{self.mode}-{self.scenario}{spec.point_label(self.point)}"
                f"{params}{spec.numeric_label(self.point)}-dt{dt}{ph}")

    def build_scenario(self) -> Any:
        """The scenario object (its defaults, these fields, this point)."""
        return self.spec.build(self.point, self.parameters)

    @property
    def reference_key(self) -> tuple:
        return (self.scenario, self.point, self.parameters)


@dataclass(frozen=True)
class Job(RunKey):
    """One engine run of a report. ``study`` is ``matrix`` (headline tables),
    ``work_precision`` or ``practical``; ``keep_history`` keeps its thinned force history."""

    study: str = "matrix"
    keep_history: bool = False
    advice: str = ""
    """The packaged advice file a practical run takes its ``custom`` params from ('' none)."""

    @property
    def id(self) -> str:
        dt = f"{self.timestep_s:.3e}" if self.timestep_s else "default"
        params = "".join(f"/{k}={v!r}" for k, v in self.parameters)  # ids must be unique
        point = self.spec.point_id(self.point)
        ph = f"/ph{self.phases}" if self.phases > 1 else ""
        return (f"{self.study}/{self.scenario}{point}/"
                f"{self.engine}/{self.mode}{self.variant and '[' + self.variant + ']'}/dt{dt}"
                f"{params}{ph}")

    @property
    def key(self) -> RunKey:
        """The run without the report's bookkeeping."""
        return RunKey(self.engine, self.scenario, self.point, self.mode, self.timestep_s,
                      self.parameters, self.params, self.tuned_file, self.phases)


@dataclass
class JobResult:
    job: Job
    run: dict[str, Any]
    history: dict[str, np.ndarray] = field(default_factory=dict)
    cached: bool = False
    """True when the run came from the results store instead of an engine."""
    took_s: float = math.nan
    """What the job took in its worker (s), scoring included (a batch's time shared out);
    not stored: the time-left estimate learns from it (:class:`TimeLeft`)."""


def job_settings(job: Job):
    """The :class:`~impactbench.engines.base.RunSettings` of a job (hashed into its store key)."""
    from impactbench.config import thawed
    from impactbench.engines.base import RunSettings
    from impactbench.tuned import tuned_settings

    settings = RunSettings(timestep_s=job.timestep_s,
                           params=thawed(job.params) if job.mode == "custom" else None)
    if job.mode == "tuned":
        tuned, provenance = tuned_settings(job.engine, job.build_scenario(), job.timestep_s,
                                           job.tuned_file or None, thawed(job.params))
        settings = RunSettings(timestep_s=job.timestep_s, tuned=tuned, tuned_for=provenance)
    return settings


def job_inputs(job: RunKey, settings: Any) -> dict[str, Any]:
    """What determines a job's stored run (:func:`impactbench.store.run_inputs`, hashed into
    its key), its phases included when more than one."""
    from impactbench import store as store_mod

    inputs = store_mod.run_inputs(job.engine, job.scenario, job.build_scenario(), job.mode,
                                  settings)
    if job.phases > 1:
        inputs["phases"] = job.phases
    return inputs


Item = tuple[Job, "dict[str, Any] | None", Any]
"""One job as the workers get it: (job, its reference metrics, its RunSettings)."""


def execute(job: Job, reference: dict[str, Any] | None = None,
            settings: Any = None) -> JobResult:
    """Run one job (in a worker process). Never raises for engine trouble. A job of several
    phases runs once per phase (:func:`impactbench.phases.offsets`) and is merged
    (:func:`impactbench.phases.merge`: the median and range, judged at the worst phase; its
    history is the worst phase's)."""
    settings = settings if settings is not None else job_settings(job)
    pairs = []
    try:
        for scenario, mode, ph_settings, ref in _phase_runs(job, reference, settings):
            pairs.append(compare(job.engine, scenario, mode, ph_settings, ref))
    except ValueError as exc:  # settings the engine refused (bad input for a lone run):
        # in a matrix, one row that says why, never the loss of the other runs
        return _crashed(job, f"bad settings: {exc}", reference or {})
    return _result(job, pairs)


def _phase_runs(job: Job, reference: dict[str, Any] | None, settings: Any) -> list[tuple]:
    """The engine runs of a job: ``(scenario, mode, settings, reference)`` per phase."""
    from impactbench import phases

    scenario = job.build_scenario()
    offsets = phases.offsets(job.phases) if job.phases > 1 else (None,)
    return [(scenario, job.mode, settings if ph is None else replace(settings, phase=ph),
             reference) for ph in offsets]


def _result(job: Job, pairs: list[tuple[dict[str, Any], Any]]) -> JobResult:
    """A job's result from its runs' (object, record) pairs, one per phase."""
    from impactbench import phases

    runs = [run for run, _ in pairs]
    if job.phases > 1:
        worst = phases.worst(runs)
        run, rec = phases.merge(runs, phases.offsets(job.phases)), pairs[worst][1]
    else:
        run, rec = pairs[0]
    history = job.spec.kept_history(rec, run, job.build_scenario()) \
        if job.keep_history and rec is not None else {}
    return JobResult(job, run, history)


def execute_items(items: list[Item]) -> list[JobResult]:
    """The results of a work item (what the workers run): one job (:func:`execute`), or jobs
    of one engine whose builder batches their scenario, all their runs (every phase of each)
    handed to the engine in one call (:func:`impactbench.evaluate.compare_many_records` →
    :meth:`~impactbench.engines.base.Adapter.run_many`: MJX one ``vmap``, Newton one model
    with a world per run), each record the lone run's; should the batch refuse its settings,
    each job alone says which."""
    t0 = time.perf_counter()
    out = _execute_items(items)
    took = (time.perf_counter() - t0) / len(out)
    for result in out:
        result.took_s = took
    return out


def _execute_items(items: list[Item]) -> list[JobResult]:
    if len(items) == 1:
        return [execute(*items[0])]
    from impactbench.evaluate import compare_many_records

    runs: list[tuple] = []
    owner: list[int] = []
    for k, (job, reference, settings) in enumerate(items):
        settings = settings if settings is not None else job_settings(job)
        for run in _phase_runs(job, reference, settings):
            runs.append(run)
            owner.append(k)
    try:
        pairs = compare_many_records(items[0][0].engine, runs)
    except ValueError:
        return [execute(*item) for item in items]
    grouped: list[list[tuple]] = [[] for _ in items]
    for k, pair in zip(owner, pairs, strict=True):
        grouped[k].append(pair)
    return [_result(job, got) for (job, _, _), got in zip(items, grouped, strict=True)]


def prepare_items(items: list[Item]) -> None:
    """Load a work item's engine adapter (its modules and the engine's package) before the
    item's clock starts: on a restarted worker these imports take seconds under load. An
    engine that fails to load is left to the run itself, which reports it."""
    from impactbench.engines.base import get_adapter

    with contextlib.suppress(Exception):
        get_adapter(items[0][0].engine)


BATCH_RUNS = 512
"""At most this many engine runs (phases counted) in one batched work item."""


def work_items(pending: list[Job], settings: dict[str, Any],
               references: dict[tuple, dict[str, Any]]) -> list[list[Item]]:
    """``pending`` as work items, in the order given: each job alone, but the jobs of an
    engine that runs their scenario as one item (:func:`_together`: a builder that batches
    it, or an engine that compiles on first use) together, per engine and scenario, in items
    of at most :data:`BATCH_RUNS` runs (placed where the group's first job is)."""
    together: dict[tuple[str, str], bool] = {}
    groups: dict[tuple[str, str], list[list[Item]]] = {}
    out: list[list[Item]] = []
    for job in pending:
        item = (job, references[job.reference_key], settings[job.id])
        key = (job.engine, job.scenario)
        if key not in together:
            together[key] = _together(job)
        if not together[key]:
            out.append([item])
            continue
        chunks = groups.get(key)
        if chunks is None or sum(i[0].phases for i in chunks[-1]) + job.phases > BATCH_RUNS:
            chunks = groups.setdefault(key, [])
            chunks.append([])
            out.append(chunks[-1])
        chunks[-1].append(item)
    return out


def _together(job: Job) -> bool:
    """Whether ``job``'s engine runs of its scenario go to one process as one item: its
    builder batches them (``batch``: one call), or the engine compiles on first use in a
    process (its spec's ``first_use_s``: MJX's XLA, Newton's warp kernels), so that each
    scenario's compile happens once, not once on every worker (cold caches, the default
    report: MJX's cube tosses took 115 s of engine time over two workers)."""
    from impactbench.engines.base import get_adapter
    from impactbench.engines.registry import spec

    try:
        found = get_adapter(job.engine).builder(job.build_scenario())
        compiles = spec(job.engine).first_use_s > 0.0
    except Exception:  # an engine not installed here: its runs say so, one by one
        return False
    return bool(found is not None and (found.batch or compiles))


def plan(config: ReportConfig, engines: Iterable[str] | None = None) -> list[Job]:
    """All jobs of a config: the matrix and a measured scenario's replays
    (:meth:`~impactbench.scenarios.spec.ScenarioSpec.report_jobs`), then the practical and
    work-precision studies."""
    from impactbench.tuned import tuned_path

    restricted = engines
    engines = tuple(engines if engines is not None else config.engines)
    jobs: list[Job] = []
    for sm in config.scenarios:
        if scenarios.get(sm.name).measured:  # its replays, beside the matrix on its workers
            jobs += scenarios.get(sm.name).report_jobs(config, sm, restricted)
            continue
        params = tuple(sorted(sm.parameters.items()))
        for engine in engines:
            modes = [m for m in sm.modes or config.modes
                     if m != "tuned" or _has_tuned(engine, sm, tuned_path)
                     or engine in config.tuned_files]
            if engine in config.engine_params and "custom" not in modes:
                modes.append("custom")  # the user's own settings get their column
            for mode in modes:
                if mode == "custom" and engine not in config.engine_params:
                    continue  # custom needs the user's parameters ([engines.<name>])
                user = config.engine_params.get(engine, ()) if mode == "custom" else ()
                tuned_file = config.tuned_files.get(engine, "") if mode == "tuned" else ""
                for point in sm.points():
                    jobs.append(Job(engine, sm.name, point, mode, sm.timestep_s.get(engine),
                                    params, user, tuned_file, study="matrix",
                                    keep_history=True))
    jobs += _practical_jobs(config, engines)
    wp = config.work_precision
    if wp is not None:
        scenario, params = _study_scenario(config, "work_precision")
        for engine in engines:
            for mode in wp.modes:
                for v in wp.velocities_m_s:
                    for dt in wp.timesteps_s:
                        jobs.append(Job(engine, scenario, (("velocity_m_s", v),), mode, dt,
                                        params, study="work_precision"))
    for more in config.work_precision_more:
        sm = next((s for s in config.scenarios if s.name == more.scenario), None)
        params = tuple(sorted(sm.parameters.items())) if sm else ()
        jobs += [Job(engine, more.scenario, point, mode, dt, params, study="work_precision")
                 for engine in engines for mode in more.modes for point in more.points
                 for dt in more.timesteps_s]
    return jobs


def _has_tuned(engine: str, sm: Any, tuned_path: Any) -> bool:
    """Whether ``engine`` has a packaged tuned file for the scenario: its own, or for a
    scenario whose tuned runs take another's files (its spec's ``tuned_from``: the bounce
    takes the ball's) one fitted at the run's step."""
    spec = scenarios.get(sm.name)
    if not spec.tuned_from:
        return tuned_path(engine, sm.name).is_file()
    from impactbench.engines.base import get_adapter
    from impactbench.tuned import fitted_at

    try:
        dt = sm.timestep_s.get(engine) or get_adapter(engine).default_timestep_s(
            spec.build(sm.points()[0] if sm.points() else ()), "tuned")
    except Exception:  # an engine not installed here: its runs say so
        return tuned_path(engine, spec.tuned_from).is_file()
    return fitted_at(engine, spec.tuned_from, dt)


def _study_scenario(config: ReportConfig, study: str) -> tuple[str, tuple]:
    """The scenario a single-scenario study runs, and its configured fields."""
    name = scenarios.for_study(study).name
    sm = next((s for s in config.scenarios if s.name == name), None)
    return name, tuple(sorted(sm.parameters.items())) if sm else ()


def _practical_jobs(config: ReportConfig, engines: tuple[str, ...]) -> list[Job]:
    """The "at practical timesteps" study: per engine and customary step, the configured
    modes (default, native, tuned, custom with the user's [engines] table), per variant,
    custom (default plus the variant) and tuned (the file fitted with it), and (``advice``)
    the packaged advice for that step (:mod:`impactbench.advice_files`) as custom; each run
    at every phase of the step where the step is not much shorter than the contact."""
    pr = config.practical
    if pr is None:
        return []
    from impactbench.advice_files import packaged
    from impactbench.config import frozen_params

    scenario, params = _study_scenario(config, "practical")
    jobs = []
    durations: dict[tuple, float] = {}
    for engine in engines:
        variants = pr.variants.get(engine, ())
        runs: list[tuple[str, tuple]] = []
        for mode in pr.modes:
            if mode == "custom":
                if engine in config.engine_params:
                    runs.append(("custom", config.engine_params[engine]))
            elif not (mode == "tuned" and variants):
                runs.append((mode, ()))
        for variant in variants:
            runs.append(("custom", variant))
            if "tuned" in pr.modes:
                runs.append(("tuned", variant))
        for dt in pr.timesteps_s.get(engine, ()):
            advice = packaged(engine, dt) if pr.advice else None
            extra = [("custom", frozen_params(advice["params"]))] if advice else []
            for mode, variant_params in runs + extra:
                for v in pr.velocities_m_s:
                    point = (("velocity_m_s", v),)
                    job = Job(engine, scenario, point, mode, dt, params, variant_params,
                              study="practical")
                    n = _phases_at(job, durations)
                    jobs.append(replace(job, phases=n, advice=advice["file"] if advice and
                                        (mode, variant_params) == extra[0] else ""))
    return jobs


def _phases_at(job: Job, durations: dict[tuple, float]) -> int:
    """How many phases of its step a practical job is measured at: :data:`impactbench.phases.
    PHASES` where the step is not much shorter than the reference contact
    (:func:`impactbench.phases.needs_phases`), else 1."""
    from impactbench import phases

    if job.reference_key not in durations:
        durations[job.reference_key] = float(reference_metrics(job.build_scenario())
                                             .get("duration_s", math.nan))
    return phases.PHASES if phases.needs_phases(job.timestep_s,
                                                durations[job.reference_key]) else 1


def _crashed(job: Job, why: str, reference: dict[str, Any],
             status: str = "crashed") -> JobResult:
    """The result of a job whose worker died (or, ``status = "timeout"``, that outlasted its
    timeout): no numbers, not stored (a dying worker or a slow machine may be transient)."""
    names = job.spec.metrics
    run = {"status": status, "message": why, "engine": job.engine, "engine_version": "",
           "mode": job.mode, "timestep_s": job.timestep_s, "wall_s": math.nan,
           **{k: math.nan for k in names}, "reference": reference,
           "rel_error": dict.fromkeys(names, math.nan)}
    return JobResult(job, run)


UNSTORED = ("crashed", "timeout")
"""Statuses never stored (they may be transient): such runs rerun next time."""


class Interrupted(KeyboardInterrupt):
    """Ctrl-C, SIGTERM or SIGHUP (the CLI turns both into a KeyboardInterrupt) during
    :func:`run_jobs` (or a sweep: ``unit`` points); what finished is stored.
    ``str()`` is the one line."""

    def __init__(self, stored: int, total: int, store: bool, unit: str = "runs") -> None:
        super().__init__(stored, total)
        self.stored, self.total = stored, total
        self.line = (f"interrupted; {stored} of {total} {unit} stored; rerun to resume"
                     if store else f"interrupted; {stored} of {total} {unit} done (no store)")

    def __str__(self) -> str:
        return self.line


def _result_from_store(job: Job, run: dict[str, Any], history: dict[str, np.ndarray],
                       reference: dict[str, Any]) -> JobResult:
    """A stored run object (JSON: NaN kept) with this process's reference put back."""
    run = {**run, "reference": reference}
    return JobResult(job, run, history if job.keep_history else {}, cached=True)


FLUSH_EVERY_S = 2.0
"""Finished runs are written to the store at least this often (and at the end)."""


def estimated_steps_of(reference: dict[str, Any], timestep_s: float | None) -> float:
    """Rough integration steps of one run (:func:`impactbench.scenarios.spec.
    contact_steps`: twice the reference contact time over the timestep; 0 with the adapter's
    default step)."""
    from impactbench.scenarios.spec import contact_steps

    return contact_steps(reference, timestep_s)


def estimated_steps(job: Job, reference: dict[str, Any]) -> float:
    """A job's rough integration steps: its scenario's estimate
    (:meth:`~impactbench.scenarios.spec.ScenarioSpec.estimated_steps`), each phase a run."""
    return job.phases * job.spec.estimated_steps(job.build_scenario(), reference,
                                                 job.timestep_s)


TIME_PRIORS = Path(__file__).resolve().parent / "data" / "time_priors.json"
"""What each group of a fresh default report's work items took over its estimate, measured
(``python -m benchmarks report --priors``) twice: with empty compile caches (``cold``: the
JIT engines compile first) and with warm ones (``warm``) — :class:`TimeLeft`'s prior for a
group before any of its items has finished here."""

PACE_PRIOR_S = 30.0
"""The work (s, as the priors predict it) :meth:`TimeLeft.pace` counts as done at pace 1
before any item finished, so that one early item cannot swing the pace (measured on four
fresh default reports, each estimated with the other pair's priors: the time left's median
error ×1.06–1.17 at 30 s against ×1.07–1.21 at 0, the worst ×1.28–1.89 against ×1.42–1.92)."""


@functools.lru_cache(maxsize=1)
def _packaged_priors() -> dict[str, dict[tuple[str, str, bool], float]]:
    """:data:`TIME_PRIORS`'s columns, ``{"cold": {group: ratio}, "warm": {…}}`` (empty where
    the file is missing or unreadable)."""
    try:
        data = json.loads(TIME_PRIORS.read_text())
        return {column: {(str(e), str(sc), bool(b)): float(r) for e, sc, b, r in data[column]}
                for column in ("cold", "warm") if column in data}
    except (OSError, ValueError, KeyError, TypeError):
        return {}


def cold_engines() -> frozenset[str]:
    """The registered engines whose compile cache is empty here (their first runs compile:
    :meth:`impactbench.engines.registry.EngineSpec.compile_cache_warm`)."""
    from impactbench.engines import registry

    return frozenset(name for name in registry.engine_names()
                     if registry.spec(name).compile_cache_warm() is False)


def time_priors(cold: Iterable[str] | None = None) -> dict[tuple[str, str, bool], float]:
    """The measured priors, ``{(engine, scenario, batched): took / estimate}``: the ``cold``
    column's for the engines in ``cold`` (default :func:`cold_engines`), the ``warm``
    column's for the others (either column where only one has the group; {} without the
    file: the estimates as they are)."""
    columns = _packaged_priors()
    cold = cold_engines() if cold is None else frozenset(cold)
    with_compiles, without = columns.get("cold", {}), columns.get("warm", {})
    out = {**with_compiles, **without}
    out.update((g, r) for g, r in with_compiles.items() if g[0] in cold)
    return out


class TimeLeft:
    """The seconds a run of work items has left, learnt as it goes: each item's time estimate
    (:func:`impactbench.cluster.run_estimate_s` of its steps × its scenario's step cost)
    scaled by what finished items took over their estimate — per group of items
    ``(engine, scenario, batched)``. A group with none finished yet takes its measured prior
    (:func:`time_priors`: a fresh default report's ratio, imports included, the compiles too
    for an engine whose compile cache is empty here) times this machine's pace (what the
    finished items took over their priors' prediction, :data:`PACE_PRIOR_S` of work at 1
    counted in: a busy machine's is above 1); a group without a prior the median over the
    finished groups of its scenario (batched alike), else of its engine, else of all; 1
    before any. Summed over the items left and shared over the workers."""

    def __init__(self, workers: int,
                 priors: dict[tuple[str, str, bool], float] | None = None) -> None:
        self.workers = max(1, workers)
        self.priors = time_priors() if priors is None else priors
        self.pending: dict[tuple, float] = {}
        self.done: dict[tuple, list[float]] = {}
        """group → [estimate, took] of its finished items."""

    def add(self, group: tuple, estimate_s: float) -> None:
        self.pending[group] = self.pending.get(group, 0.0) + estimate_s

    def finished(self, group: tuple, estimate_s: float, took_s: float) -> None:
        self.pending[group] = max(0.0, self.pending.get(group, 0.0) - estimate_s)
        if math.isfinite(took_s):
            got = self.done.setdefault(group, [0.0, 0.0])
            got[0] += estimate_s
            got[1] += took_s

    def pace(self) -> float:
        """What the finished items of groups with a prior took over the priors' prediction,
        with :data:`PACE_PRIOR_S` of predicted work taken at 1 (1 before any)."""
        predicted = sum(est * self.priors[g] for g, (est, _) in self.done.items()
                        if g in self.priors)
        took = sum(t for g, (_, t) in self.done.items() if g in self.priors)
        return (took + PACE_PRIOR_S) / (predicted + PACE_PRIOR_S)

    def ratio(self, group: tuple) -> float:
        """What ``group``'s items take over their estimate."""
        return self._ratio(group, self._learnt(), self.pace())

    def _learnt(self) -> dict[tuple, float]:
        return {g: took / est for g, (est, took) in self.done.items() if est > 0.0}

    def _ratio(self, group: tuple, ratios: dict[tuple, float], pace: float) -> float:
        if group in ratios:
            return ratios[group]
        if group in self.priors:
            return self.priors[group] * pace
        engine, scenario, batched = group
        for alike in (lambda g: g[1:] == (scenario, batched), lambda g: g[0] == engine,
                      lambda g: True):
            near = [r for g, r in ratios.items() if alike(g)]
            if near:
                return float(np.median(near))
        return 1.0

    def seconds(self) -> float:
        ratios, pace = self._learnt(), self.pace()  # once per estimate, not once per group
        return sum(est * self._ratio(g, ratios, pace)
                   for g, est in self.pending.items()) / self.workers

    def measured(self) -> list[list[Any]]:
        """The finished groups' ratios, ``[[engine, scenario, batched, took / estimate]]``
        (sorted: what :data:`TIME_PRIORS` holds)."""
        return sorted([*g, took / est] for g, (est, took) in self.done.items() if est > 0.0)


DISPATCH_MIN_S = 1.0
"""Runs predicted (:func:`predicted_s`: their estimates times the measured priors) below this
in all run in this process under the default placement: a local cluster's start (~1.5 s on
two cores) would cost more than it saves (a 20-run report: 1.29x the in-process time on
Dask)."""


def predicted_s(estimates: dict[tuple, float], clock: TimeLeft) -> float:
    """The time (s, in one process) of work whose estimates (:func:`impactbench.cluster.
    run_estimate_s`) add up to ``estimates[group]`` per group ``(engine, scenario, batched)``:
    each group's sum times what its items take over their estimate (``clock.ratio``: the
    measured prior before any finished). The estimates alone are a generic step cost: a
    MuJoCo cube toss takes 0.07 of its estimate (:data:`TIME_PRIORS`): a cube-toss tune's
    generation of 18 tosses is estimated at 1.76 s and predicted at 0.12 s, and the whole
    tune of 8 candidates takes 0.2 s here against 1.7 s (3 CPU s) with that generation
    sent to a fresh local cluster."""
    return sum(est * clock.ratio(group) for group, est in estimates.items())


def runner_for(workers: int | None = None, scheduler: str | None = None) -> Any:
    """The :class:`impactbench.cluster.Runner` :func:`run_jobs` runs on by default: ``workers``
    local processes or ``scheduler``; with neither, the default placement (work predicted
    below :data:`DISPATCH_MIN_S` runs in this process, a given --workers N or a scheduler
    always gets the work)."""
    from impactbench import cluster

    floor = DISPATCH_MIN_S if workers is None and scheduler is None else 0.0
    return cluster.Runner(workers, scheduler, min_dispatch_s=floor)


def run_jobs(jobs: list[Job], workers: int | None = None,
             progress: Callable[[int], None] | None = None, *, store: Any = None,
             fresh: bool = False, scheduler: str | None = None,
             yes: bool = True, limits: Any = None,
             timeout_s: float | None = None,
             references: dict[tuple, dict[str, Any]] | None = None,
             clock: TimeLeft | None = None, runner: Any = None) -> list[JobResult]:
    """Run ``jobs``; results sorted by job id.

    ``store`` (an :class:`impactbench.store.Store`) serves finished runs and keeps new ones
    (written at least every :data:`FLUSH_EVERY_S`); ``fresh`` runs everything again (and
    stores it). ``workers`` local worker processes (default one per core, at most one per
    core and per missing run; 0 runs in this process without crash isolation);
    ``scheduler`` the address of an existing Dask scheduler instead; by default, missing runs
    predicted (:func:`predicted_s`) below :data:`DISPATCH_MIN_S` in all run in this process
    (no cluster start).
    The runs go in small batches (:meth:`impactbench.cluster.Runner.run`), so ``progress(n)``
    hears of each within seconds (``progress(0)``: nothing new, a heartbeat).
    A run that outlasts ``timeout_s`` (default: :func:`impactbench.cluster.
    configured_timeout`, else :func:`impactbench.cluster.default_timeout` of its estimate)
    becomes a ``timeout`` row, its worker restarted; like ``crashed`` rows, not stored.
    Ctrl-C (SIGTERM, SIGHUP) raises :class:`Interrupted` after storing what finished.
    ``yes = False`` refuses (ValueError) when the missing runs need more than
    ``cliutil.COST_LIMIT`` steps in all.
    ``limits`` (:class:`impactbench.plausibility.Limits`): judge every run, stored or new, by
    these instead of the defaults (a stored run keeps its measures, not its verdict).
    ``references``: reference metrics already computed, by ``Job.reference_key`` (filled in).
    ``clock``: the time-left estimate to keep (:class:`TimeLeft`; a new one by default): after
    the run it holds what each group of work items took.
    ``runner``: an open :class:`impactbench.cluster.Runner` to run the missing runs on (its
    placement instead of ``workers`` and ``scheduler``'s), left open: calls that share one
    share its cluster (a tune's generations: one cluster start, not one per generation);
    default one of ``workers`` and ``scheduler``, closed on return.
    """
    from impactbench import cluster
    from impactbench import store as store_mod

    references = references if references is not None else {}
    settings: dict[str, Any] = {}
    inputs: dict[str, dict[str, Any]] = {}
    keys: dict[str, str] = {}
    for job in jobs:
        if job.reference_key not in references:
            references[job.reference_key] = reference_metrics(job.build_scenario())
        settings[job.id] = job_settings(job)
        if store is not None:
            inputs[job.id] = job_inputs(job, settings[job.id])
            keys[job.id] = store_mod.run_key(inputs[job.id])
    results: dict[str, JobResult] = {}
    if store is not None and not fresh:
        found = store.get(keys.values(), with_history=[keys[j.id] for j in jobs
                                                       if j.keep_history])
        for job in jobs:
            if keys[job.id] in found:
                results[job.id] = _result_from_store(job, *found[keys[job.id]],
                                                     references[job.reference_key])
        if progress and results:
            progress(len(results))
    # one run per store key: a work-precision point that equals a matrix point runs once and
    # serves both (the representative keeps a history when any twin needs one)
    twins: dict[str, list[Job]] = {}
    for job in sorted((j for j in jobs if j.id not in results), key=lambda j: j.id):
        group = twins.setdefault(keys.get(job.id, job.id), [])
        if job.keep_history and not (group and group[0].keep_history):
            group.insert(0, job)
        else:
            group.append(job)
    steps = {j.id: estimated_steps(j, references[j.reference_key])
             for g in twins.values() for j in g[:1]}
    # the longest runs first (by estimated work), so that they do not finish last alone
    pending = sorted((g[0] for g in twins.values()),
                     key=lambda j: (-steps[j.id] * j.spec.step_cost, j.id))
    if not yes:
        from impactbench.cliutil import check_cost

        check_cost(sum(steps.values()), f"{len(pending)} runs", yes, "integration steps")
    if timeout_s is None:
        timeout_s = cluster.configured_timeout()
    if timeout_s is not None and not (math.isfinite(timeout_s) and timeout_s > 0):
        raise ValueError(f"timeout = {timeout_s!r}: must be a number of seconds > 0")

    def cost_of(item: list[Item]) -> float:
        return sum(cluster.run_estimate_s(steps[job.id] * job.spec.step_cost)
                   for job, _, _ in item)

    def timeout_of(item: list[Item]) -> float:
        # the engine's first-use compile does not count against the timeout; a batch's
        # (its runs' together) is its runs' own timeouts added up
        job = item[0][0]
        return (timeout_s * len(item) if timeout_s else cluster.default_timeout(
            cost_of(item))) + cluster.first_use_s(job.engine)

    unstored: list[JobResult] = []
    last_flush = time.monotonic()

    def flush() -> None:
        nonlocal last_flush
        if store is not None and unstored:
            store.put((keys[r.job.id], inputs[r.job.id], r.job, r.run, r.history)
                      for r in unstored if r.run["status"] not in UNSTORED)
        unstored.clear()
        last_flush = time.monotonic()

    estimates: dict[str, tuple[Any, float]] = {}
    left = getattr(progress, "left", None)

    def say_left(clock: TimeLeft) -> None:
        if left is not None:
            left(clock.seconds())

    def finished(result: JobResult) -> None:
        unstored.append(result)  # first: a result counted below is one the flush writes
        results[result.job.id] = result
        if result.job.id in estimates:
            group, share = estimates[result.job.id]
            clock.finished(group, share, result.took_s)
            say_left(clock)
        group = twins[keys.get(result.job.id, result.job.id)]
        for twin in group[1:]:
            results[twin.id] = JobResult(twin, dict(result.run),
                                         result.history if twin.keep_history else {},
                                         result.cached)
        if time.monotonic() - last_flush > FLUSH_EVERY_S:
            flush()
        if progress:
            progress(len(group))

    def tick() -> None:
        if unstored and time.monotonic() - last_flush > FLUSH_EVERY_S:
            flush()
        if progress:
            progress(0)

    try:
        if pending:
            items = work_items(pending, settings, references)
            clock = clock if clock is not None else TimeLeft(1)
            by_group: dict[tuple, float] = {}
            for item in items:
                group = (item[0][0].engine, item[0][0].scenario, len(item) > 1)
                for job, _, _ in item:
                    share = cluster.run_estimate_s(steps[job.id] * job.spec.step_cost)
                    clock.add(group, share)
                    estimates[job.id] = (group, share)
                    by_group[group] = by_group.get(group, 0.0) + share
            estimate = predicted_s(by_group, clock)

            def failed(item: list[Item], why: str, status: str = "crashed") -> None:
                more = f" (one of a batch of {len(item)} runs)" if len(item) > 1 else ""
                for job, reference, _ in item:
                    finished(_crashed(job, why + more, reference, status))

            with (contextlib.nullcontext(runner) if runner is not None else
                  runner_for(workers, scheduler)) as runner:
                clock.workers = 1 if estimate < runner.min_dispatch_s else runner.size
                say_left(clock)
                try:
                    runner.run(execute_items, items, estimate_s=estimate,
                               on_result=lambda _item, got: [finished(r) for r in got],
                               on_crash=failed,
                               on_timeout=lambda item, why: failed(item, why, "timeout"),
                               label="runs",
                               group=lambda item: (item[0][0].engine, len(item) > 1),
                               cost=cost_of, timeout_s=timeout_of, on_tick=tick,
                               prepare=prepare_items)
                except KeyboardInterrupt:
                    flush()  # before the cluster closes (seconds)
                    raise
    except KeyboardInterrupt:
        flush()
        kept = sum(r.run["status"] not in UNSTORED for r in results.values())
        raise Interrupted(kept, len(jobs), store is not None) from None
    flush()
    out = [results[j.id] for j in sorted(jobs, key=lambda j: j.id)]
    if limits is not None:
        from impactbench.plausibility import judge

        for r in out:
            r.run = judge(r.run, limits)
    return out


def tidy(results: list[JobResult]) -> list[dict[str, Any]]:
    """One row per run and metric (DESIGN.md's columns, plus study, the run's plausibility
    measures ``penetration_ratio``, ``energy_ratio`` and ``step_overlap_ratio``
    (:mod:`impactbench.plausibility`), ``phases`` (how many phases of the step the run was
    measured at: ``value`` is then their median, ``value_min``/``value_max`` their range,
    NaN for a run of one phase; :mod:`impactbench.phases`), ``advice`` (the packaged advice
    file a practical run's params come from, '' for none) and
    the point's axes:
    every registered scenario's, each once — categorical ones after ``scenario``, numeric
    ones after ``mode``; a scenario without an axis leaves it "" or NaN)."""
    cats, nums = scenarios.point_columns()
    rows = []
    for r in results:
        j, run = r.job, r.run
        point = dict(j.point)
        measures = run.get("plausibility") or {}
        spread = (run.get("phases") or {}).get("spread") or {}
        for metric in j.spec.metrics:
            rows.append({
                "study": j.study,
                "scenario": j.scenario,
                **{c: point.get(c, "") for c in cats},
                "engine": j.engine,
                "mode": j.mode,
                **{c: point.get(c, math.nan) for c in nums},
                "timestep_s": run.get("timestep_s"),
                "metric": metric,
                "value": run.get(metric),
                "reference": run["reference"].get(metric),
                "rel_error": run["rel_error"].get(metric),
                "resolved": bool(run.get("resolved", {}).get(metric, True)),
                "params": j.variant,
                "status": run["status"],
                "message": run.get("not_comparable", {}).get(metric) or run.get("message", ""),
                "wall_s": run.get("wall_s"),
                "engine_version": run.get("engine_version", ""),
                "penetration_ratio": measures.get("penetration_ratio", math.nan),
                "energy_ratio": measures.get("energy_ratio", math.nan),
                "step_overlap_ratio": measures.get("step_overlap_ratio", math.nan),
                "phases": j.phases,
                "advice": j.advice,
                "value_min": spread.get(metric, (math.nan,) * 3)[0],
                "value_max": spread.get(metric, (math.nan,) * 3)[2],
            })
    return rows
