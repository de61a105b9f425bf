"""pymunk (Chipmunk2D) adapter: the ball is a circle, the 2-DOF bodies are circles on the x axis.

pymunk is 2D and its contacts are *rigid*: one velocity-level impulse per step, with a
restitution target ``vₙ⁺ = −e·vₙ⁻`` (e = the product of the two shapes' elasticities). A rigid
contact has no compliance and hence no duration: what it reports is one impulse J in one step.
Everything here is in SI units (m, kg, s, N); ``space.collision_slop = 0`` (its default, 0.1,
would be 10 cm of allowed overlap) and ``space.iterations`` (default 10) is stated in the meta.

Time stepping (checked on pymunk 7.3.1): ``space.step(dt)`` first drifts every body,
x ← x + v·dt, then runs collision detection and the ``pre_solve`` callbacks at the *new*
positions, then kicks, v ← v + (F/m + g)·dt, with the forces set in ``pre_solve``, then solves
the rigid contacts and joints (``DampedSpring`` applies k·(L − d)·dt from the new positions
too). A force applied in ``pre_solve`` is therefore semi-implicit (symplectic) Euler in its
drift–kick form, x_{k+1} = x_k + v_k·dt, v_{k+1} = v_k + F(x_{k+1}, v_k)·dt/m — for an
elastic force a symplectic, leapfrog-equivalent scheme, not the explicit Euler that a force
set before ``space.step`` would give. Measured on the paper's ball at V0 = 5 m/s, elastic
(b = 0): restitution 0.99994 at dt = 1e-6 s and 0.9999999 at 1e-7 s (explicit Euler, force
from the state before the step: 1.078 and 1.0075 — it gains energy).
The damping term sees the pre-kick velocity v_k, half a step behind x_{k+1}: that adds
≈ b·|ẍ|·dt/2 relative to the force (≈ 1e-3 at the V0 = 5 m/s peak at dt = 1e-7 s), an
error of first order in dt on peak force, duration and max penetration (at dt = 1e-7 s:
+6.1e-4, −3.5e-4, −2.6e-4 at 5 m/s; +1.1e-4, −5.9e-5, −4.2e-5 at 1 m/s), which cancels
between compression and restitution in the restitution (−1.1e-7 at 1e-7 s, −2.7e-5 at 1e-6 s).

Samples (``impactbench.engines.common.Recorder``'s layout: sample k = the state at the start of a
step and
the force the engine applies over it; t_k = k·dt; the samples are gathered in a flat list and
turned into arrays once, because ``Recorder.append``'s per-sample numpy write costs ~0.4 µs,
a third of a bare pymunk step):

- penalty force: the force is computed from the post-drift position, so the step is read as
  kick-then-drift: sample k = (x_k after k drifts, the velocity entering the kick, the force
  F(x_k, ·) of that kick). Force and penetration stay aligned (∮F dx is right).
- rigid impulse: sample k = (x_k, v_k before ``space.step``, J/dt of that step's impulse), the
  next sample carrying the velocity after it — the velocity jump sits between the two samples,
  where the metrics' interpolation expects it, so the measured restitution is exactly the
  solver's.

Ball-on-plate: a circle (radius R, mass m, infinite moment: friction is 0 and it must not spin)
moving along −y onto a static thick segment (radius 0.5 m, core at y = −0.5 m, so its top face
is y = 0: a step as long as 1/60 s cannot carry the ball past it), starting 2 + phase steps of
free flight away (:func:`~impactbench.engines.base.ball_gap_m`: 2.5 at the default phase);
penetration x = R − y. Gravity ``scenario.gravity_m_s2`` acts along −y.

- ``native``: rigid contact with circle elasticity e and plate elasticity 1, so the pair
  restitution is e = k_ref, the reference's restitution at the reference velocity v_ref
  (``impactbench.engines.common.NATIVE_REFERENCE_VELOCITY_M_S``, 1 m/s, or
  ``settings.options["reference_velocity_m_s"]``): e = hunt_crossley.solve(V0 = v_ref)
  ["restitution"], as a user would set a constant coefficient of restitution. The force sample
  is ``arbiter.total_impulse`` / dt from ``post_solve``. Honest consequence: restitution is
  right at v_ref only (Hunt–Crossley's k falls with α = b·V0: 0.937 at 1 m/s, 0.748 at
  5 m/s), and duration, peak force, max penetration and the loss fraction are one-step
  artefacts (duration 2·dt as located by the metrics, peak = m·(1+e)·V0/dt, the penetration
  sample is the pre-step one) that say nothing about the physics: a rigid contact has no
  duration.
- ``injected`` (``settings.options["injection"] = "penalty"``, the default): a compliant
  Hunt–Crossley penalty contact. pymunk *cannot* run a force law through its own contact
  (injection's meaning elsewhere: the law through the engine's contact integration, see
  :attr:`PymunkAdapter.injection`): its contacts are rigid velocity-level impulses. The law
  therefore bypasses the contact solver and is integrated by pymunk's body step (drift–kick,
  symplectic), which is what injected numbers measure here. In ``pre_solve`` the rigid
  contact is rejected (``arbiter.process_collision = False``), x = R − y is read from the
  geometry (the handler runs exactly while the shapes overlap, i.e. x > 0, so first touch is
  the first step that ends in overlap) and F = c·xⁿ·(1 + b·ẋ) (the scenario's
  ``HuntCrossley`` object) is applied to the ball. That force is the engine's contact output
  in this mode.
- ``injected`` with ``injection = "restitution"``: the rigid contact kept, with
  ``arbiter.restitution`` set in ``pre_solve`` to Hunt–Crossley's k(α = b·ẋ) for the current
  approach speed ẋ (closed form, ``impactbench.reference.hunt_crossley.restitution``). Restitution
  then
  matches the reference at every velocity; duration and force stay one-step artefacts.
- ``tuned``: ``settings.tuned["elasticity"]`` (pair restitution) replaces e; otherwise
  ``unsupported``.

- ``default``: pymunk out of the box: elasticity 0 on both shapes (pymunk's default; the pair
  restitution is the product), ``collision_slop`` 0.1, ``collision_bias`` (1 − 0.1)^60,
  ``iterations`` 10, ``damping`` 1 — only geometry, mass, the step, gravity and zero friction
  are set.
  ``meta["engine_defaults"]`` holds the values read back from the space and shapes.
- ``custom``: ``default`` plus ``settings.params`` by pymunk's own names
  (:data:`PARAMETER_KEYS`): ``elasticity`` (pair restitution: the ball gets it, the plate 1),
  ``collision_slop``, ``collision_bias``, ``iterations``, ``damping``.

Rigid–flexible: body 1 (circle, m1) moves along +x at v1 into body 2 (circle, m2), which a
``GrooveJoint`` keeps on the x axis (infinite moments) and a ``DampedSpring`` (damping 0,
anchored far to its right, rest length L) ties to the ground: force k2·x2 for the linear
structure, the cubic softening k2·x2 − β·x2³ through a replaced ``force_func``. Positions are
measured from first touch: x1 = x_body1 + h, x2 = x_body2 − h (h the circles' radius), Δx = x1 − x2.

- ``native``: rigid contact with pair elasticity 1. A contact spring k1 without damping stores
  and returns all the energy it takes, so the rigid model a user would pick for it is the
  perfectly elastic one, e = 1. It cannot express k1: every impact is a one-step impulse, so
  the pulse width is the time between the first and last impacts, and the peak force is an
  impulse divided by dt (both dt artefacts; reported as they are).
- ``injected``: the scenario's local law (``scenario.local_law()``, with its memory) as a penalty
  force: in ``pre_solve`` F1 = law.force(Δx), then law.update(Δx) (every step is accepted),
  applied as −F1 to body 1 and +F1 to body 2, the rigid contact rejected.
- ``tuned``: ``settings.tuned["elasticity"]`` replaces e = 1.

The run stops when ``impactbench.reference.laws.no_further_contact`` holds (with the local law's
permanent
set; after a collapse of the softening structure — body 2's energy ½·m2·v2² + Π(x2) rising
above ``collapse_energy`` = k2²/(4β) in a contact, the reference's rule: status
``structure_collapsed`` — once body 2 has escaped past the potential's peak), or at the time
cap (``settings.max_time_s`` or ``scenario.max_time_s``; status ``max_time``). The ball
stops a few steps after it lets go (moving away, no force, no overlap), or as ``tunneled``
once its centre is past the plate.

Oblique impact (:class:`~impactbench.reference.oblique_scenario.Oblique`, gravity off): the
ball is a circle with the scenario's moment of inertia — the sphere's (2/5)·m·R² by default (a
sphere's oblique impact on a plane is planar, so the circle carries its motion exactly and the
sphere's references apply), a disc's m·R²/2 with ``shape = "disc"`` (the disc's references;
the records are marked ``planar``, :data:`impactbench.engines.oblique_common.PLANAR`) — moving
along +x and −y onto the same segment; spin ω about n × t = −z (ω = −angular_velocity).
Friction: Chipmunk's Coulomb in the rigid contact, the pair's μ the product of the shapes'
(ball μ, plate 1). Tangential force: pymunk's own contact impulse (``total_impulse``'s x) / dt.

- ``native``: rigid contact with the ball's native elasticity and μ: the rigid Coulomb theory
  to round-off with the contact's own restitution (e at 1 m/s).
- ``injected``: the normal law as the penalty force and ideal Coulomb friction as a force and
  torque at the contact point, −s·m_s/dt clipped to ±μ·F_n from the state the handler sees
  (:func:`impactbench.engines.stepping.coulomb_force`); ``injection = "restitution"``: the
  rigid contact with the law's restitution k(b·ẋ) and pymunk's own friction μ.
- ``default``: out of the box (elasticity 0, slop 0.1 m, …) with the scenario's μ;
  ``custom``: that plus ``settings.params`` (``friction`` the pair's μ); ``tuned``:
  ``unsupported`` (no fit covers friction).

Bounce to rest (:class:`~impactbench.reference.bounce_scenario.Bounce`): the ball's space and
contact for each mode (:func:`ball_model` with the first impact's ball, ``Bounce.ball()``), the
ball built at rest with its lowest point ``height_m`` above the plate (the same 0.5 m-thick
segment, ±10·R wide: the ball moves along y only), gravity along −y throughout, stepped by
:func:`run_bounce` until :class:`~impactbench.engines.bounce.BounceEnd` ends it; default step
1/60 s. Chipmunk applies restitution at every speed: ``cpArbiterPreStep`` (Chipmunk2D
src/cpArbiter.c) sets each contact's target ``bounce = vₙ·e`` with no velocity threshold, so no
``bounce_threshold_m_s`` is recorded (measured: a 2 mm drop, 0.2 m/s, at dt = 1 ms rises to
e²·h within 0.15 %). Nothing else eats a bounce:

- ``collision_bias`` (beyond ``collision_slop``) corrects overlap through separate bias
  velocities (``v_bias``, ``jBias`` in ``cpArbiterApplyImpulse``) that move the body but never
  enter its velocity. With slop 0 (native, tuned, injected restitution) it lifts a ball resting
  in the plate clear of it, and each re-touch is a fresh rigid impact: at 1/60 s a contact
  with e > 0 never rests but cycles every 3 steps at |ẋ| ≈ 2·g·dt/(1 + e) (status
  ``max_time``; with ``collision_bias`` 1, no correction, it rests). Out of the box (slop
  0.1 m) the ball stays embedded, up to v·dt deep, in a persisting contact and rests.
- ``collision_persistence`` (3 steps): a contact touching again within 3 steps of separating
  keeps its old accumulated impulse (copied by contact hash in ``cpArbiterUpdate``) but skips
  its warm start (``cpArbiterApplyCachedImpulse``: a first contact again), so
  ``total_impulse`` reports that stale impulse plus this step's (hundreds of N that never
  acted, growing bounce by bounce). The force recorded is the accumulated impulse less the
  stale one, read in ``pre_solve`` (:meth:`BallModel._stale_impulse`): it equals the momentum
  change m·(Δẋ + g·dt) to round-off. The stale impulse also loosens the solver's clamp (a
  pull of up to it), which only a ball re-touching while moving away could meet: none does.

Options (``settings.options``): ``injection`` (ball, injected mode: penalty | restitution),
``reference_velocity_m_s`` (native ball), ``iterations`` (pymunk solver iterations, default
10). Tuned keys (``settings.tuned``): ``elasticity`` (pair restitution, both scenarios).

Default timesteps: ball and oblique 1e-6 s in every mode; bounce 1/60 s; rigid–flexible
1e-5 s (injected at 3.3 m/s: linear/linear and elastoplastic/linear within 2e-7 of the
reference on peak, pulse width and impulse, mutation within 4e-5).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from functools import lru_cache
from typing import Any, ClassVar

import numpy as np
from impactbench.engines import oblique_common, oblique_tuned, stepping
from impactbench.engines.base import (
    CUBE_TOSS_TWO_D,
    RIGID_FLEXIBLE_MODES,
    Adapter,
    RunSettings,
    Scenario,
    ball_gap_m,
    ball_phase,
    checked_params,
    import_engine,
    scenario_builders,
)
from impactbench.engines.bounce import BounceEnd
from impactbench.engines.common import (
    NATIVE_REFERENCE_VELOCITY_M_S,
    Recorder,
    classify,
)
from impactbench.reference import validation as check
from impactbench.reference.bounce_scenario import Bounce
from impactbench.reference.oblique_scenario import Oblique
from impactbench.reference.record import ImpactRecord
from impactbench.reference.scenarios import BallOnPlate, RigidFlexible
from impactbench.reference.validation import InvalidValue

INJECTIONS: tuple[str, ...] = ("penalty", "restitution")
"""``settings.options["injection"]`` values for the ball in injected mode."""

GAP_STEPS = 2.5
"""Free flight before first touch, in steps (non-integer: touch falls inside a step): the
rigid–flexible pair's and the oblique ball's; the head-on ball's is 2 + ``RunSettings.phase``
(:func:`~impactbench.engines.base.ball_gap_m`), this at the default phase."""

TAIL_STEPS = 2
"""Samples recorded after the ball has let go (the metrics locate the end between samples)."""

BALL_TIME_CAP_S = 2e-3
"""Default ball time cap after first touch (s): ~20 contact durations of the paper's ball."""

