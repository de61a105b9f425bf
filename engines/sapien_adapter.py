"""PhysX 5 through SAPIEN 3 (``pip install sapien``), on its CPU system, headless.

PhysX facts this adapter relies on (checked with SAPIEN 3.0.3 / PhysX 5.3.1, CPU, float32):

- A material's ``restitution`` e ≥ 0 makes a *rigid* contact (a velocity-level target
  vₙ⁺ = −e·vₙ⁻, the pair's value the average of the two materials), applied only when the
  approach speed exceeds the scene's ``bounce_threshold`` — 2 m/s by default, so the paper's
  ball at 1 m/s stops dead (e = 0) out of the box. A *negative* restitution −K makes the
  contact *compliant*: an undamped spring of stiffness K (N/m; the pair's value is the
  average of the two materials', so both get −K). SAPIEN exposes no contact damping, so a
  compliant contact returns all the energy it takes (e ≈ 1); measured at K = 1e8 N/m,
  dt = 1e-7 s: e = 0.9995, 99.13 µs, 3161 N (the undamped spring: 1, 99.35 µs, 3162 N).
- Scene settings (``bounce_threshold``, TGS or PGS solver, PCM) are read from a process-wide
  config when a scene is created; the adapter sets it, creates its scene and restores it.
  Shapes carry ``contact_offset`` (10 mm by default: contacts are generated, speculatively,
  that far before touch) and ``rest_offset``; bodies their solver iteration counts (10
  position, 1 velocity by default) and a sleep threshold.
- Contact output: ``scene.get_contacts()`` lists points with the ``impulse`` applied over the
  last step; the force sample is |impulse · axis| / dt summed over points. An external force
  (``add_force_torque``) acts for one step and is cleared; PhysX integrates it as semi-implicit
  Euler (v ← v + F·dt/m, then x ← x + v·dt), so an injected force evaluated from the state at
  the start of the step is the same symplectic scheme as pymunk's penalty contact (measured on
  the paper's ball at dt = 1e-7 s, 5 m/s: restitution −1.1e-7, duration −3.5e-4, peak +6.1e-4).
- Poses and velocities are float32: the ball is placed so that the contact happens near the
  origin (plate top at z = −R, the ball's centre at z = −x), where float32 resolves ~1e-11 m.

Ball on plate: a sphere (radius R, mass m, friction 0) above a static box whose top face is the
plate; gravity −g along z with g = ``scenario.gravity_m_s2``; the ball starts 2 + phase steps
of flight away (:func:`~impactbench.engines.base.ball_gap_m`: 2.5 at the default phase).
Penetration x = −z_centre, approach rate ẋ = −ż.

- ``native``: the compliant contact K = m·(π/T_ref)² (both materials −K), the undamped spring
  whose duration π·√(m/K) equals the reference's at the reference velocity (1 m/s, or
  ``options["reference_velocity_m_s"]``). Duration and peak force follow a linear spring; the
  restitution stays ≈ 1 because PhysX has no settable contact damping — the contact model's
  error, reported as it is. ``options["contact"] = "rigid"`` instead gives a rigid contact with
  restitution e = the reference's at the reference velocity and ``bounce_threshold = 0`` (its
  duration, peak force, penetration and loss are one-step artefacts, marked not comparable).
- ``injected``: the ball has no collision shape; each step the reference law
  F = c·xⁿ·(1 + b·ẋ) (``scenario.law()``) at the step's start state is applied with
  ``add_force_torque``; that force is the record's.
- ``default``: nothing set but geometry, mass, velocity and gravity: PhysX's default material
  (friction 0.3, restitution 0.1, rigid), ``bounce_threshold`` 2 m/s, TGS, 10 mm contact offset
  (``meta["engine_defaults"]``).
- ``custom``: the defaults with ``settings.params`` on top (keys :data:`PARAMETERS`).
- ``tuned``: native with ``settings.tuned`` on top (the same keys); ``unsupported`` without.

Rigid–flexible: body 1 (a sphere, m1) moves along +x into body 2 (a box, m2); both bodies
have every axis but x locked. Body 2 hangs on a D6 drive to the world along x (stiffness k2,
damping 0: PhysX's own implicit spring); the softening structure's +β·x2³ is an applied
force each step. Positions from first touch: x1 = sphere front − 0, x2 = box face − 0.

- ``native``: the compliant contact K = k1 (both materials −k1): the linear local law exactly.
  Elastoplastic and mutation laws cannot be expressed (no memory): their k1 is used.
- ``injected``: no collision shapes; the local law (``scenario.local_law()``, with memory)
  F1(Δx) at the step's start is applied as −F1 to body 1 and +F1 to body 2, then
  ``law.update(Δx)``.
- ``default`` / ``custom`` / ``tuned``: as for the ball (default: restitution 0.1, applied only
  above 2 m/s).

Oblique impact (gravity off): a sphere with its own moment of inertia moving along +x and −z
onto the plate; spin ω = ω_y (about n × t = +y). Friction: PhysX's patch friction (static and
dynamic μ, ``enable_friction_every_iteration``), the pair's μ the average of the two materials'
(both get μ). PhysX reports a contact point's normal impulse only: the tangential force is
m·Δv_t/dt. PhysX damps spin (``angular_damping`` 0.05 /s) and clamps it
(``max_angular_velocity`` 100 rad/s) by default: native and injected set 0 and 1e7.

- ``native``: the ball's native contact (compliant undamped spring, or ``options["contact"] =
  "rigid"``) with μ. The rigid contact's patch friction overshoots the rigid theory (45°:
  spin 97 against 69.6 rad/s).
- ``injected``: no shape; the normal law and ideal Coulomb friction (−s·m_s/dt clipped to
  ±μ·F_n, :func:`impactbench.engines.stepping.coulomb_force`) as a force and torque.
- ``default``: PhysX's defaults (rigid, restitution 0.1 above the 2 m/s bounce threshold) with
  the scenario's μ; ``custom``: that plus ``settings.params``; ``tuned``: ``native`` with a
  tuned file's friction knobs (:data:`impactbench.engines.oblique_tuned.SPACES`:
  ``static_friction``, ``dynamic_friction`` of both materials); no file: ``unsupported`` with
  the reason.

Bounce to rest (:class:`~impactbench.reference.bounce_scenario.Bounce`): the ball's model for
the mode at the first impact (``Bounce.ball()``), started at rest with its lowest point
``height_m`` above the plate, gravity on; the plate (a 2 m box) holds it at rest for seconds.
A rigid contact with e > 0 records the scene's ``bounce_threshold`` read back from the engine
(``meta["bounce_threshold_m_s"]``): ``default``'s 2 m/s swallows the first impact from 0.2 m
(√(2gh) = 1.98 m/s), so the ball stops dead there.

The run loop and stopping rules are :mod:`impactbench.engines.stepping`'s. Default timesteps:
ball and oblique 1e-6 s, rigid–flexible 1e-5 s, bounce 0.01 s (SAPIEN's scene default).
"""

