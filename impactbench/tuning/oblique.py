"""Fit an engine's oblique friction knobs to the rigid reference (``impactbench tune
--scenario oblique``; the knobs: :data:`impactbench.engines.oblique_tuned.SPACES`).

What ``tuned`` means for the oblique scenario: the engine's ``native`` oblique run (its native
normal contact, μ from the scenario) with its friction-related parameters replaced by values
fitted here, against the scenario's reference (the rigid Coulomb closed form unless the
scenario says ``tangential = "mindlin"``), over an angle sweep at one speed and one timestep.

Objective: J = Σ over angles (and speeds) and targets of w·e², e the signed relative error of
``tangential_restitution``, ``spin_out_rad_s`` and ``rebound_angle_deg`` (weights 1 unless
given); a run that does not end ``ok`` (or leaves a target undefined) adds :data:`FAILED`·w per
target instead. The normal restitution is not a target: it is the native normal contact's, the
same before and after (a sticking contact's rebound angle follows it, so its error there is a
floor the friction knobs cannot lower).

Search (deterministic, seeded): the start is the native values of the knobs (a ``tuned`` run
there is the ``native`` run, evaluated as such too); the categorical knobs' combinations are
searched in turn (the start's first), each with a scrambled Sobol scan (seed
:data:`SEED` + the combination's index) of the continuous knobs' box in unit coordinates
(log or linear per knob) and a bounded Nelder–Mead (scipy) from the best point seen; the
evaluation budget ``max_evals`` (one evaluation = one run per angle) is shared out evenly. That
is the one tuner's ``nelder_mead`` method (:func:`impactbench.tuning.search.nelder_mead`) on
:func:`knob_space`, with :class:`Sweep` as its batch objective (a scan, a simplex: one batch).
The result is the best evaluation seen — among those within :data:`TIE_RTOL` of the best
objective, the one closest to the start — so the fit is never worse than its start.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from impactbench.engines import oblique_tuned
from impactbench.engines.base import RunSettings, get_adapter, run_safely
from impactbench.engines.knobs import Knob
from impactbench.reference import validation as check
from impactbench.reference.record import Status
from impactbench.tuning import search

TARGETS: tuple[str, ...] = ("tangential_restitution", "spin_out_rad_s", "rebound_angle_deg")
SHOWN: tuple[str, ...] = (*TARGETS, "restitution")
"""The metrics of the residual table: the targets and the normal restitution (not fitted)."""
DEFAULT_ANGLES_DEG: tuple[float, ...] = (20.0, 45.0, 60.0, 80.0)
"""The default report's ``[oblique]`` angles: three sticking, one sliding (threshold 63.9°)."""
DEFAULT_VELOCITY_M_S = 2.0
DEFAULT_MAX_EVALS = 150
"""Evaluations (the start included), shared by the categorical combinations: two or three
continuous knobs settle in 40–70 Nelder–Mead steps."""
SEED = 20240607
FAILED = 1e3
"""A failed run's contribution to J per target (times its weight)."""
SIMPLEX_STEP = 0.25
"""Nelder–Mead's initial simplex: this far along each unit coordinate (reflected inside)."""
SCAN_MAX = 16
TIE_RTOL = 1e-6
"""Evaluations within this relative distance of the best objective are equally good (the
float32 engines' rounding): the one closest to the start (fewest categorical changes, then
the shortest unit-coordinate distance) is the result, so a knob the objective does not see
stays native."""
OPTIMIZER = ("categorical knobs enumerated; per combination a scrambled Sobol scan (seeded) of "
             "the continuous knobs' box (log or linear unit coordinates) and a bounded scipy "
             "Nelder-Mead from the best point seen; the best evaluation is kept")
OBJECTIVE = ("sum over angles and targets of weight * relative_error^2 (a failed run: "
             f"{FAILED:g} * weight per target)")


@dataclass
class Evaluation:
    """The runs of one parameter set at every point of the sweep."""

    parameters: dict[str, Any]
    objective: float
    statuses: list[str]
    metrics: list[dict[str, float]]
    rel_errors: list[dict[str, float]]

    def max_abs_error(self, key: str) -> float:
        """max over the sweep of |relative error| of ``key`` (NaN if any is undefined)."""
        vals = [abs(e.get(key, math.nan)) for e in self.rel_errors]
        return max(vals) if vals and all(math.isfinite(v) for v in vals) else math.nan