PARAMETER_KEYS: tuple[str, ...] = ("elasticity", "collision_slop", "collision_bias",
                                   "iterations", "damping", "friction")
"""``custom``-mode keys (pymunk's Shape/Space attribute names; ``friction``: the pair's, the
ball's shape with the plate's 1, as ``elasticity``; oblique scenario only)."""
OBLIQUE_KEYS: tuple[str, ...] = ("friction",)
"""``custom`` keys only the oblique scenario uses (a head-on ball has no friction)."""
THICK_PLATE_RADIUS_M = 0.5
MIN_CAP_STEPS = 50
"""The ball's time cap is at least this many steps (a coarse step: 2 ms is two steps)."""
OUT_OF_BOX_TIME_CAP_S = 0.5
"""``default``/``custom`` cap after first touch (s): an inelastic ball may never let go."""


def _import_pymunk() -> Any:
    return import_engine("pymunk", "pymunk")


def _space(pymunk: Any, iterations: int, gravity_m_s2: float) -> Any:
    space = pymunk.Space()
    space.collision_slop = 0.0
    space.iterations = iterations
    space.gravity = (0.0, -gravity_m_s2)
    return space


def _iterations(settings: RunSettings) -> int:
    it = settings.options.get("iterations", 10)
    if isinstance(it, bool) or not isinstance(it, int) or it < 1:
        raise ValueError(f"options.iterations = {it!r}: must be an integer >= 1")
    return it


