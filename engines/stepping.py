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

The oblique impact (:func:`run_oblique`) adds the tangential channels: an oblique model's
``state()`` returns (x, ẋ, v_t, ω) — the penetration and its rate as above, the centre's
velocity along the plate (along the incoming tangential direction t) and the spin about n × t
(positive: forward rolling) — and its ``step()`` returns (F_n, F_t), the normal force and the
friction force on the ball along t over the step. Injected mode gives such a model a
:class:`CoulombContact`: the scenario's normal law and ideal Coulomb friction, applied as
forces (:func:`coulomb_force`).
"""

from __future__ import annotations

import math
from abc import abstractmethod
from collections.abc import Callable
from typing import Any, ClassVar, Protocol

import numpy as np
from impactbench.engines import oblique_common
from impactbench.engines.base import (
    Adapter,
    Builder,
    RunSettings,
    Scenario,
    ball_gap_m,
    ball_phase,
    scenario_builders,
)
from impactbench.engines.common import (
    Recorder,
    classify,
    native_ball_restitution,
    reference_velocity,
)
from impactbench.reference.bounce_scenario import Bounce
from impactbench.reference.laws import StructuralLaw, no_further_contact
from impactbench.reference.oblique_scenario import Oblique
from impactbench.reference.record import ImpactRecord, Status
from impactbench.reference.scenarios import BallOnPlate, RigidFlexible

GAP_STEPS = 2.5
"""Free flight before first touch, in steps (non-integer: touch falls inside a step): the
2-DOF pair's and the oblique ball's (:func:`gap_m`); the head-on ball's is 2 + phase
(:func:`~impactbench.engines.base.ball_gap_m`), this at the default phase."""

TAIL_STEPS = 2
"""Steps recorded after the contact has ended (the metrics locate the end between samples)."""

BALL_TIME_CAP_S = 2e-3
"""Default ball time cap after first touch (s): ~20 contact durations of the paper's ball."""

REST_FRACTION = 1e-6
"""A ball approaching at less than this fraction of its impact speed is at rest (float32)."""

RIGID_REST_FRACTION = 1e-3
"""The oblique ball is at rest after a rigid contact (an impulse, e = 0) once it approaches at
less than this fraction of v_n (the float32 residue of an impulse that stopped it)."""

MIN_STEPS = 50
"""The ball's time cap is never fewer steps than this (engines' customary steps, ≤ 1e-2 s)."""


RIGID_BALL_ARTEFACTS: dict[str, str] = dict.fromkeys(
    ("duration_s", "peak_force_n", "max_penetration_m", "energy_loss_fraction"),
    "a rigid contact is a one-step impulse: no duration, force or penetration")
RIGID_RF_ARTEFACTS: dict[str, str] = dict.fromkeys(
    ("peak_force_n", "pulse_width_s", "contact_time_s"),
    "a rigid contact is a one-step impulse: no contact stiffness k1, force or duration")


RIGID_OBLIQUE_ARTEFACTS: dict[str, str] = dict.fromkeys(
    ("duration_s", "peak_force_n", "peak_tangential_force_n"),
    "a rigid contact is a one-step impulse: no duration or force (normal or tangential)")

OBLIQUE_TIMESTEP_S = 1e-6
"""The oblique impact's default step (s): the ball's."""


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


def user_params(mode: str, settings: RunSettings, validators: dict[str, Callable[[str, Any], Any]]
                ) -> dict[str, Any]:
    """``custom`` mode's engine parameters, validated (:func:`engine_params`); none for any
    other mode."""
    return engine_params("params", settings.params, validators) if mode == "custom" else {}


def params_meta(mode: str, own: dict[str, Any]) -> dict[str, Any]:
    """What a run's meta records of the user's parameters: ``params`` in ``custom`` mode."""
    return {"params": own} if mode == "custom" else {}