@dataclass
class ObliqueFit:
    """The outcome of :func:`fit` (what the tuned file and the CLI report)."""

    engine: str
    engine_version: str
    scenario: Any
    angles_deg: tuple[float, ...]
    velocities_m_s: tuple[float, ...]
    timestep_s: float
    weights: dict[str, float]
    knobs: tuple[Knob, ...]
    references: list[dict[str, Any]]
    native: Evaluation
    start: Evaluation
    tuned: Evaluation
    evaluations: int
    budget: int
    seed: int
    stop: str
    wall_s: float
    stages: list[str] = field(default_factory=list)

    @property
    def points(self) -> list[tuple[float, float]]:
        """(velocity, angle) of every run of an evaluation, in order."""
        return points(self.velocities_m_s, self.angles_deg)

    @property
    def parameters(self) -> dict[str, Any]:
        return dict(self.tuned.parameters)

    @property
    def start_parameters(self) -> dict[str, Any]:
        return dict(self.start.parameters)


def points(velocities: Sequence[float], angles: Sequence[float]) -> list[tuple[float, float]]:
    return [(float(v), float(a)) for v in velocities for a in angles]


def check_angles(angles: Sequence[float]) -> tuple[float, ...]:
    """The sweep's angles (one-line ValueError: empty, repeated, outside (0, 90) degrees)."""
    out = tuple(float(a) for a in angles)
    if not out:
        raise ValueError("angles = []: must list at least one incidence angle (degrees)")
    for a in out:
        if not (math.isfinite(a) and 0.0 < a < 90.0):
            raise ValueError(f"angles = {a!r}: each must be in (0, 90) degrees (at 0° the "
                             "tangential restitution is undefined)")
    if len(set(out)) != len(out):
        raise ValueError(f"angles = {list(out)}: each angle once")
    return out


def check_weights(weights: Sequence[float] | None) -> dict[str, float]:
    """{target: weight} (default all 1; one-line ValueError: count, sign, all zero)."""
    if weights is None:
        return dict.fromkeys(TARGETS, 1.0)
    if len(weights) != len(TARGETS):
        raise ValueError(f"weights = {list(weights)}: must give {len(TARGETS)} weights, one per "
                         f"target ({', '.join(TARGETS)})")
    out = {k: check.non_negative(f"weights.{k}", float(w))
           for k, w in zip(TARGETS, weights, strict=True)}
    if not any(w > 0 for w in out.values()):
        raise ValueError(f"weights = {list(weights)}: at least one must be > 0")
    return out


def evaluate(engine: str, scenario: Any, pts: list[tuple[float, float]], dt: float,
             references: list[dict[str, Any]], weights: dict[str, float], mode: str,
             parameters: dict[str, Any]) -> Evaluation:
    """Run ``engine`` in ``mode`` (``tuned`` with ``parameters``, or ``native``) at every
    (velocity, angle) of ``pts`` and score it (module doc)."""
    return evaluate_many(engine, scenario, pts, dt, references, weights, mode,
                         [parameters])[0]


def evaluate_many(engine: str, scenario: Any, pts: list[tuple[float, float]], dt: float,
                  references: list[dict[str, Any]], weights: dict[str, float], mode: str,
                  candidates: Sequence[dict[str, Any]]) -> list[Evaluation]:
    """:func:`evaluate` of each candidate, every run of them all handed to the engine at
    once (:func:`impactbench.evaluate.compare_many`: an engine whose oblique builder batches
    runs them in one call; the same objects as one by one)."""
    from impactbench.evaluate import compare_many

    items = [(scenario.replace(angle_deg=a, velocity_m_s=v), mode,
              RunSettings(timestep_s=dt, tuned=dict(c) if mode == "tuned" else None), ref)
             for c in candidates for (v, a), ref in zip(pts, references, strict=True)]
    with np.errstate(all="ignore"):
        outs = compare_many(engine, items)
    n = len(pts)
    return [_scored(c, outs[i * n:(i + 1) * n], weights) for i, c in enumerate(candidates)]


def _scored(parameters: dict[str, Any], outs: list[dict[str, Any]],
            weights: dict[str, float]) -> Evaluation:
    """The :class:`Evaluation` of one candidate's runs (module doc's objective)."""
    statuses, got, errs = [], [], []
    total = 0.0
    for out in outs:
        statuses.append(str(out["status"]))
        got.append({k: float(out.get(k, math.nan)) for k in SHOWN})
        rel = {k: float(out["rel_error"].get(k, math.nan)) for k in SHOWN}
        errs.append(rel)
        for k, w in weights.items():
            e = rel[k]
            ok = out["status"] == "ok" and math.isfinite(e)
            total += w * (e * e if ok else FAILED)
    return Evaluation(dict(parameters), total, statuses, got, errs)


