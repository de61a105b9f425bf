"""Tuning spaces of SAPIEN (PhysX 5), DART, Box2D and Newton (see :mod:`.tuning_spaces` for the
:class:`~impactbench.engines.tuning_spaces.Space` contract and MuJoCo/MJX, PyBullet, pymunk,
Drake).

Force laws and units (x penetration, ẋ its rate, m the ball's mass, V0 the impact velocity):

- **SAPIEN / PhysX 5**, ``compliant-stiffness``: a negative material ``restitution`` −K makes
  the contact the undamped spring F = K·x (K in N/m; the pair's value is the average of the two
  materials', so both get −K). Duration π·√(m/K) and peak force V0·√(K·m) follow a linear
  spring; the restitution stays ≈ 1 (0.994 at 1e-6 s: PhysX's own stepping loss) because
  SAPIEN exposes no contact damping, so restitution is not a target. Start: the native K whose
  duration equals the reference's at 1 m/s. ``restitution``: a rigid contact (velocity-level
  target vₙ⁺ = −e·vₙ⁻, e ∈ [0, 1], the pair's the average) with ``bounce_threshold`` = 0 m/s so
  it acts at every approach speed (PhysX's default 2 m/s swallows slower bounces).
- **DART** ``restitution``: rigid LCP contact, vₙ⁺ = −e·vₙ⁻ with e the *product* of the two
  shapes' ``restitution_coeff`` (the plate's is 1, so the pair has the ball's).
- **Box2D** ``restitution``: rigid contact, e the *maximum* of the two fixtures' (the plate's 0),
  applied only when the approach speed exceeds ``b2_velocityThreshold`` (1 m/s, compiled in):
  at and below it the ball stops dead whatever e, so those velocities keep a −100 % restitution
  error that no parameter changes (their residuals are constant in the objective).
- **Newton** ``ke+kd``: Featherstone's penalty contact F = ke·x + kd·max(ẋ, 0) (``ke`` N/m,
  ``kd`` N·s/m, averaged over the two shapes, so both get them). Damping only while approaching:
  e = exp(−ζφ/√(1−ζ²)), T = (φ/√(1−ζ²) + π/2)/ωn with ωn = √(ke/m), ζ = kd/(2√(ke·m)),
  φ = atan2(√(1−ζ²), ζ) — scale-invariant, so e and T do not depend on V0. Start: the native
  (ke, kd) with the reference's restitution and duration at 1 m/s
  (:func:`impactbench.engines.newton_adapter.approach_damped_matching`).

Every start is the adapter's native conversion at 1 m/s, so a tune at its start reproduces
native mode.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
from impactbench.engines.common import NATIVE_REFERENCE_VELOCITY_M_S
from impactbench.engines.tuning_spaces import (
    ALL_METRICS,
    LINEAR_LIMITS,
    RIGID_LIMITS,
    Parameter,
    Space,
    _decades,
    _step_floor,
)
from impactbench.reference.scenarios import BallOnPlate

SAPIEN_DIFF_STEP = 2e-2
"""PhysX's float32 compliant contact: duration and peak force jitter by ~1e-3 (relative)
between stiffnesses 0.1 % apart, so the polish differentiates over ~10 % of K (0.01 of u)."""
NEWTON_DIFF_STEP = 1e-3
"""Newton's float32 metrics jitter by ~5e-6; a 1e-3 step (~1 % of ke) clears it 100-fold."""
CONSTANT_E = ("a constant restitution coefficient cannot follow Hunt–Crossley's restitution, "
              "which falls with the impact velocity")


def _rigid(engine: str, scenario: BallOnPlate, key: str,
           snippet: Callable[[float], str], extra: dict[str, Any] | None = None,
           limits: tuple[str, ...] = ()) -> Space:
    """A rigid contact whose only tuned quantity is a restitution coefficient e (tuned key
    ``key``, plus fixed ``extra`` settings); start: the reference's restitution at 1 m/s."""
    from impactbench.engines.common import native_ball_restitution

    e0 = native_ball_restitution(scenario, NATIVE_REFERENCE_VELOCITY_M_S)
    param = Parameter(key, "1", 1e-3, 1.0)

    def to_tuned(v: np.ndarray) -> dict[str, Any]:
        return {key: float(v[0]), **(extra or {})}

    return Space(engine, "restitution", (param,), (param.clip(e0),), "tuned",
                 frozenset({"restitution"}), (*RIGID_LIMITS, *limits, CONSTANT_E), to_tuned,
                 lambda t: snippet(t[key]), linear=True)