def apply_tuned(native: dict[str, Any], meta: dict[str, Any], mode: str, settings: RunSettings,
                validators: dict[str, Callable[[str, Any], Any]]) -> None:
    """``tuned`` mode: the tuned parameters (validated, :func:`engine_params`) over the
    native set, and recorded in ``meta["tuned"]``; nothing in any other mode."""
    if mode == "tuned":
        tuned = engine_params("tuned", settings.tuned, validators)
        native.update(tuned)
        meta["tuned"] = tuned


def rigid_parameters(scenario: Scenario, mode: str, settings: RunSettings, ball: bool, *,
                     defaults: dict[str, Any], validators: dict[str, Callable[[str, Any], Any]],
                     restitution_key: str, frictionless: dict[str, Any],
                     injected_contact: str, not_expressible: tuple[str, str],
                     neutral: dict[str, Any] | None = None,
                     default_params: dict[str, Any] | None = None
                     ) -> tuple[dict[str, Any], dict[str, Any]]:
    """The complete parameter set for ``mode`` and the run's meta of an engine whose contacts
    are rigid (a one-step impulse with a restitution coefficient, no stiffness: Box2D, DART);
    ``ball``: the ball-on-plate scenario, else the rigid–flexible pair.

    ``default``: ``default_params`` (the engine's ``defaults`` when None); ``custom``: the
    defaults, ``neutral`` (plate values that leave the pair's coefficient to body 1's) and
    the user's validated ``settings.params``; ``injected``: the defaults, ``neutral`` and
    ``frictionless`` (the law acts as a force, described by ``injected_contact``); ``native``
    and ``tuned``: that with ``restitution_key`` set to the ball's native restitution at the
    reference velocity (m/s, ``settings.options``) or, for the pair, 1 (an elastic impulse:
    a rigid contact has no stiffness k1 to carry the local law), ``not_expressible`` (ball,
    pair) noted, and in ``tuned`` the tuned parameters over it (:func:`apply_tuned`)."""
    neutral = neutral or {}
    rigid = {"contact": "rigid", "not_comparable": rigid_artefacts(ball)}
    if mode == "default":
        params = dict(defaults) if default_params is None else default_params
        return params, {**rigid, "engine_defaults": defaults}
    if mode == "custom":
        own = engine_params("params", settings.params, validators)
        return {**defaults, **neutral, **own}, {**rigid, "params": own,
                                                "engine_defaults": defaults}
    native = {**defaults, **neutral, **frictionless}
    if mode == "injected":
        law = "hunt_crossley" if ball else scenario.local
        return native, {"contact": injected_contact, "injected_law": law}
    meta: dict[str, Any] = dict(rigid)
    if ball:
        v_ref = reference_velocity(settings.options)
        native[restitution_key] = native_ball_restitution(scenario, v_ref)
        meta["reference_velocity_m_s"] = v_ref
    else:
        native[restitution_key] = 1.0
    meta["not_expressible"] = not_expressible[0] if ball else not_expressible[1]
    apply_tuned(native, meta, mode, settings, validators)
    meta["restitution"] = native[restitution_key]
    return native, meta


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


def record_steps(model: SteppedModel, dt: float, n_max: int, rec: Recorder,
                 ended: Callable[[float, float, float], bool]) -> tuple[int, float, float]:
    """Step ``model`` up to ``n_max`` times at ``dt``, recording each step in ``rec`` (the
    module's layout: the state at the step's start with its force, a rigid contact's second
    sample at the same instant), until ``ended(x, ẋ, F)`` says so after a step; then one
    last sample, the final state with force 0. Returns (steps taken, final x, final ẋ)."""
    impulsive = getattr(model, "impulsive", False)
    x, v, _, _ = model.state()
    k = 0
    while k < n_max:
        f = model.step()
        rec.append(k * dt, x, v, f, v)
        x_k = x
        x, v, _, _ = model.state()
        if impulsive and f > 0.0:
            rec.append(k * dt, x_k, v, f, v)
        k += 1
        if ended(x, v, f):
            break
    rec.append(k * dt, x, v, 0.0, v)
    return k, x, v


