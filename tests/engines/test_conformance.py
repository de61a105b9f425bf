"""Conformance of the engine adapters (real engines, no mocks): every shape the adapters share
is written once here, parametrised over engine × scenario × mode, and each engine's numbers
(tolerances, recorded defaults, the steps it is run at) stand in one table, :data:`ENGINES`.

The shapes: injected reproduces the reference (the ball, the 2-DOF model, the oblique impact)
and its error falls with the step; native maps the reference's restitution (and duration,
where the contact is compliant) and the 2-DOF linear law, or exchanges momentum elastically
where the contact is rigid; tuned needs parameters and uses them; default is what the engine
gives out of the box, its defaults recorded; custom keys reach the engine and bad values are
one-line errors; physical outcomes (collapse, a step too large, an unsupported combination)
are statuses; runs are deterministic. What is one engine's own (a setting read back from the
engine's model, MJX against C MuJoCo, Newton's float32 law and graph stepping) is in
``test_specifics_{mujoco,pybullet,drake,newton}.py`` and, for the smaller engines,
``test_engine_specifics.py``. Adding an engine: its entry in :data:`ENGINES`.

Tolerances are mostly about 3× the error measured on this machine, each measurement (and any
other margin) in a comment beside it (mujoco 4.0.0, pybullet 3.2.7, pymunk 7.3.1, drake
1.51.1, SAPIEN 3.0.3 / PhysX 5.3.1, dartpy 6.20.0, Box2D 2.3.10, mujoco-mjx 3.17.0 on jax
0.10.2 CPU, newton 1.8 on warp, float32); the issue's bounds (injected ball at 1e-7 s:
restitution ≤ 0.5 %, duration and peak ≤ 1 %; 2-DOF: ≤ 1 %) are looser still. An engine that
is not installed skips with the pip command that installs it
(``tests.conftest.require_engine``).
"""

from __future__ import annotations

import dataclasses
import itertools
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pytest
from conftest import assert_escaped_after_whole_contact, rel, require_engine
from impactbench.engines.base import RunSettings, get_adapter
from impactbench.engines.common import native_ball_spring_damper
from impactbench.reference import hunt_crossley, metrics, two_dof
from impactbench.reference.oblique import Oblique, threshold_angle_deg
from impactbench.reference.record import ImpactRecord, Status
from impactbench.reference.scenarios import BallOnPlate, RigidFlexible

from impactbench.evaluate import compare

BALL = ("restitution", "duration_s", "peak_force_n")
RF_METRICS = ("peak_force_n", "pulse_width_s", "impulse_ns")
FLOAT32 = 1.2e-7
"""Box2D keeps velocities in float32: one float32 ulp (2⁻²³), 3× the largest measured error
of an exact rigid restitution (3.97e-8 for e = 0.6 and 0.8)."""
CFM_LOSS = 1e-4
"""DART's constraint-force mixing trims a rigid restitution (not settable): measured 2.1e-5
(native, e = 0.968), 2.4e-5 (e = 0.7), 3.5e-5 (e = 0.4) relative; 3× the worst."""

ANGLES = ((20.0, 0.0), (45.0, 0.0), (60.0, 0.0), (80.0, 0.0))
"""(angle θ in degrees, initial spin ω0 in rad/s) of the 3D engines' oblique checks: stick at
20–60°, slide at 80° (the threshold is 63.9° for the paper's steel ball at 2 m/s, μ 0.3)."""
CASES = (*ANGLES, (45.0, -60.0), (45.0, 60.0))
"""ANGLES with back- and topspin: the 2D engines' and the extras' oblique checks."""


@dataclass(frozen=True)
class Within:
    """Compares equal to a number in [lo, hi] ((lo, hi) when ``strict``)."""

    lo: float = -math.inf
    hi: float = math.inf
    strict: bool = False

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, (int, float)):
            return NotImplemented
        if self.strict:
            return self.lo < other < self.hi
        return self.lo <= other <= self.hi

    def __hash__(self) -> int:
        return hash((self.lo, self.hi, self.strict))


@dataclass(frozen=True)
class Contains:
    """Compares equal to a string (or collection) that contains ``part``."""

    part: str

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, (str, list, tuple, dict)):
            return NotImplemented
        return self.part in other

    def __hash__(self) -> int:
        return hash(self.part)


# ------------------------------------------------------------------------------- table rows


@dataclass(frozen=True)
class ErrorFalls:
    """An injected run's |relative error| against the reference falls strictly at each of
    ``timesteps_s`` (s), for each of ``keys``; ``ratio``: the first over the last exceeds it."""

    scenario: Any
    timesteps_s: tuple[float, ...]
    keys: tuple[str, ...]
    ratio: float | None = None


@dataclass(frozen=True)
class RF:
    """A 2-DOF run at v1 (m/s) with ``local`` on ``structure``: |relative error| of each metric
    within ``tol``; the step (s) the adapter's 1e-5 s unless given; ``yields``: the contact
    passes the elastoplastic law's yield point εs."""

    local: str
    structure: str
    velocity_m_s: float
    tol: dict[str, float]
    timestep_s: float | None = None
    yields: bool = False

    @property
    def scenario(self) -> RigidFlexible:
        return RigidFlexible(velocity_m_s=self.velocity_m_s, local=self.local,
                             structure=self.structure)


@dataclass(frozen=True)
class NativeBall:
    """A native ball run at ``velocity_m_s`` (step in s, None: the adapter's): its restitution
    within ``restitution`` (relative) of the reference's at ``restitution_at_m_s`` (None: at
    the reference velocity, where the conversion is matched), its duration within
    ``duration`` of the reference's at the reference velocity; a rigid contact (one impulse)
    has no comparable duration and, with ``impulse``, the impulse m·(1 + e)·V0 within it."""

    velocity_m_s: float
    timestep_s: float | None
    restitution: float | None = None
    duration: float | None = None
    options: dict[str, Any] = field(default_factory=dict)
    restitution_at_m_s: float | None = None
    rigid: bool = False
    impulse: float | None = None
    recorded: dict[str, Any] = field(default_factory=dict)

    @property
    def reference_velocity_m_s(self) -> float:
        return self.options.get("reference_velocity_m_s", 1.0)


