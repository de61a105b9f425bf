"""Materials and the Hertz stiffness of a sphere, so "my ball" needs no hand calculation.

The packaged table ``reference/data/materials.toml`` gives, per material, Young's modulus E (Pa),
Poisson's ratio ν, density ρ (kg/m³), an indicative restitution range and a nominal
restitution e (one representative value at about 1–2 m/s inside that range), each with its
source (the file's header lists them). A ball of a material bounces at about its e: its
contact damping is set from e (:func:`ball_parameters` returns it as ``nominal_restitution``,
and the Hunt–Crossley model derives b = α(e)/V0 at each impact velocity).

Hertz contact of two elastic bodies (Johnson, Contact Mechanics, 1985, §4.2) gives
F = c·x^(3/2) with

    c = (4/3)·E*·√R*,   1/E* = (1 − ν₁²)/E₁ + (1 − ν₂²)/E₂,   1/R* = 1/R₁ + 1/R₂,

a plate being a sphere of radius R₂ = ∞; a ball of radius R has mass m = ρ·(4/3)·π·R³.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass
from functools import cache
from importlib import resources
from typing import Any

from impactbench.reference import validation as check
from impactbench.reference.scenarios import hertz_stiffness

HERTZ_EXPONENT = 1.5


@dataclass(frozen=True)
class Material:
    """One row of the materials table (SI)."""

    name: str
    description: str
    youngs_modulus_pa: float
    poisson: float
    density_kg_m3: float
    source: str
    restitution_range: tuple[float, float]
    restitution_source: str
    restitution: float | None = None
    """Nominal restitution e at about 1–2 m/s (inside ``restitution_range``); None: unknown."""


@cache
def materials() -> dict[str, Material]:
    """The packaged materials table, keyed by name (steel, aluminium, glass, …)."""
    text = resources.files("impactbench.reference").joinpath("data/materials.toml").read_text()
    return {name: Material(name=name, description=row["description"],
                           youngs_modulus_pa=float(row["youngs_modulus_pa"]),
                           poisson=float(row["poisson"]),
                           density_kg_m3=float(row["density_kg_m3"]), source=row["source"],
                           restitution_range=tuple(row["restitution_range"]),
                           restitution_source=row["restitution_source"],
                           restitution=float(row["restitution"]))
            for name, row in tomllib.loads(text).items()}


def material(name: str) -> Material:
    """The material called ``name``; a one-line error lists the valid names."""
    table = materials()
    check.one_of("material", name, tuple(table))
    return table[name]


def _elastic(young_pa: float, poisson: float, label: str) -> tuple[float, float]:
    e = check.positive(f"{label}youngs_modulus_pa", young_pa)
    nu = check.finite(f"{label}poisson", poisson)
    if not -1.0 < nu < 0.5:
        raise ValueError(f"{label}poisson = {poisson!r}: must be in (-1, 0.5)")
    return e, nu


def sphere_on_plate(radius_m: float, ball: Material, plate: Material) -> float:
    """Hertz c (N/m^1.5) of a sphere of radius R (m) on a flat massive plate."""
    r = check.positive("radius_m", radius_m)
    return hertz_stiffness(r, ball.youngs_modulus_pa, ball.poisson, math.inf,
                           plate.youngs_modulus_pa, plate.poisson)


def sphere_on_sphere(radius_1_m: float, material_1: Material, radius_2_m: float,
                     material_2: Material) -> float:
    """Hertz c (N/m^1.5) of two spheres of radii R₁, R₂ (m) in contact."""
    r1 = check.positive("radius_1_m", radius_1_m)
    r2 = check.positive("radius_2_m", radius_2_m)
    return hertz_stiffness(r1, material_1.youngs_modulus_pa, material_1.poisson, r2,
                           material_2.youngs_modulus_pa, material_2.poisson)


def sphere_mass_kg(radius_m: float, density_kg_m3: float) -> float:
    """m = ρ·(4/3)·π·R³ (kg)."""
    r = check.positive("radius_m", radius_m)
    return check.positive("density_kg_m3", density_kg_m3) * 4.0 / 3.0 * math.pi * r**3


def ball_parameters(radius_m: float, *, material_name: str | None = None,
                    youngs_modulus_pa: float | None = None, poisson: float | None = None,
                    mass_kg: float | None = None, plate_material: str = "steel"
                    ) -> dict[str, Any]:
    """BallOnPlate fields (mass_kg, stiffness, exponent, radius_m, nominal_restitution) of a
    ball on a plate.

    E and ν come from ``material_name``, overridden by ``youngs_modulus_pa``/``poisson``;
    without a material both must be given. The mass is ``mass_kg`` when given, else ρ·(4/3)πR³
    of the material (a ball without a material and without a mass is an error).
    ``nominal_restitution`` is the ball material's nominal e (None without a material): with it
    a BallOnPlate's damping is derived from e at each impact velocity, so the ball bounces at
    about e (the Hunt–Crossley model's k(3(1 − e)/2), e.g. 0.833 for e = 0.8).
    """
    mat = material(material_name) if material_name is not None else None
    if mat is None and (youngs_modulus_pa is None or poisson is None):
        missing = "poisson" if youngs_modulus_pa is not None else "youngs_modulus_pa"
        raise ValueError(f"{missing} = None: give a material, or both youngs_modulus_pa "
                         "and poisson")
    e, nu = _elastic(youngs_modulus_pa if youngs_modulus_pa is not None
                     else mat.youngs_modulus_pa,  # type: ignore[union-attr]
                     poisson if poisson is not None else mat.poisson,  # type: ignore[union-attr]
                     "")
    if mass_kg is None and mat is None:
        raise ValueError("mass_kg = None: without a material (density) give the ball's mass")
    r = check.positive("radius_m", radius_m)
    ball = Material("ball", "", e, nu, mat.density_kg_m3 if mat else math.nan, "", (0.0, 1.0),
                    "")
    m = mass_kg if mass_kg is not None else sphere_mass_kg(r, ball.density_kg_m3)
    return {"mass_kg": check.positive("mass_kg", m),
            "stiffness": sphere_on_plate(r, ball, material(plate_material)),
            "exponent": HERTZ_EXPONENT, "radius_m": r,
            "nominal_restitution": mat.restitution if mat is not None else None}
