"""pymunk adapter, oblique impact (issue 22): the paper's steel ball at 2 m/s, μ = 0.3, as a
circle with the sphere's moment of inertia (2/5)·m·R² (the impact is planar, so the circle
carries the sphere's motion exactly; ``shape = "disc"``: the disc's m·R²/2 against the disc's
references), through ``evaluate.compare`` (real engine, no mocks).

Injected (the normal law as a penalty force, ideal Coulomb friction as a force and torque,
the contact rejected) must reproduce the rigid-Coulomb reference; native is pymunk's own
rigid contact, whose Coulomb friction gives the rigid theory exactly with the contact's own
restitution (the native e at 1 m/s).
"""

from __future__ import annotations

import math

import pytest
from conftest import require_engine

require_engine("pymunk")

import oblique_cases  # noqa: E402
from impactbench.engines.base import RunSettings, get_adapter  # noqa: E402
from impactbench.reference.oblique import Oblique  # noqa: E402
from impactbench.reference.record import Status  # noqa: E402
from impactbench.reference.scenarios import BallOnPlate  # noqa: E402
from oblique_cases import CASES, check_injected  # noqa: E402

ENGINE = "pymunk"

# |rel err| against the rigid reference, injected, default step 1e-6 s: about 3× the worst
# measured over CASES on this machine (pymunk 7.3.1), the measurement in each comment.
INJECTED_TOL = {
    "restitution": 1.0e-4,  # 3.39e-5 (20°): the normal law's drift–kick stepping
    "tangential_restitution": 2.3e-7,  # 7.57e-8 (80°)
    "rebound_angle_deg": 1.0e-4,  # 3.21e-5 (20°)
    "spin_out_rad_s": 2.0e-6,  # 6.48e-7 (80°)
    "peak_tangential_force_n": 0.11,  # 3.70e-2 (45°, ω0 = 60: the slip stops within a step
    # of a steeply rising normal force; 1.84e-2 at 20°, ≤ 1.6e-3 otherwise)
}
BETA_TOL = 7e-7  # |Δβ| (contact-point ratio, absolute): 2.37e-7 (80°)

NATIVE_TOL = 1e-9  # rigid Coulomb friction in pymunk's rigid contact: measured ≤ 3.3e-14


def run(mode: str, angle: float = 45.0, spin: float = 0.0, **settings):
    return oblique_cases.run(ENGINE, mode, angle, spin, **settings)


@pytest.mark.parametrize(("angle", "spin"), CASES)
def test_injected_reproduces_the_rigid_reference(angle, spin):
    out, rec = run("injected", angle, spin)
    check_injected(out, INJECTED_TOL, BETA_TOL)
    assert rec.tangential_force_n is not None and rec.spin_rad_s is not None
    assert rec.meta["contact"] == "penalty"


def test_injected_through_the_rigid_contact_is_the_rigid_theory():
    """``injection = "restitution"``: pymunk's own contact and Coulomb friction with the law's
    restitution k(b·ẋ) — the rigid reference to round-off (measured ≤ 3.3e-14)."""
    for angle in (20.0, 80.0):
        out, _ = run("injected", angle, options={"injection": "restitution"})
        assert out["status"] == "ok"
        for key in ("restitution", "tangential_restitution", "spin_out_rad_s"):
            assert abs(out["rel_error"][key]) <= NATIVE_TOL, (angle, key)


def test_native_is_rigid_coulomb_with_its_own_restitution():
    out, rec = run("native", 45.0)  # stick: rolling after, e_t = 5/7 whatever e is
    assert out["status"] == "ok"
    assert out["tangential_restitution"] == pytest.approx(5.0 / 7.0, rel=NATIVE_TOL)
    assert out["rel_error"]["spin_out_rad_s"] == pytest.approx(0.0, abs=NATIVE_TOL)
    facts = rec.meta["engine_defaults"]
    assert facts["friction_effective"] == 0.3 and facts["friction_combination"] == "product"
    assert (facts["friction_ball"], facts["friction_plate"]) == (0.3, 1.0)
    assert "peak_tangential_force_n" in rec.meta["not_comparable"]
    out, _ = run("native", 80.0)  # slide: Δv_t = μ·(1 + e)·v_n with the contact's own e
    e = out["restitution"]
    assert e == pytest.approx(0.937476, rel=1e-5)  # the reference's at 1 m/s
    expected = 1.0 - 0.3 * (1.0 + e) / math.tan(math.radians(80.0))
    assert out["tangential_restitution"] == pytest.approx(expected, rel=1e-9)


