"""pymunk adapter against the reference solvers (real engine, no mocks).

Tolerances are the issue's (injected ball at dt = 1e-7 s: restitution ≤ 0.5 %, duration and
peak force ≤ 1 %; injected rigid–flexible at the default 1e-5 s: peak, pulse width and
impulse ≤ 1 %). The native checks assert what a rigid contact must do (exact restitution at
the reference velocity, momentum exchange), not numbers copied from a run.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import assert_escaped_after_whole_contact, rel, require_engine

require_engine("pymunk")

from impactbench.engines.base import RunSettings, get_adapter  # noqa: E402
from impactbench.engines.common import NATIVE_REFERENCE_VELOCITY_M_S  # noqa: E402
from impactbench.reference import hunt_crossley, metrics, two_dof  # noqa: E402
from impactbench.reference.record import Status  # noqa: E402
from impactbench.reference.scenarios import BallOnPlate, RigidFlexible  # noqa: E402

RF_METRICS = ("peak_force_n", "pulse_width_s", "impulse_ns")


@pytest.fixture(scope="module")
def adapter():
    return get_adapter("pymunk")



def ball(adapter, velocity: float, mode: str = "injected", dt: float = 1e-7, **options):
    rec = adapter.run(BallOnPlate(velocity_m_s=velocity), mode,
                      RunSettings(timestep_s=dt, options=options))
    return rec, metrics.compute(rec)


@pytest.mark.parametrize("velocity", [1.0, 5.0])
def test_injected_ball_reproduces_hunt_crossley(adapter, velocity: float) -> None:
    rec, got = ball(adapter, velocity)
    ref = hunt_crossley.solve(BallOnPlate(velocity_m_s=velocity))
    assert rec.status is Status.OK, rec.message
    assert got["impacts"] == 1
    # measured at 1e-7 s (1 / 5 m/s): restitution 7.8e-8 / 1.1e-7, duration 5.9e-5 / 3.5e-4,
    # peak 1.1e-4 / 6.1e-4, max penetration 4.2e-5 / 2.6e-4
    assert rel(got["restitution"], ref["restitution"]) <= 3.3e-7
    assert rel(got["duration_s"], ref["duration_s"]) <= 1.1e-3
    assert rel(got["peak_force_n"], ref["peak_force_n"]) <= 1.8e-3
    assert rel(got["max_penetration_m"], ref["max_penetration_m"]) <= 8e-4
    # the record starts a few steps before touch and ends a few steps after release
    assert rec.penetration_m[0] < 0.0 and rec.penetration_m[-1] < 0.0
    assert len(rec) < 1.1 * ref["duration_s"] / 1e-7


def test_injected_ball_error_falls_with_timestep(adapter) -> None:
    ref = hunt_crossley.solve(BallOnPlate(velocity_m_s=5.0))
    errors = {k: [] for k in ("duration_s", "peak_force_n", "max_penetration_m")}
    for dt in (1e-6, 3e-7, 1e-7):
        _, got = ball(adapter, 5.0, dt=dt)
        for k in errors:
            errors[k].append(rel(got[k], ref[k]))
    for k, e in errors.items():
        assert e[0] > e[1] > e[2], (k, e)
        assert e[0] / e[2] > 5.0, (k, e)  # first order in dt: ~10× over a decade


def test_penalty_force_in_pre_solve_is_symplectic(adapter) -> None:
    """An elastic (b = 0) Hertz ball at ω·dt ≈ 0.04 (dt = 1e-6 s): explicit Euler (force from
    the state before the step) gains ~8 % of restitution; pymunk's drift–kick step with the
    force applied in pre_solve keeps it at 1 (measured within 5.9e-5)."""
    sc = BallOnPlate(velocity_m_s=5.0, damping_s_per_m=0.0)
    rec = adapter.run(sc, "injected", RunSettings(timestep_s=1e-6))
    got = metrics.compute(rec)
    assert rec.status is Status.OK
    assert abs(got["restitution"] - 1.0) < 1.8e-4


@pytest.mark.parametrize("velocity", [0.5, 5.0])
def test_restitution_injection_matches_hunt_crossley_restitution(adapter, velocity) -> None:
    rec, got = ball(adapter, velocity, dt=1e-6, injection="restitution")
    ref = hunt_crossley.solve(BallOnPlate(velocity_m_s=velocity))
    assert rec.status is Status.OK
    assert rel(got["restitution"], ref["restitution"]) <= 1e-15  # measured 1.1e-16, 0
    assert rec.meta["injection"] == "restitution"


def test_native_ball_is_a_rigid_contact_with_the_reference_restitution_at_v_ref(adapter):
    v_ref = NATIVE_REFERENCE_VELOCITY_M_S
    k_ref = hunt_crossley.solve(BallOnPlate(velocity_m_s=v_ref))["restitution"]
    k_fast = hunt_crossley.solve(BallOnPlate(velocity_m_s=5.0))["restitution"]
    for velocity in (v_ref, 5.0):
        rec, got = ball(adapter, velocity, mode="native", dt=1e-6)
        assert rec.status is Status.OK
        assert rec.meta["elasticity"] == pytest.approx(k_ref, rel=1e-12)
        assert rec.meta["reference_velocity_m_s"] == v_ref
        assert got["restitution"] == pytest.approx(k_ref, rel=1e-9)
        assert got["duration_s"] <= 2e-6 + 1e-15  # one impulse: no physical duration
        assert float(np.sum(rec.normal_force_n > 0)) == 1
        assert got["peak_force_n"] == pytest.approx(0.1 * (1 + k_ref) * velocity / 1e-6,
                                                    rel=1e-9)
    assert abs(k_fast - k_ref) > 0.1  # hence native is wrong away from v_ref


def test_native_reference_velocity_option(adapter) -> None:
    rec, got = ball(adapter, 5.0, mode="native", dt=1e-6, reference_velocity_m_s=5.0)
    k5 = hunt_crossley.solve(BallOnPlate(velocity_m_s=5.0))["restitution"]
    assert got["restitution"] == pytest.approx(k5, rel=1e-9)
    assert rec.meta["reference_velocity_m_s"] == 5.0


def test_tuned_mode(adapter) -> None:
    sc = BallOnPlate(velocity_m_s=2.0)
    assert adapter.run(sc, "tuned").status is Status.UNSUPPORTED
    rec = adapter.run(sc, "tuned", RunSettings(tuned={"elasticity": 0.8}))
    assert rec.status is Status.OK
    assert metrics.compute(rec)["restitution"] == pytest.approx(0.8, rel=1e-9)
    with pytest.raises(ValueError, match=r"tuned\.elasticity"):
        adapter.run(sc, "tuned", RunSettings(tuned={"restitution": 0.8}))


def test_gravity_option_runs_and_stays_close(adapter) -> None:
    sc = BallOnPlate(velocity_m_s=1.0, gravity_m_s2=9.81)
    rec = adapter.run(sc, "injected", RunSettings(timestep_s=1e-7))
    got = metrics.compute(rec)
    ref = hunt_crossley.solve(BallOnPlate(velocity_m_s=1.0))
    assert rec.status is Status.OK
    # m·g ≈ 1 N against a ~3.4 kN peak: measured 5.1e-4 (with the 1.1e-4 stepping error)
    assert rel(got["peak_force_n"], ref["peak_force_n"]) <= 1.5e-3


def test_huge_timestep_is_a_status_not_a_number(adapter) -> None:
    rec = adapter.run(BallOnPlate(velocity_m_s=5.0), "injected", RunSettings(timestep_s=1e-4))
    assert rec.status in (Status.TUNNELED, Status.DIVERGED), rec.status


def test_rigid_contact_at_ten_ms_keeps_its_restitution(adapter) -> None:
    """A rigid contact is one impulse at any step; the thick plate keeps a 5 cm step from
    carrying the ball through it, so native mode at 1e-2 s still bounces with e = elasticity."""
    rec = adapter.run(BallOnPlate(velocity_m_s=5.0), "native", RunSettings(timestep_s=1e-2))
    assert rec.status is Status.OK
    assert metrics.compute(rec)["restitution"] == pytest.approx(rec.meta["elasticity"],
                                                                rel=1e-12)
    assert not metrics.resolved(rec)["duration_s"]


# measured worst of peak, pulse width, impulse at 1e-5 s: 1.7e-7, 1.7e-7, 8.1e-8
@pytest.mark.parametrize("local,velocity,tol", [
    ("linear", 3.3, 5e-7),
    ("elastoplastic", 3.3, 5e-7),  # below yield at 3.3 m/s
    ("elastoplastic", 10.0, 2.5e-7),  # yields; re-contact 1.7 ms after the first contact ends
])
def test_injected_rigid_flexible_reproduces_the_reference(adapter, local: str,
                                                         velocity: float, tol: float) -> None:
    sc = RigidFlexible(velocity_m_s=velocity, local=local, structure="linear")
    rec = adapter.run(sc, "injected")
    assert rec.meta["timestep_s"] == 1e-5
    got = metrics.compute(rec)
    ref = two_dof.solve(sc)
    assert rec.status is Status.OK, rec.message
    assert got["impacts"] == ref["impacts"]
    for k in RF_METRICS:
        assert rel(got[k], ref[k]) <= tol, (k, got[k], ref[k])
    assert rec.displacement_2_m is not None and rec.mass_2_kg == sc.m2_kg


def test_injected_rigid_flexible_memory_law_and_softening(adapter) -> None:
    """The mutation law's irreversible failure, on the softening structure."""
    sc = RigidFlexible(velocity_m_s=3.3, local="mutation", structure="softening")
    got = metrics.compute(adapter.run(sc, "injected"))
    ref = two_dof.solve(sc)
    assert got["impacts"] == ref["impacts"]
    for k in RF_METRICS:  # measured: peak 3.5e-5, pulse width 5.9e-6, impulse 6.3e-6
        assert rel(got[k], ref[k]) <= 1.0e-4, (k, got[k], ref[k])


