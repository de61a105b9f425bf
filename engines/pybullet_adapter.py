"""PyBullet adapter: both scenarios through Bullet's soft (stiffness/damping) contact.

World (one DIRECT client per run, its world reset in ``finally`` and the client reused,
:mod:`~impactbench.engines.pybullet_clients`):
``fixedTimeStep = dt``, ``numSubSteps = 0``, ``contactBreakingThreshold = 1e-12 m`` (no
speculative contact braking the body before it touches), ``contactSlop = 0`` (the default slop
would shift the penetration by 10 µm), split impulse off; every body has restitution 0,
friction 0, ``linearDamping = angularDamping = 0`` and sleeping disabled.

* Ball on plate: a free sphere (radius R, mass m) moving along −z onto a static box whose top
  face is z = 0; gravity −``gravity_m_s2`` along z. Penetration x = R − z_ball (the same number
  as ``getContactPoints()[8]``, negated), approach speed ẋ = −v_z. The ball starts
  2 + ``RunSettings.phase`` steps of free flight above the plate
  (:func:`~impactbench.engines.base.ball_gap_m`; ``FLIGHT_STEPS`` at the default phase).
* Rigid–flexible: one fixed-base multibody with two sibling prismatic links along x (body 1 and
  body 2, self-collision on), each link a sphere collider. Reduced coordinates keep both bodies
  exactly on the axis without constraint rows competing with the contact row in the solver,
  and sphere colliders make a one-point manifold (a box–box face contact makes four points whose
  impulses the iterative solver shares out). The default joint motors are disabled
  (``VELOCITY_CONTROL, force=0``); the structural force F2(x2) (linear, or cubic softening) is
  applied each step with ``TORQUE_CONTROL`` (explicit in x2). x = Δx = x1 − x2 from first touch.

Bullet's soft contact, measured here (and by the tests) to round-off: with pair stiffness K and
damping D, erp = dt·K/(dt·K + D) and cfm = 1/(dt·(dt·K + D)) make the contact impulse
λ = dt·F with

    F = K·x_{k+1} + D·ẋ_{k+1} = [K·x_k + (D + K·dt)·ẋ*] / (1 + dt·D/m_eff + dt²·K/m_eff),

x_{k+1} = x_k + dt·ẋ_{k+1}, ẋ_{k+1} = ẋ* − F·dt/m_eff (ẋ* the approach speed after gravity and
applied forces, m_eff = 1/(1/m1 + 1/m2), m2 = ∞ for the plate), clipped at F ≥ 0: a backward-Euler
spring–damper, which loses energy like exp(−π·ω·dt/2) per contact.
Pair values combine in series (stiffness) and by sum (damping); body 1 carries the pair's K and
D, body 2 has stiffness ∞ and damping 0 (an unset body would add damping 0.1 N·s/m), so the
pair has exactly K and D.

Modes
* ``native`` ball: the clipped linear spring–damper of
  :func:`impactbench.engines.common.native_ball_spring_damper` (restitution and duration of the
  Hunt–Crossley reference at ``reference_velocity_m_s``, default 1 m/s): with the reference's
  restitution e and duration T, ζ solves e_clip(ζ) = e, ωd = θe(ζ)/T, ωn = ωd/√(1−ζ²),
  K = m·ωn² (N/m), D = 2ζ·√(K·m) (N·s/m). Rigid–flexible: K = k1, D = 0 for every local law.
* ``injected``: the reference law through Bullet's own contact integration (the meaning of
  injection in every adapter, :attr:`PybulletAdapter.injection`). Option ``injection``
  (``settings.options``):
  - ``"secant"`` (default): each step the contact gets the law's secant stiffness and damping
    at the start state, K = c·x_k^(n−1), D = c·b·x_k^n (rigid–flexible: K = F1(x_k)/x_k with
    the law's memory, D = 0), and Bullet's soft contact evaluates that spring–damper at the end
    of the step (backward Euler, above). Bullet's implicit step is part of what is measured:
    it dissipates like exp(−π·ω·dt/2). Measured (dt = 1e-6 s / 1e-7 s) restitution −3.4 % /
    −0.35 % at V0 = 1 m/s and −4.2 % / −0.43 % at 5 m/s, peak force −1.9 % / −0.19 % and
    −2.0 % / −0.20 %; rigid–flexible (1e-5 s) peak −1.1e-3, impulse −6.6e-4, contact time
    +2.5e-3 (linear, 2 m/s).
  - ``"explicit"``: not injection in the suite's sense — a force replay that *cancels*
    Bullet's implicit step, kept only to measure that step's share. From (x_k, ẋ_k) the target
    is the law's force F_t; the backward-Euler end state it implies is
    ẋ' = ẋ* − F_t·dt/m_eff, x' = x_k + dt·ẋ'; the contact gets K = F_t/x', D = 0, so Bullet
    applies exactly F_t and the run equals the explicit stepping of MuJoCo or pymunk.
    Measured against ``"secant"`` at the same steps: restitution −8.9e-5 / −2.8e-7 (1 m/s) and
    −1.8e-4 / −4.6e-7 (5 m/s), peak force +1.1e-3 / +1.1e-4 and +6.3e-3 / +6.1e-4;
    rigid–flexible peak −1.7e-7, impulse −9.6e-8. The difference between the two is
    Bullet's implicit contact step, not its contact model.
    The one step in which a body leaves the overlap (x' ≤ 0) cannot be given a positive force
    by any K, D ≥ 0; Bullet applies 0 there (a tail force of c·(ẋ·dt)^n, negligible).
  (Negative damping is refused by pybullet.) Where the law's force is zero (inside an
  elastoplastic permanent set) the contact gets K = 0, which Bullet clamps to 2.2e-16 N/m: a
  ~1e-20·F_max dust the shared metrics' round-off floor ignores.
* ``tuned``: native with ``settings.tuned["contact_stiffness"]`` (pair K, N/m) and
  ``settings.tuned["contact_damping"]`` (pair D, N·s/m; default 0); ``unsupported`` without them.
* ``default`` (ball): Bullet out of the box. Only the step (``fixedTimeStep``), gravity,
  geometry, mass and the scenario's zero friction are set; everything else is Bullet's:
  the rigid ERP/CFM contact (no contactStiffness/Damping), restitution 0 on both bodies
  (Bullet combines restitutions by product), ``restitutionVelocityThreshold`` 0.2 m/s,
  the default contact breaking threshold and slop, split impulse, 50 solver iterations and
  linear/angular damping 0.04. ``meta["engine_defaults"]`` holds what pybullet reports
  (``getPhysicsEngineParameters``, ``getDynamicsInfo``) and the threshold.
* ``custom`` (ball): ``default`` plus the user's ``settings.params`` by Bullet's own names
  (:data:`PARAMETER_KEYS`). Body keys (``restitution``, ``contactStiffness`` with
  ``contactDamping``, ``linearDamping``) go to the ball with ``changeDynamics`` and are pair
  values: the plate then gets restitution 1, stiffness ∞ and damping 0 so the pair has exactly
  the given value; engine keys (``restitutionVelocityThreshold``, ``erp``, ``contactERP``,
  ``numSolverIterations``, ``useSplitImpulse``, ``contactSlop``,
  ``contactBreakingThreshold``, …) go to ``setPhysicsEngineParameter``.

Large steps: Bullet's soft contact is backward Euler, hence unconditionally stable. In
``native`` mode a step far too large gives a finite, over-damped result (V0 = 5 m/s:
restitution 0.34 at dt = 1e-4 s against 0.75; 0.50 at 1e-2 s, the contact a one-step
impulse whose duration and peak force the metrics flag as not resolved) and a status only
once the explicit structural spring goes unstable (ω2·dt > 2: ``diverged``); the plate is
thick enough that no step carries the ball through it. With ``injection = "explicit"`` the
force overshoots and the body tunnels (ball at dt = 1e-4 s, rigid–flexible at dt = 1e-2 s).

Recording (``impactbench.engines.common.Recorder``): sample k is the state at the start of step k
and the
normal force ``getContactPoints()[9]`` (impulse/dt) Bullet applied over that step. The ball
run stops once it moves away, out of the overlap, with zero force; the rigid–flexible run when
``impactbench.reference.laws.no_further_contact`` holds (after a collapse — body 2's energy
above the softening potential's peak → ``structure_collapsed`` — once body 2 has escaped past
the peak), or at the time cap (``max_time``).

Bounce to rest (``_run_bounce``; :class:`~impactbench.reference.bounce_scenario.Bounce`): the
ball's world and contact for the mode, as the head-on ball at its first impact
(:meth:`Bounce.ball`, V0 = √(2gh)) has them, with the ball released from rest ``height_m``
above the plate under gravity; every step recorded until
:class:`~impactbench.engines.bounce.BounceEnd` (at rest, tunnelled past the plate's mid-plane
or, injected, past the surface by R, non-finite, the cap). At the customary 1/240 s (pybullet's
default ``fixedTimeStep``) Bullet's rigid contact of ``default``/``custom`` bounces by its
restitution (the pair's product; 0 out of the box) only above ``restitutionVelocityThreshold``
(0.2 m/s by default), which the run records in ``meta["bounce_threshold_m_s"]`` whenever the
pair's restitution is above 0.

Oblique impact (``_run_oblique``; frame and channels of
:mod:`impactbench.engines.oblique_common`): the free sphere starts along +x and −z with spin
about +y over a box plate 2 m wide, gravity off. Friction: ``lateralFriction`` μ on the ball
and 1 on the plate (Bullet multiplies the two, so the pair has μ); Bullet's friction is rigid
Coulomb at the velocity level (lateral friction rows clamped at μ times the normal impulse).
The record's friction force is ``getContactPoints()`` lateral friction 1 and 2 along their
directions (impulse/dt; Bullet reports it on the plate, so it is negated for the ball).

* ``native``: the ball's native pair K, D; rolling/spinning friction and damping 0; Bullet's
  clamp of the ball's velocities (``maxJointVelocity`` 100, the spin in rad/s) lifted; the
  ``contactBreakingThreshold`` is 0.01 (Bullet scales it by the sphere's bounding radius), not
  the ball's 1e-12: with that, a rolling ball's manifold keeps adding points (up to four, each a
  full spring of the soft contact), so once the contact sticks the normal force doubles to
  quadruples (restitution 1.57 for 0.90 at 45°). The larger threshold merges each new point
  into the old one (:data:`OBLIQUE_MERGE_FRACTION`).
* ``injected``: the ball's secant scheduling (or ``injection = "explicit"``) for the normal law
  and Bullet's own Coulomb friction. Measured against the rigid reference (2 m/s, μ 0.3,
  dt 1e-6 s): the tangential outcome in stick is exact to round-off (1e-14) at 20°, 45° and
  60°; the restitution carries Bullet's implicit contact step (−3.7 % to −2.8 %; −0.37 % at
  1e-7 s), and at 80° (slide) the tangential impulse μ·(1 + e)·v_n with it (spin −1.4 %);
  with the engine's own e the slide is exact too. ``explicit``: restitution −1.1e-4, spin
  −1.2e-5.
* ``default``: Bullet out of the box (rigid ERP contact, restitution 0, its breaking threshold,
  damping 0.04, the 100 rad/s spin clamp) with the pair's μ as above; at 1e-6 s the ball never
  leaves (restitution 0: ``max_time``), at 1/240 s the ERP push-out gives e ≈ 0.04.
  ``custom``: the ball's keys plus :data:`OBLIQUE_KEYS` (``lateralFriction``,
  ``rollingFriction``, ``spinningFriction``, ``frictionAnchor``, ``angularDamping``,
  ``maxJointVelocity``), set on the ball, read back with ``getDynamicsInfo`` into
  ``meta["engine_defaults"]``.
* ``tuned``: ``native`` with a tuned file's friction knobs on the ball
  (:data:`impactbench.engines.oblique_tuned.SPACES`: ``lateralFriction``, ``frictionAnchor``;
  the plate keeps 1), read back with ``getDynamicsInfo`` into ``meta["engine_defaults"]``; no
  file: ``unsupported`` with the reason.
"""

