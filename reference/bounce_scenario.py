"""The bounce-to-rest set-up: the ball on the plate dropped from rest, followed to rest.

The paper's steel ball (:class:`~impactbench.reference.scenarios.BallOnPlate`'s fields) is
released from rest with its lowest point ``height_m`` above a massive fixed plate, under
gravity ``gravity_m_s2`` acting throughout, and followed across its impacts and flights until
it rests on the plate or ``max_time_s`` has passed. Contact: Hunt–Crossley
F = c·xⁿ·(1 + b·ẋ) (x ≥ 0 the overlap, ẋ its rate), the same law as the head-on ball.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

from impactbench.reference import validation as check
from impactbench.reference.laws import HuntCrossley
from impactbench.reference.scenarios import (
    PAPER_RADIUS_M,
    PAPER_STIFFNESS,
    BallOnPlate,
    ScenarioFields,
    check_ball_contact,
)

STANDARD_GRAVITY_M_S2 = 9.80665
"""Standard gravity (m/s²; CGPM 1901), the default ``gravity_m_s2``."""

APEX_COUNT_M = 1e-3
"""A bounce counts (``bounces_above_1mm``) when its apex is above this (m)."""


@dataclass(frozen=True)
class Bounce(ScenarioFields):
    """The ball dropped from rest at ``height_m`` (its lowest point above the plate, m) under
    gravity ``gravity_m_s2`` (m/s², > 0), followed for at most ``max_time_s`` (s, longer than
    the fall √(2h/g)). The contact fields are the head-on ball's (:class:`BallOnPlate`)."""

    name: ClassVar[str] = "bounce"

    height_m: float = 0.2
    mass_kg: float = 0.1
    stiffness: float = PAPER_STIFFNESS
    exponent: float = 1.5
    damping_s_per_m: float = 0.1
    radius_m: float = PAPER_RADIUS_M
    gravity_m_s2: float = STANDARD_GRAVITY_M_S2
    max_time_s: float = 15.0

    def __post_init__(self) -> None:
        check.positive("height_m", self.height_m)
        check_ball_contact(self)
        check.positive("gravity_m_s2", self.gravity_m_s2)
        check.positive("max_time_s", self.max_time_s)
        if self.max_time_s <= self.fall_time_s:
            raise ValueError(f"max_time_s = {self.max_time_s!r}: must be longer than the fall "
                             f"to the first impact, √(2h/g) = {self.fall_time_s:.4g} s")

    @property
    def impact_velocity_m_s(self) -> float:
        """The first impact speed √(2·g·h) (m/s)."""
        return math.sqrt(2.0 * self.gravity_m_s2 * self.height_m)

    @property
    def fall_time_s(self) -> float:
        """The fall from rest to the first impact, √(2h/g) (s)."""
        return math.sqrt(2.0 * self.height_m / self.gravity_m_s2)

    @property
    def static_sink_m(self) -> float:
        """The overlap at rest, where c·xⁿ = m·g: x = (m·g/c)^(1/n) (m)."""
        return (self.mass_kg * self.gravity_m_s2 / self.stiffness) ** (1.0 / self.exponent)

    def law(self) -> HuntCrossley:
        return HuntCrossley(self.stiffness, self.exponent, self.damping_s_per_m)

    def ball(self) -> BallOnPlate:
        """The head-on ball of the first impact: the same body and contact at V0 = √(2gh),
        gravity on. Engines take its contact settings for every mode (native's spring–damper,
        the tuned file of the ball) and the injected law from it."""
        return BallOnPlate(velocity_m_s=self.impact_velocity_m_s, mass_kg=self.mass_kg,
                           stiffness=self.stiffness, exponent=self.exponent,
                           damping_s_per_m=self.damping_s_per_m, radius_m=self.radius_m,
                           gravity_m_s2=self.gravity_m_s2)
