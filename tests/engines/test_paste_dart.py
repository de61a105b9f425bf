"""The DART advice, checked through the snippet a user pastes.

``advise("dart", 1 ms)`` claims a restitution range over the phases of the step at each
speed. Here the numbers are read back out of the printed snippet alone (regexes on its text,
never ``advice.params``) and put into a plain dartpy script that uses no impactbench engine
code: a ``World`` with gravity 0 and the snippet's step, a static box skeleton (a 2 m box
welded to the world, top face z = 0) and a free-joint sphere skeleton of the paper's ball
(radius R, mass m, a solid sphere's inertia), both shape nodes colliding with the snippet's
restitution coefficients and friction 0, the ball started (2 + φ)·V·dt above the box moving at
−V, ``world.step()`` until the contact is over. Its rebound speed over V must land inside the
claimed range at every phase, and its extremes over the phases must be the claimed ones.
"""

from __future__ import annotations

import re

import numpy as np
import pytest
from conftest import require_engine
from impactbench.engines.advice_models import ENGINE_STEPS_S
from impactbench.reference.scenarios import BallOnPlate
from pasted_snippet import half_unit

from impactbench.advice_files import packaged_advice

SPEEDS = (1.0, 3.0)
"""Impact speeds (m/s)."""

TOL = 1e-9
"""|e_plain − e_claimed| allowed (dimensionless restitution; the minimum). Measured (DART
6.20.0, 1 ms, 1 and 3 m/s, 8 phases, the snippet's 10 significant digits): 1.6e-11 at both
speeds for the packaged advice (coefficient 0.8444739544156975, printed 0.8444739544); plain
script against the adapter's custom mode, ball coefficient 0.2, 0.5, 0.8123455, 0.882207,
0.8822072743, 0.9876545 (printed exactly): 0, bit for bit (a free joint against the adapter's
prismatic one, friction 0 against DART's default 1: a head-on impact has no tangential
impulse); 0.8123456789123 1.2e-11 and 0.98765432109876 1.2e-12, the printed digits. 3× the
worst is below the 1e-9 floor. Printed with 6 digits the coefficient cost up to 5.0e-7."""

MAX_STEPS = 1000
"""Steps after which the plain run gives up (the contact is over within 8 at 1 ms)."""


def _parse(snippet: str) -> dict[str, float]:
    """The snippet's numbers: the step (s) and the ball's and the plate's restitution
    coefficients (DART's pair value is their product)."""
    step = re.search(r"world\.setTimeStep\(\s*([-+0-9.eE]+)\s*\)", snippet)
    ball = re.search(r"ball_shape_node\b.*?setRestitutionCoeff\(\s*([-+0-9.eE]+)\s*\)", snippet)
    plate = re.search(r"plate_shape_node\b.*?setRestitutionCoeff\(\s*([-+0-9.eE]+)\s*\)",
                      snippet)
    assert step and ball and plate, snippet
    return {"dt": float(step.group(1)), "ball_restitution": float(ball.group(1)),
            "plate_restitution": float(plate.group(1))}


def _plain_restitution(s: dict[str, float], ball: BallOnPlate, speed: float,
                       phase: float) -> float:
    """Rebound speed / impact speed of the plain DART script (see the module)."""
    import dartpy as dart

    d = dart.dynamics
    radius, mass, dt = ball.radius_m, ball.mass_kg, s["dt"]
    world = dart.simulation.World()
    world.setGravity([0.0, 0.0, 0.0])
    world.setTimeStep(dt)

    plate = d.Skeleton("plate")
    joint, body = plate.createWeldJointAndBodyNodePair()
    offset = dart.math.Isometry3()
    offset.set_translation([0.0, 0.0, -1.0])  # top face z = 0
    joint.setTransformFromParentBodyNode(offset)
    plate_shape_node = body.createShapeNode(d.BoxShape([2.0, 2.0, 2.0]))
    plate_shape_node.createCollisionAspect()
    plate_shape_node.createDynamicsAspect().setFrictionCoeff(0.0)
    plate_shape_node.getDynamicsAspect().setRestitutionCoeff(s["plate_restitution"])
    world.addSkeleton(plate)

    skeleton = d.Skeleton("ball")
    _, ball_body = skeleton.createFreeJointAndBodyNodePair()
    ball_shape_node = ball_body.createShapeNode(d.SphereShape(radius))
    ball_shape_node.createCollisionAspect()
    ball_shape_node.createDynamicsAspect().setFrictionCoeff(0.0)
    ball_shape_node.getDynamicsAspect().setRestitutionCoeff(s["ball_restitution"])
    inertia = d.Inertia()
    inertia.setMass(mass)
    inertia.setMoment(np.eye(3) * 0.4 * mass * radius**2)
    ball_body.setInertia(inertia)
    world.addSkeleton(skeleton)
    # free joint: (rotation vector, translation), velocities likewise (no rotation here)
    skeleton.setPositions([0.0, 0.0, 0.0, 0.0, 0.0, radius + (2.0 + phase) * speed * dt])
    skeleton.setVelocities([0.0, 0.0, 0.0, 0.0, 0.0, -speed])

    tail = None
    for _ in range(MAX_STEPS):
        world.step()
        vz = float(ball_body.getLinearVelocity()[2])
        if tail is None:
            apart = world.getLastCollisionResult().getNumContacts() == 0
            if (vz > 0.0 and apart) or abs(vz) <= 1e-6 * speed:
                tail = 2  # moving away and out of contact (or at rest)
        else:
            tail -= 1
            if tail == 0:
                return vz / speed
    raise AssertionError(f"the plain ball's contact did not end in {MAX_STEPS} steps")


@pytest.fixture(scope="module")
def checked():
    """(advice, {speed: [plain e at each of the advice's phases]})."""
    require_engine("dart")
    advice = packaged_advice("dart", ENGINE_STEPS_S["dart"][0], SPEEDS)
    parsed, ball = _parse(advice.snippet), BallOnPlate()
    plain = {v: [_plain_restitution(parsed, ball, v, ph) for ph in advice.phases]
             for v in SPEEDS}
    return advice, plain


def test_the_snippet_holds_the_advice_step(checked) -> None:
    """The snippet's printed step is the advice's (s, to its 10 printed digits)."""
    advice, _ = checked
    dt = _parse(advice.snippet)["dt"]
    assert abs(dt - advice.timestep_s) <= half_unit(dt)
    assert advice.phases and len(advice.phases) >= 8


def test_every_phase_of_the_plain_script_lies_in_the_claimed_range(checked) -> None:
    """DART's contact is a rigid LCP impulse with the target v⁺ = −e_ball·e_plate·v⁻ (less
    ~2e-5 of constraint mixing): the plain script's rebound ratio at each phase lies in the
    advice's [min, max] for that speed."""
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
