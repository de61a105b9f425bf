"""Box2D 2.3 (``pip install box2d``, module ``Box2D``; 2D like pymunk), float32 throughout.

Box2D facts this adapter relies on (checked with Box2D 2.3.10 from PyPI, Python 3.11):

- Contacts are *rigid*: one velocity-level impulse per step with the restitution target
  vₙ⁺ = −e·vₙ⁻, e the *maximum* of the two fixtures' restitutions (b2MixRestitution), applied
  only when the approach speed exceeds ``b2_velocityThreshold`` = 1 m/s — a constant compiled
  into the build, not settable: the paper's ball at exactly 1 m/s stops dead whatever e is.
  There is no contact stiffness or damping. ``b2_linearSlop`` (5 mm) of overlap is tolerated
  and polygons and edges carry a 10 mm skin (``b2_polygonRadius``): a ball meets an edge or
  box 1 cm before touch. Circles have no skin, so every body here is a circle (the plate is a
  static circle of radius 1 m below the ball; curvature does not matter to a rigid impulse).
- The contact impulse of a step is the sum of the normal impulses a contact listener's
  ``PostSolve`` receives (Box2D calls it after the regular solve and after a time-of-impact
  sub-step, which is where a fast body meeting a static one is stopped at a coarse step); the
  force sample is that sum / dt. Forces applied with
  ``ApplyForceToCenter`` act for one step (auto-cleared); Box2D integrates v ← v + F·dt/m, then
  x ← x + v·dt (semi-implicit Euler), so an injected force evaluated at the step's start
  state is the same symplectic scheme as pymunk's penalty contact.
- Solver iterations are arguments of ``World.Step``; Box2D has no default (its manual
  recommends 8 velocity and 3 position iterations, used here).

Ball on plate: penetration x = −y of the ball's centre (the plate circle's top is at y = −R),
ẋ = −ẏ; gravity −g along y. Rigid contacts are one-step impulses: duration, peak force,
penetration and loss are marked not comparable.

- ``native``: ball restitution e = the reference's at the reference velocity (1 m/s, or
  ``options["reference_velocity_m_s"]``), plate 0 (always: Box2D's default, neutral for the
  max), so the pair has e; friction 0.
  At 1 m/s the threshold swallows it: restitution 0 — Box2D cannot express a bounce at or
  below 1 m/s (reported as it is, ``meta["not_expressible"]``).
- ``injected``: the ball has no fixture; the reference law F(x, ẋ) (``scenario.law()``) at the
  step's start is applied to its centre; that force is the record's.
- ``default``: restitution 0, friction 0.2 (b2FixtureDef's), 8/3 iterations.
- ``custom``: the defaults with ``settings.params`` on top (keys :data:`PARAMETERS`);
  ``tuned``: native with ``settings.tuned`` on top (the same keys).

Rigid–flexible: two circles on the x axis (radius 0.1 m, fixed rotation; all forces act along
x so they stay on it); body 2 hangs on a soft ``b2DistanceJoint`` to the ground, anchored 1 m to
its right, with frequency f = √(k2/m2)/(2π) and damping ratio 0 — Box2D's own spring of
stiffness m2·(2πf)² = k2; the softening structure's +β·x2³ is an applied force.

- ``native``: rigid contact with pair restitution 1 (as pymunk and DART: an undamped contact
  spring returns all its energy); k1 and the local law cannot be expressed.
- ``injected``: no fixtures; the local law F1(Δx) at the step's start (memory updated after)
  applied as −F1 to body 1, +F1 to body 2.
- ``default`` (restitution 0: plastic), ``custom``, ``tuned``: as for the ball.

Oblique impact (gravity off): the ball is a circle with the scenario's moment of inertia —
the sphere's (2/5)·m·R² by default (a sphere's oblique impact on a plane is planar, so the
circle carries its motion exactly and the sphere's references apply), a disc's m·R²/2 with
``shape = "disc"`` (the disc's references; the records are marked ``planar``,
:data:`impactbench.engines.oblique_common.PLANAR`) — moving along +x and −y; spin
ω = −angularVelocity (about n × t = −z). The plate circle's top sits under the point of first
touch (its curvature tilts the normal by the ball's travel over 1 m). Friction: Box2D's
Coulomb in the rigid contact, the pair's μ = √(μ_ball·μ_plate) (both fixtures μ). Tangential
force: the contact's own impulses on the ball (``PostSolve``'s normal and tangent impulses
along the world manifold) / dt.

- ``native``: the ball's native restitution and μ: the rigid Coulomb theory with the contact's
  own restitution — 0 at normal velocities ≤ 1 m/s (the threshold: 60° and 80° at 2 m/s).
- ``injected``: no fixture; the normal law and ideal Coulomb friction (−s·m_s/dt clipped to
  ±μ·F_n, :func:`impactbench.engines.stepping.coulomb_force`) as a force and torque at the
  contact point from the step's start state.
- ``default``: Box2D's defaults (restitution 0) with the scenario's μ; ``custom``: that plus
  ``settings.params``; ``tuned``: ``unsupported``.

Bounce to rest (:class:`~impactbench.reference.bounce_scenario.Bounce`): the ball's model for
the mode at the first impact (``Bounce.ball()``), started at rest with its lowest point
``height_m`` above the plate circle's top, gravity on. A rigid contact with e > 0 records
``b2_velocityThreshold`` (1 m/s, read from the build) as ``meta["bounce_threshold_m_s"]``:
the bounces stop once the ball meets the plate at ≤ 1 m/s (a drop of ≤ 5.1 cm).

The run loop and stopping rules are :mod:`impactbench.engines.stepping`'s. Default timesteps:
ball and oblique 1e-6 s, rigid–flexible 1e-5 s, bounce 1/60 s (the Box2D manual's).
"""

