"""Scenario defaults and validation."""

from __future__ import annotations

import math

import pytest
from impactbench.reference.scenarios import (
    PAPER_STIFFNESS,
    STEEL_DENSITY_KG_M3,
    STEEL_POISSON,
    STEEL_YOUNG_PA,
    BallOnPlate,
    RigidFlexible,
    hertz_stiffness,
)


def test_paper_ball_radius_and_hertz_constant() -> None:
    radius = (3 * 0.1 / (4 * math.pi * STEEL_DENSITY_KG_M3)) ** (1 / 3)
    assert radius == pytest.approx(BallOnPlate().radius_m, rel=2e-4)
    c = hertz_stiffness(radius, STEEL_YOUNG_PA, STEEL_POISSON)
    assert c == pytest.approx(PAPER_STIFFNESS, rel=2e-4)


@pytest.mark.parametrize(
    ("field", "value", "rule"),
    [
        ("velocity_m_s", 0.0, "> 0"),
        ("mass_kg", -1.0, "> 0"),
        ("stiffness", math.nan, "> 0"),
        ("exponent", math.inf, "> 0"),
        ("damping_s_per_m", -0.1, ">= 0"),
    ],
)
def test_ball_rejects_bad_values_naming_field(field: str, value: float, rule: str) -> None:
    with pytest.raises(ValueError) as err:
        BallOnPlate(**{field: value})
    msg = str(err.value)
    assert field in msg and rule in msg and "\n" not in msg


def test_ball_allows_elastic_limit() -> None:
    assert BallOnPlate(damping_s_per_m=0.0).alpha == 0.0


def test_rigid_flexible_defaults_are_the_papers() -> None:
    s = RigidFlexible()
    assert (s.m1_kg, s.m2_kg, s.k1_n_per_m, s.k2_n_per_m) == (10.0, 10.0, 1e5, 1e5)
    assert s.kt_n_per_m == pytest.approx(0.2 * s.k1_n_per_m)
    assert s.k1_failed_n_per_m == pytest.approx(0.5 * s.k1_n_per_m)
    assert (s.eps_s_m, s.beta_n_per_m3, s.fm_n) == (0.07, 3.0e6, 1.0e3)


def test_rigid_flexible_rejects_unknown_law_with_hint() -> None:
    with pytest.raises(ValueError, match="did you mean 'softening'"):
        RigidFlexible(structure="softenig")
    with pytest.raises(ValueError, match="m2_kg"):
        RigidFlexible(m2_kg=0.0)
    with pytest.raises(ValueError, match="must be a real number"):
        BallOnPlate(mass_kg="0.1")  # type: ignore[arg-type]


def test_laws_are_fresh_objects() -> None:
    s = RigidFlexible(local="elastoplastic")
    a, b = s.local_law(), s.local_law()
    a.update(0.1)
    assert a.force(0.05) != b.force(0.05)
