"""MuJoCo adapter against the reference solvers (real MuJoCo, no mocks).

Tolerances are the issue's: injected ball at dt = 1e-7 s — restitution ≤ 0.5 %, duration and
peak force ≤ 1 %; rigid–flexible at v1 = 3.3 m/s — peak, pulse width and impulse ≤ 1 %.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import assert_escaped_after_whole_contact, require_engine

mujoco = require_engine("mujoco")

from impactbench.engines.base import RunSettings, get_adapter  # noqa: E402
from impactbench.engines.mujoco_adapter import (  # noqa: E402
    SOLIMP,
    MujocoAdapter,
    ball_mjcf,
    measured_diag_a,
)
from impactbench.reference import hunt_crossley, two_dof  # noqa: E402
from impactbench.reference.metrics import compute, relative_error  # noqa: E402
from impactbench.reference.record import Status  # noqa: E402
from impactbench.reference.scenarios import BallOnPlate, RigidFlexible  # noqa: E402

BALL = ("restitution", "duration_s", "peak_force_n")
RF = ("peak_force_n", "pulse_width_s", "impulse_ns")


@pytest.fixture(scope="module")
def mj() -> MujocoAdapter:
    adapter = get_adapter("mujoco")
    assert isinstance(adapter, MujocoAdapter)
    return adapter


def _errors(measured: dict, reference: dict, keys: tuple[str, ...]) -> dict[str, float]:
    return {k: abs(relative_error(measured[k], reference[k])) for k in keys}


@pytest.mark.parametrize("velocity", [1.0, 5.0])
def test_injected_ball_reproduces_reference(mj: MujocoAdapter, velocity: float) -> None:
    scenario = BallOnPlate(velocity_m_s=velocity)
    rec = mj.run(scenario, "injected", RunSettings(timestep_s=1e-7))
    assert rec.status is Status.OK, rec.message
    assert rec.mass_2_kg == math.inf and not rec.velocity_2_m_s.any()
    assert rec.penetration_m[0] < 0.0 < rec.normal_force_n.max()
    err = _errors(compute(rec), hunt_crossley.solve(scenario), BALL)
    # measured at 1e-7 s (1 / 5 m/s): restitution 7.8e-8 / 1.1e-7, duration 5.9e-5 / 3.5e-4,
    # peak 1.1e-4 / 6.1e-4 (Euler's first-order error on the force; it cancels in restitution)
    assert err["restitution"] <= 3.3e-7, err
    assert err["duration_s"] <= 1.1e-3, err
    assert err["peak_force_n"] <= 1.8e-3, err


def test_injected_error_falls_with_timestep(mj: MujocoAdapter) -> None:
    scenario = BallOnPlate(velocity_m_s=1.0)
    ref = hunt_crossley.solve(scenario)
    errors = []
    for dt in (1.6e-6, 4e-7, 1e-7):
        rec = mj.run(scenario, "injected", RunSettings(timestep_s=dt))
        assert rec.status is Status.OK, rec.message
        errors.append(_errors(compute(rec), ref, BALL))
    for key in BALL:
        seq = [e[key] for e in errors]
        assert seq[0] > seq[1] > seq[2], (key, seq)


@pytest.mark.parametrize("local", ["linear", "elastoplastic"])
def test_injected_rigid_flexible_reproduces_reference(mj: MujocoAdapter, local: str) -> None:
    scenario = RigidFlexible(velocity_m_s=3.3, local=local, structure="linear")
    rec = mj.run(scenario, "injected")
    assert rec.status is Status.OK, rec.message
    assert rec.mass_2_kg == scenario.m2_kg and rec.displacement_2_m is not None
    ref = two_dof.solve(scenario)
    measured = compute(rec)
    assert measured["impacts"] == ref["impacts"]
    err = _errors(measured, ref, RF)
    # measured (both laws, 1e-5 s): peak 1.2e-5, pulse width 8.3e-6, impulse 9.8e-6
    assert max(err.values()) <= 3.7e-5, err


# measured worst (peak force): elastoplastic at 20 m/s 3.4e-5, mutation at 3.3 m/s 6.2e-5
@pytest.mark.parametrize(("local", "velocity", "tol"), [("elastoplastic", 20.0, 1.0e-4),
                                                        ("mutation", 3.3, 1.8e-4)])
def test_injected_memory_laws_past_their_switch(mj: MujocoAdapter, local: str,
                                                velocity: float, tol: float) -> None:
    """Yielding (contact ends at the permanent set, contacts disabled at zero law force) and
    stiffness failure, both past the law's switch point."""
    scenario = RigidFlexible(velocity_m_s=velocity, local=local)
    rec = mj.run(scenario, "injected")
    assert rec.status is Status.OK, rec.message
    ref = two_dof.solve(scenario)
    measured = compute(rec)
    assert measured["impacts"] == ref["impacts"]
    assert max(_errors(measured, ref, RF).values()) <= tol
    if local == "elastoplastic":
        assert rec.penetration_m.max() > scenario.eps_s_m  # it did yield