class _BallEnd:
    """:func:`run_ball`'s end rule, after each step: non-finite, tunnelled past ``deep_m``,
    or the contact over (no force after a step with force, the ball not approaching faster
    than ``rest_m_s``) and :data:`TAIL_STEPS` more steps recorded."""

    def __init__(self, deep_m: float, rest_m_s: float) -> None:
        self.deep_m, self.rest_m_s = deep_m, rest_m_s
        self.touched = self.tunneled = self.nonfinite = False
        self.tail = -1

    def __call__(self, x: float, v: float, f: float) -> bool:
        if not (math.isfinite(x) and math.isfinite(v) and math.isfinite(f)):
            self.nonfinite = True
            return True
        if x > self.deep_m:
            self.tunneled = True
            return True
        if f > 0.0:
            self.touched, self.tail = True, -1
        elif self.touched:
            if self.tail < 0 and v <= self.rest_m_s:
                self.tail = TAIL_STEPS
            elif self.tail > 0:
                self.tail -= 1
                if self.tail == 0:
                    return True
        return False


def run_ball(model: SteppedModel, scenario: BallOnPlate, dt: float, max_time_s: float | None,
             meta: dict, phase: float | None = None) -> ImpactRecord:
    """Step the ball from its gap (the model's: built at ``phase``, recorded in
    ``meta["phase"]``) until the contact has ended (moving away or at rest).

    The contact has ended once a step reports no force after a step that did and the ball is
    not approaching (ẋ ≤ 1e-6·V0: a ball stopped dead by a restitution threshold ends at rest);
    :data:`TAIL_STEPS` more steps are recorded. Tunneled: the ball's centre passed through the
    whole plate (x > R + ``model.plate_thickness_m``; a discrete engine may let the centre
    dip below the surface at a coarse step and still push the ball back). Time cap:
    ``max_time_s``, or gap + :data:`BALL_TIME_CAP_S` but at least :data:`MIN_STEPS` steps.
    """
    v0, radius = scenario.velocity_m_s, scenario.radius_m
    end = _BallEnd(radius + getattr(model, "plate_thickness_m", 0.0), REST_FRACTION * v0)
    cap_s = max_time_s or max(ball_gap_m(v0, dt, phase) / v0 + BALL_TIME_CAP_S, MIN_STEPS * dt)
    n_max = max(1, math.ceil(cap_s / dt))
    rec = Recorder()
    k, _, v = record_steps(model, dt, n_max, rec, end)
    out = rec.record(scenario.mass_kg, **meta, phase=ball_phase(phase), steps=k)
    half_m = 0.5 * scenario.mass_kg
    return classify(out, initial_kinetic_j=half_m * v0 * v0, final_kinetic_j=half_m * v * v,
                    tunneled=end.tunneled,
                    timed_out=k == n_max and end.tail != 0 and not end.nonfinite)


def run_bounce(model: SteppedModel, scenario: Bounce, dt: float, max_time_s: float | None,
               meta: dict[str, Any]) -> ImpactRecord:
    """The bounce to rest of a model built with the ball at rest ``height_m`` above the
    plate: every step recorded (:func:`record_steps`) until
    :class:`~impactbench.engines.bounce.BounceEnd` ends it (tunnelled: past the plate's far
    side, R + ``model.plate_thickness_m``)."""
    from impactbench.engines.bounce import BounceEnd

    end = BounceEnd(scenario, dt, max_time_s,
                    scenario.radius_m + getattr(model, "plate_thickness_m", 0.0))
    rec = Recorder()
    k, _, v = record_steps(model, dt, end.n_max, rec, end.ended)
    return end.finish(rec, scenario, v, **meta, steps=k)


