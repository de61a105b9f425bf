"""DART 6 (``pip install dartpy``): rigid LCP contacts, joint springs, generalized forces.

DART facts this adapter relies on (checked with dartpy 6.20.0, Python 3.11, headless CPU):

- Contacts are *rigid*: the boxed LCP (Dantzig by default) solves one velocity-level impulse
  per step with a restitution target vₙ⁺ = −e·vₙ⁻, e the *product* of the two shapes'
  ``DynamicsAspect`` restitution coefficients (default 0; friction default 1). There is no
  contact stiffness or damping to set, and ERP/CFM are not exposed to Python: the constraint
  mixing trims the restitution by ~2e-5 (0.9 gives 0.89998) and the error reduction pushes a
  resting body out at up to 1e-3 m/s (the default e = 0 gives 0.001). Bounce is off at low
  approach speeds: measured at e = 0.9, none at 0.1 m/s, full at 0.15 m/s.
- The contact impulse divided by dt is reported per contact as ``Contact.force`` (world
  frame) in ``world.getLastCollisionResult()``; the force sample is Σ|force · axis|.
- Generalized joint forces (``Joint.setForce``) act for one step and are cleared by
  ``World.step``; DART integrates v ← v + a·dt, then q ← q + v·dt (semi-implicit Euler), so
  an injected force evaluated at the step's start state is the same symplectic scheme as
  pymunk's penalty contact. A ``PrismaticJoint`` spring (``setSpringStiffness``, rest
  position 0) is DART's own structural spring.

Ball on plate: a sphere (radius R, mass m) on a prismatic joint along z above a welded box
whose top face z = −R is the plate, so the joint coordinate is q = −x (penetration x, approach
rate ẋ = −q̇); gravity (0, 0, −g); the ball starts 2 + phase steps of flight away
(:func:`~impactbench.engines.base.ball_gap_m`: 2.5 at the default phase). Rigid contacts are
one-step impulses: their duration, peak force, penetration and loss are marked not comparable.

- ``native``: ball restitution e = the reference's at the reference velocity (1 m/s, or
  ``options["reference_velocity_m_s"]``), plate 1, so the pair has e; friction 0. Right at
  v_ref only: Hunt–Crossley's restitution falls with velocity.
- ``injected``: the ball has no collision aspect; the reference law F = c·xⁿ·(1 + b·ẋ) at the
  step's start state is the joint force; that force is the record's.
- ``default``: nothing set but geometry, mass, velocity and gravity: restitution 0, friction 1,
  FCL collision, Dantzig LCP, no split impulse (``meta["engine_defaults"]``).
- ``custom``: the defaults with ``settings.params`` on top (keys :data:`PARAMETERS`), the
  plate's coefficient 1 so the pair has the user's ``restitution_coeff`` (default mode leaves
  both at DART's 0); ``tuned``: native with ``settings.tuned`` on top (the same keys).

Rigid–flexible: body 1 (a sphere, m1) and body 2 (a box, m2) on prismatic joints along x whose
coordinates are the positions from first touch (x1, x2); body 2's joint spring is k2, and the
softening structure's +β·x2³ a joint force each step.

- ``native``: rigid contact with pair restitution 1 (both shapes 1): an undamped contact
  spring stores and returns all the energy it takes, so e = 1 is the rigid model a user would
  pick; k1 and the local law's shape cannot be expressed (one-step impulses).
- ``injected``: no collision aspects; the local law F1(Δx) at the step's start (with its
  memory, then ``law.update(Δx)``) as joint forces −F1 on body 1, +F1 on body 2.
- ``default`` (restitution 0: a plastic first impact), ``custom``, ``tuned``: as for the ball.

Oblique impact (gravity off): a sphere with its own moment of inertia on a ``PlanarJoint``
(z of the centre, x, rotation about +y = n × t) above the plate. Friction: DART's boxed-LCP
Coulomb, the pair's μ the smaller of the two shapes' ``friction_coeff`` (measured; both get μ).
Tangential force: DART's own ``Contact.force`` (impulse / dt) along x, taken on the ball.

- ``native``: the ball's native restitution and μ: the rigid Coulomb theory with the
  contact's own restitution.
- ``injected``: no collision; the normal law and ideal Coulomb friction (−s·m_s/dt clipped to
  ±μ·F_n, :func:`impactbench.engines.stepping.coulomb_force`) as joint forces and torque.
- ``default``: DART's defaults (restitution 0) with the scenario's μ; ``custom``: that plus
  ``settings.params``; ``tuned``: ``native`` with a tuned file's ``friction_coeff`` (both
  shapes; :data:`impactbench.engines.oblique_tuned.SPACES`); no file: ``unsupported`` with the
  reason.

Bounce to rest (:class:`~impactbench.reference.bounce_scenario.Bounce`): the ball's model for
the mode at the first impact (``Bounce.ball()``), started at rest with its lowest point
``height_m`` above the plate, gravity on. A rigid contact with e > 0 records DART's bounce
threshold (:data:`BOUNCING_VELOCITY_THRESHOLD_M_S`, on the rebound speed e·vₙ) as
``meta["bounce_threshold_m_s"]``.

The run loop and stopping rules are :mod:`impactbench.engines.stepping`'s. Default timesteps:
ball and oblique 1e-6 s, rigid–flexible 1e-5 s, bounce 1e-3 s (DART's ``World`` default).
"""