SPACE_KEYS = ("collision_slop", "collision_bias", "iterations", "damping")
"""The ``custom`` keys that are the space's attributes."""


def _defaults(space: Any, ball: Any, plate: Any, friction: bool = False) -> dict[str, Any]:
    """pymunk's out-of-the-box contact settings, read from a fresh space and shapes (the
    shapes' elasticity and, with ``friction``, friction; the space's :data:`SPACE_KEYS`)."""
    out = {"elasticity": ball.elasticity, "plate_elasticity": plate.elasticity}
    if friction:
        out.update(friction=ball.friction, plate_friction=plate.friction)
    return {**out, **{key: getattr(space, key) for key in SPACE_KEYS}}


def _set_contact(space: Any, ball: Any, plate: Any, elasticity: float,
                 out_of_box: dict[str, Any] | None) -> None:
    """The pair's elasticity on the ball, the plate's 1 (Chipmunk multiplies them): the run's
    ``elasticity``, or out of the box the user's (``out_of_box``, with its space keys) over
    pymunk's defaults."""
    if out_of_box is None:
        ball.elasticity, plate.elasticity = elasticity, 1.0
        return
    for key in SPACE_KEYS:
        if key in out_of_box:
            setattr(space, key, out_of_box[key])
    if "elasticity" in out_of_box:
        ball.elasticity, plate.elasticity = out_of_box["elasticity"], 1.0


class BallModel:
    """The ball-on-plate space, with its contact handler installed.

    Args:
        scenario: the ball (mass, radius, velocity, law, gravity).
        contact: ``"rigid"`` (elasticity ``elasticity``), ``"penalty"`` (Hunt–Crossley force)
            or ``"restitution"`` (rigid, restitution k(b·ẋ) set each step).
        dt: the timestep (s), for the impulse → force conversion and the initial gap.
        measure: install the ``post_solve`` hook that reads the rigid impulse (the bare
            benchmark loop leaves it out; the penalty force is the model itself).
        drop_height_m: start the ball at rest with its lowest point this high (m) above the
            plate (the bounce to rest) instead of its gap at V0.
        phase: where first touch falls inside a step: the gap is
            :func:`~impactbench.engines.base.ball_gap_m`, 2 + phase steps of flight (None:
            the default phase, :data:`GAP_STEPS` steps); kept as ``phase``.

    ``force_n`` holds the contact force of the last step in which the handler ran; the
    caller zeroes it before each step.
    """

    def __init__(self, scenario: BallOnPlate, contact: str, dt: float, *,
                 elasticity: float = 1.0, iterations: int = 10, measure: bool = True,
                 out_of_box: dict[str, Any] | None = None,
                 drop_height_m: float | None = None, phase: float | None = None) -> None:
        pymunk = _import_pymunk()
        self.scenario, self.contact, self.dt = scenario, contact, dt
        dropped = drop_height_m is not None
        self.phase = ball_phase(phase)
        self.gap_m = (drop_height_m if dropped
                      else ball_gap_m(scenario.velocity_m_s, dt, phase))
        if out_of_box is None:
            self.space = space = _space(pymunk, iterations, scenario.gravity_m_s2)
        else:
            self.space = space = pymunk.Space()
            space.gravity = (0.0, -scenario.gravity_m_s2)
        radius = scenario.radius_m
        self.body = body = pymunk.Body(scenario.mass_kg, math.inf)
        body.position = (0.0, radius + self.gap_m)
        body.velocity = (0.0, 0.0 if dropped else -scenario.velocity_m_s)
        ball = pymunk.Circle(body, radius)
        half = 10.0 * radius
        h = THICK_PLATE_RADIUS_M
        plate = pymunk.Segment(space.static_body, (-half, -h), (half, -h), h)
        if out_of_box is not None:
            self.defaults = _defaults(space, ball, plate)
        _set_contact(space, ball, plate, elasticity, out_of_box)
        ball.friction = plate.friction = 0.0
        self.out_of_box = out_of_box is not None
        self.beyond_m = radius + THICK_PLATE_RADIUS_M  # tunnelled: past the plate's core
        space.add(body, ball, plate)
        self._position, self._velocity, self._handle = _readers(body)
        self.force_n = self._stale_n_s = 0.0
        if contact == "penalty":
            space.on_collision(pre_solve=self._penalty)
            self._law = scenario.law()
        elif contact == "restitution":
            from impactbench.reference.hunt_crossley import restitution

            self._restitution, self._b = restitution, scenario.damping_s_per_m
            space.on_collision(pre_solve=self._set_restitution,
                               post_solve=self._impulse if measure else None)
        elif contact == "rigid":
            if measure:
                space.on_collision(pre_solve=self._stale_impulse, post_solve=self._impulse)
        else:
            raise ValueError(f"contact = {contact!r}: must be rigid, penalty or restitution")

    def _penalty(self, arbiter: Any, _space: Any, _data: Any) -> None:
        arbiter.process_collision = False
        h = self._handle
        f = self._law.force(self.scenario.radius_m - self._position(h).y,
                            -self._velocity(h).y)
        self.body.force = (0.0, f)
        self.force_n = f

    def _set_restitution(self, arbiter: Any, space: Any, data: Any) -> None:
        vy = self._velocity(self._handle).y
        # still overlapping while already separating (low restitution): α = b·max(0, V)
        arbiter.restitution = float(self._restitution(max(0.0, -self._b * vy)))
        self._stale_impulse(arbiter, space, data)

    def _stale_impulse(self, arbiter: Any, _space: Any, _data: Any) -> None:
        """Before the solver (``pre_solve``): the impulse (N·s) Chipmunk's accumulator starts
        from without having applied it. A contact that touches again within
        ``collision_persistence`` steps (3) of separating is a first contact again
        (``cpArbiterUpdate``), so ``cpArbiterApplyCachedImpulse`` skips its warm start, yet
        ``cpArbiterUpdate`` has copied the old accumulated impulse ``jnAcc`` into it (matching
        contact hash): ``total_impulse`` then reports the old contact's impulse plus this
        step's (a ball bouncing at a coarse step: hundreds of N that never acted). A
        persisting contact's warm start is applied, so its ``jnAcc`` is all this step's."""
        self._stale_n_s = arbiter.total_impulse.length if arbiter.is_first_contact else 0.0

    def _impulse(self, arbiter: Any, _space: Any, _data: Any) -> None:
        """After the solver (``post_solve``): the impulse applied this step / dt (N)."""
        self.force_n = (arbiter.total_impulse.length - self._stale_n_s) / self.dt


