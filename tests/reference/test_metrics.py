"""reference.metrics on the reference's own time histories agrees with the closed form.

Tolerances, from how :func:`impactbench.reference.hunt_crossley.history` samples:

- first touch and separation are samples with x = 0, so the metrics' zero-crossing edges are
  exact and duration and restitution agree to the quadrature's accuracy (1e-12);
- the instants of x_max and of the peak force are samples, so the sampled maxima are exact
  (1e-12);
- the lost-energy fraction is the trapezoid rule of ∮F dx = ∫F·ẋ dt over steps h, whose error
  is bounded by (h²/12)·∫|d²(F·ẋ)/dt²| dt; the test computes that bound from the record itself.
"""

from __future__ import annotations

import numpy as np
import pytest
from impactbench.reference import hunt_crossley as hc
from impactbench.reference import metrics
from impactbench.reference.metrics import BALL_METRICS
from impactbench.reference.scenarios import BallOnPlate

CASES = [
    BallOnPlate(velocity_m_s=0.5),
    BallOnPlate(velocity_m_s=5.0),
    BallOnPlate(velocity_m_s=1.0, damping_s_per_m=0.0),
    BallOnPlate(velocity_m_s=1.0, damping_s_per_m=1.0, exponent=1.0, stiffness=1e7),
    BallOnPlate(velocity_m_s=2.0, exponent=2.0, stiffness=1e14),
]


@pytest.mark.parametrize("alpha", [10.0, 20.0, 30.0, 50.0])
def test_heavily_damped_contact_ends_where_the_surfaces_part(alpha):
    """α = b·V0 up to 50 (issue 16): 1 + b·ẋ fades exponentially, so F/F_max falls far below
    round-off while the surfaces still overlap (at α = 50 over the last 68 % of the contact,
    which the 1e-13 force floor alone cut off); the contact still ends at x = 0, as in the
    closed form."""
    s = BallOnPlate(velocity_m_s=5.0, damping_s_per_m=alpha / 5.0)
    got, want = metrics.compute(hc.history(s)), hc.solve(s)
    assert got["impacts"] == 1
    for key in ("restitution", "duration_s", "peak_force_n", "max_penetration_m"):
        assert got[key] == pytest.approx(want[key], rel=1e-12), key


def trapezoid_bound(rec) -> float:
    """(h²/12)·∫|(F·ẋ)''| dt over the record, by finite differences (J)."""
    g = rec.normal_force_n * rec.penetration_rate_m_s
    h = float(np.max(np.diff(rec.time_s)))
    second = np.abs(np.diff(g, 2)) / h**2
    return h**2 / 12.0 * float(np.sum(second)) * h


@pytest.mark.parametrize("scenario", CASES, ids=lambda s: f"V{s.velocity_m_s}-b{s.damping_s_per_m}"
                         f"-n{s.exponent}")
def test_metrics_of_history_match_closed_form(scenario):
    rec = hc.history(scenario)
    got = metrics.compute(rec)
    want = hc.solve(scenario)
    assert got["impacts"] == 1
    for key in ("restitution", "duration_s", "peak_force_n", "max_penetration_m"):
        assert got[key] == pytest.approx(want[key], rel=1e-12), key
    kinetic = 0.5 * scenario.mass_kg * scenario.velocity_m_s**2
    tol = trapezoid_bound(rec) / kinetic
    assert tol < 2e-6  # the sampling is fine enough for the 1e-6 class
    assert abs(got["energy_loss_fraction"] - want["energy_loss_fraction"]) <= tol
    assert got["impulse_ns"] == pytest.approx(
        scenario.mass_kg * scenario.velocity_m_s * (1.0 + want["restitution"]), rel=1e-6)
    assert set(BALL_METRICS) <= set(got)


def test_coarse_history_still_within_its_own_bound():
    """At 201 samples the bound grows as h² and still holds."""
    s = CASES[1]
    rec = hc.history(s, samples=201)
    got, want = metrics.compute(rec), hc.solve(s)
    tol = trapezoid_bound(rec) / (0.5 * s.mass_kg * s.velocity_m_s**2)
    assert abs(got["energy_loss_fraction"] - want["energy_loss_fraction"]) <= tol
    assert got["duration_s"] == pytest.approx(want["duration_s"], rel=1e-12)