def sapien_space(scenario: BallOnPlate, variant: str = "compliant-stiffness",
                 timestep_s: float | None = None) -> Space:
    """SAPIEN/PhysX: the compliant (undamped) contact stiffness K, or a rigid restitution."""
    if variant == "restitution":
        return _rigid("sapien", scenario, "restitution", lambda e: (
            "cfg = sapien.physx.PhysxSceneConfig(); cfg.bounce_threshold = 0.0\n"
            "sapien.physx.set_scene_config(cfg)  # before creating the scene\n"
            f"material = sapien.physx.PhysxMaterial(0.0, 0.0, {e:.10g})  "
            "# ball and plate (the pair averages them)"),
            extra={"bounce_threshold": 0.0})
    from impactbench.engines.common import native_ball_spring

    k0 = native_ball_spring(scenario, NATIVE_REFERENCE_VELOCITY_M_S)
    k_lo, k_hi = _decades(k0, 2.0, 2.0)
    param = Parameter("compliant_stiffness_n_per_m", "N/m",
                      min(k_lo, _step_floor(scenario.mass_kg, timestep_s)), k_hi)

    def to_tuned(v: np.ndarray) -> dict[str, Any]:
        return {"restitution": -float(v[0])}  # PhysX: restitution −K is compliant stiffness K

    def snippet(t: dict[str, Any]) -> str:
        return (f"material = sapien.physx.PhysxMaterial(0.0, 0.0, {t['restitution']:.10g})\n"
                f"(ball and plate: a negative restitution is PhysX's compliant contact "
                f"stiffness K = {-t['restitution']:.10g} N/m, the pair averages the two)")

    limits = ("PhysX's compliant contact is an undamped spring (SAPIEN exposes no contact "
              "damping): its restitution stays ≈ 1 whatever the stiffness", *LINEAR_LIMITS)
    return Space("sapien", "compliant-stiffness", (param,), (param.clip(k0),), "tuned",
                 ALL_METRICS - {"restitution", "energy_loss_fraction"}, limits, to_tuned,
                 snippet, linear=True, diff_step=SAPIEN_DIFF_STEP)


def dart_space(scenario: BallOnPlate) -> Space:
    """DART: the ball shape's restitution coefficient (the plate's is 1; pair = product)."""
    return _rigid("dart", scenario, "restitution_coeff", lambda e: (
        f"ball_node.getDynamicsAspect().setRestitutionCoeff({e:.10g})\n"
        "plate_node.getDynamicsAspect().setRestitutionCoeff(1.0)  # the pair has the product"))


def box2d_space(scenario: BallOnPlate) -> Space:
    """Box2D: the ball fixture's restitution (the plate's is 0; pair = maximum)."""
    from impactbench.engines.box2d_adapter import build_constants

    threshold = build_constants()["b2_velocityThreshold"]
    return _rigid("box2d", scenario, "restitution", lambda e: (
        f"ball.CreateCircleFixture(radius=R, density=1.0, friction=0.0, restitution={e:.10g})\n"
        "(plate fixture restitution 0: the pair has the maximum)"),
        limits=(f"Box2D applies restitution only above b2_velocityThreshold = {threshold:g} m/s "
                "(compiled in): slower impacts stop dead whatever the coefficient",))


def newton_space(scenario: BallOnPlate, timestep_s: float | None = None) -> Space:
    """Newton: shape contact stiffness ``ke`` (N/m) and approach damping ``kd`` (N·s/m)."""
    from impactbench.engines.newton_adapter import native_ball

    sd = native_ball(scenario.replace(velocity_m_s=NATIVE_REFERENCE_VELOCITY_M_S))
    k0, d0 = sd.stiffness_n_per_m, max(sd.damping_ns_per_m, 1e-9)
    k_lo, k_hi = _decades(k0, 2.0, 2.0)
    d_lo, d_hi = _decades(d0, 2.0, 2.0)
    floor = _step_floor(scenario.mass_kg, timestep_s)
    if floor < k_lo:  # keep the damping ratio's range when the stiffness reaches down
        k_lo, d_lo = floor, d_lo * (floor / k_lo) ** 0.5
    params = (Parameter("ke", "N/m", k_lo, k_hi), Parameter("kd", "N·s/m", d_lo, d_hi))

    def to_tuned(v: np.ndarray) -> dict[str, Any]:
        return {"ke": float(v[0]), "kd": float(v[1])}

    def snippet(t: dict[str, Any]) -> str:
        return (f"cfg = newton.ModelBuilder.ShapeConfig(ke={t['ke']:.10g}, kd={t['kd']:.10g}, "
                "kf=0.0, mu=0.0)\n"
                "builder.add_ground_plane(cfg=cfg); builder.add_shape_sphere(body, radius=R, "
                "cfg=cfg)  # both shapes: the pair averages them (SolverFeatherstone)")

    limits = ("Newton's penalty contact ke·x + kd·max(ẋ, 0) is linear: its restitution and "
              "duration do not depend on the impact velocity and its peak force is ∝ V0, while "
              "Hunt–Crossley's restitution falls with b·V0 and its duration and peak force "
              "follow Hertz's V0^(−1/5) and V0^(6/5)",)
    return Space("newton", "ke+kd", params, (k0, d0), "tuned", ALL_METRICS, limits, to_tuned,
                 snippet, linear=True, diff_step=NEWTON_DIFF_STEP)