from __future__ import annotations

import functools
import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from impactbench.engines import oblique_tuned, pybullet_clients
from impactbench.engines.base import (
    RIGID_FLEXIBLE_MODES,
    Adapter,
    EngineUnavailable,
    RunSettings,
    Scenario,
    ball_gap_m,
    ball_phase,
    scenario_builders,
)
from impactbench.engines.bounce import BounceEnd
from impactbench.engines.common import (
    NATIVE_REFERENCE_VELOCITY_M_S,
    Recorder,
    classify,
    reference_velocity,
    silenced_fds,
)
from impactbench.engines.oblique_common import (
    combined,
    elastic_duration_s,
    finish,
    friction_facts,
    native_normal,
    neutral_plate,
    record,
    start,
)
from impactbench.reference import validation as check
from impactbench.reference.bounce_scenario import Bounce
from impactbench.reference.models import spring_damper
from impactbench.reference.record import ImpactRecord, Status
from impactbench.reference.scenarios import BallOnPlate, RigidFlexible
from impactbench.reference.validation import InvalidValue

FLIGHT_STEPS = 2.5
"""Steps of free flight before first touch (the record starts there). The half step puts
first touch between two samples, so the shared metrics locate it by the penetration's zero
crossing instead of extrapolating the force."""
BREAKING_THRESHOLD_M = 1e-12
BULLET_BREAKING_THRESHOLD_M = 0.02
"""Bullet's default ``contactBreakingThreshold`` (m; ``gContactBreakingThreshold`` in
btPersistentManifold.cpp). pybullet keeps it in that process-wide global, not per client:
a native run's 1e-12 would outlive its client and reach the next ``default`` run, whose
later impacts then differ (measured: a bounce with restitution 0.9 that settles after
138 contacts times out after 87). The out-of-box worlds set this value back explicitly."""
PLATE_HALF_THICKNESS_M = 0.01
PLATE_STEPS = 20.0
"""The plate's half thickness is max(1 cm, 20·V0·dt): thick at a practical step, so a contact
that lets the ball sink a whole step (1/240 s at 5 m/s: 21 mm) or a soft contact tuned for that
step never puts its centre below the box's mid-plane (which would flip the contact normal:
tunnelling that is the plate's thinness, not the engine's); thin at a fine step, because
Bullet computes the penetration in the box's frame, whose coordinates lose digits in
proportion to its size (0.5 m: forces off by 6e-13 of the peak instead of 5e-14). Only the top
face z = 0 touches the ball."""


def plate_half_thickness_m(scenario: BallOnPlate, dt: float) -> float:
    """Half thickness (m) of the plate box for this impact velocity and step."""
    return max(PLATE_HALF_THICKNESS_M, PLATE_STEPS * scenario.velocity_m_s * dt)
RESTITUTION_VELOCITY_THRESHOLD_M_S = 0.2
"""Bullet's default ``btContactSolverInfo::m_restitutionVelocityThreshold`` (m/s): below this
approach speed Bullet applies no restitution."""
BODY_KEYS: tuple[str, ...] = ("restitution", "contactStiffness", "contactDamping",
                              "linearDamping")
