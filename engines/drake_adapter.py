"""Drake adapter: MultibodyPlant point contact (native, tuned) or the reference law applied as a
generalized force (injected), integrated with a fixed step.

Time stepping
    The plant is *continuous* (``time_step = 0``) and integrated by Drake's ``runge_kutta3``
    in fixed-step mode (error control off, every step exactly ``timestep_s``), so the timestep
    setting is a real step size and a work-precision sweep over it means something. Why this
    and not a discrete plant: in continuous mode Drake's point contact force is exactly
    f = k·x·(1 + d·ẋ)₊ (checked to 1e-7 against a tight ODE), and a force injected through an
    input port is evaluated at every Runge–Kutta stage, so the reference law enters the step at
    third order; the discrete solvers (TAMSI/Similar/Lagged) linearise the contact implicitly at
    first order (numerical damping at moderate ω·dt) and SAP ignores d altogether. Explicit
    RK3 is only conditionally stable: a timestep far beyond 1/ω blows up and is reported as
    ``diverged``/``tunneled`` rather than silently damped. ``options["integrator"]`` selects
    another of Drake's schemes (still fixed-step), e.g. ``runge_kutta2``.

Ball on plate (MODELS.md §1)
    A sphere (mass m, radius R) on a prismatic joint along world z hits the plate, the top face
    z = 0 of a 1 m box welded to the world; penetration x = R − z, velocity_1 = −ż; gravity
    is (0, 0, −g) with g = ``scenario.gravity_m_s2`` (0 by default); friction 0. The ball starts
    2 + ``RunSettings.phase`` steps of flight away from the plate
    (:func:`~impactbench.engines.base.ball_gap_m`; ``FREE_FLIGHT_STEPS``, 2.5, at the default
    phase).

    * native: Drake's point contact, f = k·x·(1 + d·ẋ)₊ — linear Hunt–Crossley. Its
      restitution depends on α = d·V0 alone, so d = b gives the reference's restitution at
      every velocity. k is chosen so the *linear* HC duration equals the reference duration at
      the reference velocity V_ref (``impactbench.engines.common.NATIVE_REFERENCE_VELOCITY_M_S``,
      override
      ``options["reference_velocity_m_s"]``). For n = 1 the problem is self-similar with
      t* = √(m/k): T(k) = √(m/k)·τ(α), hence with T₁ = T(k = 1 N/m) at V_ref and
      T_ref = the Hertz–HC reference duration at V_ref:

          k = (T₁ / T_ref)²  [N/m],   d = b  [s/m].

      Drake combines the two geometries' point stiffnesses in series and their dissipations
      weighted by the other's stiffness (d = (k₂d₁ + k₁d₂)/(k₁ + k₂)); both geometries get
      stiffness 2k and dissipation d so the *pair* has exactly k and d (verified by a run).
    * injected: Drake *cannot* run the reference law through its contact model (point
      contact is linear, k·x·(1 + d·ẋ)₊, with no xⁿ and no elastoplastic memory; see
      :attr:`DrakeAdapter.injection`). In the continuous plant a contact force is one more
      term of the ODE right-hand side, integrated by the same fixed-step RK3, so the law is
      applied where a contact force would enter: no collision geometry; a LeafSystem computes
      the reference law
      F = c·xⁿ·(1 + b·ẋ)₊ (``scenario.law()``) from the plant state and feeds it to the plant's
      applied-generalized-force input, so it acts inside every integrator stage. The recorded
      force is that system's output — the force Drake applies.
    * tuned: native with ``settings.tuned`` keys ``point_stiffness_n_per_m`` (pair k, N/m,
      required) and ``hunt_crossley_dissipation_s_per_m`` (pair d, s/m; default b).

Out of the box (ball; ``default`` and ``custom`` modes)
    A *discrete* plant with time step = ``timestep_s``, as a Drake user builds it
    (``AddMultibodyPlant(MultibodyPlantConfig(time_step=dt))``): Drake's default contact model
    (hydroelastic with fallback: the geometries carry no hydroelastic properties, so it falls
    back to point contact), its default discrete contact approximation (``lagged`` in Drake
    1.51) and its default point stiffness and dissipation, estimated by the plant from the
    ``penetration_allowance`` (1 mm); the only contact property set is the scenario's zero
    friction. ``meta["engine_defaults"]`` holds the plant configuration and the plant's
    penalty time scale. ``custom`` overrides these with ``settings.params`` by Drake's own names
    (:data:`PARAMETER_KEYS`): ``point_stiffness`` (pair N/m, each geometry gets 2k) and
    ``hunt_crossley_dissipation`` (s/m), ``relaxation_time`` (s, the dissipation SAP-family
    approximations use), ``discrete_contact_approximation`` (tamsi, sap, similar, lagged;
    ``discrete_contact_solver`` is Drake's older name, tamsi or sap), ``contact_model``,
    ``penetration_allowance`` and ``stiction_tolerance``. ``tuned`` with a
    ``discrete_contact_approximation`` key runs this discrete plant with the tuned point
    stiffness and dissipation (``relaxation_time_s`` for SAP; Drake's customary 1 ms step).
    The discrete plant's contact results port is sampled: after a step it holds the force
    applied over that step, so sample k pairs the state before step k with that force, as the
    other engines' records do.

Bounce to rest (:class:`~impactbench.reference.bounce_scenario.Bounce`)
    The ball's diagram for the mode at the first impact (``scenario.ball()``, V0 = √(2gh),
    gravity on: the same plant, contact settings and injected law as the head-on ball), the
    ball released at rest with its lowest point ``height_m`` above the 1 m plate box, stepped
    at Drake's customary 1 ms (``MultibodyPlantConfig().time_step``) until it rests or the
    cap (:class:`~impactbench.engines.bounce.BounceEnd`), every step recorded as the ball's
    are (the continuous plant: each state with the force there; the discrete plant: the state
    before each step with that step's contact force). Drake's contact is compliant: no
    restitution velocity threshold, so no ``bounce_threshold_m_s``. At 1 ms the paper ball's
    continuous-plant modes (native, injected, a continuous tuned file: ω·dt ≈ 30) are far past
    RK3's stability and diverge; the discrete plant's default contact stops the ball dead.

Rigid–flexible (MODELS.md §2)
    Two bodies on prismatic joints along world x, positions measured from first touch: body 1
    (a sphere whose front surface is at q1) and body 2 (a box whose front face is at q2);
    Δx = q1 − q2. The structural law is a ``PrismaticSpring`` of stiffness k2 on body 2's joint
    plus, for cubic softening, the term +β·x2³ as an applied generalized force.

    * native: point contact with pair stiffness k1 and dissipation 0 for every local law (a
      user's natural mapping); tuned: ``point_stiffness_n_per_m`` (required) and
      ``hunt_crossley_dissipation_s_per_m`` (default 0).
    * injected: no contact geometry; the local law object (``scenario.local_law()``) is applied
      as generalized forces (−F1 on body 1, +F1 on body 2), evaluated with its memory frozen
      during a step; after each accepted step the simulator monitor commits it with
      ``law.update(Δx)`` before anything evaluates the force at the new state.

Measurement and stopping
    One sample per step through the simulator monitor: sample k is the state at the start of
    step k and the force Drake applies at that state — native: the plant's contact results
    output port (sum of ``point_pair_contact_info(i).contact_force()`` along the axis);
    injected: the applied-force system's output. The run stops when the ball is outside the
    plate and moving away (x < 0, ẋ < 0: point contact has no margin, so the force is 0),
    when no further contact is possible (``impactbench.reference.laws.no_further_contact``),
    flagging a structural collapse (body 2's energy above ``collapse_energy``) and ending
    once body 2 escaped, when a body ends past the other (``tunneled``), on a non-finite
    state, or at the time cap (``max_time``).
    Energy check (``impactbench.engines.common.classify``): kinetic energy (+ gravity potential for
    the
    ball; + structural potential for the 2-DOF model) at the end against the start.

Oblique impact (MODELS.md §3; frame and channels of :mod:`impactbench.engines.oblique_common`)
    A free sphere (quaternion floating joint: q = [quaternion, position], v = [ω, v] in the
    world frame) over the plate box, gravity off. Friction facts (the pair rule 2ab/(a + b),
    the effective μ read back from the scene graph's properties, the stiction tolerance, the
    discrete approximation read back from the plant) go to ``meta["engine_defaults"]``.

    * native: the continuous plant with the ball's point contact (k, d = b) and
      ``CoulombFriction(μ, μ)`` on both geometries; friction is Drake's regularised Stribeck
      model with the stiction tolerance 1e-4 m/s (Drake's default; ``options
      ["stiction_tolerance"]`` overrides it). Its slope 2μ·F_n/v_s is far stiffer than one RK3
      step at 1e-6 s can follow, so in the stick phase the slip chatters at ~1e-2 m/s and the
      sampled friction force flips between ±μ·F_n (its samples do not sum to the tangential
      impulse); the chatter averages out: velocities within 1.4e-3 of the rigid theory.
    * injected: no collision geometry; a LeafSystem applies the normal law along +z and
      Coulomb friction along +x at the contact point (torque −R·F_t about +y) as a generalized
      force, F_t = −μ·F_n·s/max(|s|, v_s) with v_s = 3.5·μ·F_n·dt/m, inside which the slip
      decays at the rate 1/dt (RK3 damps it monotonically; the rigid limit as dt → 0).
      Measured against the rigid reference (2 m/s, μ 0.3, dt 1e-6 s, 20°–80°): restitution
      ≤ 4.8e-6, tangential restitution ≤ 7.3e-8, spin ≤ 6.2e-7, rebound angle ≤ 4.5e-6.
    * default / custom: the discrete plant as for the ball (Drake's defaults: lagged, the
      stiction tolerance 1e-4 m/s, point properties from the penetration allowance) with
      ``CoulombFriction(μ, μ)`` on both geometries; custom takes the ball's keys
      (``stiction_tolerance``, ``discrete_contact_approximation``, …).
    * tuned: native with a tuned file's friction knobs
      (:data:`impactbench.engines.oblique_tuned.SPACES`: ``coulomb_friction``, the
      CoulombFriction(μ, μ) of both geometries, and the continuous plant's
      ``stiction_tolerance``); μ is read back from the scene graph
      (``friction_effective``), the stiction tolerance has no getter. No file:
      ``unsupported`` with the reason.

Cost
    Stepping runs inside one ``Simulator.AdvanceTo`` with a per-step monitor (no Python call
    per step besides the monitor); ``benchmarks/bench_engine_drake.py`` compares it with a bare
    ``AdvanceTo`` loop over the same diagram and step count.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np
from impactbench.engines import oblique_tuned
from impactbench.engines.base import (
    PIP,
    RIGID_FLEXIBLE_MODES,
    Adapter,
    Builder,
    EngineUnavailable,
    RunSettings,
    Scenario,
    ball_gap_m,
    ball_phase,
    checked_params,
    scenario_builders,
)
from impactbench.engines.bounce import BounceEnd
from impactbench.engines.common import (
    NATIVE_REFERENCE_VELOCITY_M_S,
    Recorder,
    classify,
)
from impactbench.engines.oblique_common import (
    REGULARISATION_STEPS,
    coulomb_force,
    elastic_duration_s,
    finish,
    friction_facts,
    record,
    start,
)
from impactbench.reference import validation as check
from impactbench.reference.bounce_scenario import Bounce
from impactbench.reference.laws import LocalLaw, StructuralLaw, no_further_contact
from impactbench.reference.record import ImpactRecord, Status
from impactbench.reference.scenarios import BallOnPlate, RigidFlexible

FREE_FLIGHT_STEPS = 2.5
"""Steps of free flight before first touch. Not an integer, so first touch falls mid-step
and no sample sits on the contact edge (where the metrics' edge location degenerates). The
rigid–flexible pair's and the oblique ball's; the head-on ball's is 2 + ``RunSettings.phase``
(this at the default phase)."""
DEFAULT_INTEGRATOR = "runge_kutta3"
BALL_TIMESTEP_S = 1e-6
RIGID_FLEXIBLE_TIMESTEP_S = 1e-5
BOUNCE_TIMESTEP_S = 1e-3  # Drake's customary step: MultibodyPlantConfig().time_step (1.51)
PLATE_SIDE_M = 1.0
"""Side of the cubic plate (m), top face at z = 0 (a box, not a HalfSpace: Drake warns about
half-spaces on every registration)."""
BALL_TIME_CAP_DURATIONS = 100.0
"""Default ball time cap: the free flight plus this many elastic (b = 0) contact durations."""

DISCRETE_APPROXIMATIONS = ("tamsi", "sap", "similar", "lagged")
PARAMETER_KEYS: tuple[str, ...] = (
    "point_stiffness", "hunt_crossley_dissipation", "relaxation_time",
    "discrete_contact_approximation", "discrete_contact_solver", "contact_model",
    "penetration_allowance", "stiction_tolerance")
"""``custom``-mode keys: Drake's own names (contact properties and MultibodyPlantConfig)."""
CONTACT_MODELS = ("point", "hydroelastic_with_fallback", "hydroelastic")
OUT_OF_BOX_CAP_TIME_SCALES = 20.0
"""``default``/``custom`` time cap: this many of the plant's penalty time scales (the default
contact is soft: ~10 ms for the paper's ball)."""

_DRAKE: Any = None


def _drake() -> Any:
    """``pydrake.all``, imported once per process (it takes seconds)."""
    global _DRAKE
    if _DRAKE is None:
        try:
            import pydrake.all as drake_all
        except ImportError as exc:
            raise EngineUnavailable("drake", str(exc)) from exc
        from impactbench.engines.common import quiet_drake_log

        quiet_drake_log()
        _DRAKE = drake_all
    return _DRAKE


# ----------------------------------------------------------------------------------------------
# Parameter mapping
# ----------------------------------------------------------------------------------------------


def native_ball_point_contact(scenario: BallOnPlate, reference_velocity_m_s: float | None = None
                              ) -> tuple[float, float]:
    """Pair (k N/m, d s/m) of Drake's linear Hunt–Crossley point contact for the ball.

    d = b (exact restitution at every velocity); k = (T₁/T_ref)², with T₁ the duration of the
    linear HC contact of stiffness 1 N/m and T_ref the reference (power-law HC) duration, both
    at the reference velocity. Depends on (m, c, n, b, V_ref) only, so it is cached: a velocity
    sweep solves the two reference problems once.
    """
    v_ref = reference_velocity_m_s or NATIVE_REFERENCE_VELOCITY_M_S
    return _point_contact_mapping(scenario.mass_kg, scenario.stiffness, scenario.exponent,
                                  scenario.damping_s_per_m, v_ref)


@functools.lru_cache(maxsize=256)
def _point_contact_mapping(mass_kg: float, stiffness: float, exponent: float,
                           damping_s_per_m: float, v_ref: float) -> tuple[float, float]:
    from impactbench.reference import hunt_crossley

    at_ref = BallOnPlate(velocity_m_s=v_ref, mass_kg=mass_kg, stiffness=stiffness,
                         exponent=exponent, damping_s_per_m=damping_s_per_m)
    t_ref = hunt_crossley.solve(at_ref)["duration_s"]
    t_unit = hunt_crossley.solve(at_ref.replace(stiffness=1.0, exponent=1.0))["duration_s"]
    return float((t_unit / t_ref) ** 2), float(damping_s_per_m)


def _tuned_point_contact(tuned: dict[str, Any], default_dissipation: float) -> tuple[float, float]:
    k = check.positive("point_stiffness_n_per_m", tuned.get("point_stiffness_n_per_m"))
    d = check.non_negative("hunt_crossley_dissipation_s_per_m",
                           tuned.get("hunt_crossley_dissipation_s_per_m", default_dissipation))
    return k, d


# ----------------------------------------------------------------------------------------------
# Diagram building
# ----------------------------------------------------------------------------------------------


@dataclass
class DrakeModel:
    """A built diagram ready to step, with its initial state and force read-out.

    ``force()`` returns the normal force (N) Drake applies at the simulator's current state.
    ``reset()`` restores the initial state (and the local law's memory) and initialises the
    simulator without a monitor, so a bare stepping loop can reuse the same model.
    """

    simulator: Any
    plant: Any
    context: Any
    timestep_s: float
    q0: np.ndarray
    v0: np.ndarray
    force: Callable[[], float]
    law: LocalLaw | None = None
    meta: dict[str, Any] = field(default_factory=dict)
    forces: Callable[[], tuple[float, float]] | None = None
    """Oblique models: (normal force, friction force along t) on the ball at the current
    state (None for the other scenarios)."""

    def reset(self) -> None:
        plant_context = self.plant.GetMyMutableContextFromRoot(self.context)
        self.context.SetTime(0.0)
        self.plant.SetPositions(plant_context, self.q0)
        self.plant.SetVelocities(plant_context, self.v0)
        if self.law is not None:
            self.law.reset()
        self.simulator.clear_monitor()
        self.simulator.Initialize()

    def state(self) -> list[float]:
        """[q…, v…] of the plant, as Python floats."""
        if self.plant.time_step() > 0.0:
            return self.plant.GetPositionsAndVelocities(
                self.plant.GetMyContextFromRoot(self.context)).tolist()
        return self.context.get_continuous_state_vector().CopyToVector().tolist()


def _contact_props(d: Any, stiffness: float, dissipation: float) -> Any:
    props = d.ProximityProperties()
    d.AddContactMaterial(dissipation=dissipation, point_stiffness=stiffness,
                         friction=d.CoulombFriction(0.0, 0.0), properties=props)
    return props


def _add_applied_force(d: Any, builder: Any, plant: Any, nq: int,
                       calc: Callable[[np.ndarray], np.ndarray]) -> Any:
    """Add a LeafSystem mapping the plant state [q, v] to the generalized force τ = calc(state)
    (N per prismatic joint), wired into the plant's applied-generalized-force input."""

    class AppliedForce(d.LeafSystem):
        def __init__(self) -> None:
            super().__init__()
            self._state = self.DeclareVectorInputPort("state", 2 * nq)
            self.DeclareVectorOutputPort("generalized_force", nq, self._calc)

        def _calc(self, context: Any, output: Any) -> None:
            output.SetFromVector(calc(self._state.Eval(context)))

    applied = builder.AddSystem(AppliedForce())
    builder.Connect(plant.get_state_output_port(), applied.get_input_port(0))
    builder.Connect(applied.get_output_port(0), plant.get_applied_generalized_force_input_port())
    return applied


def _simulator(d: Any, builder: Any, plant: Any, dt: float, integrator: str
               ) -> tuple[Any, Any]:
    diagram = builder.Build()
    sim = d.Simulator(diagram)
    config = d.SimulatorConfig(integration_scheme=integrator, max_step_size=dt,
                               use_error_control=False, publish_every_time_step=False)
    d.ApplySimulatorConfig(config, sim)
    sim.get_mutable_integrator().set_fixed_step_mode(True)
    return sim, sim.get_mutable_context()


def _integrator(settings: RunSettings) -> str:
    name = settings.options.get("integrator", DEFAULT_INTEGRATOR)
    return check.one_of("integrator", name, tuple(_drake().GetIntegrationSchemes()))


def custom_parameters(params: dict[str, Any]) -> dict[str, Any]:
    """Validated ``custom`` parameters (Drake's names; see :data:`PARAMETER_KEYS`)."""
    out = {**checked_params(params, ("point_stiffness", "penetration_allowance",
                                     "stiction_tolerance"), check.positive),
           **checked_params(params, ("hunt_crossley_dissipation", "relaxation_time"),
                            check.non_negative)}
    if "discrete_contact_solver" in params:
        solver = check.one_of("param discrete_contact_solver",
                              params["discrete_contact_solver"], ("tamsi", "sap"))
        out["discrete_contact_approximation"] = solver
    if "discrete_contact_approximation" in params:
        out["discrete_contact_approximation"] = check.one_of(
            "param discrete_contact_approximation", params["discrete_contact_approximation"],
            DISCRETE_APPROXIMATIONS)
    if "contact_model" in params:
        out["contact_model"] = check.one_of("param contact_model", params["contact_model"],
                                            CONTACT_MODELS)
    return out


def _discrete_parameters(mode: str, settings: RunSettings) -> dict[str, Any] | None:
    """The discrete plant's user parameters, or None for the continuous plant."""
    if mode == "default":
        return {}
    if mode == "custom":
        return custom_parameters(settings.params or {})
    tuned = settings.tuned or {}
    if mode == "tuned" and "discrete_contact_approximation" in tuned:
        k, diss = _tuned_point_contact(tuned, 0.0)
        params = {"point_stiffness": k, "hunt_crossley_dissipation": diss,
                  "discrete_contact_approximation": tuned["discrete_contact_approximation"]}
        if "relaxation_time_s" in tuned:  # SAP-family: linear Kelvin–Voigt dissipation
            params["relaxation_time"] = tuned["relaxation_time_s"]
        return custom_parameters(params)
    return None


def build_discrete_ball(scenario: BallOnPlate, params: dict[str, Any], dt: float,
                        drop_height_m: float | None = None, phase: float | None = None
                        ) -> DrakeModel:
    """The ball on a discrete plant with Drake's defaults plus ``params`` (see module doc),
    starting as :func:`_ball_start` says (``drop_height_m``: at rest that high, m; else at
    the gap for ``phase``, recorded in ``meta["phase"]``)."""
    d = _drake()
    m, r = scenario.mass_kg, scenario.radius_m
    config_keys = ("discrete_contact_approximation", "contact_model", "penetration_allowance",
                   "stiction_tolerance")
    config = d.MultibodyPlantConfig(time_step=dt,
                                    **{k: params[k] for k in config_keys if k in params})
    builder = d.DiagramBuilder()
    plant, _ = d.AddMultibodyPlant(config, builder)
    ball = plant.AddRigidBody("ball", d.SpatialInertia.SolidSphereWithMass(m, r))
    plant.AddJoint(d.PrismaticJoint("z", plant.world_frame(), ball.body_frame(), [0.0, 0.0, 1.0]))
    plant.mutable_gravity_field().set_gravity_vector([0.0, 0.0, -scenario.gravity_m_s2])
    props = d.ProximityProperties()
    material: dict[str, Any] = {}
    if "point_stiffness" in params:  # a pair value: series combination of 2k and 2k
        material["point_stiffness"] = 2.0 * params["point_stiffness"]
    if "hunt_crossley_dissipation" in params:
        material["dissipation"] = params["hunt_crossley_dissipation"]
    d.AddContactMaterial(friction=d.CoulombFriction(0.0, 0.0), properties=props, **material)
    if "relaxation_time" in params:
        props.AddProperty("material", "relaxation_time", params["relaxation_time"])
    plant.RegisterCollisionGeometry(ball, d.RigidTransform(), d.Sphere(r), "ball", props)
    side = PLATE_SIDE_M
    plant.RegisterCollisionGeometry(plant.world_body(), d.RigidTransform([0, 0, -side / 2]),
                                    d.Box(side, side, side), "plate", props)
    plant.Finalize()
    defaults = {"time_step": config.time_step, "contact_model": config.contact_model,
                "discrete_contact_approximation": config.discrete_contact_approximation,
                "penetration_allowance": config.penetration_allowance,
                "stiction_tolerance": config.stiction_tolerance,
                "contact_penalty_method_time_scale_s":
                    plant.get_contact_penalty_method_time_scale()}
    meta: dict[str, Any] = {
        "plant": f"discrete (time_step = {dt!r} s), {config.discrete_contact_approximation}",
        "force_source": "contact results output port (sampled: the force of the last step)",
        "params": dict(params), "engine_defaults": defaults}
    if drop_height_m is None:
        meta["phase"] = ball_phase(phase)
    sim, context = _simulator(d, builder, plant, dt, DEFAULT_INTEGRATOR)
    model = DrakeModel(sim, plant, context, dt,
                       *_ball_start(scenario, dt, drop_height_m, phase), lambda: 0.0,
                       meta=meta)
    model.force = _force_reader(model, axis=2)
    return model


def _ball_start(scenario: BallOnPlate, dt: float, drop_height_m: float | None,
                phase: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The ball's initial (q0, v0) = ([z], [ż]) (m, m/s; z its centre above the plate's top
    face z = 0): the head-on ball 2 + ``phase`` steps of flight (``dt``, s) above the plate
    at −V0 (:func:`~impactbench.engines.base.ball_gap_m`; ``phase`` None:
    ``FREE_FLIGHT_STEPS``); with ``drop_height_m`` (the bounce) at rest, its lowest point
    that high."""
    r = scenario.radius_m
    if drop_height_m is not None:
        return np.array([r + drop_height_m]), np.array([0.0])
    gap = ball_gap_m(scenario.velocity_m_s, dt, phase)
    return np.array([r + gap]), np.array([-scenario.velocity_m_s])


def build_ball(scenario: BallOnPlate, mode: str, settings: RunSettings,
               drop_height_m: float | None = None) -> DrakeModel:
    """The ball-on-plate diagram for ``mode`` (every mode; see the module docstring); the
    ball starts as :func:`_ball_start` says (``drop_height_m``: at rest that high, m; else
    at the gap for ``settings.phase``, recorded in ``meta["phase"]``)."""
    dt = float(settings.timestep_s or BALL_TIMESTEP_S)
    discrete = _discrete_parameters(mode, settings)
    if discrete is not None:
        return build_discrete_ball(scenario, discrete, dt, drop_height_m, settings.phase)
    d = _drake()
    m, r = scenario.mass_kg, scenario.radius_m
    builder = d.DiagramBuilder()
    plant, _ = d.AddMultibodyPlantSceneGraph(builder, 0.0)
    plant.set_contact_model(d.ContactModel.kPoint)
    ball = plant.AddRigidBody("ball", d.SpatialInertia.SolidSphereWithMass(m, r))
    plant.AddJoint(d.PrismaticJoint("z", plant.world_frame(), ball.body_frame(), [0.0, 0.0, 1.0]))
    plant.mutable_gravity_field().set_gravity_vector([0.0, 0.0, -scenario.gravity_m_s2])
    meta: dict[str, Any] = {"plant": "continuous (time_step = 0), point contact"}
    applied = None
    if mode == "injected":
        law = scenario.law()

        def calc(s: np.ndarray) -> np.ndarray:
            return np.array([law.force(r - s[0], -s[1])])

        plant.Finalize()
        applied = _add_applied_force(d, builder, plant, 1, calc)
        meta.update(force_source="applied generalized force (reference Hunt–Crossley law)")
    else:
        if mode == "tuned":
            k, diss = _tuned_point_contact(settings.tuned or {}, scenario.damping_s_per_m)
        else:
            v_ref = settings.options.get("reference_velocity_m_s")
            v_ref = check.positive("reference_velocity_m_s", v_ref) if v_ref is not None else None
            k, diss = native_ball_point_contact(scenario, v_ref)
            meta["reference_velocity_m_s"] = v_ref or NATIVE_REFERENCE_VELOCITY_M_S
        props = _contact_props(d, 2.0 * k, diss)  # series: the pair gets k; weighted mean: d
        plant.RegisterCollisionGeometry(ball, d.RigidTransform(), d.Sphere(r), "ball", props)
        side = PLATE_SIDE_M  # a thick box whose top face is the plane z = 0
        plant.RegisterCollisionGeometry(plant.world_body(), d.RigidTransform([0, 0, -side / 2]),
                                        d.Box(side, side, side), "plate", props)
        plant.Finalize()
        meta.update(force_source="contact results output port (point pair contact force)",
                    native_parameters={"point_stiffness_n_per_m": k,
                                       "hunt_crossley_dissipation_s_per_m": diss,
                                       "geometry_point_stiffness_n_per_m": 2.0 * k})
    integrator = _integrator(settings)
    sim, context = _simulator(d, builder, plant, dt, integrator)
    meta["integrator"] = f"{integrator}, fixed step"
    if drop_height_m is None:
        meta["phase"] = ball_phase(settings.phase)
    model = DrakeModel(sim, plant, context, dt,
                       *_ball_start(scenario, dt, drop_height_m, settings.phase), lambda: 0.0,
                       meta=meta)
    model.force = _force_reader(model, axis=2, applied=applied, sign=1.0)
    return model


def build_bounce(scenario: Bounce, mode: str, settings: RunSettings) -> DrakeModel:
    """The bounce's diagram: the head-on ball's for ``mode`` at the first impact
    (:meth:`Bounce.ball`, gravity on), the ball at rest ``height_m`` above the plate."""
    return build_ball(scenario.ball(), mode, settings, drop_height_m=scenario.height_m)


def build_rigid_flexible(scenario: RigidFlexible, mode: str, settings: RunSettings
                         ) -> DrakeModel:
    """The rigid–flexible diagram for ``mode`` (native, tuned or injected)."""
    d = _drake()
    dt = float(settings.timestep_s or RIGID_FLEXIBLE_TIMESTEP_S)
    s = scenario
    structure = s.structural_law()
    builder = d.DiagramBuilder()
    plant, _ = d.AddMultibodyPlantSceneGraph(builder, 0.0)
    plant.set_contact_model(d.ContactModel.kPoint)
    plant.mutable_gravity_field().set_gravity_vector([0.0, 0.0, 0.0])
    size = _body_size_m(s)
    body1 = plant.AddRigidBody("body1", d.SpatialInertia.SolidSphereWithMass(s.m1_kg, size))
    side = 2.0 * size
    body2 = plant.AddRigidBody("body2", d.SpatialInertia.SolidBoxWithMass(s.m2_kg, side, side,
                                                                          side))
    axis = [1.0, 0.0, 0.0]
    plant.AddJoint(d.PrismaticJoint("x1", plant.world_frame(), body1.body_frame(), axis))
    joint2 = plant.AddJoint(d.PrismaticJoint("x2", plant.world_frame(), body2.body_frame(), axis))
    plant.AddForceElement(d.PrismaticSpring(joint2, 0.0, s.k2_n_per_m))
    meta: dict[str, Any] = {"plant": "continuous (time_step = 0), point contact",
                            "structure": "PrismaticSpring k2"
                            + (" + cubic applied force" if s.structure != "linear" else "")}
    law = s.local_law() if mode == "injected" else None
    if mode != "injected":
        if mode == "tuned":
            k, diss = _tuned_point_contact(settings.tuned or {}, 0.0)
        else:
            k, diss = s.k1_n_per_m, 0.0
        props = _contact_props(d, 2.0 * k, diss)
        plant.RegisterCollisionGeometry(body1, d.RigidTransform([-size, 0.0, 0.0]),
                                        d.Sphere(size), "body1", props)
        plant.RegisterCollisionGeometry(body2, d.RigidTransform([size, 0.0, 0.0]),
                                        d.Box(side, side, side), "body2", props)
        meta.update(force_source="contact results output port (point pair contact force)",
                    native_parameters={"point_stiffness_n_per_m": k,
                                       "hunt_crossley_dissipation_s_per_m": diss,
                                       "geometry_point_stiffness_n_per_m": 2.0 * k})
    else:
        meta.update(force_source=f"applied generalized force (reference {law.name} local law)")
    plant.Finalize()
    applied = None
    if law is not None or s.structure != "linear":
        calc = _rigid_flexible_forces(law, structure, s.k2_n_per_m)
        applied = _add_applied_force(d, builder, plant, 2, calc)
    integrator = _integrator(settings)
    sim, context = _simulator(d, builder, plant, dt, integrator)
    meta.update(integrator=f"{integrator}, fixed step", body_size_m=size)
    gap = FREE_FLIGHT_STEPS * s.velocity_m_s * dt
    model = DrakeModel(sim, plant, context, dt, np.array([-gap, 0.0]),
                       np.array([s.velocity_m_s, 0.0]), lambda: 0.0, law=law, meta=meta)
    # injected: τ[0] = −F1 acts on body 1
    model.force = _force_reader(model, axis=0, applied=applied if law else None, sign=-1.0)
    return model


def _body_size_m(s: RigidFlexible) -> float:
    """Sphere radius / half box size (m): several times any penetration the energy allows.

    Δx ≤ εs + √(m1·v1²/k_min) bounds the overlap, k_min the softest local stiffness.
    """
    k_min = min(s.k1_n_per_m, s.kt_n_per_m, s.k1_failed_n_per_m)
    return max(1.0, 4.0 * (s.eps_s_m + math.sqrt(s.m1_kg * s.velocity_m_s**2 / k_min)))


def _rigid_flexible_forces(law: LocalLaw | None, structure: StructuralLaw, k2: float
                           ) -> Callable[[np.ndarray], np.ndarray]:
    """τ = [−F1, F1 − (F2(x2) − k2·x2)]: the local law (if injected) and the structure's
    non-linear part (the PrismaticSpring supplies −k2·x2)."""

    def calc(state: np.ndarray) -> np.ndarray:
        q1, q2 = state[0], state[1]
        f1 = law.force(q1 - q2) if law is not None else 0.0
        extra = structure.force(q2) - k2 * q2
        return np.array([-f1, f1 - extra])

    return calc


def _force_reader(model: DrakeModel, axis: int, applied: Any = None, sign: float = 1.0
                  ) -> Callable[[], float]:
    """The normal force Drake applies at the current state (N, ≥ 0).

    Native/tuned: the plant's contact results (point pairs, force component on ``axis``).
    Injected: ``sign`` × the first generalized force of the ``applied`` system's output.
    """
    plant, context = model.plant, model.context
    if applied is not None:
        port, sub = applied.get_output_port(0), applied.GetMyContextFromRoot(context)

        def read_injected() -> float:
            return sign * float(port.Eval(sub)[0])

        return read_injected
    port, plant_context = plant.get_contact_results_output_port(), plant.GetMyContextFromRoot(
        context)

    def read_contact() -> float:
        results = port.Eval(plant_context)
        total = 0.0
        for i in range(results.num_point_pair_contacts()):
            total += abs(float(results.point_pair_contact_info(i).contact_force()[axis]))
        return total

    return read_contact


# ----------------------------------------------------------------------------------------------
# Oblique impact
# ----------------------------------------------------------------------------------------------


OBLIQUE_TIMESTEP_S = 1e-6
DRAKE_STICTION_TOLERANCE_M_S = 1e-4
"""Drake's default stiction tolerance (``MultibodyPlantConfig().stiction_tolerance``, Drake
1.51), set explicitly on the continuous plant, which has no getter for it."""


def _friction_props(d: Any, friction: float, stiffness: float | None = None,
                    dissipation: float | None = None, relaxation: float | None = None) -> Any:
    props = d.ProximityProperties()
    material: dict[str, Any] = {}
    if stiffness is not None:
        material["point_stiffness"] = stiffness
    if dissipation is not None:
        material["dissipation"] = dissipation
    d.AddContactMaterial(friction=d.CoulombFriction(friction, friction), properties=props,
                         **material)
    if relaxation is not None:
        props.AddProperty("material", "relaxation_time", relaxation)
    return props


def _effective_friction(d: Any, plant: Any, scene_graph: Any, ids: list[Any]) -> float:
    """The pair's μ Drake computes from the two geometries' properties (read back from the
    scene graph; Drake's rule 2ab/(a + b))."""
    inspector = scene_graph.model_inspector()
    a, b = (inspector.GetProximityProperties(i).GetProperty("material", "coulomb_friction")
            for i in ids)
    return float(d.CalcContactFrictionFromSurfaceProperties(a, b).dynamic_friction())


def _oblique_forces(d: Any, builder: Any, plant: Any, law: Any, s: Any, dt: float) -> Any:
    """Injected: a LeafSystem mapping the free ball's state [q(7), v(6)] to its generalized
    force [torque(3), force(3)] (world frame): the normal law F_n(x, ẋ) along +z and Coulomb
    friction F_t (:func:`~impactbench.engines.oblique_common.coulomb_force`) along +x at the
    contact point (0, 0, −R), whose torque about +y is −R·F_t."""
    r, m, mu = s.radius_m, s.mass_kg, s.friction

    class ObliqueForce(d.LeafSystem):
        def __init__(self) -> None:
            super().__init__()
            self._state = self.DeclareVectorInputPort("state", 13)
            self.DeclareVectorOutputPort("generalized_force", 6, self._calc)

        def _calc(self, context: Any, output: Any) -> None:
            st = self._state.Eval(context)
            normal = law.force(r - st[6], -st[12])
            tangential = coulomb_force(normal, st[10] - r * st[8], mu, m, dt)
            output.SetFromVector([0.0, -r * tangential, 0.0, tangential, 0.0, normal])

    applied = builder.AddSystem(ObliqueForce())
    builder.Connect(plant.get_state_output_port(), applied.get_input_port(0))
    builder.Connect(applied.get_output_port(0), plant.get_applied_generalized_force_input_port())
    return applied


def build_oblique(scenario: Any, mode: str, settings: RunSettings) -> DrakeModel:
    """The oblique diagram for ``mode``: a free sphere over the plate box (module doc,
    oblique section); ``model.forces()`` reads (F_n, F_t) on the ball."""
    d = _drake()
    s = scenario
    dt = float(settings.timestep_s or OBLIQUE_TIMESTEP_S)
    discrete = _discrete_parameters(mode, settings)
    m, r, mu = s.mass_kg, s.radius_m, s.friction
    builder = d.DiagramBuilder()
    meta: dict[str, Any] = {"scenario": s.name}
    applied: dict[str, Any] = {}
    if mode == "tuned":  # native's continuous plant, the fitted friction knobs
        applied = oblique_tuned.friction("drake", settings, s, dt)
        mu = applied["coulomb_friction"]
        meta.update(oblique_tuned.meta(applied, settings))
    if discrete is not None:
        config_keys = ("discrete_contact_approximation", "contact_model",
                       "penetration_allowance", "stiction_tolerance")
        config = d.MultibodyPlantConfig(time_step=dt,
                                        **{k: discrete[k] for k in config_keys if k in discrete})
        plant, scene_graph = d.AddMultibodyPlant(config, builder)
        stiction = config.stiction_tolerance
        meta.update(plant=f"discrete (time_step = {dt!r} s), "
                    f"{config.discrete_contact_approximation}", params=dict(discrete))
    else:
        plant, scene_graph = d.AddMultibodyPlantSceneGraph(builder, 0.0)
        plant.set_contact_model(d.ContactModel.kPoint)
        stiction = check.positive("options.stiction_tolerance", settings.options.get(
            "stiction_tolerance", DRAKE_STICTION_TOLERANCE_M_S))
        if applied:
            stiction = applied["stiction_tolerance"]
        plant.set_stiction_tolerance(stiction)
        meta["plant"] = "continuous (time_step = 0), point contact"
    ball = plant.AddRigidBody("ball", d.SpatialInertia.SolidSphereWithMass(m, r))
    plant.mutable_gravity_field().set_gravity_vector([0.0, 0.0, 0.0])
    applied = None
    if mode == "injected":
        plant.Finalize()
        applied = _oblique_forces(d, builder, plant, s.normal_scenario().law(), s, dt)
        facts = friction_facts(
            "Coulomb as an applied force: μ·F_n against the slip, regularised only within "
            f"v_s = {REGULARISATION_STEPS:g}·3.5·μ·F_n·dt/m (the slip decays at the rate "
            f"1/({REGULARISATION_STEPS:g}·dt) there)", "none", mu, mu, mu)
        meta.update(force_source="applied generalized force (reference normal law and "
                    "Coulomb friction)", engine_defaults=facts)
    else:
        if discrete is not None:
            props = _friction_props(
                d, mu, 2.0 * discrete["point_stiffness"] if "point_stiffness" in discrete
                else None, discrete.get("hunt_crossley_dissipation"),
                discrete.get("relaxation_time"))
            law = (f"{config.discrete_contact_approximation} discrete contact solver: Coulomb "
                   "friction solved with the contact impulses, regularised within the stiction "
                   "tolerance")
        else:
            v_ref = settings.options.get("reference_velocity_m_s")
            v_ref = check.positive("reference_velocity_m_s", v_ref) if v_ref is not None else None
            k, diss = native_ball_point_contact(s.normal_scenario(), v_ref)
            props = _friction_props(d, mu, 2.0 * k, diss)
            law = ("regularised Coulomb (continuous plant's Stribeck model, static = dynamic "
                   "= μ): the friction rises from 0 to μ·F_n over slip speeds up to the "
                   "stiction tolerance")
            meta.update(reference_velocity_m_s=v_ref or NATIVE_REFERENCE_VELOCITY_M_S,
                        native_parameters={"point_stiffness_n_per_m": k,
                                           "hunt_crossley_dissipation_s_per_m": diss,
                                           "geometry_point_stiffness_n_per_m": 2.0 * k})
        ids = [plant.RegisterCollisionGeometry(ball, d.RigidTransform(), d.Sphere(r), "ball",
                                               props),
               plant.RegisterCollisionGeometry(
                   plant.world_body(), d.RigidTransform([0.0, 0.0, -PLATE_SIDE_M / 2.0]),
                   d.Box(PLATE_SIDE_M, PLATE_SIDE_M, PLATE_SIDE_M), "plate", props)]
        plant.Finalize()
        facts = friction_facts(law, "harmonic", mu, mu,
                               _effective_friction(d, plant, scene_graph, ids),
                               stiction_tolerance_m_s=stiction)
        if discrete is not None:  # read back from the plant where it has a getter
            facts.update(time_step=plant.time_step(), contact_model=config.contact_model,
                         discrete_contact_approximation=str(
                             plant.get_discrete_contact_approximation().name).lower()[1:],
                         penetration_allowance=config.penetration_allowance,
                         contact_penalty_method_time_scale_s=(
                             plant.get_contact_penalty_method_time_scale()))
        meta.update(force_source="contact results output port (point pair contact force)",
                    engine_defaults=facts)
    integrator = DEFAULT_INTEGRATOR if discrete is not None else _integrator(settings)
    sim, context = _simulator(d, builder, plant, dt, integrator)
    if discrete is None:
        meta["integrator"] = f"{integrator}, fixed step"
    st = start(s, dt)
    q0 = np.array([1.0, 0.0, 0.0, 0.0, 0.0, 0.0, r + st.gap_m])
    v0 = np.array([0.0, st.spin_rad_s, 0.0, st.tangential_velocity_m_s, 0.0,
                   -st.normal_velocity_m_s])
    model = DrakeModel(sim, plant, context, dt, q0, v0, lambda: 0.0, meta=meta)
    reader = _oblique_reader(model, ball, applied)
    model.force = lambda: reader()[0]
    model.forces = reader
    return model


def _oblique_reader(model: DrakeModel, ball: Any, applied: Any
                    ) -> Callable[[], tuple[float, float]]:
    """(F_n, F_t) on the ball at the current state: the applied system's output (injected) or
    the plant's point-pair contact forces, each taken on the ball (+z normal, +x along t)."""
    context = model.context
    if applied is not None:
        port, sub = applied.get_output_port(0), applied.GetMyContextFromRoot(context)

        def read_injected() -> tuple[float, float]:
            tau = port.Eval(sub)
            return float(tau[5]), float(tau[3])

        return read_injected
    plant = model.plant
    port, plant_context = plant.get_contact_results_output_port(), plant.GetMyContextFromRoot(
        context)
    index = ball.index()

    def read_contact() -> tuple[float, float]:
        results = port.Eval(plant_context)
        normal = tangential = 0.0
        for i in range(results.num_point_pair_contacts()):
            info = results.point_pair_contact_info(i)
            f = info.contact_force()  # on body B
            sign = 1.0 if info.bodyB_index() == index else -1.0
            normal += sign * float(f[2])
            tangential += sign * float(f[0])
        return normal, tangential

    return read_contact


def _run_oblique(model: DrakeModel, scenario: Any, settings: RunSettings) -> ImpactRecord:
    """Step and record the oblique impact (the ball's stopping rules; state [q(7), v(6)])."""
    s = scenario
    r, dt = s.radius_m, model.timestep_s
    read = model.forces
    assert read is not None, "an oblique model reads both forces"
    rows: list[tuple[float, ...]] = []
    flags = {"tunneled": False}
    context = model.context
    discrete = model.plant.time_step() > 0.0
    beyond = r + PLATE_SIDE_M / 2.0 if discrete else 2.0 * r
    before: list[float] = []
    st0 = start(s, dt)

    def monitor(state: list[float]) -> bool:
        x, rate, v_t, spin = r - state[6], -state[12], state[10], state[8]
        normal, tangential = read()
        now = context.get_time() - st0.flight_s
        if not discrete:
            rows.append((now, x, rate, normal, v_t, spin, tangential))
        elif before:
            rows.append((before[0], before[1], before[2], normal, before[3], before[4],
                         tangential))
        before[:] = (now, x, rate, v_t, spin)
        if not math.isfinite(x + rate + normal + tangential + v_t + spin):
            return True
        if x < 0.0 and rate < 0.0:
            return True  # outside the plate and moving away (no force there): separated
        if x >= beyond:
            flags["tunneled"] = True
            return True
        return False

    t_cap = settings.max_time_s if settings.max_time_s is not None else (
        (FREE_FLIGHT_STEPS + 1) * dt + max(BALL_TIME_CAP_DURATIONS * elastic_duration_s(s),
                                           1000 * dt))
    if discrete and settings.max_time_s is None:
        scale = model.meta["engine_defaults"]["contact_penalty_method_time_scale_s"]
        t_cap = max(t_cap, OUT_OF_BOX_CAP_TIME_SCALES * scale)
    stopped, error = _advance(model, monitor, t_cap)
    if discrete and before:
        rows.append((*before[:3], 0.0, *before[3:], 0.0))  # the last state
    cols = list(zip(*rows, strict=True)) if rows else [()] * 7
    out = finish(record(s, *cols, meta=model.meta), s, tunneled=flags["tunneled"],
                 timed_out=not stopped)
    if error and out.status is not Status.DIVERGED:
        out.status, out.message = Status.DIVERGED, f"Drake stopped: {error}"
    return out


@functools.cache
def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("drake")
    except PackageNotFoundError:
        return "unknown"


# ----------------------------------------------------------------------------------------------
# The adapter
# ----------------------------------------------------------------------------------------------


class DrakeAdapter(Adapter):
    """Drake (pydrake) behind the adapter contract; see the module docstring for the physics."""

    name: ClassVar[str] = "drake"
    value_check = staticmethod(custom_parameters)
    injection: ClassVar[str] = (
        "cannot: its point contact is k·x·(1 + d·ẋ)₊ (no xⁿ, no memory); the law is a "
        "generalized force integrated by the same RK3 stages that integrate contact forces "
        "in the continuous plant; oblique: Coulomb friction too (μ·F_n against the slip, "
        "regularised only within the slip one explicit step would overshoot)")
    pip: ClassVar[str] = PIP["drake"]
    modes: ClassVar[tuple[str, ...]] = ("native", "injected", "tuned", "default", "custom")
    parameter_keys: ClassVar[tuple[str, ...]] = PARAMETER_KEYS
    tuned_keys: ClassVar[tuple[str, ...]] = (
        "point_stiffness_n_per_m", "hunt_crossley_dissipation_s_per_m", "relaxation_time_s",
        "discrete_contact_approximation")
    """What ``tuned`` mode reads (:func:`impactbench.tuned.tuned_keys`): the fitted keys of the
    tuning spaces and the discrete approximation a fit at a practical step holds fixed."""
    tuned_parameters: ClassVar[str] = (
        "point_stiffness_n_per_m, optional hunt_crossley_dissipation_s_per_m; a discrete "
        "plant's discrete_contact_approximation and relaxation_time_s")
    builders: ClassVar[dict[str, Builder]] = scenario_builders(
        ball_s=BALL_TIMESTEP_S, pair_s=RIGID_FLEXIBLE_TIMESTEP_S, oblique_s=OBLIQUE_TIMESTEP_S,
        oblique_tuned_check=oblique_tuned.refused, engine_3d="drake",
        pair_modes=RIGID_FLEXIBLE_MODES, bounce_s=BOUNCE_TIMESTEP_S)
    model_builders: ClassVar[dict[str, Callable[[Any, str, RunSettings], DrakeModel]]] = {
        "ball-on-plate": build_ball,
        "rigid-flexible": build_rigid_flexible,
        "oblique": build_oblique,
        "bounce": build_bounce,
    }
    """Scenario name → the function that builds its diagram (:meth:`build`)."""

    def __init__(self) -> None:
        self._import_engine()  # a missing pydrake raises EngineUnavailable here (the registry)

    @staticmethod
    def _import_engine() -> Any:
        """``pydrake.all`` (imported once per process); EngineUnavailable if not installed."""
        return _drake()

    def version(self) -> str:
        return _version()

    def build(self, scenario: Scenario, mode: str, settings: RunSettings) -> DrakeModel:
        """The diagram the adapter steps (public for the benchmark's bare stepping loop)."""
        name = getattr(scenario, "name", type(scenario).__name__)
        if name not in self.model_builders:
            raise ValueError(f"scenario = {name!r}: Drake builds "
                             f"{', '.join(self.model_builders)}")
        return self.model_builders[name](scenario, mode, settings)

    def run_ball(self, scenario: BallOnPlate, mode: str, settings: RunSettings) -> ImpactRecord:
        return self._run_with(_run_ball, scenario, mode, settings)

    def run_rigid_flexible(self, scenario: RigidFlexible, mode: str, settings: RunSettings
                           ) -> ImpactRecord:
        return self._run_with(_run_rigid_flexible, scenario, mode, settings)

    def run_oblique(self, scenario: Scenario, mode: str, settings: RunSettings) -> ImpactRecord:
        return self._run_with(_run_oblique, scenario, mode, settings)

    def run_bounce(self, scenario: Bounce, mode: str, settings: RunSettings) -> ImpactRecord:
        """The bounce to rest: the ball's diagram for ``mode`` (:func:`build_bounce`),
        stepped at ``settings.timestep_s`` until at rest or the cap (:func:`_run_bounce`)."""
        return self._run_with(_run_bounce, scenario, mode, settings)

    def _run_with(self, run: Callable[[DrakeModel, Any, RunSettings], ImpactRecord],
                  scenario: Scenario, mode: str, settings: RunSettings) -> ImpactRecord:
        """What every scenario shares: :meth:`build`, then ``run``."""
        model = self.build(scenario, mode, settings)
        with np.errstate(over="ignore", invalid="ignore"):  # a blow-up is a status, not noise
            return run(model, scenario, settings)


def _advance(model: DrakeModel, monitor: Callable[[Any], bool], t_cap: float,
             initial: bool = True) -> tuple[bool, str]:
    """Step to ``t_cap`` calling ``monitor(state)`` after each step (and on the initial state
    first where ``initial``); True = it stopped the run.

    Returns (stopped_by_monitor, error message if Drake raised)."""
    d = _drake()
    stop = d.EventStatus.ReachedTermination(None, "separated")
    go = d.EventStatus.DidNothing()

    model.reset()
    if model.plant.time_step() > 0.0:
        plant_context = model.plant.GetMyContextFromRoot(model.context)
        positions_and_velocities = model.plant.GetPositionsAndVelocities

        def read() -> list[float]:
            return positions_and_velocities(plant_context).tolist()
    else:
        view = model.context.get_continuous_state_vector()  # a view that stays valid

        def read() -> list[float]:
            return view.CopyToVector().tolist()

    def on_step(_context: Any) -> Any:
        return stop if monitor(read()) else go

    if initial:
        monitor(model.state())  # sample 0: the initial state
    model.simulator.set_monitor(on_step)
    try:
        status = model.simulator.AdvanceTo(t_cap)
    except RuntimeError as exc:  # e.g. a non-finite state caught by Drake
        return True, str(exc).splitlines()[0]
    finally:
        model.simulator.clear_monitor()
    return status.reason() == status.ReturnReason.kReachedTerminationCondition, ""


def _ball_time_cap(scenario: BallOnPlate, settings: RunSettings, dt: float) -> float:
    if settings.max_time_s is not None:
        return settings.max_time_s
    s = scenario
    n = s.exponent
    x_max = ((n + 1) * s.mass_kg * s.velocity_m_s**2 / (2 * s.stiffness)) ** (1 / (n + 1))
    elastic = (2 * x_max / s.velocity_m_s) * math.sqrt(math.pi) * math.gamma(
        1 + 1 / (n + 1)) / math.gamma(0.5 + 1 / (n + 1))
    flight_steps = 2.0 + ball_phase(settings.phase)  # FREE_FLIGHT_STEPS at the default
    return (flight_steps + 1) * dt + max(BALL_TIME_CAP_DURATIONS * elastic, 1000 * dt)


def _tunnel_depth_m(model: DrakeModel, radius_m: float) -> float:
    """The overlap x = R − z (m) past which the ball has tunnelled: in the continuous plant
    the whole ball past the surface (2R); in the discrete plant (a soft default contact may
    sink the ball deeper than its diameter) its centre past the plate box's mid-plane."""
    if model.plant.time_step() > 0.0:
        return radius_m + PLATE_SIDE_M / 2.0
    return 2.0 * radius_m


def _run_ball(model: DrakeModel, scenario: BallOnPlate, settings: RunSettings) -> ImpactRecord:
    r, dt = scenario.radius_m, model.timestep_s
    rec = Recorder()
    flags = {"tunneled": False}
    context = model.context
    discrete = model.plant.time_step() > 0.0
    beyond = _tunnel_depth_m(model, r)
    before: list[float] = []  # discrete: the state before the step whose force is sampled

    def monitor(state: list[float]) -> bool:
        x, rate = r - state[0], -state[1]
        force = model.force()
        if not discrete:
            rec.append(context.get_time(), x, rate, force, rate)
        elif before:
            rec.append(before[0], before[1], before[2], force, before[2])
        before[:] = (context.get_time(), x, rate)
        if not math.isfinite(x + rate + force):
            return True
        if x < 0.0 and rate < 0.0:
            return True  # outside the plate and moving away (the force is 0 there): separated
        if x >= beyond:
            flags["tunneled"] = True
            return True
        return False

    t_cap = _ball_time_cap(scenario, settings, dt)
    if discrete and settings.max_time_s is None:
        scale = model.meta["engine_defaults"]["contact_penalty_method_time_scale_s"]
        t_cap = max(t_cap, OUT_OF_BOX_CAP_TIME_SCALES * scale)
    stopped, error = _advance(model, monitor, t_cap)
    if discrete and before:
        rec.append(before[0], before[1], before[2], 0.0, before[2])  # the last state
    out = rec.record(scenario.mass_kg, **model.meta)
    m, g = scenario.mass_kg, scenario.gravity_m_s2

    def energy(v: float, x: float) -> float:  # kinetic + gravity potential (height −x)
        return 0.5 * m * v * v - m * g * x

    final = energy(out.velocity_1_m_s[-1], out.penetration_m[-1]) if len(out) else math.nan
    out = classify(out, initial_kinetic_j=energy(scenario.velocity_m_s, r - model.q0[0]),
                   final_kinetic_j=final, tunneled=flags["tunneled"], timed_out=not stopped)
    if error and out.status is not Status.DIVERGED:
        out.status, out.message = Status.DIVERGED, f"Drake stopped: {error}"
    return out


def _run_rigid_flexible(model: DrakeModel, scenario: RigidFlexible, settings: RunSettings
                        ) -> ImpactRecord:
    s = scenario
    structure = s.structural_law()
    collapse, m2 = structure.collapse_energy, s.m2_kg
    softening = math.isfinite(collapse)
    size = model.meta["body_size_m"]
    law, context = model.law, model.context
    rec = Recorder()
    flags = {"collapsed": False, "tunneled": False, "contact": False}

    def monitor(state: list[float]) -> bool:
        q1, q2, v1, v2 = state
        dx = q1 - q2
        if law is not None:
            law.update(dx)  # commit the accepted step before the force is evaluated here
        force = model.force()
        rec.append(context.get_time(), dx, v1 - v2, force, v1, v2, q2)
        if not math.isfinite(q1 + q2 + v1 + v2 + force):
            return True
        if force > 0.0:
            flags["contact"] = True
        elif flags["contact"] and no_further_contact(q1, v1, q2, v2, m2, structure):
            return True  # (after a collapse: once body 2 has escaped)
        if softening and 0.5 * m2 * v2 * v2 + structure.potential(q2) > collapse:
            flags["collapsed"] = True  # flagged; the run goes on
        if law is None and dx > size:  # body 1's centre is past body 2's face
            flags["tunneled"] = True
            return True
        return False

    t_cap = settings.max_time_s if settings.max_time_s is not None else s.max_time_s
    stopped, error = _advance(model, monitor, t_cap)
    out = rec.record(s.m1_kg, s.m2_kg, with_displacement_2=True, **model.meta)
    final = math.nan
    if len(out):
        v1, v2, x2 = out.velocity_1_m_s[-1], out.velocity_2_m_s[-1], out.displacement_2_m[-1]
        final = 0.5 * s.m1_kg * v1**2 + 0.5 * s.m2_kg * v2**2 + structure.potential(x2)
    out = classify(out, initial_kinetic_j=0.5 * s.m1_kg * s.velocity_m_s**2,
                   final_kinetic_j=final, tunneled=flags["tunneled"], timed_out=not stopped)
    if error and out.status is not Status.DIVERGED:
        out.status, out.message = Status.DIVERGED, f"Drake stopped: {error}"
    elif flags["collapsed"] and out.status is not Status.DIVERGED:
        out.status = Status.STRUCTURE_COLLAPSED
        out.message = "body 2's energy exceeded the softening structure's collapse energy"
    return out


def _run_bounce(model: DrakeModel, scenario: Bounce, settings: RunSettings) -> ImpactRecord:
    """Step the bounce to rest (:class:`~impactbench.engines.bounce.BounceEnd`) and record
    every step as the ball does: continuous plant, the state after each step with the force
    Drake applies there (sample 0: the release); discrete plant, the state before each step
    with the contact force of that step (sampled port), then the last state with F = 0."""
    r, dt = scenario.radius_m, model.timestep_s
    discrete = model.plant.time_step() > 0.0
    end = BounceEnd(scenario, dt, settings.max_time_s, _tunnel_depth_m(model, r))
    n_max, ended, force = end.n_max, end.ended, model.force
    rec = Recorder()
    append = rec.append
    x0, v0 = r - float(model.q0[0]), -float(model.v0[0])
    last = [x0, v0]  # the state before the step just taken (x m, ẋ m/s)
    steps = [0]

    def monitor(state: list[float]) -> bool:
        x, v = r - state[0], -state[1]
        f = force()
        k = steps[0] = steps[0] + 1
        if discrete:
            append((k - 1) * dt, last[0], last[1], f, last[1])
        else:
            append(k * dt, x, v, f, v)
        last[0], last[1] = x, v
        return ended(x, v, f) or k >= n_max

    if not discrete:
        append(0.0, x0, v0, 0.0, v0)  # the release: at rest, in flight (no force)
    _, error = _advance(model, monitor, (n_max + 0.5) * dt, initial=False)
    if discrete:
        append(steps[0] * dt, last[0], last[1], 0.0, last[1])  # the last state
    out = end.finish(rec, scenario, last[1], **model.meta, steps=steps[0])
    if error and out.status is not Status.DIVERGED:
        out.status, out.message = Status.DIVERGED, f"Drake stopped: {error}"
    return out
