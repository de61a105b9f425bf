"""MuJoCo's bounce to rest (``run_bounce``) on the real engine: the ball released from rest
``height_m`` above the plane, every step recorded until it rests or the time cap.

Tolerances are about 3× the errors measured on this machine (mujoco 4.0.0), written beside
them. MuJoCo's contact is soft: no restitution threshold (``bounce_threshold_m_s``)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import require_engine
from impactbench.engines.base import RunSettings, get_adapter
from impactbench.engines.bounce import SETTLE_S, SETTLE_SPEED_M_S
from impactbench.engines.common import SpringDamper
from impactbench.reference.bounce_scenario import Bounce
from impactbench.reference.record import Status

CUSTOMARY_S = 0.002
"""MuJoCo's default ``<option timestep>`` (s), the bounce builder's step."""


@pytest.fixture(scope="module")
def mujoco():
    """The MuJoCo adapter (skips with its pip command when mujoco is missing)."""
    require_engine("mujoco")
    return get_adapter("mujoco")


def contacts(rec) -> list[tuple[int, int]]:
    """The contacts of a record: (first, last + 1) sample index of each run with F > 0."""
    touching = (rec.normal_force_n > 0.0).astype(int)
    edges = np.diff(np.concatenate(([0], touching, [0])))
    return list(zip(np.flatnonzero(edges == 1).tolist(), np.flatnonzero(edges == -1).tolist(),
                    strict=True))


def test_bounce_runs_at_mujocos_default_step_from_rest(mujoco) -> None:
    s = Bounce()
    assert mujoco.default_timestep_s(s, "native") == CUSTOMARY_S
    rec = mujoco.run(s, "default")
    assert rec.meta["timestep_s"] == CUSTOMARY_S
    # every step recorded, from rest with the lowest point h above the plane
    np.testing.assert_allclose(np.diff(rec.time_s), CUSTOMARY_S, rtol=1e-9)
    assert rec.time_s[0] == 0.0 and rec.penetration_m[0] == -s.height_m
    assert rec.penetration_rate_m_s[0] == 0.0
    assert "bounce_threshold_m_s" not in rec.meta  # soft contact: no threshold


@pytest.mark.parametrize("mode", ["default", "custom"])
def test_first_contact_is_at_the_free_fall_time_and_speed(mujoco, mode) -> None:
    """First contact at √(2h/g) to within a step, at √(2gh) to within a step's gravity g·dt
    (the sample falls up to a step after the touch): measured sample 101 (0.202 s for
    0.20196 s), ẋ 1.98094 m/s for 1.98057 (+1.9e-4; g·dt is 1.0e-2 of it)."""
    s = Bounce()
    params = {"solref": [0.01, 0.5]} if mode == "custom" else None
    rec = mujoco.run(s, mode, RunSettings(params=params))
    first = contacts(rec)[0][0]
    assert abs(rec.time_s[first] - s.fall_time_s) <= CUSTOMARY_S
    assert rec.penetration_m[first - 1] < 0.0 <= rec.penetration_m[first]
    assert abs(rec.penetration_rate_m_s[first] - s.impact_velocity_m_s) <= \
        s.gravity_m_s2 * CUSTOMARY_S


def test_native_first_apex_is_e_squared_h(mujoco) -> None:
    """At a step that resolves the contact (2 µs; the native contact lasts ~0.1 ms) the first
    apex is e²·h, e the native clipped spring–damper's restitution (velocity-independent).
    Measured: 0.175757 m for e²h = 0.175772 m, −8.7e-5 (gravity during the contact; at 1e-6 s
    −5.8e-5, at 1e-5 s −2.1e-2). The cap (0.45 s) ends the run in the first flight."""
    s = Bounce(max_time_s=0.45)
    rec = mujoco.run(s, "native", RunSettings(timestep_s=2e-6))
    assert rec.status is Status.MAX_TIME and rec.meta["settled"] is False, rec.message
    [(_, off)] = contacts(rec)
    apex = float(np.max(-rec.penetration_m[off:]))
    e = SpringDamper(rec.meta["stiffness_n_per_m"], rec.meta["damping_ns_per_m"]).restitution(
        s.mass_kg)
    assert apex == pytest.approx(e * e * s.height_m, rel=3e-4)
    assert np.argmax(-rec.penetration_m[off:]) < len(rec) - off - 1  # the apex was passed


def test_default_contact_settles_ok_within_the_cap(mujoco) -> None:
    """MuJoCo's default contact (solref (0.02, 1): critically damped) takes the ball in and
    never lets it go; it rests, sunk 0.366 mm (measured), at 0.438 s."""
    s = Bounce()
    rec = mujoco.run(s, "default")
    assert rec.status is Status.OK and rec.meta["settled"] is True, rec.message
    assert rec.time_s[-1] < s.max_time_s
    assert len(contacts(rec)) == 1  # the final sample's F is 0 (no step from it)
    quiet = math.ceil(SETTLE_S / CUSTOMARY_S)
    assert np.all(np.abs(rec.penetration_rate_m_s[-quiet:]) < SETTLE_SPEED_M_S)
    assert abs(rec.penetration_rate_m_s[-quiet - 1]) >= SETTLE_SPEED_M_S  # ended at once
    assert 0.0 < rec.penetration_m[-1] < s.radius_m
    assert rec.meta["engine_defaults"]["solref"] == [0.02, 1.0]
    assert rec.meta["steps"] == len(rec) - 1


def test_custom_solref_reaches_the_bounce(mujoco) -> None:
    """A custom solref (0.01, 0.5) bounces where the default does not: measured first apex
    12.3 mm, four contacts, at rest at 0.476 s."""
    rec = mujoco.run(Bounce(), "custom", RunSettings(params={"solref": [0.01, 0.5]}))
    assert rec.status is Status.OK and rec.meta["settled"] is True, rec.message
    assert rec.meta["solref"] == [0.01, 0.5] and rec.meta["params"] == {"solref": [0.01, 0.5]}
    (_, off), (on, _) = contacts(rec)[:2]
    assert float(np.max(-rec.penetration_m[off:on])) == pytest.approx(12.3e-3, rel=0.05)
    with pytest.raises(ValueError, match="oblique scenario only"):
        mujoco.run(Bounce(), "custom", RunSettings(params={"cone": "elliptic"}))


def test_every_mode_returns_a_status(mujoco) -> None:
    """Every mode of the ball builder runs the bounce. At the customary 2 ms the stiff
    contacts (native, tuned with native's solref, the injected Hunt–Crossley law, each
    lasting ~0.1 ms) gain energy at the first impact (measured: mechanical energy 3.4e6×
    m·g·h, 3.7e8× injected, one step after it): ``diverged``; MuJoCo's default contact and
    a custom RK4 run rest."""
    s = Bounce(max_time_s=0.5)
    native = mujoco.run(s, "native")
    tuned = RunSettings(tuned={"solref": native.meta["solref"], "solimp": native.meta["solimp"]})
    got = {"native": native, "tuned": mujoco.run(s, "tuned", tuned),
           "injected": mujoco.run(s, "injected"), "default": mujoco.run(s, "default"),
           "custom": mujoco.run(s, "custom", RunSettings(params={"integrator": "RK4"}))}
    assert {m: r.status for m, r in got.items()} == {
        "native": Status.DIVERGED, "tuned": Status.DIVERGED, "injected": Status.DIVERGED,
        "default": Status.OK, "custom": Status.OK}
    assert got["injected"].meta["stepping"] == "python loop"
    assert got["native"].meta["stepping"] == "rollout"
    for rec in got.values():
        assert len(rec) <= math.ceil(s.max_time_s / CUSTOMARY_S) + 1
    np.testing.assert_array_equal(got["tuned"].penetration_m, got["native"].penetration_m)
    assert mujoco.run(s, "tuned").status is Status.UNSUPPORTED  # no tuned file
