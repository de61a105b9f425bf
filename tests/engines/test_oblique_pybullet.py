"""PyBullet's oblique impact (issue 22) through the one metrics path
(:func:`impactbench.evaluate.compare`): injected against the rigid Coulomb reference on both
sides of the stick/slide threshold (63.9°), native and default running and recording Bullet's
friction model, custom keys reaching the engine.

Tolerances are ~3× the errors measured on this machine (pybullet 3.2.7, dt 1e-6 s), written
beside them; round-off-exact results get 1e-9.
"""

from __future__ import annotations

import math

import pytest
from conftest import require_engine

require_engine("pybullet")

from impactbench.engines.base import RunSettings, get_adapter  # noqa: E402
from impactbench.reference.oblique import SPIN_FACTOR, Oblique  # noqa: E402

from impactbench.evaluate import compare  # noqa: E402

ANGLES = [(20.0, 0.0), (45.0, 0.0), (60.0, 0.0), (80.0, 1.0)]
# injected (secant: the ball's injection, Bullet's implicit contact step) vs rigid, measured
# |rel err|: restitution −3.73e-2 / −3.58e-2 / −3.40e-2 / −2.82e-2 at 20/45/60/80°; tangential
# restitution and spin exact in stick (2e-14), at 80° +1.6e-3 and −1.39e-2 (the tangential
# impulse μ·(1 + e)·v_n carries the low e); rebound angle 3.7e-2 (20°)
SECANT_TOLERANCE = {"restitution": 0.11, "tangential_restitution": 5e-3,
                    "spin_out_rad_s": 0.042, "rebound_angle_deg": 0.11}
# injection = "explicit" vs rigid, measured worst: restitution 1.1e-4 (20°), tangential
# restitution 1.4e-6 (80°; stick 1e-14), spin 1.2e-5 (80°), rebound angle 1.0e-4 (20°)
EXPLICIT_TOLERANCE = {"restitution": 3.3e-4, "tangential_restitution": 4.2e-6,
                      "spin_out_rad_s": 3.7e-5, "rebound_angle_deg": 3.1e-4}
CUSTOMARY_S = 1.0 / 240.0


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


@pytest.mark.parametrize(("angle", "regime"), ANGLES)
def test_injected_reproduces_the_rigid_reference(angle, regime):
    s = Oblique(angle_deg=angle)
    out, rec = compare("pybullet", s, "injected", RunSettings())
    assert out["status"] == "ok", out["message"]
    for key, tol in SECANT_TOLERANCE.items():
        assert abs(out["rel_error"][key]) <= tol, (angle, key, out["rel_error"][key])
    assert out["regime"] == regime
    # Bullet's friction is the rigid theory exactly, given its own normal impulse (the
    # implicit contact step's loss is all in the normal part)
    v_t, spin = rigid_given(s, -rec.penetration_rate_m_s[-1] / s.normal_velocity_m_s)
    assert rec.tangential_velocity_m_s[-1] == pytest.approx(v_t, rel=1e-9)
    assert rec.spin_rad_s[-1] == pytest.approx(spin, rel=1e-9)


@pytest.mark.parametrize(("angle", "regime"), ANGLES)
def test_injected_explicit_reproduces_the_rigid_reference(angle, regime):
    out, _ = compare("pybullet", Oblique(angle_deg=angle), "injected",
                     RunSettings(options={"injection": "explicit"}))
    assert out["status"] == "ok", out["message"]
    for key, tol in EXPLICIT_TOLERANCE.items():
        assert abs(out["rel_error"][key]) <= max(tol, 1e-9), (angle, key, out["rel_error"][key])
    assert out["regime"] == regime


def test_records_channels_are_the_momentum_the_engine_applied():
    # the lateral friction Bullet reports (on the plate, negated for the ball) sums to the
    # ball's tangential momentum change; backspin to start
    s = Oblique(angle_deg=45.0, spin_rad_s=-20.0)
    out, rec = compare("pybullet", s, "native", RunSettings())
    dt = rec.meta["timestep_s"]
    dv_t = rec.tangential_velocity_m_s[-1] - rec.tangential_velocity_m_s[0]
    assert rec.tangential_force_n.sum() * dt == pytest.approx(s.mass_kg * dv_t, rel=1e-9)
    dv_n = rec.penetration_rate_m_s[0] - rec.penetration_rate_m_s[-1]
    assert rec.normal_force_n.sum() * dt == pytest.approx(s.mass_kg * dv_n, rel=1e-9)
    assert abs(out["rel_error"]["spin_out_rad_s"]) < 1e-9


