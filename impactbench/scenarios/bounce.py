"""The bounce-to-rest scenario: the ball dropped on the plate, followed until it rests.

Physics: :class:`~impactbench.reference.bounce_scenario.Bounce` (the head-on ball's
Hunt–Crossley contact, gravity throughout); reference: :mod:`impactbench.reference.bounce`
(exact flights, every contact integrated with gravity). One point per drop height h (m).

What is measured, alike from the reference and from every engine's record
(:func:`bounces_of`): the apex of every flight after the first impact (the largest gap
max(−x) between two contacts), the impact and rebound speeds around each contact, the number
of bounces whose apex exceeds 1 mm and when the last of them left the plate; then, where the
ball came to rest (:mod:`impactbench.engines.bounce`), its mean overlap over the last
0.1 s against the static sink (m·g/c)^(1/n) and the largest speed there (the jitter).
Where and why the engine stopped bouncing is said in ``stop_reason``: at a restitution
velocity threshold the engine reports, or by its contact's own losses. An apex above the
one before it (or the first above the drop) is energy created: ``energy_ratio`` over 1, so
the run is ``implausible``, never ``ok``.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from functools import lru_cache
from typing import Any

import numpy as np

from impactbench.scenarios.spec import Axis, Flag, ScenarioSpec

NAME = "bounce"

METRICS = ("first_apex_m", "bounces_above_1mm", "last_bounce_time_s", "rest_sink_m",
           "rest_jitter_m_s")
"""Scalar metrics of a results row (the sequences are in the run object)."""

APEX_COUNT_M = 1e-3
"""The apex a bounce must exceed to count (m; the reference's ``APEX_COUNT_M``)."""
SETTLE_S = 0.1
"""The window at rest the sinking and jitter are read over (s; the engines' ``SETTLE_S``)."""

FLAGS = (
    Flag("height", "height_m", "drop height h: the ball's lowest point above the plate at "
         "release, from rest (m)"),
    Flag("mass", "mass_kg", "ball mass (kg)"),
    Flag("stiffness", "stiffness", "Hunt–Crossley stiffness c (N/m^n)"),
    Flag("exponent", "exponent", "force-law exponent n (1.5 Hertz)"),
    Flag("damping", "damping_s_per_m", "Hunt–Crossley damping b (s/m)"),
    Flag("radius", "radius_m", "ball radius R (m)"),
    Flag("gravity", "gravity_m_s2", "gravity g (m/s², > 0)"),
    Flag("max-time", "max_time_s", "time cap (s): a ball still moving then is max_time"),
)


@dataclass
class Bounces:
    """The bounces read from one record (SI; ``apex_heights_m[k]`` after contact k)."""

    apex_heights_m: list[float]
    impact_speeds_m_s: list[float]
    rebound_speeds_m_s: list[float]
    leave_times_s: list[float]

    @property
    def above(self) -> list[int]:
        return [k for k, a in enumerate(self.apex_heights_m) if a > APEX_COUNT_M]


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """[start, stop) index ranges of the True runs of ``mask``."""
    edges = np.flatnonzero(np.diff(np.concatenate(([0], mask.astype(np.int8), [0]))))
    return list(zip(edges[::2].tolist(), edges[1::2].tolist(), strict=True))


def bounces_of(rec: Any) -> Bounces:
    """The flights between contacts of an engine record (contact: the engine reports a
    force, F > 0). Each flight that ends in a contact gives an apex max(−x), the speed the
    ball left with (−ẋ at its first sample) and arrived with (ẋ at its last), and when it
    left (s). The fall before the first contact and a flight cut by the end are not bounces."""
    force = rec.normal_force_n
    contacts = _runs(force > 0.0)
    out = Bounces([], [], [], [])
    if not contacts:
        return out
    x, v, t = rec.penetration_m, rec.penetration_rate_m_s, rec.time_s
    out.impact_speeds_m_s.append(float(v[contacts[0][0] - 1]) if contacts[0][0] else
                                 float(v[0]))
    for (_, stop), (start, _) in itertools.pairwise(contacts):
        out.apex_heights_m.append(float(np.max(-x[stop:start])))
        out.rebound_speeds_m_s.append(float(-v[stop]))
        out.leave_times_s.append(float(t[stop]))
        out.impact_speeds_m_s.append(float(v[start - 1]))
    return out


def metrics_of_record(rec: Any) -> dict[str, Any]:
    """The scenario's metrics and sequences of an engine record (see the module)."""
    b = bounces_of(rec)
    above = b.above
    settled = bool(rec.meta.get("settled", False)) and len(rec) > 0
    if settled:
        window = rec.time_s >= rec.time_s[-1] - SETTLE_S
        sink = float(np.mean(rec.penetration_m[window]))
        jitter = float(np.max(np.abs(rec.penetration_rate_m_s[window])))
    else:
        sink = jitter = math.nan
    return {
        "first_apex_m": b.apex_heights_m[0] if b.apex_heights_m else 0.0,
        "bounces_above_1mm": len(above),
        "last_bounce_time_s": b.leave_times_s[above[-1]] if above else math.nan,
        "rest_sink_m": sink,
        "rest_jitter_m_s": jitter,
        "apex_heights_m": b.apex_heights_m,
        "impact_speeds_m_s": b.impact_speeds_m_s,
        "rebound_speeds_m_s": b.rebound_speeds_m_s,
    }


def stop_reason(rec: Any, b: Bounces) -> str:
    """Where the engine stopped bouncing (above 1 mm) and why, in words."""
    n = len(b.above)
    if not b.impact_speeds_m_s:
        return "no contact"
    last = b.impact_speeds_m_s[min(len(b.impact_speeds_m_s) - 1, n + 1)] \
        if len(b.impact_speeds_m_s) > n + 1 else b.impact_speeds_m_s[-1]
    where = f"after {n} bounce{'s' if n != 1 else ''} above 1 mm"
    threshold = rec.meta.get("bounce_threshold_m_s")
    if threshold is not None and math.isfinite(float(threshold)) and last < float(threshold):
        return (f"{where}: the next impact, at {last:.3g} m/s, is below the engine's "
                f"restitution threshold {float(threshold):g} m/s (no bounce below it)")
    if not rec.meta.get("settled", False):
        return f"{where}; still moving at the time cap"
    return f"{where}: its contact's own losses (next impact at {last:.3g} m/s)"


@lru_cache(maxsize=64)
def _reference(scenario: Any) -> dict[str, Any]:
    from impactbench.reference import bounce

    return bounce.metrics(scenario)


@dataclass(frozen=True)
class BounceSpec(ScenarioSpec):
    """The bounce to rest: its dataclass, the reference sequence, the bounces of a record,
    plausibility (overlap over R, the largest apex growth) and the ball's tuned files."""

    @property
    def cls(self) -> type:
        from impactbench.reference.bounce_scenario import Bounce

        return Bounce

    def reference_metrics(self, scenario: Any) -> dict[str, Any]:
        """The reference's ``reference bounce --json`` object (cached per scenario: ~1 s)."""
        return dict(_reference(scenario))

    def metrics_of(self, record: Any, scenario: Any) -> dict[str, Any]:
        return {k: v for k, v in metrics_of_record(record).items() if k in METRICS}

    def run_details(self, record: Any, scenario: Any, mode: str) -> dict[str, Any]:
        """The sequences (``apex_heights_m``, ``impact_speeds_m_s``, ``rebound_speeds_m_s``),
        ``static_sink_m``, ``stop_reason`` and the engine's ``bounce_threshold_m_s``."""
        got = metrics_of_record(record)
        out = {k: got[k] for k in ("apex_heights_m", "impact_speeds_m_s",
                                   "rebound_speeds_m_s")}
        out["static_sink_m"] = scenario.static_sink_m
        out["stop_reason"] = stop_reason(record, bounces_of(record))
        out["bounce_threshold_m_s"] = record.meta.get("bounce_threshold_m_s")
        return out

    def run_errors(self, run: Any, metrics: Any, reference: Any, resolved: Any
                   ) -> dict[str, float]:
        """Relative errors; the jitter at rest is reported, not compared (the reference's
        is 0)."""
        out = super().run_errors(run, metrics, reference, resolved)
        out["rest_jitter_m_s"] = math.nan
        return out

    def measure(self, scenario: Any, rec: Any, metrics: Any) -> dict[str, float]:
        """The largest overlap over R, and the largest growth of an apex over the one before
        it (the first over the drop height), less the sampling of an apex at the step dt
        (g·dt²/8): over 1, energy was created."""
        b = bounces_of(rec)
        pen = float(rec.penetration_m.max()) if len(rec) else math.nan
        dt = float(rec.meta.get("timestep_s") or 0.0)
        slack = scenario.gravity_m_s2 * dt * dt / 8.0
        apexes = [scenario.height_m, *b.apex_heights_m]
        growth = [max(0.0, after - slack) / before
                  for before, after in itertools.pairwise(apexes)
                  if before > APEX_COUNT_M / 10.0]
        return {"penetration_ratio": pen / scenario.radius_m,
                "energy_ratio": max(growth, default=math.nan)}

    def load_tuned(self, engine: str, scenario: Any, timestep_s: float | None,
                   tuned_file: Any = None, variant: Any = None) -> Any:
        """The head-on ball's tuned file (the same body and contact) at this step, bound to
        this scenario: its provenance names the ball's file, and leaves out the impact speed
        and gravity it was fitted at (the bounce's first impact is √(2gh), gravity on)."""
        from impactbench import tuned

        params, prov = tuned.load_tuned_settings(engine, "ball-on-plate", timestep_s,
                                                 tuned_file, variant)
        if prov is None:
            return params, prov
        prov = {k: v for k, v in prov.items()
                if k not in ("scenario_velocity_m_s", "scenario_gravity_m_s2")}
        prov.update(scenario=self.name, fitted_on="ball-on-plate")
        return params, prov


SPEC = BounceSpec(
    name=NAME,
    title="Bounce to rest",
    summary="the steel ball dropped on the plate and followed to rest, gravity on",
    metrics=METRICS,
    headline=("first_apex_m", "bounces_above_1mm", "rest_sink_m"),
    axes=(Axis("height_m", "heights_m", "h (m)", short="h"),),
    table="bounce",
    flags=FLAGS,
    gate_velocities_m_s=(),
    figure_stem="bounce",
    velocity_symbol="V1",
    descriptions={"height_m": "drop height h (m): the ball's lowest point above the plate, "
                              "released from rest"},
)
