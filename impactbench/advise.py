"""The advisor: the best settings at your step, for your body, judged at the worst phase.

``advise(engine, timestep_s, …)`` searches every contact model the engine offers a user
(:mod:`impactbench.engines.advice_models`: the engine's defaults plus a few of its own
settings, ``custom`` mode) for the one whose restitution follows the target over a speed range
(the Hunt–Crossley reference of the body, or the user's measured restitution-vs-speed CSV):

- every candidate is run at each speed at :data:`impactbench.phases.PHASES` phases of the step
  (where the first touch falls inside a step) and judged at its worst phase: a phase that
  creates energy or sinks beyond the step's own overlap makes the speed implausible
  (:mod:`impactbench.plausibility`), and its error is the worst phase's;
- the answer is the plausible candidate with the smallest worst error over speeds and phases;
  each model's search is a seeded scrambled Sobol scan of its box (in ln of each setting)
  followed by Nelder–Mead polishes of the worst error from the best scan points, in an equal
  share of :data:`EVALUATIONS` candidates per engine: a fixed number of evaluations, so the
  answer does not depend on the machine; the time budget is a cap (shared out over the
  models in turn) that only a slow machine reaches, and the answer then says so (``stop``);
- where no candidate is plausible at every speed it says so and looks for the longest step at
  which one is, halving the step: "run at ≤ X (its worst error there) or accept Y" (the best
  error at your step, with implausible runs). (Not "within 5 %": a constant restitution, what
  most engines offer, cannot come within 12.8 % of the paper's ball over 0.5–5 m/s at any
  step.)

MJX runs MuJoCo's model and law (its records equal C MuJoCo's; the suite tests that), so its
search runs on C MuJoCo and only the answer is run in MJX, at every speed and phase.
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from impactbench.engines.advice_models import ENGINE_STEPS_S, ContactModel, models, snippet
from impactbench.engines.base import RunSettings, get_adapter
from impactbench.engines.tuning_spaces import Parameter, Space
from impactbench.phases import PHASES, offsets
from impactbench.reference import validation as check
from impactbench.reference.scenarios import BallOnPlate
from impactbench.tuning.objective import Evaluation, Objective, quiet
from impactbench.tuning.search import SEED, OutOfBudget

DEFAULT_VELOCITIES_M_S = (0.5, 1.0, 2.0, 3.0, 4.0, 5.0)
"""The paper's speed range, 0.5–5 m/s."""
DEFAULT_BUDGET_S = 60.0
"""Wall time the advice may take per engine (s)."""
FALLBACK_EVALUATIONS = 48
"""Candidates per engine at each step the fallback tries (a quarter of :data:`EVALUATIONS`:
it looks for a step where anything is plausible, then reports the best it found there)."""
EVALUATIONS = 200
"""Candidates evaluated per engine, shared out equally over its contact models: each model's
Sobol scan takes a power of two of them, at most :data:`SCAN_PER_SETTING` per setting and
at most half its share, and the Nelder–Mead polishes the rest."""
SCAN_PER_SETTING = 16
"""Sobol points per searched setting at most (16 for a constant restitution, 32 for a
spring: a power of two each, Sobol's balance)."""
POLISH_STARTS = 2
"""Nelder–Mead starts: the best scan points, each polished with an equal part of what the
scan left."""
TWIN = {"mjx": "mujoco"}
"""Engines searched through a twin whose records equal theirs (the answer is run in both)."""
TIE_BREAK = 1e-3
"""Weight of the mean error over speeds in :func:`score` (it only orders equal worst errors)."""
SMALLEST_STEP_S = 1e-5
"""The fallback halves the step no further than this."""


@dataclass
class Tried:
    """One evaluated candidate: its model, params, score and what it did."""

    model: str
    params: dict[str, Any]
    worst_error: float
    max_sinking: float
    plausible: bool