def fit(engine: str, scenario: Any = None, angles_deg: Sequence[float] | None = None,
        velocities_m_s: Sequence[float] | None = None, *, timestep_s: float | None = None,
        weights: Sequence[float] | None = None, max_evals: int | None = None,
        seed: int = SEED, progress: Callable[[int, int, float, float], None] | None = None
        ) -> ObliqueFit:
    """Fit ``engine``'s oblique friction knobs (module doc).

    Args:
        engine: an engine with an oblique space (:data:`~impactbench.engines.oblique_tuned.
            SPACES`) whose adapter runs oblique ``tuned``.
        scenario: the oblique impact (default: the paper's steel ball, μ 0.3); its angle and
            speed are replaced by the sweep's.
        angles_deg: incidence angles (default :data:`DEFAULT_ANGLES_DEG`), in (0, 90).
        velocities_m_s: impact speeds (default :data:`DEFAULT_VELOCITY_M_S`).
        timestep_s: the step (default the adapter's oblique step, 1e-6 s).
        weights: one per target (:data:`TARGETS`; default 1).
        max_evals: evaluations, the start included (default :data:`DEFAULT_MAX_EVALS`).
        seed: the Sobol scan's seed.
        progress: called after each evaluation with (done, budget, J, best J).

    Raises ValueError (one line) on bad input; engine trouble becomes failed runs, and a start
    the engine refuses (no oblique ``tuned`` in its adapter) a ValueError with its reason.
    """
    from impactbench.evaluate import reference_metrics
    from impactbench.reference.oblique_scenario import Oblique

    t0 = time.perf_counter()
    knobs = oblique_tuned.knobs(engine)
    scenario = scenario if scenario is not None else Oblique()
    if not isinstance(scenario, Oblique):
        raise ValueError(f"scenario = {scenario!r}: must be an Oblique")
    angles = check_angles(DEFAULT_ANGLES_DEG if angles_deg is None else angles_deg)
    speeds = tuple(float(check.positive("velocities", v)) for v in (
        (DEFAULT_VELOCITY_M_S,) if velocities_m_s is None else velocities_m_s))
    if not speeds:
        raise ValueError("velocities = []: must list at least one impact speed")
    budget = DEFAULT_MAX_EVALS if max_evals is None else max_evals
    if isinstance(budget, bool) or not isinstance(budget, int) or budget < 1:
        raise ValueError(f"max_evals = {budget!r}: must be an integer >= 1 (evaluations, the "
                         "start included)")
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise ValueError(f"seed = {seed!r}: must be an integer >= 0")
    w = check_weights(weights)
    adapter = get_adapter(engine)
    builder = adapter.builder(scenario)
    if builder is None:
        raise ValueError(f"engine = {engine!r}: has no oblique builder")
    dt = float(check.positive("timestep", timestep_s) if timestep_s is not None
               else builder.timestep_s)
    pts = points(speeds, angles)
    refs = [reference_metrics(scenario.replace(angle_deg=a, velocity_m_s=v)) for v, a in pts]
    start = oblique_tuned.start_values(engine, scenario, dt)
    space = knob_space(knobs, scenario, dt)
    probe = run_safely(engine, scenario.replace(angle_deg=pts[0][1], velocity_m_s=pts[0][0]),
                       "tuned", RunSettings(timestep_s=dt, tuned=dict(start)))
    if probe.status is Status.UNSUPPORTED:  # before any output: the adapter is not wired
        raise ValueError(f"engine = {engine!r}: its oblique tuned mode does not run "
                         f"({probe.message})")
    native = evaluate(engine, scenario, pts, dt, refs, w, "native", {})
    sweep = Sweep(engine, scenario, pts, dt, refs, w)
    tracker = search.Tracker(sweep, max_evals=budget, dedupe=True, progress=progress)
    outcome = search.nelder_mead(space, tracker, seed=seed, scan_max=SCAN_MAX,
                                 simplex_step=SIMPLEX_STEP)
    first = sweep.evaluations[search.candidate_key(start)]  # the native values through tuned
    stages = [f"start (native values through tuned mode): J = {first.objective:.6g}; native "
              f"run: J = {native.objective:.6g}", *outcome.stages]
    best = _closest_of_best(list(sweep.evaluations.values()), space)
    return ObliqueFit(engine, adapter.version(), scenario, angles, speeds, dt, w, knobs, refs,
                      native, first, best, tracker.evaluations, budget, seed, outcome.stop,
                      time.perf_counter() - t0, stages)


