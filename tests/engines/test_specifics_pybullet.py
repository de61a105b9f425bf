"""PyBullet's own checks (real engine, no mocks): what injection means in Bullet (its implicit
contact step, and the explicit replay that cancels it), no speculative contact, a rigid one-step
bounce, Bullet's friction given its own normal impulse. The shapes every adapter shares are in
test_conformance.py. Tolerances: the measurement beside each (pybullet 3.2.7); round-off-exact
results get 1e-9 to 1.5e-13.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import require_engine
from impactbench.engines.base import RunSettings, get_adapter
from impactbench.reference import hunt_crossley, metrics
from impactbench.reference.oblique import SPIN_FACTOR, Oblique
from impactbench.reference.record import Status
from impactbench.reference.scenarios import BallOnPlate

from impactbench.evaluate import compare


@pytest.fixture(scope="module")
def adapter():
    require_engine("pybullet")
    return get_adapter("pybullet")


def _ball(adapter, v: float, dt: float, mode: str = "injected", **kw):
    rec = adapter.run(BallOnPlate(velocity_m_s=v), mode, RunSettings(timestep_s=dt, **kw))
    assert rec.status is Status.OK, rec.message
    return rec


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


def test_native_at_ten_ms_is_a_one_step_bounce(adapter):
    """Native at 1e-2 s is a measured one-step bounce off the thick plate: ok, the peak force
    not resolved, a restitution between 0 and 1 (a status at this step: injected, in
    test_conformance.py)."""
    rec = adapter.run(BallOnPlate(velocity_m_s=5.0), "native", RunSettings(timestep_s=1e-2))
    assert rec.status is Status.OK and not metrics.resolved(rec)["peak_force_n"]
    assert 0.0 < metrics.compute(rec)["restitution"] < 1.0


def rigid_given(s: Oblique, e: float) -> tuple[float, float]:
    """(v_t', ω') of the rigid Coulomb theory with the engine's own normal restitution e."""
    v_n, v_t, w0, r = s.normal_velocity_m_s, s.tangential_velocity_m_s, s.spin_rad_s, \
        s.radius_m
    s0 = v_t - r * w0
    impulse = s.friction * (1.0 + e) * v_n
    if abs(s0) > impulse * SPIN_FACTOR:
        sign = math.copysign(1.0, s0)
        return v_t - impulse * sign, w0 + impulse * sign / (0.4 * r)
    v_out = v_t - s0 / SPIN_FACTOR
    return v_out, v_out / r


@pytest.mark.parametrize("angle", [20.0, 45.0, 60.0, 80.0])
def test_oblique_injected_friction_is_the_rigid_theory_given_bullets_normal_impulse(adapter,
                                                                                   angle):
    """Bullet's friction is the rigid theory exactly, given its own normal impulse (the
    implicit contact step's loss is all in the normal part); the errors against the
    reference are in test_conformance.py."""
    s = Oblique(angle_deg=angle)
    out, rec = compare("pybullet", s, "injected", RunSettings())
    assert out["status"] == "ok", out["message"]
    v_t, spin = rigid_given(s, -rec.penetration_rate_m_s[-1] / s.normal_velocity_m_s)
    assert rec.tangential_velocity_m_s[-1] == pytest.approx(v_t, rel=1e-9)
    assert rec.spin_rad_s[-1] == pytest.approx(spin, rel=1e-9)
