"""Fitting an engine's contact parameters to the cube tosses, on the training split only.

``tune(engine, budget)`` searches the engine's parameter space
(:mod:`~impactbench.engines.cube_toss_spaces`, named by the engine's
:class:`~impactbench.engines.registry.EngineSpec`) with the one tuner
(:mod:`impactbench.tuning.search`: its ``nevergrad`` method; ``pip install nevergrad``; DAIR
fitted with its ``NGOpt``) and returns a :class:`CubeTuneFit`; :func:`write_tuned` writes it as
a packaged tuned file ``impactbench/data/tuned/cube_toss/<engine>.toml`` (``[parameters]`` in
the engine's own keys, as ``replay(engine, "custom", params=…)`` takes them; :func:`load_tuned`
reads them).

Objective (:data:`OBJECTIVE`): the mean over the training tosses of each toss's time-mean
position error |p_sim − p_real| / (2h) — DAIR's position metric, a fraction of the cube's width,
under DAIR's replay protocol. Not DAIR's own training loss (they fitted a weighted sum of
position and rotation errors); the rotation error is reported, not fitted. A toss whose replay
fails or goes non-finite counts :data:`FAILED_TOSS_ERROR` widths.

- **Training tosses only.** The deterministic split of :mod:`~impactbench.cube_tosses.data`
  (367 training tosses of the packaged 456); ``tune`` refuses a test toss, every evaluation the
  optimiser sees replays exactly the training tosses it was given, and the test split is scored
  once, after the fit, for the provenance.
- **Through the one door.** An evaluation is a run of the cube-toss scenario
  (:class:`~impactbench.scenarios.cube_toss.CubeToss` with the selected tosses) in ``custom``
  mode with the candidate's engine parameters, through the engine's adapter and its cube-toss
  builder (:func:`impactbench.matrix.run_jobs`, :func:`impactbench.evaluate.compare`): one engine
  instance replays the tosses (MJX and Newton all of them in one call), the scenario scores them.
- **Batches.** The optimiser asks a whole CMA-ES generation at once
  (:func:`impactbench.tuning.search.nevergrad`); its runs go to ``run_jobs`` together, which runs
  them in this process, or on Dask workers (``workers``; the same numbers).
- **Parameter spaces** (:data:`SPACES`, :mod:`~impactbench.engines.cube_toss_spaces`, in the
  engine layer): named knobs with bounds, log-scaled where a knob spans decades, a categorical
  where the engine has a discrete choice (MuJoCo's friction cone). The start is the middle of
  each box, never DAIR's fitted values: those were fitted on all tosses, test tosses
  included.
- **Optimiser**: nevergrad ``CMA`` by default (the ``cma`` package's CMA-ES; its candidates
  depend on the seed and the evaluations so far, never on the budget, so a longer budget repeats
  the shorter run's candidates — served from the store — and continues). Any nevergrad name
  works (``optimizer="NGOpt"``, DAIR's: its algorithm is chosen from the budget, so a different
  budget starts a different search; asked one candidate at a time). Seeded (``seed``): the same
  seed, data and engine give the same parameters.
- **Results store** (:class:`impactbench.store.Store`, the same DuckDB file as every run):
  every evaluation is a stored run (study ``tune``, :data:`impactbench.store.CANDIDATE`: left
  out of ``impactbench history``), keyed like any run by the engine and its version, the
  scenario's fields (data file and its SHA-256, tosses, protocol), the mode and the engine
  parameters: a rerun, or a longer budget, evaluates only what the store lacks.
- The result is the best evaluated candidate (lowest training objective; the start counts).
"""

from __future__ import annotations

import hashlib
import math
import tempfile
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

import impactbench.cube_tosses.data as data_mod
import impactbench.engines.cube_toss as engines_mod
from impactbench.cube_tosses.protocol import Protocol, summarize
from impactbench.engines.cube_toss_spaces import (
    DRAKE_APPROXIMATION,
    SPACES,
    Knob,
    engine_params,
    space,
)
from impactbench.tuning import search as search_mod

OBJECTIVE = ("mean over the training tosses of the time-mean position error "
             "|p_sim - p_real| / (2h) (DAIR's protocol; a failed toss counts 10)")