from __future__ import annotations

import math
from typing import Any, ClassVar

from impactbench.engines import oblique_common, oblique_tuned, stepping
from impactbench.engines.base import (
    CUBE_TOSS_TWO_D,
    RunSettings,
    Scenario,
    ball_gap_m,
    import_engine,
)
from impactbench.engines.common import native_ball_restitution, reference_velocity
from impactbench.reference import validation as check
from impactbench.reference.oblique_scenario import Oblique
from impactbench.reference.scenarios import BallOnPlate, RigidFlexible

PARAMETERS: dict[str, Any] = {
    "restitution": check.non_negative,  # body 1's fixture; body 2's is 0, so the pair (max) is it
    "friction": check.non_negative,  # both fixtures
    "velocity_iterations": stepping.count,
    "position_iterations": stepping.count,
}
"""Box2D's own parameter names accepted in ``custom`` and ``tuned`` mode, with their checks."""

ITERATIONS = {"velocity_iterations": 8, "position_iterations": 3}
"""The Box2D manual's recommended solver iterations (``World.Step`` has no default)."""

BODY_RADIUS_M = 0.1
"""Radius of both 2-DOF bodies (m)."""

PLATE_RADIUS_M = 1.0
"""Radius of the static circle whose top is the plate (m)."""

PLATE_RESTITUTION = 0.0
"""Body 2's (the plate's) fixture restitution: Box2D's default, and neutral for the max the
pair takes, so the pair has exactly body 1's value."""

SPRING_LENGTH_M = 1.0
"""Rest length of body 2's distance-joint spring (m)."""


def _import_box2d() -> Any:
    return import_engine("box2d", "Box2D")


def engine_defaults() -> dict[str, Any]:
    """Box2D's fixture defaults (read from the engine) and the manual's iteration counts, plus
    the compiled-in constants that shape its contacts (informational, not settable)."""
    b2 = _import_box2d()
    fixture = b2.b2FixtureDef()
    return {
        "restitution": float(fixture.restitution),
        "friction": float(fixture.friction),
        **ITERATIONS,
    }


def build_constants() -> dict[str, float]:
    """Constants compiled into the Box2D build (m/s and m)."""
    b2 = _import_box2d()
    return {"b2_velocityThreshold": float(b2.b2_velocityThreshold),
            "b2_linearSlop": float(b2.b2_linearSlop),
            "b2_polygonRadius": float(b2.b2_polygonRadius)}


