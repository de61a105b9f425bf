"""DART bounce to rest: the drop from rest, DART's rigid restitution and its compiled-in
bounce threshold (0.1 m/s on the rebound speed e·vₙ), every mode at the customary step."""

from __future__ import annotations

import pytest
from bounce_records import PHYSICAL, apexes, first_contact
from conftest import require_engine
from impactbench.engines.base import RunSettings, get_adapter
from impactbench.reference.bounce_scenario import Bounce
from impactbench.reference.record import Status

require_engine("dart")


E = {"restitution_coeff": 0.9}
"""A custom rigid restitution (the plate's coefficient is 1: the pair's product is 0.9)."""


def run(mode: str, scenario: Bounce, **settings) -> object:
    return get_adapter("dart").run(scenario, mode, RunSettings(**settings))


def test_customary_step_is_dart_world_default():
    import dartpy

    step = get_adapter("dart").builders["bounce"].timestep_s
    assert step == dartpy.simulation.World().getTimeStep() == 1e-3


def test_rigid_restitution_apex_and_settling():
    s = Bounce(max_time_s=6.0)
    rec = run("custom", s, params=E)  # the customary 1e-3 s
    dt = rec.meta["timestep_s"]
    assert dt == 1e-3
    k = first_contact(rec)
    assert abs(rec.time_s[k] - s.fall_time_s) <= dt
    # measured 1.98094 against 1.98064 m/s
    assert rec.penetration_rate_m_s[k] == pytest.approx(s.impact_velocity_m_s, rel=0.02)
    # first apex e²·h: measured 0.163494 against 0.162 m (+1.5e-3 m: DART's restitution
    # acts on the approach after the step's gravity, v + g·dt)
    assert apexes(rec)[0] == pytest.approx(0.81 * s.height_m, abs=4.5e-3)
    assert rec.meta["bounce_threshold_m_s"] == 0.1
    assert rec.status == Status.OK and rec.meta["settled"]
    assert rec.time_s[-1] < s.max_time_s  # at rest at 4.57 s


def test_threshold_is_on_the_rebound_speed():
    # e·√(2gh) = 0.08 m/s < 0.1: no bounce; 0.18 m/s > 0.1: bounces (e²·h = 1.6 mm)
    dead = run("custom", Bounce(height_m=4e-4, max_time_s=1.0), params=E)
    assert dead.meta["bounce_threshold_m_s"] == 0.1
    assert dead.status == Status.OK and dead.meta["settled"]
    assert max(apexes(dead)) < 1e-4
    live = run("custom", Bounce(height_m=2e-3, max_time_s=1.0), params=E)
    assert apexes(live)[0] > 1e-3  # measured 1.79 mm


def test_default_restitution_zero_has_no_threshold():
    rec = run("default", Bounce(max_time_s=2.0))
    assert "bounce_threshold_m_s" not in rec.meta  # e = 0: DART's bounce is off
    assert rec.status == Status.OK and rec.meta["settled"]
    assert max(apexes(rec)) < 1e-3


@pytest.mark.parametrize("mode, settings", [
    ("native", {}),
    ("injected", {}),
    ("default", {}),
    ("custom", {"params": {"restitution_coeff": 0.5}}),
    ("tuned", {"tuned": {"restitution_coeff": 0.5}}),
])
def test_every_mode_returns_a_status(mode, settings):
    s = Bounce(max_time_s=2.0)
    rec = run(mode, s, **settings)
    assert rec.status in PHYSICAL
    assert rec.time_s[-1] <= s.max_time_s + 1e-3