class PairEnd:
    """The end rules of a 2-DOF run, checked after every step (:func:`run_pair`'s, pymunk's).

    No further contact: ``no_further_contact(x1 − p, …)`` with p the injected local law's
    permanent set (``contact_threshold()``; 0 for an engine contact): body 2 bounded in its
    well out of body 1's reach, or escaped past a softening potential's peak. Collapse
    (softening structure): body 2's energy ½·m2·v2² + Π(x2) above the potential's peak
    k2²/(4β) during a contact — the reference's rule; it is flagged and the run goes on until
    body 2 has escaped, so the metrics cover the whole contact as the reference's do.
    """

    def __init__(self, scenario: RigidFlexible, structure: StructuralLaw,
                 contact_threshold: Callable[[], float] | None = None) -> None:
        self.scenario, self.structure, self.threshold = scenario, structure, contact_threshold
        self.m2 = scenario.m2_kg
        self.collapse_energy = structure.collapse_energy
        self.softening = self.collapse_energy < math.inf
        self.collapsed = self.done = False

    def ended(self, f: float, x1: float, v1: float, x2: float, v2: float) -> bool:
        """After a step with contact force ``f`` (N) that left body 1 at x1, v1 and body 2 at
        x2, v2 (m, m/s): flag a collapse; True once no further contact is possible."""
        if f > 0.0:
            if self.softening and (0.5 * self.m2 * v2 * v2 + self.structure.potential(x2)
                                   > self.collapse_energy):
                self.collapsed = True  # flagged; the run goes on until body 2 escapes
        elif v1 <= 0.0 or self.collapsed:
            p = self.threshold() if self.threshold is not None else 0.0
            self.done = no_further_contact(x1 - p, v1, x2, v2, self.m2, self.structure)
        return self.done

    def outcome(self, out: ImpactRecord, v1: float, v2: float, x2: float, nonfinite: bool
                ) -> ImpactRecord:
        """Classify the run's record (energy in: body 1's ½·m1·V²; out: both bodies' kinetic
        energy and the structure's potential at the end, J); ``structure_collapsed`` when a
        collapse was flagged; ``max_time`` when it neither ended nor collapsed."""
        s = self.scenario
        initial = 0.5 * s.m1_kg * s.velocity_m_s**2
        final = 0.5 * s.m1_kg * v1 * v1 + 0.5 * self.m2 * v2 * v2 + self.structure.potential(x2)
        out = classify(out, initial_kinetic_j=initial, final_kinetic_j=final,
                       timed_out=not (self.done or self.collapsed or nonfinite))
        if self.collapsed and out.status in (Status.OK, Status.MAX_TIME):
            out.status = Status.STRUCTURE_COLLAPSED
            out.message = "body 2's energy passed the softening potential's peak k2²/(4β)"
        return out


def run_pair(model: SteppedModel, scenario: RigidFlexible, dt: float, max_time_s: float | None,
             meta: dict, contact_threshold: Callable[[], float] | None = None) -> ImpactRecord:
    """Step the 2-DOF model until no further contact is possible, collapse, or the time cap
    (:class:`PairEnd`)."""
    end = PairEnd(scenario, scenario.structural_law(), contact_threshold)
    n_max = max(1, math.ceil((max_time_s or scenario.max_time_s) / dt))
    rec = Recorder()
    x1, v1, x2, v2 = model.state()
    impulsive = getattr(model, "impulsive", False)
    nonfinite = False
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
        if end.ended(f, x1, v1, x2, v2):
            break
    rec.append(k * dt, x1 - x2, v1 - v2, 0.0, v1, v2, x2)
    out = rec.record(scenario.m1_kg, scenario.m2_kg, with_displacement_2=True, **meta, steps=k)
    return end.outcome(out, v1, v2, x2, nonfinite)


def slip_mass_kg(scenario: Oblique) -> float:
    """The ball's effective mass at the contact point along the plate (kg): a tangential
    force F_t at the contact point changes the slip s = v_t − R·ω at the rate
    F_t·(1/m + R²/I), so m_s = 1/(1/m + R²/I) (m/3.5 for a solid sphere)."""
    m, r = scenario.mass_kg, scenario.radius_m
    return 1.0 / (1.0 / m + r * r / scenario.moment_of_inertia_kg_m2)