ENGINE_KEYS: tuple[str, ...] = ("restitutionVelocityThreshold", "erp", "contactERP",
                                "numSolverIterations", "useSplitImpulse",
                                "splitImpulsePenetrationThreshold", "contactSlop",
                                "contactBreakingThreshold", "numSubSteps")
PARAMETER_KEYS: tuple[str, ...] = BODY_KEYS + ENGINE_KEYS
"""``custom``-mode keys: pybullet's own ``changeDynamics`` / ``setPhysicsEngineParameter``
argument names."""
INTEGER_KEYS = ("numSolverIterations", "useSplitImpulse", "numSubSteps")
OBLIQUE_DT_S = 1e-6
OBLIQUE_KEYS: tuple[str, ...] = ("lateralFriction", "rollingFriction", "spinningFriction",
                                 "frictionAnchor", "angularDamping", "maxJointVelocity")
"""``custom``-mode keys of the oblique scenario only (``changeDynamics`` names, set on the
ball; the plate gets the combination's neutral value so the pair has the given number)."""
RF_MIN_RADIUS_M = 0.05
INJECTIONS = ("secant", "explicit")
BALL_DEFAULT_DT_S = 1e-6
RF_DEFAULT_DT_S = 1e-5
BOUNCE_DT_S = 1.0 / 240.0  # pybullet's default fixedTimeStep (getPhysicsEngineParameters)
MIN_STEPS = 64
OUT_OF_BOX_TIME_CAP_S = 0.5
"""``default``/``custom`` without a soft contact: the rigid contact's push-out (ERP) spans a
few steps, not a physical duration; the cap only bounds a ball that never lets go."""


def _import_engine() -> Any:
    try:
        with silenced_fds():  # pybullet prints its build time from C on import
            import pybullet
    except ImportError as exc:  # pragma: no cover - exercised where pybullet is absent
        raise EngineUnavailable("pybullet", str(exc)) from exc
    return pybullet


@functools.lru_cache(maxsize=1)
def _version() -> str:
    """The installed pybullet's version (cached: the metadata lookup costs ~0.6 ms per run)."""
    from importlib.metadata import PackageNotFoundError, version

    _import_engine()
    try:
        return version("pybullet")
    except PackageNotFoundError:  # pragma: no cover
        return "unknown"


def _connect(p: Any, dt: float, gravity_z: float = 0.0) -> int:
    cid = pybullet_clients.acquire(p)
    p.setPhysicsEngineParameter(
        fixedTimeStep=dt, numSubSteps=0, contactBreakingThreshold=BREAKING_THRESHOLD_M,
        contactSlop=0.0, useSplitImpulse=0, restitutionVelocityThreshold=0.0,
        physicsClientId=cid)
    p.setGravity(0.0, 0.0, gravity_z, physicsClientId=cid)
    return cid


def _plain(p: Any, cid: int, body: int, link: int) -> None:
    """Restitution 0, friction 0, no velocity damping, never asleep.

    Each property goes in its own ``changeDynamics`` call: passing ``activationState`` or
    ``maxJointVelocity`` together with the contact stiffness silently drops the stiffness
    (measured with pybullet 3.2.7: the contact became rigid).
    """
    p.changeDynamics(body, link, restitution=0.0, lateralFriction=0.0, rollingFriction=0.0,
                     spinningFriction=0.0, linearDamping=0.0, angularDamping=0.0,
                     physicsClientId=cid)
    p.changeDynamics(body, link, activationState=p.ACTIVATION_STATE_DISABLE_SLEEPING,
                     physicsClientId=cid)


def custom_parameters(params: dict[str, Any]) -> dict[str, Any]:
    """Validated ``custom`` parameters (numbers ≥ 0; integers where Bullet wants them)."""
    out: dict[str, Any] = {}
    for key, value in params.items():
        if key in INTEGER_KEYS:
            if isinstance(value, bool) or not isinstance(value, int | float) \
                    or value != int(value) or value < 0:
                raise InvalidValue(f"param {key} = {value!r}: must be an integer >= 0")
            out[key] = int(value)
        elif key == "splitImpulsePenetrationThreshold":
            out[key] = check.finite(f"param {key}", value)
        else:
            out[key] = check.non_negative(f"param {key}", value)
    if ("contactStiffness" in out) != ("contactDamping" in out):
        raise ValueError("param contactStiffness/contactDamping: give both (Bullet applies "
                         "a soft contact only with both set)")
    return out


