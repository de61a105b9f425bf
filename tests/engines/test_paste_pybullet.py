"""The PyBullet advice's snippet, pasted into a plain PyBullet script, gives the restitution
the advice claims.

``impactbench.advise`` searches PyBullet's contact settings at its customary 1/240 s step and
prints them as ``p.*`` calls (``setTimeStep``, ``setPhysicsEngineParameter``, ``changeDynamics``
on ``ball`` and ``plate``). Here those lines alone are executed (not ``advice.params``) in a
plain script — ``p.connect(p.DIRECT)`` through ``bullet_client``, a static box plate 1 m × 1 m ×
10 cm whose top face is z = 0, the paper's steel ball (radius and mass of ``BallOnPlate()``) as
a ``createMultiBody`` sphere, ``setGravity(0, 0, 0)``, zero friction, Bullet's defaults
otherwise — with no impactbench code, the ball started (2 + φ)·V·dt above the plate at −V for
each speed V (m/s) and each of the advice's 8 phases φ. The rebound speed over the impact
speed (:mod:`pasted_snippet`) must lie in the advice's claimed range per speed, and its min,
median and max over the phases must be the claimed ones.

Bullet's default ``linearDamping`` 0.04 stays on, as in any user's script: on a base-only
multibody it is a drag m·v·0.04·(1 + |v|) (N), which slows the ball by 3.3e-4 (1 m/s) to
6.7e-4 (3 m/s) of its speed per step of free flight. So the speeds are read at the free-flight
samples just outside the contact (as the suite reads them), not at launch or long after:
read at launch and 3 steps after, the advice's e would be 3.1e-3 lower at 3 m/s.
"""

from __future__ import annotations

import statistics

import pytest
from conftest import require_engine
from pasted_snippet import NUMBER, Run, assert_matches, read_all

SPEEDS = (1.0, 3.0)
"""Impact speeds (m/s)."""
TOL = 1e-9
"""e allowed outside what the plain script reads (the minimum for exact agreement). Measured
(PyBullet 3.2.7, 1/240 s, 1 and 3 m/s, 8 phases, the snippet's 10 significant digits): 0
outside the plain reading at both speeds for the packaged advice (``restitution=0.8476701389``,
no push-out; 3.7e-11 before the printed number's rounding is allowed for) and for the custom
runs ``restitution=0.9`` (bit for bit) and ``0.8123456789123`` (1.2e-11 before the allowance);
the compliant snippet of the last test (K 3.1e4 N/m, D 1.3 N·s/m) ≤ 7.8e-16 (the plate's box
differs from the suite's), K 31234.56789123, D 1.3456789123 0 (8.7e-12 before the allowance).
Read at launch and 3 steps after the contact instead (the drag, module doc) the advice's e
would be 1.6e-3 (1 m/s) and 3.1e-3 (3 m/s) lower. With 6 digits the snippet printed the
advice's restitution 0.8476701389 as 0.84767 and the plain e was 1.4e-7 off; before it printed
the step as ``1 / 240`` (it printed 0.00416667) the restitution snippets were ~1e-9 off, and
before it gave the plate infinite stiffness and zero damping the compliant one was 3.7e-4
off."""
CAP_S = 0.5
"""Time after launch before a plain run gives up (s): the suite's cap for an out-of-box
PyBullet ball (a ball still in contact then is ``max_time``, left out of the spread)."""
AFTER_STEPS = 3
"""Steps of free flight, moving away, that say the contact is over."""
SETTING = rf"(?:=|\()\s*(?P<n>{NUMBER})"
"""A number the snippet sets: a keyword's value or a call's first argument (not the link
index -1 of ``changeDynamics``)."""
BULLET_BREAKING_THRESHOLD_M = 0.02
"""Bullet's default ``contactBreakingThreshold`` (m). pybullet keeps it in one process-wide
global, which an earlier client in this process may have changed: a fresh user's script has
this value, so the plain script sets it back before the snippet runs."""


@pytest.fixture(scope="module")
def advice():
    """The packaged advice at PyBullet's customary 1/240 s (the file the report shows), its
    rows at 1 and 3 m/s."""
    require_engine("pybullet")
    from impactbench.engines.advice_models import ENGINE_STEPS_S

    from impactbench.advice_files import packaged_advice

    return packaged_advice("pybullet", ENGINE_STEPS_S["pybullet"][0], SPEEDS)