from __future__ import annotations

import warnings
from contextlib import contextmanager
from typing import Any

from impactbench.engines import oblique_tuned, stepping
from impactbench.engines.base import (
    EngineUnavailable,
    RunSettings,
    Scenario,
    ball_gap_m,
)
from impactbench.engines.common import (
    native_ball_restitution,
    native_ball_spring,
    reference_velocity,
)
from impactbench.reference import validation as check
from impactbench.reference.oblique_scenario import Oblique
from impactbench.reference.scenarios import BallOnPlate, RigidFlexible

PARAMETERS: dict[str, Any] = {
    "restitution": check.finite,  # both materials; < 0: compliant stiffness −K (N/m)
    "static_friction": check.non_negative,
    "dynamic_friction": check.non_negative,
    "bounce_threshold": check.non_negative,  # m/s
    "enable_tgs": stepping.flag,
    "enable_pcm": stepping.flag,
    "contact_offset": check.positive,  # m
    "rest_offset": check.non_negative,  # m
    "solver_position_iterations": stepping.count,
    "solver_velocity_iterations": stepping.count,
    "sleep_threshold": check.non_negative,
    "enable_friction_every_iteration": stepping.flag,  # scene: friction in every iteration
    "angular_damping": check.non_negative,  # 1/s, the dynamic bodies'
    "max_angular_velocity": check.positive,  # rad/s, the dynamic bodies' clamp
}
"""SAPIEN's own parameter names accepted in ``custom`` and ``tuned`` mode, with their checks."""

