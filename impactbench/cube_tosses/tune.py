"""Fitting an engine's contact parameters to the cube tosses, on the training split only.

``tune(engine, budget)`` searches the engine's parameter space (:data:`SPACES`) with a
derivative-free optimiser from nevergrad (``pip install nevergrad``; DAIR fitted with its
``NGOpt``) and returns a :class:`CubeTuneFit`; :func:`write_tuned` writes it as a packaged
tuned file ``impactbench/data/tuned/cube_toss/<engine>.toml`` (``[parameters]`` in the engine's
own keys, as ``replay(engine, "custom", params=…)`` takes them; :func:`load_tuned` reads them).

Objective (:data:`OBJECTIVE`): the mean over the training tosses of each toss's time-mean
position error |p_sim − p_real| / (2h) — DAIR's position metric, a fraction of the cube's width,
under DAIR's replay protocol. Not DAIR's own training loss (they fitted a weighted sum of
position and rotation errors); the rotation error is reported, not fitted. A toss whose replay
fails or goes non-finite counts :data:`FAILED_TOSS_ERROR` widths.

- **Training tosses only.** The deterministic split of :mod:`~impactbench.cube_tosses.data`
  (367 training tosses of the packaged 456); ``tune`` refuses a test toss, every evaluation the
  optimiser sees replays exactly the training tosses it was given (one engine instance per
  candidate, batched: Newton and MJX replay them in one call), and the test split is scored once,
  after the fit, for the provenance.
- **Parameter spaces** (:data:`SPACES`): named knobs with bounds, log-scaled where a knob
  spans decades, a categorical where the engine has a discrete choice (MuJoCo's friction cone,
  Drake's discrete solver). The start is the middle of each box (the geometric mean of a log
  knob), never DAIR's fitted values: those were fitted on all tosses, test tosses included.
  Each knob maps onto the engine's keys so that the *effective* pair value is the knob (both
  bodies set where the engine combines them; see :func:`engine_params`).
- **Optimiser**: nevergrad ``CMA`` by default (the ``cma`` package's CMA-ES; its candidates
  depend on the seed and the evaluations so far, never on the budget, so a longer budget repeats
  the shorter run's candidates — served from the cache — and continues). Any nevergrad name
  works (``optimizer="NGOpt"``, DAIR's: its algorithm is chosen from the budget, so a different
  budget starts a different search). Seeded (``seed``): the same seed, data and engine give the
  same parameters.
- **Cache** (:class:`EvalCache`): every evaluation in a small SQLite file
  (``$IMPACTBENCH_TUNE_CACHE``, else ``$XDG_CACHE_HOME/impactbench/cube_toss_tune.sqlite``),
  keyed by a SHA-256 of the engine and its version, the parameters, the protocol, the toss ids
  and a hash of their data: a rerun, or a longer budget, evaluates only what it has not seen.
  (Not the results store: that keys whole scenario runs; these are per-candidate batches.)
- The result is the best evaluated candidate (lowest training objective; the start counts).
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import sqlite3
import time
import warnings
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

import impactbench.cube_tosses.data as data_mod
import impactbench.engines.cube_toss as engines_mod
from impactbench.cube_tosses.protocol import Protocol, Start, prepare, summarize, toss_errors

OBJECTIVE = ("mean over the training tosses of the time-mean position error "
             "|p_sim - p_real| / (2h) (DAIR's protocol; a failed toss counts 10)")
FAILED_TOSS_ERROR = 10.0
SEED = 20240607
DEFAULT_OPTIMIZER = "CMA"
TUNED_DIR = Path(__file__).resolve().parents[1] / "data" / "tuned" / "cube_toss"
CACHE_ENV = "IMPACTBENCH_TUNE_CACHE"
_CACHE_VERSION = 1


# ------------------------------------------------------------------------------ spaces


@dataclass(frozen=True)
class Knob:
    """One tuned quantity: a number in [low, high] (log-scaled when ``log``) or one of
    ``choices``; ``start`` is the middle of the box unless given."""

    name: str
    low: float = math.nan
    high: float = math.nan
    log: bool = True
    choices: tuple[str, ...] = ()
    unit: str = ""
    note: str = ""

    @property
    def start(self) -> Any:
        if self.choices:
            return self.choices[0]
        return math.sqrt(self.low * self.high) if self.log else 0.5 * (self.low + self.high)

    def describe(self) -> dict[str, Any]:
        if self.choices:
            return {"name": self.name, "choices": list(self.choices), "start": self.start,
                    "note": self.note}
        return {"name": self.name, "low": self.low, "high": self.high,
                "scale": "log" if self.log else "linear", "start": self.start,
                "unit": self.unit, "note": self.note}


def _friction(note: str) -> Knob:
    return Knob("friction", 0.02, 2.0, unit="", note=note)


SPACES: dict[str, tuple[Knob, ...]] = {
    "pybullet": (
        Knob("stiffness", 1e2, 1e6, unit="N/m", note="board.contactStiffness (the cube unset: "
             "1e30 in series, so the pair's value is the board's)"),
        Knob("damping", 0.1, 1e3, unit="N·s/m", note="board.contactDamping (pair: + the "
             "cube's 0.1)"),
        _friction("board.lateralFriction, cube.lateralFriction = 1 (Bullet multiplies)"),
    ),
    "mujoco": (
        Knob("stiffness", 1e2, 1e6, unit="1/s² (per unit effective mass)",
             note="direct solref (−k, −b) on both geoms"),
        Knob("damping", 1.0, 1e3, unit="1/s", note="direct solref (−k, −b) on both geoms"),
        _friction("friction (μ, 0.005, 0.0001) on both geoms (MuJoCo takes the larger)"),
        Knob("solimp_dmin", 0.5, 0.9999, log=False, note="solimp[0] on both geoms"),
        Knob("solimp_dmax", 0.5, 0.9999, log=False, note="solimp[1] on both geoms"),
        Knob("solimp_width", 1e-4, 0.1, unit="m", note="solimp[2] on both geoms "
             "(midpoint 0.5, power 2 kept)"),
        Knob("cone", choices=("pyramidal", "elliptic"), note="option.cone"),
        Knob("impratio", 1.0, 100.0, note="option.impratio (frictional/normal impedance)"),
    ),
    "drake": (
        Knob("stiffness", 1e3, 1e6, unit="N/m", note="effective pair point_contact_stiffness: "
             "both geometries 2k (in series)"),
        _friction("mu (static = dynamic) on both (Drake combines 2ab/(a + b))"),
        Knob("relaxation_time", 1e-4, 1.0, unit="s", note="relaxation_time on both (SAP's "
             "linear dissipation; SAP ignores hunt_crossley_dissipation)"),
    ),
    "sapien": (
        _friction("static = dynamic friction of both materials (PhysX averages)"),
        Knob("restitution", 0.0, 0.9, log=False, note="restitution of both materials "
             "(rigid contact; PhysX's compliant contact is undamped, not searched)"),
        Knob("bounce_threshold", 0.01, 5.0, unit="m/s", note="scene bounce_threshold"),
    ),
    "dart": (
        _friction("friction_coeff of both shapes (DART takes the smaller)"),
        Knob("restitution", 0.0, 0.9, log=False, note="board.restitution_coeff, cube 1 "
             "(DART multiplies)"),
    ),
    "newton": (
        Knob("ke", 1e2, 3e5, unit="N/m", note="ke of both shapes (averaged); semi-implicit "
             "stepping is unstable above ~3e5 at the protocol's step"),
        Knob("kd", 0.1, 300.0, unit="N·s/m", note="kd of both shapes"),
        Knob("kf", 1.0, 1e5, unit="N·s/m", note="kf (friction regularisation) of both shapes"),
        _friction("mu of both shapes"),
    ),
}
SPACES["mjx"] = SPACES["mujoco"]
DRAKE_APPROXIMATION = "sap"
"""Drake's discrete solver in a fit, fixed: SAP (DAIR's parameters replay best under it, and it
is not deprecated as TAMSI is); lagged and similar, the other current choices, run at about the
same speed and would need a categorical knob — more evaluations than one Drake budget holds
(a training evaluation takes 10–30 s on 2 shared cores)."""
"""engine → its knobs (bounds, scale); :func:`engine_params` maps them onto engine keys."""


def engine_params(engine: str, knobs: Mapping[str, Any]) -> dict[str, Any]:
    """The engine's own keys for the knob values ``knobs`` (module doc)."""
    k = dict(knobs)
    if engine == "pybullet":
        return {"board.contactStiffness": k["stiffness"], "board.contactDamping": k["damping"],
                "board.lateralFriction": k["friction"], "cube.lateralFriction": 1.0}
    if engine in ("mujoco", "mjx"):
        solref = (-k["stiffness"], -k["damping"])
        friction = (k["friction"], 0.005, 0.0001)
        solimp = (k["solimp_dmin"], k["solimp_dmax"], k["solimp_width"], 0.5, 2.0)
        return {"board.solref": solref, "cube.solref": solref, "board.friction": friction,
                "cube.friction": friction, "board.solimp": solimp, "cube.solimp": solimp,
                "option.cone": k["cone"], "option.impratio": k["impratio"]}
    if engine == "drake":
        out = {"contact_model": "point", "discrete_contact_approximation": DRAKE_APPROXIMATION}
        for body in ("board", "cube"):
            out |= {f"{body}.point_contact_stiffness": 2.0 * k["stiffness"],
                    f"{body}.mu": k["friction"],
                    f"{body}.relaxation_time": k["relaxation_time"]}
        return out
    if engine == "sapien":
        out = {"bounce_threshold": k["bounce_threshold"]}
        for body in ("board", "cube"):
            out |= {f"{body}.static_friction": k["friction"],
                    f"{body}.dynamic_friction": k["friction"],
                    f"{body}.restitution": k["restitution"]}
        return out
    if engine == "dart":
        return {"board.friction_coeff": k["friction"], "cube.friction_coeff": k["friction"],
                "board.restitution_coeff": k["restitution"], "cube.restitution_coeff": 1.0}
    if engine == "newton":
        return {f"{body}.{name}": k["friction" if name == "mu" else name]
                for body in ("board", "cube") for name in ("ke", "kd", "kf", "mu")}
    raise ValueError(f"engine = {engine!r}: tunable on the cube tosses: {', '.join(SPACES)}")


