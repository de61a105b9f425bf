"""One record loop for adapters whose engine advances one step per Python call (PhysX through
SAPIEN, DART, Box2D): the adapter supplies a small model object, this module steps it, records
it with :class:`~impactbench.engines.common.Recorder` and classifies the outcome.

A model exposes, along the impact axis (SI units; body 1 moves toward body 2):

- ``state() -> (x1, v1, x2, v2)``: positions measured from first touch (m) and velocities (m/s)
  at the current instant. For the ball, x1 is the penetration R − z of the ball into the plate,
  v1 = −ż its approach rate, and x2 = v2 = 0 (the plate).
- ``step() -> float``: advance one timestep and return the compressive normal force (N) the
  engine applied over that step — its reported contact impulse / dt for an engine contact, or
  the force it was given for an injected law.

Sample k is the state at the start of step k together with the force of step k (the
``Recorder`` layout), and one last sample carries the state after the final step with force 0.

A model whose contact is *rigid* sets ``impulsive = True``: its engine applies the contact as
one velocity jump at the start of the step (then drifts, x_{k+1} = x_k + v_{k+1}·dt), so a step
with force gets a second sample at the same instant carrying the velocity after the jump. The
metrics then see the jump where it happened — inside the contact's samples — and read the
restitution exactly whether the engine detected the contact before touch (speculative) or
after, and ∫F dt is the impulse.
"""

from __future__ import annotations

import math
from abc import abstractmethod
from collections.abc import Callable
from typing import Any, ClassVar, Protocol

from impactbench.engines.base import Adapter, Builder, RunSettings, Scenario
from impactbench.engines.common import Recorder, classify
from impactbench.reference.laws import StructuralLaw, no_further_contact
from impactbench.reference.record import ImpactRecord, Status
from impactbench.reference.scenarios import BallOnPlate, RigidFlexible

GAP_STEPS = 2.5
"""Free flight before first touch, in steps (non-integer: touch falls inside a step)."""

TAIL_STEPS = 2
"""Steps recorded after the contact has ended (the metrics locate the end between samples)."""

BALL_TIME_CAP_S = 2e-3
"""Default ball time cap after first touch (s): ~20 contact durations of the paper's ball."""

REST_FRACTION = 1e-6
"""A ball approaching at less than this fraction of its impact speed is at rest (float32)."""

MIN_STEPS = 50
"""The ball's time cap is never fewer steps than this (engines' customary steps, ≤ 1e-2 s)."""


RIGID_BALL_ARTEFACTS: dict[str, str] = dict.fromkeys(
    ("duration_s", "peak_force_n", "max_penetration_m", "energy_loss_fraction"),
    "a rigid contact is a one-step impulse: no duration, force or penetration")
RIGID_RF_ARTEFACTS: dict[str, str] = dict.fromkeys(
    ("peak_force_n", "pulse_width_s", "contact_time_s"),
    "a rigid contact is a one-step impulse: no contact stiffness k1, force or duration")


def rigid_artefacts(ball: bool) -> dict[str, str]:
    """``meta["not_comparable"]`` of a rigid (one-step impulse) contact."""
    return RIGID_BALL_ARTEFACTS if ball else RIGID_RF_ARTEFACTS


def flag(field: str, value: object) -> bool:
    """A boolean engine parameter (``True``/``False`` only)."""
    if not isinstance(value, bool):
        raise ValueError(f"{field} = {value!r}: must be true or false")
    return value


def count(field: str, value: object) -> int:
    """A positive integer engine parameter (e.g. solver iterations)."""
    if isinstance(value, bool) or not isinstance(value, int) or value < 1:
        raise ValueError(f"{field} = {value!r}: must be an integer >= 1")
    return value


def engine_params(prefix: str, values: dict[str, Any] | None,
                  validators: dict[str, Callable[[str, Any], Any]]) -> dict[str, Any]:
    """Validate ``values`` (an engine's own parameter names) key by key; an unknown key or a
    bad value is a one-line ValueError naming ``prefix.key``, the value and the rule."""
    out = {}
    for key, value in (values or {}).items():
        if key not in validators:
            raise ValueError(f"{prefix}.{key} = {value!r}: not a parameter; valid keys: "
                             f"{', '.join(validators)}")
        out[key] = validators[key](f"{prefix}.{key}", value)
    return out


class SteppedModel(Protocol):
    """What :func:`run_ball` and :func:`run_pair` need from an engine model (and, for a rigid
    contact, ``impulsive = True``)."""

    def state(self) -> tuple[float, float, float, float]: ...

    def step(self) -> float: ...