class Box2dWorld:
    """A Box2D world (no sleeping) whose bodies are circles.

    Args:
        params: the complete parameter set (every key of :data:`PARAMETERS`).
        dt: the timestep (s).
        gravity_y: gravity along y (m/s²).
    """

    def __init__(self, params: dict[str, Any], dt: float, gravity_y: float) -> None:
        self.b2 = b2 = _import_box2d()
        self.params, self.dt = params, dt
        self.world = b2.b2World(gravity=(0.0, gravity_y), doSleep=False)
        self.iterations = (params["velocity_iterations"], params["position_iterations"])

    def circle(self, position: tuple[float, float], radius: float, mass: float,
               restitution: float | None, static: bool = False,
               inertia: float | None = None) -> Any:
        """A circle body; ``restitution`` ``None``: no fixture (injected forces only);
        ``inertia`` None: fixed rotation, else its moment of inertia (kg·m²)."""
        w = self.world
        if static:
            body = w.CreateStaticBody(position=position)
        else:
            body = w.CreateDynamicBody(position=position, fixedRotation=inertia is None,
                                       bullet=False)
        if restitution is not None:
            body.CreateCircleFixture(radius=radius, density=1.0, restitution=restitution,
                                     friction=self.params["friction"])
        if not static:
            data = body.massData
            data.mass, data.I = mass, 0.0 if inertia is None else inertia
            body.massData = data
        return body

    def step(self) -> None:
        self.world.Step(self.dt, *self.iterations)

    def contact_force_n(self) -> float:
        """Σ normal impulse / dt of the last step's contacts (N), from ``PostSolve``."""
        return self._listener.impulse / self.dt

    def listen(self) -> None:
        """Sum every contact's normal impulses in ``PostSolve``, which Box2D calls after the
        regular solve *and* after a time-of-impact sub-step (a fast body meeting a static one
        is stopped there, and the manifold's ``normalImpulse`` does not keep that impulse)."""
        b2 = self.b2

        class Listener(b2.b2ContactListener):
            impulse = 0.0

            def PostSolve(self, contact: Any, impulse: Any) -> None:  # Box2D names it
                n = contact.manifold.pointCount
                self.impulse += sum(impulse.normalImpulses[:n])

        self._listener = Listener()
        self.world.contactListener = self._listener

    def listen_body(self, body: Any) -> None:
        """As :meth:`listen`, and also sum the impulse the contacts apply to ``body`` along
        x (``tangential``): each point's normal and tangent impulses along the world
        manifold's normal n (from fixture A to B) and Box2D's tangent (n_y, −n_x), which
        push body B and pull body A."""
        b2 = self.b2

        class Listener(b2.b2ContactListener):
            impulse = 0.0
            tangential = 0.0

            def PostSolve(self, contact: Any, impulse: Any) -> None:  # Box2D names it
                n = contact.manifold.pointCount
                world = contact.worldManifold  # kept: .normal points into it (SWIG)
                normal = tuple(world.normal)
                jn, jt = sum(impulse.normalImpulses[:n]), sum(impulse.tangentImpulses[:n])
                sign = 1.0 if contact.fixtureB.body == body else -1.0
                self.impulse += jn
                self.tangential += sign * (normal[0] * jn + normal[1] * jt)

        self._listener = Listener()
        self.world.contactListener = self._listener

    def tangential_force_n(self) -> float:
        """The last step's contact impulse on the listened body along x / dt (N)."""
        return self._listener.tangential / self.dt

    def advance(self) -> None:
        """One step with the impulse sum reset first."""
        self._listener.impulse = 0.0
        self.world.Step(self.dt, *self.iterations)