def space(engine: str) -> tuple[Knob, ...]:
    """The knobs of ``engine`` (ValueError naming the tunable engines)."""
    if engine not in SPACES:
        raise ValueError(f"engine = {engine!r}: tunable on the cube tosses: "
                         f"{', '.join(SPACES)}")
    return SPACES[engine]


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
    """One candidate replayed on a set of tosses."""

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


def evaluate(engine: str, params: Mapping[str, Any], starts: Sequence[Start],
             protocol: Protocol | None = None) -> Evaluation:
    """Replay ``starts`` in one instance of ``engine`` with ``params`` (batched engines in one
    call) and score them (:data:`OBJECTIVE`)."""
    protocol = protocol or Protocol()
    t0 = time.perf_counter()
    pos, rot, failed = [], [], []
    try:
        sim = engines_mod.make(engine, params, starts[0].step_s, protocol.board_z_m)
    except (ValueError, RuntimeError):
        n = len(starts)
        return Evaluation(FAILED_TOSS_ERROR, [math.nan] * n, [math.nan] * n,
                          [s.toss for s in starts], time.perf_counter() - t0)
    try:
        batch = sim.run_many(starts) if getattr(sim, "batched", False) else None
        for n, start in enumerate(starts):
            try:
                if batch is not None and isinstance(batch[n], Exception):
                    raise batch[n]
                p, q = batch[n] if batch is not None else sim.run(start)
                if not (np.all(np.isfinite(p)) and np.all(np.isfinite(q))):
                    raise FloatingPointError("non-finite state")
                e = toss_errors(start, p, q, protocol)
                pos.append(e["position_error"])
                rot.append(e["rotation_error_deg"])
            except (RuntimeError, FloatingPointError, ValueError):
                pos.append(math.nan)
                rot.append(math.nan)
                failed.append(start.toss)
    finally:
        sim.close()
    scored = np.where(np.isfinite(pos), pos, FAILED_TOSS_ERROR)
    return Evaluation(float(np.mean(scored)), pos, rot, failed, time.perf_counter() - t0)


