"""Drake's bounce to rest (real Drake, no mocks): the ball released from rest, followed across
its bounces until it rests. The continuous plant (native, injected, tuned) at a step that
resolves a softened contact gives the first apex e²·h of Hunt–Crossley's restitution e; at
Drake's customary 1 ms step the stiff paper ball blows up the explicit RK3 and the discrete
plant's default contact stops it dead. Tolerances are about 3× the error measured on this
machine (drake 1.51.1), written beside them.
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import require_engine
from impactbench.engines.base import RunSettings, get_adapter
from impactbench.reference import bounce, hunt_crossley
from impactbench.reference.bounce_scenario import Bounce
from impactbench.reference.record import ImpactRecord, Status

CUSTOMARY_S = 1e-3
RESOLVED = Bounce(stiffness=1e6, max_time_s=0.7)
"""A softened ball (contact ≈ 2 ms) that the continuous plant resolves at 1e-4 s."""


@pytest.fixture(scope="module")
def drake():
    require_engine("drake")
    return get_adapter("drake")


@pytest.fixture(scope="module")
def default_run(drake) -> ImpactRecord:
    return drake.run(Bounce(max_time_s=2.0), "default")


@pytest.fixture(scope="module", params=["native", "injected"])
def resolved_run(drake, request) -> ImpactRecord:
    return drake.run(RESOLVED, request.param, RunSettings(timestep_s=1e-4))


def _contact_starts(rec: ImpactRecord) -> np.ndarray:
    touching = rec.normal_force_n > 0.0
    return np.flatnonzero(touching[1:] & ~touching[:-1]) + 1


def _check_first_impact(rec: ImpactRecord, scenario: Bounce, dt: float) -> None:
    """First contact within one step of the fall √(2h/g), at √(2gh) (measured: +3.8e-5 s,
    speed error ≤ 1.7e-4 at 1 ms and ≤ 1.2e-4 at 1e-4 s)."""
    first = _contact_starts(rec)[0]
    assert abs(rec.time_s[first] - scenario.fall_time_s) <= dt
    speed = rec.penetration_rate_m_s[first]
    assert speed == pytest.approx(scenario.impact_velocity_m_s, rel=5e-4)


def test_default_contact_stops_the_ball_dead_and_it_settles(default_run) -> None:
    """Drake's default (discrete lagged, point properties from the 1 mm penetration allowance)
    at its customary step: one contact, the ball never leaves the plate again (measured
    max(−x) after impact −1.4e-7 m), at rest after 0.36 s, inside the cap."""
    rec = default_run
    assert rec.status is Status.OK, rec.message
    assert rec.meta["settled"] is True
    assert rec.meta["timestep_s"] == CUSTOMARY_S
    assert rec.time_s[-1] < 2.0
    _check_first_impact(rec, Bounce(), CUSTOMARY_S)
    after = -rec.penetration_m[_contact_starts(rec)[0]:]
    assert after.max() < 1e-3  # no bounce above 1 mm
    assert rec.meta["engine_defaults"]["discrete_contact_approximation"] == "lagged"
    assert "bounce_threshold_m_s" not in rec.meta  # compliant contact: no threshold


def test_every_step_is_recorded_from_rest(default_run) -> None:
    """Discrete plant: one sample per step (the state before it, with its force) plus the
    last state: ``steps`` + 1 samples, k·dt apart, starting at rest at x = −h."""
    rec = default_run
    assert len(rec) == rec.meta["steps"] + 1
    np.testing.assert_allclose(np.diff(rec.time_s), CUSTOMARY_S, rtol=1e-9)
    assert rec.penetration_m[0] == pytest.approx(-Bounce().height_m, abs=1e-12)
    assert rec.penetration_rate_m_s[0] == 0.0
    assert rec.normal_force_n[-1] == 0.0


def test_resolved_first_apex_is_e_squared_h(resolved_run) -> None:
    """Native (linear HC, d = b) and injected (the power law) share HC's restitution e(b·V0),
    so the first apex is e²·h; gravity during the 2 ms contact lowers it (measured −4.8e-3
    for both, converged in the step: −4.8e-3 at 2e-5 s too). Against the reference that
    integrates the contact with gravity: −9.1e-5 (native), −1.2e-4 (injected)."""
    rec = resolved_run
    _check_first_impact(rec, RESOLVED, 1e-4)
    first, second = _contact_starts(rec)[:2]
    apex = -rec.penetration_m[first:second].min()
    e = hunt_crossley.solve(RESOLVED.ball())["restitution"]
    assert apex == pytest.approx(e * e * RESOLVED.height_m, rel=1.5e-2)
    assert apex == pytest.approx(bounce.solve(RESOLVED).apex_heights_m[0], rel=3.5e-4)


def test_a_ball_still_bouncing_at_the_cap_is_max_time(resolved_run) -> None:
    """Hunt–Crossley's restitution tends to 1 as the bounces slow: the ball is still
    bouncing at the 0.7 s cap, which ends the run at exactly the cap's step count."""
    rec = resolved_run
    assert rec.status is Status.MAX_TIME, rec.message
    assert rec.meta["settled"] is False
    assert rec.time_s[-1] == pytest.approx(RESOLVED.max_time_s, abs=1e-9)
    assert len(rec) == rec.meta["steps"] + 1 == 7001


NATIVE_PAIR = {"point_stiffness_n_per_m": 91330705.86558773,
               "hunt_crossley_dissipation_s_per_m": 0.1}
SAP_FILE = {"point_stiffness_n_per_m": 1291557536.1770985, "relaxation_time_s": 1e-6,
            "discrete_contact_approximation": "sap"}


@pytest.mark.parametrize(("mode", "settings", "status"), [
    ("native", RunSettings(), Status.DIVERGED),  # RK3 at ω·dt ≈ 30: far past stability
    ("injected", RunSettings(), Status.DIVERGED),
    ("tuned", RunSettings(tuned=NATIVE_PAIR), Status.DIVERGED),
    ("tuned", RunSettings(tuned=SAP_FILE), Status.OK),  # discrete SAP: settles at 0.58 s
    ("tuned", RunSettings(), Status.UNSUPPORTED),  # no tuned file
    ("custom", RunSettings(params={"discrete_contact_approximation": "tamsi",
                                   "point_stiffness": 1e4}), Status.OK),
])
def test_every_mode_gives_a_status_at_the_customary_step(drake, mode, settings, status
                                                         ) -> None:
    rec = drake.run(Bounce(max_time_s=1.0), mode, settings)
    assert rec.status is status, rec.message
    if status is Status.UNSUPPORTED:
        return
    assert rec.meta["timestep_s"] == CUSTOMARY_S
    if mode == "custom":
        assert rec.meta["params"] == settings.params
    if status is Status.OK:
        assert rec.meta["settled"] is True
