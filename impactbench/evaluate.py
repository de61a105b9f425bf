"""One comparison: an engine run and the reference for the same scenario, side by side.

The reference metrics come from the reference solvers; the engine's from
``impactbench.reference.metrics.compute`` of the engine's record (the one metrics path). Used by the
``run`` command, the report, the tuner and the gates alike.
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Any

from impactbench import plausibility
from impactbench.engines.base import (
    EngineUnavailable,
    RunSettings,
    Scenario,
    get_adapter,
    run_many_safely,
    run_safely,
)
from impactbench.reference import metrics
from impactbench.reference.record import ImpactRecord, Status
from impactbench.scenarios import spec_of


def scenario_name(scenario: Scenario) -> str:
    """The registry name of a scenario object (its spec's)."""
    return spec_of(scenario).name


def reference_metrics(scenario: Scenario) -> dict[str, Any]:
    """The reference command's object for ``scenario`` (same keys as its ``--json``)."""
    return spec_of(scenario).reference_metrics(scenario)


def record_metrics(rec: ImpactRecord, scenario: Scenario) -> dict[str, Any]:
    """The scenario's metrics of an engine record.

    NaN where the run failed, and for metrics the adapter declares not comparable in
    ``rec.meta["not_comparable"]`` (metric → reason; e.g. a rigid contact's duration, which is
    one timestep by construction and says nothing about the physics).
    """
    spec = spec_of(scenario)
    names = spec.metrics
    if rec.status not in (Status.OK, Status.MAX_TIME, Status.STRUCTURE_COLLAPSED):
        return {k: (0 if k == "impacts" else math.nan) for k in names}
    got = spec.metrics_of(rec, scenario)
    skip = rec.meta.get("not_comparable", {})
    return {k: (math.nan if k in skip else got[k]) for k in names}


def compare(engine: str, scenario: Scenario, mode: str,
            settings: RunSettings | None = None,
            reference: dict[str, Any] | None = None, *, timeout_s: float | None = None,
            backstop: bool = False) -> tuple[dict[str, Any], ImpactRecord | None]:
    """Run ``engine`` on ``scenario`` and compare with the reference.

    Returns the ``run --json`` object (status, engine, engine_version, mode, timestep_s,
    wall_s, the metrics, ``reference``, ``rel_error`` and ``plausibility``, the scenario's
    measures; a run beyond the limits of :mod:`impactbench.plausibility` is ``implausible``,
    its metrics kept) and the engine's record.

    ``timeout_s``: a run still going after this many seconds is stopped (SIGALRM, this
    process's main thread; :func:`impactbench.cluster.alarm`) and reported with status
    ``timeout`` and no record; ``backstop`` adds :func:`impactbench.cluster.deadline`'s
    process exit for a run stuck in C (the CLI's lone run only).
    """
    from impactbench import cluster

    scenario, settings, step_source, ref, rec = _prepared(engine, scenario, mode, settings,
                                                          reference)
    if rec is None and timeout_s is None:  # (a caller's own alarm passes through)
        rec = run_safely(engine, scenario, mode, settings)
    elif rec is None:
        guard = cluster.deadline if backstop else cluster.alarm
        try:
            with guard(timeout_s):
                rec = run_safely(engine, scenario, mode, settings)
        except cluster.RunTimeout:
            return timed_out(engine, scenario, mode, settings, ref, timeout_s), None
    return _scored(engine, scenario, mode, settings, step_source, ref, rec), rec


def compare_many(engine: str, items: list[tuple[Scenario, str, RunSettings | None,
                                                dict[str, Any] | None]]
                 ) -> list[dict[str, Any]]:
    """:func:`compare`'s object of each ``(scenario, mode, settings, reference)`` item, the
    same objects (``wall_s`` aside): the runs go to the engine together
    (:func:`~impactbench.engines.base.run_many_safely`), so an engine that batches (MJX's
    ball: one ``vmap``) runs them in one call — a tuner's generation."""
    return [run for run, _ in compare_many_records(engine, items)]


def compare_many_records(engine: str, items: list[tuple[Scenario, str, RunSettings | None,
                                                        dict[str, Any] | None]]
                         ) -> list[tuple[dict[str, Any], ImpactRecord]]:
    """:func:`compare_many` with each run's record: ``(object, record)`` per item, as
    :func:`compare` returns them (a report's batch of runs keeps their force histories)."""
    prepared = [_prepared(engine, *item) for item in items]
    todo = [i for i, p in enumerate(prepared) if p[4] is None]
    recs = dict(zip(todo, run_many_safely(engine, [(prepared[i][0], items[i][1],
                                                    prepared[i][1]) for i in todo]),
                    strict=True))
    out = []
    for i, (p, item) in enumerate(zip(prepared, items, strict=True)):
        rec = recs.get(i, p[4])
        out.append((_scored(engine, p[0], item[1], p[1], p[2], p[3], rec), rec))
    return out


def _prepared(engine: str, scenario: Scenario, mode: str, settings: RunSettings | None,
              reference: dict[str, Any] | None) -> tuple[Scenario, RunSettings | None, str,
                                                         dict[str, Any], ImpactRecord | None]:
    """What :func:`compare` runs: (the scenario at the run's step, the settings, where the
    step came from, the reference metrics, a record when the run stops before the engine —
    tuned parameters bound to another case)."""
    spec = spec_of(scenario)
    scenario, step_source = spec.at_timestep(scenario, settings.timestep_s if settings else None)
    if step_source and settings is not None:  # the scenario's own fields now carry the step
        settings = replace(settings, timestep_s=None)
    ref = reference if reference is not None else reference_metrics(scenario)
    return scenario, settings, step_source, ref, _unbound(engine, scenario, mode, settings)


def _scored(engine: str, scenario: Scenario, mode: str, settings: RunSettings | None,
            step_source: str, ref: dict[str, Any], rec: ImpactRecord) -> dict[str, Any]:
    """:func:`compare`'s object of an engine record."""
    spec = spec_of(scenario)
    got = record_metrics(rec, scenario)
    resolved = record_resolution(rec, scenario)
    out: dict[str, Any] = {
        "status": str(rec.status),
        "message": rec.message,
        "engine": engine,
        "engine_version": rec.meta.get("engine_version", ""),
        "mode": mode,
        "timestep_s": rec.meta.get("timestep_s", settings.timestep_s if settings else None),
        "wall_s": rec.meta.get("wall_s", math.nan),
        **got,
        "not_comparable": dict(rec.meta.get("not_comparable", {})),
        "resolved": resolved,
        "params": dict(rec.meta.get("params", {})),
        "engine_defaults": dict(rec.meta.get("engine_defaults", {})),
        "reference": ref,
    }
    if step_source:
        out["timestep_source"] = step_source
    if mode == "tuned" and settings is not None and settings.tuned_for:
        out["tuned_file"] = settings.tuned_for.get("file")
    if rec.status in (Status.OK, Status.MAX_TIME, Status.STRUCTURE_COLLAPSED):
        details = spec.run_details(rec, scenario, mode)
        note = details.pop("note", "")
        out.update(details)
        if note:  # what the reader should know of these numbers (not held out)
            out["message"] = "; ".join(x for x in (out["message"], note) if x)
    # an unresolved metric is reported, never compared: no relative error
    out["rel_error"] = spec.run_errors(out, got, ref, resolved)
    if rec.status in (Status.OK, Status.MAX_TIME, Status.STRUCTURE_COLLAPSED):
        out["plausibility"] = spec.measure(scenario, rec, got)
        out = plausibility.judge(out)
    problem = spec.problem(scenario, ref)
    if problem:  # the reference itself is outside its model: nothing to compare with
        out.update(status=str(Status.UNSUPPORTED), message=problem,
                   rel_error=dict.fromkeys(got, math.nan))
    return out


def timed_out(engine: str, scenario: Scenario, mode: str, settings: RunSettings | None,
              reference: dict[str, Any], timeout_s: float) -> dict[str, Any]:
    """:func:`compare`'s object for a run stopped after ``timeout_s`` seconds: status
    ``timeout``, no numbers (NaN metrics and errors)."""
    from impactbench.cluster import first_use_s

    names = spec_of(scenario).metrics
    compile_s = first_use_s(engine)
    return {"status": "timeout",
            "message": f"no result after {timeout_s:g} s (the per-run timeout"
                       + (f", {compile_s:g} s of it for {engine}'s first-use compile"
                          if compile_s else "")
                       + "; --timeout S, or [execution] timeout_s in a config, allows longer)",
            "engine": engine, "engine_version": "", "mode": mode,
            "timestep_s": settings.timestep_s if settings else None, "wall_s": timeout_s,
            **{k: (0 if k == "impacts" else math.nan) for k in names},
            "not_comparable": {}, "resolved": dict.fromkeys(names, False), "params": {},
            "engine_defaults": {}, "reference": reference,
            "rel_error": dict.fromkeys(names, math.nan)}


def record_resolution(rec: ImpactRecord, scenario: Scenario) -> dict[str, bool]:
    """Per scenario metric: is it resolved in time (``impactbench.reference.metrics.resolved``;
    a step about as long as the contact leaves duration and peak force unresolved)?"""
    names = spec_of(scenario).metrics
    if rec.status not in (Status.OK, Status.MAX_TIME, Status.STRUCTURE_COLLAPSED):
        return dict.fromkeys(names, True)
    flags = metrics.resolved(rec)
    return {k: flags.get(k, True) for k in names}


def _unbound(engine: str, scenario: Scenario, mode: str,
             settings: RunSettings | None) -> ImpactRecord | None:
    """An ``unsupported`` record when a ``tuned`` run's parameters were fitted for another
    engine, scenario or timestep (:func:`impactbench.tuned.binding_mismatch`); None when they
    apply, when nothing is bound, or when the engine cannot run the case at all (the run
    then reports why)."""
    if mode != "tuned" or settings is None or settings.tuned_for is None:
        return None
    try:
        adapter = get_adapter(engine)
        builder = adapter.builder(scenario)
        if builder is None or mode not in adapter.modes or (builder.modes is not None
                                                            and mode not in builder.modes):
            return None
        from impactbench.tuned import binding_mismatch

        dt = settings.timestep_s or builder.timestep_s
        why = settings.tuned_for["mismatch"] if "mismatch" in settings.tuned_for else \
            binding_mismatch(settings.tuned_for, engine, scenario, dt)
        if not why:
            return None
        return ImpactRecord.failed(Status.UNSUPPORTED, why, engine=engine,
                                   engine_version=adapter.version(), mode=mode, timestep_s=dt)
    except EngineUnavailable:
        return None