def default_cache_path() -> Path:
    """``$IMPACTBENCH_TUNE_CACHE``, else ``$XDG_CACHE_HOME/impactbench/cube_toss_tune.sqlite``."""
    if os.environ.get(CACHE_ENV):
        return Path(os.environ[CACHE_ENV])
    base = Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache"))
    return base / "impactbench" / "cube_toss_tune.sqlite"


def _canonical(value: Any) -> Any:
    if isinstance(value, Mapping):
        return {str(k): _canonical(v) for k, v in sorted(value.items())}
    if isinstance(value, list | tuple | np.ndarray):
        return [_canonical(v) for v in value]
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, float):
        return repr(value)   # exact: 17 significant digits
    return value


class EvalCache:
    """Evaluations in an SQLite file (module doc), or none when ``path`` is None."""

    def __init__(self, path: str | Path | None) -> None:
        self.path = None if path is None else Path(path)
        self.hits = 0
        if self.path is not None:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            with self._connect() as con:
                con.execute("CREATE TABLE IF NOT EXISTS evaluations (key TEXT PRIMARY KEY, "
                            "engine TEXT, params TEXT, objective REAL, result TEXT)")

    def _connect(self) -> sqlite3.Connection:
        return sqlite3.connect(self.path, timeout=30.0)

    @staticmethod
    def key(engine: str, version: str, params: Mapping[str, Any], protocol: Protocol,
            ids: Sequence[int], data: str) -> str:
        blob = json.dumps({"v": _CACHE_VERSION, "engine": engine, "version": version,
                           "params": _canonical(params), "protocol": _canonical(
                               protocol.describe()), "ids": ids_hash(ids), "data": data,
                           "objective": OBJECTIVE}, sort_keys=True)
        return hashlib.sha256(blob.encode()).hexdigest()

    def get(self, key: str) -> Evaluation | None:
        if self.path is None:
            return None
        with self._connect() as con:
            row = con.execute("SELECT result FROM evaluations WHERE key = ?", (key,)).fetchone()
        if row is None:
            return None
        self.hits += 1
        d = json.loads(row[0])
        return Evaluation(d["objective"], _floats(d["position_error"]),
                          _floats(d["rotation_error_deg"]), d["failed"], d["elapsed_s"], True)

    def put(self, key: str, engine: str, params: Mapping[str, Any], ev: Evaluation) -> None:
        if self.path is None:
            return
        result = json.dumps({"objective": ev.objective,
                             "position_error": [_json_float(x) for x in ev.position_error],
                             "rotation_error_deg": [_json_float(x)
                                                    for x in ev.rotation_error_deg],
                             "failed": ev.failed, "elapsed_s": ev.elapsed_s})
        with self._connect() as con:
            con.execute("INSERT OR REPLACE INTO evaluations VALUES (?, ?, ?, ?, ?)",
                        (key, engine, json.dumps(_canonical(params)), ev.objective, result))


