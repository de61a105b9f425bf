"""Drake's oblique impact (issue 22) through the one metrics path
(:func:`impactbench.evaluate.compare`): injected (the normal law and Coulomb friction as
generalized forces, integrated by the continuous plant's RK3) against the rigid Coulomb
reference on both sides of the stick/slide threshold (63.9°), native (point contact with the
continuous plant's regularised friction) and default (the discrete plant) running and
recording their friction model, custom keys reaching the plant.

Tolerances are ~3× the errors measured on this machine (drake 1.51.1, dt 1e-6 s), written
beside them.
"""

from __future__ import annotations

import math

import pytest
from conftest import require_engine

require_engine("drake")

from impactbench.engines.base import RunSettings, get_adapter  # noqa: E402
from impactbench.reference.oblique import Oblique  # noqa: E402

from impactbench.evaluate import compare  # noqa: E402

# injected vs rigid, measured worst |rel err| over 20°, 45°, 60° (stick) and 80° (slide):
# restitution 4.8e-6 (20°), tangential restitution 7.3e-8 (80°), spin 6.2e-7 (80°), rebound
# angle 4.5e-6 (20°)
INJECTED_TOLERANCE = {"restitution": 1.5e-5, "tangential_restitution": 2.2e-7,
                      "spin_out_rad_s": 1.9e-6, "rebound_angle_deg": 1.4e-5}
# native vs rigid (regularised Stribeck friction, stiction tolerance 1e-4 m/s, chattering in
# the stick phase), measured: 20° tangential restitution −9.8e-4, spin +1.4e-3, rebound angle
# −9.5e-4; 60° −1.3e-4, −6.1e-4, −7.1e-5; restitution ≤ 2.1e-5 (d = b: exact restitution)
NATIVE_TOLERANCE = {"restitution": 6.3e-5, "tangential_restitution": 3e-3,
                    "spin_out_rad_s": 4.2e-3, "rebound_angle_deg": 2.9e-3}
CUSTOMARY_S = 1e-3


@pytest.fixture(scope="module")
def drake():
    return get_adapter("drake")


@pytest.mark.parametrize(("angle", "regime"), [(20.0, 0.0), (45.0, 0.0), (60.0, 0.0),
                                               (80.0, 1.0)])
def test_injected_reproduces_the_rigid_reference(angle, regime):
    out, rec = compare("drake", Oblique(angle_deg=angle), "injected", RunSettings())
    assert out["status"] == "ok", out["message"]
    for key, tol in INJECTED_TOLERANCE.items():
        assert abs(out["rel_error"][key]) <= tol, (angle, key, out["rel_error"][key])
    assert out["regime"] == regime
    assert rec.meta["engine_defaults"]["friction_combination"] == "none"


def test_injected_channels_are_the_momentum_applied():
    # the applied force's samples (step starts) sum to the momentum change up to RK3's stage
    # average (measured 1.5e-3: the step where the slip stops); backspin to start
    s = Oblique(angle_deg=45.0, spin_rad_s=-20.0)
    out, rec = compare("drake", s, "injected", RunSettings())
    dt = rec.meta["timestep_s"]
    dv_t = rec.tangential_velocity_m_s[-1] - rec.tangential_velocity_m_s[0]
    assert rec.tangential_force_n.sum() * dt == pytest.approx(s.mass_kg * dv_t, rel=4.5e-3)
    dv_n = rec.penetration_rate_m_s[0] - rec.penetration_rate_m_s[-1]
    assert rec.normal_force_n.sum() * dt == pytest.approx(s.mass_kg * dv_n, rel=1e-4)
    assert abs(out["rel_error"]["spin_out_rad_s"]) < 1e-5


@pytest.mark.parametrize("angle", [20.0, 60.0])
def test_native_is_the_regularised_friction_and_records_it(angle):
    out, rec = compare("drake", Oblique(angle_deg=angle), "native", RunSettings())
    assert out["status"] == "ok", out["message"]
    for key, tol in NATIVE_TOLERANCE.items():
        assert abs(out["rel_error"][key]) <= tol, (angle, key, out["rel_error"][key])
    facts = rec.meta["engine_defaults"]
    assert facts["friction_combination"] == "harmonic"
    assert facts["friction_effective"] == pytest.approx(0.3)  # read from the scene graph
    assert facts["stiction_tolerance_m_s"] == 1e-4 and "Stribeck" in facts["friction_model"]
    # the contact force sampled at step starts is the engine's output: in the stick phase
    # the regularised friction chatters between ±μ·F_n (documented in the adapter)
    ratio = rec.tangential_force_n[rec.normal_force_n > 0] / rec.normal_force_n[
        rec.normal_force_n > 0]
    assert max(abs(ratio)) == pytest.approx(0.3, rel=1e-6)


@pytest.mark.parametrize("dt", [None, CUSTOMARY_S])
def test_default_runs_the_discrete_plant_and_records_its_friction(dt):
    out, _ = compare("drake", Oblique(angle_deg=60.0), "default", RunSettings(timestep_s=dt))
    assert out["status"] in ("ok", "implausible"), out["message"]
    assert math.isfinite(out["spin_out_rad_s"]) and math.isfinite(out["rebound_angle_deg"])
    facts = out["engine_defaults"]
    assert facts["discrete_contact_approximation"] == "lagged"  # read back from the plant
    assert facts["stiction_tolerance_m_s"] == 1e-4
    assert facts["friction_effective"] == pytest.approx(0.3)
    # Drake's default point contact (from the penetration allowance) is nearly plastic
    assert out["restitution"] < 0.1
    assert out["timestep_s"] == (dt or 1e-6)


def test_custom_keys_reach_the_plant(drake):
    import pydrake.all as d

    params = {"discrete_contact_approximation": "sap", "stiction_tolerance": 1e-2}
    settings = RunSettings(timestep_s=CUSTOMARY_S, params=params)
    s = Oblique(angle_deg=20.0)
    model = drake.build(s, "custom", settings)
    assert model.plant.get_discrete_contact_approximation() == \
        d.DiscreteContactApproximation.kSap
    assert model.plant.time_step() == CUSTOMARY_S
    out, _ = compare("drake", s, "custom", settings)
    default, _ = compare("drake", s, "default", RunSettings(timestep_s=CUSTOMARY_S))
    assert out["status"] in ("ok", "implausible"), out["message"]
    facts = out["engine_defaults"]
    assert facts["discrete_contact_approximation"] == "sap"
    assert facts["stiction_tolerance_m_s"] == 1e-2
    assert out["params"] == params
    assert out["spin_out_rad_s"] != default["spin_out_rad_s"]


def test_bad_custom_values_are_one_line_errors():
    with pytest.raises(ValueError, match="param stiction_tolerance") as info:
        get_adapter("drake").run(Oblique(), "custom",
                                 RunSettings(params={"stiction_tolerance": -1.0}))
    assert "\n" not in str(info.value)


def test_tuned_with_the_balls_parameters_is_unsupported_with_a_reason():
    # oblique tuned reads friction knobs (impactbench.engines.oblique_tuned); a ball's
    # parameters are refused, and none at all too (tests/impactbench/test_oblique_tuned.py)
    out, _ = compare("drake", Oblique(), "tuned",
                     RunSettings(tuned={"point_stiffness_n_per_m": 1e8}))
    assert out["status"] == "unsupported"
    assert "not drake's oblique friction" in out["message"]