FAILED_TOSS_ERROR = 10.0
SEED = search_mod.SEED
DEFAULT_OPTIMIZER = "CMA"
TUNED_DIR = Path(__file__).resolve().parents[1] / "data" / "tuned" / "cube_toss"
RUN_TIMEOUT_S = 3600.0
"""A replay still going after this long is a hang (``run_jobs``' per-run timeout): the training
split's 367 tosses take 1–30 s per engine on 2 shared cores (measured), far under the
60 s floor of the default timeout only on a quiet machine."""


# ------------------------------------------------------------------------------ evaluation


def ids_hash(ids: Iterable[int]) -> str:
    """SHA-256 (first 16 hex digits) of the toss ids, comma-separated in the given order."""
    return hashlib.sha256(",".join(str(int(i)) for i in ids).encode()).hexdigest()[:16]


def data_hash(df: pd.DataFrame, ids: Sequence[int]) -> str:
    """SHA-256 (first 16 hex digits) of the rows of tosses ``ids`` (every column)."""
    rows = df[df["toss"].isin([int(i) for i in ids])][list(data_mod.COLUMNS)]
    digest = hashlib.sha256(pd.util.hash_pandas_object(rows, index=False).to_numpy().tobytes())
    return digest.hexdigest()[:16]


@dataclass
class Evaluation:
    """One candidate replayed on a set of tosses (from its run object: :func:`evaluation_of`).

    Attributes:
        objective: :data:`OBJECTIVE` (widths).
        position_error, rotation_error_deg: per toss, in the ids' order (NaN where failed).
        failed: the tosses that did not replay. elapsed_s: the replay's wall time (s).
        cached: served from the results store.
    """

    objective: float
    position_error: list[float]
    rotation_error_deg: list[float]
    failed: list[int]
    elapsed_s: float
    cached: bool = False

    def summary(self, ids: Sequence[int]) -> dict[str, Any]:
        rows = [{"toss": i, "status": "ok", "position_error": p, "rotation_error_deg": r}
                for i, p, r in zip(ids, self.position_error, self.rotation_error_deg,
                                   strict=True) if i not in set(self.failed)]
        return {**summarize(rows), "objective": self.objective, "tosses": len(ids),
                "failed": list(self.failed)}


def evaluation_of(run: Mapping[str, Any], ids: Sequence[int], cached: bool = False
                  ) -> Evaluation:
    """The :class:`Evaluation` of a cube-toss run object (``compare``'s, or the store's) on
    tosses ``ids``: each toss's errors from its ``per_toss`` row; a toss without an ``ok`` row
    (it failed, or the run did: no rows) is failed and counts :data:`FAILED_TOSS_ERROR`."""
    rows = {int(r["toss"]): r for r in (run.get("per_toss") or ())}
    pos, rot, failed = [], [], []
    for i in ids:
        row = rows.get(int(i))
        if row is not None and row.get("status", "ok") == "ok":
            pos.append(float(row["position_error"]))
            rot.append(float(row["rotation_error_deg"]))
        else:
            pos.append(math.nan)
            rot.append(math.nan)
            failed.append(int(i))
    scored = np.where(np.isfinite(pos), pos, FAILED_TOSS_ERROR)
    elapsed = float(run.get("elapsed_s", run.get("wall_s", math.nan)) or math.nan)
    return Evaluation(float(np.mean(scored)), pos, rot, failed, elapsed, cached)


def scenario_of(data: str | Path | None, tosses: str | Sequence[int],
                protocol: Protocol | None = None) -> Any:
    """The cube-toss scenario (:class:`~impactbench.scenarios.cube_toss.CubeToss`, through the
    scenario registry) replaying ``tosses`` (a split name or ids) of ``data`` (a CSV path;
    None: the packaged tosses) under ``protocol`` (DAIR's by default)."""
    from impactbench.scenarios import get

    protocol = protocol or Protocol()
    selection = tosses if isinstance(tosses, str) else ",".join(str(int(i)) for i in tosses)
    return get("cube-toss").cls(half_width_m=protocol.half_width_m, data=str(data) if data else "",
                    tosses=selection, substeps=protocol.substeps,
                    start_rule=protocol.start_rule, samples_before=protocol.samples_before,
                    refit=protocol.refit, min_preceding=protocol.min_preceding,
                    velocity_fit=protocol.velocity_fit, sample_dt_s=protocol.sample_dt_s,
                    board_z_m=protocol.board_z_m)


