"""DART adapter, oblique impact (issue 22): the paper's steel ball at 2 m/s, μ = 0.3, a sphere
with its own moment of inertia on a planar joint (z, x, rotation about y), through
``evaluate.compare`` (real engine, no mocks).

Injected (no collision; the normal law and ideal Coulomb friction as joint forces and torque)
must reproduce the rigid-Coulomb reference. Native is DART's rigid LCP contact, whose boxed
Coulomb friction gives the rigid theory with the contact's own restitution (the native e at
1 m/s); the tangential force is DART's own ``Contact.force``.
"""

from __future__ import annotations

import math

import pytest
from conftest import require_engine

require_engine("dart")

import oblique_cases  # noqa: E402
from impactbench.engines.base import RunSettings, get_adapter  # noqa: E402
from impactbench.reference.oblique import Oblique  # noqa: E402
from impactbench.reference.record import Status  # noqa: E402
from oblique_cases import CASES, check_injected  # noqa: E402

ENGINE = "dart"

# |rel err| against the rigid reference, injected, default step 1e-6 s: about 3× the worst
# measured over CASES on this machine (dartpy 6.20), the measurement in each comment.
INJECTED_TOL = {
    "restitution": 1.0e-4,  # 3.39e-5 (20°): the normal law's semi-implicit Euler stepping
    "tangential_restitution": 2.3e-7,  # 7.57e-8 (80°; stick: round-off)
    "rebound_angle_deg": 1.0e-4,  # 3.21e-5 (20°)
    "spin_out_rad_s": 2.0e-6,  # 6.48e-7 (80°)
    "peak_tangential_force_n": 0.11,  # 3.70e-2 (45°, ω0 = 60: the slip stops within a step
    # of a steeply rising normal force; 1.84e-2 at 20°, ≤ 1.6e-3 otherwise)
}
BETA_TOL = 7e-7  # |Δβ| (contact-point ratio, absolute): 2.37e-7 (80°)

NATIVE_TOL = 5e-5  # DART's rigid Coulomb (its constraint mixing): measured ≤ 1.45e-5 (20°)


def run(mode: str, angle: float = 45.0, spin: float = 0.0, **settings):
    return oblique_cases.run(ENGINE, mode, angle, spin, **settings)


@pytest.mark.parametrize(("angle", "spin"), CASES)
def test_injected_reproduces_the_rigid_reference(angle, spin):
    out, rec = run("injected", angle, spin)
    check_injected(out, INJECTED_TOL, BETA_TOL)
    assert rec.tangential_force_n is not None and rec.spin_rad_s is not None


def test_native_is_rigid_coulomb_with_its_own_restitution():
    out, rec = run("native", 45.0)  # stick: rolling after, e_t = 5/7 whatever e is
    assert out["status"] == "ok"
    assert out["restitution"] == pytest.approx(0.937476, rel=1e-4)  # e at 1 m/s, less CFM
    assert out["tangential_restitution"] == pytest.approx(5.0 / 7.0, rel=NATIVE_TOL)
    assert abs(out["rel_error"]["spin_out_rad_s"]) <= NATIVE_TOL
    facts = rec.meta["engine_defaults"]
    assert facts["friction_effective"] == 0.3 and facts["friction_combination"] == "min"
    out, _ = run("native", 80.0)  # slide: Δv_t = μ·(1 + e)·v_n with the contact's own e
    expected = 1.0 - 0.3 * (1.0 + out["restitution"]) / math.tan(math.radians(80.0))
    assert out["tangential_restitution"] == pytest.approx(expected, rel=1e-5)


def test_the_tangential_force_is_darts_own_contact_force():
    """Σ F_t·dt over the contact step is m·Δv_t: the friction impulse DART reports."""
    s = Oblique(angle_deg=45.0)
    rec = get_adapter(ENGINE).run(s, "native", RunSettings())
    # a rigid contact's step carries two samples at one instant (before and after the jump)
    impulse = float(rec.tangential_force_n.sum()) * rec.meta["timestep_s"] / 2.0
    dv = rec.tangential_velocity_m_s[-1] - s.tangential_velocity_m_s
    assert impulse == pytest.approx(s.mass_kg * dv, rel=1e-6)


def test_default_is_dart_out_of_the_box_with_the_scenarios_friction():
    out, rec = run("default", 45.0)
    assert out["status"] == "ok"
    assert out["restitution"] < 0.01  # restitution 0 (the error reduction's ~1e-3 m/s push)
    assert out["tangential_restitution"] == pytest.approx(5.0 / 7.0, rel=NATIVE_TOL)
    assert rec.meta["engine_defaults"]["friction_coeff"] == 1.0  # DART's, replaced by μ
    assert rec.meta["engine_defaults"]["friction_effective"] == 0.3


def test_custom_applies_darts_own_keys():
    params = {"friction_coeff": 0.0, "restitution_coeff": 0.9}
    out, rec = run("custom", 45.0, params=params)
    assert out["status"] == "ok"
    assert out["tangential_restitution"] == pytest.approx(1.0, abs=1e-9)
    assert out["spin_out_rad_s"] == pytest.approx(0.0, abs=1e-9)
    assert out["restitution"] == pytest.approx(0.9, rel=1e-4)
    assert rec.meta["params"] == params
    adapter = get_adapter(ENGINE)
    with pytest.raises(ValueError, match="friction_coeff"):
        adapter.run(Oblique(), "custom", RunSettings(params={"friction_coeff": -0.1}))
    with pytest.raises(ValueError, match="valid keys"):
        adapter.run(Oblique(), "custom", RunSettings(params={"mu": 0.3}))


def test_tuned_with_the_balls_parameters_is_unsupported_with_a_reason():
    # oblique tuned reads friction knobs (impactbench.engines.oblique_tuned); a ball's
    # parameters are refused, and none at all too (tests/impactbench/test_oblique_tuned.py)
    rec = get_adapter(ENGINE).run(Oblique(), "tuned",
                                  RunSettings(tuned={"restitution_coeff": 0.9}))
    assert rec.status is Status.UNSUPPORTED
    assert "not dart's oblique friction" in rec.message