class BallModel(stepping.WorldModel):
    """The ball above the plate circle; ``law`` set: no fixture and the law acts.

    ``drop_height_m`` None: the ball starts at its gap (2 + ``phase`` steps of flight,
    :func:`~impactbench.engines.base.ball_gap_m`), approaching at V0; a value (m): at rest
    with its lowest point that high above the plate (the bounce to rest), gravity
    −``scenario.gravity_m_s2`` along y as always. The ball moves along the plate circle's
    vertical axis only (no force has an x part), so it rests on its top for seconds; the
    world never sleeps (:class:`Box2dWorld`)."""

    def __init__(self, scenario: BallOnPlate, params: dict[str, Any], dt: float,
                 law: Any = None, drop_height_m: float | None = None,
                 phase: float | None = None) -> None:
        self.w = w = Box2dWorld(params, dt, -scenario.gravity_m_s2)
        radius = scenario.radius_m
        self.plate_thickness_m = 2.0 * PLATE_RADIUS_M
        w.circle((0.0, -radius - PLATE_RADIUS_M), PLATE_RADIUS_M, 0.0,
                 PLATE_RESTITUTION, static=True)  # top at y = −R
        dropped = drop_height_m is not None
        y0 = drop_height_m if dropped else ball_gap_m(scenario.velocity_m_s, dt, phase)
        self.body = w.circle((0.0, y0), radius, scenario.mass_kg,
                             None if law is not None else params["restitution"])
        self.body.linearVelocity = (0.0, 0.0 if dropped else -scenario.velocity_m_s)
        if dropped and law is not None:
            self.plate_thickness_m = 0.0  # no fixture: past x = R the law's ball went through
        self.law = law
        self.impulsive = law is None  # Box2D contacts are rigid
        if self.impulsive:
            w.listen()

    def state(self) -> tuple[float, float, float, float]:
        return -self.body.position[1], -self.body.linearVelocity[1], 0.0, 0.0

    def advance(self) -> float:
        """Apply this step's forces (injected law, softening term) and step the engine;
        returns the injected contact force (N; 0 without a law)."""
        if self.law is None:
            self.w.advance()
            return 0.0
        f = self.law.force(-self.body.position[1], -self.body.linearVelocity[1])
        if f > 0.0:
            self.body.ApplyForceToCenter((0.0, f), True)
        self.w.step()
        return f


class PairModel(stepping.WorldModel):
    """The 2-DOF model along x; ``law`` set: no fixtures and the local law acts."""

    def __init__(self, scenario: RigidFlexible, params: dict[str, Any], dt: float,
                 law: Any = None) -> None:
        self.w = w = Box2dWorld(params, dt, 0.0)
        h = self.h = BODY_RADIUS_M
        collide = law is None
        gap = stepping.gap_m(scenario.velocity_m_s, dt)
        self.body1 = w.circle((-h - gap, 0.0), h, scenario.m1_kg,
                              params["restitution"] if collide else None)
        self.body2 = w.circle((h, 0.0), h, scenario.m2_kg,
                              PLATE_RESTITUTION if collide else None)
        self.body1.linearVelocity = (scenario.velocity_m_s, 0.0)
        ground = w.world.CreateStaticBody(position=(h + SPRING_LENGTH_M, 0.0))
        w.world.CreateDistanceJoint(
            bodyA=ground, bodyB=self.body2, anchorA=(h + SPRING_LENGTH_M, 0.0),
            anchorB=(h, 0.0), collideConnected=False, dampingRatio=0.0,
            frequencyHz=math.sqrt(scenario.k2_n_per_m / scenario.m2_kg) / (2.0 * math.pi))
        self.beta = scenario.beta_n_per_m3 if scenario.structure == "softening" else 0.0
        self.law = law
        self.impulsive = collide
        if collide:
            w.listen()

    def state(self) -> tuple[float, float, float, float]:
        h, b1, b2 = self.h, self.body1, self.body2
        return (b1.position[0] + h, b1.linearVelocity[0], b2.position[0] - h,
                b2.linearVelocity[0])

    def advance(self) -> float:
        """Apply this step's forces (injected law, softening term) and step the engine;
        returns the injected contact force (N; 0 without a law)."""
        x2 = self.body2.position[0] - self.h
        f = 0.0
        if self.law is not None:
            dx = self.body1.position[0] + self.h - x2
            f = self.law.force(dx)
            self.law.update(dx)
            if f:
                self.body1.ApplyForceToCenter((-f, 0.0), True)
        if f or self.beta:
            self.body2.ApplyForceToCenter((f + self.beta * x2**3, 0.0), True)
        if self.law is not None:
            self.w.step()
        else:
            self.w.advance()
        return f


