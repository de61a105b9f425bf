"""The Euler engine's adapter: the ball on the plate by semi-implicit Euler, in pure Python.

The engine is one body on one axis: the ball (mass m) moving onto a fixed plate, x its
penetration (m, > 0 in contact), ẋ = v its penetration rate (m/s, > 0 approaching). Each step
of length dt is semi-implicit (symplectic) Euler, kick then drift::

    F_k = F(x_k, v_k)              the contact force (N), 0 out of contact
    v_{k+1} = v_k + (g − F_k/m)·dt  (g = scenario.gravity_m_s2 pulls the ball into the plate)
    x_{k+1} = x_k + v_{k+1}·dt

For an elastic force this is a symplectic, leapfrog-equivalent scheme (no energy drift); the
damping term sees v_k, so peak force, duration and penetration carry a first-order error in
dt that largely cancels in the restitution.

Modes (ball-on-plate only; every other scenario is ``unsupported``, as is every other mode):

- ``injected``: F is the scenario's own contact law, ``scenario.law()`` (Hunt–Crossley or
  whichever model the scenario names), evaluated by the engine each step as its contact
  force: the error is this engine's time stepping alone.
- ``native``: the engine's own contact, a clipped linear spring–damper (never pulls) with
  stiffness and damping matched to the reference's restitution and duration at 1 m/s
  (``settings.options["reference_velocity_m_s"]`` to change it), the mapping MuJoCo's and
  PyBullet's native modes use (:func:`impactbench.engines.common.native_ball_spring_damper`):
  right at that velocity, off at others (a linear spring has no velocity-dependent loss).

The record follows the adapters' conventions (``impactbench.engines.base``'s checklist):
sample k holds t_k = k·dt, the state (x_k, v_k) at the start of step k and the force F_k that
acts over that step, from 2.5 steps of free flight before first touch (so touch falls inside
a step) to two samples after the ball has let go (moving away, out of contact). The run
stops as ``tunneled`` once the ball's centre is past the plate's surface (x > R), and as
``max_time`` at the cap (``settings.max_time_s``, else 2 ms after touch or 50 steps);
:func:`impactbench.engines.common.classify` sets the status from the energies.
"""

from __future__ import annotations

import math
from typing import Any, ClassVar

import numpy as np
from impactbench.engines.base import Adapter, Builder, RunSettings
from impactbench.engines.common import classify, native_ball_spring_damper
from impactbench.reference.models import KelvinVoigt
from impactbench.reference.record import ImpactRecord
from impactbench.reference.scenarios import BallOnPlate

from impactbench_euler import NAME, __version__

STEP_S = 1e-6
"""The default step (s): ~100 steps over the paper's ball contact (77–120 µs at 1–5 m/s)."""
GAP_STEPS = 2.5
"""Free flight before first touch, in steps (non-integer: touch falls inside a step)."""
TAIL_STEPS = 2
"""Samples recorded after the ball has let go (the metrics locate the end between samples)."""
TIME_CAP_S = 2e-3
"""Time cap after first touch (s): ~20 contact durations of the paper's ball."""
MIN_CAP_STEPS = 50
"""The time cap is never fewer steps than this (a coarse step)."""


class EulerAdapter(Adapter):
    """The ball on the plate by semi-implicit Euler steps (module doc)."""

    name = NAME
    modes = ("native", "injected")
    injection = ("the law is the engine's contact force, F(x_k, ẋ_k) each step, integrated by "
                 "its semi-implicit Euler step (kick, then drift)")
    builders: ClassVar[dict[str, Builder]] = {"ball-on-plate": Builder("run_ball", STEP_S)}

    def version(self) -> str:
        return __version__

    def run_ball(self, scenario: BallOnPlate, mode: str, settings: RunSettings
                 ) -> ImpactRecord:
        """One impact of ``scenario`` in ``mode`` (``native`` or ``injected``) at
        ``settings.timestep_s`` (s; :meth:`Adapter.run` fills the default)."""
        meta: dict[str, Any] = {"integrator": "semi-implicit Euler"}
        if mode == "injected":
            law: Any = scenario.law()
            meta["contact"] = f"the scenario's law ({scenario.model})"
        else:
            v_ref = settings.options.get("reference_velocity_m_s")
            spring = native_ball_spring_damper(scenario, v_ref)
            law = KelvinVoigt(spring.stiffness_n_per_m, spring.damping_ns_per_m, clipped=True)
            meta.update(contact="clipped linear spring–damper",
                        stiffness_n_per_m=spring.stiffness_n_per_m,
                        damping_ns_per_m=spring.damping_ns_per_m)
        return integrate(scenario, law.force, float(settings.timestep_s), settings.max_time_s,
                         meta)


def integrate(scenario: BallOnPlate, force: Any, dt: float, max_time_s: float | None,
              meta: dict[str, Any]) -> ImpactRecord:
    """Step the ball from its gap until it has let go, tunnels, goes non-finite or reaches
    the cap; ``force(x, ẋ)`` is the contact force (N) at penetration x (m), rate ẋ (m/s)."""
    m, g, radius = scenario.mass_kg, scenario.gravity_m_s2, scenario.radius_m
    v0 = scenario.velocity_m_s
    gap = GAP_STEPS * v0 * dt
    cap_s = max_time_s or (gap / v0 + max(TIME_CAP_S, MIN_CAP_STEPS * dt))
    n_max = max(1, math.ceil(cap_s / dt))
    x, v = -gap, v0
    xs, vs, fs = [], [], []
    touched = tunneled = False
    tail = -1
    for _ in range(n_max):
        f = force(x, v) if x > 0.0 else 0.0
        xs.append(x)
        vs.append(v)
        fs.append(f)
        v += (g - f / m) * dt
        x += v * dt
        if f > 0.0:
            touched = True
        elif tail > 0:
            tail -= 1
            if tail == 0:
                break
        elif touched and tail < 0 and v < 0.0 and x <= 0.0:
            tail = TAIL_STEPS
        if x > radius:  # the centre passed the plate's surface
            tunneled = True
            break
        if not (math.isfinite(x) and math.isfinite(v)):
            break
    xs.append(x)
    vs.append(v)
    fs.append(0.0)
    n = len(xs)
    steps = n - 1
    timed_out = steps == n_max and tail != 0 and not tunneled
    x_arr, v_arr = np.asarray(xs), np.asarray(vs)
    rec = ImpactRecord(np.arange(n) * dt, x_arr, v_arr, np.asarray(fs), v_arr, np.zeros(n),
                       mass_1_kg=m, meta=dict(meta, steps=steps))
    return classify(rec, initial_kinetic_j=0.5 * m * v0 * v0, final_kinetic_j=0.5 * m * v * v,
                    tunneled=tunneled, timed_out=timed_out)
