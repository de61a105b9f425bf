"""Physical set-ups shared by the reference solvers and every engine adapter.

Frozen dataclasses with the papers' defaults, SI units in the field names, validated on
construction: a bad value raises ``ValueError`` naming the field, the value and the rule.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import asdict, dataclass, fields
from typing import Any, ClassVar

from impactbench.reference import validation as check
from impactbench.reference.laws import (
    ALL_LOCAL_LAWS,
    STRUCTURAL_LAWS,
    ContinuousMutation,
    Elastoplastic,
    HuntCrossley,
    LinearLocal,
    LinearStructure,
    LocalLaw,
    SofteningStructure,
    StiffnessMutation,
    StructuralLaw,
)
from impactbench.reference.models import (
    HYSTERESIS_MODELS,
    LINEAR_MODELS,
    MODELS,
    KelvinVoigt,
    check_restitution,
    linear_damping_ns_per_m,
)

STEEL_YOUNG_PA = 2.0e11
STEEL_POISSON = 0.25
STEEL_DENSITY_KG_M3 = 7800.0


def hertz_stiffness(radius_1_m: float, young_1_pa: float, poisson_1: float,
                    radius_2_m: float = math.inf, young_2_pa: float = STEEL_YOUNG_PA,
                    poisson_2: float = STEEL_POISSON) -> float:
    """Hertz sphere contact constant c = (4/3)·E*·√R* in N/m^1.5.

    1/E* = (1−ν₁²)/E₁ + (1−ν₂²)/E₂, 1/R* = 1/R₁ + 1/R₂ (a plate has R₂ = ∞).
    """
    e_star = 1.0 / ((1 - poisson_1**2) / young_1_pa + (1 - poisson_2**2) / young_2_pa)
    r_star = 1.0 / (1.0 / radius_1_m + 1.0 / radius_2_m)
    return 4.0 / 3.0 * e_star * math.sqrt(r_star)


PAPER_RADIUS_M = 0.01452
"""The card's ball radius (the preprint's m = 0.1 kg steel ball: R = 1.4517 cm)."""
PAPER_STIFFNESS = 1.7135e10
"""The preprint's c for that ball on a massive steel plate (N/m^1.5)."""
PAPER_VELOCITIES_M_S: tuple[float, ...] = (0.5, 1.0, 2.0, 3.0, 4.0, 5.0)
MIN_VELOCITY_M_S = 1e-100
"""Smallest ball impact velocity: the closed form (x_max ∝ V0^(4/(n+1))) is exact down to
here; far below, V0² underflows and every metric would come out 0."""


class ScenarioFields:
    """What every scenario dataclass shares (a plug-in's too: it subclasses this):
    ``to_dict``, ``replace`` and ``field_names``. ``name`` is its registry name, the key
    adapters find their builder under (:attr:`impactbench.engines.base.Adapter.builders`)."""

    name: ClassVar[str]

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)  # type: ignore[call-overload]

    def replace(self, **changes: Any) -> Any:
        from dataclasses import replace

        return replace(self, **changes)  # type: ignore[type-var]

    @classmethod
    def field_names(cls) -> tuple[str, ...]:
        return tuple(f.name for f in fields(cls))  # type: ignore[arg-type]


def check_each(rule: Callable[[str, object], float], scenario: Any, *names: str) -> None:
    """``rule`` (a check of :mod:`impactbench.reference.validation`, such as
    ``positive``) on each named field of ``scenario``, in order: the first bad one raises."""
    for name in names:
        rule(name, getattr(scenario, name))


def check_ball_contact(ball: Any) -> None:
    """The contact fields of a ball on a plate (:class:`BallOnPlate`, ``Oblique``): mass,
    stiffness, exponent and radius > 0, damping >= 0."""
    check_each(check.positive, ball, "mass_kg", "stiffness", "exponent")
    check.non_negative("damping_s_per_m", ball.damping_s_per_m)
    check.positive("radius_m", ball.radius_m)