def _flat_length(scenario: RigidFlexible) -> float:
    """A length (m) comfortably beyond any displacement of the run: body radius and spring."""
    soft = min(scenario.k1_n_per_m, scenario.kt_n_per_m, scenario.k1_failed_n_per_m,
               scenario.k2_n_per_m)
    amplitude = scenario.velocity_m_s * math.sqrt(max(scenario.m1_kg, scenario.m2_kg) / soft)
    return max(1.0, 20.0 * amplitude)


class RigidFlexibleModel:
    """The 2-DOF space: two circles on the x axis, body 2 on a groove and a spring.

    Args:
        scenario: the 2-DOF set-up (masses, laws, v1).
        contact: ``"rigid"`` (pair elasticity ``elasticity``) or ``"penalty"`` (local law).
        dt: the timestep (s).
        measure: install the ``post_solve`` impulse hook (rigid contact only).
    """

    def __init__(self, scenario: RigidFlexible, contact: str, dt: float, *,
                 elasticity: float = 1.0, iterations: int = 10, measure: bool = True) -> None:
        pymunk = _import_pymunk()
        self.scenario, self.contact, self.dt = scenario, contact, dt
        self.gap_m = GAP_STEPS * scenario.velocity_m_s * dt
        self.h = h = _flat_length(scenario)
        self.spring_length = length = h
        self.space = space = _space(pymunk, iterations, 0.0)
        self.body1 = b1 = pymunk.Body(scenario.m1_kg, math.inf)
        self.body2 = b2 = pymunk.Body(scenario.m2_kg, math.inf)
        b1.position, b1.velocity = (-h - self.gap_m, 0.0), (scenario.velocity_m_s, 0.0)
        b2.position = (h, 0.0)
        s1, s2 = pymunk.Circle(b1, h), pymunk.Circle(b2, h)
        s1.friction = s2.friction = 0.0
        s1.elasticity, s2.elasticity = elasticity, 1.0
        self.structure = structure = scenario.structural_law()
        spring = pymunk.DampedSpring(space.static_body, b2, (h + length, 0.0), (0.0, 0.0),
                                     length, scenario.k2_n_per_m, 0.0)
        if structure.name != "linear":
            spring.force_func = lambda _s, dist: structure.force(length - dist)
        groove = pymunk.GrooveJoint(space.static_body, b2, (-1e3 * h, 0.0), (1e3 * h, 0.0),
                                    (0.0, 0.0))
        space.add(b1, b2, s1, s2, spring, groove)
        self._position, _, self._h1 = _readers(b1)
        self._h2 = _readers(b2)[2]
        self.force_n = 0.0
        self.law = scenario.local_law() if contact == "penalty" else None
        if contact == "penalty":
            space.on_collision(pre_solve=self._penalty)
        elif contact == "rigid":
            if measure:
                space.on_collision(post_solve=self._impulse)
        else:
            raise ValueError(f"contact = {contact!r}: must be rigid or penalty")

    def positions(self) -> tuple[float, float]:
        """(x1, x2) from first touch (m)."""
        return self.body1.position.x + self.h, self.body2.position.x - self.h

    def _penalty(self, arbiter: Any, _space: Any, _data: Any) -> None:
        arbiter.process_collision = False
        position = self._position
        dx = position(self._h1).x - position(self._h2).x + 2.0 * self.h
        law = self.law
        f = law.force(dx)
        law.update(dx)
        self.body1.force = (-f, 0.0)
        self.body2.force = (f, 0.0)
        self.force_n = f

    def _impulse(self, arbiter: Any, _space: Any, _data: Any) -> None:
        self.force_n = arbiter.total_impulse.length / self.dt


