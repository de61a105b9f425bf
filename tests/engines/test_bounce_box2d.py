"""Box2D bounce to rest: the drop from rest, Box2D's rigid restitution and its build's
``b2_velocityThreshold`` (read back), every mode at the customary step."""

from __future__ import annotations

import pytest
from bounce_records import PHYSICAL, apexes, first_contact
from conftest import require_engine
from impactbench.engines.base import RunSettings, get_adapter
from impactbench.reference.bounce_scenario import Bounce
from impactbench.reference.record import Status

require_engine("box2d")


E = {"restitution": 0.9}
"""A custom rigid restitution (the plate's is 0: the pair's maximum is 0.9)."""


def run(mode: str, scenario: Bounce, **settings) -> object:
    return get_adapter("box2d").run(scenario, mode, RunSettings(**settings))


def test_customary_step_is_the_manuals():
    assert get_adapter("box2d").builders["bounce"].timestep_s == 1.0 / 60.0


def test_rigid_restitution_apex_and_threshold_read_back():
    import Box2D

    s = Bounce(max_time_s=4.0)
    dt = 1e-3  # the customary 1/60 s lets the 14.5 mm ball sink up to 3·b2_linearSlop
    rec = run("custom", s, timestep_s=dt, params=E)
    k = first_contact(rec)
    assert abs(rec.time_s[k] - s.fall_time_s) <= dt
    # measured 1.98094 against 1.98064 m/s
    assert rec.penetration_rate_m_s[k] == pytest.approx(s.impact_velocity_m_s, rel=0.02)
    # first apex e²·h: measured 0.163501 against 0.162 m (+1.5e-3 m: Box2D's restitution
    # acts on the approach after the step's gravity, v + g·dt)
    assert apexes(rec)[0] == pytest.approx(0.81 * s.height_m, abs=4.5e-3)
    assert rec.meta["bounce_threshold_m_s"] == float(Box2D.b2_velocityThreshold) == 1.0
    assert rec.status == Status.OK and rec.meta["settled"]
    assert rec.time_s[-1] < s.max_time_s  # stopped dead at 2.43 s (impact ≤ 1 m/s)


def test_threshold_swallows_a_slow_impact():
    # √(2gh) = 0.89 m/s < 1 m/s: restitution 0.9 does not apply, the ball stops dead
    rec = run("custom", Bounce(height_m=0.04, max_time_s=1.0), timestep_s=1e-3, params=E)
    assert rec.meta["bounce_threshold_m_s"] == 1.0
    assert rec.status == Status.OK and rec.meta["settled"]
    assert max(apexes(rec)) < 1e-3


def test_default_restitution_zero_has_no_threshold():
    rec = run("default", Bounce(max_time_s=2.0))
    assert "bounce_threshold_m_s" not in rec.meta
    assert rec.status == Status.OK and rec.meta["settled"]


@pytest.mark.parametrize("mode, settings", [
    ("native", {}),
    ("injected", {}),
    ("default", {}),
    ("custom", {"params": E}),
    ("tuned", {"tuned": {"restitution": 0.5}}),
])
def test_every_mode_returns_a_status(mode, settings):
    s = Bounce(max_time_s=2.0)
    rec = run(mode, s, **settings)
    assert rec.status in PHYSICAL
    assert rec.meta["timestep_s"] == pytest.approx(1.0 / 60.0)
    assert rec.time_s[-1] <= s.max_time_s + 1.0 / 60.0