@dataclass
class Advice:
    """The advisor's answer (see the module).

    Attributes:
        engine, timestep_s: the engine and the step (s) the advice is for.
        model: the chosen contact model's name; ``params``: its ``custom`` settings (the
            engine's own keys: ``impactbench run … --mode custom --param KEY=VALUE`` reruns
            it); ``snippet``: what to paste, in the engine's own words.
        plausible: every speed, at every phase, ok (no energy created, no sinking beyond the
            step's own overlap).
        worst_error: the largest |relative restitution error| over speeds and phases.
        per_speed: one row per speed (``velocity_m_s``, ``reference_restitution``,
            ``restitution`` (median over phases), ``restitution_min``/``_max`` (over the
            ``phases_measured`` phases that measured one: a diverged phase has none),
            ``worst_error``, ``step_overlap_ratio``, ``sinking_ratio``, ``status``).
        tried: every candidate evaluated (the trade-off figure's points).
        fallback: where nothing is plausible, ``{"timestep_s": X, "worst_error": …,
            "model": …}`` — the longest step found at which a candidate is plausible at every
            speed and phase, and its worst error there (``timestep_s`` None when none down to
            :data:`SMALLEST_STEP_S`), and ``accept``: the best worst error at the asked step
            (implausible).
    """

    engine: str
    timestep_s: float
    model: str
    params: dict[str, Any]
    snippet: str
    plausible: bool
    worst_error: float
    per_speed: list[dict[str, Any]]
    tried: list[Tried] = field(default_factory=list)
    phases: tuple[float, ...] = ()
    wall_s: float = 0.0
    engine_version: str = ""
    target: str = "hunt-crossley"
    searched_on: str = ""
    fallback: dict[str, Any] | None = None
    scenario: dict[str, Any] = field(default_factory=dict)
    stop: str = "searched"
    """``searched``: every model's scan and polish ran; else the time budget cut them."""
    note: str = ""
    """What the chosen model is and where it cannot follow (e.g. Box2D's 1 m/s threshold)."""

    def to_json(self) -> dict[str, Any]:
        """The JSON object ``impactbench advise --json`` prints."""
        return {"engine": self.engine, "timestep_s": self.timestep_s, "model": self.model,
                "params": self.params, "snippet": self.snippet, "plausible": self.plausible,
                "worst_error": self.worst_error, "per_speed": self.per_speed,
                "phases": list(self.phases), "wall_s": self.wall_s,
                "engine_version": self.engine_version, "target": self.target,
                "searched_on": self.searched_on, "fallback": self.fallback,
                "scenario": self.scenario, "stop": self.stop, "note": self.note,
                "candidates": len(self.tried)}


class _Tracked(Objective):
    """An :class:`Objective` that keeps every evaluation (the trade-off figure's points)."""

    def __post_init__(self) -> None:
        super().__post_init__()
        self.seen: list[Evaluation] = []

    def evaluate(self, values: np.ndarray, *, count_budget: bool = True) -> Evaluation:
        ev = super().evaluate(values, count_budget=count_budget)
        self.seen.append(ev)
        return ev


def _space(model: ContactModel, engine: str, timestep_s: float) -> Space:
    """A contact model as the tuner's :class:`Space` of ``custom`` runs of ``engine``."""
    params = tuple(Parameter(s.key, s.unit, s.low, s.high) for s in model.settings)
    names = [s.key for s in model.settings]

    def to_params(v: np.ndarray) -> dict[str, Any]:
        return model.params(dict(zip(names, (float(x) for x in v), strict=True)))

    def run_args(v: np.ndarray, sc: BallOnPlate, dt: float | None
                 ) -> tuple[BallOnPlate, str, RunSettings]:
        return sc, "custom", RunSettings(timestep_s=dt, params=to_params(v))

    return Space(engine, model.name, params,
                 tuple(p.clip(s.start) for p, s in zip(params, model.settings, strict=True)),
                 "custom", frozenset({"restitution"}), (), to_params,
                 lambda t: snippet(engine, t, timestep_s), run_args=run_args, linear=True)


