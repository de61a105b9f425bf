"""PyBullet adapter against the reference solvers (real engine, no mocks)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import assert_escaped_after_whole_contact, require_engine

require_engine("pybullet")

from impactbench.engines.base import RunSettings, get_adapter  # noqa: E402
from impactbench.engines.common import native_ball_spring_damper  # noqa: E402
from impactbench.reference import hunt_crossley, metrics, two_dof  # noqa: E402
from impactbench.reference.record import Status  # noqa: E402
from impactbench.reference.scenarios import BallOnPlate, RigidFlexible  # noqa: E402

RF_METRICS = ("peak_force_n", "pulse_width_s", "impulse_ns")


@pytest.fixture(scope="module")
def adapter():
    return get_adapter("pybullet")


def _errors(got: dict, ref: dict, keys) -> dict[str, float]:
    return {k: abs(metrics.relative_error(got[k], ref[k])) for k in keys}


def _ball(adapter, v: float, dt: float, mode: str = "injected", **kw):
    rec = adapter.run(BallOnPlate(velocity_m_s=v), mode, RunSettings(timestep_s=dt, **kw))
    assert rec.status is Status.OK, rec.message
    return rec


@pytest.mark.parametrize("v", [1.0, 5.0])
def test_injected_ball_reproduces_hunt_crossley(adapter, v):
    rec = _ball(adapter, v, 1e-7)
    err = _errors(metrics.compute(rec), hunt_crossley.solve(BallOnPlate(velocity_m_s=v)),
                  ("restitution", "duration_s", "peak_force_n"))
    # measured at 1e-7 s (Bullet's implicit contact step, 1 / 5 m/s): restitution 3.5e-3 /
    # 4.3e-3, duration 8.5e-4 / 1.2e-3, peak 1.9e-3 / 2.0e-3
    assert err["restitution"] <= 0.013, err
    assert err["duration_s"] <= 0.0035, err
    assert err["peak_force_n"] <= 0.006, err
    assert rec.meta["engine"] == "pybullet" and rec.meta["injection"] == "secant"


def test_injected_force_is_bullets_implicit_contact_step(adapter):
    """Injection is the law through Bullet's own contact integration: the recorded force is
    what Bullet's solver applied, the secant spring–damper scheduled from the start state
    (K = c·x_k^(n−1), D = c·b·x_k^n) evaluated at the end of the step (backward Euler),
    F_k = K·x_{k+1} + D·ẋ_{k+1} — measured to 4.9e-14 of the peak."""
    s = BallOnPlate(velocity_m_s=5.0)
    rec = _ball(adapter, 5.0, 1e-7)
    c, n, b = s.stiffness, s.exponent, s.damping_s_per_m
    x, v, f = rec.penetration_m, rec.penetration_rate_m_s, rec.normal_force_n
    i = np.flatnonzero(f[:-1] > 0.0)
    want = c * x[i] ** (n - 1.0) * x[i + 1] + c * b * x[i] ** n * v[i + 1]
    assert i.size > 500
    assert np.max(np.abs(f[i] - want)) <= 1.5e-13 * np.max(f)


def test_explicit_replay_force_is_the_law_at_the_start_state(adapter):
    """``injection = "explicit"`` replays the law's force at the start-of-step state, sample by
    sample, except the exit step (it cancels Bullet's implicit step)."""
    s = BallOnPlate(velocity_m_s=5.0)
    rec = _ball(adapter, 5.0, 1e-7, options={"injection": "explicit"})
    law = s.law()
    inside = rec.normal_force_n > 0.0
    want = [law.force(x, v) for x, v in zip(rec.penetration_m[inside],
                                            rec.penetration_rate_m_s[inside], strict=True)]
    got = rec.normal_force_n[inside]
    worst = max(abs(g - w) for g, w in zip(got, want, strict=True))
    assert worst <= 1e-6 * max(want)
    # the ball starts in free flight and leaves the overlap before the record ends
    assert rec.normal_force_n[0] == 0.0 and rec.penetration_m[0] < 0.0
    assert rec.penetration_m[-1] <= 0.0 and rec.penetration_rate_m_s[-1] < 0.0


def test_injected_ball_error_falls_with_timestep(adapter):
    v = 5.0
    ref = hunt_crossley.solve(BallOnPlate(velocity_m_s=v))
    errs = []
    for dt in (1e-6, 3e-7, 1e-7):
        got = metrics.compute(_ball(adapter, v, dt))
        errs.append(_errors(got, ref, ("duration_s", "peak_force_n", "restitution")))
    for key in ("duration_s", "peak_force_n", "restitution"):
        seq = [e[key] for e in errs]
        assert seq[0] > seq[1] > seq[2], (key, seq)


def test_bullets_implicit_step_is_what_injection_measures(adapter):
    """Issue 16: injected mode keeps Bullet's implicit contact step, which loses restitution
    like exp(−π·ω·dt/2) (measured −4.17e-2 at 5 m/s, 1e-6 s); the explicit replay cancels it
    (−1.76e-4), so the difference is Bullet's step, not its contact model."""
    ref = hunt_crossley.solve(BallOnPlate(velocity_m_s=5.0))
    injected = metrics.compute(_ball(adapter, 5.0, 1e-6))
    replay = metrics.compute(_ball(adapter, 5.0, 1e-6, options={"injection": "explicit"}))
    assert metrics.relative_error(injected["restitution"], ref["restitution"]) == \
        pytest.approx(-4.17e-2, rel=0.05)
    assert abs(metrics.relative_error(replay["restitution"], ref["restitution"])) < 5.3e-4


@pytest.mark.parametrize("v", [1.0, 5.0])
def test_native_ball_is_the_mapped_clipped_spring_damper(adapter, v):
    s = BallOnPlate(velocity_m_s=v)
    rec = _ball(adapter, v, 1e-7, mode="native")
    sd = native_ball_spring_damper(s)
    got = metrics.compute(rec)
    assert rec.meta["contact_stiffness"] == pytest.approx(sd.stiffness_n_per_m, rel=1e-12)
    assert rec.meta["contact_damping"] == pytest.approx(sd.damping_ns_per_m, rel=1e-12)
    assert rec.meta["reference_velocity_m_s"] == 1.0
    # Bullet's backward-Euler spring–damper at ω·dt ≈ 3e-3: measured restitution 4.55e-3,
    # duration 9.0e-4 against the mapped spring–damper (the same at 1 and 5 m/s)
    assert abs(metrics.relative_error(got["restitution"], sd.restitution(s.mass_kg))) <= 0.0065
    assert abs(metrics.relative_error(got["duration_s"], sd.duration_s(s.mass_kg))) <= 0.0027
    if v == 1.0:  # at the reference velocity it matches the Hunt–Crossley reference
        ref = hunt_crossley.solve(s)
        err = _errors(got, ref, ("restitution", "duration_s"))
        assert err["restitution"] <= 0.0065 and err["duration_s"] <= 0.0027, err


@pytest.mark.parametrize("mode", ["native", "injected"])
def test_no_speculative_contact_before_touch(adapter, mode):
    """contactBreakingThreshold is tiny: no force (no braking) while the ball is still above
    the plate, and the first force sample comes with a positive penetration."""
    rec = _ball(adapter, 5.0, 1e-7, mode=mode)
    first = int((rec.normal_force_n > 0.0).argmax())
    assert first >= 2
    assert all(rec.penetration_m[:first] < 0.0)
    assert rec.penetration_m[first] > 0.0
    assert all(rec.velocity_1_m_s[:first + 1] == 5.0)


def test_tuned_needs_parameters_and_uses_them(adapter):
    s = BallOnPlate(velocity_m_s=1.0)
    assert adapter.run(s, "tuned").status is Status.UNSUPPORTED
    rec = adapter.run(s, "tuned", RunSettings(timestep_s=1e-6, tuned={
        "contact_stiffness": 5e7, "contact_damping": 0.0}))
    assert rec.status is Status.OK
    # undamped: duration π·√(m/K) and restitution near 1 (backward Euler loses a little)
    got = metrics.compute(rec)
    # measured 7.0e-3 (backward Euler at ω·dt = 0.022)
    assert got["duration_s"] == pytest.approx(math.pi * math.sqrt(0.1 / 5e7), rel=0.01)
    assert 0.95 < got["restitution"] < 1.0
    with pytest.raises(ValueError, match=r"tuned\.contact_stiffness"):
        adapter.run(s, "tuned", RunSettings(tuned={"contact_stiffness": -1.0}))


def test_bad_injection_option_is_a_value_error(adapter):
    with pytest.raises(ValueError, match="injection"):
        adapter.run(BallOnPlate(), "injected", RunSettings(options={"injection": "magic"}))


def test_gravity_option_runs(adapter):
    s = BallOnPlate(velocity_m_s=1.0, gravity_m_s2=9.81)
    rec = adapter.run(s, "injected", RunSettings(timestep_s=1e-7))
    assert rec.status is Status.OK
    got = metrics.compute(rec)
    ref = hunt_crossley.solve(s)  # gravity's work over 100 µs is ~1e-6 of the energy
    # measured 3.5e-3 (Bullet's implicit step; the same as without gravity)
    assert abs(metrics.relative_error(got["restitution"], ref["restitution"])) <= 0.011


# Bullet's implicit contact is unconditionally stable (injected mode keeps it): a status needs
# a step that crosses the plate in one go, or one beyond the explicit structural spring's
# limit ω2·dt = 2; at 1e-4 s the injected ball is over-damped but finite (restitution 0.36)
@pytest.mark.parametrize(("mode", "dt_ball", "dt_rf"), [
    ("injected", 1e-2, 3e-2),
    # native at 1e-2 s is a measured one-step bounce off the thick plate
    ("native", 1e-2, 3e-2),
])
def test_huge_timestep_is_a_status_not_a_number(adapter, mode, dt_ball, dt_rf):
    rec = adapter.run(BallOnPlate(velocity_m_s=5.0), mode, RunSettings(timestep_s=dt_ball))
    if mode == "native":
        assert rec.status is Status.OK and not metrics.resolved(rec)["peak_force_n"]
        assert 0.0 < metrics.compute(rec)["restitution"] < 1.0
    else:
        assert rec.status in (Status.TUNNELED, Status.DIVERGED), rec.status
    rec = adapter.run(RigidFlexible(velocity_m_s=3.3), mode, RunSettings(timestep_s=dt_rf))
    assert rec.status in (Status.TUNNELED, Status.DIVERGED), rec.status


@pytest.mark.parametrize("local", ["linear", "elastoplastic"])
def test_injected_rigid_flexible_reproduces_two_dof(adapter, local):
    s = RigidFlexible(velocity_m_s=3.3, local=local, structure="linear")
    rec = adapter.run(s, "injected")
    assert rec.status is Status.OK, rec.message
    got, ref = metrics.compute(rec), two_dof.solve(s)
    assert got["impacts"] == ref["impacts"]
    err = _errors(got, ref, RF_METRICS)
    # measured (both laws, 1e-5 s): peak 1.06e-3, pulse width 3.9e-4, impulse 6.6e-4
    assert max(err.values()) <= 0.0032, err
    assert rec.mass_2_kg == s.m2_kg and rec.displacement_2_m is not None


@pytest.mark.parametrize(("v", "local", "structure"), [
    (10.0, "elastoplastic", "linear"),   # yields: permanent set, memory
    (10.0, "mutation", "softening"),
])
def test_injected_local_laws_with_memory(adapter, v, local, structure):
    s = RigidFlexible(velocity_m_s=v, local=local, structure=structure)
    rec = adapter.run(s, "injected")
    got, ref = metrics.compute(rec), two_dof.solve(s)
    assert rec.status is Status.OK and ref["status"] == "ok"
    assert got["impacts"] == ref["impacts"]
    # measured worst: elastoplastic 4.8e-4 (impulse), mutation/softening 7.6e-4 (peak)
    assert max(_errors(got, ref, RF_METRICS).values()) <= 0.0023
    if local == "elastoplastic":
        assert got["max_penetration_m"] > s.eps_s_m  # the law really yielded


def test_softening_collapse_is_reported(adapter):
    s = RigidFlexible(velocity_m_s=20.0, structure="softening")
    assert two_dof.solve(s)["status"] == "structure_collapsed"
    rec = adapter.run(s, "injected")
    assert rec.status is Status.STRUCTURE_COLLAPSED
    assert all(math.isfinite(x) for x in rec.displacement_2_m)
    assert_escaped_after_whole_contact(rec, s)


def test_native_linear_rigid_flexible(adapter):
    s = RigidFlexible(velocity_m_s=3.3)
    rec = adapter.run(s, "native")
    assert rec.status is Status.OK
    assert rec.meta["contact_stiffness"] == s.k1_n_per_m and rec.meta["contact_damping"] == 0
    got, ref = metrics.compute(rec), two_dof.solve(s)
    assert got["impacts"] == ref["impacts"]
    # measured worst 1.06e-3 (peak), the same as injected: a linear law is Bullet's own
    assert max(_errors(got, ref, RF_METRICS).values()) <= 0.0032


def test_injected_rigid_flexible_error_falls_with_timestep(adapter):
    s = RigidFlexible(velocity_m_s=3.3)
    ref = two_dof.solve(s)
    errs = [_errors(metrics.compute(adapter.run(s, "injected", RunSettings(timestep_s=dt))),
                    ref, RF_METRICS) for dt in (1e-4, 3e-5, 1e-5)]
    for key in RF_METRICS:
        seq = [e[key] for e in errs]
        assert seq[0] > seq[1] > seq[2], (key, seq)