class BallWorld:
    """Free sphere above a static box plate; pair contact K (N/m), D (N·s/m).

    ``out_of_box`` (``default``/``custom`` modes): Bullet's defaults plus these user
    parameters instead of impactbench's contact set-up (K and D are then ignored).
    ``drop_height_m`` (the bounce to rest): the ball starts at rest with its lowest point this
    far above the plate (m) instead of its gap at −V0: 2 + ``phase`` steps of flight
    (:func:`~impactbench.engines.base.ball_gap_m`; ``phase`` None: ``FLIGHT_STEPS``)."""

    def __init__(self, p: Any, scenario: BallOnPlate, dt: float, k: float, d: float,
                 out_of_box: dict[str, Any] | None = None,
                 drop_height_m: float | None = None, phase: float | None = None) -> None:
        self.p, self.dt, self.radius = p, dt, scenario.radius_m
        self.out_of_box = out_of_box
        self.drop_height_m = drop_height_m
        self.phase = phase
        # the restitutionVelocityThreshold this world sets (m/s): _connect's 0, else the
        # user's key or Bullet's default (btContactSolverInfo.h, 0.2)
        self.threshold_set_m_s = 0.0 if out_of_box is None else float(out_of_box.get(
            "restitutionVelocityThreshold", RESTITUTION_VELOCITY_THRESHOLD_M_S))
        if out_of_box is None:
            self.cid = _connect(p, dt, -scenario.gravity_m_s2)
        else:
            self.cid = pybullet_clients.acquire(p)
            p.setPhysicsEngineParameter(  # Bullet's default, process-wide: set it back
                fixedTimeStep=dt, contactBreakingThreshold=BULLET_BREAKING_THRESHOLD_M,
                physicsClientId=self.cid)
            p.setGravity(0.0, 0.0, -scenario.gravity_m_s2, physicsClientId=self.cid)
        try:
            self._build(scenario, k, d)
        except BaseException:
            self.close()
            raise

    def engine_defaults(self) -> dict[str, Any]:
        """What pybullet reports for this world before the user's parameters are applied."""
        p, cid = self.p, self.cid
        info = p.getDynamicsInfo(self.ball, -1, physicsClientId=cid)
        engine = p.getPhysicsEngineParameters(physicsClientId=cid)
        return {**{k: engine[k] for k in ("fixedTimeStep", "numSubSteps", "numSolverIterations")
                   if k in engine},
                "restitution": info[5], "contactDamping": info[8], "contactStiffness": info[9],
                "collisionMargin_m": info[11],
                "restitutionVelocityThreshold": RESTITUTION_VELOCITY_THRESHOLD_M_S,
                "contactBreakingThreshold": BULLET_BREAKING_THRESHOLD_M,
                "contact": "rigid (ERP/CFM): contactStiffness/contactDamping unset (-1)"}

    def _apply_custom(self, params: dict[str, Any]) -> None:
        p, cid = self.p, self.cid
        engine = {k: v for k, v in params.items() if k in ENGINE_KEYS}
        if engine:
            p.setPhysicsEngineParameter(**engine, physicsClientId=cid)
        if "restitution" in params:
            p.changeDynamics(self.plate, -1, restitution=1.0, physicsClientId=cid)
            p.changeDynamics(self.ball, -1, restitution=params["restitution"],
                             physicsClientId=cid)
        if "linearDamping" in params:
            p.changeDynamics(self.ball, -1, linearDamping=params["linearDamping"],
                             physicsClientId=cid)
        if "contactStiffness" in params:
            p.changeDynamics(self.plate, -1, contactStiffness=math.inf, contactDamping=0.0,
                             physicsClientId=cid)
            self.set_contact(params["contactStiffness"], params["contactDamping"])

    def _build(self, scenario: BallOnPlate, k: float, d: float) -> None:
        p, cid, dt = self.p, self.cid, self.dt
        h = self.plate_half_m = plate_half_thickness_m(scenario, dt)
        box = p.createCollisionShape(p.GEOM_BOX, halfExtents=[0.1, 0.1, h], physicsClientId=cid)
        self.plate = p.createMultiBody(0.0, box, basePosition=[0.0, 0.0, -h],
                                       physicsClientId=cid)
        sphere = p.createCollisionShape(p.GEOM_SPHERE, radius=scenario.radius_m,
                                        physicsClientId=cid)
        drop = self.drop_height_m
        self.gap_m = (ball_gap_m(scenario.velocity_m_s, dt, self.phase) if drop is None
                      else drop)
        self.ball = p.createMultiBody(scenario.mass_kg, sphere,
                                      basePosition=[0.0, 0.0, scenario.radius_m + self.gap_m],
                                      physicsClientId=cid)
        if self.out_of_box is not None:
            for body in (self.plate, self.ball):  # the scenario is frictionless
                p.changeDynamics(body, -1, lateralFriction=0.0, rollingFriction=0.0,
                                 spinningFriction=0.0, physicsClientId=cid)
            self.defaults = self.engine_defaults()
            self._apply_custom(self.out_of_box)
        else:
            for body in (self.plate, self.ball):
                _plain(p, cid, body, -1)
            p.changeDynamics(self.plate, -1, contactStiffness=math.inf, contactDamping=0.0,
                             physicsClientId=cid)
            self.set_contact(k, d)
        v0 = scenario.velocity_m_s if drop is None else 0.0
        p.resetBaseVelocity(self.ball, [0.0, 0.0, -v0], [0.0, 0.0, 0.0], physicsClientId=cid)

    def set_contact(self, k: float, d: float) -> None:
        self.p.changeDynamics(self.ball, -1, contactStiffness=k, contactDamping=d,
                              physicsClientId=self.cid)

    def restitution_threshold_m_s(self) -> float | None:
        """Bullet's ``restitutionVelocityThreshold`` (m/s; below this approach speed a contact
        gets no restitution) where a restitution is in effect — the pair's, the product of the
        two bodies' as ``getDynamicsInfo`` reports them, above 0 — else None. pybullet
        (3.2.7) does not report the threshold in ``getPhysicsEngineParameters``: then it is
        the value this world set (the user's key, else Bullet's default 0.2 m/s,
        ``btContactSolverInfo::m_restitutionVelocityThreshold`` in btContactSolverInfo.h)."""
        p, cid = self.p, self.cid
        pair = (p.getDynamicsInfo(self.ball, -1, physicsClientId=cid)[5]
                * p.getDynamicsInfo(self.plate, -1, physicsClientId=cid)[5])
        if not pair > 0.0:
            return None
        reported = p.getPhysicsEngineParameters(physicsClientId=cid)
        return float(reported.get("restitutionVelocityThreshold", self.threshold_set_m_s))

    def close(self) -> None:
        pybullet_clients.release(self.p, self.cid)


class FlexWorld:
    """Two sibling prismatic links (spheres) on a fixed base, along x; pair contact K, D."""

    def __init__(self, p: Any, scenario: RigidFlexible, dt: float, k: float, d: float) -> None:
        self.p, self.dt = p, dt
        self.cid = _connect(p, dt)
        try:
            self._build(scenario, k, d)
        except BaseException:
            self.close()
            raise

    def _build(self, scenario: RigidFlexible, k: float, d: float) -> None:
        p, cid, dt = self.p, self.cid, self.dt
        r = self.radius_m = rf_sphere_radius_m(scenario)
        self.gap_m = FLIGHT_STEPS * scenario.velocity_m_s * dt
        sphere = p.createCollisionShape(p.GEOM_SPHERE, radius=r, physicsClientId=cid)
        origin, no_turn = [0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]
        self.body = p.createMultiBody(
            0.0, -1, basePosition=origin,
            linkMasses=[scenario.m1_kg, scenario.m2_kg],
            linkCollisionShapeIndices=[sphere, sphere], linkVisualShapeIndices=[-1, -1],
            linkPositions=[[-r - self.gap_m, 0.0, 0.0], [r, 0.0, 0.0]],
            linkOrientations=[no_turn, no_turn], linkInertialFramePositions=[origin, origin],
            linkInertialFrameOrientations=[no_turn, no_turn], linkParentIndices=[0, 0],
            linkJointTypes=[p.JOINT_PRISMATIC, p.JOINT_PRISMATIC],
            linkJointAxis=[[1.0, 0.0, 0.0], [1.0, 0.0, 0.0]],
            flags=p.URDF_USE_SELF_COLLISION, physicsClientId=cid)
        _plain(p, cid, self.body, -1)
        for link in (0, 1):
            _plain(p, cid, self.body, link)
            p.changeDynamics(self.body, link, jointDamping=0.0, physicsClientId=cid)
            p.changeDynamics(self.body, link,
                             maxJointVelocity=10.0 * scenario.velocity_m_s + 1e3,
                             physicsClientId=cid)
            p.setJointMotorControl2(self.body, link, p.VELOCITY_CONTROL, force=0.0,
                                    physicsClientId=cid)
        p.changeDynamics(self.body, 1, contactStiffness=math.inf, contactDamping=0.0,
                         physicsClientId=cid)
        self.set_contact(k, d)
        p.resetJointState(self.body, 0, 0.0, scenario.velocity_m_s, physicsClientId=cid)

    def set_contact(self, k: float, d: float) -> None:
        self.p.changeDynamics(self.body, 0, contactStiffness=k, contactDamping=d,
                              physicsClientId=self.cid)

    def close(self) -> None:
        pybullet_clients.release(self.p, self.cid)


def rf_sphere_radius_m(s: RigidFlexible) -> float:
    """Collider radius (m) for the rigid–flexible bodies: ten times the largest overlap body 1
    could reach against a wall with the softest local stiffness, so the spheres never pass
    through each other (a sphere–sphere overlap is 2r − distance; r ≫ Δx changes nothing)."""
    k_min = min(s.k1_n_per_m, s.kt_n_per_m, s.k1_failed_n_per_m)
    return max(RF_MIN_RADIUS_M, 10.0 * s.velocity_m_s * math.sqrt(s.m1_kg / k_min))


def _hertz_duration_s(s: BallOnPlate) -> float:
    """Elastic (b = 0) contact duration (s): the time-cap estimate."""
    n = s.exponent
    x_max = ((n + 1.0) * s.mass_kg * s.velocity_m_s**2 / (2.0 * s.stiffness)) ** (1.0 / (n + 1.0))
    shape = math.sqrt(math.pi) * math.gamma(1 + 1 / (n + 1)) / math.gamma(0.5 + 1 / (n + 1))
    return 2.0 * x_max / s.velocity_m_s * shape