def coulomb_force(normal_force_n: float, slip_m_s: float, friction: float,
                  slip_mass: float, dt: float) -> float:
    """Ideal Coulomb friction for one explicit step (N, on the ball along t): the force that
    stops the contact point's slip within the step, −s·m_s/dt, clipped to the cone ±μ·F_n.

    A body step v ← v + F·dt/m, ω ← ω + τ·dt/I with this force at the contact point leaves
    the slip exactly 0 while the cone allows (stick: the rigid theory's rolling, without the
    chatter of a sign(s) law) and otherwise applies μ·F_n against the slip (sliding), so
    the tangential impulse is μ times the normal impulse while the ball slides. For these
    semi-implicit Euler engines this is the discrete rigid limit exactly;
    :func:`impactbench.engines.oblique_common.coulomb_force` regularises over two steps
    instead, as an explicit Runge–Kutta step needs."""
    cap = friction * normal_force_n
    if cap <= 0.0:
        return 0.0
    return max(-cap, min(cap, -slip_m_s * slip_mass / dt))


class CoulombContact:
    """The injected oblique contact: the scenario's normal law F_n(x, ẋ) (its
    :meth:`~impactbench.reference.oblique_scenario.Oblique.normal_scenario`'s law, set up at
    the normal velocity) and ideal Coulomb friction μ (:func:`coulomb_force`), evaluated at
    a step's start state."""

    def __init__(self, scenario: Oblique, dt: float) -> None:
        self.normal = scenario.normal_scenario().law()
        self.friction = scenario.friction
        self.radius_m = scenario.radius_m
        self.slip_mass = slip_mass_kg(scenario)
        self.dt = dt

    def forces(self, x: float, rate: float, v_t: float, spin: float) -> tuple[float, float]:
        """(F_n, F_t) at penetration x, its rate ẋ, tangential velocity v_t and spin ω."""
        fn = self.normal.force(x, rate)
        if fn <= 0.0:
            return 0.0, 0.0
        return fn, coulomb_force(fn, v_t - self.radius_m * spin, self.friction,
                                 self.slip_mass, self.dt)


def friction_facts(model: str, rule: str, ball: float, plate: float, effective: float,
                   **extra: Any) -> dict[str, Any]:
    """An oblique run's friction facts for ``meta["engine_defaults"]``, the keys of
    :func:`impactbench.engines.oblique_common.friction_facts` (``friction_model``,
    ``friction_combination``, ``friction_ball``, ``friction_plate``, ``friction_effective``
    and extras); a rule that module does not list (Box2D's ``geometric`` mean √(μ_a·μ_b))
    gets the same keys."""
    if rule in (*oblique_common.COMBINATIONS, "none"):
        return oblique_common.friction_facts(model, rule, ball, plate, effective, **extra)
    return {"friction_model": model, "friction_combination": rule,
            "friction_ball": float(ball), "friction_plate": float(plate),
            "friction_effective": float(effective), **extra}


INJECTED_FRICTION = ("ideal Coulomb as a force at the contact point: −s·m_s/dt clipped to "
                     "±μ·F_n at the step's start state (stops the slip within a step)")
"""``friction_model`` of an injected oblique run whose friction is an applied force."""


class ObliqueModel(Protocol):
    """What :func:`run_oblique` needs from an engine model (and, for a rigid contact,
    ``impulsive = True``; ``plate_thickness_m`` for the tunnelling test)."""

    def state(self) -> tuple[float, float, float, float]: ...

    def step(self) -> tuple[float, float]: ...