class ObliqueModel:
    """The oblique impact in the x–y plane: the ball (a circle with the scenario's moment of
    inertia: the sphere's or the disc's) moving along +x and −y onto the plate circle;
    ``contact`` set: no fixture and the injected normal law and Coulomb friction act at the
    contact point."""

    def __init__(self, scenario: Oblique, params: dict[str, Any], dt: float,
                 contact: stepping.CoulombContact | None = None) -> None:
        self.w = w = Box2dWorld(params, dt, 0.0)
        self.radius = radius = scenario.radius_m
        self.plate_thickness_m = 2.0 * PLATE_RADIUS_M
        gap = stepping.gap_m(scenario.normal_velocity_m_s, dt)
        # the plate circle's top (y = −R) right under the point of first touch, where its
        # normal is the plate's: its curvature tilts the normal by the ball's travel / 1 m
        touch = scenario.tangential_velocity_m_s * gap / scenario.normal_velocity_m_s
        w.circle((touch, -radius - PLATE_RADIUS_M), PLATE_RADIUS_M, 0.0,
                 PLATE_RESTITUTION, static=True)
        self.body = w.circle((0.0, gap), radius,
                             scenario.mass_kg,
                             None if contact is not None else params["restitution"],
                             inertia=scenario.moment_of_inertia_kg_m2)
        self.body.linearVelocity = (scenario.tangential_velocity_m_s,
                                    -scenario.normal_velocity_m_s)
        self.body.angularVelocity = -scenario.spin_rad_s  # spin about n × t = −z
        self.contact = contact
        self.impulsive = contact is None  # Box2D contacts are rigid
        if self.impulsive:
            w.listen_body(self.body)

    def state(self) -> tuple[float, float, float, float]:
        (vx, vy), body = self.body.linearVelocity, self.body
        return -body.position[1], -vy, vx, -body.angularVelocity

    def step(self) -> tuple[float, float]:
        """One step; returns (F_n, F_t): the injected forces, or the engine's contact
        impulses / dt (normal, and the friction impulse on the ball along x)."""
        if self.contact is None:
            w = self.w
            w._listener.tangential = 0.0
            w.advance()
            return w.contact_force_n(), w.tangential_force_n()
        fn, ft = self.contact.forces(*self.state())
        if fn > 0.0:
            body = self.body
            body.ApplyForceToCenter((ft, fn), True)
            body.ApplyTorque(self.radius * ft, True)  # (0, −R) × (F_t, F_n) along z
        self.w.step()
        return fn, ft


class Box2dAdapter(stepping.SteppedAdapter):
    """Box2D 2.3: rigid contacts (1 m/s restitution threshold) natively; injected forces."""

    name = "box2d"
    parameter_keys = tuple(PARAMETERS)
    ball_model, pair_model, oblique_model = BallModel, PairModel, ObliqueModel
    # the bounce at 1/60 s, the Box2D v2.3 manual's step (World, "Simulation": "A time step of
    # 1/60 seconds will usually deliver a high quality simulation"; Hello Box2D uses 1.0f/60.0f)
    builders = stepping.builders(oblique_tuned.refused, bounce_s=1.0 / 60.0)
    missing_builders: ClassVar[dict[str, str]] = {"cube-toss": CUBE_TOSS_TWO_D.format("Box2D")}
    injection = ("cannot: Box2D's contacts are rigid impulses with no compliance; the law is a "
                 "force on the body (no fixture) integrated by Box2D's semi-implicit Euler step"
                 "; oblique: Coulomb friction is a force too (the contact is off with the "
                 "normal law), −s·m_s/dt clipped to ±μ·F_n at the contact point")

    def version(self) -> str:
        return str(_import_box2d().__version__)

    def bounce_threshold(self, model: stepping.SteppedModel) -> float | None:
        """``b2_velocityThreshold`` (m/s), read back from the Box2D build, for a rigid contact
        with restitution e > 0 (a contact approaching slower gets no restitution: b2ContactSolver
        sets the velocity bias −e·vₙ only if vₙ < −b2_velocityThreshold); None for e = 0 or
        an injected law (no fixture)."""
        body = getattr(model, "body", None)
        if not getattr(model, "impulsive", False) or body is None:
            return None
        if max(f.restitution for f in body.fixtures) <= 0.0:  # b2MixRestitution: the max,
            return None  # and the plate's is 0
        return float(_import_box2d().b2_velocityThreshold)

    def parameters(self, scenario: Scenario, mode: str, settings: RunSettings, ball: bool
                   ) -> tuple[dict[str, Any], dict[str, Any]]:
        params, meta = parameters(scenario, mode, settings, ball)
        meta["build_constants"] = build_constants()
        return params, meta

    def oblique_parameters(self, scenario: Oblique, mode: str, settings: RunSettings
                           ) -> tuple[dict[str, Any], dict[str, Any]]:
        params, meta = oblique_parameters(scenario, mode, settings)
        meta["build_constants"] = build_constants()
        meta[oblique_common.PLANAR] = True  # a circle: the disc runs too
        return params, meta