class PybulletAdapter(Adapter):
    """PyBullet (Bullet 3, maximal-coordinate sphere / Featherstone prismatic links)."""

    name = "pybullet"
    value_check = staticmethod(custom_parameters)
    modes = ("native", "injected", "tuned", "default", "custom")
    parameter_keys = PARAMETER_KEYS + OBLIQUE_KEYS
    injection = ("the law through Bullet's soft contact: its secant stiffness and damping "
                 "scheduled each step, applied by Bullet's implicit (backward-Euler) contact "
                 "step; oblique: with Bullet's own rigid Coulomb friction (lateral friction "
                 "rows clamped at μ times the normal impulse)")
    tuned_parameters = "contact_stiffness, optional contact_damping"
    builders = scenario_builders(
        ball_s=BALL_DEFAULT_DT_S, pair_s=RF_DEFAULT_DT_S, oblique_s=OBLIQUE_DT_S,
        oblique_tuned_check=oblique_tuned.refused, engine_3d="pybullet",
        pair_modes=RIGID_FLEXIBLE_MODES, ball_keys=PARAMETER_KEYS,
        bounce_s=BOUNCE_DT_S)

    def version(self) -> str:
        return _version()

    def run_ball(self, scenario: BallOnPlate, mode: str, settings: RunSettings) -> ImpactRecord:
        return self._run_with(_run_ball, scenario, mode, settings)

    def run_bounce(self, scenario: Bounce, mode: str, settings: RunSettings) -> ImpactRecord:
        return self._run_with(_run_bounce, scenario, mode, settings)

    def run_oblique(self, scenario: Scenario, mode: str, settings: RunSettings
                    ) -> ImpactRecord:
        return self._run_with(_run_oblique, scenario, mode, settings)

    def run_rigid_flexible(self, scenario: RigidFlexible, mode: str, settings: RunSettings
                           ) -> ImpactRecord:
        return self._run_with(_run_flex, scenario, mode, settings)

    def _run_with(self, run: Callable[..., ImpactRecord], scenario: Scenario, mode: str,
                  settings: RunSettings) -> ImpactRecord:
        """What every scenario shares: the injection option, the import."""
        injection = check.one_of("injection", settings.options.get("injection", "secant"),
                                 INJECTIONS)
        p = _import_engine()
        dt = float(settings.timestep_s or self.default_timestep_s(scenario, mode))
        return run(p, scenario, mode, settings, dt, injection)


# --------------------------------------------------------------------------- oblique impact


OBLIQUE_PLATE_HALF_SIDE_M = 1.0
"""Half side of the plate box along the plate (m): room for the ball's travel along t."""
OBLIQUE_MERGE_FRACTION = 0.01
"""native/injected ``contactBreakingThreshold``: max(this, 5·V·dt/(√3·R)). Bullet scales the
setting by each shape's bounding radius (√3·R for the sphere's box), so two manifold points
closer than ~1.7 % of R (or five steps of travel) merge. With the ball's 1e-12 a rolling
(stuck) ball keeps its old manifold points — they do not drift apart, so they are never
removed — and each new point is added beside them (up to four), each a full spring of the
soft contact: the normal force doubles to quadruples (measured at 45°: restitution 1.57 for
0.90; Kharaz's 2.5 mm sphere at 1e-7 s even while sliding, with a 2.5e-5 setting:
``diverged``). Merged, the contact keeps one point, as a soft contact needs. The price is a
speculative contact from that distance on, which a soft contact softens by its cfm (native:
−0.1 % of restitution against the ball; injected has no stiffness before touch, so none)."""


BULLET_MAX_JOINT_VELOCITY = 100.0
"""Bullet's default clamp on a multibody's velocities (``maxJointVelocity``; the free ball's
spin too, in rad/s): ``default`` keeps it, ``native``/``injected`` lift it."""


def oblique_speed_limit(s: Any) -> float:
    """native/injected ``maxJointVelocity``: ten times the largest speed or spin the impact
    can reach (V, |ω0| + 3.5·V/R), at least Bullet's default."""
    spin = abs(s.spin_rad_s) + 3.5 * s.velocity_m_s / s.radius_m
    return max(BULLET_MAX_JOINT_VELOCITY, 10.0 * max(s.velocity_m_s, spin))


def oblique_breaking_threshold(s: Any, dt: float) -> float:
    """native/injected ``contactBreakingThreshold``: :data:`OBLIQUE_MERGE_FRACTION`."""
    return max(OBLIQUE_MERGE_FRACTION,
               5.0 * s.velocity_m_s * dt / (math.sqrt(3.0) * s.radius_m))


def oblique_parameters(params: dict[str, Any]) -> dict[str, Any]:
    """Validated ``custom`` parameters of the oblique scenario: the ball's and
    :data:`OBLIQUE_KEYS` (``frictionAnchor`` 0 or 1, the others numbers ≥ 0)."""
    out = custom_parameters({k: v for k, v in params.items() if k not in OBLIQUE_KEYS})
    for key in OBLIQUE_KEYS:
        if key not in params:
            continue
        if key == "frictionAnchor":
            value = params[key]
            if isinstance(value, bool) or value not in (0, 1):
                raise InvalidValue(f"param frictionAnchor = {value!r}: must be 0 or 1")
            out[key] = int(value)
        else:
            out[key] = check.non_negative(f"param {key}", params[key])
    return out