class ObliqueModel:
    """The oblique impact's space: the ball (a circle with the scenario's moment of inertia,
    :attr:`~impactbench.reference.oblique_scenario.Oblique.moment_of_inertia_kg_m2`: the
    sphere's (2/5)·m·R² — a sphere's oblique impact on a plane is planar, so the circle
    carries its motion exactly — or a disc's m·R²/2) moving along +x and −y onto the plate
    segment; spin ω about n × t = −z.

    Args:
        scenario: the oblique impact.
        contact: ``"rigid"`` (elasticity ``elasticity``, pymunk's Coulomb friction),
            ``"penalty"`` (the normal law and ideal Coulomb friction as forces, the contact
            rejected) or ``"restitution"`` (rigid, restitution k(b·ẋ) set each step, pymunk's
            friction).
        dt: the timestep (s).
        friction: the pair's μ (the ball's shape; the plate's is 1, pymunk multiplies them).
        out_of_box: as :class:`BallModel`'s (default and custom modes).

    ``force_n``, ``force_t`` hold the normal and tangential force on the ball of the last
    step in which the handler ran; the caller zeroes them before each step.
    """

    def __init__(self, scenario: Oblique, contact: str, dt: float, *, friction: float,
                 elasticity: float = 1.0, iterations: int = 10,
                 out_of_box: dict[str, Any] | None = None) -> None:
        pymunk = _import_pymunk()
        self.scenario, self.contact, self.dt = scenario, contact, dt
        v_n = scenario.normal_velocity_m_s
        self.gap_m = GAP_STEPS * v_n * dt
        if out_of_box is None:
            self.space = space = _space(pymunk, iterations, 0.0)
        else:
            self.space = space = pymunk.Space()
        self.radius = radius = scenario.radius_m
        self.body = body = pymunk.Body(scenario.mass_kg, scenario.moment_of_inertia_kg_m2)
        body.position = (0.0, radius + self.gap_m)
        body.velocity = (scenario.tangential_velocity_m_s, -v_n)
        body.angular_velocity = -scenario.spin_rad_s
        ball = pymunk.Circle(body, radius)
        h = THICK_PLATE_RADIUS_M
        plate = pymunk.Segment(space.static_body, (-10.0, -h), (10.0, -h), h)
        if out_of_box is not None:
            self.defaults = _defaults(space, ball, plate, friction=True)
        _set_contact(space, ball, plate, elasticity, out_of_box)
        ball.friction, plate.friction = friction, 1.0
        self.out_of_box = out_of_box is not None
        self.beyond_m = radius + THICK_PLATE_RADIUS_M
        space.add(body, ball, plate)
        self.force_n = self.force_t = 0.0
        if contact == "penalty":
            self._law = stepping.CoulombContact(scenario, dt)
            space.on_collision(pre_solve=self._penalty)
        elif contact == "restitution":
            from impactbench.reference.hunt_crossley import restitution

            self._restitution = restitution
            self._b = scenario.normal_scenario().law().damping
            space.on_collision(pre_solve=self._set_restitution, post_solve=self._impulse)
        elif contact == "rigid":
            space.on_collision(post_solve=self._impulse)
        else:
            raise ValueError(f"contact = {contact!r}: must be rigid, penalty or restitution")

    def state(self) -> tuple[float, float, float, float]:
        """(x, ẋ, v_t, ω): penetration, its rate, tangential velocity and spin."""
        body = self.body
        (vx, vy), (_, y) = body.velocity, body.position
        return self.radius - y, -vy, vx, -body.angular_velocity

    def _penalty(self, arbiter: Any, _space: Any, _data: Any) -> None:
        arbiter.process_collision = False
        fn, ft = self._law.forces(*self.state())
        body = self.body
        body.force = (ft, fn)
        body.torque = self.radius * ft  # (0, −R) × (F_t, F_n) along z
        self.force_n, self.force_t = fn, ft

    def _set_restitution(self, arbiter: Any, _space: Any, _data: Any) -> None:
        vy = self.body.velocity.y
        arbiter.restitution = float(self._restitution(max(0.0, -self._b * vy)))

    def _impulse(self, arbiter: Any, _space: Any, _data: Any) -> None:
        jx, jy = arbiter.total_impulse
        sign = 1.0 if jy >= 0.0 else -1.0  # the impulse on the ball pushes it up
        self.force_n, self.force_t = sign * jy / self.dt, sign * jx / self.dt


class PymunkAdapter(Adapter):
    """pymunk 7 (Chipmunk2D): rigid contacts natively, penalty forces when injected."""

    name = "pymunk"
    value_check = staticmethod(lambda params: custom_parameters(params))  # defined below
    modes = ("native", "injected", "tuned", "default", "custom")
    parameter_keys = PARAMETER_KEYS
    injection = ("cannot: pymunk's contacts are rigid impulses with no compliance; the law is "
                 "a penalty force (contact rejected) integrated by pymunk's drift–kick step; "
                 "oblique: Coulomb friction is a force and torque too, −s·m_s/dt clipped to "
                 "±μ·F_n (options injection = restitution: pymunk's own rigid contact and "
                 "Coulomb friction, with the law's restitution)")
    tuned_parameters = "elasticity"
    builders = scenario_builders(
        ball_s=1e-6, pair_s=1e-5, oblique_s=1e-6, oblique_tuned_check=oblique_tuned.refused,
        pair_modes=RIGID_FLEXIBLE_MODES,
        ball_keys=tuple(k for k in PARAMETER_KEYS if k not in OBLIQUE_KEYS),
        # 1/60 s: pymunk's examples' step (examples/bouncing_balls.py: self._dt = 1.0 / 60.0) and
        # the step its collision_bias default is set for (space.py: 10 % per 1/60th of a s)
        bounce_s=1.0 / 60.0)
    missing_builders: ClassVar[dict[str, str]] = {"cube-toss": CUBE_TOSS_TWO_D.format("pymunk")}

    def version(self) -> str:
        return str(_import_pymunk().version)

    def run_ball(self, scenario: BallOnPlate, mode: str, settings: RunSettings) -> ImpactRecord:
        return self._run_with(ball_model, run_ball, scenario, mode, settings)

    def run_bounce(self, scenario: Bounce, mode: str, settings: RunSettings) -> ImpactRecord:
        """The bounce to rest: the ball's space and contact for ``mode`` at the first impact
        (:meth:`Bounce.ball`, :func:`ball_model`), the ball built at rest ``height_m`` above
        the plate, stepped by :func:`run_bounce`. Chipmunk has no restitution velocity
        threshold (see the module), so no ``bounce_threshold_m_s`` is recorded."""
        dt = float(settings.timestep_s)  # Adapter.run fills the default
        model, meta = ball_model(scenario.ball(), mode, settings, dt, _iterations(settings),
                                 drop_height_m=scenario.height_m)
        return run_bounce(model, scenario, settings.max_time_s, meta)

    def run_rigid_flexible(self, scenario: RigidFlexible, mode: str, settings: RunSettings
                           ) -> ImpactRecord:
        return self._run_with(rigid_flexible_model, run_rigid_flexible, scenario, mode,
                              settings)

    def run_oblique(self, scenario: Oblique, mode: str, settings: RunSettings
                    ) -> ImpactRecord:
        return self._run_with(oblique_model, run_oblique, scenario, mode, settings)

    def _run_with(self, build: Callable[..., tuple[Any, dict[str, Any]]],
                  run: Callable[[Any, RunSettings, dict[str, Any]], ImpactRecord],
                  scenario: Scenario, mode: str, settings: RunSettings) -> ImpactRecord:
        """What every scenario shares: the step and the solver iterations, then
        ``build(scenario, mode, settings, dt, iterations)`` and ``run``."""
        dt = float(settings.timestep_s)  # Adapter.run fills the default
        iterations = _iterations(settings)
        model, meta = build(scenario, mode, settings, dt, iterations)
        return run(model, settings, meta)


def _tuned_elasticity(settings: RunSettings) -> float:
    value = (settings.tuned or {}).get("elasticity")
    return check.non_negative("tuned.elasticity", value)


RIGID_BALL_ARTEFACTS = stepping.RIGID_BALL_ARTEFACTS
RIGID_RF_ARTEFACTS = stepping.RIGID_RF_ARTEFACTS
"""``meta["not_comparable"]`` of a rigid (one-step impulse) contact: the stepped engines'."""