def check_contact_model(ball: Any) -> float | None:
    """The ball's nominal restitution, checked against its contact ``model``: None only for
    the default hunt-crossley (which takes ``damping_s_per_m`` as given), else in (0, 1]; a
    linear model needs ``exponent`` 1."""
    e = ball.nominal_restitution
    if e is None:
        if ball.model != "hunt-crossley":
            raise ValueError(f"nominal_restitution = None: model {ball.model!r} needs a "
                             "nominal restitution in (0, 1]")
        return None
    check_restitution("nominal_restitution", e)
    if ball.model in LINEAR_MODELS and ball.exponent != 1.0:
        raise ValueError(f"exponent = {ball.exponent!r}: model {ball.model!r} is a linear "
                         "spring (stiffness in N/m); must be 1")
    return e


@dataclass(frozen=True)
class BallOnPlate(ScenarioFields):
    """A steel ball hitting a massive fixed plate head-on (MODELS.md §1).

    Hunt–Crossley contact F = c·xⁿ·(1 + b·ẋ). Gravity is off by default (the paper's
    impact is collinear and gravity-free); ``gravity_m_s2 = 9.81`` turns it on in engines.

    ``model`` picks a contact model of the zoo (:mod:`impactbench.reference.models`); with
    ``nominal_restitution`` e set, the model's damping follows from e at ``velocity_m_s``:
    for the hysteresis-damping models ``damping_s_per_m`` is *derived* (b = α(e)/V0, any given
    value is replaced), for the linear Kelvin–Voigt models ``stiffness`` is k in N/m
    (``exponent`` must be 1) and d = 2ζ√(k·m). The default model ``hunt-crossley`` without e
    takes ``damping_s_per_m`` as given (the paper's b).
    """

    name: ClassVar[str] = "ball-on-plate"

    velocity_m_s: float = 1.0
    mass_kg: float = 0.1
    stiffness: float = PAPER_STIFFNESS
    exponent: float = 1.5
    damping_s_per_m: float = 0.1
    radius_m: float = PAPER_RADIUS_M
    gravity_m_s2: float = 0.0
    model: str = "hunt-crossley"
    nominal_restitution: float | None = None

    def __post_init__(self) -> None:
        check.positive("velocity_m_s", self.velocity_m_s)
        if self.velocity_m_s < MIN_VELOCITY_M_S:
            raise ValueError(f"velocity_m_s = {self.velocity_m_s!r}: must be >= "
                             f"{MIN_VELOCITY_M_S:g} m/s (below it V0² underflows double "
                             "precision and the closed form would return zeros)")
        check_ball_contact(self)
        check.non_negative("gravity_m_s2", self.gravity_m_s2)
        check.one_of("model", self.model, MODELS)
        e = check_contact_model(self)
        if e is None:
            return
        if self.model in LINEAR_MODELS:
            object.__setattr__(self, "damping_s_per_m", 0.0)
        else:
            b = HYSTERESIS_MODELS[self.model].alpha(float(e)) / self.velocity_m_s
            object.__setattr__(self, "damping_s_per_m", b)

    @property
    def alpha(self) -> float:
        """α = b·V0, the only parameter restitution depends on (hysteresis models)."""
        return self.damping_s_per_m * self.velocity_m_s

    @property
    def is_linear(self) -> bool:
        """True for the linear Kelvin–Voigt models."""
        return self.model in LINEAR_MODELS

    def penetration_problem(self, max_penetration_m: float) -> str:
        """Why a solution with this largest indentation is outside the model ("" if none).

        The force laws are small-indentation contact laws of a ball of radius R: an indentation
        beyond R has the ball's centre below the plate surface, where no contact law holds."""
        if max_penetration_m > self.radius_m:
            return (f"max_penetration_m = {max_penetration_m:.4g}: beyond radius_m = "
                    f"{self.radius_m:g} (the ball's centre below the surface); the contact law "
                    f"does not hold at V0 = {self.velocity_m_s:g} m/s")
        return ""

    def law(self) -> HuntCrossley | KelvinVoigt:
        """The contact law: a Hunt–Crossley-family law, or a Kelvin–Voigt spring–damper."""
        if self.is_linear:
            d = linear_damping_ns_per_m(float(self.nominal_restitution), self.stiffness,
                                        self.mass_kg)
            return KelvinVoigt(self.stiffness, d, clipped=LINEAR_MODELS[self.model])
        if self.nominal_restitution is None:
            return HuntCrossley(self.stiffness, self.exponent, self.damping_s_per_m)
        return HYSTERESIS_MODELS[self.model](
            stiffness=self.stiffness, exponent=self.exponent,
            nominal_restitution=self.nominal_restitution, velocity_m_s=self.velocity_m_s)