from __future__ import annotations

from typing import Any

from impactbench.engines import oblique_tuned, stepping
from impactbench.engines.base import (
    RunSettings,
    Scenario,
    ball_gap_m,
    import_engine,
)
from impactbench.engines.common import native_ball_restitution, reference_velocity
from impactbench.reference import validation as check
from impactbench.reference.oblique_scenario import Oblique
from impactbench.reference.scenarios import BallOnPlate, RigidFlexible

COLLISION_DETECTORS: tuple[str, ...] = ("fcl", "dart", "bullet", "ode")


def _detector(field: str, value: object) -> str:
    return check.one_of(field, value, COLLISION_DETECTORS)


PARAMETERS: dict[str, Any] = {
    "restitution_coeff": check.non_negative,  # the pair's: body 1's shape (body 2's is 1)
    "friction_coeff": check.non_negative,  # both shapes
    "split_impulse": stepping.flag,
    "collision_detector": _detector,
}
"""DART's own parameter names accepted in ``custom`` and ``tuned`` mode, with their checks."""

BODY_HALF_SIZE_M = 0.1
"""Radius of body 1 and half-size of body 2 in the 2-DOF model (m)."""

BOUNCING_VELOCITY_THRESHOLD_M_S = 0.1
"""DART's restitution threshold (m/s): a contact bounces only when its rebound target e·vₙ⁻
exceeds it (``DART_BOUNCING_VELOCITY_THRESHOLD`` 1e-1, a ``#define`` in DART 6's
dart/constraint/ContactConstraint.cpp, ``getInformation``: ``if (restitutionVel >
DART_BOUNCING_VELOCITY_THRESHOLD)``; bounce is on at all only for e > 1e-3,
``DART_RESTITUTION_COEFF_THRESHOLD``). dartpy does not expose it, so it cannot be read back.
Unlike PhysX's and Box2D's it applies to the rebound speed, not the approach: the ball stops
dead below an approach of 0.1/e m/s."""


def _import_dart() -> Any:
    return import_engine("dart", "dartpy")


def engine_defaults() -> dict[str, Any]:
    """DART's defaults for every key of :data:`PARAMETERS`, read from the engine."""
    dart = _import_dart()
    skeleton = dart.dynamics.Skeleton("probe")
    _, body = skeleton.createFreeJointAndBodyNodePair()
    aspect = body.createShapeNode(dart.dynamics.SphereShape(1.0)).createDynamicsAspect()
    solver = dart.simulation.World().getConstraintSolver()
    return {
        "restitution_coeff": float(aspect.getRestitutionCoeff()),
        "friction_coeff": float(aspect.getFrictionCoeff()),
        "split_impulse": bool(solver.isSplitImpulseEnabled()),
        "collision_detector": str(solver.getCollisionDetector().getType()),
    }


