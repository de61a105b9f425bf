"""Is a run physically plausible? Penetration relative to the ball's radius, and energy.

An engine can reproduce a restitution while its contact is absurd: a ball buried ten radii
deep in the plate for 100 ms bounces back at the right speed. Such a setting would wreck a
simulation that uses it (the ball visibly sinks, a robot foot stands inside the floor), so a
run beyond a limit is not ``ok``: its status is ``implausible`` (its metrics are kept, so the
tables can show what happened), which the tables, the scoreboard, the gates and tuning honour.

Each scenario measures (its spec's ``plausibility`` function, from the record and metrics):

- ``penetration_ratio``: how far the contact lets the ball sink, over its radius: the largest
  overlap in a contact beyond the step's own (below). The contact laws are
  small-indentation laws: Hertz's theory assumes a contact radius a = √(R·x) much smaller
  than R, and at x = 0.1·R it is already 0.32·R; past that the geometry the law describes
  is gone (and an engine's ball sinking by more than a tenth of its radius is visible in any
  rendering). Default limit **0.1** (10 % of the radius). The paper's steel ball at 5 m/s
  indents 114 µm, 0.8 % of its radius.
- ``step_overlap_ratio``: the step's own overlap, over the radius — reported, never judged.
  A discrete engine sees a contact only at a step: a ball arriving at speed v from a gap
  x_k ≤ 0 moves to x_k + (v + g·dt)·dt in one (semi-implicit Euler) step, so it may cross
  the surface by up to v·dt + g·dt² before any contact can act. An ideal rigid contact at
  that step stops it there: that overlap is the step's, whatever the contact (at 1/240 s
  and 2 m/s, 8.3 mm, 0.57 of the paper's ball), and only what lies beyond it is the
  contact's sinking (:func:`overlaps`). At the paper's 1 µs step the allowance is 2 µm at
  2 m/s, so there nearly all of an overlap is the contact's.
- ``energy_ratio``: kinetic energy after the impact over before (the ball: e²; a body on a
  flexible structure: body 1's). A passive contact cannot create energy; integration error
  may, a little. Default limit **1.01** (1 % created, the adapters' own divergence rule,
  :data:`impactbench.engines.common.ENERGY_GAIN_LIMIT`).

The limits are :class:`Limits`; a report config's ``[plausibility]`` table changes them, and a
run is judged again whenever it is read (a stored run keeps its measures, not its verdict).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

IMPLAUSIBLE = "implausible"
OK = "ok"
MAX_TIME = "max_time"


@dataclass(frozen=True)
class Limits:
    """The plausibility limits (dimensionless).

    Attributes:
        max_penetration_ratio: the largest overlap over the ball's radius (x_max/R).
        max_energy_ratio: the largest kinetic energy after the impact over before.
    """

    max_penetration_ratio: float = 0.1
    max_energy_ratio: float = 1.01

    def __post_init__(self) -> None:
        from impactbench.reference import validation as check

        check.positive("max_penetration_ratio", self.max_penetration_ratio)
        if not (math.isfinite(self.max_energy_ratio) and self.max_energy_ratio >= 1.0):
            raise ValueError(f"max_energy_ratio = {self.max_energy_ratio!r}: must be >= 1 "
                             "(a passive contact cannot create energy)")


DEFAULT = Limits()


def overlaps(rec: Any, timestep_s: float, gravity_m_s2: float = 0.0) -> tuple[float, float]:
    """(the step's own overlap, the contact's sinking) of a record (m, each ≥ 0; NaN for an
    empty one): over each contact (a run of samples with force F > 0, and the sample after
    it), the part of its deepest overlap within one step's travel at the speed it arrived
    with, v·dt + g·dt² (the module's rule), and the part beyond it; the largest of each."""
    import numpy as np

    x, v, f = rec.penetration_m, rec.penetration_rate_m_s, rec.normal_force_n
    if not len(x):
        return math.nan, math.nan
    edges = np.flatnonzero(np.diff(np.concatenate(([0], (f > 0.0).astype(np.int8), [0]))))
    step = sink = 0.0
    for start, stop in zip(edges[::2].tolist(), edges[1::2].tolist(), strict=True):
        arrived = max(float(v[start - 1] if start else v[0]), 0.0)
        allowance = arrived * timestep_s + gravity_m_s2 * timestep_s * timestep_s
        deepest = float(x[start:stop + 1].max())
        step = max(step, min(deepest, allowance))
        sink = max(sink, deepest - allowance)
    return step, sink


def overlap_measures(rec: Any, radius_m: float, gravity_m_s2: float = 0.0
                     ) -> dict[str, float]:
    """``penetration_ratio`` (the contact's sinking) and ``step_overlap_ratio`` (the step's
    own overlap), over the radius, of a record at its step (``meta["timestep_s"]``)."""
    dt = float(rec.meta.get("timestep_s") or 0.0)
    step, sink = overlaps(rec, dt, gravity_m_s2)
    return {"penetration_ratio": sink / radius_m, "step_overlap_ratio": step / radius_m}


def problems(measures: dict[str, float], limits: Limits = DEFAULT) -> list[str]:
    """What is beyond the limits, in words ([] when nothing is)."""
    out = []
    p = measures.get("penetration_ratio", math.nan)
    if math.isfinite(p) and p > limits.max_penetration_ratio:
        step = measures.get("step_overlap_ratio", math.nan)
        beyond = (f" beyond the step's own overlap ({step:.3g})" if math.isfinite(step)
                  and step > 0.0 else "")
        out.append(f"penetration {p:.3g} of its radius{beyond} (limit "
                   f"{limits.max_penetration_ratio:g})")
    e = measures.get("energy_ratio", math.nan)
    if math.isfinite(e) and e > limits.max_energy_ratio:
        out.append(f"kinetic energy ×{e:.4g} after the impact (limit ×"
                   f"{limits.max_energy_ratio:g}): energy created")
    return out


def judge(run: dict[str, Any], limits: Limits = DEFAULT) -> dict[str, Any]:
    """``run`` (a comparison object with its ``plausibility`` measures) with its status set
    from the limits: an ``ok`` run beyond them becomes ``implausible`` (the message says
    why), an ``implausible`` one within them ``ok`` again. A ``max_time`` run (still moving
    at the cap: a ball still bouncing) that created energy becomes ``implausible`` too (and
    ``max_time`` again within the limits: ``judged_from`` keeps what it was). Other statuses
    are kept."""
    status = run.get("status")
    if status == MAX_TIME:  # still moving at the cap: created energy is the worse verdict
        created = [w for w in problems(run.get("plausibility") or {}, limits)
                   if "energy created" in w]
        if not created:
            return run
        return {**run, "status": IMPLAUSIBLE, "message": "; ".join([*created, run["message"]]),
                "judged_from": [MAX_TIME, run.get("message", "")]}
    if status not in (OK, IMPLAUSIBLE):
        return run
    why = problems(run.get("plausibility") or {}, limits)
    if why:
        return {**run, "status": IMPLAUSIBLE, "message": "; ".join(why)}
    if status == IMPLAUSIBLE:
        before, message = run.get("judged_from") or (OK, "")
        out = {k: v for k, v in run.items() if k != "judged_from"}
        return judge({**out, "status": before, "message": message}, limits) \
            if before == MAX_TIME else {**out, "status": OK, "message": ""}
    return run
