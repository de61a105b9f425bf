"""SAPIEN (PhysX) bounce to rest: the drop from rest, PhysX's restitution and its scene's
``bounce_threshold`` (read back), every mode at the customary step."""

from __future__ import annotations

import math

import pytest
from bounce_records import PHYSICAL, apexes, first_contact
from conftest import require_engine
from impactbench.engines.base import RunSettings, get_adapter
from impactbench.reference.bounce_scenario import Bounce
from impactbench.reference.record import Status

require_engine("sapien")


def run(mode: str, scenario: Bounce, **settings) -> object:
    return get_adapter("sapien").run(scenario, mode, RunSettings(**settings))


def test_customary_step_is_sapien_scene_default():
    import sapien.physx as px

    step = get_adapter("sapien").builders["bounce"].timestep_s
    assert step == pytest.approx(px.PhysxCpuSystem().timestep, rel=1e-6)  # 0.01 s, float32


def test_rigid_restitution_apex_and_threshold_read_back():
    s = Bounce(max_time_s=4.0)
    dt = 1e-3
    rec = run("custom", s, timestep_s=dt,
              params={"restitution": 0.9, "bounce_threshold": 0.5})
    k = first_contact(rec)
    # PhysX's speculative contact (10 mm offset) acts within the step that reaches the plate
    assert abs(rec.time_s[k] - s.fall_time_s) <= dt
    # measured 1.971 against 1.981 m/s (−0.5 %: the sample is the step's start)
    assert rec.penetration_rate_m_s[k] == pytest.approx(s.impact_velocity_m_s, rel=0.02)
    # first apex e²·h: measured 0.161994 against 0.162 m (−6e-6 m)
    assert apexes(rec)[0] == pytest.approx(0.81 * s.height_m, abs=2e-5)
    assert rec.meta["bounce_threshold_m_s"] == 0.5
    assert rec.status == Status.OK and rec.meta["settled"]
    assert rec.time_s[-1] < s.max_time_s  # stopped dead below 0.5 m/s, at 3.1 s


def test_default_threshold_swallows_a_slow_first_impact():
    import sapien.physx as px

    default = float(px.PhysxSceneConfig().bounce_threshold)  # 2 m/s
    slow = run("default", Bounce(max_time_s=2.0))  # √(2gh) = 1.98 m/s, customary 0.01 s
    assert slow.meta["timestep_s"] == pytest.approx(0.01)
    assert slow.meta["bounce_threshold_m_s"] == default == 2.0
    assert slow.status == Status.OK and slow.meta["settled"]
    assert max(apexes(slow)) < 1e-3  # stopped dead
    fast = Bounce(height_m=0.3, max_time_s=2.0)  # 2.43 m/s: restitution 0.1 applies
    rec = run("default", fast, timestep_s=1e-3)
    # e²·h = 3 mm: measured 3.078 mm (+2.6 %)
    assert apexes(rec)[0] == pytest.approx(0.01 * fast.height_m, abs=2.5e-4)


def test_compliant_native_has_no_threshold():
    rec = run("native", Bounce(max_time_s=2.0))
    assert "bounce_threshold_m_s" not in rec.meta
    assert rec.status == Status.OK and rec.meta["settled"]


@pytest.mark.parametrize("mode, settings", [
    ("native", {}),
    ("native", {"options": {"contact": "rigid"}}),
    ("injected", {}),
    ("default", {}),
    ("custom", {"params": {"restitution": 0.5}}),
    ("tuned", {"tuned": {"restitution": 0.5}}),
])
def test_every_mode_returns_a_status(mode, settings):
    s = Bounce(max_time_s=2.0)
    rec = run(mode, s, **settings)
    assert rec.status in PHYSICAL
    assert rec.time_s.size > s.fall_time_s / 0.01
    assert math.isfinite(rec.time_s[-1]) and rec.time_s[-1] <= s.max_time_s + 0.01