ROTATION_FREE = {"angular_damping": 0.0, "max_angular_velocity": 1e7}
"""Native and injected oblique runs: no spin damping (PhysX's default 0.05 /s) and no clamp of
the spin (PhysX's default 100 rad/s)."""

CONTACTS: tuple[str, ...] = ("compliant", "rigid")
"""``options["contact"]`` for the native ball."""

BODY_HALF_SIZE_M = 0.1
"""Radius of body 1 and half-size of body 2 in the 2-DOF model (m)."""


def _import_sapien() -> tuple[Any, Any]:
    try:
        with warnings.catch_warnings():  # "Failed to find system libvulkan": headless is fine
            warnings.simplefilter("ignore")
            import sapien
            import sapien.physx as physx
    except ImportError as exc:
        raise EngineUnavailable("sapien", str(exc)) from None
    return sapien, physx


def engine_defaults() -> dict[str, Any]:
    """PhysX's defaults for every key of :data:`PARAMETERS`, read from the engine."""
    _, px = _import_sapien()
    scene, shape, body = px.PhysxSceneConfig(), px.PhysxShapeConfig(), px.PhysxBodyConfig()
    material = px.get_default_material()
    probe = px.PhysxRigidDynamicComponent()
    return {
        "restitution": float(material.restitution),
        "static_friction": float(material.static_friction),
        "dynamic_friction": float(material.dynamic_friction),
        "bounce_threshold": float(scene.bounce_threshold),
        "enable_tgs": bool(scene.enable_tgs),
        "enable_pcm": bool(scene.enable_pcm),
        "contact_offset": float(shape.contact_offset),
        "rest_offset": float(shape.rest_offset),
        "solver_position_iterations": int(body.solver_position_iterations),
        "solver_velocity_iterations": int(body.solver_velocity_iterations),
        "sleep_threshold": float(body.sleep_threshold),
        "enable_friction_every_iteration": bool(scene.enable_friction_every_iteration),
        "angular_damping": float(probe.get_angular_damping()),
        "max_angular_velocity": float(probe.get_max_angular_velocity()),
    }


@contextmanager
def _scene_config(px: Any, params: dict[str, Any], gravity_z: float):
    """Set the process-wide PhysX scene config for one scene's creation, then restore it."""
    previous = px.get_scene_config()
    cfg = px.PhysxSceneConfig()
    cfg.gravity = [0.0, 0.0, gravity_z]
    cfg.bounce_threshold = params["bounce_threshold"]
    cfg.enable_tgs = params["enable_tgs"]
    cfg.enable_pcm = params["enable_pcm"]
    cfg.enable_friction_every_iteration = params["enable_friction_every_iteration"]
    px.set_scene_config(cfg)
    try:
        yield
    finally:
        px.set_scene_config(previous)