def plain_run(text: str, speed: float, phase: float) -> Run:
    """The snippet ``text``'s ``p.*`` lines in a plain PyBullet script: the ball
    (2 + phase)·V·dt above the plate at −V (m/s), stepped until it has flown free and away for
    a few steps (``pushed``: Bullet reported a normal force over the step)."""
    import pybullet
    from impactbench.reference.scenarios import BallOnPlate
    from pybullet_utils import bullet_client

    s = BallOnPlate()
    p = bullet_client.BulletClient(connection_mode=pybullet.DIRECT)
    try:
        p.setPhysicsEngineParameter(contactBreakingThreshold=BULLET_BREAKING_THRESHOLD_M)
        p.setGravity(0, 0, 0)
        box = p.createCollisionShape(p.GEOM_BOX, halfExtents=[0.5, 0.5, 0.05])
        plate = p.createMultiBody(0, box, basePosition=[0, 0, -0.05])
        ball = p.createMultiBody(s.mass_kg, p.createCollisionShape(p.GEOM_SPHERE,
                                                                   radius=s.radius_m))
        for body in (ball, plate):
            p.changeDynamics(body, -1, lateralFriction=0.0)
        for line in text.splitlines():
            if line.startswith("p."):
                exec(line, {"p": p, "ball": ball, "plate": plate})
        dt = p.getPhysicsEngineParameters()["fixedTimeStep"]
        p.resetBasePositionAndOrientation(ball, [0, 0, s.radius_m + (2 + phase) * speed * dt],
                                          [0, 0, 0, 1])
        p.resetBaseVelocity(ball, [0, 0, -speed], [0, 0, 0])
        vel, pushed, free = [], [], 0
        for _ in range(int(CAP_S / dt)):
            vel.append(p.getBaseVelocity(ball)[0][2])
            p.stepSimulation()
            pushed.append(sum(c[9] for c in p.getContactPoints(ball, plate)) > 0.0)
            free = free + 1 if any(pushed) and not pushed[-1] and vel[-1] > 0.0 else 0
            if free > AFTER_STEPS:
                break
        vel.append(p.getBaseVelocity(ball)[0][2])
        return Run(vel, pushed, speed, ended=free > AFTER_STEPS)
    finally:
        p.disconnect()


def test_the_snippet_sets_the_advised_step(advice) -> None:
    """The snippet's ``setTimeStep`` is the advice's step (s) to the bit."""
    import re

    step = re.search(r"p\.setTimeStep\(([^)]*)\)", advice.snippet).group(1)
    assert eval(step, {}) == advice.timestep_s
    assert [r["velocity_m_s"] for r in advice.per_speed] == list(SPEEDS)
    assert len(advice.phases) == 8


def test_the_pasted_snippet_gives_the_claimed_restitution(advice) -> None:
    """Per speed, every phase's plain e (dimensionless) lies in the claimed [min, max] and the
    min, median and max over the phases are the claimed ones, within :data:`TOL`."""
    readings = read_all(plain_run, advice.snippet, SPEEDS, advice.phases, SETTING)
    assert_matches(advice.per_speed, advice.phases, readings, TOL)


@pytest.mark.parametrize("params", [{"contactStiffness": 3.1e4, "contactDamping": 1.3}],
                         ids=["stiffness+damping"])
def test_the_soft_contact_snippet_gives_the_custom_restitution(params: dict) -> None:
    """The compliant model's snippet (a pair stiffness K = 3.1e4 N/m and damping D = 1.3
    N·s/m, a one- or two-step contact at 1/240 s) gives the ``custom`` mode's restitution at
    every phase: the snippet must also give the plate infinite stiffness and zero damping, or
    Bullet adds the plate's default 0.1 N·s/m to the pair (measured: e up to 3.7e-4 off)."""
    require_engine("pybullet")
    from impactbench.engines.advice_models import ENGINE_STEPS_S, snippet
    from impactbench.engines.base import RunSettings, get_adapter
    from impactbench.reference import metrics
    from impactbench.reference.scenarios import BallOnPlate

    from impactbench.phases import offsets

    dt, phases = ENGINE_STEPS_S["pybullet"][0], offsets()
    rows = []
    for v in SPEEDS:
        recs = [get_adapter("pybullet").run(BallOnPlate(velocity_m_s=v), "custom",
                                            RunSettings(timestep_s=dt, phase=ph,
                                                        params=params))
                for ph in phases]
        es = [metrics.compute(r)["restitution"] for r in recs]
        assert all(r.status == "ok" for r in recs), [r.status for r in recs]
        rows.append({"velocity_m_s": v, "restitution_min": min(es),
                     "restitution_max": max(es), "restitution": statistics.median(es),
                     "status": "ok"})
    text = snippet("pybullet", params, dt)
    readings = read_all(plain_run, text, SPEEDS, phases, SETTING)
    assert_matches(rows, phases, readings, TOL)