@lru_cache(maxsize=256)
def _reference_restitution(scenario: BallOnPlate) -> float:
    """Hunt–Crossley restitution of ``scenario`` (cached: sweeps map the same v_ref again)."""
    from impactbench.reference import hunt_crossley

    return float(hunt_crossley.solve(scenario)["restitution"])


def _fraction(field: str, value: object) -> float:
    """A fraction in [0, 1] (a per-step bias or velocity damping factor)."""
    out = check.non_negative(field, value)
    if out > 1.0:
        raise InvalidValue(f"{field} = {value!r}: must be in [0, 1]")
    return out


def custom_parameters(params: dict[str, Any]) -> dict[str, Any]:
    """Validated ``custom`` parameters (pymunk's names; see :data:`PARAMETER_KEYS`)."""
    out = {**checked_params(params, ("elasticity", "collision_slop", "friction"),
                            check.non_negative),
           **checked_params(params, ("collision_bias", "damping"), _fraction)}
    if "iterations" in params:
        it = params["iterations"]
        if isinstance(it, bool) or not isinstance(it, int | float) or it != int(it) or it < 1:
            raise InvalidValue(f"param iterations = {it!r}: must be an integer >= 1")
        out["iterations"] = int(it)
    return out


def ball_model(scenario: BallOnPlate, mode: str, settings: RunSettings, dt: float,
               iterations: int, measure: bool = True, drop_height_m: float | None = None
               ) -> tuple[BallModel, dict[str, Any]]:
    """Build the ball space for ``mode``; returns it and the meta of its parameters.
    ``drop_height_m``: the ball starts at rest that high (m) above the plate (the bounce to
    rest, :class:`BallModel`); else at its gap for ``settings.phase``."""
    phase = settings.phase if drop_height_m is None else None
    if mode in ("default", "custom"):
        params = custom_parameters(settings.params or {}) if mode == "custom" else {}
        model = BallModel(scenario, "rigid", dt, measure=measure, out_of_box=params,
                          drop_height_m=drop_height_m, phase=phase)
        return model, {"contact": "rigid", "params": params,
                       "engine_defaults": model.defaults,
                       "not_comparable": RIGID_BALL_ARTEFACTS}
    meta: dict[str, Any] = {"iterations": iterations, "collision_slop": 0.0}
    if mode == "injected":
        injection = settings.options.get("injection", "penalty")
        check.one_of("options.injection", injection, INJECTIONS)
        contact = "penalty" if injection == "penalty" else "restitution"
        meta.update(injection=injection, contact=contact)
        if contact == "restitution":
            meta["not_comparable"] = RIGID_BALL_ARTEFACTS
        return BallModel(scenario, contact, dt, iterations=iterations, measure=measure,
                         drop_height_m=drop_height_m, phase=phase), meta
    if mode == "tuned":
        tuned = settings.tuned or {}
        if tuned.get("restitution_law") == "hunt_crossley":
            b = check.non_negative("tuned.restitution_damping_s_per_m",
                                   tuned.get("restitution_damping_s_per_m"))
            meta.update(contact="restitution", restitution_damping_s_per_m=b,
                        tuned=dict(tuned), not_comparable=RIGID_BALL_ARTEFACTS)
            return BallModel(scenario.replace(damping_s_per_m=b), "restitution", dt,
                             iterations=iterations, measure=measure,
                             drop_height_m=drop_height_m, phase=phase), meta
        e = _tuned_elasticity(settings)
        meta.update(contact="rigid", elasticity=e, tuned=dict(tuned),
                    not_comparable=RIGID_BALL_ARTEFACTS)
    else:
        v_ref = check.positive(
            "options.reference_velocity_m_s",
            settings.options.get("reference_velocity_m_s", NATIVE_REFERENCE_VELOCITY_M_S))
        e = _reference_restitution(scenario.replace(velocity_m_s=v_ref))
        meta.update(contact="rigid", elasticity=e, reference_velocity_m_s=v_ref,
                    not_comparable=RIGID_BALL_ARTEFACTS)
    model = BallModel(scenario, "rigid", dt, elasticity=e, iterations=iterations,
                      measure=measure, drop_height_m=drop_height_m, phase=phase)
    return model, meta


def rigid_flexible_model(scenario: RigidFlexible, mode: str, settings: RunSettings, dt: float,
                         iterations: int, measure: bool = True
                         ) -> tuple[RigidFlexibleModel, dict[str, Any]]:
    """Build the 2-DOF space for ``mode``; returns it and the meta of its parameters."""
    meta: dict[str, Any] = {"iterations": iterations, "collision_slop": 0.0}
    if mode == "injected":
        meta.update(contact="penalty", local_law=scenario.local)
        model = RigidFlexibleModel(scenario, "penalty", dt, iterations=iterations,
                                   measure=measure)
        return model, meta
    e = _tuned_elasticity(settings) if mode == "tuned" else 1.0
    meta.update(contact="rigid", elasticity=e, not_comparable=RIGID_RF_ARTEFACTS)
    if mode == "tuned":
        meta["tuned"] = dict(settings.tuned or {})
    model = RigidFlexibleModel(scenario, "rigid", dt, elasticity=e, iterations=iterations,
                               measure=measure)
    return model, meta


def _readers(body: Any) -> tuple[Callable[[Any], Any], Callable[[Any], Any], Any]:
    """(position getter, velocity getter, handle) for ``body``; getter(handle) has .x, .y.

    pymunk's own properties build a ``Vec2d`` through a Python property (~0.4 µs each);
    calling Chipmunk's getters through pymunk's cffi module directly costs ~0.1 µs, which
    matters when the bare step is ~1 µs. Falls back to the public properties if pymunk's
    internals move.
    """
    try:
        from pymunk._chipmunk_cffi import lib

        handle = body._body
        lib.cpBodyGetPosition(handle).x  # noqa: B018 - probe the internal API once
        return lib.cpBodyGetPosition, lib.cpBodyGetVelocity, handle
    except (ImportError, AttributeError, TypeError):
        return _public_position, _public_velocity, body


def _public_position(body: Any) -> Any:
    return body.position


def _public_velocity(body: Any) -> Any:
    return body.velocity


def _columns(flat: list[float], width: int) -> np.ndarray:
    """Samples appended flat, ``width`` values each, as a (width, n) array."""
    return np.array(flat, dtype=float).reshape(-1, width).T


def _step_cap(model: BallModel | ObliqueModel, settings: RunSettings, v0: float) -> int:
    """A ball run's step cap: ``max_time_s``, else the free flight and
    :data:`BALL_TIME_CAP_S` (out of the box :data:`OUT_OF_BOX_TIME_CAP_S`), at least
    :data:`MIN_CAP_STEPS` steps; ``v0`` the approach speed (m/s)."""
    dt = model.dt
    cap_s = settings.max_time_s or (model.gap_m / v0 + max(
        OUT_OF_BOX_TIME_CAP_S if model.out_of_box else BALL_TIME_CAP_S, MIN_CAP_STEPS * dt))
    return max(1, math.ceil(cap_s / dt))