class PhysxWorld:
    """A SAPIEN scene on the PhysX CPU system with bodies along one axis.

    Args:
        params: the complete parameter set (every key of :data:`PARAMETERS`).
        dt: the timestep (s).
        gravity_z: gravity along z (m/s²).
        axis: the impact axis (0 = x, 2 = z): contact impulses are read along it.
    """

    def __init__(self, params: dict[str, Any], dt: float, gravity_z: float, axis: int) -> None:
        self.sapien, self.px = sapien, px = _import_sapien()
        self.params, self.dt, self.axis = params, dt, axis
        with _scene_config(px, params, gravity_z):
            self.scene = sapien.Scene([px.PhysxCpuSystem()])
        self.scene.set_timestep(dt)
        self.material = px.PhysxMaterial(params["static_friction"],
                                         params["dynamic_friction"], params["restitution"])

    def _shape(self, shape: Any) -> Any:
        shape.set_contact_offset(self.params["contact_offset"])
        shape.set_rest_offset(self.params["rest_offset"])
        return shape

    def sphere(self, radius: float) -> Any:
        return self._shape(self.px.PhysxCollisionShapeSphere(radius, self.material))

    def box(self, half: float) -> Any:
        import numpy as np

        return self._shape(self.px.PhysxCollisionShapeBox(
            np.full(3, half, dtype=np.float32), self.material))

    def add(self, position: list[float], mass: float, shape: Any | None = None,
            static: bool = False, inertia: float = 1.0) -> Any:
        """A body at ``position`` (m) with ``shape`` (``None``: no collision) and the
        principal moments of inertia ``inertia`` (kg·m²; 1 where rotations are locked or
        never excited)."""
        px, p = self.px, self.params
        entity = self.sapien.Entity()
        body = px.PhysxRigidStaticComponent() if static else px.PhysxRigidDynamicComponent()
        if shape is not None:
            body.attach(shape)
        entity.add_component(body)
        entity.set_pose(self.sapien.Pose(position))
        self.scene.add_entity(entity)
        if not static:
            body.set_mass(mass)
            body.set_inertia([inertia] * 3)
            body.set_solver_position_iterations(p["solver_position_iterations"])
            body.set_solver_velocity_iterations(p["solver_velocity_iterations"])
            body.set_sleep_threshold(p["sleep_threshold"])
            body.set_angular_damping(p["angular_damping"])
            body.set_max_angular_velocity(p["max_angular_velocity"])
        return body

    def contact_force_n(self) -> float:
        """|Σ impulse · axis| / dt over every contact point of the last step (N)."""
        a = self.axis
        total = 0.0
        for contact in self.scene.get_contacts():
            for point in contact.points:
                total += abs(float(point.impulse[a]))
        return total / self.dt


class _BallAbovePlate:
    """A ball (a sphere of radius R, or no shape when its contact is ``driven`` by applied
    forces) at the gap above a static plate whose top face is z = −R, so that the ball's
    penetration is −z; rigid (``impulsive``) when its contact is PhysX's with a restitution
    ≥ 0. The base of :class:`BallModel` and :class:`ObliqueModel`."""

    def __init__(self, params: dict[str, Any], dt: float, gravity_m_s2: float,
                 radius_m: float, mass_kg: float, inertia_kg_m2: float,
                 velocity_m_s: list[float], spin_rad_s: list[float] | None,
                 driven: bool, height_m: float | None = None,
                 phase: float | None = None) -> None:
        """``velocity_m_s`` (x, y, z; its −z part the approach speed that sets the gap) and
        ``spin_rad_s`` (about x, y, z; None: not set) are the ball's at the start;
        ``gravity_m_s2`` is along z; ``height_m``: the ball's lowest point starts that high
        above the plate (m; None: at the gap of 2 + ``phase`` steps of flight,
        :func:`~impactbench.engines.base.ball_gap_m`; ``phase`` None: 2.5 steps)."""
        import numpy as np

        self.world = w = PhysxWorld(params, dt, gravity_m_s2, axis=2)
        # a static box 2 m wide and 2 m thick: one step at the customary 0.01 s cannot carry
        # the ball through it, and a ball resting on it for seconds stays on its flat top
        self.plate_thickness_m = 2.0
        w.add([0.0, 0.0, -radius_m - 1.0], 0.0, w.box(1.0), static=True)  # top face z = −R
        shape = None if driven else w.sphere(radius_m)
        z0 = ball_gap_m(-velocity_m_s[2], dt, phase) if height_m is None else height_m
        self.body = w.add([0.0, 0.0, z0], mass_kg, shape, inertia=inertia_kg_m2)
        self.body.set_linear_velocity(velocity_m_s)
        if spin_rad_s is not None:
            self.body.set_angular_velocity(spin_rad_s)
        self.impulsive = not driven and params["restitution"] >= 0.0  # rigid
        self._force = np.zeros(3, dtype=np.float32)
        self._torque = np.zeros(3, dtype=np.float32)
        self._reach = params["contact_offset"]
        self._last = self.state()

    def state(self) -> tuple[float, float, float, float]:
        raise NotImplementedError


