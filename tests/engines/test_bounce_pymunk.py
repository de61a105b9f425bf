"""pymunk's bounce to rest (real engine): the ball dropped from rest on the plate, at pymunk's
customary 1/60 s and finer. Tolerances: 3× the error measured beside each (pymunk 7.3.1)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import require_engine
from impactbench.engines.base import RunSettings, get_adapter
from impactbench.reference.bounce_scenario import Bounce
from impactbench.reference.record import ImpactRecord, Status

CUSTOMARY_S = 1.0 / 60.0
"""pymunk's customary step (s), the bounce builder's default."""


def run(scenario: Bounce, mode: str, **settings) -> ImpactRecord:
    require_engine("pymunk")
    return get_adapter("pymunk").run(scenario, mode, RunSettings(**settings))


def contacts(rec: ImpactRecord) -> list[tuple[int, int]]:
    """(first, last) sample index of each run of samples with a positive force."""
    on = np.flatnonzero(rec.normal_force_n > 0.0)
    if on.size == 0:
        return []
    cut = np.flatnonzero(np.diff(on) > 1)
    return list(zip(np.r_[on[0], on[cut + 1]], np.r_[on[cut], on[-1]], strict=True))


def first_apex(rec: ImpactRecord) -> float:
    """max(−x) between the end of the first contact and the start of the second (m)."""
    found = contacts(rec)
    stop = found[1][0] if len(found) > 1 else rec.time_s.size
    return float(np.max(-rec.penetration_m[found[0][1] + 1:stop + 1]))


def native_restitution(scenario: Bounce) -> float:
    """The native contact's elasticity: Hunt–Crossley's restitution at 1 m/s."""
    from impactbench.reference import hunt_crossley

    return float(hunt_crossley.solve(scenario.ball().replace(velocity_m_s=1.0))["restitution"])


def test_the_ball_starts_at_rest_and_first_touches_after_the_free_fall() -> None:
    sc = Bounce(max_time_s=1.0)
    rec = run(sc, "native")
    assert rec.penetration_m[0] == -sc.height_m and rec.penetration_rate_m_s[0] == 0.0
    assert rec.meta["timestep_s"] == CUSTOMARY_S  # the builder's default
    k = contacts(rec)[0][0]
    # touch at 0.2 s, the fall √(2h/g) = 0.2019 s: 0.12 steps early (the step that ends in
    # overlap starts at 12·dt)
    assert abs(rec.time_s[k] - sc.fall_time_s) <= CUSTOMARY_S
    # measured −0.97 %: drift-then-kick brings the ball in at 12·g·dt, not √(2gh)
    assert rec.penetration_rate_m_s[k] == pytest.approx(sc.impact_velocity_m_s, rel=0.03)


@pytest.mark.parametrize(("dt", "tol"), [
    (CUSTOMARY_S, 0.016),  # measured +0.54 % (native), −0.42 % (custom 0.9)
    (1e-3, 0.002),  # measured −0.04 %, −0.07 %
])
@pytest.mark.parametrize("mode", ["native", "custom"])
def test_first_apex_is_restitution_squared_times_the_height(mode, dt, tol) -> None:
    sc = Bounce(max_time_s=1.0)
    params = {"elasticity": 0.9} if mode == "custom" else None
    rec = run(sc, mode, timestep_s=dt, params=params)
    e = 0.9 if mode == "custom" else native_restitution(sc)
    if mode == "native":
        assert rec.meta["elasticity"] == pytest.approx(e, rel=1e-12)
    assert len(contacts(rec)) >= 2
    assert first_apex(rec) == pytest.approx(e * e * sc.height_m, rel=tol)


def test_no_restitution_velocity_threshold_a_slow_drop_still_bounces() -> None:
    """Chipmunk applies restitution at any speed (cpArbiterPreStep: bounce = vₙ·e): a 2 mm
    drop hits at 0.2 m/s (below Box2D's 1 m/s threshold) and still rises to e²·h."""
    sc = Bounce(height_m=0.002, max_time_s=0.1)
    rec = run(sc, "custom", timestep_s=1e-3, params={"elasticity": 0.9})
    assert "bounce_threshold_m_s" not in rec.meta
    assert first_apex(rec) == pytest.approx(0.81 * sc.height_m, rel=0.0045)  # measured −0.15 %


def test_force_is_the_impulse_applied_in_the_step_not_chipmunks_stale_total() -> None:
    """Re-touching within collision_persistence steps, Chipmunk's total_impulse carries the
    previous contact's impulse (hundreds of N by 15 s); the recorded force is this step's:
    F·dt = m·(ẋ_k + g·dt − ẋ_{k+1}) (measured ≤ 5.6e-17 N·s over 900 steps)."""
    sc = Bounce()
    rec = run(sc, "tuned", tuned={"elasticity": 0.9})
    v, f = rec.penetration_rate_m_s, rec.normal_force_n
    applied = sc.mass_kg * (v[:-1] + sc.gravity_m_s2 * CUSTOMARY_S - v[1:])
    assert len(contacts(rec)) > 100
    assert np.max(np.abs(applied - f[:-1] * CUSTOMARY_S)) < 1e-15
    assert f.min() >= 0.0


@pytest.mark.parametrize(("mode", "params", "end_s"), [
    ("default", None, 0.3),  # elasticity 0: stays at the first impact (measured 0.3 s)
    ("custom", {"elasticity": 0.9}, 4.033),  # slop 0.1 m: rests in the plate (4.033 s)
])
def test_out_of_the_box_contact_comes_to_rest(mode, params, end_s) -> None:
    sc = Bounce()
    rec = run(sc, mode, params=params)
    assert rec.status is Status.OK, rec.message
    assert rec.meta["settled"] is True
    assert rec.meta["engine_defaults"]["collision_slop"] == pytest.approx(0.1)
    assert rec.time_s[-1] < sc.max_time_s
    assert rec.time_s[-1] == pytest.approx(end_s, abs=CUSTOMARY_S)
    assert abs(rec.penetration_rate_m_s[-1]) < 0.01


def test_rigid_contact_with_zero_slop_never_rests_at_one_sixtieth() -> None:
    """native (slop 0): the bias lifts the resting ball clear, each re-touch is a fresh rigid
    impact, and the ball cycles every 3 steps, falling in at 2·g·dt/(1 + e)."""
    sc = Bounce()
    rec = run(sc, "native")
    assert rec.status is Status.MAX_TIME and rec.meta["settled"] is False
    e = rec.meta["elasticity"]
    tail = rec.penetration_rate_m_s[-7:]
    cycle = 2.0 * sc.gravity_m_s2 * CUSTOMARY_S / (1.0 + e)
    assert np.max(tail) == pytest.approx(cycle, rel=3e-4)  # measured 6.0e-5


@pytest.mark.parametrize(("mode", "settings", "status"), [
    ("native", {}, Status.MAX_TIME),
    ("injected", {}, Status.DIVERGED),  # the Hertz penalty at 1/60 s: 2.9e7 N in one step
    ("injected", {"options": {"injection": "restitution"}}, Status.MAX_TIME),
    ("tuned", {"tuned": {"elasticity": 0.9}}, Status.MAX_TIME),
    ("tuned", {"tuned": {"restitution_law": "hunt_crossley",
                         "restitution_damping_s_per_m": 0.1}}, Status.MAX_TIME),
    ("tuned", {}, Status.UNSUPPORTED),
    ("default", {}, Status.OK),
    ("custom", {"params": {"elasticity": 0.9}}, Status.OK),
])
def test_every_mode_returns_a_status(mode, settings, status) -> None:
    rec = run(Bounce(max_time_s=3.0 if status is Status.MAX_TIME else 15.0), mode, **settings)
    assert rec.status is status, rec.message
    if status is not Status.UNSUPPORTED:
        assert rec.time_s.size >= 2 and math.isfinite(rec.time_s[-1])
        assert rec.meta["steps"] == round(rec.time_s[-1] / CUSTOMARY_S)