class ObliqueWorld(BallWorld):
    """A free sphere above a static box plate, moving at the oblique start (along +x and −z,
    spin about +y); pair contact K, D (native/injected) or Bullet's defaults plus the user's
    parameters (``out_of_box``). Friction: μ on the ball, 1 on the plate (Bullet multiplies
    the two: the pair has μ). The ball's world's helpers (defaults read back, custom keys,
    contact setting) apply as they are; the world itself is built here (no gravity)."""

    def __init__(self, p: Any, s: Any, dt: float, k: float, d: float,
                 out_of_box: dict[str, Any] | None = None) -> None:
        self.p, self.dt, self.radius = p, dt, s.radius_m
        self.out_of_box = out_of_box
        self.speed_limit = oblique_speed_limit(s)
        if out_of_box is None:
            self.cid = _connect(p, dt)
            self.threshold = oblique_breaking_threshold(s, dt)
            p.setPhysicsEngineParameter(contactBreakingThreshold=self.threshold,
                                        physicsClientId=self.cid)
        else:
            self.cid = pybullet_clients.acquire(p)
            self.threshold = None
            p.setPhysicsEngineParameter(  # Bullet's default, process-wide: set it back
                fixedTimeStep=dt, contactBreakingThreshold=BULLET_BREAKING_THRESHOLD_M,
                physicsClientId=self.cid)
            p.setGravity(0.0, 0.0, 0.0, physicsClientId=self.cid)
        try:
            self._build(s, k, d)
        except BaseException:
            self.close()
            raise

    def _build(self, s: Any, k: float, d: float) -> None:  # type: ignore[override]
        p, cid, dt = self.p, self.cid, self.dt
        h = self.plate_half_m = plate_half_thickness_m(s, dt)
        side = OBLIQUE_PLATE_HALF_SIDE_M
        box = p.createCollisionShape(p.GEOM_BOX, halfExtents=[side, side, h],
                                     physicsClientId=cid)
        self.plate = p.createMultiBody(0.0, box, basePosition=[0.0, 0.0, -h],
                                       physicsClientId=cid)
        sphere = p.createCollisionShape(p.GEOM_SPHERE, radius=s.radius_m, physicsClientId=cid)
        st = start(s, dt)
        self.gap_m = st.gap_m
        self.ball = p.createMultiBody(s.mass_kg, sphere,
                                      basePosition=[0.0, 0.0, s.radius_m + st.gap_m],
                                      physicsClientId=cid)
        if self.out_of_box is not None:
            p.changeDynamics(self.ball, -1, lateralFriction=s.friction, physicsClientId=cid)
            p.changeDynamics(self.plate, -1, lateralFriction=neutral_plate("product", s.friction),
                             physicsClientId=cid)
            self.defaults = self.engine_defaults()
            self._apply_custom(self.out_of_box)
            self._apply_friction(self.out_of_box)
        else:
            for body in (self.plate, self.ball):
                _plain(p, cid, body, -1)
            p.changeDynamics(self.ball, -1, lateralFriction=s.friction, physicsClientId=cid)
            p.changeDynamics(self.plate, -1, lateralFriction=neutral_plate("product", s.friction),
                             physicsClientId=cid)
            p.changeDynamics(self.plate, -1, contactStiffness=math.inf, contactDamping=0.0,
                             physicsClientId=cid)
            self.set_contact(k, d)
            # Bullet clamps a multibody's velocities at 100 (rad/s for the spin): lift it
            # (its own call: passed with the contact stiffness it drops the stiffness)
            p.changeDynamics(self.ball, -1, maxJointVelocity=oblique_speed_limit(s),
                             physicsClientId=cid)
        p.resetBaseVelocity(self.ball, [st.tangential_velocity_m_s, 0.0,
                                        -st.normal_velocity_m_s],
                            [0.0, st.spin_rad_s, 0.0], physicsClientId=cid)

    def _apply_friction(self, params: dict[str, Any]) -> None:
        p, cid = self.p, self.cid
        friction = {k: params[k] for k in OBLIQUE_KEYS if k in params
                    and k != "maxJointVelocity"}
        if friction:
            p.changeDynamics(self.ball, -1, **friction, physicsClientId=cid)
        if "maxJointVelocity" in params:  # its own call (see _build)
            p.changeDynamics(self.ball, -1, maxJointVelocity=params["maxJointVelocity"],
                             physicsClientId=cid)

    def friction_facts(self, anchor: int) -> dict[str, Any]:
        """Bullet's friction read back (``getDynamicsInfo``): lateral friction of each body
        and the pair's product, rolling/spinning friction, the anchor flag as set."""
        p, cid = self.p, self.cid
        ball = p.getDynamicsInfo(self.ball, -1, physicsClientId=cid)
        plate = p.getDynamicsInfo(self.plate, -1, physicsClientId=cid)
        model = ("rigid Coulomb, velocity level: two lateral friction rows per contact point "
                 "clamped to ±μ times the point's normal impulse (Bullet's sequential impulse)"
                 + ("; friction anchor: the contact point is kept where it was created"
                    if anchor else ""))
        return friction_facts(
            model, "product", ball[1], plate[1], min(10.0, combined("product", ball[1], plate[1])),
            rollingFriction_ball=ball[6], spinningFriction_ball=ball[7],
            rollingFriction_pair=ball[6] * plate[1] + plate[6] * ball[1],
            frictionAnchor=anchor,
            contactBreakingThreshold=(self.threshold if self.threshold is not None
                                      else "Bullet's default (0.02, not reported)"),
            angularDamping_ball="0 (set)" if self.out_of_box is None else
            self.out_of_box.get("angularDamping", "0.04 (Bullet's default)"),
            maxJointVelocity_ball=(self.speed_limit if self.out_of_box is None else
                                   self.out_of_box.get("maxJointVelocity",
                                                       f"{BULLET_MAX_JOINT_VELOCITY:g} "
                                                       "(Bullet's default clamp)")))



def _contact_start(s: Any, mode: str, settings: RunSettings, injection: str,
                   custom: Callable[[dict[str, Any]], dict[str, Any]],
                   native: Callable[[Any, str, RunSettings],
                                    tuple[float, float, dict[str, Any]]]
                   ) -> tuple[dict[str, Any], dict[str, Any] | None, float, float]:
    """(meta, out-of-box settings or None, contact stiffness K, damping D) of one run of a
    ball scenario: default/custom leave Bullet's contact unless the user sets K and D
    (``custom`` validates the keys), injected sets none (the law runs through the secant),
    native and tuned take ``native``'s."""
    meta: dict[str, Any] = {"scenario": s.name}
    if mode in ("default", "custom"):
        out_of_box = custom(settings.params or {}) if mode == "custom" else {}
        meta["params"] = dict(out_of_box)
        return (meta, out_of_box, out_of_box.get("contactStiffness", 0.0),
                out_of_box.get("contactDamping", 0.0))
    if mode == "injected":
        meta["injection"] = injection
        return meta, None, 0.0, 0.0
    k0, d0, more = native(s, mode, settings)
    meta.update(more)
    return meta, None, k0, d0


def _step_cap(s: Any, settings: RunSettings, dt: float, contact_s: float, injected: bool,
              out_of_box: dict[str, Any] | None, k0: float,
              flight_steps: float = FLIGHT_STEPS) -> int:
    """The largest number of steps: free flight (``flight_steps`` steps: the head-on ball's
    2 + phase), five contacts and (unless injected) five periods of the contact spring, or
    the out-of-box cap when Bullet's rigid contact runs."""
    t_cap = settings.max_time_s or (
        flight_steps * dt + 5.0 * contact_s
        + (0.0 if injected else OUT_OF_BOX_TIME_CAP_S if out_of_box is not None and k0 == 0.0
           else 5.0 * math.pi * math.sqrt(s.mass_kg / k0)))
    return max(MIN_STEPS, math.ceil(t_cap / dt))


def _oblique_native(s: Any, mode: str, settings: RunSettings
                    ) -> tuple[float, float, dict[str, Any]]:
    """The native normal contact of the oblique ball: the ball's linear spring–damper."""
    v_ref = reference_velocity(settings.options)
    sd = native_normal(s, v_ref)
    k0, d0 = sd.stiffness_n_per_m, sd.damping_ns_per_m
    return k0, d0, {"contact_stiffness": k0, "contact_damping": d0,
                    "reference_velocity_m_s": v_ref}