class BallModel(_BallAbovePlate):
    """The ball above the plate; ``law`` set: the ball has no shape and the law is applied.

    ``drop_height_m`` None: the ball starts at its gap (2 + ``phase`` steps of flight,
    :func:`~impactbench.engines.base.ball_gap_m`), approaching at V0; a value (m): at rest
    with its lowest point that high above the plate (the bounce to rest), gravity
    −``scenario.gravity_m_s2`` along z as always."""

    def __init__(self, scenario: BallOnPlate, params: dict[str, Any], dt: float,
                 law: Any = None, drop_height_m: float | None = None,
                 phase: float | None = None) -> None:
        self.law = law
        v0 = scenario.velocity_m_s if drop_height_m is None else 0.0
        super().__init__(params, dt, -scenario.gravity_m_s2, scenario.radius_m,
                         scenario.mass_kg, 1.0, [0.0, 0.0, -v0], None,
                         driven=law is not None, height_m=drop_height_m, phase=phase)
        if drop_height_m is not None and law is not None:
            self.plate_thickness_m = 0.0  # no shape: past x = R the law's ball went through

    def state(self) -> tuple[float, float, float, float]:
        self._last = out = (-float(self.body.entity_pose.p[2]),
                            -float(self.body.linear_velocity[2]), 0.0, 0.0)
        return out

    def step(self) -> float:
        """:meth:`advance` from the state last read, then the force of that step: the
        injected law's, or the engine's reported contact impulse / dt (read only when the
        ball was within reach of the plate: contact offset + 2·|ẋ|·dt)."""
        x, v, _, _ = self._last
        f = self.advance(x, v)
        if self.law is not None:
            return f
        w = self.world
        return w.contact_force_n() if x + self._reach + 2.0 * abs(v) * w.dt > 0.0 else 0.0

    def advance(self, x: float | None = None, v: float | None = None) -> float:
        """Apply this step's injected force (at state x, ẋ; read from the engine if not
        given) and step the engine; returns that force (N; 0 without a law)."""
        f = 0.0
        if self.law is not None:
            if x is None or v is None:
                x, v, _, _ = self.state()
            f = self.law.force(x, v)
            if f > 0.0:
                self._force[2] = f
                self.body.add_force_torque(self._force, self._torque)
        self.world.scene.step()
        return f


class PairModel:
    """The 2-DOF model along x; ``law`` set: no shapes and the local law is applied."""

    def __init__(self, scenario: RigidFlexible, params: dict[str, Any], dt: float,
                 law: Any = None) -> None:
        import numpy as np

        self.world = w = PhysxWorld(params, dt, 0.0, axis=0)
        h = self.h = BODY_HALF_SIZE_M
        gap = stepping.gap_m(scenario.velocity_m_s, dt)
        self.body1 = w.add([-h - gap, 0.0, 0.0], scenario.m1_kg,
                           None if law is not None else w.sphere(h))
        self.body2 = w.add([h, 0.0, 0.0], scenario.m2_kg, None if law is not None else w.box(h))
        for body in (self.body1, self.body2):
            body.set_locked_motion_axes([False, True, True, True, True, True])
        self.body1.set_linear_velocity([scenario.velocity_m_s, 0.0, 0.0])
        drive = w.scene.create_drive(None, w.sapien.Pose([h, 0.0, 0.0]), self.body2,
                                     w.sapien.Pose())
        drive.set_drive_property_x(scenario.k2_n_per_m, 0.0)
        self.drive = drive
        self.beta = scenario.beta_n_per_m3 if scenario.structure == "softening" else 0.0
        self.law = law
        self.impulsive = law is None and params["restitution"] >= 0.0  # rigid
        self._f1 = np.zeros(3, dtype=np.float32)
        self._f2 = np.zeros(3, dtype=np.float32)
        self._torque = np.zeros(3, dtype=np.float32)
        self._reach = params["contact_offset"]
        self._last = self.state()

    def state(self) -> tuple[float, float, float, float]:
        h = self.h
        self._last = out = (
            float(self.body1.entity_pose.p[0]) + h, float(self.body1.linear_velocity[0]),
            float(self.body2.entity_pose.p[0]) - h, float(self.body2.linear_velocity[0]))
        return out

    def step(self) -> float:
        """:meth:`advance` from the state last read, then the force of that step: the
        injected law's, or the engine's reported contact impulse / dt (read only when the
        bodies were within reach: contact offset + 2·|Δẋ|·dt)."""
        x1, v1, x2, v2 = self._last
        f = self.advance(x1, x2)
        if self.law is not None:
            return f
        w = self.world
        near = x1 - x2 + self._reach + 2.0 * abs(v1 - v2) * w.dt > 0.0
        return w.contact_force_n() if near else 0.0

    def advance(self, x1: float | None = None, x2: float | None = None) -> float:
        """Apply this step's forces (injected law, softening term; at positions x1, x2,
        read from the engine if not given) and step the engine; returns the injected
        contact force (N; 0 without a law)."""
        if (x1 is None or x2 is None) and (self.law is not None or self.beta):
            x1, _, x2, _ = self.state()
        f, extra = 0.0, self.beta * x2**3 if self.beta else 0.0
        if self.law is not None:
            dx = x1 - x2
            f = self.law.force(dx)
            self.law.update(dx)
            self._f1[0] = -f
            self.body1.add_force_torque(self._f1, self._torque)
        if f != 0.0 or extra != 0.0:
            self._f2[0] = f + extra
            self.body2.add_force_torque(self._f2, self._torque)
        self.world.scene.step()
        return f


