"""engines.common: the clipped spring–damper conversion, recorder and classification."""

from __future__ import annotations

import math

import numpy as np
import pytest
from impactbench.engines.common import (
    Recorder,
    SpringDamper,
    classify,
    clipped_restitution,
    spring_damper_matching,
)
from impactbench.reference.record import Status
from scipy.integrate import solve_ivp


def simulate_clipped(sd: SpringDamper, m: float, v0: float) -> tuple[float, float]:
    """Independent ODE of m·ẍ = −max(0, k·x + d·ẋ): (duration, restitution)."""

    def rhs(_t, y):
        return [y[1], -max(0.0, sd.stiffness_n_per_m * y[0] + sd.damping_ns_per_m * y[1]) / m]

    def release(_t, y):
        return sd.stiffness_n_per_m * y[0] + sd.damping_ns_per_m * y[1]

    release.terminal, release.direction = True, -1
    sol = solve_ivp(rhs, (0, 1.0), [0.0, v0], method="DOP853", rtol=1e-12, atol=1e-15,
                    events=release, first_step=1e-9)
    return float(sol.t_events[0][0]), -float(sol.y_events[0][0][1]) / v0


@pytest.mark.parametrize("restitution", [0.999, 0.9, 0.75, 0.4])
def test_matching_reproduces_targets_in_an_ode(restitution: float) -> None:
    m, duration = 0.1, 1e-4
    sd = spring_damper_matching(m, restitution, duration)
    t_end, e = simulate_clipped(sd, m, v0=2.0)
    assert t_end == pytest.approx(duration, rel=1e-8)
    assert e == pytest.approx(restitution, rel=1e-8)


def test_clipped_restitution_is_above_unclipped_and_monotone() -> None:
    """Letting go early skips the adhesive tail that would pull the body back: e rises."""
    zetas = np.linspace(0.01, 0.6, 30)
    e = [clipped_restitution(z) for z in zetas]
    assert all(np.diff(e) < 0)
    for z, ez in zip(zetas, e, strict=True):
        assert ez > math.exp(-z * math.pi / math.sqrt(1 - z * z))


def test_matching_rejects_impossible_restitution() -> None:
    with pytest.raises(ValueError, match="restitution"):
        spring_damper_matching(0.1, 1.5, 1e-4)


def test_recorder_grows_and_classify_orders_statuses() -> None:
    r = Recorder()
    for i in range(100):
        r.append(i * 1e-3, 0.0, 1.0, 1.0 if 10 < i < 20 else 0.0, 1.0)
    rec = r.record(mass_1_kg=1.0)
    assert len(rec) == 100 and rec.time_s[-1] == pytest.approx(0.099)
    assert classify(rec, initial_kinetic_j=1.0, final_kinetic_j=1.0).status is Status.OK
    assert classify(rec, initial_kinetic_j=1.0, final_kinetic_j=1.02).status is Status.DIVERGED
    assert classify(rec, initial_kinetic_j=1.0, final_kinetic_j=1.0,
                    tunneled=True).status is Status.TUNNELED
    assert classify(rec, initial_kinetic_j=1.0, final_kinetic_j=1.0,
                    timed_out=True).status is Status.MAX_TIME
    rec.normal_force_n[:] = 0.0
    assert classify(rec, initial_kinetic_j=1.0, final_kinetic_j=1.0).status is Status.NO_CONTACT
    rec.penetration_m[3] = math.nan
    assert classify(rec, initial_kinetic_j=1.0, final_kinetic_j=1.0).status is Status.DIVERGED