def parameters(scenario: Scenario, mode: str, settings: RunSettings, ball: bool
               ) -> tuple[dict[str, Any], dict[str, Any]]:
    """The complete Box2D parameter set for ``mode`` and the run's meta (``ball``: the
    ball-on-plate scenario, else the rigid–flexible pair): :func:`stepping.rigid_parameters`
    with ``restitution`` (Box2D's fixtures have no bounce below ``b2_velocityThreshold``)."""
    threshold = float(_import_box2d().b2_velocityThreshold)
    return stepping.rigid_parameters(
        scenario, mode, settings, ball, defaults=engine_defaults(), validators=PARAMETERS,
        restitution_key="restitution", frictionless={"friction": 0.0},
        injected_contact="injected force (no fixtures)",
        not_expressible=("contact stiffness and damping (Box2D contacts are rigid); any bounce "
                         f"at or below {threshold:g} m/s",
                         "contact stiffness k1 and the local law (rigid contacts)"))


FRICTION_MODEL = ("Coulomb in the rigid velocity-level contact (sequential impulses: the "
                  "friction impulse clamped to ±μ times the step's normal impulse)")
FRICTION_COMBINATION = "geometric"
"""b2MixFriction: the pair's μ = √(μ_ball·μ_plate); both fixtures get μ."""


def oblique_parameters(scenario: Oblique, mode: str, settings: RunSettings
                       ) -> tuple[dict[str, Any], dict[str, Any]]:
    """The complete Box2D parameter set of the oblique impact for ``mode`` and its meta (the
    friction facts in ``meta["engine_defaults"]``).

    The ball is a circle with the scenario's moment of inertia: the sphere's (2/5)·m·R² (an
    oblique impact of a sphere on a plane is planar, so the circle carries exactly the
    sphere's motion) or, ``shape = "disc"``, the disc's m·R²/2.
    ``default``: Box2D's fixture defaults and the manual's iterations, with the scenario's μ
    on both fixtures (the pair's √(μ·μ) = μ); ``custom``: that plus ``settings.params``;
    ``native``: the ball's native restitution (at the reference velocity) and μ;
    ``injected``: no fixtures, the normal law and Coulomb friction as forces."""
    defaults = engine_defaults()
    mu = scenario.friction
    inertia = scenario.moment_of_inertia_kg_m2
    rigid = {"contact": "rigid", "not_comparable": stepping.RIGID_OBLIQUE_ARTEFACTS}
    threshold = float(_import_box2d().b2_velocityThreshold)
    if mode in ("default", "custom"):
        own = stepping.user_params(mode, settings, PARAMETERS)
        params = {**defaults, "friction": mu, **own}
        facts = stepping.friction_facts(FRICTION_MODEL, FRICTION_COMBINATION,
                                        params["friction"], params["friction"],
                                        params["friction"], moment_of_inertia_kg_m2=inertia)
        return params, {**rigid, "restitution": params["restitution"],
                        "engine_defaults": {**defaults, **facts},
                        **stepping.params_meta(mode, own)}
    native = {**defaults, "friction": mu}
    if mode == "injected":
        facts = stepping.friction_facts(stepping.INJECTED_FRICTION, "none", mu, mu, mu,
                                        moment_of_inertia_kg_m2=inertia)
        return native, {"contact": "injected forces (no fixtures)",
                        "injected_law": scenario.model, "engine_defaults": facts}
    v_ref = reference_velocity(settings.options)
    native["restitution"] = native_ball_restitution(scenario.normal_scenario(), v_ref)
    tuned: dict[str, Any] = {}
    if mode == "tuned":  # native with the tuned file's friction knobs
        applied = oblique_tuned.friction("box2d", settings, scenario, settings.timestep_s)
        native.update(applied)
        mu = applied["friction"]
        tuned = oblique_tuned.meta(applied, settings)
    facts = stepping.friction_facts(FRICTION_MODEL, FRICTION_COMBINATION, mu, mu, mu,
                                    moment_of_inertia_kg_m2=inertia, **ITERATIONS)
    return native, {**rigid, **tuned, "reference_velocity_m_s": v_ref,
                    "restitution": native["restitution"], "engine_defaults": facts,
                    "not_expressible": ("contact stiffness and damping (Box2D contacts are "
                                        f"rigid); any bounce at a normal velocity at or below "
                                        f"{threshold:g} m/s")}