class WorldModel:
    """Base of models whose ``advance()`` applies this step's forces and steps the engine
    (returning the injected law's force, 0 without a law) and whose world ``w`` reports
    the engine's contact force (its contact impulse / dt) as ``w.contact_force_n()``."""

    law: Any
    w: Any

    def advance(self) -> float:
        raise NotImplementedError

    def step(self) -> float:
        """:meth:`advance`, then the force of that step: the injected law's, or the
        engine's reported contact impulse / dt."""
        f = self.advance()
        return f if self.law is not None else self.w.contact_force_n()


def gap_m(velocity_m_s: float, dt: float) -> float:
    """Initial free-flight distance (m): :data:`GAP_STEPS` steps at the impact velocity."""
    return GAP_STEPS * velocity_m_s * dt


def run_ball(model: SteppedModel, scenario: BallOnPlate, dt: float, max_time_s: float | None,
             meta: dict) -> ImpactRecord:
    """Step the ball from its gap until the contact has ended (moving away or at rest).

    The contact has ended once a step reports no force after a step that did and the ball is
    not approaching (ẋ ≤ 1e-6·V0: a ball stopped dead by a restitution threshold ends at rest);
    :data:`TAIL_STEPS` more steps are recorded. Tunneled: the ball's centre passed through the
    whole plate (x > R + ``model.plate_thickness_m``; a discrete engine may let the centre
    dip below the surface at a coarse step and still push the ball back). Time cap:
    ``max_time_s``, or gap + :data:`BALL_TIME_CAP_S` but at least :data:`MIN_STEPS` steps.
    """
    v0, radius = scenario.velocity_m_s, scenario.radius_m
    deep = radius + getattr(model, "plate_thickness_m", 0.0)
    cap_s = max_time_s or max(gap_m(v0, dt) / v0 + BALL_TIME_CAP_S, MIN_STEPS * dt)
    n_max = max(1, math.ceil(cap_s / dt))
    rec = Recorder()
    x, v, _, _ = model.state()
    impulsive = getattr(model, "impulsive", False)
    touched = tunneled = nonfinite = False
    tail = -1
    k = 0
    while k < n_max:
        f = model.step()
        rec.append(k * dt, x, v, f, v)
        x_k = x
        x, v, _, _ = model.state()
        if impulsive and f > 0.0:
            rec.append(k * dt, x_k, v, f, v)
        k += 1
        if not (math.isfinite(x) and math.isfinite(v) and math.isfinite(f)):
            nonfinite = True
            break
        if x > deep:
            tunneled = True
            break
        if f > 0.0:
            touched, tail = True, -1
        elif touched:
            if tail < 0 and v <= REST_FRACTION * v0:
                tail = TAIL_STEPS
            elif tail > 0:
                tail -= 1
                if tail == 0:
                    break
    rec.append(k * dt, x, v, 0.0, v)
    out = rec.record(scenario.mass_kg, **meta, steps=k)
    half_m = 0.5 * scenario.mass_kg
    return classify(out, initial_kinetic_j=half_m * v0 * v0, final_kinetic_j=half_m * v * v,
                    tunneled=tunneled, timed_out=k == n_max and tail != 0 and not nonfinite)