@pytest.mark.parametrize("angle", [20.0, 60.0])
def test_native_sticks_as_the_rigid_theory_and_records_the_friction_model(angle):
    out, rec = compare("pybullet", Oblique(angle_deg=angle), "native", RunSettings())
    assert out["status"] == "ok", out["message"]
    # stick: Bullet's velocity-level Coulomb is exact (measured 2e-15); the normal part is
    # the ball's native contact with Bullet's implicit step (e 0.8950 for the reference's
    # 0.8885 / 0.9375 at 20° / 60°)
    assert abs(out["rel_error"]["tangential_restitution"]) < 1e-9
    assert abs(out["rel_error"]["spin_out_rad_s"]) < 1e-9
    assert out["restitution"] == pytest.approx(0.8950, abs=1e-3)
    facts = rec.meta["engine_defaults"]
    assert facts["friction_combination"] == "product"
    assert facts["friction_ball"] == 0.3 and facts["friction_plate"] == 1.0
    assert facts["friction_effective"] == pytest.approx(0.3)
    assert facts["frictionAnchor"] == 0 and "Coulomb" in facts["friction_model"]
    # one manifold point: the merging threshold (a 1e-12 one lets a rolling ball's points
    # pile up, each a full spring); the spin clamp lifted
    assert facts["contactBreakingThreshold"] == 0.01
    assert facts["maxJointVelocity_ball"] > 1e3


def test_default_at_the_customary_step_records_bullets_friction():
    out, _ = compare("pybullet", Oblique(angle_deg=60.0), "default",
                     RunSettings(timestep_s=CUSTOMARY_S))
    # the rigid default contact at 1/240 s: a one-step impulse, the ball sinks a step's worth
    assert out["status"] in ("ok", "implausible"), out["message"]
    assert math.isfinite(out["spin_out_rad_s"])
    facts = out["engine_defaults"]
    assert facts["friction_effective"] == pytest.approx(0.3)
    assert facts["friction_combination"] == "product"
    assert facts["contactStiffness"] == -1.0  # rigid, unset
    assert out["timestep_s"] == CUSTOMARY_S


def test_custom_keys_reach_the_engine():
    s = Oblique(angle_deg=20.0)
    settings = RunSettings(timestep_s=CUSTOMARY_S)
    params = {"lateralFriction": 0.5, "rollingFriction": 0.01, "frictionAnchor": 1}
    custom, _ = compare("pybullet", s, "custom",
                        RunSettings(timestep_s=CUSTOMARY_S, params=params))
    default, _ = compare("pybullet", s, "default", settings)
    assert custom["status"] in ("ok", "implausible"), custom["message"]
    facts = custom["engine_defaults"]  # read back with getDynamicsInfo
    assert facts["friction_ball"] == 0.5 and facts["friction_effective"] == pytest.approx(0.5)
    assert facts["rollingFriction_ball"] == pytest.approx(0.01)
    assert facts["rollingFriction_pair"] == pytest.approx(0.01)  # r_ball·μ_plate + r_plate·μ_ball
    assert facts["frictionAnchor"] == 1 and "anchor" in facts["friction_model"]
    assert custom["params"] == params
    assert custom["spin_out_rad_s"] != default["spin_out_rad_s"]


@pytest.mark.parametrize(("params", "match"), [
    ({"frictionAnchor": 2}, "param frictionAnchor"),
    ({"lateralFriction": -0.1}, "param lateralFriction"),
    ({"rollingFriction": "x"}, "param rollingFriction"),
])
def test_bad_custom_values_are_one_line_errors(params, match):
    with pytest.raises(ValueError, match=match) as info:
        get_adapter("pybullet").run(Oblique(), "custom", RunSettings(params=params))
    assert "\n" not in str(info.value)


def test_oblique_keys_are_refused_on_the_ball():
    from impactbench.reference.scenarios import BallOnPlate

    with pytest.raises(ValueError, match="applies to the oblique scenario only"):
        get_adapter("pybullet").run(BallOnPlate(), "custom",
                                    RunSettings(params={"lateralFriction": 0.5}))


def test_tuned_with_the_balls_parameters_is_unsupported_with_a_reason():
    # oblique tuned reads friction knobs (impactbench.engines.oblique_tuned); a ball's
    # parameters are refused, and none at all too (tests/impactbench/test_oblique_tuned.py)
    out, _ = compare("pybullet", Oblique(), "tuned",
                     RunSettings(tuned={"contact_stiffness": 1e8}))
    assert out["status"] == "unsupported"
    assert "not pybullet's oblique friction" in out["message"]