class ObliqueModel(_BallAbovePlate):
    """The oblique impact: the ball (a sphere with its own moment of inertia) moving along +x
    and −z onto the plate; ``contact`` set: no collision shape and the injected normal law
    and Coulomb friction act at the contact point."""

    def __init__(self, scenario: Oblique, params: dict[str, Any], dt: float,
                 contact: stepping.CoulombContact | None = None) -> None:
        self.radius = scenario.radius_m
        self.mass, self.dt = scenario.mass_kg, dt
        self.contact = contact
        super().__init__(params, dt, 0.0, scenario.radius_m, scenario.mass_kg,
                         scenario.moment_of_inertia_kg_m2,
                         [scenario.tangential_velocity_m_s, 0.0, -scenario.normal_velocity_m_s],
                         [0.0, scenario.spin_rad_s, 0.0],  # n × t = +y
                         driven=contact is not None)

    def state(self) -> tuple[float, float, float, float]:
        body = self.body
        v, w = body.linear_velocity, body.angular_velocity
        self._last = out = (-float(body.entity_pose.p[2]), -float(v[2]), float(v[0]),
                            float(w[1]))
        return out

    def step(self) -> tuple[float, float]:
        """One step from the state last read; returns (F_n, F_t): the injected forces, or
        the engine's normal contact impulse / dt (read only within reach of the plate) and
        m·Δv_t/dt (PhysX reports the normal impulse of a contact point only)."""
        x, rate, v_t, spin = self._last
        w = self.world
        if self.contact is not None:
            fn, ft = self.contact.forces(x, rate, v_t, spin)
            if fn > 0.0:
                self._force[0], self._force[2] = ft, fn
                self._torque[1] = -self.radius * ft  # (0, 0, −R) × (F_t, 0, F_n)
                self.body.add_force_torque(self._force, self._torque)
            w.scene.step()
            return fn, ft
        w.scene.step()
        fn = w.contact_force_n() if x + self._reach + 2.0 * abs(rate) * w.dt > 0.0 else 0.0
        return fn, self.mass * (float(self.body.linear_velocity[0]) - v_t) / self.dt


def _physx_version() -> str:
    _, px = _import_sapien()
    return str(getattr(px, "version", lambda: "?")())