def knob_space(knobs: Sequence[Knob], scenario: Any, dt: float) -> search.KnobSpace:
    """The one tuner's space of the oblique knobs for ``scenario`` at step ``dt``: each knob's
    absolute box and its start (the native run's value)."""
    return search.KnobSpace(tuple(k.resolve(scenario, dt) for k in knobs))


@dataclass
class Sweep:
    """The fit's batch objective (:class:`~impactbench.tuning.search.BatchObjective`): each
    candidate (knob key → value) run in ``tuned`` mode at every point of the sweep, the whole
    batch's runs handed to the engine at once (:func:`evaluate_many`), and scored; every
    :class:`Evaluation` kept by its candidate, in evaluation order."""

    engine: str
    scenario: Any
    pts: list[tuple[float, float]]
    dt: float
    references: list[dict[str, Any]]
    weights: dict[str, float]
    evaluations: dict[tuple, Evaluation] = field(default_factory=dict)

    def evaluate_batch(self, candidates: Sequence[dict[str, Any]]) -> list[float]:
        evs = evaluate_many(self.engine, self.scenario, self.pts, self.dt, self.references,
                            self.weights, "tuned", [dict(c) for c in candidates])
        for c, ev in zip(candidates, evs, strict=True):
            self.evaluations[search.candidate_key(c)] = ev
        return [ev.objective for ev in evs]


def _closest_of_best(evals: list[Evaluation], space: search.KnobSpace) -> Evaluation:
    """The evaluation closest to the start among those within :data:`TIE_RTOL` of the best
    objective (categorical changes first, then the unit-coordinate distance)."""
    low = min(ev.objective for ev in evals)
    tied = [ev for ev in evals if ev.objective <= low + TIE_RTOL * abs(low)]
    start = space.start_candidate

    def distance(ev: Evaluation) -> tuple[int, float]:
        changed = sum(ev.parameters[k.name] != start[k.name] for k in space.categorical)
        far = sum((k.to_unit(float(ev.parameters[k.name])) - k.to_unit(float(start[k.name])))
                  ** 2 for k in space.continuous)
        return changed, far

    return min(tied, key=distance)


# ------------------------------------------------------------------------------ output


def residual_rows(result: ObliqueFit) -> list[dict[str, Any]]:
    """Per point and metric (targets, then the normal restitution): the reference, native and
    tuned values and relative errors."""
    rows = []
    for i, (v, a) in enumerate(result.points):
        for k in SHOWN:
            rows.append({"angle_deg": a, "velocity_m_s": v, "metric": k,
                         "weight": result.weights.get(k, 0.0),
                         "reference": float(result.references[i][k]),
                         "native": result.native.metrics[i][k],
                         "native_rel_error": result.native.rel_errors[i][k],
                         "tuned": result.tuned.metrics[i][k],
                         "tuned_rel_error": result.tuned.rel_errors[i][k]})
    return rows


def summary_rows(result: ObliqueFit) -> list[dict[str, Any]]:
    """Per metric: the worst |relative error| over the sweep, native and tuned."""
    return [{"metric": k, "weight": result.weights.get(k, 0.0),
             "native_max_abs_rel_error": result.native.max_abs_error(k),
             "tuned_max_abs_rel_error": result.tuned.max_abs_error(k)} for k in SHOWN]


def parameter_rows(result: ObliqueFit) -> list[dict[str, Any]]:
    """Per knob: the native (start) and tuned value and the searched space."""
    s, dt = result.scenario, result.timestep_s
    return [{"key": k.name, "native": result.start.parameters[k.name],
             "tuned": result.tuned.parameters[k.name], "space": k.summary(s, dt)}
            for k in result.knobs]


def notes(result: ObliqueFit) -> list[str]:
    """What the fit cannot change, in lines."""
    return ["the normal contact is native's in both runs (restitution not fitted): a sticking "
            "contact's rebound angle follows its restitution, so that part of the rebound-angle "
            "error is a floor for any friction setting"]