def run_oblique(model: ObliqueModel, scenario: Oblique, dt: float, max_time_s: float | None,
                meta: dict) -> ImpactRecord:
    """Step the oblique impact from its gap until the contact has ended: :func:`run_ball`'s
    rules along the normal (with the normal velocity v_n; a rigid contact has ended once the
    ball no longer approaches, whatever resting force it reports), and the tangential channels
    recorded alongside (sample k: the state at the start of step k and the forces of step k;
    a rigid contact's second sample at the same instant carries the velocities after the
    jump). The record and its status: :func:`impactbench.engines.oblique_common.record` and
    ``finish`` (:func:`run_ball`'s rules, the energies with the tangential motion and spin)."""
    v0, radius = scenario.normal_velocity_m_s, scenario.radius_m
    deep = radius + getattr(model, "plate_thickness_m", 0.0)
    cap_s = max_time_s or max(gap_m(v0, dt) / v0 + BALL_TIME_CAP_S, MIN_STEPS * dt)
    n_max = max(1, math.ceil(cap_s / dt))
    rows: list[tuple[float, ...]] = []
    x, v, vt, w = model.state()
    impulsive = getattr(model, "impulsive", False)
    rest = (RIGID_REST_FRACTION if impulsive else REST_FRACTION) * v0
    touched = tunneled = nonfinite = False
    tail = -1
    k = 0
    while k < n_max:
        fn, ft = model.step()
        rows.append((k * dt, x, v, fn, vt, w, ft))
        x_k = x
        x, v, vt, w = model.state()
        if impulsive and (fn > 0.0 or ft != 0.0):
            rows.append((k * dt, x_k, v, fn, vt, w, ft))
        k += 1
        if not all(map(math.isfinite, (x, v, vt, w, fn, ft))):
            nonfinite = True
            break
        if x > deep:
            tunneled = True
            break
        # a rigid contact that stopped the ball dead (e = 0: a restitution threshold) may
        # go on reporting resting forces (position correction, the plate's curvature) and
        # leave a float32 residue of the approach: its impact is over once the ball no
        # longer approaches faster than RIGID_REST_FRACTION of v_n
        resting = impulsive and touched and v <= rest
        if fn > 0.0 and not resting:
            touched, tail = True, -1
        elif touched:
            if tail < 0 and v <= rest:
                tail = TAIL_STEPS
            elif tail > 0:
                tail -= 1
                if tail == 0:
                    break
    rows.append((k * dt, x, v, 0.0, vt, w, 0.0))
    d = np.array(rows, dtype=float).reshape(-1, 7).T
    out = oblique_common.record(scenario, d[0], d[1], d[2], d[3], d[4], d[5], d[6],
                                dict(meta, steps=k))
    return oblique_common.finish(out, scenario, tunneled=tunneled,
                                 timed_out=k == n_max and tail != 0 and not nonfinite)