def parameters(scenario: Scenario, mode: str, settings: RunSettings, ball: bool
               ) -> tuple[dict[str, Any], dict[str, Any]]:
    """The complete PhysX parameter set for ``mode`` and the run's meta (``ball``: the
    ball-on-plate scenario, else the rigid–flexible pair)."""
    defaults = engine_defaults()
    if mode == "default":
        return dict(defaults), {"contact": "rigid", "engine_defaults": defaults,
                                **_artefacts(defaults, ball)}
    if mode == "custom":
        own = stepping.engine_params("params", settings.params, PARAMETERS)
        params = {**defaults, **own}
        return params, {"contact": _kind(params), "params": own, "engine_defaults": defaults,
                        **_artefacts(params, ball)}
    native = {**defaults, "static_friction": 0.0, "dynamic_friction": 0.0,
              "sleep_threshold": 0.0}
    if mode == "injected":
        law = "hunt_crossley" if ball else scenario.local
        return native, {"contact": "injected force (no collision shapes)", "injected_law": law}
    meta: dict[str, Any] = {}
    if ball:
        v_ref = reference_velocity(settings.options)
        contact = check.one_of("options.contact", settings.options.get("contact", "compliant"),
                               CONTACTS)
        meta.update(reference_velocity_m_s=v_ref)
        if contact == "compliant":
            native["restitution"] = -native_ball_spring(scenario, v_ref)
            meta["not_expressible"] = "contact damping (PhysX compliant contacts are undamped)"
        else:
            native.update(restitution=native_ball_restitution(scenario, v_ref),
                          bounce_threshold=0.0)
    else:
        native["restitution"] = -scenario.k1_n_per_m
        if scenario.local != "linear":
            meta["not_expressible"] = f"the {scenario.local} local law (no contact memory)"
    stepping.apply_tuned(native, meta, mode, settings, PARAMETERS)
    meta.update(contact=_kind(native), restitution=native["restitution"],
                bounce_threshold=native["bounce_threshold"], **_artefacts(native, ball))
    return native, meta


def _kind(params: dict[str, Any]) -> str:
    return "compliant" if params["restitution"] < 0.0 else "rigid"


def _artefacts(params: dict[str, Any], ball: bool) -> dict[str, Any]:
    if _kind(params) == "compliant":
        return {}
    return {"not_comparable": stepping.rigid_artefacts(ball)}


FRICTION_MODEL = ("PhysX patch friction: velocity-level Coulomb in the contact solver, static "
                  "μ_s until the patch slips, dynamic μ_d while it slides")
FRICTION_COMBINATION = "average"
"""PhysX's default combine mode (SAPIEN exposes no other): both materials get μ."""


def _facts(params: dict[str, Any], mu: float, model: str = FRICTION_MODEL,
           rule: str = FRICTION_COMBINATION, **extra: Any) -> dict[str, Any]:
    """The friction facts (``meta["engine_defaults"]``) of a PhysX parameter set."""
    keys = ("static_friction", "dynamic_friction", "enable_friction_every_iteration",
            "enable_tgs", "angular_damping", "max_angular_velocity")
    return stepping.friction_facts(model, rule, mu, mu, mu, **{k: params[k] for k in keys},
                                   **extra)