def score(ev: Evaluation) -> float:
    """The worst |restitution error| over speeds (each at its worst phase), plus
    :data:`TIE_BREAK` × their mean, when every speed is ok and no phase rebounds faster
    than it arrived (energy created); else 2 + the share of speeds
    that are not + 0.1 × the share of runs (speeds × phases) that did not measure (a failed
    candidate ranks below any plausible one, and fewer failures rank higher)."""
    # energy created at any phase (a rebound faster than the impact) is no advice, even
    # within the plausibility rule's 1 % allowance for integration error
    bad = sum(st != "ok" or sp["restitution_max"] > 1.0
              for st, sp in zip(ev.statuses, ev.spreads, strict=True))
    if bad:
        # among failed candidates: fewer failed speeds, then fewer failed phases first
        runs = sum(sp["phases"] for sp in ev.spreads) or 1.0
        failed = 1.0 - sum(sp["measured"] for sp in ev.spreads) / runs
        return 2.0 + bad / len(ev.statuses) + 0.1 * failed
    errs = [abs(e["restitution"]) for e in ev.rel_errors]
    if not all(math.isfinite(e) for e in errs):
        return 2.0
    # ties on the worst speed (Box2D: no restitution below its 1 m/s threshold, whatever
    # is set) are broken by the mean over the speeds
    return max(errs) + TIE_BREAK * sum(errs) / len(errs)


def _raw_worst(ev: Evaluation, refs: Sequence[Mapping[str, Any]]) -> float:
    """The worst |restitution error| whatever the plausibility (NaN when a speed did not
    measure)."""
    out = 0.0
    for m, ref in zip(ev.metrics, refs, strict=True):
        e = float(m["restitution"])
        if not math.isfinite(e):
            return math.nan
        out = max(out, abs(e - float(ref["restitution"])) / abs(float(ref["restitution"])))
    return out


