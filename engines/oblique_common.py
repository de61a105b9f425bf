"""Pieces the engines' oblique builders share (MODELS.md §3; the scenario is
:class:`~impactbench.reference.oblique_scenario.Oblique`).

Frame and signs, the same in every adapter: the plate's top face is z = 0 with its outward
normal n = +z; the ball comes in along t = +x, so its centre starts at velocity
(V·sin θ, 0, −V·cos θ) and spin ω0 about n × t = +y (positive: forward rolling, the contact
point's slip is s = v_t − R·ω). Gravity is off. An engine record carries, per step (sample k:
the state at the start of step k and the forces the engine applied over step k):

- the normal channels as the ball's: penetration x = R − z, its rate ẋ = −ż (also
  ``velocity_1_m_s``), the engine's normal contact force (N, ≥ 0);
- the tangential channels: the centre's v_t = ẋ_centre (``tangential_velocity_m_s``), the spin
  ω_y (``spin_rad_s``) and the friction force on the ball along +x (``tangential_force_n``),
  read from the engine's contact output as the normal force is.

:func:`impactbench.reference.oblique.record_metrics` reads them (the normal part through the
one metrics path, the velocities after from the last sample).

Friction facts reach the results through ``meta["engine_defaults"]`` (flat keys, read back
from the engine where it can report them): :func:`friction_facts`.

The disc (``Oblique.shape = "disc"``, k² = R²/2) exists only in the plane: a 2D engine's
builder marks its records ``meta["planar"] = True`` (:data:`PLANAR`; its circle carries the
scenario's moment of inertia, :attr:`Oblique.moment_of_inertia_kg_m2`). Every other builder's
disc run is turned into ``unsupported`` with the reason (:data:`DISC_UNSUPPORTED`) by
:func:`finish`, which every oblique builder calls — so the 3D adapters need no code of their
own for it (they simulate their sphere first; :func:`shape_unsupported` is the same check
before the run for a builder that wants to skip it).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from impactbench.engines.common import SpringDamper, classify, native_ball_spring_damper
from impactbench.reference.oblique_scenario import SPIN_FACTOR, Oblique
from impactbench.reference.record import ImpactRecord, Status

PLANAR = "planar"
"""The ``meta`` key a 2D engine's oblique builder sets to True: it runs the in-plane problem
(a circle), so a disc is as valid as a sphere there."""
DISC_UNSUPPORTED = ("shape 'disc': a disc (k² = R²/2) exists only in the 2D engines (pymunk, "
                    "Box2D); this engine's ball is a sphere (run shape 'sphere')")
GAP_STEPS = 2.5
"""Free flight before first touch, in steps (first touch falls inside a step)."""
COMBINATIONS = ("product", "max", "min", "average", "harmonic")
"""How engines combine the two bodies' friction coefficients into the pair's μ: Bullet
multiplies, MuJoCo takes the larger, Drake the harmonic mean 2ab/(a + b)."""
FRICTION_RELAXATION_PER_CONTACT = 20.0
"""An injected velocity-level Coulomb friction that cannot be rigid in one step relaxes the
slip at this many times the inverse contact duration (MuJoCo's elliptic cone), so the stick
phase is reached within 1/20 of the contact."""
REGULARISATION_STEPS = 1.0
"""A Coulomb friction applied as a force (:func:`coulomb_force`): inside the slip scale the
slip decays at the rate 1/(this many steps) — λ·dt = 1, where RK3 damps monotonically (its
amplification 1/3). Measured on Kharaz's sphere at 1e-6 s (a contact of ~8 steps): spin −13 %
with 2 steps, −4 % with 1; the paper's ball is the same to 1e-9 with either."""


@dataclass(frozen=True)
class Start:
    """The initial state of an oblique run: the ball ``gap_m`` above the plate (along n),
    centre velocity v_t along +x and −v_n along z, spin ω0 about +y."""

    normal_velocity_m_s: float
    tangential_velocity_m_s: float
    spin_rad_s: float
    gap_m: float

    @property
    def flight_s(self) -> float:
        """Time from the start to first touch (s)."""
        return self.gap_m / self.normal_velocity_m_s


def start(s: Oblique, dt: float) -> Start:
    """The start :data:`GAP_STEPS` steps of normal flight above the plate."""
    v_n = s.normal_velocity_m_s
    return Start(v_n, s.tangential_velocity_m_s, s.spin_rad_s, GAP_STEPS * v_n * dt)


def kinetic_energy_j(s: Oblique, v_n: float, v_t: float, spin: float) -> float:
    """½·m·(v_n² + v_t²) + ½·I·ω², I = m·k² of the shape (sphere (2/5)·m·R², disc m·R²/2)."""
    return 0.5 * s.mass_kg * (v_n * v_n + v_t * v_t) + 0.5 * s.moment_of_inertia_kg_m2 * spin**2


def record(s: Oblique, t: Any, x: Any, rate: Any, normal: Any, v_t: Any, spin: Any,
           tangential: Any, meta: dict[str, Any]) -> ImpactRecord:
    """The oblique record (module doc): normal channels as the ball's, plus the tangential
    ones; body 2 is the fixed plate."""
    rate = np.asarray(rate, dtype=float)
    return ImpactRecord(t, x, rate, normal, rate, np.zeros_like(rate), mass_1_kg=s.mass_kg,
                        mass_2_kg=math.inf, meta=meta, tangential_velocity_m_s=v_t,
                        spin_rad_s=spin, tangential_force_n=tangential)


def shape_unsupported(s: Oblique, planar: bool = False) -> ImpactRecord | None:
    """``unsupported`` (:data:`DISC_UNSUPPORTED`) for a disc outside a planar (2D) engine,
    else None."""
    if s.shape == "disc" and not planar:
        return ImpactRecord.failed(Status.UNSUPPORTED, DISC_UNSUPPORTED)
    return None


def finish(rec: ImpactRecord, s: Oblique, *, tunneled: bool = False,
           timed_out: bool = False) -> ImpactRecord:
    """Classify an oblique record (:func:`impactbench.engines.common.classify`) with the
    whole kinetic energy, translation and spin: a run that ends with more than 1 % more than
    it started with diverged; a non-finite tangential channel too. A disc run of a builder
    that did not mark its record planar (``meta["planar"]``, the 2D engines) is returned as
    an empty ``unsupported`` record with the reason (its meta kept; module doc)."""
    bad = shape_unsupported(s, bool(rec.meta.get(PLANAR, False)))
    if bad is not None:
        bad.meta.update(rec.meta)
        return bad
    if len(rec):
        final = kinetic_energy_j(s, float(rec.penetration_rate_m_s[-1]),
                                 float(rec.tangential_velocity_m_s[-1]),
                                 float(rec.spin_rad_s[-1]))
    else:
        final = math.nan
    initial = kinetic_energy_j(s, s.normal_velocity_m_s, s.tangential_velocity_m_s,
                               s.spin_rad_s)
    classify(rec, initial_kinetic_j=initial, final_kinetic_j=final, tunneled=tunneled,
             timed_out=timed_out)
    tangential = (rec.tangential_velocity_m_s, rec.spin_rad_s, rec.tangential_force_n)
    if rec.status is not Status.DIVERGED and not all(
            a is None or np.all(np.isfinite(a)) for a in tangential):
        rec.status, rec.message = Status.DIVERGED, "non-finite tangential state"
    return rec


def native_normal(s: Oblique, reference_velocity_m_s: float) -> SpringDamper:
    """The ball's native conversion for the oblique impact's normal law: the clipped linear
    spring–damper matching the Hunt–Crossley reference's restitution and duration at the
    reference velocity (default 1 m/s), independent of θ (cached per normal law)."""
    return _native(s.normal_scenario(reference_velocity_m_s), reference_velocity_m_s)


@functools.lru_cache(maxsize=64)
def _native(ball: Any, reference_velocity_m_s: float) -> SpringDamper:
    return native_ball_spring_damper(ball, reference_velocity_m_s)


@functools.lru_cache(maxsize=256)
def normal_duration_s(s: Oblique) -> float:
    """The reference normal contact's duration at v_n (the zoo's closed form)."""
    from impactbench.reference.oblique import normal_sweep

    return float(normal_sweep(s, np.asarray([s.normal_velocity_m_s]))["duration_s"].iloc[0])


def elastic_duration_s(s: Oblique) -> float:
    """The elastic (b = 0) power-law duration at v_n (s): a time-scale for caps and chunks."""
    v, n1 = s.normal_velocity_m_s, s.exponent + 1.0
    x_max = (n1 * s.mass_kg * v * v / (2.0 * s.stiffness)) ** (1.0 / n1)
    shape = math.sqrt(math.pi) * math.gamma(1.0 + 1.0 / n1) / math.gamma(0.5 + 1.0 / n1)
    return 2.0 * x_max / v * shape


def friction_relaxation_rate(s: Oblique, dt: float) -> float:
    """The slip relaxation rate B (1/s) of an injected velocity-level Coulomb friction:
    :data:`FRICTION_RELAXATION_PER_CONTACT` / T (T: the reference normal duration), at most
    1/dt (a step removes the whole slip: the discrete rigid limit)."""
    return min(FRICTION_RELAXATION_PER_CONTACT / normal_duration_s(s), 1.0 / dt)


def coulomb_force(normal_n: float, slip_m_s: float, friction: float, mass_kg: float,
                  dt: float, spin_factor: float = SPIN_FACTOR) -> float:
    """Coulomb friction on the ball along the slip's axis, F_t = −μ·F_n·s/max(|s|, v_s),
    regularised only where one explicit step would overshoot: v_s = κ·(1 + R²/k²)·μ·F_n·dt/m
    (κ = :data:`REGULARISATION_STEPS`; ``spin_factor`` 1 + R²/k², the sphere's 3.5 unless
    given), so inside it the slip decays at the rate 1/(κ·dt) — the rigid limit as dt → 0,
    stable for an explicit Runge–Kutta step — and outside it the force is exactly μ·F_n
    against the slip."""
    if normal_n <= 0.0 or friction == 0.0 or slip_m_s == 0.0:
        return 0.0
    scale = REGULARISATION_STEPS * spin_factor * friction * normal_n * dt / mass_kg
    return -friction * normal_n * slip_m_s / max(abs(slip_m_s), scale)


def combined(rule: str, ball: float, plate: float) -> float:
    """The pair's μ under an engine's combination rule (:data:`COMBINATIONS`)."""
    if rule == "product":
        return ball * plate
    if rule == "max":
        return max(ball, plate)
    if rule == "min":
        return min(ball, plate)
    if rule == "average":
        return 0.5 * (ball + plate)
    if rule == "harmonic":
        return 2.0 * ball * plate / (ball + plate) if ball + plate > 0.0 else 0.0
    raise ValueError(f"rule = {rule!r}: must be one of {', '.join(COMBINATIONS)}")


def friction_facts(model: str, rule: str, ball: float, plate: float, effective: float,
                   **extra: Any) -> dict[str, Any]:
    """The friction facts an oblique record carries in ``meta["engine_defaults"]``:
    ``friction_model`` (the engine's law, in words), ``friction_combination`` (the pair rule;
    ``none`` where μ is applied directly, not combined from two bodies),
    the coefficients set on ``friction_ball`` and ``friction_plate``, the pair's
    ``friction_effective`` (read back from the engine where it reports it) and engine-specific
    extras (cone, anchors, tolerances, …)."""
    if rule not in (*COMBINATIONS, "none"):
        raise ValueError(f"rule = {rule!r}: must be one of {', '.join(COMBINATIONS)}, none")
    return {"friction_model": model, "friction_combination": rule,
            "friction_ball": float(ball), "friction_plate": float(plate),
            "friction_effective": float(effective), **extra}


def neutral_plate(rule: str, friction: float) -> float:
    """The plate's coefficient that gives the pair exactly ``friction`` under ``rule``
    (product: 1; max, min, average, harmonic: the same value)."""
    if rule == "product":
        return 1.0
    if rule in COMBINATIONS:
        return friction
    raise ValueError(f"rule = {rule!r}: must be one of {', '.join(COMBINATIONS)}")


__all__ = [
    "COMBINATIONS",
    "DISC_UNSUPPORTED",
    "FRICTION_RELAXATION_PER_CONTACT",
    "GAP_STEPS",
    "PLANAR",
    "REGULARISATION_STEPS",
    "SPIN_FACTOR",
    "Start",
    "combined",
    "coulomb_force",
    "elastic_duration_s",
    "finish",
    "friction_facts",
    "friction_relaxation_rate",
    "kinetic_energy_j",
    "native_normal",
    "neutral_plate",
    "normal_duration_s",
    "record",
    "shape_unsupported",
    "start",
]