def _json_float(x: float) -> float | None:
    return float(x) if math.isfinite(x) else None


def _floats(xs: list[Any]) -> list[float]:
    return [math.nan if x is None else float(x) for x in xs]


def engine_version(engine: str) -> str:
    """The installed version of the engine's distribution (for the cache key and provenance)."""
    dist = {"mjx": "mujoco-mjx", "dart": "dartpy"}.get(engine, engine)
    out = engines_mod._version(dist)
    if engine == "mjx":
        out += f" (mujoco {engines_mod._version('mujoco')}, jax {engines_mod._version('jax')})"
    if engine == "newton":
        out += f" (warp {engines_mod._version('warp-lang')})"
    return out


# ------------------------------------------------------------------------------ the fit


@dataclass
class CubeTuneFit:
    """What :func:`tune` found (write it with :func:`write_tuned`).

    Attributes:
        engine, params (the engine's keys), knobs (the tuned values by knob name),
        start_knobs, space (the knobs' bounds and scales), objective_start, objective
        (the best training objective), train / test / all_tosses (summaries: mean, median,
        quartiles of both errors; test and all are scored after the fit, None when not),
        evaluations (candidates evaluated, start included), cache_hits, budget, seed,
        optimizer, train_ids, wall_time_s, history ((knobs, objective) per evaluation).
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


def _parametrization(knobs: Sequence[Knob], seed: int) -> Any:
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


def search(knobs: Sequence[Knob], run: Callable[[Mapping[str, Any]], float], budget: int,
           seed: int, optimizer: str = DEFAULT_OPTIMIZER) -> float:
    """Evaluate the start (each knob's ``start``), then ``budget − 1`` candidates of the
    nevergrad ``optimizer`` seeded with ``seed`` (one at a time: ask, ``run``, tell); ``run``
    keeps what it needs (the best). Returns the start's objective."""
    import nevergrad as ng

    objective_start = run({k.name: k.start for k in knobs})
    opt = ng.optimizers.registry[optimizer](parametrization=_parametrization(knobs, seed),
                                            budget=budget - 1, num_workers=1)
    with warnings.catch_warnings():
        # cma's "orphanated injected solution": nevergrad injects its candidates; harmless
        warnings.filterwarnings("ignore", message=".*orphanated injected solution")
        for _ in range(budget - 1):
            cand = opt.ask()
            opt.tell(cand, run(cand.value))
    return objective_start


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


def _starts(df: pd.DataFrame, ids: Sequence[int], protocol: Protocol) -> list[Start]:
    return [prepare(t, protocol) for t in data_mod.tosses(df, ids)]


def tune(engine: str, budget: int, *, seed: int = SEED,
         data: pd.DataFrame | str | Path | None = None,
         tosses: str | Iterable[int] = "train", protocol: Protocol | None = None,
         optimizer: str = DEFAULT_OPTIMIZER, cache: str | Path | bool | None = True,
         score: bool = True,
         progress: Callable[[int, int, float, float], None] | None = None) -> CubeTuneFit:
    """Fit ``engine``'s contact parameters to the training tosses (module doc).

    Args:
        engine: one of :data:`SPACES` (pybullet, mujoco, drake, sapien, dart, newton, mjx).
        budget: candidate evaluations, the start included (≥ 2).
        seed: the optimiser's seed.
        data: the tosses (a DataFrame, a CSV path, None: the packaged ones).
        tosses: "train" or training-toss ids (a test toss is refused).
        protocol: the replay protocol (DAIR's by default).
        optimizer: a nevergrad optimiser name ("CMA", "NGOpt", …).
        cache: True (the default file), a path, or False/None (no cache).
        score: also score the best candidate on the test split and on all tosses (after the
            fit; the optimiser never sees them).
        progress: called after each evaluation with (done, budget, objective, best).
    """
    import nevergrad as ng

    if not (isinstance(budget, int) and budget >= 2):
        raise ValueError(f"budget = {budget!r}: must be an integer ≥ 2")
    knobs = space(engine)
    if optimizer not in ng.optimizers.registry:
        raise ValueError(f"optimizer = {optimizer!r}: not a nevergrad optimiser (e.g. CMA, "
                         "NGOpt, TwoPointsDE)")
    protocol = protocol or Protocol()
    df = data_mod.validate(data) if isinstance(data, pd.DataFrame) else data_mod.load(data)
    ids = training_ids(df, tosses)
    starts = _starts(df, ids, protocol)
    dhash = data_hash(df, ids)
    version = engine_version(engine)
    store = EvalCache(default_cache_path() if cache is True else (cache or None))

    history: list[tuple[dict[str, Any], float]] = []
    best: tuple[float, dict[str, Any], Evaluation] | None = None
    t0 = time.perf_counter()

    def run(values: Mapping[str, Any]) -> float:
        nonlocal best
        values = _plain(values)
        params = engine_params(engine, values)
        key = EvalCache.key(engine, version, params, protocol, ids, dhash)
        ev = store.get(key)
        if ev is None:
            ev = evaluate(engine, params, starts, protocol)
            store.put(key, engine, params, ev)
        history.append((values, ev.objective))
        if best is None or ev.objective < best[0]:
            best = (ev.objective, values, ev)
        if progress is not None:
            progress(len(history), budget, ev.objective, best[0])
        return ev.objective

    start_knobs = {k.name: k.start for k in knobs}
    objective_start = search(knobs, run, budget, seed, optimizer)
    assert best is not None
    objective, best_knobs, best_ev = best
    params = engine_params(engine, best_knobs)
    wall = time.perf_counter() - t0

    test = all_tosses = None
    hits = store.hits  # the fit's own evaluations served from the cache
    if score:
        all_tosses = score_params(engine, params, df, "all", protocol, store)
        test = split_summary(all_tosses, "test")
    return CubeTuneFit(
        engine=engine, params=params, knobs=best_knobs, start_knobs=_plain(start_knobs),
        space=[k.describe() for k in knobs], objective_start=objective_start,
        objective=objective, train=best_ev.summary(ids), test=test, all_tosses=all_tosses,
        evaluations=len(history), cache_hits=hits, budget=budget, seed=seed,
        optimizer=optimizer, optimizer_version=f"nevergrad {engines_mod._version('nevergrad')}",
        engine_version=version, train_ids=ids, train_ids_hash=ids_hash(ids), data_hash=dhash,
        protocol=protocol.describe(), wall_time_s=wall, history=history)


def score_params(engine: str, params: Mapping[str, Any], data: pd.DataFrame | None = None,
                 tosses: str | Iterable[int] = "test", protocol: Protocol | None = None,
                 cache: EvalCache | None = None) -> dict[str, Any]:
    """``params`` replayed on a split or ids (not for fitting): the summary of both errors.
    ``cache``: served from / kept in an :class:`EvalCache` (a rerun scores nothing again)."""
    protocol = protocol or Protocol()
    df = data if data is not None else data_mod.load()
    ids = (data_mod.split(data_mod.toss_ids(df), tosses) if isinstance(tosses, str)
           else [int(i) for i in tosses])
    key = ev = None
    if cache is not None:
        key = EvalCache.key(engine, engine_version(engine), params, protocol, ids,
                            data_hash(df, ids))
        ev = cache.get(key)
    if ev is None:
        ev = evaluate(engine, params, _starts(df, ids, protocol), protocol)
        if cache is not None:
            cache.put(key, engine, params, ev)
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


def _toml_value(v: Any) -> Any:
    if isinstance(v, tuple | list):
        return [_toml_value(x) for x in v]
    if isinstance(v, np.generic):
        return v.item()
    if isinstance(v, float) and not math.isfinite(v):
        return repr(v)
    if isinstance(v, dict):
        return {str(k): _toml_value(x) for k, x in v.items() if x is not None}
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
        "parameters": _toml_value(fit.params),
        "knobs": _toml_value(fit.knobs),
        "start": _toml_value(fit.start_knobs),
        "provenance": _toml_value({
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
        "train": _toml_value(_short(fit.train)),
        "test": _toml_value(_short(fit.test)),
        "all": _toml_value(_short(fit.all_tosses)),
        "space": {k["name"]: _toml_value({x: y for x, y in k.items() if x != "name"})
                  for k in fit.space},
    }
    if references:
        doc["reference"] = {name: {split: _toml_value(_short(summary))
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


__all__ = ["OBJECTIVE", "SPACES", "CubeTuneFit", "EvalCache", "Knob", "engine_params",
           "evaluate", "load_tuned", "score_params", "space", "tune", "tuned_path",
           "write_tuned"]