class DartWorld:
    """A DART world with bodies on prismatic joints along one axis.

    Args:
        params: the complete parameter set (every key of :data:`PARAMETERS`).
        dt: the timestep (s).
        gravity_z: gravity along z (m/s²).
        axis: the impact axis (0 = x, 2 = z): contact forces are read along it.
    """

    def __init__(self, params: dict[str, Any], dt: float, gravity_z: float, axis: int) -> None:
        self.dart = dart = _import_dart()
        self.params, self.axis = params, axis
        self.world = world = dart.simulation.World()
        world.setGravity([0.0, 0.0, gravity_z])
        world.setTimeStep(dt)
        solver = world.getConstraintSolver()
        if params["collision_detector"] != solver.getCollisionDetector().getType():
            name = {"fcl": "FCL", "dart": "DART", "bullet": "Bullet", "ode": "Ode"}
            solver.setCollisionDetector(
                getattr(dart.collision, name[params["collision_detector"]] + "CollisionDetector")())
        solver.setSplitImpulseEnabled(params["split_impulse"])

    def _offset(self, position: list[float]) -> Any:
        tf = self.dart.math.Isometry3()
        tf.set_translation(position)
        return tf

    def slider(self, name: str, offset: list[float], mass: float, shape: Any,
               restitution: float | None) -> tuple[Any, Any]:
        """A body on a prismatic joint along the axis, its q = 0 at ``offset`` (m).

        ``restitution`` ``None``: the shape has no collision aspect (injected forces only).
        """
        d = self.dart.dynamics
        skeleton = d.Skeleton(name)
        joint, body = skeleton.createPrismaticJointAndBodyNodePair()
        axis = [0.0, 0.0, 0.0]
        axis[self.axis] = 1.0
        joint.setAxis(axis)
        joint.setTransformFromParentBodyNode(self._offset(offset))
        node = body.createShapeNode(shape)
        if restitution is not None:
            node.createCollisionAspect()
            aspect = node.createDynamicsAspect()
            aspect.setRestitutionCoeff(restitution)
            aspect.setFrictionCoeff(self.params["friction_coeff"])
        inertia = d.Inertia()
        inertia.setMass(mass)
        body.setInertia(inertia)
        self.world.addSkeleton(skeleton)
        return skeleton, joint

    def wall(self, offset: list[float], half: float) -> None:
        """A welded box centred at ``offset`` (m) with body 2's restitution."""
        d = self.dart.dynamics
        skeleton = d.Skeleton("plate")
        joint, body = skeleton.createWeldJointAndBodyNodePair()
        joint.setTransformFromParentBodyNode(self._offset(offset))
        node = body.createShapeNode(d.BoxShape([2.0 * half] * 3))
        node.createCollisionAspect()
        aspect = node.createDynamicsAspect()
        aspect.setRestitutionCoeff(self.params["plate_restitution_coeff"])
        aspect.setFrictionCoeff(self.params["friction_coeff"])
        self.world.addSkeleton(skeleton)

    def contact_force_n(self) -> float:
        """Σ|force · axis| over the last step's contacts (N)."""
        result = self.world.getLastCollisionResult()
        a = self.axis
        return sum(abs(float(c.force[a])) for c in result.getContacts())