@dataclass(frozen=True)
class Elastic:
    """Native 2-DOF of a rigid contact at 3.3 m/s: e = 1 between equal masses, so body 1
    stops, body 2 swings out and back after half a period π·√(m2/k2), two impacts and the
    impulse 2·m1·v1 within ``impulse`` (relative), the pulse width within ``pulse_width_s``
    (absolute, s); ``rebound``: body 1 leaves at −v1 within it (relative)."""

    impulse: float
    pulse_width_s: float
    timestep_s: float | None = None
    rebound: float | None = None
    recorded: dict[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class Tuned:
    """A tuned ball run at ``velocity_m_s``: ``tuned`` (or a function of the native run's
    record and the scenario giving them); its measured metrics equal ``expect``'s values
    (numbers, ``pytest.approx`` or :class:`Within`); ``same_as_native``: the metrics within
    that relative distance of the native run's (0: the force samples bit for bit)."""

    velocity_m_s: float
    tuned: dict[str, Any] | Callable[[ImpactRecord, BallOnPlate], dict[str, Any]]
    timestep_s: float | None = None
    expect: dict[str, Any] = field(default_factory=dict)
    same_as_native: float | None = None


@dataclass(frozen=True)
class Default:
    """A default-mode ball run at ``velocity_m_s`` and ``timestep_s``: ok, the recorded engine
    defaults include ``recorded``, and the restitution equals ``restitution``."""

    velocity_m_s: float
    timestep_s: float
    recorded: dict[str, Any] = field(default_factory=dict)
    restitution: Any = None


@dataclass(frozen=True)
class Custom:
    """A custom-mode ball run: ok, ``params`` recorded as applied, the restitution equals
    ``restitution``."""

    velocity_m_s: float
    timestep_s: float
    params: dict[str, Any]
    restitution: Any


@dataclass(frozen=True)
class Bad:
    """Bad input: a one-line ValueError matching ``match``."""

    scenario: Any
    mode: str
    settings: dict[str, Any]
    match: str


@dataclass(frozen=True)
class ObliqueInjected:
    """Injected oblique runs over ``cases`` against the rigid Coulomb reference: |relative
    error| within ``tol`` per metric, the contact-point ratio β within ``beta`` (absolute),
    the reference's regime; ``meta``: what the record says it ran."""

    tol: dict[str, float]
    cases: tuple[tuple[float, float], ...] = ANGLES
    beta: float | None = None
    shape: str = "sphere"
    options: dict[str, Any] | None = None
    meta: dict[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class ObliqueRun:
    """One oblique run in ``mode`` (native, default or custom) at ``angle_deg`` (step in s;
    None: the adapter's 1e-6 s): the status one of ``statuses``; each rel_error within
    ``tol``; the measured values equal ``expect``'s; ``slide``: sliding throughout, so
    e_t = 1 − μ·(1 + e)/tan θ within it (relative), e the run's own unless ``slide_e``; the
    recorded params (None: ``params``), engine facts, meta and not-comparable metrics;
    ``differs``: the spin differs from the default run's."""

    mode: str
    angle_deg: float
    timestep_s: float | None = None
    shape: str = "sphere"
    options: dict[str, Any] | None = None
    params: dict[str, Any] | None = None
    statuses: tuple[str, ...] = ("ok",)
    tol: dict[str, float] = field(default_factory=dict)
    expect: dict[str, Any] = field(default_factory=dict)
    slide: float | None = None
    slide_e: float | None = None
    recorded_params: dict[str, Any] | None = None
    facts: dict[str, Any] = field(default_factory=dict)
    meta: dict[str, Any] = field(default_factory=dict)
    not_comparable: tuple[str, ...] = ()
    differs: bool = False


@dataclass(frozen=True)
class Momentum:
    """The recorded force channels are the momentum the engine applied: Σ F·dt over the record
    equals m·Δv (tangential within ``tangential``, normal within ``normal``, relative); a rigid
    contact's step records ``per_instant`` samples at one instant; the spin's rel_error within
    ``spin`` (strict)."""

    mode: str
    angle_deg: float
    spin_rad_s: float
    tangential: float
    normal: float | None = None
    per_instant: int = 1
    spin: float | None = None


# --------------------------------------------------------------------------------- the table


def _all(tol: float) -> dict[str, float]:
    return dict.fromkeys(RF_METRICS, tol)


def _mujoco_native_ball(rec: ImpactRecord, s: BallOnPlate) -> list[tuple[str, Any, Any]]:
    k, d, a = rec.meta["stiffness_n_per_m"], rec.meta["damping_ns_per_m"], rec.meta["efc_diagA"]
    return [("solref", rec.meta["solref"], [-k * a, -d * a])]


def _mujoco_native_rf(rec: ImpactRecord, s: RigidFlexible) -> list[tuple[str, Any, Any]]:
    return [("solref", rec.meta["solref"], [-s.k1_n_per_m * rec.meta["efc_diagA"], 0.0])]


def _pybullet_native_ball(rec: ImpactRecord, s: BallOnPlate) -> list[tuple[str, Any, Any]]:
    sd = native_ball_spring_damper(s, rec.meta["reference_velocity_m_s"])
    return [("contact_stiffness", rec.meta["contact_stiffness"],
             pytest.approx(sd.stiffness_n_per_m, rel=1e-12)),
            ("contact_damping", rec.meta["contact_damping"],
             pytest.approx(sd.damping_ns_per_m, rel=1e-12))]


def _reference_restitution(rec: ImpactRecord, s: BallOnPlate) -> float:
    v_ref = rec.meta["reference_velocity_m_s"]
    return hunt_crossley.solve(s.replace(velocity_m_s=v_ref))["restitution"]


def _drake_point_contact(s: BallOnPlate, reference_velocity_m_s: float | None = None
                         ) -> dict[str, float]:
    """Drake's mapped native point contact for the ball (N/m, s/m), as tuned parameters."""
    from impactbench.engines.drake_adapter import native_ball_point_contact

    k, d = native_ball_point_contact(s, reference_velocity_m_s)
    return {"point_stiffness_n_per_m": k, "hunt_crossley_dissipation_s_per_m": d}


def _drake_native_ball(rec: ImpactRecord, s: BallOnPlate) -> list[tuple[str, Any, Any]]:
    mapped = _drake_point_contact(s, rec.meta["reference_velocity_m_s"])
    k, d = mapped["point_stiffness_n_per_m"], mapped["hunt_crossley_dissipation_s_per_m"]
    native = rec.meta["native_parameters"]
    return [("point_stiffness_n_per_m", native["point_stiffness_n_per_m"], k),
            ("geometry_point_stiffness_n_per_m", native["geometry_point_stiffness_n_per_m"],
             2 * k),
            ("hunt_crossley_dissipation_s_per_m", native["hunt_crossley_dissipation_s_per_m"],
             d),
            ("d = b", d, s.damping_s_per_m)]


APPLIED_FORCE_BALL = {  # rel. error at dt = 1e-7 s; measured in the comments
    1.0: {"restitution": 3.5e-6,  # 1.17e-6
          "duration_s": 1.8e-4,  # 5.88e-5
          "peak_force_n": 3.2e-4,  # 1.07e-4
          "max_penetration_m": 1.3e-4},  # 4.19e-5
    5.0: {"restitution": 3.2e-7,  # 1.07e-7
          "duration_s": 1.1e-3,  # 3.53e-4 (a third of a step of the 776-step contact)
          "peak_force_n": 1.8e-3,  # 6.11e-4
          "max_penetration_m": 7.8e-4},  # 2.61e-4
}
"""The injected ball as an applied force stepped by semi-implicit Euler: SAPIEN's and Box2D's
tolerances (their measurements are the same)."""


def _applied_force_rf(linear: tuple[float, float, float],
                      elastoplastic: tuple[float, float, float]) -> list[RF]:
    """The injected 2-DOF rows of SAPIEN, DART and Box2D (the local law as an applied force):
    the linear law at 3.3 m/s and the elastoplastic law at 10 m/s, both on the linear
    structure, each within its |relative error| bounds on RF_METRICS (in that order)."""
    return [RF("linear", "linear", 3.3, dict(zip(RF_METRICS, linear, strict=True))),
            RF("elastoplastic", "linear", 10.0,
               dict(zip(RF_METRICS, elastoplastic, strict=True)))]


def _frictionless(params: dict[str, Any], e_t_abs: float, spin_abs: float,
                  e_rel: float) -> ObliqueRun:
    """The custom oblique run at 45° with friction off and restitution 0.9 (``params``, the
    engine's names): the ball slides through, e_t 1 within ``e_t_abs`` and no spin within
    ``spin_abs`` (absolute), and rebounds at 0.9 within ``e_rel`` (relative)."""
    return ObliqueRun("custom", 45.0, params=params,
                      expect={"tangential_restitution": pytest.approx(1.0, abs=e_t_abs),
                              "spin_out_rad_s": pytest.approx(0.0, abs=spin_abs),
                              "restitution": pytest.approx(0.9, rel=e_rel)})


PEAK_TANGENTIAL = 0.11
"""|rel err| of an injected oblique run's peak tangential force (the sphere: pymunk, DART,
Box2D, SAPIEN, Newton), measured 3.70e-2 (45°, ω0 = 60: the slip stops within a step of a
steeply rising normal force; 1.84e-2 at 20°, ≤ 1.6e-3 otherwise)."""

RIGID_COULOMB_INJECTED = ObliqueInjected(
    {"restitution": 1.0e-4,  # 3.39e-5 (20°): the normal law's stepping (pymunk's drift–kick,
     # DART's semi-implicit Euler)
     "tangential_restitution": 2.3e-7,  # 7.57e-8 (80°; stick: round-off)
     "rebound_angle_deg": 1.0e-4,  # 3.21e-5 (20°)
     "spin_out_rad_s": 2.0e-6,  # 6.48e-7 (80°)
     "peak_tangential_force_n": PEAK_TANGENTIAL},
    CASES, beta=7e-7)  # |Δβ| (contact-point ratio, absolute): 2.37e-7 (80°)
"""pymunk's and DART's injected oblique tolerances against the rigid reference (default step
1e-6 s): about 3× the worst measured over CASES (the same in both), each in a comment."""


ENGINES: dict[str, dict[str, Any]] = {
    # ------------------------------------------------------------------------------- MuJoCo
    "mujoco": {
        # measured at 1e-7 s (1 / 5 m/s): restitution 7.8e-8 / 1.1e-7, duration 5.9e-5 /
        # 3.5e-4, peak 1.1e-4 / 6.1e-4 (Euler's first-order error on the force; it cancels
        # in restitution)
        "injected_ball": {v: {"restitution": 3.3e-7, "duration_s": 1.1e-3,
                              "peak_force_n": 1.8e-3} for v in (1.0, 5.0)},
        "ball_error_falls": [ErrorFalls(BallOnPlate(velocity_m_s=1.0), (1.6e-6, 4e-7, 1e-7),
                                        BALL)],
        "injected_rf": [
            # measured (both laws, 1e-5 s): peak 1.2e-5, pulse width 8.3e-6, impulse 9.8e-6
            RF("linear", "linear", 3.3, _all(3.7e-5)),
            RF("elastoplastic", "linear", 3.3, _all(3.7e-5)),
            # past the law's switch point: yielding (contact ends at the permanent set,
            # contacts disabled at zero law force) and stiffness failure; measured worst (peak
            # force): elastoplastic at 20 m/s 3.4e-5, mutation at 3.3 m/s 6.2e-5
            RF("elastoplastic", "linear", 20.0, _all(1.0e-4), yields=True),
            RF("mutation", "linear", 3.3, _all(1.8e-4)),
        ],
        # measured 1.2e-5 (peak), as injected
        "native_rf": [RF("linear", "linear", 3.3, _all(3.7e-5))],
        "native_rf_mapping": _mujoco_native_rf,
        "native_rf_meta": {"stepping": "rollout"},
        # the clipped spring–damper conversion, checked by a run at its reference velocity;
        # measured at 1e-7 s (V_ref = 1 / 5 m/s): restitution 4.1e-6 / 5.3e-5, duration
        # 3.2e-5 / 2.0e-4
        "native_ball": [NativeBall(v, 1e-7, restitution=1.6e-4, duration=6.0e-4,
                                   options={"reference_velocity_m_s": v}) for v in (1.0, 5.0)],
        "native_ball_mapping": _mujoco_native_ball,
        "tuned": Tuned(2.0, lambda native, s: {"solref": native.meta["solref"]},
                       same_as_native=0.0),
        "collapse": [(30.0, "linear", ("injected", "native"))],
        "huge_steps": [(BallOnPlate(velocity_m_s=5.0), "native", 1e-4),
                       (BallOnPlate(velocity_m_s=5.0), "injected", 1e-4)],
        "bad": [
            Bad(BallOnPlate(velocity_m_s=2.0), "tuned", {"tuned": {"solref": [1.0]}},
                r"^tuned\.solref = "),
            Bad(BallOnPlate(), "custom", {"params": {"cone": "elliptic"}},
                "applies to the oblique scenario only"),
            Bad(Oblique(), "custom", {"params": {"cone": "round"}}, "param cone"),
            Bad(Oblique(), "custom", {"params": {"condim": 2}}, "param condim"),
            Bad(Oblique(), "custom", {"params": {"impratio": 0}}, "param impratio"),
            Bad(Oblique(), "custom", {"params": {"friction": [0.1, 0.2, 0.3, 0.4]}},
                "param friction"),
            Bad(Oblique(), "custom", {"params": {"noslip_iterations": 1.5}},
                "param noslip_iterations"),
            Bad(Oblique(), "custom", {"params": {"solreffriction": [0.02]}},
                "param solreffriction"),
        ],
        # injected vs rigid, measured worst |rel err| over 20°, 45°, 60° (stick) and 80°
        # (slide) (dt 1e-6 s): restitution 3.2e-4 (80°), tangential restitution 4.2e-4 (45°),
        # spin 5.6e-4 (80°), rebound angle 3.4e-4 (20°)
        "oblique_injected": {"sphere": ObliqueInjected(
            {"restitution": 1e-3, "tangential_restitution": 1.3e-3, "spin_out_rad_s": 1.7e-3,
             "rebound_angle_deg": 1e-3},
            meta={"engine_defaults": {"cone": "elliptic", "impratio": 1e4,
                                      "friction_effective": pytest.approx(0.3)}})},
        "oblique_momentum": [
            # the friction force read from the contact sensor (sign: on the ball, along t)
            # sums to the tangential momentum change; MuJoCo's Euler step applies the
            # sample's force; backspin: still the rigid theory
            Momentum("injected", 45.0, -20.0, tangential=1e-9, normal=1e-9, spin=2e-3)],
        "oblique_runs": {
            # MuJoCo's default soft contact (solref 0.02 1) lets the 14.5 mm ball sink deep
            **{f"default-{dt}": ObliqueRun(
                "default", 60.0, dt, statuses=("ok", "implausible"),
                facts={"cone": "pyramidal", "condim": 3, "impratio": 1.0,
                       "solref": [0.02, 1.0], "noslip_iterations": 0,
                       "friction_effective": 0.3, "geom_friction": [0.3, 0.005, 0.0001]})
               for dt in (None, 2e-3)},
            "custom": ObliqueRun(
                "custom", 30.0, 2e-3, statuses=("ok", "implausible"),
                params={"cone": "elliptic", "impratio": 10, "condim": 4, "friction": [0.5],
                        "noslip_iterations": 5, "solreffriction": [0.02, 1.0]},
                recorded_params={"friction": [0.5, 0.005, 0.0001]},
                facts={"friction_effective": 0.5, "condim": 4}, differs=True),
        },
        "oblique_tuned_ball_params": {"solref": [-1, -1]},
    },
    # ---------------------------------------------------------------------------------- MJX
    # MuJoCo's physics in JAX, 64-bit: its errors are C MuJoCo's (to 1e-14; the records are
    # compared in test_specifics_mujoco.py)
    "mjx": {
        "injected_ball": {5.0: {"restitution": 3.3e-7,  # measured 1.10e-7 (C MuJoCo: the same)
                                "duration_s": 1.1e-3,  # 3.53e-4: a third of a step (776 steps)
                                "peak_force_n": 1.8e-3}},  # 6.10e-4
        "native_rf": [RF("linear", "linear", 3.3,
                         {"peak_force_n": 3.7e-5,  # measured 1.23e-5 (C MuJoCo: the same)
                          "pulse_width_s": 2.5e-5,  # 8.27e-6
                          "impulse_ns": 2.9e-5})],  # 9.76e-6
        "native_rf_mapping": _mujoco_native_rf,
        # MuJoCo's own solref (0.02, 1): a soft, heavily damped contact (its duration in
        # test_specifics_mujoco.py)
        "default": [Default(1.0, 1e-5, {"solref": [0.02, 1.0],
                                        "solimp": [0.9, 0.95, 0.001, 0.5, 2.0]},
                            restitution=Within(hi=0.5, strict=True))],
        "unsupported": [(RigidFlexible(local="elastoplastic"), "injected", "memory")],
        "bad": [Bad(BallOnPlate(velocity_m_s=1.0), "custom", {"params": {"solref": [1.0]}},
                    "solref"),
                # MJX has no noslip solver: the key is not offered
                Bad(Oblique(), "custom", {"params": {"noslip_iterations": 5}}, "valid keys")],
        # injected vs rigid, measured worst |rel err| over 20°, 45°, 60° (stick) and 80°
        # (slide) — C MuJoCo's: restitution 3.2e-4, tangential restitution 4.2e-4, spin
        # 5.6e-4, rebound angle 3.4e-4
        "oblique_injected": {"sphere": ObliqueInjected(
            {"restitution": 1e-3, "tangential_restitution": 1.3e-3, "spin_out_rad_s": 1.7e-3,
             "rebound_angle_deg": 1e-3},
            meta={"engine_defaults": {"cone": "elliptic"}})},
        "oblique_runs": {
            "default": ObliqueRun("default", 60.0, 2e-3, statuses=("ok", "implausible"),
                                  facts={"cone": "pyramidal", "friction_effective": 0.3,
                                         "friction_combination": "max"})},
        "oblique_tuned_ball_params": {"solref": [-1, -1]},
    },
    # ------------------------------------------------------------------------------ PyBullet
    "pybullet": {
        # measured at 1e-7 s (Bullet's implicit contact step, 1 / 5 m/s): restitution 3.5e-3 /
        # 4.3e-3, duration 8.5e-4 / 1.2e-3, peak 1.9e-3 / 2.0e-3
        "injected_ball": {v: {"restitution": 0.013, "duration_s": 0.0035,
                              "peak_force_n": 0.006} for v in (1.0, 5.0)},
        "injected_ball_meta": {"injection": "secant"},
        "ball_error_falls": [ErrorFalls(BallOnPlate(velocity_m_s=5.0), (1e-6, 3e-7, 1e-7),
                                        ("duration_s", "peak_force_n", "restitution"))],
        "injected_rf": [
            # measured (both laws, 1e-5 s): peak 1.06e-3, pulse width 3.9e-4, impulse 6.6e-4
            RF("linear", "linear", 3.3, _all(0.0032)),
            RF("elastoplastic", "linear", 3.3, _all(0.0032)),
            # laws with memory; measured worst: elastoplastic 4.8e-4 (impulse),
            # mutation/softening 7.6e-4 (peak)
            RF("elastoplastic", "linear", 10.0, _all(0.0023), yields=True),  # yields
            RF("mutation", "softening", 10.0, _all(0.0023)),
        ],
        "rf_error_falls": [ErrorFalls(RigidFlexible(velocity_m_s=3.3), (1e-4, 3e-5, 1e-5),
                                      RF_METRICS)],
        # measured worst 1.06e-3 (peak), the same as injected: a linear law is Bullet's own
        "native_rf": [RF("linear", "linear", 3.3, _all(0.0032))],
        "native_rf_mapping": lambda rec, s: [
            ("contact_stiffness", rec.meta["contact_stiffness"], s.k1_n_per_m),
            ("contact_damping", rec.meta["contact_damping"], 0)],
        # the mapped clipped spring–damper (matched to the reference at 1 m/s): Bullet's
        # backward-Euler spring–damper at ω·dt ≈ 3e-3: measured restitution 4.55e-3, duration
        # 9.0e-4 against the mapped spring–damper (the same at 1 and 5 m/s)
        "native_ball": [NativeBall(v, 1e-7, restitution=0.0065, duration=0.0027)
                        for v in (1.0, 5.0)],
        "native_ball_mapping": _pybullet_native_ball,
        # undamped: duration π·√(m/K) and restitution near 1 (backward Euler loses a
        # little); measured 7.0e-3 (backward Euler at ω·dt = 0.022)
        "tuned": Tuned(1.0, {"contact_stiffness": 5e7, "contact_damping": 0.0}, 1e-6,
                       expect={"duration_s": pytest.approx(math.pi * math.sqrt(0.1 / 5e7),
                                                           rel=0.01),
                               "restitution": Within(0.95, 1.0, strict=True)}),
        # m·g against the impact: measured 3.5e-3 (Bullet's implicit step; the same as
        # without gravity)
        "gravity": ("restitution", 0.011),
        "collapse": [(20.0, "linear", ("injected",))],
        # Bullet's implicit contact is unconditionally stable (injected mode keeps it): a
        # status needs a step that crosses the plate in one go, or one beyond the explicit
        # structural spring's limit ω2·dt = 2; at 1e-4 s the injected ball is over-damped but
        # finite (restitution 0.36)
        "huge_steps": [(BallOnPlate(velocity_m_s=5.0), "injected", 1e-2),
                       (RigidFlexible(velocity_m_s=3.3), "injected", 3e-2),
                       (RigidFlexible(velocity_m_s=3.3), "native", 3e-2)],
        "bad": [
            Bad(BallOnPlate(velocity_m_s=1.0), "tuned",
                {"tuned": {"contact_stiffness": -1.0}}, r"tuned\.contact_stiffness"),
            Bad(BallOnPlate(), "injected", {"options": {"injection": "magic"}}, "injection"),
            Bad(BallOnPlate(), "custom", {"params": {"lateralFriction": 0.5}},
                "applies to the oblique scenario only"),
            Bad(Oblique(), "custom", {"params": {"frictionAnchor": 2}}, "param frictionAnchor"),
            Bad(Oblique(), "custom", {"params": {"lateralFriction": -0.1}},
                "param lateralFriction"),
            Bad(Oblique(), "custom", {"params": {"rollingFriction": "x"}},
                "param rollingFriction"),
        ],
        "oblique_injected": {
            # injected (secant: the ball's injection, Bullet's implicit contact step) vs
            # rigid (dt 1e-6 s), measured |rel err|: restitution −3.73e-2 / −3.58e-2 /
            # −3.40e-2 / −2.82e-2 at 20/45/60/80°; tangential restitution and spin exact in
            # stick (2e-14), at 80° +1.6e-3 and −1.39e-2 (the tangential impulse μ·(1 + e)·v_n
            # carries the low e); rebound angle 3.7e-2 (20°)
            "secant": ObliqueInjected({"restitution": 0.11, "tangential_restitution": 5e-3,
                                       "spin_out_rad_s": 0.042, "rebound_angle_deg": 0.11}),
            # injection = "explicit" vs rigid, measured worst: restitution 1.1e-4 (20°),
            # tangential restitution 1.4e-6 (80°; stick 1e-14), spin 1.2e-5 (80°), rebound
            # angle 1.0e-4 (20°)
            "explicit": ObliqueInjected({"restitution": 3.3e-4, "tangential_restitution": 4.2e-6,
                                         "spin_out_rad_s": 3.7e-5, "rebound_angle_deg": 3.1e-4},
                                        options={"injection": "explicit"}),
        },
        # the lateral friction Bullet reports (on the plate, negated for the ball) sums to
        # the ball's tangential momentum change; backspin to start
        "oblique_momentum": [Momentum("native", 45.0, -20.0, tangential=1e-9, normal=1e-9,
                                      spin=1e-9)],
        "oblique_runs": {
            # stick: Bullet's velocity-level Coulomb is exact (measured 2e-15); the normal part
            # is the ball's native contact with Bullet's implicit step (e 0.8950 for the
            # reference's 0.8885 / 0.9375 at 20° / 60°); one manifold point: the merging
            # threshold (a 1e-12 one lets a rolling ball's points pile up, each a full
            # spring); the spin clamp lifted
            **{f"native-{angle:g}": ObliqueRun(
                "native", angle,
                expect={"rel_error": {"tangential_restitution": Within(-1e-9, 1e-9, strict=True),
                                      "spin_out_rad_s": Within(-1e-9, 1e-9, strict=True)},
                        "restitution": pytest.approx(0.8950, abs=1e-3)},
                facts={"friction_combination": "product", "friction_ball": 0.3,
                       "friction_plate": 1.0, "friction_effective": pytest.approx(0.3),
                       "frictionAnchor": 0, "contactBreakingThreshold": 0.01,
                       "maxJointVelocity_ball": Within(1e3, strict=True),
                       "friction_model": Contains("Coulomb")}) for angle in (20.0, 60.0)},
            # the rigid default contact at 1/240 s: a one-step impulse, the ball sinks a
            # step's worth
            "default": ObliqueRun("default", 60.0, 1.0 / 240.0, statuses=("ok", "implausible"),
                                  facts={"friction_effective": pytest.approx(0.3),
                                         "friction_combination": "product",
                                         "contactStiffness": -1.0}),  # rigid, unset
            # read back with getDynamicsInfo; rollingFriction_pair: r_ball·μ_plate +
            # r_plate·μ_ball
            "custom": ObliqueRun(
                "custom", 20.0, 1.0 / 240.0, statuses=("ok", "implausible"),
                params={"lateralFriction": 0.5, "rollingFriction": 0.01, "frictionAnchor": 1},
                facts={"friction_ball": 0.5, "friction_effective": pytest.approx(0.5),
                       "rollingFriction_ball": pytest.approx(0.01),
                       "rollingFriction_pair": pytest.approx(0.01), "frictionAnchor": 1,
                       "friction_model": Contains("anchor")}, differs=True),
        },
        "oblique_tuned_ball_params": {"contact_stiffness": 1e8},
    },
    # -------------------------------------------------------------------------------- pymunk
    "pymunk": {
        # measured at 1e-7 s (1 / 5 m/s): restitution 7.8e-8 / 1.1e-7, duration 5.9e-5 /
        # 3.5e-4, peak 1.1e-4 / 6.1e-4, max penetration 4.2e-5 / 2.6e-4
        "injected_ball": {v: {"restitution": 3.3e-7, "duration_s": 1.1e-3,
                              "peak_force_n": 1.8e-3, "max_penetration_m": 8e-4}
                          for v in (1.0, 5.0)},
        # first order in dt: ~10× over a decade
        "ball_error_falls": [ErrorFalls(BallOnPlate(velocity_m_s=5.0), (1e-6, 3e-7, 1e-7),
                                        ("duration_s", "peak_force_n", "max_penetration_m"),
                                        ratio=5.0)],
        "injected_rf": [
            # measured worst of peak, pulse width, impulse at 1e-5 s: 1.7e-7, 1.7e-7, 8.1e-8
            RF("linear", "linear", 3.3, _all(5e-7)),
            RF("elastoplastic", "linear", 3.3, _all(5e-7)),  # below yield at 3.3 m/s
            # yields; re-contact 1.7 ms after the first contact ends
            RF("elastoplastic", "linear", 10.0, _all(2.5e-7), yields=True),
            # the mutation law's irreversible failure, on the softening structure; measured:
            # peak 3.5e-5, pulse width 5.9e-6, impulse 6.3e-6
            RF("mutation", "softening", 3.3, _all(1.0e-4)),
        ],
        "rf_error_falls": [ErrorFalls(RigidFlexible(velocity_m_s=3.3, local="mutation"),
                                      (1e-4, 3e-5, 1e-5), RF_METRICS)],
        # a rigid contact with the reference restitution at V_ref (1 m/s, or the option's):
        # measured exact to 1e-9
        "native_ball": [NativeBall(1.0, 1e-6, restitution=1e-9, rigid=True),
                        NativeBall(5.0, 1e-6, restitution=1e-9, rigid=True),
                        NativeBall(5.0, 1e-6, restitution=1e-9, rigid=True,
                                   options={"reference_velocity_m_s": 5.0})],
        "native_ball_mapping": lambda rec, s: [
            ("elasticity", rec.meta["elasticity"],
             pytest.approx(_reference_restitution(rec, s), rel=1e-12))],
        # measured within 1e-6 of 2·m1·v1 and −v1 (the explicit 1e-5 s step)
        "elastic_rf": Elastic(impulse=1e-6, pulse_width_s=3e-5, timestep_s=1e-5, rebound=1e-6,
                              recorded={"elasticity": 1.0}),
        "tuned": Tuned(2.0, {"elasticity": 0.8}, expect={"restitution": pytest.approx(0.8,
                                                                                      rel=1e-9)}),
        # m·g ≈ 1 N against a ~3.4 kN peak: measured 5.1e-4 (with the 1.1e-4 stepping error)
        "gravity": ("peak_force_n", 1.5e-3),
        "collapse": [(30.0, "linear", ("injected",))],
        "huge_steps": [(BallOnPlate(velocity_m_s=5.0), "injected", 1e-4)],
        "deterministic": (RigidFlexible(velocity_m_s=3.3, local="elastoplastic"), "injected"),
        "bad": [
            Bad(BallOnPlate(velocity_m_s=2.0), "tuned", {"tuned": {"restitution": 0.8}},
                r"tuned\.elasticity"),
            Bad(BallOnPlate(), "injected", {"options": {"injection": "spring"}},
                r"options\.injection"),
            Bad(BallOnPlate(), "native", {"options": {"iterations": 0}}, r"options\.iterations"),
            Bad(Oblique(), "custom", {"params": {"friction": -1.0}}, "friction"),
            Bad(Oblique(), "custom", {"params": {"mu": 0.3}}, "valid keys"),
            # head-on: no friction
            Bad(BallOnPlate(), "custom", {"params": {"friction": 0.3}}, "oblique scenario only"),
        ],
        "oblique_injected": {
            # injected: the normal law as a penalty force, ideal Coulomb friction as a force
            # and torque, the contact rejected
            "sphere": dataclasses.replace(RIGID_COULOMB_INJECTED, meta={"contact": "penalty"}),
            # the disc (k² = R²/2) against the disc's rigid reference: the sphere's
            # measurements, but for the peak tangential force at 20°
            "disc": ObliqueInjected(
                {"restitution": 1.0e-4,  # 3.39e-5 (20°)
                 "tangential_restitution": 2.3e-7,  # 7.57e-8 (80°)
                 "rebound_angle_deg": 1.0e-4,  # 3.23e-5 (20°)
                 "spin_out_rad_s": 2.0e-6,  # 6.48e-7 (80°)
                 "peak_tangential_force_n": 0.13},  # 4.42e-2 (20°: the slip stops within a
                # step of a steeply rising normal force; the sphere's worst there is 1.84e-2)
                CASES, beta=6.1e-7, shape="disc",  # |Δβ|: 2.03e-7 (80°)
                meta={"planar": True}),
        },
        "oblique_runs": {
            # rigid Coulomb friction in pymunk's rigid contact: measured ≤ 3.3e-14; stick:
            # rolling after, e_t = 5/7 whatever e is
            "native-45": ObliqueRun(
                "native", 45.0, tol={"spin_out_rad_s": 1e-9},
                expect={"tangential_restitution": pytest.approx(5.0 / 7.0, rel=1e-9)},
                facts={"friction_effective": 0.3, "friction_combination": "product",
                       "friction_ball": 0.3, "friction_plate": 1.0},
                not_comparable=("peak_tangential_force_n",)),
            # slide: Δv_t = μ·(1 + e)·v_n with the contact's own e, the reference's at 1 m/s
            "native-80": ObliqueRun("native", 80.0, expect={"restitution": pytest.approx(0.937476,
                                                                                rel=1e-5)},
                                    slide=1e-9),
            # the disc: stick at 45° leaves it rolling with v_t' = (2/3)·v_t (the sphere's
            # 5/7), whatever the restitution
            "native-disc": ObliqueRun(
                "native", 45.0, shape="disc", tol={"spin_out_rad_s": 1e-9},
                expect={"tangential_restitution": pytest.approx(2.0 / 3.0, rel=1e-9)}),
            "default": ObliqueRun(
                "default", 45.0,
                expect={"restitution": pytest.approx(0.0, abs=1e-9),  # elasticity 0 by default
                        "tangential_restitution": pytest.approx(5.0 / 7.0, rel=1e-9)},
                facts={"friction": 0.0,  # pymunk's, replaced by μ
                       "collision_slop": pytest.approx(0.1), "friction_effective": 0.3}),
            "custom": _frictionless({"friction": 0.0, "elasticity": 0.9}, 1e-12, 1e-9, 1e-9),
        },
        "oblique_tuned_ball_params": {"elasticity": 0.9},
    },
    # --------------------------------------------------------------------------------- Drake
    "drake": {
        # measured at 1e-7 s (RK3; 1 / 5 m/s): restitution 4.8e-9 / 6.1e-8, duration 7.4e-10 /
        # 1.0e-9, peak 1.7e-6 / 2.7e-6 (a sampled maximum: the peak falls between samples)
        "injected_ball": {v: {"restitution": 1.8e-7, "duration_s": 3.2e-9,
                              "peak_force_n": 8.1e-6} for v in (1.0, 5.0)},
        "ball_error_falls": [ErrorFalls(BallOnPlate(velocity_m_s=v), (4e-6, 2e-6, 1e-6),
                                        ("restitution",)) for v in (1.0, 5.0)],
        "injected_rf": [
            # measured (both laws, 1e-5 s): peak 6.2e-8, pulse width 2.0e-9, impulse 7.6e-8
            RF("linear", "linear", 3.3, _all(2.3e-7)),
            RF("elastoplastic", "linear", 3.3, _all(2.3e-7)),
            # beyond yield / failure the law's memory matters (linear native contact misses
            # it: test_specifics_drake.py); measured worst injected error: elastoplastic at
            # 20 m/s 5.2e-8, mutation 4.8e-5; native (linear k1) 0.59 and 0.44
            RF("elastoplastic", "linear", 20.0, _all(1.6e-7)),
            RF("mutation", "linear", 3.3, _all(1.5e-4)),
        ],
        # measured 7.6e-8 (linear), 8.3e-8 (softening)
        "native_rf": [RF("linear", s, 3.3, _all(2.5e-7)) for s in ("linear", "softening")],
        "native_rf_mapping": lambda rec, s: [
            ("point_stiffness_n_per_m", rec.meta["native_parameters"]["point_stiffness_n_per_m"],
             s.k1_n_per_m)],
        # point contact is linear Hunt–Crossley with d = b: restitution k(α) at every
        # velocity; the stiffness matches the duration at the reference velocity (1 m/s)
        # only. Measured at 1e-7 s: restitution 7.2e-7 / 2.6e-7 / 8.8e-7 (0.5 / 1 / 5 m/s);
        # duration at 1 m/s 3.6e-10 (against linear HC: test_specifics_drake.py); with the
        # reference velocity option at 5 m/s, duration 1.5e-8
        "native_ball": [
            *(NativeBall(v, 1e-7, restitution=2.7e-6, restitution_at_m_s=v)
              for v in (0.5, 5.0)),
            NativeBall(1.0, 1e-7, restitution=2.7e-6, duration=1.1e-9),
            NativeBall(5.0, 1e-7, duration=4.5e-8, options={"reference_velocity_m_s": 5.0}),
        ],
        "native_ball_mapping": _drake_native_ball,
        "tuned": Tuned(2.0, lambda native, s: _drake_point_contact(s), same_as_native=1e-12),
        "collapse": [(40.0, "linear", ("native", "injected"))],
        "huge_steps": [(BallOnPlate(velocity_m_s=5.0), "native", 1e-3),
                       (BallOnPlate(velocity_m_s=5.0), "injected", 1e-3),
                       (RigidFlexible(velocity_m_s=3.3), "native", 0.1),
                       (RigidFlexible(velocity_m_s=3.3), "injected", 0.1)],
        "bad": [
            Bad(BallOnPlate(), "native", {"options": {"integrator": "rk9"}},
                r"^integrator = 'rk9': must be one of"),
            Bad(BallOnPlate(), "tuned", {"tuned": {"point_stiffness_n_per_m": -1.0}},
                r"^point_stiffness_n_per_m = -1.0: must be > 0"),
            Bad(BallOnPlate(), "native", {"options": {"reference_velocity_m_s": 0}},
                r"^reference_velocity_m_s = 0: must be > 0"),
            Bad(Oblique(), "custom", {"params": {"stiction_tolerance": -1.0}},
                "param stiction_tolerance"),
        ],
        # injected vs rigid (the normal law and Coulomb friction as generalized forces, the
        # continuous plant's RK3, dt 1e-6 s), measured worst |rel err| over 20°, 45°, 60°
        # (stick) and 80° (slide): restitution 4.8e-6 (20°), tangential restitution 7.3e-8
        # (80°), spin 6.2e-7 (80°), rebound angle 4.5e-6 (20°)
        "oblique_injected": {"sphere": ObliqueInjected(
            {"restitution": 1.5e-5, "tangential_restitution": 2.2e-7, "spin_out_rad_s": 1.9e-6,
             "rebound_angle_deg": 1.4e-5},
            meta={"engine_defaults": {"friction_combination": "none"}})},
        # the applied force's samples (step starts) sum to the momentum change up to RK3's
        # stage average (measured 1.5e-3: the step where the slip stops); backspin to start
        "oblique_momentum": [Momentum("injected", 45.0, -20.0, tangential=4.5e-3, normal=1e-4,
                                      spin=1e-5)],
        "oblique_runs": {
            # native vs rigid (regularised Stribeck friction, stiction tolerance 1e-4 m/s,
            # chattering in the stick phase), measured: 20° tangential restitution −9.8e-4,
            # spin +1.4e-3, rebound angle −9.5e-4; 60° −1.3e-4, −6.1e-4, −7.1e-5; restitution
            # ≤ 2.1e-5 (d = b: exact restitution)
            **{f"native-{angle:g}": ObliqueRun(
                "native", angle, tol={"restitution": 6.3e-5, "tangential_restitution": 3e-3,
                            "spin_out_rad_s": 4.2e-3, "rebound_angle_deg": 2.9e-3},
                facts={"friction_combination": "harmonic",
                       "friction_effective": pytest.approx(0.3),  # read from the scene graph
                       "stiction_tolerance_m_s": 1e-4, "friction_model": Contains("Stribeck")})
               for angle in (20.0, 60.0)},
            # the discrete plant; its default point contact (from the penetration allowance)
            # is nearly plastic
            **{f"default-{dt}": ObliqueRun(
                "default", 60.0, dt, statuses=("ok", "implausible"),
                expect={"restitution": Within(hi=0.1, strict=True)},
                facts={"discrete_contact_approximation": "lagged",  # read back from the plant
                       "stiction_tolerance_m_s": 1e-4,
                       "friction_effective": pytest.approx(0.3)}) for dt in (None, 1e-3)},
            "custom": ObliqueRun(
                "custom", 20.0, 1e-3, statuses=("ok", "implausible"),
                params={"discrete_contact_approximation": "sap", "stiction_tolerance": 1e-2},
                facts={"discrete_contact_approximation": "sap", "stiction_tolerance_m_s": 1e-2},
                differs=True),
        },
        "oblique_tuned_ball_params": {"point_stiffness_n_per_m": 1e8},
    },
    # -------------------------------------------------------------------- SAPIEN (PhysX 5)
    # a change of the contact worth a few per cent (the compliant stiffness off by 2 % gives
    # 9.5e-3 in the 2-DOF native run) must fail
    "sapien": {
        "injected_ball": APPLIED_FORCE_BALL,
        # rel. error (peak force, pulse width, impulse) at the default 1e-5 s; measured:
        # linear 2.08e-5, 1.42e-5, 5.96e-5; elastoplastic 2.05e-6, 5.96e-6, 6.13e-5
        "injected_rf": _applied_force_rf(linear=(6.2e-5, 4.3e-5, 1.8e-4),
                                         elastoplastic=(6.2e-6, 1.8e-5, 1.8e-4)),
        # both materials −k1: PhysX's compliant contact is the linear local law exactly
        "native_rf": [RF("linear", "softening", 3.3, {"peak_force_n": 3.2e-4,  # measured 1.06e-4
                                                      "pulse_width_s": 3.4e-4,  # 1.13e-4
                                                      "impulse_ns": 4.0e-4})],  # 1.32e-4
        "native_rf_meta": {"contact": "compliant"},
        "native_ball": [
            # the compliant contact K = −restitution matched to the reference duration at
            # 1 m/s (an undamped spring: test_engine_specifics.py); measured 1.37e-4
            NativeBall(1.0, 1e-7, duration=4.1e-4),
            # options["contact"] = "rigid": the reference restitution, measured 4.5e-8 (float32)
            NativeBall(1.0, 1e-6, restitution=1.5e-7, options={"contact": "rigid"},
                       rigid=True, recorded={"bounce_threshold": 0.0}),
        ],
        # measured 1.49e-3 (1.5 steps of the 993-step contact at 1e-7 s): kept at 2×
        "tuned": Tuned(1.0, {"restitution": -1e8}, 1e-7,
                       expect={"duration_s": pytest.approx(math.pi * math.sqrt(0.1 / 1e8),
                                                           rel=3e-3)}),
        # out of the box: restitution 0.1 (float32) applied only above 2 m/s — the ball
        # stops dead at 1 m/s; at SAPIEN's own default scene step (0.01 s) a rigid contact
        # still stops the ball
        "default": [
            Default(1.0, 1e-6, {"bounce_threshold": pytest.approx(2.0)},
                    restitution=pytest.approx(0.0, abs=1e-9)),  # measured exactly 0
            Default(5.0, 1e-6, {"restitution": float(np.float32(0.1))},
                    restitution=pytest.approx(float(np.float32(0.1)), rel=7e-7)),  # 2.2e-7
            Default(5.0, 0.01),
        ],
        "custom": [
            # measured 0; a float32 ulp
            Custom(1.0, 1e-6, {"bounce_threshold": 0.0, "restitution": 0.5},
                   pytest.approx(0.5, rel=1.2e-7)),
            # at the 0.01 s scene step a custom restitution sends the ball back: the plate
            # holds; measured 1.78e-3: kept at 2e-3 (1.1×)
            Custom(5.0, 0.01, {"restitution": 0.9, "bounce_threshold": 0.0},
                   pytest.approx(0.9, rel=2e-3)),
        ],
        "collapse": [(30.0, "linear", ("injected",))],
        "deterministic": (BallOnPlate(velocity_m_s=2.0), "native"),
        "bad": [
            Bad(BallOnPlate(), "custom", {"params": {"enable_tgs": 1}}, r"params\.enable_tgs"),
            Bad(BallOnPlate(), "custom", {"params": {"erp": 0.2}}, "valid keys"),
            Bad(Oblique(), "custom", {"params": {"max_angular_velocity": 0.0}},
                "max_angular_velocity"),
            Bad(Oblique(), "custom", {"params": {"enable_friction_every_iteration": 1}},
                "enable_friction_every_iteration"),
        ],
        # |rel err| against the rigid reference, injected (no collision shapes; the normal
        # law and ideal Coulomb friction as a force and torque at the contact point), default
        # step 1e-6 s: about 3× the worst measured over CASES (float32), the measurement in
        # each comment
        "oblique_injected": {"sphere": ObliqueInjected(
            {"restitution": 1.0e-4,  # 3.38e-5 (20°): the normal law's semi-implicit Euler
             "tangential_restitution": 4.1e-5,  # 1.37e-5 (45°, ω0 = 60): float32 velocities
             "rebound_angle_deg": 1.2e-4,  # 4.04e-5 (20°)
             "spin_out_rad_s": 9.0e-5,  # 2.97e-5 (80°)
             "peak_tangential_force_n": PEAK_TANGENTIAL},
            CASES, beta=2.7e-5,  # |Δβ| (contact-point ratio, absolute): 9.03e-6 (45°, ω0 = 60)
            meta={"engine_defaults": {"angular_damping": 0.0}})},  # PhysX's 0.05 /s brakes
        "oblique_runs": {
            # the ball's native compliant contact (an undamped spring) with PhysX's patch
            # friction; native e_t and spin at 20–60°: measured ≤ 1.71e-3 (20°)
            "native-45": ObliqueRun(
                "native", 45.0, tol={"tangential_restitution": 5e-3,  # -1.62e-3
                                     "spin_out_rad_s": 5e-3},  # +1.61e-3
                expect={"restitution": pytest.approx(0.9944, abs=1e-3)},  # undamped spring
                facts={"friction_effective": 0.3, "friction_combination": "average",
                       "friction_model": Contains("patch")},
                meta={"contact": "compliant"}),
            # slide: Δv_t = μ·(1 + e)·v_n with the contact's own e; measured 2.2e-6
            "native-80": ObliqueRun("native", 80.0, slide=1e-5),
            "default": ObliqueRun(
                "default", 45.0,
                expect={"restitution": pytest.approx(0.0, abs=1e-4)},  # below the 2 m/s threshold
                facts={"bounce_threshold": pytest.approx(2.0),
                       "angular_damping": pytest.approx(0.05),
                       "max_angular_velocity": pytest.approx(100.0),
                       "friction_effective": 0.3}),
            "custom": ObliqueRun(
                "custom", 45.0, params={"static_friction": 0.0, "dynamic_friction": 0.0,
                              "enable_friction_every_iteration": False,
                              "angular_damping": 0.0},
                expect={"tangential_restitution": pytest.approx(1.0, abs=1e-6),
                        "spin_out_rad_s": pytest.approx(0.0, abs=1e-6)}),
        },
        "oblique_tuned_ball_params": {"restitution": -1e8},
    },
    # ---------------------------------------------------------------------------------- DART
    "dart": {
        "injected_ball": {  # rel. error at dt = 1e-7 s; measured in the comments
            1.0: {"restitution": 2.4e-7,  # 7.75e-8
                  "duration_s": 1.8e-4,  # 5.87e-5
                  "peak_force_n": 3.2e-4,  # 1.06e-4
                  "max_penetration_m": 1.3e-4},  # 4.25e-5
            5.0: {"restitution": 3.3e-7,  # 1.10e-7
                  "duration_s": 1.1e-3,  # 3.53e-4 (a third of a step of the 776-step contact)
                  "peak_force_n": 1.8e-3,  # 6.10e-4
                  "max_penetration_m": 7.8e-4},  # 2.61e-4
        },
        # rel. error (peak force, pulse width, impulse) at the default 1e-5 s; measured:
        # linear 7.74e-5, 4.57e-5, 6.20e-4; elastoplastic 1.63e-5, 4.15e-5, 6.29e-4
        "injected_rf": _applied_force_rf(linear=(2.3e-4, 1.4e-4, 1.9e-3),
                                         elastoplastic=(4.9e-5, 1.3e-4, 1.9e-3)),
        # a rigid LCP contact with the reference restitution at 1 m/s (the pair's product,
        # the plate's 1): measured 2.07e-5 (CFM); the impulse measured exact (0)
        "native_ball": [NativeBall(v, 1e-6, restitution=6.2e-5, rigid=True, impulse=1e-9)
                        for v in (1.0, 5.0)],
        "native_ball_mapping": lambda rec, s: [
            ("restitution", rec.meta["restitution"],
             pytest.approx(_reference_restitution(rec, s), rel=1e-12))],
        # body 2 swings on its joint spring; measured 7.95e-4 and 1.85e-5 s (one 1e-5 s
        # step): kept at 1.3× and 1.6×
        "elastic_rf": Elastic(impulse=1e-3, pulse_width_s=3e-5),
        "tuned": Tuned(2.0, {"restitution_coeff": 0.7}, 1e-6,
                       expect={"restitution": pytest.approx(0.7, rel=7.3e-5)}),  # 2.43e-5 (CFM)
        # DART's default restitution is 0: the ball stops; the error reduction pushes it out
        # at no more than 1e-3 m/s (measured 1.000e-3: the push-out bound); at DART's default
        # World step (1e-3 s) a rigid contact still stops the ball
        "default": [Default(1.0, 1e-6, {"restitution_coeff": 0.0},
                            restitution=Within(0.0, 1.5e-3)),
                    Default(5.0, 1e-3)],
        # DART pairs restitution as the product of the shapes' coefficients; the plate's is 1
        # (neutral), so the pair has the user's value
        "custom": [Custom(1.0, 1e-6, {"restitution_coeff": 0.4, "collision_detector": "dart"},
                          pytest.approx(0.4, rel=CFM_LOSS)),
                   # at the 1e-3 s step the plate holds; measured 2.11e-5
                   Custom(5.0, 1e-3, {"restitution_coeff": 0.9}, pytest.approx(0.9, rel=6.5e-5))],
        "collapse": [(30.0, "linear", ("injected",))],
        "deterministic": (RigidFlexible(velocity_m_s=3.3, local="mutation",
                                        structure="softening"), "injected"),
        "bad": [
            Bad(BallOnPlate(), "custom", {"params": {"collision_detector": "gjk"}},
                r"params\.collision_detector"),
            Bad(Oblique(), "custom", {"params": {"friction_coeff": -0.1}}, "friction_coeff"),
            Bad(Oblique(), "custom", {"params": {"mu": 0.3}}, "valid keys"),
        ],
        # injected: no collision; the normal law and ideal Coulomb friction as joint forces
        # and torque
        "oblique_injected": {"sphere": RIGID_COULOMB_INJECTED},
        # Σ F_t·dt over the contact step is m·Δv_t: the friction impulse DART reports (its
        # own Contact.force)
        "oblique_momentum": [Momentum("native", 45.0, 0.0, tangential=1e-6, per_instant=2)],
        "oblique_runs": {
            # DART's rigid Coulomb (its constraint mixing): measured ≤ 1.45e-5 (20°); stick:
            # rolling after, e_t = 5/7 whatever e is
            "native-45": ObliqueRun(
                "native", 45.0, tol={"spin_out_rad_s": 5e-5},
                expect={"restitution": pytest.approx(0.937476, rel=1e-4),  # at 1 m/s, less CFM
                        "tangential_restitution": pytest.approx(5.0 / 7.0, rel=5e-5)},
                facts={"friction_effective": 0.3, "friction_combination": "min"},
                not_comparable=("peak_tangential_force_n",)),
            "native-80": ObliqueRun("native", 80.0, slide=1e-5),
            "default": ObliqueRun(
                "default", 45.0,
                # restitution 0 (the error reduction's ~1e-3 m/s push)
                expect={"restitution": Within(hi=0.01, strict=True),
                        "tangential_restitution": pytest.approx(5.0 / 7.0, rel=5e-5)},
                facts={"friction_coeff": 1.0,  # DART's, replaced by μ
                       "friction_effective": 0.3}),
            "custom": _frictionless({"friction_coeff": 0.0, "restitution_coeff": 0.9},
                                    1e-9, 1e-9, 1e-4),
        },
        "oblique_tuned_ball_params": {"restitution_coeff": 0.9},
    },
    # --------------------------------------------------------------------------------- Box2D
    "box2d": {
        "injected_ball": APPLIED_FORCE_BALL,
        # rel. error (peak force, pulse width, impulse) at the default 1e-5 s; measured:
        # linear 8.20e-5, 4.29e-5, 6.19e-4; elastoplastic 1.66e-5, 4.10e-5, 6.30e-4
        "injected_rf": _applied_force_rf(linear=(2.5e-4, 1.3e-4, 1.9e-3),
                                         elastoplastic=(5e-5, 1.3e-4, 1.9e-3)),
        # restitution e = k_ref(1 m/s) applied above b2_velocityThreshold = 1 m/s only (at
        # 1 m/s: test_engine_specifics.py); measured 6.4e-9, impulse 9.2e-9
        "native_ball": [NativeBall(5.0, 1e-6, restitution=2e-8, rigid=True, impulse=3e-8)],
        # body 2's distance-joint spring (f = √(k2/m2)/2π); measured 7.91e-4 and 1.81e-5 s
        # (one 1e-5 s step): kept at 1.3× and 1.7×
        "elastic_rf": Elastic(impulse=1e-3, pulse_width_s=3e-5),
        "tuned": Tuned(3.0, {"restitution": 0.8}, 1e-6,
                       expect={"restitution": pytest.approx(0.8, rel=FLOAT32)}),
        # at the Box2D manual's step (1 / 60 s) a rigid contact still stops the ball
        "default": [Default(5.0, 1e-6, {"restitution": 0.0},
                            restitution=pytest.approx(0.0, abs=FLOAT32)),  # measured exactly 0
                    Default(5.0, 1 / 60)],
        # the plate's fixture has 0, neutral for the max Box2D takes: the pair has the
        # user's value; at 1 / 60 s the plate holds (measured 0)
        "custom": [Custom(2.0, 1e-6, {"restitution": 0.6}, pytest.approx(0.6, rel=FLOAT32)),
                   Custom(5.0, 1 / 60, {"restitution": 0.9}, pytest.approx(0.9, rel=FLOAT32))],
        "collapse": [(30.0, "linear", ("injected",))],
        "deterministic": (BallOnPlate(velocity_m_s=2.0), "injected"),
        "bad": [
            Bad(BallOnPlate(), "custom", {"params": {"velocity_iterations": 0}},
                r"params\.velocity_iterations"),
            Bad(Oblique(), "custom", {"params": {"friction": -1.0}}, "friction"),
            Bad(Oblique(), "custom", {"params": {"mu": 0.3}}, "valid keys"),
        ],
        # |rel err| against the rigid reference, injected (no fixtures; the normal law and
        # ideal Coulomb friction as a force and torque at the contact point), default step
        # 1e-6 s: about 3× the worst measured over CASES (float32), the measurement in each
        # comment
        "oblique_injected": {
            "sphere": ObliqueInjected(
                {"restitution": 1.0e-4,  # 3.38e-5 (20°): the normal law's semi-implicit Euler
                 "tangential_restitution": 3.1e-7,  # 1.02e-7 (45°, ω0 = −60)
                 "rebound_angle_deg": 1.0e-4,  # 3.20e-5 (20°)
                 "spin_out_rad_s": 7.1e-7,  # 2.37e-7 (80°)
                 "peak_tangential_force_n": PEAK_TANGENTIAL},
                CASES, beta=1.8e-7),  # |Δβ| (contact-point ratio, absolute): 5.77e-8 (45°, 60)
            # the disc (k² = R²/2) against the disc's rigid reference: as the sphere's, but
            # for the peak tangential force at 20°
            "disc": ObliqueInjected(
                {"restitution": 1.0e-4,  # 3.38e-5 (20°)
                 "tangential_restitution": 3.9e-7,  # 1.29e-7 (45°, ω0 = −60)
                 "rebound_angle_deg": 1.0e-4,  # 3.22e-5 (20°)
                 "spin_out_rad_s": 2.6e-6,  # 8.56e-7 (80°)
                 "peak_tangential_force_n": 0.13},  # 4.42e-2 (20°: the slip stops within a
                # step of a steeply rising normal force; the sphere's worst there is 1.84e-2)
                CASES, beta=2.7e-7, shape="disc",  # |Δβ|: 8.87e-8 (80°)
                meta={"planar": True}),
        },
        # Σ F_t·dt over the contact step is m·Δv_t: the friction impulse Box2D reports
        "oblique_momentum": [Momentum("native", 45.0, 0.0, tangential=1e-5, per_instant=2)],
        "oblique_runs": {
            # rigid Coulomb in Box2D's float32 contact: measured ≤ 1.53e-5 (20°); stick:
            # rolling after, e_t = 5/7 whatever e is
            "native-45": ObliqueRun(
                "native", 45.0, tol={"spin_out_rad_s": 5e-5},
                expect={"restitution": pytest.approx(0.937476, rel=5e-5),  # e at 1 m/s
                        "tangential_restitution": pytest.approx(5.0 / 7.0, rel=5e-5)},
                facts={"friction_effective": 0.3, "friction_combination": "geometric"},
                not_comparable=("peak_tangential_force_n",)),
            # v_n = 0.35 m/s: below the 1 m/s threshold, no bounce; slide: Δv_t = μ·v_n
            "native-80": ObliqueRun("native", 80.0,
                                    expect={"restitution": pytest.approx(0.0, abs=1e-4)},
                                    slide=5e-5, slide_e=0.0,
                                    meta={"not_expressible": Contains("1 m/s")}),
            # the disc: stick at 45° leaves it rolling with v_t' = (2/3)·v_t
            "native-disc": ObliqueRun(
                "native", 45.0, shape="disc", tol={"spin_out_rad_s": 5e-5},
                expect={"tangential_restitution": pytest.approx(2.0 / 3.0, rel=5e-5)}),
            "default": ObliqueRun(
                "default", 45.0,
                expect={"restitution": pytest.approx(0.0, abs=1e-4),  # restitution 0 by default
                        "tangential_restitution": pytest.approx(5.0 / 7.0, rel=5e-5)},
                facts={"friction": pytest.approx(0.2),  # replaced by μ
                       "friction_effective": 0.3}),
            # frictionless: e_t 1 + 1.3e-6 measured (float32, the plate circle's normal
            # tilted by the ball's float32 position off its top)
            "custom": _frictionless({"friction": 0.0, "restitution": 0.9}, 5e-6, 1e-6, 1e-5),
        },
        "oblique_tuned_ball_params": {"restitution": 0.9},
    },
    # -------------------------------------------------------------------------------- Newton
    # warp on CPU, float32, Featherstone; the contact law ke·x + kd·max(ẋ, 0) and the graph
    # stepping are in test_specifics_newton.py
    "newton": {
        "injected_ball": {5.0: {"restitution": 1.3e-7,  # measured 4.3e-8 (under one float32 ulp)
                                "duration_s": 1.1e-3,  # measured 3.5e-4
                                "peak_force_n": 1.9e-3}},  # measured 6.1e-4
        # at 10 m/s the elastoplastic contact yields (at 3.3 m/s it never passes εs and is
        # the linear law): its second contact runs on the unloading line from the permanent
        # set. Rel. error at 2e-5 s; measured in the comments
        "injected_rf": [RF("elastoplastic", "linear", 10.0,
                           {"peak_force_n": 2.5e-5,  # 8.2e-6
                            "pulse_width_s": 1.2e-5,  # 3.9e-6
                            "impulse_ns": 2.6e-6},  # 8.7e-7
                           timestep_s=2e-5, yields=True)],
        "native_rf": [RF("linear", "linear", 3.3, {"peak_force_n": 1.6e-5,  # 5.4e-6
                                                   "pulse_width_s": 4.7e-7,  # 1.6e-7
                                                   "impulse_ns": 1.0e-6},  # 3.3e-7
                         timestep_s=2e-5)],
        # measured 8.9e-4 and 3.6e-4 (at the default 1e-6 s)
        "native_ball": [NativeBall(1.0, None, restitution=2.7e-3, duration=1.1e-3)],
        # ShapeConfig defaults (ke = 2.5e3 N/m, kd = 100 N·s/m: overdamped approach; the
        # duration's closed form in test_specifics_newton.py)
        "default": [Default(1.0, 1e-5, {"ke": 2.5e3, "kd": 100.0})],
        "bad": [Bad(Oblique(), "custom", {"params": {"kf": -1.0}}, "kf"),
                Bad(Oblique(), "custom", {"params": {"friction": 0.3}}, "valid keys")],
        # |rel err| against the rigid reference, injected (the normal law through Newton's
        # contact, ke = the law's secant; Coulomb friction through Newton's own friction,
        # mu = μ and kf = m_s/dt, ideal Coulomb for the step), default step 1e-6 s: about 3×
        # the worst measured over CASES (float32), the measurement in each comment
        "oblique_injected": {"sphere": ObliqueInjected(
            {"restitution": 1.1e-4,  # 3.50e-5 (20°): the normal law's semi-implicit Euler
             "tangential_restitution": 9.0e-7,  # 2.99e-7 (60°): float32 velocities
             "rebound_angle_deg": 1.0e-4,  # 3.33e-5 (20°)
             "spin_out_rad_s": 2.5e-6,  # 8.38e-7 (80°)
             "peak_tangential_force_n": PEAK_TANGENTIAL},
            CASES, beta=1.1e-6,  # |Δβ| (contact-point ratio, absolute): 3.70e-7 (80°)
            meta={"kf": pytest.approx(0.1 / 3.5 / 1e-6),  # m_s/dt
                  "stepping": Contains("graph")})},
        "oblique_runs": {
            # Newton's penalty contact with the ball's native ke, kd and the same friction;
            # native e_t and spin at 20–60°: measured ≤ 3.21e-7 (45°)
            "native-45": ObliqueRun(
                "native", 45.0, tol={"tangential_restitution": 1e-6, "spin_out_rad_s": 1e-6},
                # its law's e at 2 m/s·cos θ
                expect={"restitution": pytest.approx(0.9366, abs=1e-3)},
                facts={"friction_effective": 0.3, "friction_combination": "average"},
                meta={"mu": 0.3}),
            "native-80": ObliqueRun("native", 80.0, slide=3.3e-5),  # measured 1.1e-5
            "default": ObliqueRun(
                "default", 45.0,
                expect={"restitution": pytest.approx(0.147, abs=1e-3),  # ke 2.5e3, kd 100
                        "tangential_restitution": pytest.approx(5.0 / 7.0, rel=3e-6)},  # 8.6e-7
                facts={"ke": 2.5e3, "kd": 100.0, "mu": 1.0, "kf": 1e3,
                       "friction_effective": 0.3}),
            "custom": ObliqueRun(
                "custom", 45.0, params={"mu": 0.0, "ke": 1e8},
                expect={"tangential_restitution": pytest.approx(1.0, abs=1e-6),
                        "spin_out_rad_s": pytest.approx(0.0, abs=1e-6)}),
        },
        "oblique_tuned_ball_params": {"ke": 1e8},
    },
}


# --------------------------------------------------------------------------------- plumbing


def rows(key: str, *, whole: bool = False) -> list[Any]:
    """``pytest.param(engine, row)`` for every engine's rows under ``key`` (a list, a dict of
    named rows or one row; ``whole``: the entry is one row), with readable ids."""
    out = []
    for engine, table in ENGINES.items():
        entry = table.get(key)
        if entry is None:
            continue
        if whole:
            items = [("", entry)]
        elif isinstance(entry, dict):
            items = list(entry.items())
        elif isinstance(entry, list):
            items = [(str(i), row) for i, row in enumerate(entry)]
        else:
            items = [("", entry)]
        for name, row in items:
            out.append(pytest.param(engine, row, id=f"{engine}-{name}".rstrip("-")))
    return out


def adapter(engine: str):
    """The engine's adapter, or a skip naming the pip command that installs it."""
    require_engine(engine)
    return get_adapter(engine)


def errors(got: dict[str, Any], ref: dict[str, Any], keys) -> dict[str, float]:
    """|relative error| of each metric in ``keys``."""
    return {k: rel(got[k], ref[k]) for k in keys}


def check_recorded(recorded: dict[str, Any], expected: dict[str, Any], where: str) -> None:
    """Each expected entry equals the recorded one (nested dicts compared key by key)."""
    for key, want in expected.items():
        assert key in recorded, (where, key, sorted(recorded))
        if isinstance(want, dict):
            check_recorded(recorded[key], want, f"{where}.{key}")
        else:
            assert recorded[key] == want, (where, key, recorded[key], want)


def check_ball_record(rec: ImpactRecord, engine: str, dt: float) -> None:
    """A ball record: ok, the plate immovable, and the record starts in free flight, before
    touch, and ends after release, a few steps either side of the contact."""
    assert rec.status is Status.OK, rec.message
    assert rec.meta["engine"] == engine
    assert rec.mass_2_kg == math.inf
    assert rec.velocity_2_m_s is None or not rec.velocity_2_m_s.any()
    assert rec.penetration_m[0] < 0.0 < rec.normal_force_n.max()
    assert rec.penetration_m[-1] < 0.0


# ------------------------------------------------------------------------ ball: injected


@pytest.mark.parametrize(("engine", "velocity", "tol"), [
    pytest.param(engine, velocity, tol, id=f"{engine}-{velocity:g}")
    for engine, table in ENGINES.items()
    for velocity, tol in table.get("injected_ball", {}).items()])
def test_injected_ball_reproduces_hunt_crossley(engine: str, velocity: float,
                                                tol: dict[str, float]):
    """The reference law through the engine at 1e-7 s: only the time stepping differs."""
    s = BallOnPlate(velocity_m_s=velocity)
    rec = adapter(engine).run(s, "injected", RunSettings(timestep_s=1e-7))
    check_ball_record(rec, engine, 1e-7)
    got, ref = metrics.compute(rec), hunt_crossley.solve(s)
    assert got["impacts"] == 1
    assert len(rec) < 1.1 * ref["duration_s"] / 1e-7  # a few steps either side
    err = errors(got, ref, tol)
    assert all(err[k] <= tol[k] for k in tol), err
    check_recorded(rec.meta, ENGINES[engine].get("injected_ball_meta", {}), "meta")


@pytest.mark.parametrize(("engine", "row"), rows("ball_error_falls") + rows("rf_error_falls"))
def test_injected_error_falls_with_timestep(engine: str, row: ErrorFalls):
    a = adapter(engine)
    ref = (hunt_crossley.solve(row.scenario) if isinstance(row.scenario, BallOnPlate)
           else two_dof.solve(row.scenario))
    seqs: dict[str, list[float]] = {k: [] for k in row.keys}
    for dt in row.timesteps_s:
        rec = a.run(row.scenario, "injected", RunSettings(timestep_s=dt))
        assert rec.status is Status.OK, (dt, rec.message)
        for k, e in errors(metrics.compute(rec), ref, row.keys).items():
            seqs[k].append(e)
    for k, seq in seqs.items():
        assert all(x > y for x, y in itertools.pairwise(seq)), (k, seq)
        if row.ratio is not None:
            assert seq[0] / seq[-1] > row.ratio, (k, seq)


@pytest.mark.parametrize(("engine", "row"), rows("gravity"))
def test_injected_ball_with_gravity_stays_close(engine: str, row: tuple[str, float]):
    """Gravity's work over the ~100 µs contact is ~1e-6 of the impact energy: the run with
    gravity stays within the engine's stepping error of the gravity-free reference."""
    key, tol = row
    s = BallOnPlate(velocity_m_s=1.0, gravity_m_s2=9.81)
    rec = adapter(engine).run(s, "injected", RunSettings(timestep_s=1e-7))
    assert rec.status is Status.OK, rec.message
    got, ref = metrics.compute(rec), hunt_crossley.solve(BallOnPlate(velocity_m_s=1.0))
    assert rel(got[key], ref[key]) <= tol, (key, got[key], ref[key])


# --------------------------------------------------------------------------- ball: native


@pytest.mark.parametrize(("engine", "row"), rows("native_ball"))
def test_native_ball_maps_the_reference(engine: str, row: NativeBall):
    """Native mode's contact parameters are mapped from the reference at the reference
    velocity (1 m/s unless the option says): the restitution there (everywhere, for a rigid
    or linear contact) and, where the contact is compliant, the duration."""
    s = BallOnPlate(velocity_m_s=row.velocity_m_s)
    rec = adapter(engine).run(s, "native", RunSettings(timestep_s=row.timestep_s,
                                                       options=row.options))
    assert rec.status is Status.OK, rec.message
    assert rec.meta["reference_velocity_m_s"] == row.reference_velocity_m_s
    got = metrics.compute(rec)
    at = row.restitution_at_m_s or row.reference_velocity_m_s
    if row.restitution is not None:
        want = hunt_crossley.solve(s.replace(velocity_m_s=at))["restitution"]
        assert rel(got["restitution"], want) <= row.restitution, (got["restitution"], want)
    if row.duration is not None:
        want = hunt_crossley.solve(s.replace(velocity_m_s=row.reference_velocity_m_s))
        assert rel(got["duration_s"], want["duration_s"]) <= row.duration, \
            (got["duration_s"], want["duration_s"])
    if row.rigid:
        assert "duration_s" in rec.meta["not_comparable"]
    if row.impulse is not None:
        impulse = s.mass_kg * (1.0 + got["restitution"]) * row.velocity_m_s
        assert got["impulse_ns"] == pytest.approx(impulse, rel=row.impulse)
    check_recorded(rec.meta, row.recorded, "meta")
    mapping = ENGINES[engine].get("native_ball_mapping")
    for name, value, want in (mapping(rec, s) if mapping else ()):
        assert value == want, (name, value, want)


# ---------------------------------------------------------------------------- ball: tuned


@pytest.mark.parametrize("engine", list(ENGINES))
def test_tuned_without_parameters_is_unsupported(engine: str):
    rec = adapter(engine).run(BallOnPlate(), "tuned")
    assert rec.status is Status.UNSUPPORTED and "tuned" in rec.message, rec.message


@pytest.mark.parametrize(("engine", "row"), rows("tuned"))
def test_tuned_uses_its_parameters(engine: str, row: Tuned):
    a = adapter(engine)
    s = BallOnPlate(velocity_m_s=row.velocity_m_s)
    settings = RunSettings(timestep_s=row.timestep_s)
    native = a.run(s, "native", settings) if row.same_as_native is not None else None
    tuned = row.tuned(native, s) if callable(row.tuned) else row.tuned
    rec = a.run(s, "tuned", RunSettings(timestep_s=row.timestep_s, tuned=tuned))
    assert rec.status is Status.OK, rec.message
    got = metrics.compute(rec)
    check_recorded(got, row.expect, "metrics")
    if native is not None:
        if row.same_as_native == 0.0:
            np.testing.assert_array_equal(rec.normal_force_n, native.normal_force_n)
        assert got == pytest.approx(metrics.compute(native), rel=row.same_as_native)


# ------------------------------------------------------------------- ball: default, custom


@pytest.mark.parametrize(("engine", "row"), rows("default"))
def test_default_ball_is_the_engine_out_of_the_box(engine: str, row: Default):
    rec = adapter(engine).run(BallOnPlate(velocity_m_s=row.velocity_m_s), "default",
                              RunSettings(timestep_s=row.timestep_s))
    assert rec.status is Status.OK, rec.message
    assert rec.meta["engine_defaults"], "the engine's defaults must be recorded"
    check_recorded(rec.meta["engine_defaults"], row.recorded, "engine_defaults")
    if row.restitution is not None:
        assert metrics.compute(rec)["restitution"] == row.restitution


@pytest.mark.parametrize(("engine", "row"), rows("custom"))
def test_custom_ball_parameters_reach_the_engine(engine: str, row: Custom):
    rec = adapter(engine).run(BallOnPlate(velocity_m_s=row.velocity_m_s), "custom",
                              RunSettings(timestep_s=row.timestep_s, params=row.params))
    assert rec.status is Status.OK, rec.message
    assert rec.meta["params"] == row.params
    assert metrics.compute(rec)["restitution"] == row.restitution


@pytest.mark.parametrize(("engine", "row"), rows("bad"))
def test_bad_settings_are_one_line_value_errors(engine: str, row: Bad):
    with pytest.raises(ValueError, match=row.match) as info:
        adapter(engine).run(row.scenario, row.mode, RunSettings(**row.settings))
    assert "\n" not in str(info.value)


# ------------------------------------------------------------------ rigid–flexible (2-DOF)


def _check_rf(rec: ImpactRecord, row: RF) -> None:
    s = row.scenario
    ref = two_dof.solve(s)
    assert rec.status is Status.OK and ref["status"] == "ok", (rec.message, ref["status"])
    assert rec.meta["timestep_s"] == (row.timestep_s or 1e-5)
    assert rec.mass_2_kg == s.m2_kg
    assert rec.displacement_2_m is not None and rec.displacement_2_m.size == len(rec)
    got = metrics.compute(rec)
    assert got["impacts"] == ref["impacts"]
    err = errors(got, ref, row.tol)
    assert all(err[k] <= tol for k, tol in row.tol.items()), err
    if row.yields:  # the law really yielded
        assert got["max_penetration_m"] > s.eps_s_m
        assert rec.penetration_m.max() > s.eps_s_m


@pytest.mark.parametrize(("engine", "row"), rows("injected_rf"))
def test_injected_rigid_flexible_reproduces_two_dof(engine: str, row: RF):
    rec = adapter(engine).run(row.scenario, "injected", RunSettings(timestep_s=row.timestep_s))
    _check_rf(rec, row)


@pytest.mark.parametrize(("engine", "row"), rows("native_rf"))
def test_native_rigid_flexible_is_the_linear_law(engine: str, row: RF):
    """A compliant contact with stiffness k1 is the linear local law itself."""
    rec = adapter(engine).run(row.scenario, "native", RunSettings(timestep_s=row.timestep_s))
    _check_rf(rec, row)
    check_recorded(rec.meta, ENGINES[engine].get("native_rf_meta", {}), "meta")
    mapping = ENGINES[engine].get("native_rf_mapping")
    for name, value, want in (mapping(rec, row.scenario) if mapping else ()):
        assert value == want, (name, value, want)


@pytest.mark.parametrize(("engine", "row"), rows("elastic_rf"))
def test_native_rigid_flexible_is_elastic_momentum_exchange(engine: str, row: Elastic):
    s = RigidFlexible(velocity_m_s=3.3)
    rec = adapter(engine).run(s, "native", RunSettings(timestep_s=row.timestep_s))
    assert rec.status is Status.OK, rec.message
    check_recorded(rec.meta, row.recorded, "meta")
    got = metrics.compute(rec)
    assert got["impacts"] == 2
    assert rel(got["impulse_ns"], 2 * s.m1_kg * s.velocity_m_s) <= row.impulse
    half_period = math.pi * math.sqrt(s.m2_kg / s.k2_n_per_m)
    assert abs(got["pulse_width_s"] - half_period) <= row.pulse_width_s
    if row.rebound is not None:
        assert rec.velocity_1_m_s[-1] == pytest.approx(-s.velocity_m_s, rel=row.rebound)


@pytest.mark.parametrize(("engine", "row"), rows("collapse"))
def test_softening_collapse_is_a_status(engine: str, row: tuple):
    velocity, local, modes = row
    s = RigidFlexible(velocity_m_s=velocity, local=local, structure="softening")
    assert two_dof.solve(s)["status"] == "structure_collapsed"
    for mode in modes:
        rec = adapter(engine).run(s, mode)
        assert rec.status is Status.STRUCTURE_COLLAPSED, (mode, rec.status, rec.message)
        assert np.all(np.isfinite(rec.displacement_2_m))
        assert_escaped_after_whole_contact(rec, s)


@pytest.mark.parametrize(("engine", "row"), rows("huge_steps"))
def test_huge_timestep_is_a_status_not_a_number(engine: str, row: tuple):
    scenario, mode, dt = row
    rec = adapter(engine).run(scenario, mode, RunSettings(timestep_s=dt))
    assert rec.status in (Status.TUNNELED, Status.DIVERGED), (rec.status, rec.message)


@pytest.mark.parametrize(("engine", "row"), rows("deterministic"))
def test_runs_are_deterministic(engine: str, row: tuple):
    scenario, mode = row
    a, b = adapter(engine).run(scenario, mode), adapter(engine).run(scenario, mode)
    assert a.status is Status.OK, a.message
    np.testing.assert_array_equal(a.normal_force_n, b.normal_force_n)
    np.testing.assert_array_equal(a.penetration_m, b.penetration_m)


@pytest.mark.parametrize(("engine", "row"), rows("unsupported"))
def test_unsupported_combinations_say_why(engine: str, row: tuple):
    scenario, mode, why = row
    rec = adapter(engine).run(scenario, mode)
    assert rec.status is Status.UNSUPPORTED and why in rec.message, rec.message


# ------------------------------------------------------------------------ oblique impacts


def test_the_angles_straddle_the_stick_slide_threshold():
    assert 60.0 < threshold_angle_deg(Oblique()) < 80.0  # 63.9°


def _oblique(engine: str, mode: str, angle: float, spin: float = 0.0, *, shape: str = "sphere",
             **settings: Any) -> tuple[dict[str, Any], ImpactRecord]:
    """The paper's steel ball (or a disc) at 2 m/s, μ = 0.3, at ``angle`` (°) with ``spin``
    (rad/s) through ``evaluate.compare``, the one metrics path."""
    require_engine(engine)
    given = {k: v for k, v in settings.items() if v is not None}  # None: the default
    return compare(engine, Oblique(angle_deg=angle, spin_rad_s=spin, shape=shape), mode,
                   RunSettings(**given))


def _oblique_injected_cases() -> list[Any]:
    return [pytest.param(engine, row, angle, spin, id=f"{engine}-{variant}-{angle:g}-{spin:g}")
            for engine, table in ENGINES.items()
            for variant, row in table.get("oblique_injected", {}).items()
            for angle, spin in row.cases]


@pytest.mark.parametrize(("engine", "row", "angle", "spin"), _oblique_injected_cases())
def test_oblique_injected_reproduces_the_rigid_reference(engine: str, row: ObliqueInjected,
                                                         angle: float, spin: float):
    """Injected: the normal law and ideal Coulomb friction through the engine reproduce the
    rigid Coulomb reference on both sides of the stick/slide threshold, with spin."""
    out, rec = _oblique(engine, "injected", angle, spin, shape=row.shape, options=row.options)
    assert out["status"] == "ok", out["message"]
    for key, tol in row.tol.items():
        assert abs(out["rel_error"][key]) <= tol, (key, out["rel_error"][key])
    if row.beta is not None:
        beta = out["contact_point_ratio"] - out["reference"]["contact_point_ratio"]
        assert abs(beta) <= row.beta, beta
    assert out["regime"] == out["reference"]["regime"]
    if spin == 0.0:  # stick below the threshold, slide above it
        assert out["regime"] == (1.0 if angle == 80.0 else 0.0)
    assert rec.tangential_force_n is not None and rec.spin_rad_s is not None
    check_recorded(rec.meta, row.meta, "meta")


@pytest.mark.parametrize(("engine", "row"), rows("oblique_runs"))
def test_oblique_native_default_and_custom(engine: str, row: ObliqueRun):
    """Native: the engine's own contact and friction, mapped; default: out of the box with
    the scenario's friction, its friction model recorded; custom: the engine's own keys reach
    it (recorded as applied)."""
    mode = row.mode
    settings: dict[str, Any] = {"timestep_s": row.timestep_s, "options": row.options}
    if mode == "custom":
        settings["params"] = row.params
    out, rec = _oblique(engine, mode, row.angle_deg, shape=row.shape, **settings)
    assert out["status"] in row.statuses, out["message"]
    assert math.isfinite(out["spin_out_rad_s"]) and math.isfinite(out["rebound_angle_deg"])
    assert out["timestep_s"] == (row.timestep_s or 1e-6)
    for key, tol in row.tol.items():
        assert abs(out["rel_error"][key]) <= tol, (key, out["rel_error"][key])
    check_recorded(out, row.expect, "out")
    if row.slide is not None:
        e = out["restitution"] if row.slide_e is None else row.slide_e
        expected = 1.0 - 0.3 * (1.0 + e) / math.tan(math.radians(row.angle_deg))
        assert out["tangential_restitution"] == pytest.approx(expected, rel=row.slide)
    facts = out["engine_defaults"]
    check_recorded(facts, row.facts, "engine_defaults")
    check_recorded(rec.meta, row.meta, "meta")
    if mode == "default":
        assert facts["friction_model"]
    assert all(key in rec.meta["not_comparable"] for key in row.not_comparable)
    if mode == "custom":
        if row.recorded_params is None:
            assert out["params"] == row.params
        else:
            check_recorded(out["params"], row.recorded_params, "params")
    if row.differs:
        default, _ = _oblique(engine, "default", row.angle_deg, timestep_s=row.timestep_s)
        assert out["spin_out_rad_s"] != default["spin_out_rad_s"]


@pytest.mark.parametrize(("engine", "row"), rows("oblique_momentum"))
def test_oblique_force_channels_are_the_momentum_applied(engine: str, row: Momentum):
    s = Oblique(angle_deg=row.angle_deg, spin_rad_s=row.spin_rad_s)
    out, rec = _oblique(engine, row.mode, row.angle_deg, row.spin_rad_s)
    dt = rec.meta["timestep_s"]
    assert rec.spin_rad_s[0] == row.spin_rad_s
    dv_t = rec.tangential_velocity_m_s[-1] - s.tangential_velocity_m_s
    impulse_t = rec.tangential_force_n.sum() * dt / row.per_instant
    assert impulse_t == pytest.approx(s.mass_kg * dv_t, rel=row.tangential)
    if row.normal is not None:
        dv_n = rec.penetration_rate_m_s[0] - rec.penetration_rate_m_s[-1]
        assert rec.normal_force_n.sum() * dt == pytest.approx(s.mass_kg * dv_n, rel=row.normal)
    if row.spin is not None:
        assert abs(out["rel_error"]["spin_out_rad_s"]) < row.spin


@pytest.mark.parametrize(("engine", "row"), rows("oblique_tuned_ball_params", whole=True))
def test_oblique_tuned_with_the_balls_parameters_is_unsupported_with_a_reason(engine: str,
                                                                             row: dict):
    # oblique tuned reads friction knobs (impactbench.engines.oblique_tuned); a ball's
    # parameters are refused, and none at all too (tests/impactbench/test_oblique_tuned.py)
    out, _ = _oblique(engine, "tuned", 45.0, tuned=row)
    assert out["status"] == "unsupported"
    assert f"not {engine}'s oblique friction" in out["message"], out["message"]