def data_file(data: pd.DataFrame | str | Path | None) -> str | None:
    """A path the scenario can name for ``data``: the path itself, None for the packaged
    tosses, and for a DataFrame a CSV of its rows named by their SHA-256 in the temporary
    directory (the same rows, the same file: stored runs of it are found again)."""
    if not isinstance(data, pd.DataFrame):
        return None if data is None else str(data)
    frame = data_mod.validate(data)
    digest = hashlib.sha256(pd.util.hash_pandas_object(
        frame[list(data_mod.COLUMNS)], index=False).to_numpy().tobytes()).hexdigest()[:16]
    path = Path(tempfile.gettempdir()) / f"impactbench-tosses-{digest}.csv"
    if not path.is_file():
        partial = path.with_suffix(f".{time.time_ns()}.part")
        frame.to_csv(partial, index=False)
        partial.replace(path)
    return str(path)


@dataclass
class Replays:
    """The fit's batch objective (:class:`~impactbench.tuning.search.BatchObjective`): each
    candidate (knob name → value) is a ``custom`` run of ``scenario`` with the engine
    parameters it maps to (:func:`~impactbench.engines.cube_toss_spaces.engine_params`), a batch's
    runs handed to :func:`impactbench.matrix.run_jobs` at once (served by ``store`` where it has
    them; the rest in this process, or on ``workers`` Dask workers / a ``scheduler``), then
    scored (:func:`evaluation_of`). Keeps every evaluation in order (``history``), the best,
    and how many the store served (``hits``); ``progress`` hears (done, budget, J, best J)."""

    engine: str
    scenario: Any
    ids: list[int]
    budget: int = 0
    store: Any = None
    fresh: bool = False
    workers: int | None = None
    scheduler: str | None = None
    progress: Callable[[int, int, float, float], None] | None = None
    runner: Any = None
    """An open :class:`impactbench.cluster.Runner` the generations share (one cluster start
    for the whole fit); None: each generation's own (:func:`impactbench.matrix.run_jobs`)."""
    history: list[tuple[dict[str, Any], float]] = field(default_factory=list)
    best: tuple[float, dict[str, Any], Evaluation] | None = None
    hits: int = 0
    references: dict[tuple, dict[str, Any]] = field(default_factory=dict, repr=False)

    def runs(self, params: Sequence[Mapping[str, Any] | None]) -> list[tuple[dict, bool]]:
        """(run object, served from the store) of each engine-parameter set (None or {}: the
        engine out of the box, ``default`` mode), in order."""
        # a local cluster is started with at most one worker per item: a generation smaller
        # than the cluster (the start candidate alone) runs on its own Runner, so that the
        # shared one is started by a generation that fills it
        shared = self.runner
        if shared is not None and not shared.started and len(params) < shared.size:
            shared = None
        return replay_runs(self.engine, self.scenario, params, store=self.store,
                           fresh=self.fresh, workers=self.workers, scheduler=self.scheduler,
                           references=self.references, runner=shared)

    def evaluate_batch(self, candidates: Sequence[Mapping[str, Any]]) -> list[float]:
        values = [_plain(c) for c in candidates]
        out = []
        for knobs, (run, cached) in zip(values, self.runs(
                [engine_params(self.engine, v) for v in values]), strict=True):
            if run["status"] == "unavailable":
                raise ValueError(f"engine = {self.engine!r}: {run['message']}")
            ev = evaluation_of(run, self.ids, cached)
            self.hits += cached
            self.history.append((knobs, ev.objective))
            if self.best is None or ev.objective < self.best[0]:
                self.best = (ev.objective, knobs, ev)
            if self.progress is not None:
                self.progress(len(self.history), self.budget, ev.objective, self.best[0])
            out.append(ev.objective)
        return out