def _search(obj: _Tracked, space: Space, evaluations: int) -> bool:
    """Sobol scan, then Nelder–Mead on the worst error from the best points (module doc), in
    about ``evaluations`` candidates; stops quietly at the deadline. True when the deadline
    cut it short."""
    from scipy import optimize
    from scipy.stats import qmc

    dim = len(space.parameters)
    start = np.asarray(space.start, dtype=float)
    m = math.floor(math.log2(max(2, min(SCAN_PER_SETTING * dim, evaluations // 2))))
    pts = qmc.Sobol(dim, scramble=True, seed=SEED).random_base2(m)
    polish = max(dim + 2, (evaluations - len(pts) - 1) // POLISH_STARTS)
    cands = [space.candidate(start)] + [space.from_unit(u) for u in pts]
    def f(u: np.ndarray) -> float:
        return score(obj.batch([space.from_unit(np.clip(u, 0.0, 1.0))])[0])

    try:
        obj.batch(cands)
        # the landscape is rugged (the phase spread moves with every setting): polish from
        # the best scan points, each a start of its own
        ranked = sorted(obj.seen, key=score)[:POLISH_STARTS]
        for start_ev in ranked:
            u0 = space.to_unit(space.candidate(start_ev.values))
            optimize.minimize(f, u0, method="Nelder-Mead",
                              options={"maxfev": polish, "xatol": 1e-3,
                                       "fatol": 1e-4, "initial_simplex": _simplex(u0)})
    except OutOfBudget:
        return True
    return False


def _simplex(u0: np.ndarray) -> np.ndarray:
    """Nelder–Mead's first simplex: u0 and a step of 0.08 of the box along each axis, inward."""
    out = [u0]
    for i in range(len(u0)):
        u = u0.copy()
        u[i] = u[i] + 0.08 if u[i] < 0.5 else u[i] - 0.08
        out.append(u)
    return np.asarray(out)


def targets_from_csv(path: str | Path) -> tuple[tuple[float, ...], list[dict[str, float]]]:
    """A user's measured restitution against impact speed: a CSV with columns
    ``velocity_m_s`` and ``restitution`` (one row per speed) → (speeds, targets)."""
    import pandas as pd

    p = Path(path)
    if not p.is_file():
        raise ValueError(f"target = {str(path)!r}: no such file")
    try:
        df = pd.read_csv(p)
    except Exception as exc:  # any unreadable file is one line
        raise ValueError(f"target = {str(path)!r}: not a readable CSV ({exc})") from None
    for col in ("velocity_m_s", "restitution"):
        if col not in df.columns:
            raise ValueError(f"target = {str(path)!r}: missing column {col!r} (needs "
                             f"velocity_m_s and restitution)")
    if df.empty:
        raise ValueError(f"target = {str(path)!r}: has no rows")
    speeds, out = [], []
    for i, (v, e) in enumerate(zip(df.velocity_m_s, df.restitution, strict=True)):
        speeds.append(check.positive(f"target row {i + 1} velocity_m_s", float(v)))
        e = float(e)
        if not math.isfinite(e) or e <= 0.0:
            raise ValueError(f"target row {i + 1} restitution = {e!r}: must be a finite "
                             f"number > 0")
        out.append({"restitution": e})
    return tuple(speeds), out


def check_speeds(velocities_m_s: Sequence[float]) -> tuple[float, ...]:
    """Speeds (m/s): a non-empty list of positive finite numbers."""
    v = tuple(float(x) for x in velocities_m_s)
    if not v:
        raise ValueError("velocities = []: must list at least one impact speed")
    for i, x in enumerate(v):
        check.positive(f"velocities[{i}]", x)
    return v


def advise(engine: str, timestep_s: float | None = None, scenario: BallOnPlate | None = None,
           velocities_m_s: Sequence[float] = DEFAULT_VELOCITIES_M_S, *,
           target_csv: str | Path | None = None, budget_s: float = DEFAULT_BUDGET_S,
           phases: int = PHASES, fallback: bool = True, workers: int | None = 0) -> Advice:
    """The best settings for ``engine`` at ``timestep_s`` (default: its first customary step)
    for ``scenario``'s ball (default: the paper's steel ball) over ``velocities_m_s`` (module
    doc). ``workers``: where each candidate's runs execute (0: here; N local Dask worker
    processes, None one per core: each batch's runs shared out, the answer the same).
    Raises ValueError (one line) on bad input; engine trouble costs candidates."""
    from impactbench.evaluate import reference_metrics

    t0 = time.perf_counter()
    check.one_of("engine", engine, tuple(ENGINE_STEPS_S))
    dt = ENGINE_STEPS_S[engine][0] if timestep_s is None else \
        check.positive("timestep_s", timestep_s)
    budget_s = check.positive("budget_s", budget_s)
    scenario = scenario or BallOnPlate()
    if target_csv is not None:
        speeds, refs = targets_from_csv(target_csv)
        target = str(target_csv)
    else:
        speeds = check_speeds(velocities_m_s)
        refs = [reference_metrics(scenario.replace(velocity_m_s=v)) for v in speeds]
        target = "hunt-crossley"
    refs = [{**{k: math.nan for k in ("duration_s", "peak_force_n", "max_penetration_m",
                                      "energy_loss_fraction")}, **dict(r)} for r in refs]
    adapter = get_adapter(engine)  # ValueError: unknown; EngineUnavailable: not installed
    search_on = TWIN.get(engine, engine)
    if search_on != engine:
        get_adapter(search_on)
    ph = offsets(phases)
    deadline = t0 + budget_s
    if workers is not None and (isinstance(workers, bool) or int(workers) != workers
                                or workers < 0):
        raise ValueError(f"workers = {workers!r}: must be an integer >= 0 (None: one per core)")
    out = _answer(engine, search_on, dt, scenario, speeds, refs, ph, deadline, workers,
                  target, budget_s, fallback, adapter.version())
    out.wall_s = time.perf_counter() - t0
    return out


def _answer(engine: str, search_on: str, dt: float, scenario: BallOnPlate,
            speeds: Sequence[float], refs: list[dict[str, Any]], ph: tuple[float, ...],
            deadline: float, workers: int | None, target: str, budget_s: float,
            fallback: bool, version: str) -> Advice:
    """:func:`advise`'s search and answer (``workers``: :func:`_advise_at`)."""
    best_ev, best_model, tried, cut = _advise_at(engine, search_on, dt, scenario, speeds,
                                                 refs, ph, deadline, workers)
    assert best_ev is not None and best_model is not None
    space = _space(best_model, engine, dt)
    if search_on != engine:  # the answer, run in the engine itself at every speed and phase
        final = _objective(_space(best_model, engine, dt), scenario, speeds, refs, dt, ph,
                           math.inf)
        with quiet(engine):
            best_ev = final.evaluate(best_ev.values, count_budget=False)
    params = space.to_tuned(best_ev.values)
    ok = score(best_ev) < 2.0
    rows = _rows(best_ev, speeds, refs)
    text = snippet(engine, params, dt, scenario.mass_kg)
    out = Advice(engine, dt, best_model.name, params, text, ok,
                 max((r["worst_error"] for r in rows), default=math.nan), rows, tried, ph,
                 0.0, version, target, search_on,
                 scenario=scenario.to_dict(),
                 stop=f"time budget of {budget_s:g} s reached" if cut else "searched",
                 note=best_model.note)
    if not ok and fallback:
        finite = [t.worst_error for t in tried if math.isfinite(t.worst_error)]
        out.fallback = _longest_step(engine, search_on, dt, scenario, speeds, refs, ph,
                                     deadline, min(finite, default=math.nan), workers)
    return out


def _objective(space: Space, scenario: BallOnPlate, speeds: Sequence[float],
               refs: list[dict[str, Any]], dt: float, ph: tuple[float, ...],
               deadline: float) -> _Tracked:
    """The restitution-only objective of one space, at every speed and phase, every
    evaluation kept."""
    return _Tracked(space, scenario, tuple(speeds), {"restitution": 1.0}, dt,
                    deadline=deadline, references=list(refs), phases=ph)


def search_model(item: tuple) -> tuple[list[Evaluation], bool]:
    """One contact model's search (a worker's task, picklable): ``item`` is (engine, engine
    to run, model index, step, scenario, speeds, references, phases, seconds allowed,
    evaluations) → (every evaluation, whether the time cut it short). The model is rebuilt
    from its index (its functions do not pickle)."""
    (engine, search_on, index, dt, scenario, speeds, refs, ph, allowed_s, evaluations) = item
    model = models(engine, dt, scenario.mass_kg)[index]
    space = _space(model, search_on, dt)
    obj = _objective(space, scenario, speeds, refs, dt, ph, time.perf_counter() + allowed_s)
    with quiet(search_on):
        obj.evaluate(np.asarray(space.start), count_budget=False)  # at least the start
        cut = _search(obj, space, evaluations)
    return obj.seen, cut


def _in_processes(items: list[tuple], n: int) -> list[tuple[list[Evaluation], bool]]:
    """:func:`search_model` of each item on ``n`` fresh worker processes (spawned: engines
    hold no state across them); a task whose process dies gives no evaluations."""
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor
    from concurrent.futures.process import BrokenProcessPool

    out: list[tuple[list[Evaluation], bool]] = []
    with ProcessPoolExecutor(n, mp_context=multiprocessing.get_context("spawn")) as pool:
        futures = [pool.submit(search_model, item) for item in items]
        for f in futures:
            try:
                out.append(f.result())
            except BrokenProcessPool:
                out.append(([], False))
    return out


def _advise_at(engine: str, search_on: str, dt: float, scenario: BallOnPlate,
               speeds: Sequence[float], refs: list[dict[str, Any]], ph: tuple[float, ...],
               deadline: float, workers: int | None = 0, evaluations: int = EVALUATIONS
               ) -> tuple[Evaluation | None, ContactModel | None, list[Tried], bool]:
    """Search every model of ``engine`` (run on ``search_on``) at ``dt`` until ``deadline``:
    one task per model (:func:`search_model`), here one after another (``workers`` 0) or on
    that many worker processes at once (None: one per core, at most one per model), the
    remaining time shared out over the models that run one after another — (best
    evaluation, its model, all, whether the deadline cut a search short). A model's search
    is the same wherever it runs; one whose worker dies costs that model only."""
    from impactbench.cluster import available_cores

    ms = models(engine, dt, scenario.mass_kg)
    n = len(ms) if workers == 0 else min(len(ms), workers or available_cores())
    at_once = 1 if workers == 0 else n
    allowed = max(deadline - time.perf_counter(), 0.0) * at_once / len(ms)
    share = max(evaluations // len(ms), 8)
    items = [(engine, search_on, i, dt, scenario, tuple(speeds), refs, ph, allowed, share)
             for i in range(len(ms))]
    if workers == 0 or n < 2:
        found = [search_model(item) for item in items]
    else:
        found = _in_processes(items, n)
    best: tuple[float, Evaluation, ContactModel] | None = None
    tried: list[Tried] = []
    cut = False
    for model, (seen, was_cut) in zip(ms, found, strict=True):
        cut = cut or was_cut
        space = _space(model, search_on, dt)
        for ev in seen:
            s = score(ev)
            sinking = max((sp["penetration_ratio"] for sp in ev.spreads
                           if math.isfinite(sp["penetration_ratio"])), default=math.nan)
            tried.append(Tried(model.name, space.to_tuned(ev.values), _raw_worst(ev, refs),
                               sinking, s < 2.0))
            if best is None or s < best[0]:
                best = (s, ev, model)
    if best is None:
        return None, None, tried, cut
    return best[1], best[2], tried, cut


def _rows(ev: Evaluation, speeds: Sequence[float], refs: Sequence[Mapping[str, Any]]
          ) -> list[dict[str, Any]]:
    """The per-speed table of an evaluation (see :class:`Advice`)."""
    rows = []
    for i, v in enumerate(speeds):
        ref = float(refs[i]["restitution"])
        sp = ev.spreads[i]
        worst = max((abs(x - ref) / ref for x in (sp["restitution_min"], sp["restitution_max"])
                     if math.isfinite(x)), default=math.nan)
        rows.append({"velocity_m_s": float(v), "reference_restitution": ref,
                     "restitution": sp["restitution_median"],
                     "restitution_min": sp["restitution_min"],
                     "restitution_max": sp["restitution_max"], "worst_error": worst,
                     "phases_measured": int(sp["measured"]),
                     "step_overlap_ratio": sp["step_overlap_ratio"],
                     "sinking_ratio": sp["penetration_ratio"],
                     "status": ev.statuses[i].partition(":")[0]})
    return rows


def _longest_step(engine: str, search_on: str, dt: float, scenario: BallOnPlate,
                  speeds: Sequence[float], refs: list[dict[str, Any]], ph: tuple[float, ...],
                  deadline: float, accept: float, workers: int | None = 0) -> dict[str, Any]:
    """Halve the step until a candidate is plausible at every speed and phase (each step a
    search of :data:`FALLBACK_EVALUATIONS` candidates, within a quarter of what is left of
    the budget but at least 5 s): that step, its best model and worst error, and ``accept``
    (the best worst error at the asked step, implausible)."""
    step = dt / 2.0
    while step >= SMALLEST_STEP_S:
        now = time.perf_counter()
        ev, model, _, _ = _advise_at(engine, search_on, step, scenario, speeds, refs, ph,
                                     now + max((deadline - now) / 4.0, 5.0), workers,
                                     FALLBACK_EVALUATIONS)
        if ev is not None and score(ev) < 2.0:
            return {"timestep_s": step, "worst_error": _raw_worst(ev, refs),
                    "model": model.name if model else "", "accept": accept}
        step /= 2.0
    return {"timestep_s": None, "worst_error": math.nan, "model": "", "accept": accept}
