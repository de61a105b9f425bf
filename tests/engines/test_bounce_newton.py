"""Newton's bounce to rest (real engine: warp on CPU, float32, Featherstone; no mocks).

The ball released from rest falls, hits Newton's ground plane and is followed to rest or the
time cap at the customary step 1/1200 s (Newton's Featherstone contact example: 60 fps, 20
substeps). Checks: the free fall to the first contact, the recorded force against Newton's own
contact law ke·x + kd·max(ẋ, 0), the first apex against the law's restitution
(:func:`~impactbench.engines.newton_adapter.approach_damped_restitution`), the end rule
(settled, tunnelled, diverged), every mode's record, and the captured-graph stepping against
the eager path and other chunk lengths, bit for bit. Tolerances are about 3× the error
measured on this machine, the measurement in a comment next to each.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import require_engine
from impactbench.engines import newton_adapter
from impactbench.engines.base import RunSettings, get_adapter
from impactbench.engines.newton_adapter import approach_damped_restitution
from impactbench.reference.bounce_scenario import Bounce
from impactbench.reference.record import Status
from scipy import optimize


@pytest.fixture(autouse=True, scope="module")
def _newton_installed() -> None:
    """Newton is imported when this file's tests run, not when it is collected: every test
    process collects every file, and importing Newton costs ~3 s of CPU."""
    require_engine("newton")


DT = 1.0 / 1200.0
ARRAYS = ("time_s", "penetration_m", "penetration_rate_m_s", "normal_force_n",
          "velocity_1_m_s")


def run(scenario: Bounce, mode: str, **settings):
    return get_adapter("newton").run(scenario, mode, RunSettings(**settings))


def first_apex_m(rec) -> float:
    """max(−x) between the end of the first contact and the start of the second (m)."""
    on = rec.normal_force_n > 0.0
    first = int(np.flatnonzero(on)[0])
    leave = first + int(np.flatnonzero(~on[first:])[0])
    again = np.flatnonzero(on[leave:])
    assert again.size, "no second contact before the cap"
    return float(np.max(-rec.penetration_m[leave:leave + int(again[0])]))


def custom_for(restitution: float, ke: float, mass_kg: float) -> dict[str, float]:
    """Newton's ``ke``, ``kd`` with this restitution (damping only while approaching)."""
    zeta = optimize.brentq(lambda z: approach_damped_restitution(z) - restitution,
                           0.0, 1.0 - 1e-12, xtol=1e-15)
    return {"ke": ke, "kd": 2.0 * zeta * math.sqrt(ke * mass_kg)}


def test_the_bounce_runs_at_the_customary_step_of_newtons_contact_example():
    assert get_adapter("newton").default_timestep_s(Bounce(), "native") == DT


def test_default_drop_falls_freely_touches_on_time_and_settles():
    s = Bounce(max_time_s=2.0)
    rec = run(s, "default")
    assert rec.status is Status.OK, rec.message
    assert rec.meta["settled"] is True
    assert rec.meta["timestep_s"] == DT
    assert rec.time_s[-1] < s.max_time_s
    assert np.all(np.diff(rec.time_s) == pytest.approx(DT, rel=1e-9))
    assert rec.meta["steps"] == len(rec.time_s) - 1  # every step recorded, and the end state
    assert rec.meta["engine_defaults"] == {"ke": 2.5e3, "kd": 100.0, "kf": 1e3, "mu": 1.0}
    assert "bounce_threshold_m_s" not in rec.meta  # Featherstone's penalty contact has none
    # released at rest h above the plane (float32 q: 0.2 to 3e-9 m)
    assert rec.penetration_m[0] == pytest.approx(-s.height_m, abs=1e-8)
    assert rec.penetration_rate_m_s[0] == 0.0
    first = int(np.flatnonzero(rec.normal_force_n > 0.0)[0])
    assert abs(rec.time_s[first] - s.fall_time_s) <= DT
    assert np.all(rec.penetration_m[:first] < 0.0)
    # semi-implicit Euler: v_k = g·dt·k; measured −0.14 % at the first contact sample
    assert rec.penetration_rate_m_s[first] == pytest.approx(s.impact_velocity_m_s, rel=5e-3)