def replay_runs(engine: str, scenario: Any, params: Sequence[Mapping[str, Any] | None],
                *, store: Any = None, fresh: bool = False, workers: int | None = None,
                scheduler: str | None = None,
                references: dict[tuple, dict[str, Any]] | None = None, runner: Any = None
                ) -> list[tuple[dict[str, Any], bool]]:
    """Run ``scenario`` in ``engine`` once per engine-parameter set of ``params`` (``custom``
    mode; None or {}: ``default``) through :func:`impactbench.matrix.run_jobs` (study
    :data:`~impactbench.store.CANDIDATE`): (run object, served from ``store``) each, in order.
    A run past :data:`RUN_TIMEOUT_S` is a ``timeout``. ``runner``: an open Runner to run on
    (:func:`~impactbench.matrix.run_jobs`'s)."""
    from impactbench.config import frozen_params
    from impactbench.matrix import Job, run_jobs
    from impactbench.store import CANDIDATE

    defaults = type(scenario)().to_dict()
    fields = tuple(sorted((k, v) for k, v in scenario.to_dict().items() if v != defaults[k]))
    jobs = [Job(engine, scenario.name, (), "custom" if p else "default", None, fields,
                frozen_params(dict(p)) if p else (), study=CANDIDATE) for p in params]
    results = {r.job.id: r for r in run_jobs(
        jobs, workers, store=store, fresh=fresh, scheduler=scheduler, timeout_s=RUN_TIMEOUT_S,
        references=references if references is not None else {}, runner=runner)}
    return [(results[j.id].run, results[j.id].cached) for j in jobs]


def engine_version(engine: str) -> str:
    """The installed version of the engine's distribution (for the provenance)."""
    dist = {"mjx": "mujoco-mjx", "dart": "dartpy"}.get(engine, engine)
    out = engines_mod._version(dist)
    if engine == "mjx":
        out += f" (mujoco {engines_mod._version('mujoco')}, jax {engines_mod._version('jax')})"
    if engine == "newton":
        out += f" (warp {engines_mod._version('warp-lang')})"
    return out


def open_store(store: Any) -> Any:
    """A :class:`impactbench.store.Store` for ``store``: True the default results store
    (``$IMPACTBENCH_STORE``), a path its file, a Store itself; None or False: none."""
    if store is None or store is False:
        return None
    from impactbench.store import Store, default_path

    if store is True:
        return Store(default_path())
    return store if isinstance(store, Store) else Store(Path(store))


# ------------------------------------------------------------------------------ the fit


@dataclass
class CubeTuneFit:
    """What :func:`tune` found (write it with :func:`write_tuned`).

    Attributes:
        engine, params (the engine's keys), knobs (the tuned values by knob name),
        start_knobs, space (the knobs' bounds and scales), objective_start, objective
        (the best training objective), train / test / all_tosses (summaries: mean, median,
        quartiles of both errors; test and all are scored after the fit, None when not),
        evaluations (candidates evaluated, start included), cache_hits (of those, served from
        the results store), budget, seed, optimizer, train_ids, wall_time_s, history ((knobs,
        objective) per evaluation).
    """

    engine: str
    params: dict[str, Any]
    knobs: dict[str, Any]
    start_knobs: dict[str, Any]
    space: list[dict[str, Any]]
    objective_start: float
    objective: float
    train: dict[str, Any]
    test: dict[str, Any] | None
    all_tosses: dict[str, Any] | None
    evaluations: int
    cache_hits: int
    budget: int
    seed: int
    optimizer: str
    optimizer_version: str
    engine_version: str
    train_ids: list[int]
    train_ids_hash: str
    data_hash: str
    protocol: dict[str, Any]
    wall_time_s: float
    history: list[tuple[dict[str, Any], float]] = field(default_factory=list)


def search(knobs: Sequence[Knob], run: Callable[[Mapping[str, Any]], float], budget: int,
           seed: int, optimizer: str = DEFAULT_OPTIMIZER) -> float:
    """The one tuner's ``nevergrad`` method (:func:`impactbench.tuning.search.nevergrad`) on a
    function ``run(knob values) -> objective`` called one candidate at a time, in order: the
    start (each knob's ``start``), then ``budget − 1`` candidates of ``optimizer`` seeded with
    ``seed`` (a generation asked at once, then run and told in order: the same candidates as
    asking one at a time); ``run`` keeps what it needs (the best). Returns the start's
    objective. (The reference model's fit, :mod:`~impactbench.cube_tosses.reference_model`.)"""
    return search_mod.nevergrad(knobs, search_mod.FunctionObjective(run), budget, seed=seed,
                                optimizer=optimizer)