class BallModel(stepping.WorldModel):
    """The ball above the plate; ``law`` set: the ball has no collision and the law acts.

    ``drop_height_m`` None: the ball starts at its gap (2 + ``phase`` steps of flight,
    :func:`~impactbench.engines.base.ball_gap_m`), approaching at V0; a value (m): at rest
    with its lowest point that high above the plate (the bounce to rest), gravity
    −``scenario.gravity_m_s2`` along z as always."""

    def __init__(self, scenario: BallOnPlate, params: dict[str, Any], dt: float,
                 law: Any = None, drop_height_m: float | None = None,
                 phase: float | None = None) -> None:
        self.w = w = DartWorld(params, dt, -scenario.gravity_m_s2, axis=2)
        radius = scenario.radius_m
        # a welded box 2 m wide and 2 m thick: one step cannot carry the ball through it,
        # and a ball resting on it for seconds stays on its flat top
        self.plate_thickness_m = 2.0
        w.wall([0.0, 0.0, -radius - 1.0], 1.0)  # top face z = −R
        shape = w.dart.dynamics.SphereShape(radius)
        restitution = None if law is not None else params["restitution_coeff"]
        self.skeleton, self.joint = w.slider("ball", [0.0, 0.0, 0.0], scenario.mass_kg, shape,
                                             restitution)
        if drop_height_m is None:
            self.skeleton.setPosition(0, ball_gap_m(scenario.velocity_m_s, dt, phase))
            self.skeleton.setVelocity(0, -scenario.velocity_m_s)
        else:
            self.skeleton.setPosition(0, drop_height_m)  # q = −x: at rest, h above
            if law is not None:
                self.plate_thickness_m = 0.0  # no collision: past x = R the law's ball is through
        self.law = law
        self.impulsive = law is None  # DART contacts are rigid
        # the pair's e: the product of the two shapes' coefficients (DART's rule)
        self.pair_restitution = 0.0 if law is not None else \
            params["restitution_coeff"] * params["plate_restitution_coeff"]

    def state(self) -> tuple[float, float, float, float]:
        return -self.skeleton.getPosition(0), -self.skeleton.getVelocity(0), 0.0, 0.0

    def advance(self) -> float:
        """Apply this step's forces (injected law, softening term) and step the engine;
        returns the injected contact force (N; 0 without a law)."""
        f = 0.0
        if self.law is not None:
            f = self.law.force(-self.skeleton.getPosition(0), -self.skeleton.getVelocity(0))
            self.joint.setForce(0, f)
        self.w.world.step()
        return f


class PairModel(stepping.WorldModel):
    """The 2-DOF model along x; ``law`` set: no collision and the local law acts."""

    def __init__(self, scenario: RigidFlexible, params: dict[str, Any], dt: float,
                 law: Any = None) -> None:
        self.w = w = DartWorld(params, dt, 0.0, axis=0)
        d, h = w.dart.dynamics, BODY_HALF_SIZE_M
        collide = law is None
        self.body1, self.joint1 = w.slider(
            "body1", [-h, 0.0, 0.0], scenario.m1_kg, d.SphereShape(h),
            params["restitution_coeff"] if collide else None)
        self.body2, self.joint2 = w.slider(
            "body2", [h, 0.0, 0.0], scenario.m2_kg, d.BoxShape([2.0 * h] * 3),
            params["plate_restitution_coeff"] if collide else None)
        self.joint2.setSpringStiffness(0, scenario.k2_n_per_m)
        self.joint2.setRestPosition(0, 0.0)
        self.body1.setPosition(0, -stepping.gap_m(scenario.velocity_m_s, dt))
        self.body1.setVelocity(0, scenario.velocity_m_s)
        self.beta = scenario.beta_n_per_m3 if scenario.structure == "softening" else 0.0
        self.law = law
        self.impulsive = law is None  # DART contacts are rigid

    def state(self) -> tuple[float, float, float, float]:
        b1, b2 = self.body1, self.body2
        return b1.getPosition(0), b1.getVelocity(0), b2.getPosition(0), b2.getVelocity(0)

    def advance(self) -> float:
        """Apply this step's forces (injected law, softening term) and step the engine;
        returns the injected contact force (N; 0 without a law)."""
        x2 = self.body2.getPosition(0)
        f = 0.0
        if self.law is not None:
            dx = self.body1.getPosition(0) - x2
            f = self.law.force(dx)
            self.law.update(dx)
            self.joint1.setForce(0, -f)
        if f != 0.0 or self.beta:
            self.joint2.setForce(0, f + self.beta * x2**3)
        self.w.world.step()
        return f