def oblique_parameters(scenario: Oblique, mode: str, settings: RunSettings
                       ) -> tuple[dict[str, Any], dict[str, Any]]:
    """The complete PhysX parameter set of the oblique impact for ``mode`` and its meta (the
    friction facts in ``meta["engine_defaults"]``).

    ``default``: PhysX's defaults (rigid contact, restitution 0.1 above the 2 m/s bounce
    threshold, spin damping 0.05 /s, spin clamp 100 rad/s, TGS) with the scenario's μ as both
    materials' static and dynamic friction; ``custom``: that plus ``settings.params``;
    ``native``: the ball's native contact (the undamped compliant spring matching the
    reference's duration at the reference velocity; ``options["contact"] = "rigid"``: rigid
    with the reference's restitution there and no bounce threshold), μ, no spin damping or
    clamp; ``injected``: no shapes, the normal law and Coulomb friction as forces."""
    defaults = engine_defaults()
    mu = scenario.friction
    friction = {"static_friction": mu, "dynamic_friction": mu}
    inertia = scenario.moment_of_inertia_kg_m2
    if mode in ("default", "custom"):
        own = stepping.user_params(mode, settings, PARAMETERS)
        params = {**defaults, **friction, **own}
        facts = _facts(params, params["static_friction"], moment_of_inertia_kg_m2=inertia)
        return params, {"contact": _kind(params), "restitution": params["restitution"],
                        "bounce_threshold": params["bounce_threshold"],
                        "engine_defaults": {**defaults, **facts}, **_oblique_artefacts(params),
                        **stepping.params_meta(mode, own)}
    native = {**defaults, **friction, **ROTATION_FREE, "sleep_threshold": 0.0}
    if mode == "injected":
        facts = _facts(native, mu, stepping.INJECTED_FRICTION, "none",
                       moment_of_inertia_kg_m2=inertia)
        return native, {"contact": "injected forces (no collision shapes)",
                        "injected_law": scenario.model, "engine_defaults": facts}
    v_ref = reference_velocity(settings.options)
    contact = check.one_of("options.contact", settings.options.get("contact", "compliant"),
                           CONTACTS)
    meta: dict[str, Any] = {"reference_velocity_m_s": v_ref}
    if mode == "tuned":  # native plus the fitted friction knobs
        applied = oblique_tuned.friction("sapien", settings, scenario, settings.timestep_s)
        native.update(applied)
        meta.update(oblique_tuned.meta(applied, settings))
        mu = applied["dynamic_friction"]
    if contact == "compliant":
        native["restitution"] = -native_ball_spring(scenario.normal_scenario(), v_ref)
        meta["not_expressible"] = "contact damping (PhysX compliant contacts are undamped)"
    else:
        native.update(restitution=native_ball_restitution(scenario.normal_scenario(), v_ref),
                      bounce_threshold=0.0)
    meta.update(contact=_kind(native), restitution=native["restitution"],
                bounce_threshold=native["bounce_threshold"],
                engine_defaults=_facts(native, mu, moment_of_inertia_kg_m2=inertia),
                **_oblique_artefacts(native))
    return native, meta


def _oblique_artefacts(params: dict[str, Any]) -> dict[str, Any]:
    if _kind(params) == "compliant":
        return {}
    return {"not_comparable": stepping.RIGID_OBLIQUE_ARTEFACTS}


class SapienAdapter(stepping.SteppedAdapter):
    """PhysX 5 (SAPIEN 3): compliant (undamped) or rigid contacts; injected laws as forces."""

    name = "sapien"
    parameter_keys = tuple(PARAMETERS)
    ball_model, pair_model, oblique_model = BallModel, PairModel, ObliqueModel
    parameters = staticmethod(parameters)
    oblique_parameters = staticmethod(oblique_parameters)
    # the bounce at SAPIEN's default step: sapien.Scene().timestep, the PhysxCpuSystem's
    # 0.01 s (sapien 3.0.3; its example/hello_world.py sets 1/100 s too)
    builders = stepping.builders(oblique_tuned.refused, "sapien", bounce_s=0.01)
    injection = ("cannot: PhysX's compliant contact is an undamped spring (no damping to "
                 "schedule); the law is an external force (collision off) integrated by PhysX's "
                 "semi-implicit Euler step; oblique: Coulomb friction is a force and torque "
                 "too (no contact with the normal law), −s·m_s/dt clipped to ±μ·F_n")

    def version(self) -> str:
        sapien, _ = _import_sapien()
        return f"{sapien.__version__} (PhysX {_physx_version()})"

    def bounce_threshold(self, model: stepping.SteppedModel) -> float | None:
        """The scene's PhysX ``bounce_threshold`` (m/s), read back from the config of the
        model's PhysX system: a rigid contact with restitution e > 0 bounces only when it
        approaches faster than this (slower: e = 0). None for a compliant contact (a
        spring, no threshold), a rigid e = 0 or an injected law (no shape)."""
        if not getattr(model, "impulsive", False):
            return None
        world = model.world  # type: ignore[attr-defined]
        if float(world.material.restitution) <= 0.0:
            return None
        return float(world.scene.physx_system.config.bounce_threshold)