def _plain(values: Mapping[str, Any]) -> dict[str, Any]:
    return {k: (v if isinstance(v, str) else float(v)) for k, v in values.items()}


def training_ids(df: pd.DataFrame, tosses: str | Iterable[int] = "train") -> list[int]:
    """The ids a fit uses: the training split, or given ids that must all be training tosses
    (ValueError naming the first test toss)."""
    if isinstance(tosses, str):
        if tosses != "train":
            raise ValueError(f"tosses = {tosses!r}: a fit uses the 'train' split (or ids of "
                             "training tosses) only")
        return data_mod.split(data_mod.toss_ids(df), "train")
    ids = [int(i) for i in tosses]
    bad = [i for i in ids if data_mod.in_test_set(i)]
    if bad:
        raise ValueError(f"tosses: toss {bad[0]} is in the test split; a fit never sees a "
                         "test toss")
    known = set(data_mod.toss_ids(df))
    missing = [i for i in ids if i not in known]
    if missing or not ids:
        raise ValueError(f"tosses: toss {missing[0] if missing else None} not in the data")
    return ids


def tune(engine: str, budget: int, *, seed: int = SEED,
         data: pd.DataFrame | str | Path | None = None,
         tosses: str | Iterable[int] = "train", protocol: Protocol | None = None,
         optimizer: str = DEFAULT_OPTIMIZER, store: Any = True, fresh: bool = False,
         workers: int | None = None, scheduler: str | None = None, score: bool = True,
         progress: Callable[[int, int, float, float], None] | None = None) -> CubeTuneFit:
    """Fit ``engine``'s contact parameters to the training tosses (module doc).

    Args:
        engine: one with a cube-toss space (:data:`SPACES`: pybullet, mujoco, drake, sapien,
            dart, newton, mjx).
        budget: candidate evaluations, the start included (≥ 2).
        seed: the optimiser's seed.
        data: the tosses (a DataFrame, a CSV path, None: the packaged ones).
        tosses: "train" or training-toss ids (a test toss is refused).
        protocol: the replay protocol (DAIR's by default).
        optimizer: a nevergrad optimiser name ("CMA", "NGOpt", …).
        store: the results store serving and keeping every evaluation (True: the default,
            ``$IMPACTBENCH_STORE``; a path or :class:`~impactbench.store.Store`; None or
            False: none); ``fresh`` runs everything again (and stores it).
        workers, scheduler: where a generation's runs go (:func:`impactbench.matrix.run_jobs`:
            default this process; N local Dask workers; a scheduler's address). The result
            does not depend on them, nor on the store.
        score: also score the best candidate on the test split and on all tosses (after the
            fit; the optimiser never sees them).
        progress: called after each evaluation with (done, budget, objective, best).
    """
    import nevergrad as ng

    from impactbench.matrix import runner_for

    if not (isinstance(budget, int) and budget >= 2):
        raise ValueError(f"budget = {budget!r}: must be an integer ≥ 2")
    knobs = space(engine)
    if optimizer not in ng.optimizers.registry:
        raise ValueError(f"optimizer = {optimizer!r}: not a nevergrad optimiser (e.g. CMA, "
                         "NGOpt, TwoPointsDE)")
    protocol = protocol or Protocol()
    df = data_mod.validate(data) if isinstance(data, pd.DataFrame) else data_mod.load(data)
    ids = training_ids(df, tosses)
    path = data_file(data)
    dhash = data_hash(df, ids)
    version = engine_version(engine)
    results = open_store(store)
    t0 = time.perf_counter()
    start_knobs = {k.name: k.start for k in knobs}
    with runner_for(workers, scheduler) as runner:  # one cluster (if any) for every generation
        replays = Replays(engine, scenario_of(path, "train" if isinstance(tosses, str) else ids,
                                              protocol),
                          ids, budget, results, fresh, workers, scheduler, progress, runner)
        objective_start = search_mod.nevergrad(knobs, replays, budget, seed=seed,
                                               optimizer=optimizer)
    assert replays.best is not None
    objective, best_knobs, best_ev = replays.best
    params = engine_params(engine, best_knobs)
    wall = time.perf_counter() - t0

    test = all_tosses = None
    hits = replays.hits  # the fit's own evaluations served from the store
    if score:
        all_tosses = score_params(engine, params, df, "all", protocol, results,
                                  data_path=path, workers=workers, scheduler=scheduler)
        test = split_summary(all_tosses, "test")
    return CubeTuneFit(
        engine=engine, params=params, knobs=best_knobs, start_knobs=_plain(start_knobs),
        space=[k.describe() for k in knobs], objective_start=objective_start,
        objective=objective, train=best_ev.summary(ids), test=test, all_tosses=all_tosses,
        evaluations=len(replays.history), cache_hits=hits, budget=budget, seed=seed,
        optimizer=optimizer, optimizer_version=f"nevergrad {engines_mod._version('nevergrad')}",
        engine_version=version, train_ids=ids, train_ids_hash=ids_hash(ids), data_hash=dhash,
        protocol=protocol.describe(), wall_time_s=wall, history=replays.history)