def tables(result: ObliqueFit) -> dict[str, dict[str, Any]]:
    """The tuned file's tables: ``parameters`` (the engine's keys), ``start`` (native's values),
    ``space`` (each knob's scale, bounds, start and meaning), ``provenance`` (bound: engine,
    scenario, timestep and the scenario's fields but its axes, angle and speed) and
    ``residuals``. No date or wall time: the same fit writes the same bytes."""
    s = result.scenario
    axes = {"angle_deg", "velocity_m_s"}
    prov: dict[str, Any] = {
        "engine": result.engine,
        "engine_version": result.engine_version,
        "scenario": s.name,
        "mode": "tuned",
        "reference": s.tangential,
        "timestep_s": result.timestep_s,
        "angles_deg": list(result.angles_deg),
        "velocities_m_s": list(result.velocities_m_s),
        "friction": s.friction,
        "targets": list(result.weights),
        "weights": list(result.weights.values()),
        "objective": OBJECTIVE,
        "objective_native": result.native.objective,
        "objective_start": result.start.objective,
        "objective_tuned": result.tuned.objective,
        "optimizer": OPTIMIZER,
        "budget": result.budget,
        "evaluations": result.evaluations,
        "runs_per_evaluation": len(result.points),
        "seed": result.seed,
        "stop": result.stop,
        **{f"max_abs_rel_error_{k}_{which}": getattr(result, which).max_abs_error(k)
           for k in SHOWN for which in ("native", "tuned")},
        "notes": notes(result),
        **{f"scenario_{k}": v for k, v in s.to_dict().items()
           if k not in axes and v is not None},  # TOML has no null
    }
    res: dict[str, Any] = {"angles_deg": [a for _, a in result.points],
                           "velocities_m_s": [v for v, _ in result.points],
                           "statuses_native": list(result.native.statuses),
                           "statuses_tuned": list(result.tuned.statuses)}
    for k in SHOWN:
        res[f"{k}_reference"] = [float(r[k]) for r in result.references]
        res[f"{k}_native"] = [m[k] for m in result.native.metrics]
        res[f"{k}_rel_error_native"] = [e[k] for e in result.native.rel_errors]
        res[f"{k}_tuned"] = [m[k] for m in result.tuned.metrics]
        res[f"{k}_rel_error_tuned"] = [e[k] for e in result.tuned.rel_errors]
    space = {k.name: k.summary(s, result.timestep_s) for k in result.knobs}
    return {"parameters": result.parameters, "start": result.start_parameters, "space": space,
            "provenance": prov, "residuals": res}


def write(result: ObliqueFit, path: Path | str) -> Path:
    """Write the tuned file (:func:`tables`) that ``run --scenario oblique --mode tuned``
    reads."""
    from impactbench.tuned import write_tuned

    header = (f"impactbench tune --scenario oblique: {result.engine}'s friction knobs fitted to "
              f"the {result.scenario.tangential} reference over angles "
              f"{', '.join(f'{a:g}' for a in result.angles_deg)} deg at "
              f"{', '.join(f'{v:g}' for v in result.velocities_m_s)} m/s, "
              f"mu = {result.scenario.friction:g}, dt = {result.timestep_s:g} s.\n"
              "Read by `impactbench run --scenario oblique --mode tuned`; [parameters] uses the "
              "engine's own keys, the normal contact stays native.")
    return write_tuned(path, tables(result), header)


def as_json(result: ObliqueFit, files: dict[str, str] | None = None) -> dict[str, Any]:
    """Everything the CLI's ``--json`` prints."""
    t = tables(result)
    return {"engine": result.engine, "engine_version": result.engine_version,
            "scenario": result.scenario.name, "timestep_s": result.timestep_s,
            "angles_deg": list(result.angles_deg),
            "velocities_m_s": list(result.velocities_m_s),
            "friction": result.scenario.friction, "reference": result.scenario.tangential,
            "targets": list(result.weights), "weights": list(result.weights.values()),
            "objective": OBJECTIVE, "objective_native": result.native.objective,
            "objective_start": result.start.objective,
            "objective_tuned": result.tuned.objective,
            "parameters": t["parameters"], "start_parameters": t["start"],
            "space": t["space"], "optimizer": OPTIMIZER, "budget": result.budget,
            "evaluations": result.evaluations, "seed": result.seed, "stop": result.stop,
            "stages": list(result.stages), "wall_s": result.wall_s,
            "summary": summary_rows(result), "residuals": residual_rows(result),
            "notes": notes(result), "files": files or {}}


__all__ = ["DEFAULT_ANGLES_DEG", "DEFAULT_MAX_EVALS", "DEFAULT_VELOCITY_M_S", "FAILED",
           "SEED", "TARGETS", "Evaluation", "ObliqueFit", "as_json", "check_angles",
           "check_weights", "evaluate", "fit", "notes", "parameter_rows", "residual_rows",
           "summary_rows", "tables", "write"]