def test_native_rigid_flexible_linear_matches_reference(mj: MujocoAdapter) -> None:
    scenario = RigidFlexible(velocity_m_s=3.3)
    rec = mj.run(scenario, "native")
    assert rec.status is Status.OK, rec.message
    assert rec.meta["stepping"] == "rollout"
    assert rec.meta["solref"] == [-scenario.k1_n_per_m * rec.meta["efc_diagA"], 0.0]
    err = _errors(compute(rec), two_dof.solve(scenario), RF)
    assert max(err.values()) <= 3.7e-5, err  # measured 1.2e-5 (peak), as injected


def test_softening_collapse_is_reported(mj: MujocoAdapter) -> None:
    scenario = RigidFlexible(velocity_m_s=30.0, structure="softening")
    assert two_dof.solve(scenario)["status"] == "structure_collapsed"
    for mode in ("injected", "native"):
        rec = mj.run(scenario, mode)
        assert rec.status is Status.STRUCTURE_COLLAPSED, (mode, rec.status, rec.message)
        assert np.all(np.isfinite(rec.displacement_2_m))
        assert_escaped_after_whole_contact(rec, scenario)


@pytest.mark.parametrize("v_ref", [1.0, 5.0])
def test_native_ball_matches_reference_at_reference_velocity(mj: MujocoAdapter,
                                                             v_ref: float) -> None:
    """The clipped spring–damper conversion, checked by a run at its reference velocity."""
    scenario = BallOnPlate(velocity_m_s=v_ref)
    settings = RunSettings(timestep_s=1e-7, options={"reference_velocity_m_s": v_ref})
    rec = mj.run(scenario, "native", settings)
    assert rec.status is Status.OK, rec.message
    assert rec.meta["reference_velocity_m_s"] == v_ref
    k, d, a = rec.meta["stiffness_n_per_m"], rec.meta["damping_ns_per_m"], rec.meta["efc_diagA"]
    assert rec.meta["solref"] == [-k * a, -d * a]
    err = _errors(compute(rec), hunt_crossley.solve(scenario), ("restitution", "duration_s"))
    # measured at 1e-7 s (V_ref = 1 / 5 m/s): restitution 4.1e-6 / 5.3e-5, duration 3.2e-5 /
    # 2.0e-4
    assert err["restitution"] <= 1.6e-4, err
    assert err["duration_s"] <= 6.0e-4, err
    # a linear contact's restitution does not follow Hunt–Crossley's fall with velocity:
    # measured equal to 1.3e-15 at three times the velocity
    other = mj.run(BallOnPlate(velocity_m_s=v_ref * 3.0), "native", settings)
    assert compute(other)["restitution"] == pytest.approx(compute(rec)["restitution"], rel=1e-14)


def test_contact_sensor_is_mj_contact_force_and_direct_solref_is_physical() -> None:
    """The recorded force (contact sensor) equals mj_contactForce's normal force, and a direct
    solref (−K·A, −D·A) with constant impedance gives F = K·x + D·ẋ."""
    scenario = BallOnPlate()
    model = mujoco.MjModel.from_xml_string(ball_mjcf(scenario, 1e-6))
    data = mujoco.MjData(model)
    a = measured_diag_a(model, data, (-1e-9,))
    assert a == pytest.approx(1.0 / scenario.mass_kg, rel=1e-9)
    k, d = 3.0e8, 250.0
    model.geom_solref[:] = (-k * a, -d * a)
    model.geom_solimp[:] = SOLIMP
    x, rate = 2.0e-5, 0.7
    data.qpos[0], data.qvel[0] = -x, -rate
    mujoco.mj_step(model, data)
    f6 = np.zeros(6)
    mujoco.mj_contactForce(model, data, 0, f6)
    assert data.sensordata[0] == pytest.approx(f6[0], rel=1e-12)
    assert f6[0] == pytest.approx(k * x + d * rate, rel=1e-6)


def test_huge_timestep_gives_status_not_number(mj: MujocoAdapter) -> None:
    for mode in ("native", "injected"):
        rec = mj.run(BallOnPlate(velocity_m_s=5.0), mode, RunSettings(timestep_s=1e-4))
        assert rec.status in (Status.TUNNELED, Status.DIVERGED), (mode, rec.status)


def test_tuned_mode(mj: MujocoAdapter) -> None:
    scenario = BallOnPlate(velocity_m_s=2.0)
    assert mj.run(scenario, "tuned").status is Status.UNSUPPORTED
    native = mj.run(scenario, "native")
    tuned = mj.run(scenario, "tuned", RunSettings(tuned={"solref": native.meta["solref"]}))
    assert tuned.status is Status.OK
    np.testing.assert_array_equal(tuned.normal_force_n, native.normal_force_n)
    with pytest.raises(ValueError, match=r"^tuned\.solref = "):
        mj.run(scenario, "tuned", RunSettings(tuned={"solref": [1.0]}))


def test_gravity_option_is_applied(mj: MujocoAdapter) -> None:
    """With gravity on, the ball leaves slower (gravity acts through the whole contact)."""
    off = compute(mj.run(BallOnPlate(velocity_m_s=0.5), "injected"))
    on = compute(mj.run(BallOnPlate(velocity_m_s=0.5, gravity_m_s2=9.81), "injected"))
    assert on["restitution"] < off["restitution"]
    # measured −4.6e-5: gravity's work over the contact against the impact energy
    assert on["restitution"] == pytest.approx(off["restitution"], rel=1.4e-4)
