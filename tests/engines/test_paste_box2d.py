"""The Box2D advice, checked through the snippet a user pastes.

``advise("box2d", 1/60 s)`` claims a restitution range over the phases of the step at each
speed. Here the numbers are read back out of the printed snippet alone (regexes on its text,
never ``advice.params``) and put into a plain pybox2d script that uses no impactbench engine
code: a ``b2World`` with gravity (0, 0), a static body with a 2 m box fixture (top edge y = 0,
restitution 0 as the snippet's comment says, friction 0) and a dynamic body with the snippet's
circle fixture (radius R, density m/(πR²) so its mass is the paper's ball's, friction 0), the
ball started (2 + φ)·V·dt above the box moving at −V, ``world.Step(dt, 8, 3)`` with the
snippet's numbers until the contact is over. Its rebound speed over V must land inside the
claimed range at every phase, and its extremes over the phases must be the claimed ones.
"""

from __future__ import annotations

import math
import re

import pytest
from conftest import require_engine
from impactbench.engines.advice_models import ENGINE_STEPS_S
from impactbench.reference.scenarios import BallOnPlate
from pasted_snippet import half_unit

from impactbench.advice_files import packaged_advice

SPEEDS = (1.0, 3.0)
"""Impact speeds (m/s): 1 m/s is Box2D's compiled-in ``b2_velocityThreshold``, at which no
restitution applies (the claim and the plain script both stop dead: e = 0), 3 m/s above it."""

TOL = 4.8e-7
"""|e_plain − e_claimed| allowed (dimensionless restitution): float32. Measured (Box2D 2.3.10,
1/60 s, 8 phases, the snippet's 10 significant digits): for the packaged advice (restitution
0.7906649908) 0 at 1, 2 and 3 m/s. Plain script against the adapter's custom mode (a static
circle plate where this script has a box: Box2D's 10 mm polygon skin moves the touch, not the
impulse), ball restitution 0.5, 0.7000005, 0.8123455, 0.882683502, 0.9, 0.9345675, 0.9876545,
0.8123456789123, 0.98765432109876: worst 1.6e-7 (0.7000005 at 3 m/s; 1.2e-7 for 0.9345675 and
0.8123456789123 at 2 m/s, 0 for the rest), all of it Box2D's float32 velocities (an ulp or
two of the rebound; the 10-digit print of the restitution and the step, 0.01666666667 s, are
below it); at 1 m/s both are exactly 0. TOL is 3× the worst. Printed with 6 digits the
restitution alone cost up to 5e-7."""

MAX_STEPS = 1000
"""Steps after which the plain run gives up (the contact is over within 7 at 1/60 s)."""


def _parse(snippet: str) -> dict[str, float]:
    """The snippet's numbers: the step (s), the velocity and position iterations and the
    ball fixture's restitution."""
    step = re.search(r"world\.Step\(\s*([-+0-9.eE]+)\s*,\s*(\d+)\s*,\s*(\d+)\s*\)", snippet)
    e = re.search(r"CreateCircleFixture\(.*?restitution\s*=\s*([-+0-9.eE]+)", snippet)
    assert step and e, snippet
    return {"dt": float(step.group(1)), "velocity_iterations": int(step.group(2)),
            "position_iterations": int(step.group(3)), "restitution": float(e.group(1))}


def _plain_restitution(s: dict[str, float], ball: BallOnPlate, speed: float,
                       phase: float) -> float:
    """Rebound speed / impact speed of the plain Box2D script (see the module)."""
    import Box2D

    radius, mass, dt = ball.radius_m, ball.mass_kg, s["dt"]
    iterations = (int(s["velocity_iterations"]), int(s["position_iterations"]))
    world = Box2D.b2World(gravity=(0.0, 0.0))
    plate = world.CreateStaticBody(position=(0.0, -1.0))  # top edge y = 0
    plate.CreatePolygonFixture(box=(1.0, 1.0), restitution=0.0, friction=0.0)
    body = world.CreateDynamicBody(position=(0.0, radius + (2.0 + phase) * speed * dt))
    body.CreateCircleFixture(radius=radius, density=mass / (math.pi * radius**2),
                             restitution=s["restitution"], friction=0.0)
    assert abs(body.mass - mass) <= 1e-6 * mass
    body.linearVelocity = (0.0, -speed)

    tail = None
    for _ in range(MAX_STEPS):
        world.Step(dt, *iterations)
        vy = float(body.linearVelocity[1])
        if tail is None:
            touching = any(edge.contact.touching for edge in body.contacts)
            if (vy > 0.0 and not touching) or abs(vy) <= 1e-6 * speed:
                tail = 2  # moving away and out of contact (or at rest on the plate)
        else:
            tail -= 1
            if tail == 0:
                return vy / speed
    raise AssertionError(f"the plain ball's contact did not end in {MAX_STEPS} steps")


@pytest.fixture(scope="module")
def checked():
    """(advice, {speed: [plain e at each of the advice's phases]})."""
    require_engine("box2d")
    advice = packaged_advice("box2d", ENGINE_STEPS_S["box2d"][0], SPEEDS)
    parsed, ball = _parse(advice.snippet), BallOnPlate()
    plain = {v: [_plain_restitution(parsed, ball, v, ph) for ph in advice.phases]
             for v in SPEEDS}
    return advice, plain


def test_the_snippet_holds_the_advice_step(checked) -> None:
    """The snippet's printed step is the advice's (s, to its 10 printed digits) with the Box2D
    manual's 8 velocity and 3 position iterations."""
    advice, _ = checked
    s = _parse(advice.snippet)
    assert abs(s["dt"] - advice.timestep_s) <= half_unit(s["dt"])
    assert (s["velocity_iterations"], s["position_iterations"]) == (8, 3)
    assert advice.phases and len(advice.phases) >= 8


def test_every_phase_of_the_plain_script_lies_in_the_claimed_range(checked) -> None:
    """Box2D's contact is a rigid impulse with the target v⁺ = −max(e_ball, e_plate)·v⁻,
    applied only above the 1 m/s velocity threshold: the plain script's rebound ratio at each
    phase lies in the advice's [min, max] for that speed."""
    advice, plain = checked
    for row in advice.per_speed:
        lo, hi = row["restitution_min"], row["restitution_max"]
        for phase, e in zip(advice.phases, plain[row["velocity_m_s"]], strict=True):
            assert lo - TOL <= e <= hi + TOL, (row["velocity_m_s"], phase, e, lo, hi)


def test_the_plain_extremes_over_phases_are_the_claimed_ones(checked) -> None:
    """The smallest and largest restitution over the phases (dimensionless) of the plain
    script are the advice's ``restitution_min`` and ``restitution_max``."""
    advice, plain = checked
    for row in advice.per_speed:
        es = plain[row["velocity_m_s"]]
        assert abs(min(es) - row["restitution_min"]) <= TOL, (row, es)
        assert abs(max(es) - row["restitution_max"]) <= TOL, (row, es)
