"""What every engine's bounce-to-rest run shares: where it starts, when it ends, its status.

A bounce run (:class:`~impactbench.reference.bounce_scenario.Bounce`) releases the ball from
rest with its lowest point ``height_m`` above the plate, gravity on, and records every step —
(t, x, ẋ, F, ẋ) with x = R − z the overlap (< 0 a gap), ẋ = −ż (> 0 falling) and F the
engine's reported normal force (N) over the step, the layout of
:class:`~impactbench.engines.common.Recorder` — until the ball is at rest or the time cap.
The metrics (apexes, bounces, sinking at rest) are read from that record by the scenario's
spec, alike for every engine.

At rest: once the engine has reported contact, |ẋ| stays below :data:`SETTLE_SPEED_M_S` for
:data:`SETTLE_S`; ``meta["rest_from_s"]`` is when that quiet stretch began (the sinking and
jitter at rest are read from there on). A ball in flight cannot: gravity takes it past that
speed within SETTLE_SPEED/g ≈ 1 ms. A ball still bouncing at the cap is ``max_time`` (its
bounces are still measured).

Each engine's contact settings for a mode are its head-on ball's at the first impact
(:meth:`Bounce.ball`: V0 = √(2gh), gravity on): native's spring–damper, the ball's tuned
file, the injected Hunt–Crossley law. An engine with a restitution velocity threshold (below
it a rigid contact does not bounce) records the value it applied, read back from the engine,
as ``meta["bounce_threshold_m_s"]``.
"""

from __future__ import annotations

import math
from typing import Any

from impactbench.engines.common import Recorder, classify
from impactbench.reference.bounce_scenario import Bounce
from impactbench.reference.record import ImpactRecord, Status

SETTLE_SPEED_M_S = 0.01
"""At rest: |ẋ| below this (m/s; a bounce this fast rises 5 µm) ..."""
SETTLE_S = 0.1
"""... for this long (s) after the engine's first contact."""
GAIN_STOP = 2.0
"""A run stops, ``diverged``, once the ball's mechanical energy ½ẋ² + g·(−x) (per unit mass,
the plate's surface its zero) exceeds this many times the drop's g·h: a contact that
diverged would otherwise fly on to the time cap."""


class BounceEnd:
    """The end rule of a bounce run, checked after every step: at rest (see the module),
    non-finite, tunnelled (the centre past ``deep_m`` below the surface: the plate's far
    side, or R for a law injected as a force) or the time cap (``max_time_s``, else the
    scenario's) at ``dt`` (s)."""

    def __init__(self, scenario: Bounce, dt: float, max_time_s: float | None = None,
                 deep_m: float | None = None) -> None:
        self.n_max = max(1, math.ceil((max_time_s or scenario.max_time_s) / dt))
        self.settle_steps = max(1, math.ceil(SETTLE_S / dt))
        self.deep_m = scenario.radius_m if deep_m is None else deep_m
        self.touched = self.settled = self.tunneled = self.nonfinite = False
        self.gained = 0.0
        self.rest_from_s = math.nan
        self._dt = dt
        self._calls = 0
        self._quiet = 0
        self._g = scenario.gravity_m_s2
        self._limit = GAIN_STOP * scenario.gravity_m_s2 * scenario.height_m

    def ended(self, x: float, v: float, force: float) -> bool:
        """After a step: the state (x, ẋ) it ended in and its force F."""
        if not (math.isfinite(x) and math.isfinite(v) and math.isfinite(force)):
            self.nonfinite = True
            return True
        if x > self.deep_m:
            self.tunneled = True
            return True
        if 0.5 * v * v - self._g * x > self._limit:  # (per unit mass; the plate at x = 0)
            self.gained = (0.5 * v * v - self._g * x) * GAIN_STOP / self._limit
            return True
        if force > 0.0:
            self.touched = True
        self._calls += 1
        self._quiet = self._quiet + 1 if self.touched and abs(v) < SETTLE_SPEED_M_S else 0
        if self._quiet == 1:  # this state, after step _calls, is sample _calls's (t = k·dt)
            self.rest_from_s = self._calls * self._dt
        self.settled = self._quiet >= self.settle_steps
        return self.settled

    def finish(self, rec: Recorder, scenario: Bounce, v_end: float, /, **meta: Any
               ) -> ImpactRecord:
        """The record with its status: diverged (non-finite, ending with more kinetic energy
        than the drop's m·g·h, or stopped for energy gained), tunneled, no_contact, max_time
        (not at rest at the cap), else ok. The head-on ball's ``not_comparable`` (its
        metrics) does not apply here and is left out."""
        meta.pop("not_comparable", None)
        out = rec.record(scenario.mass_kg, **meta, settled=self.settled,
                         rest_from_s=self.rest_from_s if self.settled else math.nan)
        if self.gained:
            out.status = Status.DIVERGED
            out.message = (f"mechanical energy ×{self.gained:.3g} the drop's m·g·h: stopped at "
                           f"×{GAIN_STOP:g}")
            return out
        drop_j = scenario.mass_kg * scenario.gravity_m_s2 * scenario.height_m
        out = classify(out, initial_kinetic_j=drop_j,
                       final_kinetic_j=0.5 * scenario.mass_kg * v_end * v_end,
                       tunneled=self.tunneled,
                       timed_out=not (self.settled or self.tunneled or self.nonfinite))
        if out.status == "max_time":
            out.message = (f"still moving at the time cap, {scenario.max_time_s:g} s "
                           f"(|ẋ| ≥ {SETTLE_SPEED_M_S:g} m/s within the last {SETTLE_S:g} s)")
        return out