class _LetGo:
    """When a ball run stops: :data:`TAIL_STEPS` steps after the ball has let go (a step
    without force after touch, the ball moving away and clear of the plate, or out of the box
    at rest on it: an inelastic rigid contact may leave it there, overlapping), or at once
    when its centre passes the plate's surface or core (``tunneled``)."""

    def __init__(self, model: BallModel | ObliqueModel) -> None:
        self.beyond_m, self.rests = model.beyond_m, model.out_of_box
        self.touched = self.tunneled = False
        self.tail = -1

    def ended(self, f: float, x: float, v: float) -> bool:
        """After a step with normal force ``f`` (N) that left penetration x (m), rate v (m/s)."""
        if f > 0.0:
            self.touched = True
        elif self.tail > 0:
            self.tail -= 1
            if self.tail == 0:
                return True
        elif self.touched and self.tail < 0 and ((v < 0.0 and x <= 0.0)
                                                 or (self.rests and v <= 0.0)):
            self.tail = TAIL_STEPS
        if x > self.beyond_m:
            self.tunneled = True
            return True
        return False


def run_ball(model: BallModel, settings: RunSettings, meta: dict[str, Any]) -> ImpactRecord:
    """Step the ball from its gap until it has let go (or tunnels, diverges, times out).

    Samples are collected in a flat list and turned into the record once at the end (the
    same layout ``impactbench.engines.common.Recorder`` produces: t_k = k·dt, x_k, ẋ_k, F_k, v1_k);
    the
    per-sample numpy write of ``Recorder.append`` (~0.4 µs) would be a third of a bare step.
    """
    sc, dt = model.scenario, model.dt
    radius, v0 = sc.radius_m, sc.velocity_m_s
    n_max = _step_cap(model, settings, v0)
    end = _LetGo(model)
    step = model.space.step
    position, velocity, handle = _readers(model.body)
    impulsive = model.contact != "penalty"
    x, v = -model.gap_m, v0
    flat = [] if impulsive else [x, v, 0.0]
    push = flat.extend
    nonfinite = False
    for _ in range(n_max):
        model.force_n = 0.0
        step(dt)
        f = model.force_n
        if impulsive:
            push((x, v, f))
            x = radius - position(handle).y
        else:
            x = radius - position(handle).y
            push((x, v, f))
        v = -velocity(handle).y
        if end.ended(f, x, v):
            break
        if not (math.isfinite(x) and math.isfinite(v)):
            nonfinite = True
            break
    if impulsive:
        push((x, v, 0.0))
    xs, vs, fs = _columns(flat, 3)
    steps = xs.size - 1
    timed_out = steps == n_max and end.tail != 0 and not (end.tunneled or nonfinite)
    out = ImpactRecord(np.arange(xs.size) * dt, xs, vs, fs, vs, np.zeros_like(vs),
                       mass_1_kg=sc.mass_kg, meta=dict(meta, phase=model.phase, steps=steps))
    vx, vy = model.body.velocity
    return classify(out, initial_kinetic_j=0.5 * sc.mass_kg * v0 * v0,
                    final_kinetic_j=0.5 * sc.mass_kg * (vx * vx + vy * vy),
                    tunneled=end.tunneled, timed_out=timed_out)


def run_bounce(model: BallModel, scenario: Bounce, max_time_s: float | None,
               meta: dict[str, Any]) -> ImpactRecord:
    """Step the dropped ball (built at rest ``height_m`` above the plate) until it rests on
    the plate, tunnels, diverges or reaches the cap (:class:`~impactbench.engines.bounce.
    BounceEnd`), recording every step in :func:`run_ball`'s layout: a rigid contact's sample
    k = (x_k, ẋ_k, J/dt) before ``space.step`` (the velocity jump between samples k and k+1),
    the penalty's (x after the drift, ẋ entering the kick, F of that kick). x = R − y (m),
    ẋ = −ẏ (m/s), F (N).

    Tunnelled: the centre past the plate segment's core (R + 0.5 m, where its normal flips)
    for a rigid contact; past R, the sphere's own size, for the law injected as a force."""
    dt, radius = model.dt, scenario.radius_m
    impulsive = model.contact != "penalty"
    end = BounceEnd(scenario, dt, max_time_s, model.beyond_m if impulsive else radius)
    ended, n_max = end.ended, end.n_max
    step = model.space.step
    position, velocity, handle = _readers(model.body)
    rec = Recorder()
    append = rec.append
    x, v = radius - position(handle).y, -velocity(handle).y
    if not impulsive:
        append(0.0, x, v, 0.0, v)
    k = 0
    while k < n_max:
        model.force_n = 0.0
        step(dt)
        f = model.force_n
        if impulsive:
            append(k * dt, x, v, f, v)
            x = radius - position(handle).y
        else:
            x = radius - position(handle).y
            append((k + 1) * dt, x, v, f, v)
        v = -velocity(handle).y
        k += 1
        if ended(x, v, f):
            break
    if impulsive:
        append(k * dt, x, v, 0.0, v)
    return end.finish(rec, scenario, v, **meta, steps=k)


def run_rigid_flexible(model: RigidFlexibleModel, settings: RunSettings,
                       meta: dict[str, Any]) -> ImpactRecord:
    """Step the 2-DOF model until no further contact is possible, collapse, or the cap.

    Collapse (softening structure) is body 2's energy E2 = ½·m2·v2² + Π(x2) rising above the
    potential's peak k2²/(4β) during a contact: E2 only changes in contact and only rises
    while v2 > 0 (dE2/dt = F1·v2), so from then on x2 runs away — the reference's rule.
    No further contact: ``no_further_contact(x1 − p, …)`` with p the local law's permanent
    set (``contact_threshold()``, 0 for the rigid contact). Recording as in :func:`run_ball`.
    """
    sc, dt = model.scenario, model.dt
    end = stepping.PairEnd(sc, model.structure, getattr(model.law, "contact_threshold", None))
    cap_s = settings.max_time_s or sc.max_time_s
    n_max = max(1, math.ceil(cap_s / dt))
    step = model.space.step
    position, velocity, h1 = _readers(model.body1)
    h2 = _readers(model.body2)[2]
    off1, off2 = model.h, -model.h
    impulsive = model.contact != "penalty"
    x1, x2, v1, v2 = -model.gap_m, 0.0, sc.velocity_m_s, 0.0
    flat = [] if impulsive else [x1, x2, 0.0, v1, v2]
    push = flat.extend
    nonfinite = False
    for _ in range(n_max):
        model.force_n = 0.0
        step(dt)
        f = model.force_n
        if impulsive:
            push((x1, x2, f, v1, v2))
        x1 = position(h1).x + off1
        x2 = position(h2).x + off2
        if not impulsive:
            push((x1, x2, f, v1, v2))
        v1 = velocity(h1).x
        v2 = velocity(h2).x
        if not (math.isfinite(x1) and math.isfinite(x2) and math.isfinite(v1 + v2)):
            nonfinite = True
            break
        if end.ended(f, x1, v1, x2, v2):
            break
    if impulsive:
        push((x1, x2, 0.0, v1, v2))
    x1s, x2s, fs, v1s, v2s = _columns(flat, 5)
    out = ImpactRecord(np.arange(fs.size) * dt, x1s - x2s, v1s - v2s, fs, v1s, v2s,
                       mass_1_kg=sc.m1_kg, mass_2_kg=sc.m2_kg, displacement_2_m=x2s,
                       meta=dict(meta, steps=fs.size - 1))
    return end.outcome(out, v1, v2, x2, nonfinite)