@dataclass(frozen=True)
class RigidFlexible(ScenarioFields):
    """Rigid body 1 (m1) hitting flexible body 2 (m2) tied to the ground (MODELS.md §2).

    Defaults are Zhou & Xiao's base parameters. ``local`` names the contact law
    (linear, elastoplastic, mutation), ``structure`` the structural law (linear, softening).
    """

    name: ClassVar[str] = "rigid-flexible"

    velocity_m_s: float = 2.0
    local: str = "linear"
    structure: str = "linear"
    m1_kg: float = 10.0
    m2_kg: float = 10.0
    k1_n_per_m: float = 1.0e5
    k2_n_per_m: float = 1.0e5
    kt_n_per_m: float = 2.0e4
    k1_failed_n_per_m: float = 5.0e4
    eps_s_m: float = 0.07
    beta_n_per_m3: float = 3.0e6
    fm_n: float = 1.0e3
    max_time_s: float = 10.0

    def __post_init__(self) -> None:
        check.positive("velocity_m_s", self.velocity_m_s)
        check.one_of("local", self.local, tuple(ALL_LOCAL_LAWS))
        check.one_of("structure", self.structure, tuple(STRUCTURAL_LAWS))
        check_each(check.positive, self, "m1_kg", "m2_kg", "k1_n_per_m", "k2_n_per_m",
                   "kt_n_per_m", "k1_failed_n_per_m", "eps_s_m", "fm_n", "max_time_s")
        check.non_negative("beta_n_per_m3", self.beta_n_per_m3)
        # Energy: loading along the backbone to Δx_m = εs + d absorbs k1·εs²/2 + k1·εs·d +
        # kt·d²/2; the elastic unloading (slope k1) returns F_m²/(2·k1). Their difference is
        # (k1 − kt)·(εs·d + kt·d²/(2·k1)), ≥ 0 for every d only if kt ≤ k1. The mutation
        # law's drop k1 → k1' at Δx_f releases (k1 − k1')·Δx_f²/2, ≥ 0 only if k1' ≤ k1.
        if self.local == "elastoplastic" and self.kt_n_per_m > self.k1_n_per_m:
            raise ValueError(f"kt_n_per_m = {self.kt_n_per_m!r}: must be <= k1_n_per_m "
                             f"({self.k1_n_per_m!r}); a harder plastic branch than the elastic "
                             "one makes the elastoplastic unloading create energy")
        if self.local == "mutation" and self.k1_failed_n_per_m > self.k1_n_per_m:
            raise ValueError(f"k1_failed_n_per_m = {self.k1_failed_n_per_m!r}: must be <= "
                             f"k1_n_per_m ({self.k1_n_per_m!r}); a stiffer failed contact "
                             "makes the failure create energy")

    def local_law(self) -> LocalLaw:
        """A fresh local law object (its memory reset)."""
        if self.local == "linear":
            return LinearLocal(self.k1_n_per_m)
        if self.local == "elastoplastic":
            return Elastoplastic(self.k1_n_per_m, self.kt_n_per_m, self.eps_s_m)
        if self.local == "mutation-continuous":
            return ContinuousMutation.from_failure(self.k1_n_per_m, self.k1_failed_n_per_m,
                                                   self.fm_n)
        return StiffnessMutation(self.k1_n_per_m, self.k1_failed_n_per_m, self.fm_n)

    def structural_law(self) -> StructuralLaw:
        if self.structure == "linear":
            return LinearStructure(self.k2_n_per_m)
        return SofteningStructure(self.k2_n_per_m, self.beta_n_per_m3)


SWEEP_FIELDS: dict[str, str] = {
    "velocity": "velocity_m_s", "k1": "k1_n_per_m", "k2": "k2_n_per_m", "m2": "m2_kg",
}
"""Sweepable rigid–flexible parameters (CLI name → :class:`RigidFlexible` field, SI)."""

SCENARIOS: dict[str, type[BallOnPlate] | type[RigidFlexible]] = {
    "ball-on-plate": BallOnPlate,
    "rigid-flexible": RigidFlexible,
}