def run_pair(model: SteppedModel, scenario: RigidFlexible, dt: float, max_time_s: float | None,
             meta: dict, contact_threshold=None) -> ImpactRecord:
    """Step the 2-DOF model until no further contact is possible, collapse, or the time cap.

    No further contact: ``no_further_contact(x1 − p, …)`` with p the injected local law's
    permanent set (``contact_threshold()``; 0 for an engine contact): body 2 bounded in its
    well out of body 1's reach, or escaped past a softening potential's peak. Collapse
    (softening structure): body 2's energy ½·m2·v2² + Π(x2) above the potential's peak
    k2²/(4β) during a contact — the reference's rule; it is flagged and the run goes on until
    body 2 has escaped, so the metrics cover the whole contact as the reference's do.
    """
    m1, m2 = scenario.m1_kg, scenario.m2_kg
    structure: StructuralLaw = scenario.structural_law()
    collapse_energy = structure.collapse_energy
    softening = collapse_energy < math.inf
    n_max = max(1, math.ceil((max_time_s or scenario.max_time_s) / dt))
    rec = Recorder()
    x1, v1, x2, v2 = model.state()
    impulsive = getattr(model, "impulsive", False)
    done = collapsed = nonfinite = False
    k = 0
    while k < n_max:
        f = model.step()
        rec.append(k * dt, x1 - x2, v1 - v2, f, v1, v2, x2)
        dx, x2_k = x1 - x2, x2
        x1, v1, x2, v2 = model.state()
        if impulsive and f > 0.0:
            rec.append(k * dt, dx, v1 - v2, f, v1, v2, x2_k)
        k += 1
        if not all(map(math.isfinite, (x1, v1, x2, v2, f))):
            nonfinite = True
            break
        if f > 0.0:
            if softening and 0.5 * m2 * v2 * v2 + structure.potential(x2) > collapse_energy:
                collapsed = True  # flagged; the run goes on until body 2 escapes
        elif v1 <= 0.0 or collapsed:
            p = contact_threshold() if contact_threshold is not None else 0.0
            if no_further_contact(x1 - p, v1, x2, v2, m2, structure):
                done = True
                break
    rec.append(k * dt, x1 - x2, v1 - v2, 0.0, v1, v2, x2)
    out = rec.record(m1, m2, with_displacement_2=True, **meta, steps=k)
    initial = 0.5 * m1 * scenario.velocity_m_s**2
    final = 0.5 * m1 * v1 * v1 + 0.5 * m2 * v2 * v2 + structure.potential(x2)
    out = classify(out, initial_kinetic_j=initial, final_kinetic_j=final,
                   timed_out=not (done or collapsed or nonfinite))
    if collapsed and out.status in (Status.OK, Status.MAX_TIME):
        out.status = Status.STRUCTURE_COLLAPSED
        out.message = "body 2's energy passed the softening potential's peak k2²/(4β)"
    return out


class SteppedAdapter(Adapter):
    """An adapter whose engine runs through :func:`run_ball` / :func:`run_pair`.

    Subclasses set ``label`` (the engine's display name), ``ball_model`` and ``pair_model``
    (model classes taking ``(scenario, params, dt, law)``, ``law`` None for the engine's own
    contact) and implement :meth:`parameters`. Injected mode hands the models the scenario's
    law (the ball's contact model, or the 2-DOF local law) to apply as a force.
    """

    modes = ("native", "injected", "tuned", "default", "custom")
    builders: ClassVar[dict[str, Builder]] = {
        "ball-on-plate": Builder("run_ball", 1e-6),
        "rigid-flexible": Builder("run_pair", 1e-5),
    }
    label: ClassVar[str]
    ball_model: ClassVar[Callable[..., SteppedModel]]
    pair_model: ClassVar[Callable[..., SteppedModel]]

    @abstractmethod
    def parameters(self, scenario: Scenario, mode: str, settings: RunSettings, ball: bool
                   ) -> tuple[dict[str, Any], dict[str, Any]]:
        """The complete engine parameter set for ``mode`` and the run's meta (``ball``: the
        ball-on-plate scenario, else the rigid–flexible pair)."""

    def run_ball(self, scenario: BallOnPlate, mode: str, settings: RunSettings) -> ImpactRecord:
        refused = self._refused(mode, settings)
        if refused is not None:
            return refused
        dt = float(settings.timestep_s)
        params, meta = self.parameters(scenario, mode, settings, ball=True)
        law = scenario.law() if mode == "injected" else None
        model = self.ball_model(scenario, params, dt, law)
        return run_ball(model, scenario, dt, settings.max_time_s, meta)

    def run_pair(self, scenario: RigidFlexible, mode: str, settings: RunSettings
                 ) -> ImpactRecord:
        refused = self._refused(mode, settings)
        if refused is not None:
            return refused
        dt = float(settings.timestep_s)
        params, meta = self.parameters(scenario, mode, settings, ball=False)
        law = scenario.local_law() if mode == "injected" else None
        model = self.pair_model(scenario, params, dt, law)
        threshold = getattr(law, "contact_threshold", None)
        return run_pair(model, scenario, dt, settings.max_time_s, meta, threshold)

    def _refused(self, mode: str, settings: RunSettings) -> ImpactRecord | None:
        """``unsupported`` for tuned mode without tuned parameters (every scenario)."""
        if mode == "tuned" and settings.tuned is None:
            return ImpactRecord.failed(
                Status.UNSUPPORTED, f"tuned mode needs settings.tuned ({self.label} parameter "
                f"names: {', '.join(self.parameter_keys)}; no tuned-parameter file given)")
        return None
