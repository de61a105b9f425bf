"""PhysX 5 (SAPIEN) adapter against the reference solvers (real engine, no mocks).

The injected runs must reproduce the references (only the time stepping differs); the native
and default runs must do what the engine's contact model says it does — an undamped spring of
the mapped stiffness, a rigid restitution, the 2 m/s bounce threshold — not numbers copied from
a run.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import assert_escaped_after_whole_contact, rel, require_engine

require_engine("sapien")

from impactbench.engines.base import RunSettings, get_adapter  # noqa: E402
from impactbench.reference import hunt_crossley, metrics, two_dof  # noqa: E402
from impactbench.reference.record import Status  # noqa: E402
from impactbench.reference.scenarios import BallOnPlate, RigidFlexible  # noqa: E402

RF_METRICS = ("peak_force_n", "pulse_width_s", "impulse_ns")


@pytest.fixture(scope="module")
def adapter():
    return get_adapter("sapien")



def ball(adapter, velocity: float, mode: str, dt: float = 1e-6, **kw):
    rec = adapter.run(BallOnPlate(velocity_m_s=velocity), mode, RunSettings(timestep_s=dt, **kw))
    assert rec.status is Status.OK, rec.message
    return rec, metrics.compute(rec)


@pytest.mark.parametrize("velocity", [1.0, 5.0])
def test_injected_ball_reproduces_hunt_crossley(adapter, velocity: float) -> None:
    _, got = ball(adapter, velocity, "injected", dt=1e-7)
    ref = hunt_crossley.solve(BallOnPlate(velocity_m_s=velocity))
    assert rel(got["restitution"], ref["restitution"]) <= 1e-4
    for k in ("duration_s", "peak_force_n", "max_penetration_m"):
        assert rel(got[k], ref[k]) <= 2e-3, (k, got[k], ref[k])


def test_native_ball_is_an_undamped_spring_matching_the_duration_at_v_ref(adapter) -> None:
    """PhysX's compliant contact K = −restitution: duration π·√(m/K) = the reference's at
    1 m/s, peak V0·√(K·m), and no damping (restitution ≈ 1: the contact model's error)."""
    rec, got = ball(adapter, 1.0, "native", dt=1e-7)
    stiffness = -rec.meta["restitution"]
    ref = hunt_crossley.solve(BallOnPlate(velocity_m_s=1.0))
    assert rel(got["duration_s"], ref["duration_s"]) <= 3e-3
    assert rel(got["duration_s"], math.pi * math.sqrt(0.1 / stiffness)) <= 3e-3
    assert rel(got["peak_force_n"], math.sqrt(stiffness * 0.1)) <= 3e-3
    assert got["restitution"] > 0.995 > ref["restitution"] + 0.05
    assert "damping" in rec.meta["not_expressible"]


def test_native_rigid_option_has_the_reference_restitution(adapter) -> None:
    k_ref = hunt_crossley.solve(BallOnPlate(velocity_m_s=1.0))["restitution"]
    rec, got = ball(adapter, 1.0, "native", options={"contact": "rigid"})
    assert rec.meta["bounce_threshold"] == 0.0
    assert got["restitution"] == pytest.approx(k_ref, rel=1e-5)  # float32 velocities
    assert "duration_s" in rec.meta["not_comparable"]


def test_default_mode_shows_the_bounce_threshold(adapter) -> None:
    """Out of the box: restitution 0.1 applied only above 2 m/s — the ball stops dead at 1 m/s."""
    rec1, slow = ball(adapter, 1.0, "default")
    _, fast = ball(adapter, 5.0, "default")
    defaults = rec1.meta["engine_defaults"]
    assert defaults["bounce_threshold"] == pytest.approx(2.0)
    assert slow["restitution"] == pytest.approx(0.0, abs=1e-6)
    assert fast["restitution"] == pytest.approx(defaults["restitution"], rel=1e-5)


def test_custom_parameters_reach_the_engine(adapter) -> None:
    rec, got = ball(adapter, 1.0, "custom",
                    params={"bounce_threshold": 0.0, "restitution": 0.5})
    assert got["restitution"] == pytest.approx(0.5, rel=1e-5)
    assert rec.meta["params"] == {"bounce_threshold": 0.0, "restitution": 0.5}
    with pytest.raises(ValueError, match=r"params\.enable_tgs"):
        adapter.run(BallOnPlate(), "custom", RunSettings(params={"enable_tgs": 1}))
    with pytest.raises(ValueError, match="valid keys"):
        adapter.run(BallOnPlate(), "custom", RunSettings(params={"erp": 0.2}))


def test_tuned_mode(adapter) -> None:
    assert adapter.run(BallOnPlate(), "tuned").status is Status.UNSUPPORTED
    _, got = ball(adapter, 1.0, "tuned", dt=1e-7, tuned={"restitution": -1e8})
    assert rel(got["duration_s"], math.pi * math.sqrt(0.1 / 1e8)) <= 3e-3


@pytest.mark.parametrize("local,velocity", [("linear", 3.3), ("elastoplastic", 10.0)])
def test_injected_rigid_flexible_reproduces_the_reference(adapter, local, velocity) -> None:
    sc = RigidFlexible(velocity_m_s=velocity, local=local)
    rec = adapter.run(sc, "injected")
    got, ref = metrics.compute(rec), two_dof.solve(sc)
    assert rec.status is Status.OK, rec.message
    assert got["impacts"] == ref["impacts"]
    for k in RF_METRICS:
        assert rel(got[k], ref[k]) <= 0.01, (k, got[k], ref[k])


def test_native_rigid_flexible_linear_law_is_the_compliant_contact(adapter) -> None:
    """Both materials −k1: PhysX's compliant contact is the linear local law exactly."""
    sc = RigidFlexible(velocity_m_s=3.3, structure="softening")
    rec = adapter.run(sc, "native")
    got, ref = metrics.compute(rec), two_dof.solve(sc)
    assert rec.status is Status.OK and rec.meta["contact"] == "compliant"
    assert got["impacts"] == ref["impacts"]
    for k in RF_METRICS:
        assert rel(got[k], ref[k]) <= 0.01, (k, got[k], ref[k])


def test_collapse_is_reported(adapter) -> None:
    sc = RigidFlexible(velocity_m_s=30.0, structure="softening")
    rec = adapter.run(sc, "injected")
    assert rec.status is Status.STRUCTURE_COLLAPSED
    assert np.all(np.isfinite(rec.displacement_2_m))
    assert_escaped_after_whole_contact(rec, sc)


def test_runs_are_deterministic(adapter) -> None:
    sc = BallOnPlate(velocity_m_s=2.0)
    a, b = adapter.run(sc, "native"), adapter.run(sc, "native")
    np.testing.assert_array_equal(a.normal_force_n, b.normal_force_n)
    np.testing.assert_array_equal(a.penetration_m, b.penetration_m)


def test_default_and_custom_at_the_customary_step(adapter) -> None:
    """At SAPIEN's own default scene step (0.01 s) a rigid contact
    still stops the ball and a custom restitution sends it back: the plate holds."""
    sc = BallOnPlate(velocity_m_s=5.0)
    custom = {"restitution": 0.9, "bounce_threshold": 0.0}
    for mode, params in (("default", None), ("custom", custom)):
        rec = adapter.run(sc, mode, RunSettings(timestep_s=0.01, params=params))
        assert rec.status is Status.OK, (mode, rec.message)
    assert metrics.compute(rec)["restitution"] == pytest.approx(0.9, rel=2e-3)
