"""The contact-model zoo: the force laws engines and papers use for a ball on a plate.

Two families, each model a small law object with the contract of
:class:`~impactbench.reference.laws.HuntCrossley` (``force(x, ẋ)``, ``elastic_force(x)``,
``potential(x)``; SI units):

**Hysteresis damping** F = c·xⁿ·(1 + b·ẋ) with b chosen from a *nominal* restitution e at the
impact velocity V0: b = α(e)/V0. Every model is a Hunt–Crossley law, so its *effective*
restitution is exactly k(α(e)) (Borovin et al. closed form,
:func:`impactbench.reference.hunt_crossley.restitution`), the same at every V0 and for every
c and n — and it differs from the nominal e, which each paper derived with its own
approximation of the energy balance. The classes only differ in α(e); each docstring cites the
paper.

**Linear Kelvin–Voigt** F = k·x + d·ẋ (``exponent`` must be 1; ``stiffness`` is k in N/m) with
d = 2ζ√(k·m) and ζ = −ln e/√(π² + ln² e), the textbook conversion that is exact for the
unclipped law; clipped at F ≥ 0 (what engines do) its effective restitution is higher.
Closed form in :mod:`impactbench.reference.kelvin_voigt`.

Adding a model: one class with ``name``, ``citation`` and ``alpha`` (or ``factor``, for a
:class:`ProportionalModel`; or a new family), and one entry in :data:`MODELS`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import ClassVar

from impactbench.reference import validation as check
from impactbench.reference.laws import HuntCrossley


def check_restitution(field_name: str, value: object) -> float:
    """Return ``value`` as float; raise unless it is in (0, 1]."""
    v = check.positive(field_name, value)
    if v > 1.0:
        raise ValueError(f"{field_name} = {value!r}: must be in (0, 1]")
    return v


@dataclass(frozen=True, kw_only=True)
class HysteresisModel(HuntCrossley):
    """F = c·xⁿ·(1 + b·ẋ) with b = α(e)/V0 from the nominal restitution e at V0 (module doc).

    Args:
        stiffness: c (N/m^n); exponent: n; elastic/potential_fn: as HuntCrossley.
        nominal_restitution: e ∈ (0, 1] (1 = elastic).
        velocity_m_s: the impact velocity V0 > 0 the damping is scaled with.
    The damping b (s/m) is derived, never given.
    """

    nominal_restitution: float = 1.0
    velocity_m_s: float = 1.0
    damping: float = field(init=False, default=0.0)
    name: ClassVar[str]
    citation: ClassVar[str]

    def __post_init__(self) -> None:
        e = check_restitution("nominal_restitution", self.nominal_restitution)
        v0 = check.positive("velocity_m_s", self.velocity_m_s)
        object.__setattr__(self, "damping", self.alpha(e) / v0)
        super().__post_init__()

    @staticmethod
    def alpha(e: float) -> float:
        """α = b·V0 as a function of the nominal restitution e ∈ (0, 1] (dimensionless)."""
        raise NotImplementedError


class ProportionalModel(HysteresisModel):
    """The models whose α is proportional to the loss 1 − e: α = ``factor``·(1 − e)."""

    factor: ClassVar[float]

    @classmethod
    def alpha(cls, e: float) -> float:
        return cls.factor * (1.0 - e)


class HuntCrossleyModel(ProportionalModel):
    """Hunt & Crossley: α = 3(1 − e)/2 (linearised for e → 1).

    K. H. Hunt, F. R. E. Crossley, "Coefficient of restitution interpreted as damping in
    vibroimpact", Journal of Applied Mechanics 42(2), 440–445, 1975.
    """

    name = "hunt-crossley"
    citation = "Hunt & Crossley, J. Appl. Mech. 42(2):440–445, 1975"
    factor = 1.5


class HerbertMcWhannell(HysteresisModel):
    """Herbert & McWhannell: α = 6(1 − e)/((2e − 1)² + 3).

    R. G. Herbert, D. C. McWhannell, "Shape and frequency composition of pulses from an impact
    pair", Journal of Engineering for Industry 99(3), 513–518, 1977.
    """

    name = "herbert-mcwhannell"
    citation = "Herbert & McWhannell, J. Eng. Ind. 99(3):513–518, 1977"

    @staticmethod
    def alpha(e: float) -> float:
        return 6.0 * (1.0 - e) / ((2.0 * e - 1.0) ** 2 + 3.0)


class LeeWang(ProportionalModel):
    """Lee & Wang: α = 3(1 − e)/4.

    T. W. Lee, A. C. Wang, "On the dynamics of intermittent-motion mechanisms. Part 1: Dynamic
    model and response", Journal of Mechanisms, Transmissions, and Automation in Design 105(3),
    534–540, 1983.
    """

    name = "lee-wang"
    citation = "Lee & Wang, J. Mech. Transm. Autom. Des. 105(3):534–540, 1983"
    factor = 0.75


class LankaraniNikravesh(HysteresisModel):
    """Lankarani & Nikravesh: α = 3(1 − e²)/4 (derived for e close to 1).

    H. M. Lankarani, P. E. Nikravesh, "A contact force model with hysteresis damping for impact
    analysis of multibody systems", Journal of Mechanical Design 112(3), 369–376, 1990.
    """

    name = "lankarani-nikravesh"
    citation = "Lankarani & Nikravesh, J. Mech. Des. 112(3):369–376, 1990"

    @staticmethod
    def alpha(e: float) -> float:
        return 0.75 * (1.0 - e * e)


class Gonthier(HysteresisModel):
    """Gonthier et al.: α = (1 − e²)/e (their approximation of the exact relation).

    Y. Gonthier, J. McPhee, C. Lange, J.-C. Piedbœuf, "A regularized contact model with
    asymmetric damping and dwell-time dependent friction", Multibody System Dynamics 11(3),
    209–233, 2004.
    """

    name = "gonthier"
    citation = "Gonthier, McPhee, Lange & Piedbœuf, Multibody Syst. Dyn. 11(3):209–233, 2004"

    @staticmethod
    def alpha(e: float) -> float:
        return (1.0 - e * e) / e


class ZhiyingQishao(HysteresisModel):
    """Zhiying & Qishao: α = 3(1 − e²)·e^(2(1 − e))/4.

    Q. Zhiying, L. Qishao, "Analysis of impact process based on restitution coefficient",
    Journal of Dynamics and Control 4(4), 294–298, 2006 (in Chinese).
    """

    name = "zhiying-qishao"
    citation = "Zhiying & Qishao, J. Dyn. Control 4(4):294–298, 2006"

    @staticmethod
    def alpha(e: float) -> float:
        return 0.75 * (1.0 - e * e) * math.exp(2.0 * (1.0 - e))


class Flores(HysteresisModel):
    """Flores et al.: α = 8(1 − e)/(5e).

    P. Flores, M. Machado, M. T. Silva, J. M. Martins, "On the continuous contact force models
    for soft materials in multibody dynamics", Multibody System Dynamics 25(3), 357–375, 2011.
    """

    name = "flores"
    citation = "Flores, Machado, Silva & Martins, Multibody Syst. Dyn. 25(3):357–375, 2011"

    @staticmethod
    def alpha(e: float) -> float:
        return 1.6 * (1.0 - e) / e


class GharibHurmuzlu(HysteresisModel):
    """Gharib & Hurmuzlu: α = 1/e − 1.

    M. Gharib, Y. Hurmuzlu, "A new contact force model for low coefficient of restitution
    impact", Journal of Applied Mechanics 79(6), 064506, 2012.
    """

    name = "gharib-hurmuzlu"
    citation = "Gharib & Hurmuzlu, J. Appl. Mech. 79(6):064506, 2012"

    @staticmethod
    def alpha(e: float) -> float:
        return 1.0 / e - 1.0


class HuGuo(HysteresisModel):
    """Hu & Guo: α = 3(1 − e)/(2e), as tabulated in later comparisons of these models.

    S. Hu, X. Guo, "A dissipative contact force model for impact analysis in multibody
    dynamics", Multibody System Dynamics 35(2), 131–151, 2015. (The original was not at hand
    when this was written; one public implementation tabulates 3(1 − e)/(4e) instead — check
    against the paper before relying on this row.)
    """

    name = "hu-guo"
    citation = "Hu & Guo, Multibody Syst. Dyn. 35(2):131–151, 2015"

    @staticmethod
    def alpha(e: float) -> float:
        return 1.5 * (1.0 - e) / e


@dataclass(frozen=True)
class KelvinVoigt:
    """Linear spring–damper F = k·x + d·ẋ for x > 0 (else 0); ``clipped`` adds F ≥ 0.

    Args:
        stiffness: k (N/m).
        damping_ns_per_m: d (N·s/m).
        clipped: True → F = max(0, k·x + d·ẋ) (engines' unilateral contact); False → the
            force may pull (adhesion) until x returns to 0.
    """

    stiffness: float
    damping_ns_per_m: float
    clipped: bool = True
    exponent: ClassVar[float] = 1.0

    def __post_init__(self) -> None:
        check.positive("stiffness", self.stiffness)
        check.non_negative("damping_ns_per_m", self.damping_ns_per_m)

    @property
    def adhesive(self) -> bool:
        """True when the law can pull (F < 0 while in contact)."""
        return not self.clipped

    def elastic_force(self, x: float) -> float:
        """k·x in N (0 for x ≤ 0)."""
        return self.stiffness * x if x > 0.0 else 0.0

    def potential(self, x: float) -> float:
        """½·k·x² in J (0 for x ≤ 0)."""
        return 0.5 * self.stiffness * x * x if x > 0.0 else 0.0

    def force(self, x: float, rate: float) -> float:
        """Contact force in N at penetration x (m) and rate ẋ (m/s)."""
        if x <= 0.0:
            return 0.0
        f = self.stiffness * x + self.damping_ns_per_m * rate
        return max(0.0, f) if self.clipped else f


HYSTERESIS_MODELS: dict[str, type[HysteresisModel]] = {
    cls.name: cls for cls in (HuntCrossleyModel, HerbertMcWhannell, LeeWang, LankaraniNikravesh,
                              Gonthier, ZhiyingQishao, Flores, GharibHurmuzlu, HuGuo)
}
LINEAR_MODELS: dict[str, bool] = {"kelvin-voigt": False, "kelvin-voigt-clipped": True}
"""Linear models → whether the force is clipped at F ≥ 0."""
MODELS: tuple[str, ...] = (*HYSTERESIS_MODELS, *LINEAR_MODELS)
"""Every model name the CLI, the scenario and the figures accept."""
MODEL_CITATIONS: dict[str, str] = {
    **{name: cls.citation for name, cls in HYSTERESIS_MODELS.items()},
    "kelvin-voigt": "Kelvin–Voigt linear spring–damper, unclipped (textbook)",
    "kelvin-voigt-clipped": "Kelvin–Voigt linear spring–damper clipped at F ≥ 0 (engines)",
}


def linear_damping_ns_per_m(nominal_restitution: float, stiffness_n_per_m: float,
                            mass_kg: float) -> float:
    """d = 2ζ√(k·m), ζ = −ln e/√(π² + ln² e): the unclipped law's restitution is exactly e."""
    from impactbench.reference.kelvin_voigt import zeta_from_restitution

    zeta = zeta_from_restitution(nominal_restitution)
    return 2.0 * zeta * math.sqrt(stiffness_n_per_m * mass_kg)


def spring_damper(law: HuntCrossley | KelvinVoigt, x: float) -> tuple[float, float]:
    """(secant stiffness N/m, damping N·s/m) with F = k·x + d·ẋ at penetration x > 0.

    The form an engine's spring–damper contact takes when a law is injected through it:
    Hunt–Crossley family k = f(x)/x, d = f(x)·b; Kelvin–Voigt k, d as given.
    """
    if isinstance(law, KelvinVoigt):
        return law.stiffness, law.damping_ns_per_m
    f = law.elastic_force(x)
    return f / x, f * law.damping
