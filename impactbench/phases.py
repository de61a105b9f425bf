"""Phase-robust measurement of the head-on ball at a step not much shorter than the contact.

A discrete engine sees a contact only at its steps. The ball reaches the surface somewhere
inside a step; where — the phase φ ∈ [0, 1) of the first touch within that step — decides how
deep the ball is when the engine first sees it (φ' = 1 − φ of a step's travel, v·dt·(1 − φ)),
and so what a stiff contact does with it. Where the step is much shorter than the contact the
phase is a small shift of a resolved contact and changes nothing; where the step is as long as
the contact or longer (every engine at the steps people run: the paper's ball is in contact
for ~0.1 ms, users step at 1–17 ms) the outcome depends on it. Measured with a plain MuJoCo
script at 2 ms and 2 m/s over 12 phases: a stiff direct ``solref="-1e6 -1"`` gives e from 0.46
to 3.0, MuJoCo's default 0.115 to 0.141. One run per point cannot tell a robust setting from a
lucky one.

So at such a step (:func:`needs_phases`: dt ≥ :data:`STEP_FRACTION` of the reference
contact's duration) a run is repeated at :data:`PHASES` evenly spaced phases k/N (the
adapters' own phase, ½, among them; :attr:`impactbench.engines.base.RunSettings.phase`), and
:func:`merge` reports the median and the range over the phases, judged at the worst phase: a
phase that fails or is implausible (energy created, sinking beyond the step's overlap) makes
the whole point so. The tuner (:mod:`impactbench.tuning.objective`) and the advisor
(:mod:`impactbench.advise`) score candidates the same way, on the worst phase's error.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

PHASES = 8
"""Phases of the step each long-step run is measured at (at least 8, the issue's floor)."""

STEP_FRACTION = 0.1
"""A step of at least this fraction of the reference contact's duration is "not much shorter"
than the contact: the first touch moves by up to a tenth of the contact with the phase."""

MEASURED = ("ok", "implausible")
"""Statuses whose metrics are numbers (an implausible run measured, then failed a limit)."""

_FAILED_FIRST = ("crashed", "unavailable", "unsupported", "diverged", "tunneled", "max_time",
                 "implausible")
"""Which phase's run speaks for the point when phases disagree, worst first (then ``ok``)."""


def offsets(n: int = PHASES) -> tuple[float, ...]:
    """``n`` evenly spaced phases k/n of a step, k = 0 … n − 1 (n ≥ 1)."""
    if isinstance(n, bool) or int(n) != n or n < 1:
        raise ValueError(f"phases = {n!r}: must be an integer >= 1")
    return tuple(k / n for k in range(int(n)))


def needs_phases(timestep_s: float | None, contact_duration_s: float) -> bool:
    """True when a step ``timestep_s`` (s) is not much shorter than a contact lasting
    ``contact_duration_s`` (s): dt ≥ :data:`STEP_FRACTION` × the duration."""
    return bool(timestep_s) and timestep_s >= STEP_FRACTION * contact_duration_s


def worst(runs: Sequence[Mapping[str, Any]]) -> int:
    """Index of the phase that speaks for the point: the first with the worst status
    (:data:`_FAILED_FIRST` order), else the one whose restitution is furthest from the
    reference's (its ``rel_error``), else the first."""
    for status in _FAILED_FIRST:
        for i, run in enumerate(runs):
            if str(run.get("status")) == status:
                return i
    errors = [abs(float((r.get("rel_error") or {}).get("restitution", math.nan)))
              for r in runs]
    finite = [(e, i) for i, e in enumerate(errors) if math.isfinite(e)]
    return max(finite)[1] if finite else 0


def merge(runs: Sequence[Mapping[str, Any]], phases: Sequence[float]) -> dict[str, Any]:
    """One point's runs at ``phases`` (its run objects, :func:`impactbench.evaluate.compare`'s)
    → one run object: the worst phase's (:func:`worst`: its status, message and every
    field), with each metric and its error replaced by the median over the phases that
    measured (where the worst phase measured too), the plausibility measures the largest over
    all phases, and ``phases``: the phases, the worst one, and per metric its min, median and
    max over them."""
    import numpy as np

    if len(runs) != len(phases) or not runs:
        raise ValueError(f"runs = {len(runs)}, phases = {len(phases)}: must be equal and > 0")
    w = worst(runs)
    out = dict(runs[w])
    measured = [r for r in runs if str(r.get("status")) in MEASURED]
    spread: dict[str, list[float]] = {}
    keys = [k for k, v in runs[w].items() if isinstance(v, float | int)
            and not isinstance(v, bool) and k not in ("wall_s", "timestep_s")]
    ref = runs[w].get("reference") or {}
    for key in keys:
        if key not in ref:
            continue
        vals = [float(r[key]) for r in measured if math.isfinite(float(r.get(key, math.nan)))]
        if not vals:
            continue
        spread[key] = [min(vals), float(np.median(vals)), max(vals)]
        if str(out.get("status")) in MEASURED:
            out[key] = spread[key][1]
    if str(out.get("status")) in MEASURED and out.get("rel_error"):
        from impactbench.reference.metrics import relative_error

        # only where the worst phase compared (a metric not resolved at the step keeps NaN)
        out["rel_error"] = {k: (relative_error(float(out[k]), float(ref[k]))
                                if k in spread and k in ref and math.isfinite(float(e))
                                else e)
                            for k, e in out["rel_error"].items()}
    # the plausibility measures are the worst over every phase (the largest sinking, step
    # overlap and energy ratio), not only the speaking phase's
    measures: dict[str, float] = {}
    for r in runs:
        for k, v in (r.get("plausibility") or {}).items():
            if isinstance(v, float | int) and math.isfinite(v):
                measures[k] = max(measures.get(k, -math.inf), float(v))
    if measures:
        out["plausibility"] = {**(runs[w].get("plausibility") or {}), **measures}
    out["wall_s"] = float(sum(float(r.get("wall_s") or 0.0) for r in runs))
    out["phases"] = {"phases": [float(p) for p in phases], "worst_phase": float(phases[w]),
                     "measured": len(measured), "spread": spread}
    return out
