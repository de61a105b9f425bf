"""Box2D 2.3 adapter against the reference solvers (real engine, no mocks).

Injected runs must reproduce the references. Native and default runs are rigid contacts with
Box2D's compiled-in 1 m/s restitution threshold: the checks assert what such a contact must do
(the max-mixed restitution above the threshold, none at or below it, momentum exchange).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import assert_escaped_after_whole_contact, rel, require_engine

require_engine("box2d")

from impactbench.engines.base import RunSettings, get_adapter  # noqa: E402
from impactbench.reference import hunt_crossley, metrics, two_dof  # noqa: E402
from impactbench.reference.record import Status  # noqa: E402
from impactbench.reference.scenarios import BallOnPlate, RigidFlexible  # noqa: E402

FLOAT32 = 1.2e-7
"""Box2D keeps velocities in float32: one float32 ulp (2⁻²³), 3× the largest measured error
of an exact rigid restitution (3.97e-8 for e = 0.6 and 0.8)."""

# Tolerances are about 3× the error measured on this machine (Box2D 2.3.10), each
# measurement in a comment.
INJECTED_BALL_TOL = {  # rel. error at dt = 1e-7 s; measured in the comments
    1.0: {"restitution": 3.5e-6,  # 1.17e-6
          "duration_s": 1.8e-4,  # 5.88e-5
          "peak_force_n": 3.2e-4,  # 1.07e-4
          "max_penetration_m": 1.3e-4},  # 4.19e-5
    5.0: {"restitution": 3.2e-7,  # 1.07e-7
          "duration_s": 1.1e-3,  # 3.53e-4 (a third of a step of the 776-step contact)
          "peak_force_n": 1.8e-3,  # 6.11e-4
          "max_penetration_m": 7.8e-4},  # 2.61e-4
}
INJECTED_RF_TOL = {  # rel. error at the default 1e-5 s; measured in the comments
    "linear": {"peak_force_n": 2.5e-4,  # 8.20e-5
               "pulse_width_s": 1.3e-4,  # 4.29e-5
               "impulse_ns": 1.9e-3},  # 6.19e-4
    "elastoplastic": {"peak_force_n": 5e-5,  # 1.66e-5
                      "pulse_width_s": 1.3e-4,  # 4.10e-5
                      "impulse_ns": 1.9e-3},  # 6.30e-4
}


@pytest.fixture(scope="module")
def adapter():
    return get_adapter("box2d")



def ball(adapter, velocity: float, mode: str, dt: float = 1e-6, **kw):
    rec = adapter.run(BallOnPlate(velocity_m_s=velocity), mode, RunSettings(timestep_s=dt, **kw))
    assert rec.status is Status.OK, rec.message
    return rec, metrics.compute(rec)


@pytest.mark.parametrize("velocity", [1.0, 5.0])
def test_injected_ball_reproduces_hunt_crossley(adapter, velocity: float) -> None:
    _, got = ball(adapter, velocity, "injected", dt=1e-7)
    ref = hunt_crossley.solve(BallOnPlate(velocity_m_s=velocity))
    for k, tol in INJECTED_BALL_TOL[velocity].items():
        assert rel(got[k], ref[k]) <= tol, (k, got[k], ref[k])


def test_native_ball_bounces_only_above_the_velocity_threshold(adapter) -> None:
    """Restitution e = k_ref(1 m/s) is applied above b2_velocityThreshold = 1 m/s only: the
    ball at exactly 1 m/s stops dead; at 5 m/s it leaves with e."""
    k_ref = hunt_crossley.solve(BallOnPlate(velocity_m_s=1.0))["restitution"]
    slow_rec, slow = ball(adapter, 1.0, "native")
    _, fast = ball(adapter, 5.0, "native")
    assert slow_rec.meta["build_constants"]["b2_velocityThreshold"] == 1.0
    assert "1 m/s" in slow_rec.meta["not_expressible"]
    assert slow["restitution"] == pytest.approx(0.0, abs=FLOAT32)  # measured exactly 0
    assert fast["restitution"] == pytest.approx(k_ref, rel=2e-8)  # measured 6.4e-9
    assert fast["impulse_ns"] == pytest.approx(0.1 * (1 + k_ref) * 5.0, rel=3e-8)  # 9.2e-9


def test_default_and_custom_modes(adapter) -> None:
    rec, got = ball(adapter, 5.0, "default")
    assert rec.meta["engine_defaults"]["restitution"] == 0.0
    assert got["restitution"] == pytest.approx(0.0, abs=FLOAT32)  # measured exactly 0
    # the plate's fixture has 0, neutral for the max Box2D takes: the pair has the user's value
    rec, got = ball(adapter, 2.0, "custom", params={"restitution": 0.6})
    assert got["restitution"] == pytest.approx(0.6, rel=FLOAT32)
    with pytest.raises(ValueError, match=r"params\.velocity_iterations"):
        adapter.run(BallOnPlate(), "custom", RunSettings(params={"velocity_iterations": 0}))


def test_tuned_mode(adapter) -> None:
    assert adapter.run(BallOnPlate(), "tuned").status is Status.UNSUPPORTED
    _, got = ball(adapter, 3.0, "tuned", tuned={"restitution": 0.8})
    assert got["restitution"] == pytest.approx(0.8, rel=FLOAT32)


@pytest.mark.parametrize("local,velocity", [("linear", 3.3), ("elastoplastic", 10.0)])
def test_injected_rigid_flexible_reproduces_the_reference(adapter, local, velocity) -> None:
    sc = RigidFlexible(velocity_m_s=velocity, local=local)
    rec = adapter.run(sc, "injected")
    got, ref = metrics.compute(rec), two_dof.solve(sc)
    assert rec.status is Status.OK, rec.message
    assert got["impacts"] == ref["impacts"]
    for k, tol in INJECTED_RF_TOL[local].items():
        assert rel(got[k], ref[k]) <= tol, (k, got[k], ref[k])


def test_native_rigid_flexible_is_elastic_momentum_exchange(adapter) -> None:
    """e = 1 between equal masses; body 2's distance-joint spring (f = √(k2/m2)/2π) swings it
    back after half a period π·√(m2/k2): two impacts, impulse 2·m1·v1."""
    sc = RigidFlexible(velocity_m_s=3.3)
    rec = adapter.run(sc, "native")
    got = metrics.compute(rec)
    assert rec.status is Status.OK, rec.message
    assert got["impacts"] == 2
    # measured 7.91e-4 and 1.81e-5 s (one 1e-5 s step): kept at 1.3× and 1.7×
    assert rel(got["impulse_ns"], 2 * sc.m1_kg * sc.velocity_m_s) <= 1e-3
    assert abs(got["pulse_width_s"] - math.pi * math.sqrt(sc.m2_kg / sc.k2_n_per_m)) <= 3e-5


def test_collapse_is_reported_and_runs_are_deterministic(adapter) -> None:
    sc = RigidFlexible(velocity_m_s=30.0, structure="softening")
    rec = adapter.run(sc, "injected")
    assert rec.status is Status.STRUCTURE_COLLAPSED
    assert_escaped_after_whole_contact(rec, sc)
    ball = BallOnPlate(velocity_m_s=2.0)
    a, b = adapter.run(ball, "injected"), adapter.run(ball, "injected")
    np.testing.assert_array_equal(a.normal_force_n, b.normal_force_n)


def test_default_and_custom_at_the_customary_step(adapter) -> None:
    """At the Box2D manual's step (1 / 60 s) a rigid contact
    still stops the ball and a custom restitution sends it back: the plate holds."""
    sc = BallOnPlate(velocity_m_s=5.0)
    custom = {"restitution": 0.9}
    for mode, params in (("default", None), ("custom", custom)):
        rec = adapter.run(sc, mode, RunSettings(timestep_s=1 / 60, params=params))
        assert rec.status is Status.OK, (mode, rec.message)
    assert metrics.compute(rec)["restitution"] == pytest.approx(0.9, rel=FLOAT32)  # measured 0