class ObliqueModel:
    """The oblique impact in the z–x plane: the ball (a sphere with its own moment of
    inertia) on a ``PlanarJoint`` (q = z of the centre, x, rotation about +y) moving along
    +x and −z onto the plate; ``contact`` set: no collision aspect and the injected normal
    law and Coulomb friction act as joint forces (F_n, F_t and the torque −R·F_t)."""

    def __init__(self, scenario: Oblique, params: dict[str, Any], dt: float,
                 contact: stepping.CoulombContact | None = None) -> None:
        import numpy as np

        self.w = w = DartWorld(params, dt, 0.0, axis=2)
        d = w.dart.dynamics
        self.radius = radius = scenario.radius_m
        self.plate_thickness_m = 2.0
        w.wall([0.0, 0.0, -radius - 1.0], 1.0)  # top face z = −R
        self.skeleton = skeleton = d.Skeleton("ball")
        self.joint, body = skeleton.createPlanarJointAndBodyNodePair()
        self.joint.setZXPlane()  # dofs: z, x, rotation about +y (= n × t)
        node = body.createShapeNode(d.SphereShape(radius))
        if contact is None:
            node.createCollisionAspect()
            aspect = node.createDynamicsAspect()
            aspect.setRestitutionCoeff(params["restitution_coeff"])
            aspect.setFrictionCoeff(params["friction_coeff"])
        inertia = d.Inertia()
        inertia.setMass(scenario.mass_kg)
        inertia.setMoment(np.eye(3) * scenario.moment_of_inertia_kg_m2)
        body.setInertia(inertia)
        w.world.addSkeleton(skeleton)
        skeleton.setPositions([stepping.gap_m(scenario.normal_velocity_m_s, dt), 0.0, 0.0])
        skeleton.setVelocities([-scenario.normal_velocity_m_s,
                                scenario.tangential_velocity_m_s, scenario.spin_rad_s])
        self.contact = contact
        self.impulsive = contact is None  # DART contacts are rigid

    def state(self) -> tuple[float, float, float, float]:
        q, u = self.skeleton.getPositions(), self.skeleton.getVelocities()
        return -float(q[0]), -float(u[0]), float(u[1]), float(u[2])

    def step(self) -> tuple[float, float]:
        """One step; returns (F_n, F_t): the injected forces, or the engine's contact forces
        on the ball (``Contact.force``, impulse / dt: Σ|F_z| and Σ F_x, each contact's force
        taken on the ball, the body it pushes up)."""
        if self.contact is None:
            self.w.world.step()
            fn = ft = 0.0
            for c in self.w.world.getLastCollisionResult().getContacts():
                f = c.force
                sign = 1.0 if f[2] >= 0.0 else -1.0
                fn += sign * float(f[2])
                ft += sign * float(f[0])
            return fn, ft
        fn, ft = self.contact.forces(*self.state())
        if fn > 0.0:
            joint = self.joint
            joint.setForce(0, fn)
            joint.setForce(1, ft)
            joint.setForce(2, -self.radius * ft)  # (0, 0, −R) × (F_t, 0, F_n) along y
        self.w.world.step()
        return fn, ft


def parameters(scenario: Scenario, mode: str, settings: RunSettings, ball: bool
               ) -> tuple[dict[str, Any], dict[str, Any]]:
    """The complete DART parameter set for ``mode`` and the run's meta (``ball``: the
    ball-on-plate scenario, else the rigid–flexible pair): :func:`stepping.rigid_parameters`
    with ``restitution_coeff``, the plate's coefficient 1 (the pair's, a product, is body
    1's) except in ``default`` mode, where both shapes keep DART's default."""
    defaults = engine_defaults()
    rigid_only = "contact stiffness and damping (DART contacts are rigid)"
    return stepping.rigid_parameters(
        scenario, mode, settings, ball, defaults=defaults, validators=PARAMETERS,
        restitution_key="restitution_coeff", frictionless={"friction_coeff": 0.0},
        injected_contact="injected joint force (no collision)",
        not_expressible=(rigid_only, rigid_only), neutral={"plate_restitution_coeff": 1.0},
        default_params={**defaults, "plate_restitution_coeff": defaults["restitution_coeff"]})


FRICTION_MODEL = ("Coulomb in the rigid LCP (boxed: the friction impulse within ±μ times the "
                  "normal impulse, a pyramid of two tangent directions)")
FRICTION_COMBINATION = "min"
"""DART's pair friction is the smaller of the two shapes' ``friction_coeff`` (measured): both
shapes get μ."""