def test_default_is_pymunk_out_of_the_box_with_the_scenarios_friction():
    out, rec = run("default", 45.0)
    assert out["status"] == "ok"
    assert out["restitution"] == pytest.approx(0.0, abs=1e-9)  # elasticity 0 by default
    assert out["tangential_restitution"] == pytest.approx(5.0 / 7.0, rel=1e-9)
    assert rec.meta["engine_defaults"]["friction"] == 0.0  # pymunk's, replaced by μ
    assert rec.meta["engine_defaults"]["collision_slop"] == pytest.approx(0.1)
    assert rec.meta["engine_defaults"]["friction_effective"] == 0.3


def test_custom_applies_pymunks_own_keys():
    out, rec = run("custom", 45.0, params={"friction": 0.0, "elasticity": 0.9})
    assert out["status"] == "ok"
    assert out["tangential_restitution"] == pytest.approx(1.0, abs=1e-12)
    assert out["spin_out_rad_s"] == pytest.approx(0.0, abs=1e-9)
    assert out["restitution"] == pytest.approx(0.9, rel=1e-9)
    assert rec.meta["params"] == {"friction": 0.0, "elasticity": 0.9}
    adapter = get_adapter(ENGINE)
    with pytest.raises(ValueError, match="friction"):
        adapter.run(Oblique(), "custom", RunSettings(params={"friction": -1.0}))
    with pytest.raises(ValueError, match="valid keys"):
        adapter.run(Oblique(), "custom", RunSettings(params={"mu": 0.3}))
    with pytest.raises(ValueError, match="oblique scenario only"):  # head-on: no friction
        adapter.run(BallOnPlate(), "custom", RunSettings(params={"friction": 0.3}))


def test_tuned_is_unsupported_with_a_reason():
    rec = get_adapter(ENGINE).run(Oblique(), "tuned", RunSettings(tuned={"elasticity": 0.9}))
    assert rec.status is Status.UNSUPPORTED and "oblique" in rec.message


# ------------------------------------------------------------------ the disc (shape = "disc")

# |rel err| of the disc (k² = R²/2) against the disc's rigid reference, injected, default step
# 1e-6 s, over CASES: about 3× the worst measured on this machine (pymunk 7.3.1), the
# measurement in each comment — the sphere's own, but for the peak tangential force at 20°.
DISC_INJECTED_TOL = {
    "restitution": 1.0e-4,  # 3.39e-5 (20°)
    "tangential_restitution": 2.3e-7,  # 7.57e-8 (80°)
    "rebound_angle_deg": 1.0e-4,  # 3.23e-5 (20°)
    "spin_out_rad_s": 2.0e-6,  # 6.48e-7 (80°)
    "peak_tangential_force_n": 0.13,  # 4.42e-2 (20°: the slip stops within a step of a
    # steeply rising normal force; the sphere's worst there is 1.84e-2)
}
DISC_BETA_TOL = 6.1e-7  # |Δβ|: 2.03e-7 (80°)


def test_the_disc_is_a_circle_with_the_discs_moment_of_inertia():
    """Read back from pymunk's body: m·R²/2 for the disc, (2/5)·m·R² for the sphere."""
    from impactbench.engines.pymunk_adapter import oblique_model

    for shape, ratio in (("disc", 0.5), ("sphere", 0.4)):
        s = Oblique(shape=shape)
        for mode in ("native", "injected", "default"):
            model, meta = oblique_model(s, mode, RunSettings(timestep_s=1e-6), 1e-6, 10)
            assert model.body.moment == pytest.approx(ratio * s.mass_kg * s.radius_m**2,
                                                      rel=1e-12), (shape, mode)
            assert meta["engine_defaults"]["moment_of_inertia_kg_m2"] == pytest.approx(
                model.body.moment, rel=1e-12)


@pytest.mark.parametrize(("angle", "spin"), CASES)
def test_disc_injected_reproduces_the_discs_rigid_reference(angle, spin):
    out, rec = run("injected", angle, spin, shape="disc")
    check_injected(out, DISC_INJECTED_TOL, DISC_BETA_TOL)
    assert rec.meta["planar"] is True


def test_disc_native_rolls_at_two_thirds():
    """pymunk's rigid Coulomb contact on the disc: stick at 45° leaves it rolling with
    v_t' = (2/3)·v_t (the sphere's 5/7), whatever the restitution."""
    out, _ = run("native", 45.0, shape="disc")
    assert out["status"] == "ok"
    assert out["tangential_restitution"] == pytest.approx(2.0 / 3.0, rel=NATIVE_TOL)
    assert out["rel_error"]["spin_out_rad_s"] == pytest.approx(0.0, abs=NATIVE_TOL)
