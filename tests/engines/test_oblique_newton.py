"""Newton adapter, oblique impact (issue 22): the paper's steel ball at 2 m/s, μ = 0.3, a sphere
with its own moment of inertia on a D6 joint (z, x, rotation about y), Featherstone with one
warp CPU graph launch per step, through ``evaluate.compare`` (real engine, no mocks).

Injected (the normal law through Newton's contact, ke = the law's secant; Coulomb friction
through Newton's own friction, mu = μ and kf = m_s/dt, ideal Coulomb for the step) must
reproduce the rigid-Coulomb reference. Native is Newton's penalty contact with the ball's
native ke, kd and the same friction. Newton reports no contact force: both forces are
m·Δv/dt.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import require_engine

require_engine("newton")

import oblique_cases  # noqa: E402
from impactbench.engines import newton_adapter  # noqa: E402
from impactbench.engines.base import RunSettings, get_adapter  # noqa: E402
from impactbench.reference.oblique import Oblique  # noqa: E402
from impactbench.reference.record import Status  # noqa: E402
from oblique_cases import CASES, check_injected  # noqa: E402

ENGINE = "newton"

# |rel err| against the rigid reference, injected, default step 1e-6 s: about 3× the worst
# measured over CASES on this machine (newton 1.8 on warp, float32), the measurement in each
# comment.
INJECTED_TOL = {
    "restitution": 1.1e-4,  # 3.50e-5 (20°): the normal law's semi-implicit Euler stepping
    "tangential_restitution": 9.0e-7,  # 2.99e-7 (60°): float32 velocities
    "rebound_angle_deg": 1.0e-4,  # 3.33e-5 (20°)
    "spin_out_rad_s": 2.5e-6,  # 8.38e-7 (80°)
    "peak_tangential_force_n": 0.11,  # 3.70e-2 (45°, ω0 = 60: the slip stops within a step
    # of a steeply rising normal force; 1.84e-2 at 20°, ≤ 1.6e-3 otherwise)
}
BETA_TOL = 1.1e-6  # |Δβ| (contact-point ratio, absolute): 3.70e-7 (80°)

NATIVE_STICK_TOL = 1e-6  # native e_t and spin at 20–60°: measured ≤ 3.21e-7 (45°)


def run(mode: str, angle: float = 45.0, spin: float = 0.0, **settings):
    return oblique_cases.run(ENGINE, mode, angle, spin, **settings)


@pytest.mark.parametrize(("angle", "spin"), CASES)
def test_injected_reproduces_the_rigid_reference(angle, spin):
    out, rec = run("injected", angle, spin)
    check_injected(out, INJECTED_TOL, BETA_TOL)
    assert rec.meta["kf"] == pytest.approx(0.1 / 3.5 / 1e-6)  # m_s/dt
    assert "graph" in rec.meta["stepping"]


def test_graph_and_step_by_step_records_are_identical():
    s = Oblique(angle_deg=60.0)
    settings = RunSettings(timestep_s=1e-6)
    for mode in ("native", "injected"):
        a = newton_adapter.run_oblique(s, mode, settings)
        b = newton_adapter.run_oblique(s, mode, settings, graphs=False)
        for name in ("penetration_m", "normal_force_n", "tangential_velocity_m_s",
                     "spin_rad_s", "tangential_force_n"):
            assert np.array_equal(getattr(a, name), getattr(b, name)), (mode, name)


def test_native_penalty_contact_with_newtons_friction():
    out, rec = run("native", 45.0)  # stick: rolling after, e_t = 5/7 whatever e is
    assert out["status"] == "ok"
    assert out["restitution"] == pytest.approx(0.9366, abs=1e-3)  # its law's e at 2 m/s·cos θ
    assert abs(out["rel_error"]["tangential_restitution"]) <= NATIVE_STICK_TOL
    assert abs(out["rel_error"]["spin_out_rad_s"]) <= NATIVE_STICK_TOL
    facts = rec.meta["engine_defaults"]
    assert rec.meta["mu"] == 0.3 and facts["friction_effective"] == 0.3
    assert facts["friction_combination"] == "average"
    out, _ = run("native", 80.0)  # slide: Δv_t = μ·(1 + e)·v_n with the contact's own e
    expected = 1.0 - 0.3 * (1.0 + out["restitution"]) / math.tan(math.radians(80.0))
    assert out["tangential_restitution"] == pytest.approx(expected, rel=3.3e-5)  # 1.1e-5


def test_default_is_newtons_shape_config_with_the_scenarios_friction():
    out, rec = run("default", 45.0)
    assert out["status"] == "ok"
    assert out["restitution"] == pytest.approx(0.147, abs=1e-3)  # ke 2.5e3, kd 100
    assert out["tangential_restitution"] == pytest.approx(5.0 / 7.0, rel=3e-6)  # 8.6e-7
    facts = rec.meta["engine_defaults"]
    assert {k: facts[k] for k in ("ke", "kd", "mu")} == {"ke": 2.5e3, "kd": 100.0, "mu": 1.0}
    assert facts["kf"] == 1e3 and facts["friction_effective"] == 0.3


def test_custom_applies_newtons_own_keys():
    out, rec = run("custom", 45.0, params={"mu": 0.0, "ke": 1e8})
    assert out["status"] == "ok"
    assert out["tangential_restitution"] == pytest.approx(1.0, abs=1e-6)
    assert out["spin_out_rad_s"] == pytest.approx(0.0, abs=1e-6)
    assert rec.meta["params"] == {"mu": 0.0, "ke": 1e8}
    adapter = get_adapter(ENGINE)
    with pytest.raises(ValueError, match="kf"):
        adapter.run(Oblique(), "custom", RunSettings(params={"kf": -1.0}))
    with pytest.raises(ValueError, match="valid keys"):
        adapter.run(Oblique(), "custom", RunSettings(params={"friction": 0.3}))


def test_tuned_with_the_balls_parameters_is_unsupported_with_a_reason():
    # oblique tuned reads friction knobs (impactbench.engines.oblique_tuned); a ball's
    # parameters are refused, and none at all too (tests/impactbench/test_oblique_tuned.py)
    rec = get_adapter(ENGINE).run(Oblique(), "tuned", RunSettings(tuned={"ke": 1e8}))
    assert rec.status is Status.UNSUPPORTED
    assert "not newton's oblique friction" in rec.message