def test_injected_rigid_flexible_error_falls_with_timestep(adapter) -> None:
    sc = RigidFlexible(velocity_m_s=3.3, local="mutation")
    ref = two_dof.solve(sc)
    errors = []
    for dt in (1e-4, 3e-5, 1e-5):
        got = metrics.compute(adapter.run(sc, "injected", RunSettings(timestep_s=dt)))
        errors.append(max(rel(got[k], ref[k]) for k in RF_METRICS))
    assert errors[0] > errors[1] > errors[2], errors


def test_collapse_is_reported(adapter) -> None:
    sc = RigidFlexible(velocity_m_s=30.0, local="linear", structure="softening")
    assert two_dof.solve(sc)["status"] == "structure_collapsed"
    rec = adapter.run(sc, "injected")
    assert rec.status is Status.STRUCTURE_COLLAPSED
    assert np.all(np.isfinite(rec.displacement_2_m))
    assert_escaped_after_whole_contact(rec, sc)


def test_native_rigid_flexible_is_elastic_momentum_exchange(adapter) -> None:
    """e = 1 between equal masses: body 1 stops, body 2 swings out and back on its spring
    (half a period π·√(m2/k2)) and hands all momentum back: impulse 2·m1·v1, two impacts."""
    sc = RigidFlexible(velocity_m_s=3.3)
    dt = 1e-5
    rec = adapter.run(sc, "native", RunSettings(timestep_s=dt))
    got = metrics.compute(rec)
    assert rec.status is Status.OK
    assert rec.meta["elasticity"] == 1.0
    assert got["impacts"] == 2
    assert got["impulse_ns"] == pytest.approx(2 * sc.m1_kg * sc.velocity_m_s, rel=1e-6)
    half_period = math.pi * math.sqrt(sc.m2_kg / sc.k2_n_per_m)
    assert abs(got["pulse_width_s"] - half_period) <= 3 * dt
    assert rec.velocity_1_m_s[-1] == pytest.approx(-sc.velocity_m_s, rel=1e-6)


def test_runs_are_deterministic(adapter) -> None:
    sc = RigidFlexible(velocity_m_s=3.3, local="elastoplastic")
    a, b = adapter.run(sc, "injected"), adapter.run(sc, "injected")
    np.testing.assert_array_equal(a.normal_force_n, b.normal_force_n)
    np.testing.assert_array_equal(a.penetration_m, b.penetration_m)


def test_bad_options_raise_one_line_value_errors(adapter) -> None:
    sc = BallOnPlate()
    with pytest.raises(ValueError, match=r"options\.injection"):
        adapter.run(sc, "injected", RunSettings(options={"injection": "spring"}))
    with pytest.raises(ValueError, match=r"options\.iterations"):
        adapter.run(sc, "native", RunSettings(options={"iterations": 0}))