FRICTION_MODEL = ("Coulomb in the rigid velocity-level contact (Chipmunk's sequential "
                  "impulses: the friction impulse clamped to ±μ times the normal impulse)")
FRICTION_COMBINATION = "product"
"""Chipmunk multiplies the shapes' frictions: the ball gets μ, the plate 1."""


def _facts(model: str, rule: str, mu: float, **extra: Any) -> dict[str, Any]:
    plate = oblique_common.neutral_plate(rule, mu) if rule != "none" else mu
    return stepping.friction_facts(model, rule, mu, plate, mu, **extra)


def oblique_model(scenario: Oblique, mode: str, settings: RunSettings, dt: float,
                  iterations: int) -> tuple[ObliqueModel, dict[str, Any]]:
    """Build the oblique space for ``mode``; returns it and the meta of its parameters (the
    friction facts in ``meta["engine_defaults"]``).

    ``native``: rigid contact with the ball's native elasticity (the reference's restitution
    at the reference velocity) and pymunk's Coulomb friction μ; ``injected``: the penalty
    normal law with ideal Coulomb friction as forces (``options["injection"] =
    "restitution"``: the rigid contact with the law's restitution k(b·ẋ) and pymunk's
    friction μ); ``default``: pymunk out of the box (elasticity 0, slop 0.1 m, …) with the
    scenario's μ; ``custom``: that plus ``settings.params``."""
    mu = scenario.friction
    inertia = scenario.moment_of_inertia_kg_m2
    if mode in ("default", "custom"):
        params = custom_parameters(settings.params or {}) if mode == "custom" else {}
        friction = params.get("friction", mu)
        model = ObliqueModel(scenario, "rigid", dt, friction=friction, out_of_box=params)
        facts = _facts(FRICTION_MODEL, FRICTION_COMBINATION, friction,
                       moment_of_inertia_kg_m2=inertia)
        meta = {"contact": "rigid", "engine_defaults": {**model.defaults, **facts},
                "not_comparable": stepping.RIGID_OBLIQUE_ARTEFACTS}
        if mode == "custom":
            meta["params"] = params
        return model, meta
    meta: dict[str, Any] = {"iterations": iterations, "collision_slop": 0.0}
    if mode == "injected":
        injection = settings.options.get("injection", "penalty")
        check.one_of("options.injection", injection, INJECTIONS)
        if injection == "penalty":
            meta.update(injection=injection, contact="penalty",
                        engine_defaults=_facts(stepping.INJECTED_FRICTION, "none", mu,
                                               moment_of_inertia_kg_m2=inertia))
            return ObliqueModel(scenario, "penalty", dt, friction=mu,
                                iterations=iterations), meta
        meta.update(injection=injection, contact="restitution",
                    not_comparable=stepping.RIGID_OBLIQUE_ARTEFACTS,
                    engine_defaults=_facts(FRICTION_MODEL, FRICTION_COMBINATION, mu,
                                           moment_of_inertia_kg_m2=inertia))
        return ObliqueModel(scenario, "restitution", dt, friction=mu,
                            iterations=iterations), meta
    v_ref = check.positive(
        "options.reference_velocity_m_s",
        settings.options.get("reference_velocity_m_s", NATIVE_REFERENCE_VELOCITY_M_S))
    e = _reference_restitution(scenario.normal_scenario(v_ref))
    if mode == "tuned":  # native with the tuned file's friction knobs
        applied = oblique_tuned.friction("pymunk", settings, scenario, dt)
        mu = applied["friction"]
        meta.update(oblique_tuned.meta(applied, settings))
    meta.update(contact="rigid", elasticity=e, reference_velocity_m_s=v_ref,
                not_comparable=stepping.RIGID_OBLIQUE_ARTEFACTS,
                engine_defaults=_facts(FRICTION_MODEL, FRICTION_COMBINATION, mu,
                                       moment_of_inertia_kg_m2=inertia))
    return ObliqueModel(scenario, "rigid", dt, friction=mu, elasticity=e,
                        iterations=iterations), meta


def run_oblique(model: ObliqueModel, settings: RunSettings, meta: dict[str, Any]
                ) -> ImpactRecord:
    """Step the oblique impact from its gap until the ball has let go (or tunnels,
    diverges, times out), as :func:`run_ball`, with the tangential channels: the centre's
    tangential velocity, the spin and the tangential force on the ball (pymunk's own
    friction impulse / dt for a rigid contact, the injected Coulomb force for the penalty)."""
    sc, dt = model.scenario, model.dt
    v0 = sc.normal_velocity_m_s
    n_max = _step_cap(model, settings, v0)
    end = _LetGo(model)
    step, state = model.space.step, model.state
    impulsive = model.contact != "penalty"
    x, v, vt, w = -model.gap_m, v0, sc.tangential_velocity_m_s, sc.spin_rad_s
    flat = [] if impulsive else [x, v, 0.0, vt, w, 0.0]
    push = flat.extend
    nonfinite = False
    for _ in range(n_max):
        model.force_n = model.force_t = 0.0
        step(dt)
        f, ft = model.force_n, model.force_t
        if impulsive:
            push((x, v, f, vt, w, ft))
            x, v, vt, w = state()
        else:  # sample k: the post-drift position with the velocities entering the kick
            x = state()[0]
            push((x, v, f, vt, w, ft))
            _, v, vt, w = state()
        if end.ended(f, x, v):
            break
        if not all(map(math.isfinite, (x, v, vt, w))):
            nonfinite = True
            break
    if impulsive:
        push((x, v, 0.0, vt, w, 0.0))
    xs, vs, fs, vts, ws, fts = _columns(flat, 6)
    steps = xs.size - 1
    timed_out = steps == n_max and end.tail != 0 and not (end.tunneled or nonfinite)
    out = oblique_common.record(sc, np.arange(xs.size) * dt, xs, vs, fs, vts, ws, fts,
                                {**meta, "steps": steps, oblique_common.PLANAR: True})
    return oblique_common.finish(out, sc, tunneled=end.tunneled, timed_out=timed_out)