def _run_oblique(p: Any, s: Any, mode: str, settings: RunSettings, dt: float,
                 injection: str) -> ImpactRecord:
    """Record the oblique impact (normal channels as the ball's, the ball's velocity along t,
    its spin about +y and the friction force Bullet reports on it)."""
    injected = mode == "injected"
    meta, out_of_box, k0, d0 = _contact_start(s, mode, settings, injection,
                                              oblique_parameters, _oblique_native)
    n_max = _step_cap(s, settings, dt, elastic_duration_s(s), injected, out_of_box, k0)
    m, radius = s.mass_kg, s.radius_m
    law = s.normal_scenario().law()
    # tuned: native's contact, the fitted friction on the ball (the plate keeps 1)
    applied = oblique_tuned.friction("pybullet", settings, s, dt) if mode == "tuned" else {}
    world = ObliqueWorld(p, s, dt, k0, d0, out_of_box)
    beyond = radius if injected else radius + world.plate_half_m
    anchor = int((out_of_box or applied).get("frictionAnchor", 0))
    if applied:
        world._apply_friction(applied)
        meta.update(oblique_tuned.meta(applied, settings))
    meta["engine_defaults"] = {**(world.defaults if out_of_box is not None else {}),
                               **world.friction_facts(anchor)}
    rows: list[tuple[float, ...]] = []
    inject = _Injection(world, law, injection, dt, m) if injected else None
    end = _BallEnd(beyond)
    try:
        ball, plate, cid = world.ball, world.plate, world.cid
        get_pos, get_vel = p.getBasePositionAndOrientation, p.getBaseVelocity
        contacts, step = p.getContactPoints, p.stepSimulation
        for i in range(n_max):
            x = radius - get_pos(ball, physicsClientId=cid)[0][2]
            lin, ang = get_vel(ball, physicsClientId=cid)
            v = -lin[2]
            if inject is not None:
                inject(x, v)
            step(physicsClientId=cid)
            normal = tangential = 0.0
            for cp in contacts(ball, plate, physicsClientId=cid):
                normal += cp[9]
                # the lateral friction Bullet reports acts on body B (the plate): negate
                tangential -= cp[10] * cp[11][0] + cp[12] * cp[13][0]
            rows.append((i * dt - FLIGHT_STEPS * dt, x, v, normal, lin[0], ang[1], tangential))
            if end.ended(normal, x, v):
                break
        else:
            end.timed_out = True
        x_end = radius - get_pos(ball, physicsClientId=cid)[0][2]
    finally:
        world.close()
    cols = list(zip(*rows, strict=True)) if rows else [()] * 7
    rec = record(s, *cols, meta=meta)
    return finish(rec, s, tunneled=end.tunneled or x_end > beyond,
                  timed_out=end.timed_out and not end.tunneled)


def _tuned_pair(tuned: dict[str, Any]) -> tuple[float, float]:
    if "contact_stiffness" not in tuned:
        raise ValueError("tuned.contact_stiffness = missing: must be given (pair N/m)")
    k = check.positive("tuned.contact_stiffness", tuned["contact_stiffness"])
    d = check.non_negative("tuned.contact_damping", tuned.get("contact_damping", 0.0))
    return k, d


def _ball_native(scenario: BallOnPlate, mode: str, settings: RunSettings
                 ) -> tuple[float, float, dict[str, Any]]:
    if mode == "tuned":
        k, d = _tuned_pair(settings.tuned or {})
        return k, d, {"contact_stiffness": k, "contact_damping": d}
    v_ref = check.positive("reference_velocity_m_s", settings.options.get(
        "reference_velocity_m_s", NATIVE_REFERENCE_VELOCITY_M_S))
    k, d = _native_pair(scenario.replace(velocity_m_s=v_ref, gravity_m_s2=0.0), v_ref)
    return k, d, {"contact_stiffness": k, "contact_damping": d, "reference_velocity_m_s": v_ref}


@functools.lru_cache(maxsize=64)
def _native_pair(scenario: BallOnPlate, v_ref: float) -> tuple[float, float]:
    """(K, D) of the native conversion; cached because the reference solve costs ms, more
    than a whole impact at dt = 1e-6 s (the key drops velocity and gravity, which the
    conversion does not depend on)."""
    from impactbench.engines.common import native_ball_spring_damper

    sd = native_ball_spring_damper(scenario, v_ref)
    return sd.stiffness_n_per_m, sd.damping_ns_per_m


class _Injection:
    """Injected mode's pair contact, set before each step from the start state (x, ẋ):
    ``secant`` the law's spring–damper k, d at x (F = k·x + d·ẋ); ``explicit`` the
    stiffness F/x_end that lands the step on the law's force F, x_end the penetration the
    step reaches under F and gravity (``g_dt`` = g·dt, m/s); none again once the ball is
    out of contact."""

    def __init__(self, world: Any, law: Any, injection: str, dt: float, m: float,
                 g_dt: float = 0.0) -> None:
        self.set_contact, self.law = world.set_contact, law
        self.explicit = injection == "explicit"
        self.dt, self.m, self.g_dt = dt, m, g_dt
        self.scheduled = False

    def __call__(self, x: float, v: float) -> None:
        if x > 0.0:
            if self.explicit:
                dt = self.dt
                target = self.law.force(x, v)
                x_end = x + dt * (v + self.g_dt - target * dt / self.m)
                self.set_contact(target / x_end if x_end > 0.0 and target > 0.0 else 0.0, 0.0)
            else:
                self.set_contact(*spring_damper(self.law, x))  # F = k·x + d·ẋ at this x
            self.scheduled = True
        elif self.scheduled:
            self.set_contact(0.0, 0.0)
            self.scheduled = False


class _BallEnd:
    """When a ball run stops: after a step without force once it has touched, with the ball
    moving away and clear of the plate (x ≤ 0); or with its centre past ``beyond`` (m:
    ``tunneled``) or not finite. ``timed_out`` is set by the caller at the step cap."""

    def __init__(self, beyond: float) -> None:
        self.beyond = beyond
        self.touched = self.tunneled = self.timed_out = False

    def ended(self, force: float, x: float, v: float) -> bool:
        """After a step with normal force ``force`` (N) from penetration x (m), rate v (m/s)."""
        if force > 0.0:
            self.touched = True
        elif self.touched and v < 0.0 and x <= 0.0:
            return True
        if x > self.beyond or not math.isfinite(x):
            self.tunneled = x > self.beyond
            return True
        return False


@dataclass
class _BallSetup:
    """One ball run's world and what goes with it: the run's meta, the contact that
    :func:`_contact_start` chose (``out_of_box`` settings or None, native/tuned stiffness
    ``k0``), the injected law's scheduler (None unless injected) and the tunnelling depth
    ``beyond`` (m: the centre that far below the surface)."""

    world: BallWorld
    meta: dict[str, Any]
    out_of_box: dict[str, Any] | None
    k0: float
    inject: _Injection | None
    beyond: float


def _ball_setup(p: Any, s: BallOnPlate, mode: str, settings: RunSettings, dt: float,
                injection: str, drop_height_m: float | None = None) -> _BallSetup:
    """The head-on ball's world for ``mode`` (``drop_height_m``: released from rest that high,
    the bounce to rest): its contact (:func:`_contact_start`), Bullet's defaults read back
    in default/custom (``meta["engine_defaults"]``), the injected law's scheduler."""
    injected = mode == "injected"
    meta, out_of_box, k0, d0 = _contact_start(s, mode, settings, injection,
                                              custom_parameters, _ball_native)
    # tunnelled: the centre past the plate's mid-plane, where the normal would flip; injected,
    # whose explicit force overshoots at a coarse step, already once past the surface
    beyond = s.radius_m if injected else s.radius_m + plate_half_thickness_m(s, dt)
    world = BallWorld(p, s, dt, k0, d0, out_of_box, drop_height_m, settings.phase)
    if out_of_box is not None:
        meta["engine_defaults"] = world.defaults
    inject = (_Injection(world, s.law(), injection, dt, s.mass_kg, s.gravity_m_s2 * dt)
              if injected else None)
    return _BallSetup(world, meta, out_of_box, k0, inject, beyond)


