"""One comparison: an engine run and the reference for the same scenario, side by side.

The reference metrics come from the reference solvers; the engine's from
``impactbench.reference.metrics.compute`` of the engine's record (the one metrics path). Used by the
``run`` command, the report, the tuner and the gates alike.
"""

from __future__ import annotations

import math
from typing import Any

from impactbench.engines.base import RunSettings, run_safely
from impactbench.reference import metrics
from impactbench.reference.record import ImpactRecord, Status
from impactbench.reference.scenarios import BallOnPlate, RigidFlexible

Scenario = BallOnPlate | RigidFlexible

RIGID_FLEXIBLE_METRICS: tuple[str, ...] = (
    "peak_force_n",
    "pulse_width_s",
    "contact_time_s",
    "impulse_ns",
    "impacts",
)
SCENARIO_METRICS: dict[str, tuple[str, ...]] = {
    "ball-on-plate": metrics.BALL_METRICS,
    "rigid-flexible": RIGID_FLEXIBLE_METRICS,
}


def scenario_name(scenario: Scenario) -> str:
    return "ball-on-plate" if isinstance(scenario, BallOnPlate) else "rigid-flexible"


def reference_metrics(scenario: Scenario) -> dict[str, Any]:
    """The reference command's object for ``scenario`` (same keys as its ``--json``)."""
    if isinstance(scenario, BallOnPlate):
        from impactbench.reference import hunt_crossley

        return dict(hunt_crossley.solve(scenario))
    from impactbench.reference import two_dof

    ref = two_dof.solve(scenario)
    return {"status": str(ref["status"]), **{k: ref[k] for k in RIGID_FLEXIBLE_METRICS}}


def record_metrics(rec: ImpactRecord, scenario: Scenario) -> dict[str, Any]:
    """The scenario's metrics of an engine record.

    NaN where the run failed, and for metrics the adapter declares not comparable in
    ``rec.meta["not_comparable"]`` (metric → reason; e.g. a rigid contact's duration, which is
    one timestep by construction and says nothing about the physics).
    """
    names = SCENARIO_METRICS[scenario_name(scenario)]
    if rec.status not in (Status.OK, Status.MAX_TIME, Status.STRUCTURE_COLLAPSED):
        return {k: (0 if k == "impacts" else math.nan) for k in names}
    got = metrics.compute(rec)
    skip = rec.meta.get("not_comparable", {})
    return {k: (math.nan if k in skip else got[k]) for k in names}


def compare(engine: str, scenario: Scenario, mode: str,
            settings: RunSettings | None = None,
            reference: dict[str, Any] | None = None) -> tuple[dict[str, Any], ImpactRecord]:
    """Run ``engine`` on ``scenario`` and compare with the reference.

    Returns the ``run --json`` object (status, engine, engine_version, mode, timestep_s,
    wall_s, the metrics, ``reference`` and ``rel_error``) and the engine's record.
    """
    rec = run_safely(engine, scenario, mode, settings)
    ref = reference if reference is not None else reference_metrics(scenario)
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
        # an unresolved metric is reported, never compared: no relative error
        "rel_error": {k: (metrics.relative_error(float(got[k]), float(ref[k]))
                          if resolved[k] else math.nan) for k in got},
    }
    problem = (scenario.penetration_problem(float(ref.get("max_penetration_m", 0.0)))
               if isinstance(scenario, BallOnPlate) else "")
    if problem:  # the reference itself is outside its model: nothing to compare with
        out.update(status=str(Status.UNSUPPORTED), message=problem,
                   rel_error=dict.fromkeys(got, math.nan))
    return out, rec


def record_resolution(rec: ImpactRecord, scenario: Scenario) -> dict[str, bool]:
    """Per scenario metric: is it resolved in time (``impactbench.reference.metrics.resolved``;
    a step about as long as the contact leaves duration and peak force unresolved)?"""
    names = SCENARIO_METRICS[scenario_name(scenario)]
    if rec.status not in (Status.OK, Status.MAX_TIME, Status.STRUCTURE_COLLAPSED):
        return dict.fromkeys(names, True)
    flags = metrics.resolved(rec)
    return {k: flags.get(k, True) for k in names}
