"""MJX adapter on the real engine (jax on CPU): it is C MuJoCo's physics, so the main check is
that both give the same record for the same model (to round-off: XLA orders some sums
differently); plus reference checks whose tolerances are about 3× the errors measured on this
machine (mujoco-mjx 3.17.0, jax 0.10.2 CPU) — MJX's errors are C MuJoCo's, to 1e-14.

Each scan kind compiles once per process (2–5 s); the tests reuse a few kinds only.
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import require_engine

require_engine("mjx")
require_engine("mujoco")

from impactbench.engines.base import RunSettings, get_adapter  # noqa: E402
from impactbench.engines.mjx_adapter import MjxAdapter, ball_batch  # noqa: E402
from impactbench.reference import hunt_crossley, two_dof  # noqa: E402
from impactbench.reference.metrics import compute, relative_error  # noqa: E402
from impactbench.reference.record import Status  # noqa: E402
from impactbench.reference.scenarios import BallOnPlate, RigidFlexible  # noqa: E402

BALL = ("restitution", "duration_s", "peak_force_n")
RF = ("peak_force_n", "pulse_width_s", "impulse_ns")


@pytest.fixture(scope="module")
def mjx() -> MjxAdapter:
    adapter = get_adapter("mjx")
    assert isinstance(adapter, MjxAdapter)
    return adapter


def _errors(measured: dict, reference: dict, keys: tuple[str, ...]) -> dict[str, float]:
    return {k: abs(relative_error(measured[k], reference[k])) for k in keys}


@pytest.mark.parametrize("mode", ["native", "injected"])
def test_mjx_reproduces_c_mujoco(mjx: MjxAdapter, mode: str) -> None:
    """Same MJCF, same parameters: MJX (64-bit) and C MuJoCo give the same samples."""
    scenario = BallOnPlate(velocity_m_s=2.0)
    ours = mjx.run(scenario, mode)
    theirs = get_adapter("mujoco").run(scenario, mode)
    assert ours.status is Status.OK and theirs.status is Status.OK, (ours.message, theirs.message)
    assert len(ours) == len(theirs)
    # measured largest relative differences (native / injected): penetration 1.6e-15 /
    # 2.3e-14, force 1.5e-16 / 5.0e-15, velocity 1.2e-14 / 6.8e-15, zeros equal: a
    # round-off floor of 1e-12 (XLA's operation order follows the host CPU's vector units)
    for name in ("penetration_m", "normal_force_n", "velocity_1_m_s"):
        np.testing.assert_allclose(getattr(ours, name), getattr(theirs, name), rtol=1e-12,
                                   atol=0.0, err_msg=name)
    assert ours.meta["stepping"] == "lax.scan" and ours.meta["efc_diagA"] == theirs.meta[
        "efc_diagA"]


def test_injected_ball_reproduces_reference(mjx: MjxAdapter) -> None:
    scenario = BallOnPlate(velocity_m_s=5.0)
    rec = mjx.run(scenario, "injected", RunSettings(timestep_s=1e-7))
    assert rec.status is Status.OK, rec.message
    assert rec.meta["steps"] > rec.meta["chunk_steps"]  # the run spans several scans
    err = _errors(compute(rec), hunt_crossley.solve(scenario), BALL)
    assert err["restitution"] <= 3.3e-7, err  # measured 1.10e-7 (C MuJoCo: the same)
    assert err["duration_s"] <= 1.1e-3, err  # 3.53e-4: a third of a step (776 steps)
    assert err["peak_force_n"] <= 1.8e-3, err  # 6.10e-4


def test_native_rigid_flexible_matches_reference(mjx: MjxAdapter) -> None:
    scenario = RigidFlexible(velocity_m_s=3.3)
    rec = mjx.run(scenario, "native")
    assert rec.status is Status.OK, rec.message
    assert rec.meta["solref"] == [-scenario.k1_n_per_m * rec.meta["efc_diagA"], 0.0]
    ref = two_dof.solve(scenario)
    measured = compute(rec)
    assert measured["impacts"] == ref["impacts"]
    err = _errors(measured, ref, RF)
    assert err["peak_force_n"] <= 3.7e-5, err  # measured 1.23e-5 (C MuJoCo: the same)
    assert err["pulse_width_s"] <= 2.5e-5, err  # 8.27e-6
    assert err["impulse_ns"] <= 2.9e-5, err  # 9.76e-6


def test_injected_rigid_flexible_is_unsupported(mjx: MjxAdapter) -> None:
    rec = mjx.run(RigidFlexible(local="elastoplastic"), "injected")
    assert rec.status is Status.UNSUPPORTED and "memory" in rec.message


def test_default_and_custom_modes(mjx: MjxAdapter) -> None:
    """default: MuJoCo's own solref (0.02, 1) — a soft, heavily damped contact, recorded in
    the meta; custom with the native solref/solimp is the native run."""
    scenario = BallOnPlate(velocity_m_s=1.0)
    rec = mjx.run(scenario, "default", RunSettings(timestep_s=1e-5))
    assert rec.status is Status.OK, rec.message
    assert rec.meta["engine_defaults"]["solref"] == [0.02, 1.0]
    assert rec.meta["engine_defaults"]["solimp"] == [0.9, 0.95, 0.001, 0.5, 2.0]
    metrics = compute(rec)
    assert metrics["restitution"] < 0.5 and metrics["duration_s"] > 100 * hunt_crossley.solve(
        scenario)["duration_s"]
    native = mjx.run(scenario, "native")
    params = {"solref": native.meta["solref"], "solimp": native.meta["solimp"]}
    custom = mjx.run(scenario, "custom", RunSettings(params=params))
    assert custom.meta["solref"] == native.meta["solref"]
    np.testing.assert_array_equal(custom.normal_force_n, native.normal_force_n)
    with pytest.raises(ValueError, match="solref"):
        mjx.run(scenario, "custom", RunSettings(params={"solref": [1.0]}))


def test_batch_over_stiffness(mjx: MjxAdapter) -> None:
    """One vmapped call over three stiffnesses: restitution grows with stiffness at fixed
    damping (ζ ∝ 1/√K), and the middle world is the single run with that solref."""
    scenario = BallOnPlate(velocity_m_s=1.0)
    single = mjx.run(scenario, "native")
    s, d = single.meta["solref"]
    n = 2 * len(single)  # the softest world (duration × √3) separates within it too
    x, rate, force = ball_batch(scenario, [(s / 3, d), (s, d), (3 * s, d)], 1e-6, n)
    assert x.shape == (3, n)
    restitution = rate[:, -1] / scenario.velocity_m_s  # gap rate: upward after the bounce
    assert restitution[0] < restitution[1] < restitution[2]
    # measured bit-identical; the round-off floor of test_mjx_reproduces_c_mujoco
    np.testing.assert_allclose(force[1, :len(single)], single.normal_force_n, rtol=1e-12,
                               atol=0.0)
