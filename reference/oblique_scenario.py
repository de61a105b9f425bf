"""The oblique-impact scenario's dataclass, :class:`Oblique` (MODELS.md §3), and its cases.

Kept free of numpy, scipy and pandas (the command line builds its flags from it; ``--help``
must stay light). The physics is in :mod:`impactbench.reference.oblique` (the rigid closed
form and the metrics) and :mod:`impactbench.reference.oblique_integrate` (the time
integration and the compliant references).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, ClassVar

from impactbench.reference import validation as check
from impactbench.reference.models import LINEAR_MODELS, MODELS
from impactbench.reference.scenarios import (
    MIN_VELOCITY_M_S,
    PAPER_RADIUS_M,
    PAPER_STIFFNESS,
    STEEL_POISSON,
    STEEL_YOUNG_PA,
    BallOnPlate,
    ScenarioFields,
    check_ball_contact,
    check_contact_model,
    hertz_stiffness,
)

SHAPES: tuple[str, ...] = ("sphere", "disc")
"""The ball's shape (``Oblique.shape``): a solid sphere, or (the 2D engines' circle) a solid
disc; only the radius of gyration differs (the contact laws are the scenario's in both)."""
GYRATION_RATIOS: dict[str, float] = {"sphere": 0.4, "disc": 0.5}
"""k²/R² of each shape: solid sphere 2/5, solid disc 1/2 (:attr:`Oblique.gyration_ratio`)."""
GYRATION_RATIO = GYRATION_RATIOS["sphere"]
"""k²/R² of a solid sphere (2/5); a scenario's own is :attr:`Oblique.gyration_ratio`."""
SPIN_FACTOR = 1.0 + 1.0 / GYRATION_RATIO
"""1 + R²/k² = 3.5 for a solid sphere: the slip changes this many times faster than v_t
(a scenario's own, 3 for a disc, is :attr:`Oblique.spin_factor`)."""
TANGENTIAL_MODELS: tuple[str, ...] = ("rigid", "mindlin", "mindlin-deresiewicz")
"""``rigid``: ideal Coulomb, closed form; ``mindlin``: Mindlin's no-slip spring 8·G*·a capped at
μ·F_n (the DEM codes' simplified law, event-switched); ``mindlin-deresiewicz``: the full
Cattaneo–Mindlin/Mindlin–Deresiewicz law — micro-slip and the memory of how the contact was
loaded — as a spring bed (:mod:`impactbench.reference.oblique_integrate`)."""
COMPLIANT_MODELS: tuple[str, ...] = ("mindlin", "mindlin-deresiewicz")
"""The tangentially compliant laws (Hertz geometry: they need the Hertz normal law)."""
COMPLIANT_DEFAULT = "mindlin-deresiewicz"
"""The compliant reference the suite draws beside the rigid theory: the full contact-mechanics
law (no simplification of the Cattaneo–Mindlin problem), and the closest to Kharaz et al.'s
measurements in every angle range (tests/reference/test_oblique_microslip.py)."""
OBLIQUE_MODELS: tuple[str, ...] = tuple(m for m in MODELS if m != "kelvin-voigt")
"""The zoo's laws an oblique impact accepts: every one but the unclipped Kelvin–Voigt spring,
whose force pulls (F_n < 0) while the ball leaves, where a Coulomb cap μ·F_n means nothing."""
REGIME_TOLERANCE = 1e-3
"""``regime`` is slide (1.0) when β = −s'/s0 < −this, else stick (0.0)."""
SLIDE, STICK = 1.0, 0.0

OBLIQUE_METRICS: tuple[str, ...] = (
    "restitution",
    "tangential_restitution",
    "contact_point_ratio",
    "rebound_angle_deg",
    "spin_out_rad_s",
    "regime",
    "duration_s",
    "peak_force_n",
    "peak_tangential_force_n",
)
"""The oblique metrics, in the order of ``reference oblique --json`` and the results rows."""

KHARAZ_RADIUS_M = 0.0025
KHARAZ_DENSITY_KG_M3 = 4000.0
KHARAZ_YOUNG_PA = 3.8e11
KHARAZ_POISSON = 0.23


def _kharaz2001() -> dict[str, Any]:
    """Kharaz, Gorham & Salman (2001) with the inputs of Chung & Ooi (2011, test 4): an
    alumina sphere (R = 2.5 mm, ρ = 4000 kg/m³, E = 3.8e11 Pa, ν = 0.23) on a rigid plate,
    μ = 0.092, normal restitution 0.98 (the zoo's Hunt–Crossley model with that nominal e),
    Hertz c of the sphere alone (plate rigid). The impact speed, 3.9 m/s, is an axis value:
    :data:`CASE_POINTS`."""
    r = KHARAZ_RADIUS_M
    return {
        "friction": 0.092,
        "mass_kg": KHARAZ_DENSITY_KG_M3 * 4.0 / 3.0 * math.pi * r**3,
        "stiffness": hertz_stiffness(r, KHARAZ_YOUNG_PA, KHARAZ_POISSON, math.inf, math.inf,
                                     KHARAZ_POISSON),
        "exponent": 1.5,
        "radius_m": r,
        "model": "hunt-crossley",
        "nominal_restitution": 0.98,
        "youngs_modulus_pa": KHARAZ_YOUNG_PA,
        "poisson": KHARAZ_POISSON,
        "plate_youngs_modulus_pa": math.inf,
        "plate_poisson": KHARAZ_POISSON,
    }


CASES: dict[str, dict[str, Any]] = {"kharaz2001": _kharaz2001()}
"""Named sets of :class:`Oblique` fields (``--case``, a config's ``case = …``): the physical
parameters, never the point's axes (angle, speed)."""
CASE_POINTS: dict[str, dict[str, float]] = {"kharaz2001": {"velocity_m_s": 3.9}}
"""Each case's own point values (the experiment's impact speed): :meth:`Oblique.case` and
``reference oblique --case`` use them unless a value is given."""


def _poisson(name: str, value: object) -> float:
    v = check.finite(name, value)
    if not -1.0 < v < 0.5:
        raise ValueError(f"{name} = {value!r}: must be in (-1, 0.5)")
    return v


@dataclass(frozen=True)
class Oblique(ScenarioFields):
    """A sphere (or disc) hitting a massive plate at an angle, with friction and spin (module
    doc).

    Defaults: the preprint's steel ball (m = 0.1 kg, c = 1.7135e10 N/m^1.5, n = 1.5,
    b = 0.1 s/m, R = 1.452 cm, steel E = 2e11 Pa, ν = 0.25 for ball and plate) at 2 m/s and
    45°, μ = 0.3 (ENGINES.md, "Friction during a short impact").

    Fields (SI): ``velocity_m_s`` V; ``angle_deg`` θ from the normal, in [0, 90);
    ``friction`` μ ≥ 0; ``spin_rad_s`` ω0 (positive: forward rolling); ``tangential``
    ``rigid`` | ``mindlin`` | ``mindlin-deresiewicz`` (:data:`TANGENTIAL_MODELS`); ``shape``
    ``sphere`` (k² = 2R²/5) | ``disc`` (k² = R²/2: the 2D engines' circle with a disc's
    inertia; the 3D engines run only the sphere; the contact laws are the same for both); the
    ball's normal law as :class:`BallOnPlate` (``mass_kg``, ``stiffness``, ``exponent``,
    ``damping_s_per_m``, ``radius_m``, ``model``, ``nominal_restitution``; a nominal e sets
    b = α(e)/v_n at the normal velocity, any given b is then unused); the elastic constants of
    ball and plate for Mindlin's tangential stiffness (``youngs_modulus_pa``, ``poisson``,
    ``plate_youngs_modulus_pa`` — ``inf`` is a rigid plate — and ``plate_poisson``). The
    normal stiffness c is as given: the constants do not change it (:meth:`from_materials`
    derives it).
    """

    name: ClassVar[str] = "oblique"

    velocity_m_s: float = 2.0
    angle_deg: float = 45.0
    friction: float = 0.3
    spin_rad_s: float = 0.0
    tangential: str = "rigid"
    shape: str = "sphere"
    mass_kg: float = 0.1
    stiffness: float = PAPER_STIFFNESS
    exponent: float = 1.5
    damping_s_per_m: float = 0.1
    radius_m: float = PAPER_RADIUS_M
    model: str = "hunt-crossley"
    nominal_restitution: float | None = None
    youngs_modulus_pa: float = STEEL_YOUNG_PA
    poisson: float = STEEL_POISSON
    plate_youngs_modulus_pa: float = STEEL_YOUNG_PA
    plate_poisson: float = STEEL_POISSON

    def __post_init__(self) -> None:
        v = check.positive("velocity_m_s", self.velocity_m_s)
        a = check.finite("angle_deg", self.angle_deg)
        if not 0.0 <= a < 90.0:
            raise ValueError(f"angle_deg = {self.angle_deg!r}: must be in [0, 90) (degrees "
                             "from the plate normal)")
        if v * math.cos(math.radians(a)) < MIN_VELOCITY_M_S:
            raise ValueError(f"angle_deg = {self.angle_deg!r}: the normal velocity "
                             f"V·cos θ must be >= {MIN_VELOCITY_M_S:g} m/s")
        check.non_negative("friction", self.friction)
        check.finite("spin_rad_s", self.spin_rad_s)
        check.one_of("tangential", self.tangential, TANGENTIAL_MODELS)
        check.one_of("shape", self.shape, SHAPES)
        check_ball_contact(self)
        check.one_of("model", self.model, OBLIQUE_MODELS)
        check.positive("youngs_modulus_pa", self.youngs_modulus_pa)
        _poisson("poisson", self.poisson)
        pe = check._number("plate_youngs_modulus_pa", self.plate_youngs_modulus_pa)
        if not pe > 0.0 or math.isnan(pe):
            raise ValueError(f"plate_youngs_modulus_pa = {self.plate_youngs_modulus_pa!r}: "
                             "must be > 0 (inf: a rigid plate)")
        _poisson("plate_poisson", self.plate_poisson)
        check_contact_model(self)
        if self.tangential in COMPLIANT_MODELS and (self.exponent != 1.5
                                                    or self.model in LINEAR_MODELS):
            raise ValueError(f"tangential = {self.tangential!r}: must have the Hertz law "
                             f"(exponent 1.5, a hysteresis model; got exponent "
                             f"{self.exponent!r}, model {self.model!r}): k_t = 8·G*·√(R·x) is "
                             "Hertz geometry")

    # ------------------------------------------------------------------ constructors
    @classmethod
    def case(cls, name: str, **overrides: Any) -> Oblique:
        """The named case of :data:`CASES` (``kharaz2001``), with ``overrides`` on top."""
        check.one_of("case", name, tuple(CASES))
        return cls(**{**CASES[name], **CASE_POINTS.get(name, {}), **overrides})

    @classmethod
    def kharaz2001(cls, **overrides: Any) -> Oblique:
        """Kharaz, Gorham & Salman (2001), Chung & Ooi's inputs (:data:`CASES`)."""
        return cls.case("kharaz2001", **overrides)

    @classmethod
    def from_materials(cls, **fields: Any) -> Oblique:
        """An Oblique whose Hertz c is derived from the elastic constants of ball and plate
        (c = (4/3)·E*·√R, 1/E* = (1 − ν₁²)/E₁ + (1 − ν₂²)/E₂; a rigid plate drops its term)."""
        base = cls(**fields)
        c = hertz_stiffness(base.radius_m, base.youngs_modulus_pa, base.poisson, math.inf,
                            base.plate_youngs_modulus_pa, base.plate_poisson)
        return base.replace(stiffness=c, exponent=1.5)

    # ------------------------------------------------------------------ kinematics
    @property
    def normal_velocity_m_s(self) -> float:
        """v_n = V·cos θ."""
        return self.velocity_m_s * math.cos(math.radians(self.angle_deg))

    @property
    def tangential_velocity_m_s(self) -> float:
        """v_t = V·sin θ."""
        return self.velocity_m_s * math.sin(math.radians(self.angle_deg))

    @property
    def slip_m_s(self) -> float:
        """s0 = v_t − R·ω0, the contact point's incoming slip."""
        return self.tangential_velocity_m_s - self.radius_m * self.spin_rad_s

    @property
    def gyration_ratio(self) -> float:
        """k²/R² of the shape: 2/5 (sphere), 1/2 (disc)."""
        return GYRATION_RATIOS[self.shape]

    @property
    def spin_factor(self) -> float:
        """1 + R²/k²: 3.5 (sphere), 3 (disc); the slip s = v_t − R·ω changes this many times
        faster than v_t under a tangential force."""
        return 1.0 + 1.0 / self.gyration_ratio

    @property
    def moment_of_inertia_kg_m2(self) -> float:
        """I = m·k²: (2/5)·m·R² (sphere), (1/2)·m·R² (disc)."""
        return self.gyration_ratio * self.mass_kg * self.radius_m**2

    @property
    def shear_modulus_pa(self) -> float:
        """G* with 1/G* = (2 − ν₁)/G₁ + (2 − ν₂)/G₂, G = E/(2(1 + ν)) (Mindlin 1949); a rigid
        plate (E₂ = ∞) contributes nothing."""
        g1 = self.youngs_modulus_pa / (2.0 * (1.0 + self.poisson))
        inv = (2.0 - self.poisson) / g1
        if math.isfinite(self.plate_youngs_modulus_pa):
            g2 = self.plate_youngs_modulus_pa / (2.0 * (1.0 + self.plate_poisson))
            inv += (2.0 - self.plate_poisson) / g2
        return 1.0 / inv

    def normal_scenario(self, velocity_m_s: float | None = None) -> BallOnPlate:
        """The normal problem: a :class:`BallOnPlate` at the normal velocity v_n (or
        ``velocity_m_s``), with this ball's law."""
        return BallOnPlate(velocity_m_s=self.normal_velocity_m_s if velocity_m_s is None
                           else float(velocity_m_s),
                           mass_kg=self.mass_kg, stiffness=self.stiffness,
                           exponent=self.exponent, damping_s_per_m=self.damping_s_per_m,
                           radius_m=self.radius_m, model=self.model,
                           nominal_restitution=self.nominal_restitution)

    def penetration_problem(self, max_penetration_m: float) -> str:
        """Why a solution with this indentation is outside the model ("" if none)."""
        return self.normal_scenario().penetration_problem(max_penetration_m)