def oblique_parameters(scenario: Oblique, mode: str, settings: RunSettings
                       ) -> tuple[dict[str, Any], dict[str, Any]]:
    """The complete DART parameter set of the oblique impact for ``mode`` and its meta (the
    friction facts in ``meta["engine_defaults"]``).

    ``default``: DART's defaults (restitution 0 on both shapes) with the scenario's μ as both
    shapes' ``friction_coeff``; ``custom``: that, the plate's restitution 1 (the pair's
    product is the user's value) and ``settings.params``; ``native``: the ball's native
    restitution (at the reference velocity) and μ; ``injected``: no collision, the normal law
    and Coulomb friction as joint forces."""
    defaults = engine_defaults()
    mu = scenario.friction
    inertia = scenario.moment_of_inertia_kg_m2
    rigid = {"contact": "rigid", "not_comparable": stepping.RIGID_OBLIQUE_ARTEFACTS}
    neutral = {"plate_restitution_coeff": 1.0}
    if mode in ("default", "custom"):
        own = stepping.user_params(mode, settings, PARAMETERS)
        plate = neutral if mode == "custom" else \
            {"plate_restitution_coeff": defaults["restitution_coeff"]}
        params = {**defaults, **plate, "friction_coeff": mu, **own}
        f = params["friction_coeff"]
        facts = stepping.friction_facts(FRICTION_MODEL, FRICTION_COMBINATION, f, f, f,
                                        moment_of_inertia_kg_m2=inertia)
        restitution = params["restitution_coeff"] * params["plate_restitution_coeff"]
        return params, {**rigid, "engine_defaults": {**defaults, **facts},
                        "restitution": restitution, **stepping.params_meta(mode, own)}
    native = {**defaults, **neutral, "friction_coeff": mu}
    if mode == "injected":
        facts = stepping.friction_facts(stepping.INJECTED_FRICTION, "none", mu, mu, mu,
                                        moment_of_inertia_kg_m2=inertia)
        return native, {"contact": "injected joint forces (no collision)",
                        "injected_law": scenario.model, "engine_defaults": facts}
    v_ref = reference_velocity(settings.options)
    native["restitution_coeff"] = native_ball_restitution(scenario.normal_scenario(), v_ref)
    tuned: dict[str, Any] = {}
    if mode == "tuned":  # native plus the fitted friction knobs
        applied = oblique_tuned.friction("dart", settings, scenario, settings.timestep_s)
        native.update(applied)
        tuned = oblique_tuned.meta(applied, settings)
        mu = applied["friction_coeff"]
    facts = stepping.friction_facts(FRICTION_MODEL, FRICTION_COMBINATION, mu, mu, mu,
                                    moment_of_inertia_kg_m2=inertia,
                                    collision_detector=native["collision_detector"],
                                    split_impulse=native["split_impulse"])
    return native, {**rigid, "reference_velocity_m_s": v_ref,
                    "restitution": native["restitution_coeff"], "engine_defaults": facts,
                    "not_expressible": "contact stiffness and damping (DART contacts are rigid)",
                    **tuned}


class DartAdapter(stepping.SteppedAdapter):
    """DART 6: rigid LCP contacts natively; injected laws as joint forces."""

    name = "dart"
    parameter_keys = tuple(PARAMETERS)
    ball_model, pair_model, oblique_model = BallModel, PairModel, ObliqueModel
    parameters = staticmethod(parameters)
    oblique_parameters = staticmethod(oblique_parameters)
    # the bounce at DART's default step: dart.simulation.World().getTimeStep(), 0.001 s
    builders = stepping.builders(oblique_tuned.refused, "dart", bounce_s=1e-3)
    injection = ("cannot: DART's contacts are rigid LCP impulses with no compliance; the law is "
                 "a joint force (collision off) integrated by DART's semi-implicit Euler step; "
                 "oblique: Coulomb friction is a joint force and torque too (no contact with "
                 "the normal law), −s·m_s/dt clipped to ±μ·F_n")

    def version(self) -> str:
        return str(_import_dart().__version__)

    def bounce_threshold(self, model: stepping.SteppedModel) -> float | None:
        """:data:`BOUNCING_VELOCITY_THRESHOLD_M_S` for a rigid contact that bounces (the pair's
        e above DART's 1e-3), None otherwise (e = 0, or an injected law): DART compiles it
        in and does not expose it, so it is the source's value, not read back."""
        if getattr(model, "impulsive", False) and getattr(model, "pair_restitution", 0.0) > 1e-3:
            return BOUNCING_VELOCITY_THRESHOLD_M_S
        return None