def score_params(engine: str, params: Mapping[str, Any], data: pd.DataFrame | None = None,
                 tosses: str | Iterable[int] = "test", protocol: Protocol | None = None,
                 store: Any = None, *, data_path: str | None = None,
                 workers: int | None = None, scheduler: str | None = None) -> dict[str, Any]:
    """``params`` (the engine's keys; {}: the engine out of the box) replayed on a split or
    ids (not for fitting), through the one door: the summary of both errors, ``per_toss``,
    ``elapsed_s``. ``store`` (:func:`open_store`'s values) serves and keeps the run (a rerun
    scores nothing again); ``data_path`` names ``data``'s file (default: the packaged
    tosses, or :func:`data_file` of a DataFrame that is not them)."""
    protocol = protocol or Protocol()
    df = data if data is not None else data_mod.load()
    ids = (data_mod.split(data_mod.toss_ids(df), tosses) if isinstance(tosses, str)
           else [int(i) for i in tosses])
    if data_path is None and data is not None:
        data_path = data_file(data)
    scenario = scenario_of(data_path, tosses if isinstance(tosses, str) else ids, protocol)
    [(run, cached)] = replay_runs(engine, scenario, [dict(params)], store=open_store(store),
                                  workers=workers, scheduler=scheduler)
    ev = evaluation_of(run, ids, cached)
    per_toss = [{"toss": i, "position_error": p, "rotation_error_deg": r}
                for i, p, r in zip(ids, ev.position_error, ev.rotation_error_deg, strict=True)]
    return {**ev.summary(ids), "split": tosses if isinstance(tosses, str) else "ids",
            "elapsed_s": ev.elapsed_s, "tosses_per_s": len(ids) / ev.elapsed_s,
            "per_toss": per_toss}


def split_summary(scored: Mapping[str, Any], which: str) -> dict[str, Any]:
    """The summary of the tosses of split ``which`` among ``scored``'s (from
    :func:`score_params`): scoring all tosses once serves the test split too."""
    ids = data_mod.split([r["toss"] for r in scored["per_toss"]], which)
    keep = set(ids)
    rows = [dict(r, status="ok") for r in scored["per_toss"]
            if r["toss"] in keep and math.isfinite(r["position_error"])]
    failed = [t for t in scored["failed"] if t in keep]
    pos = [r["position_error"] for r in rows] + [FAILED_TOSS_ERROR] * len(failed)
    return {**summarize(rows), "objective": float(np.mean(pos)) if pos else math.nan,
            "tosses": len(ids), "failed": failed, "split": which}


# ------------------------------------------------------------------------------ files


def tuned_path(engine: str) -> Path:
    """The packaged tuned file of ``engine``: ``impactbench/data/tuned/cube_toss/<engine>.toml``."""
    return TUNED_DIR / f"{engine}.toml"