def test_recorded_force_is_newtons_contact_law_and_carries_the_weight_at_rest():
    s = Bounce(max_time_s=2.0)
    rec = run(s, "default")
    x, v, f = rec.penetration_m, rec.penetration_rate_m_s, rec.normal_force_n
    on = f > 0.0
    np.testing.assert_array_equal(on[:-1], x[:-1] > 0.0)  # the kernel's test, at step start
    law = 2.5e3 * x[on] + 100.0 * np.maximum(v[on], 0.0)  # ShapeConfig ke, kd
    # m·Δv/dt in float32 velocities: measured max |F − law| 8.0e-6 N over 144 samples
    np.testing.assert_allclose(f[on], law, rtol=0.0, atol=2.5e-5)
    # at rest the contact carries the weight (measured 1.1e-3 relative: still creeping in
    # against kd)
    assert f[-2] == pytest.approx(s.mass_kg * s.gravity_m_s2, rel=3e-3)


@pytest.mark.parametrize(("ke", "timestep_s", "rel"), [
    (1e4, DT, 0.13),  # measured −4.19e-2: the explicit step's damping, 12 steps in contact
    (1e5, 1e-4, 3.5e-3),  # measured +1.13e-3 (→ −3.3e-3 as dt → 0: gravity during contact)
])
def test_custom_restitution_gives_the_first_apex_e_squared_h(ke, timestep_s, rel):
    s = Bounce(max_time_s=0.7)
    params = custom_for(0.9, ke, s.mass_kg)
    rec = run(s, "custom", timestep_s=timestep_s, params=params)
    assert rec.meta["params"] == params
    assert first_apex_m(rec) == pytest.approx(0.81 * s.height_m, rel=rel)


def test_a_plate_too_soft_to_stop_the_ball_is_tunneled():
    s = Bounce(max_time_s=0.5)
    rec = run(s, "custom", params={"ke": 1e3, "kd": 0.0})  # x_max ≈ V0·√(m/ke) ≈ 20 mm > R
    assert rec.status is Status.TUNNELED, rec.message
    assert rec.penetration_m[-1] > s.radius_m
    assert rec.time_s[-1] < s.max_time_s


@pytest.mark.parametrize("mode", ["native", "injected", "tuned", "default", "custom"])
def test_every_mode_returns_a_record_with_a_status(mode):
    s = Bounce(max_time_s=0.3)
    tuned = {"ke": 1.41e8, "kd": 504.0}  # the ball's tuned file, rounded
    rec = run(s, mode, tuned=tuned if mode == "tuned" else None,
              params={"ke": 1e4, "kd": 4.0} if mode == "custom" else None)
    assert isinstance(rec.status, Status)
    assert rec.meta["mode"] == mode and rec.meta["steps"] == len(rec.time_s) - 1
    if mode in ("native", "injected", "tuned"):
        # ke ~1e8 N/m: ωn·dt ≈ 30 ≫ 2, the explicit step gains energy on the first contact
        assert rec.status is Status.DIVERGED, rec.message
    else:
        assert rec.status in (Status.OK, Status.MAX_TIME), rec.message


def test_tuned_without_a_file_is_unsupported():
    rec = run(Bounce(max_time_s=0.3), "tuned")
    assert rec.status is Status.UNSUPPORTED


def test_graph_stepping_equals_the_eager_path_and_any_chunk_length(monkeypatch):
    s = Bounce(height_m=0.01, max_time_s=0.08)  # 96 steps, in contact from step 54
    settings = RunSettings(timestep_s=DT)
    graphs = newton_adapter.run_bounce(s, "default", settings)
    eager = newton_adapter.run_bounce(s, "default", settings, graphs=False)
    monkeypatch.setattr(newton_adapter, "BOUNCE_CHUNK_S", 7 * DT)
    chunked = newton_adapter.run_bounce(s, "default", settings)
    assert np.any(graphs.normal_force_n > 0.0)
    for name in ARRAYS:
        np.testing.assert_array_equal(getattr(eager, name), getattr(graphs, name))
        np.testing.assert_array_equal(getattr(chunked, name), getattr(graphs, name))
    assert graphs.status is eager.status is chunked.status is Status.MAX_TIME