def _run_ball(p: Any, s: BallOnPlate, mode: str, settings: RunSettings, dt: float,
              injection: str) -> ImpactRecord:
    """Record the ball's impact; see the module docstring for the physics."""
    setup = _ball_setup(p, s, mode, settings, dt, injection)
    world, meta, inject, beyond = setup.world, setup.meta, setup.inject, setup.beyond
    phase = meta["phase"] = ball_phase(settings.phase)
    n_max = _step_cap(s, settings, dt, _hertz_duration_s(s), inject is not None,
                      setup.out_of_box, setup.k0, 2.0 + phase)
    m, radius = s.mass_kg, s.radius_m
    rec = Recorder()
    end = _BallEnd(beyond)
    try:
        ball, plate, cid = world.ball, world.plate, world.cid
        get_pos, get_vel = p.getBasePositionAndOrientation, p.getBaseVelocity
        contacts, step = p.getContactPoints, p.stepSimulation
        loop_start = time.perf_counter()
        for i in range(n_max):
            x = radius - get_pos(ball, physicsClientId=cid)[0][2]
            v = -get_vel(ball, physicsClientId=cid)[0][2]
            if inject is not None:
                inject(x, v)
            step(physicsClientId=cid)
            force = 0.0
            for cp in contacts(ball, plate, physicsClientId=cid):
                force += cp[9]
            rec.append(i * dt, x, v, force, v)
            if end.ended(force, x, v):
                break
        else:
            end.timed_out = True
        meta["loop_wall_s"] = time.perf_counter() - loop_start
        x_end = radius - get_pos(ball, physicsClientId=cid)[0][2]
        v_end = -get_vel(ball, physicsClientId=cid)[0][2]
    finally:
        world.close()
    out = rec.record(m, math.inf, **meta)
    tunneled = end.tunneled or x_end > beyond
    return classify(out, initial_kinetic_j=0.5 * m * (s.velocity_m_s**2 + 2 * s.gravity_m_s2
                                                      * world.gap_m),
                    final_kinetic_j=0.5 * m * v_end**2, tunneled=tunneled,
                    timed_out=end.timed_out and not tunneled)


def _run_bounce(p: Any, scenario: Bounce, mode: str, settings: RunSettings, dt: float,
                injection: str) -> ImpactRecord:
    """Record the bounce to rest: the head-on ball's world for ``mode`` at the first impact
    (:meth:`Bounce.ball`) with the ball released from rest ``height_m`` above the plate,
    every step (t, x = R − z, ẋ = −ż, Bullet's normal force ``getContactPoints()[9]`` over
    the step, ẋ) until :class:`~impactbench.engines.bounce.BounceEnd` ends it."""
    setup = _ball_setup(p, scenario.ball(), mode, settings, dt, injection,
                        drop_height_m=scenario.height_m)
    world, meta, inject = setup.world, setup.meta, setup.inject
    meta.pop("scenario", None)  # the head-on ball's name: this record is the bounce's
    end = BounceEnd(scenario, dt, settings.max_time_s, setup.beyond)
    rec = Recorder()
    append, ended, n_max, radius = rec.append, end.ended, end.n_max, scenario.radius_m
    try:
        threshold = world.restitution_threshold_m_s()
        if threshold is not None:
            meta["bounce_threshold_m_s"] = threshold
        ball, plate, cid = world.ball, world.plate, world.cid
        get_pos, get_vel = p.getBasePositionAndOrientation, p.getBaseVelocity
        contacts, step = p.getContactPoints, p.stepSimulation
        loop_start = time.perf_counter()
        x = radius - get_pos(ball, physicsClientId=cid)[0][2]
        v = -get_vel(ball, physicsClientId=cid)[0][2]
        k = 0
        while k < n_max:
            if inject is not None:
                inject(x, v)
            step(physicsClientId=cid)
            force = 0.0
            for cp in contacts(ball, plate, physicsClientId=cid):
                force += cp[9]
            append(k * dt, x, v, force, v)
            x = radius - get_pos(ball, physicsClientId=cid)[0][2]
            v = -get_vel(ball, physicsClientId=cid)[0][2]
            k += 1
            if ended(x, v, force):
                break
        meta["loop_wall_s"] = time.perf_counter() - loop_start
    finally:
        world.close()
    append(k * dt, x, v, 0.0, v)
    return end.finish(rec, scenario, v, **meta, steps=k)


def _run_flex(p: Any, s: RigidFlexible, mode: str, settings: RunSettings, dt: float,
              injection: str) -> ImpactRecord:
    """Record the rigid–flexible impact(s); see the module docstring for the physics."""
    from impactbench.reference.laws import no_further_contact

    injected = mode == "injected"
    meta: dict[str, Any] = {"scenario": s.name}
    if mode == "tuned":
        k0, d0 = _tuned_pair(settings.tuned or {})
    elif injected:
        k0, d0 = 0.0, 0.0
        meta["injection"] = injection
    else:
        k0, d0 = s.k1_n_per_m, 0.0
    if not injected:
        meta.update(contact_stiffness=k0, contact_damping=d0)
    meta["collider_radius_m"] = rf_sphere_radius_m(s)
    t_cap = settings.max_time_s or s.max_time_s
    n_max = max(MIN_STEPS, math.ceil(t_cap / dt))
    m1, m2 = s.m1_kg, s.m2_kg
    m_eff = 1.0 / (1.0 / m1 + 1.0 / m2)
    law, structure = s.local_law(), s.structural_law()
    collapse = structure.collapse_energy
    softening = math.isfinite(collapse)
    rec = Recorder()
    world = FlexWorld(p, s, dt, k0, d0)
    status = None
    try:
        body, cid, gap = world.body, world.cid, world.gap_m
        states, contacts, step = p.getJointStates, p.getContactPoints, p.stepSimulation
        motor, torque, set_contact = p.setJointMotorControl2, p.TORQUE_CONTROL, world.set_contact
        touched = timed_out = tunneled = False
        overlap_limit = 2.0 * world.radius_m
        u1 = u2 = x2_end = 0.0
        loop_start = time.perf_counter()
        for i in range(n_max):
            (q1, u1, _, _), (x2, u2, _, _) = states(body, (0, 1), physicsClientId=cid)
            x1 = q1 - gap
            x = x1 - x2
            v = u1 - u2
            f2 = structure.force(x2)
            if softening and status is None and \
                    0.5 * m2 * u2 * u2 + structure.potential(x2) > collapse:
                status = (Status.STRUCTURE_COLLAPSED,  # flagged; the run goes on
                          "body 2's energy exceeds the softening potential's peak")
            motor(body, 1, torque, force=-f2, physicsClientId=cid)
            if injected:
                target = law.force(x)
                law.update(x)
                if injection == "explicit":
                    x_end = x + dt * (v + f2 * dt / m2 - target * dt / m_eff)
                    set_contact(target / x_end if x_end > 0.0 and target > 0.0 else 0.0, 0.0)
                else:
                    set_contact(target / x if x > 0.0 else 0.0, 0.0)
            step(physicsClientId=cid)
            force = 0.0
            for cp in contacts(body, body, 0, 1, physicsClientId=cid):
                force += cp[9]
            rec.append(i * dt, x, v, force, u1, u2, x2)
            if force > 0.0:
                touched = True
            elif touched and no_further_contact(x1, u1, x2, u2, m2, structure):
                break
            if not (math.isfinite(x) and math.isfinite(x2)) or x > overlap_limit:
                tunneled = x > overlap_limit
                break
        else:
            timed_out = True
        meta["loop_wall_s"] = time.perf_counter() - loop_start
        (_, u1, _, _), (x2_end, u2, _, _) = states(body, (0, 1), physicsClientId=cid)
    finally:
        world.close()
    out = rec.record(m1, m2, with_displacement_2=True, **meta)
    kinetic_0 = 0.5 * m1 * s.velocity_m_s**2
    final = 0.5 * m1 * u1 * u1 + 0.5 * m2 * u2 * u2 + structure.potential(x2_end)
    out = classify(out, initial_kinetic_j=kinetic_0, final_kinetic_j=final,
                   tunneled=tunneled, timed_out=timed_out)
    if status is not None and out.status in (Status.OK, Status.MAX_TIME):
        out.status, out.message = status
    return out