def toml_ready(v: Any) -> Any:
    """``v`` as TOML takes it: tuples as lists, numpy scalars as Python's, a non-finite
    float as its text, None dropped from tables (the tuned files' writers')."""
    if isinstance(v, tuple | list):
        return [toml_ready(x) for x in v]
    if isinstance(v, np.generic):
        return v.item()
    if isinstance(v, float) and not math.isfinite(v):
        return repr(v)
    if isinstance(v, dict):
        return {str(k): toml_ready(x) for k, x in v.items() if x is not None}
    return v


def _short(summary: Mapping[str, Any] | None) -> dict[str, Any]:
    if summary is None:
        return {}
    keys = ("tosses", "objective", "position_error_mean", "position_error_median",
            "rotation_error_deg_mean", "rotation_error_deg_median", "failed")
    return {k: summary[k] for k in keys if k in summary}


def write_tuned(fit: CubeTuneFit, path: str | Path | None = None,
                references: Mapping[str, Mapping[str, Any]] | None = None) -> Path:
    """Write ``fit`` as a tuned file (TOML: ``[parameters]`` in the engine's keys, ``[knobs]``,
    ``[start]``, ``[provenance]`` with the optimiser, budget, seed, train-ids hash, wall time,
    ``[train]``, ``[test]``, ``[all]`` errors and ``[space]``; ``references``: name → split →
    summary of other parameter sets on the same splits, e.g. DAIR's, as
    ``[reference.<name>.<split>]``); returns the path."""
    import tomli_w

    out = Path(path) if path is not None else tuned_path(fit.engine)
    doc = {
        "parameters": toml_ready(fit.params),
        "knobs": toml_ready(fit.knobs),
        "start": toml_ready(fit.start_knobs),
        "provenance": toml_ready({
            "engine": fit.engine, "engine_version": fit.engine_version,
            "scenario": "cube-toss", "mode": "tuned", "objective": OBJECTIVE,
            "optimizer": fit.optimizer, "optimizer_version": fit.optimizer_version,
            "budget": fit.budget, "evaluations": fit.evaluations, "seed": fit.seed,
            "objective_start": fit.objective_start, "objective_tuned": fit.objective,
            "train_tosses": len(fit.train_ids), "train_ids_hash": fit.train_ids_hash,
            "data_hash": fit.data_hash, "split": "train (data.split: SHA-256 of the id ≢ 0 "
                                                  "mod 5); test scored after the fit",
            "wall_time_s": round(fit.wall_time_s, 1), "cache_hits": fit.cache_hits,
            "protocol": {k: v for k, v in fit.protocol.items() if v is not None}}),
        "train": toml_ready(_short(fit.train)),
        "test": toml_ready(_short(fit.test)),
        "all": toml_ready(_short(fit.all_tosses)),
        "space": {k["name"]: toml_ready({x: y for x, y in k.items() if x != "name"})
                  for k in fit.space},
    }
    if references:
        doc["reference"] = {name: {split: toml_ready(_short(summary))
                                   for split, summary in splits.items()}
                            for name, splits in references.items()}
    header = (f"# impactbench tune: {fit.engine} fitted to the cube tosses (training split "
              "only).\n# [parameters] are the engine's own keys: replay(engine, 'custom', "
              "params=load_tuned(engine)).\n\n")
    from impactbench.publish import atomic_write

    return atomic_write(out, header + tomli_w.dumps(doc))


def load_tuned(engine: str, path: str | Path | None = None) -> dict[str, Any]:
    """The ``[parameters]`` of ``engine``'s tuned file (packaged unless ``path``), lists as
    tuples (MuJoCo's solref); ValueError when there is none."""
    import tomllib

    src = Path(path) if path is not None else tuned_path(engine)
    if not src.is_file():
        raise ValueError(f"{engine}: no tuned file at {src}")
    params = tomllib.loads(src.read_text()).get("parameters")
    if not isinstance(params, dict):
        raise ValueError(f"{src}: [parameters] table is missing")
    return {k: tuple(v) if isinstance(v, list) else v for k, v in params.items()}


__all__ = ["DRAKE_APPROXIMATION", "OBJECTIVE", "SPACES", "CubeTuneFit", "Evaluation", "Knob",
           "Replays", "data_file", "engine_params", "evaluation_of", "load_tuned",
           "open_store", "replay_runs", "scenario_of", "score_params", "search", "space",
           "tune", "tuned_path", "write_tuned"]