class SteppedAdapter(Adapter):
    """An adapter whose engine runs through :func:`run_ball` / :func:`run_pair` /
    :func:`run_oblique`.

    Subclasses set ``builders`` (:func:`builders`), ``ball_model``, ``pair_model`` (model
    classes taking ``(scenario, params, dt, law)``, ``law`` None for the engine's own
    contact; ``ball_model`` also the keywords ``phase``, its gap's
    :attr:`~impactbench.engines.base.RunSettings.phase`, and ``drop_height_m``, the bounce's
    start) and ``oblique_model``, and implement :meth:`parameters` and
    :meth:`oblique_parameters` (an engine module's functions can serve as they are:
    ``parameters = staticmethod(parameters)``). Injected mode hands the models the
    scenario's law (the ball's contact model, or the 2-DOF local law) to apply as a force.
    The builders only build: :meth:`Adapter.run` has checked the mode and the tuned
    parameters (``tuned`` reads any of :attr:`~Adapter.parameter_keys`; oblique: the
    friction knobs of :mod:`impactbench.engines.oblique_tuned`).
    """

    modes = ("native", "injected", "tuned", "default", "custom")
    ball_model: ClassVar[Callable[..., SteppedModel]]
    pair_model: ClassVar[Callable[..., SteppedModel]]
    oblique_model: ClassVar[Callable[..., ObliqueModel]]
    """Model class of the oblique impact, ``(scenario, params, dt, contact)`` with
    ``contact`` a :class:`CoulombContact` in injected mode, else None (the engine's own)."""

    @abstractmethod
    def parameters(self, scenario: Scenario, mode: str, settings: RunSettings, ball: bool
                   ) -> tuple[dict[str, Any], dict[str, Any]]:
        """The complete engine parameter set for ``mode`` and the run's meta (``ball``: the
        ball-on-plate scenario, else the rigid–flexible pair)."""

    def run_ball(self, scenario: BallOnPlate, mode: str, settings: RunSettings) -> ImpactRecord:
        """The head-on ball: ``ball_model`` built with its gap at ``settings.phase``
        (keyword ``phase``, :func:`~impactbench.engines.base.ball_gap_m`), stepped by
        :func:`run_ball`."""
        dt = float(settings.timestep_s)
        params, meta = self.parameters(scenario, mode, settings, ball=True)
        law = scenario.law() if mode == "injected" else None
        model = self.ball_model(scenario, params, dt, law, phase=settings.phase)
        return run_ball(model, scenario, dt, settings.max_time_s, meta, settings.phase)

    def run_pair(self, scenario: RigidFlexible, mode: str, settings: RunSettings
                 ) -> ImpactRecord:
        dt = float(settings.timestep_s)
        params, meta = self.parameters(scenario, mode, settings, ball=False)
        law = scenario.local_law() if mode == "injected" else None
        model = self.pair_model(scenario, params, dt, law)
        threshold = getattr(law, "contact_threshold", None)
        return run_pair(model, scenario, dt, settings.max_time_s, meta, threshold)

    def run_bounce(self, scenario: Bounce, mode: str, settings: RunSettings) -> ImpactRecord:
        """The bounce to rest: the ball's model for ``mode`` at its first impact
        (:meth:`Bounce.ball`), built with the ball at rest ``height_m`` above the plate
        (``drop_height_m``), stepped by :func:`run_bounce`."""
        dt = float(settings.timestep_s)
        ball = scenario.ball()
        params, meta = self.parameters(ball, mode, settings, ball=True)
        law = ball.law() if mode == "injected" else None
        model = self.ball_model(ball, params, dt, law, drop_height_m=scenario.height_m)
        threshold = self.bounce_threshold(model)
        if threshold is not None:
            meta["bounce_threshold_m_s"] = threshold
        return run_bounce(model, scenario, dt, settings.max_time_s, meta)

    def bounce_threshold(self, model: SteppedModel) -> float | None:
        """The restitution velocity threshold (m/s) the engine applies to ``model``'s ball,
        read back from the engine (below it a rigid contact does not bounce); None for an
        engine or mode without one."""
        return None

    @abstractmethod
    def oblique_parameters(self, scenario: Oblique, mode: str, settings: RunSettings
                           ) -> tuple[dict[str, Any], dict[str, Any]]:
        """The complete engine parameter set of the oblique impact for ``mode`` (``tuned``:
        native with the tuned file's friction knobs) and the run's meta."""

    def run_oblique(self, scenario: Oblique, mode: str, settings: RunSettings
                    ) -> ImpactRecord:
        dt = float(settings.timestep_s)
        params, meta = self.oblique_parameters(scenario, mode, settings)
        contact = CoulombContact(scenario, dt) if mode == "injected" else None
        model = self.oblique_model(scenario, params, dt, contact)
        return run_oblique(model, scenario, dt, settings.max_time_s, meta)


TunedCheck = Callable[[str, RunSettings], ImpactRecord | None]
"""A builder's ``tuned`` check (:attr:`~impactbench.engines.base.Builder.tuned_check`)."""


def builders(oblique_tuned_check: TunedCheck, engine_3d: str | None = None,
             bounce_s: float | None = None) -> dict[str, Builder]:
    """A stepped engine's :attr:`~impactbench.engines.base.Adapter.builders`: the ball, the
    2-DOF pair and the oblique impact, whose ``tuned`` runs ``oblique_tuned_check`` decides
    (:func:`impactbench.engines.oblique_tuned.refused`, which imports this module, so the
    adapter passes it in); a 3D engine (``engine_3d``, its name) adds the cube tosses; the
    bounce to rest runs at ``bounce_s``, the engine's customary step, where given."""
    return scenario_builders(ball_s=1e-6, pair_s=1e-5, oblique_s=OBLIQUE_TIMESTEP_S,
                             oblique_tuned_check=oblique_tuned_check, engine_3d=engine_3d,
                             pair_run="run_pair", bounce_s=bounce_s)
