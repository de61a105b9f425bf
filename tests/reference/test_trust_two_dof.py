"""The 2-DOF reference always ends: a body 2 far lighter than body 1 (its vibration far faster
than the contact) stops on a step budget with status max_time and a message saying why,
instead of computing for hours; ordinary runs stay well inside the budgets."""

from __future__ import annotations

import time

import pytest
from impactbench.reference import two_dof, two_dof_fast
from impactbench.reference.record import Status
from impactbench.reference.scenarios import RigidFlexible


def test_kernel_stops_on_its_step_budget_for_a_vanishing_body_2() -> None:
    # m2 = 1e-30 kg: √((k1+k2)/m2) = 4.5e17 rad/s against the contact's 100 rad/s; before
    # the budget this ran for ever (1e-12 kg: 100 s)
    t0 = time.monotonic()
    r = two_dof.solve(RigidFlexible(m2_kg=1e-30))
    assert time.monotonic() - t0 < 60  # the budget: ~4 s here (two_dof_fast.MAX_STEPS)
    assert r["status"] == "max_time"
    assert "step budget" in r["message"] and "max_time_s = 10 s" in r["message"]
    raw = two_dof_fast.run(RigidFlexible(m2_kg=1e-30))
    assert raw[two_dof_fast.RESULTS.index("steps")] == two_dof_fast.MAX_STEPS


def test_ordinary_runs_stay_far_inside_the_kernel_budget() -> None:
    # the rigid-wall limit is the costliest case the tests run (3.1e5 steps, measured)
    raw = two_dof_fast.run(RigidFlexible(velocity_m_s=0.5, k2_n_per_m=1e13))
    steps = raw[two_dof_fast.RESULTS.index("steps")]
    assert raw[0] == 0 and steps < two_dof_fast.MAX_STEPS / 5
    r = two_dof.solve(RigidFlexible())
    assert r["status"] == "ok" and r["message"] == ""


def test_simulate_stops_on_its_step_budget(monkeypatch: pytest.MonkeyPatch) -> None:
    # the paper's base case takes ~1.3e3 scipy steps at m2 = 0.1 kg (measured): a budget of
    # 200 stops it inside the first contact, with what it computed so far
    monkeypatch.setattr(two_dof, "MAX_STEPS", 200)
    rec = two_dof.simulate(RigidFlexible(m2_kg=0.1))
    assert rec.status is Status.MAX_TIME
    assert rec.message.startswith("step budget of 2e+02 steps spent at t = ")
    assert "times the contact's" in rec.message
    assert 0.0 < rec.time_s[-1] < 0.05 and len(rec) > 2


def test_simulate_within_budget_is_unchanged() -> None:
    # the same run with the real budget ends ok (the budget only cuts spans past it)
    rec = two_dof.simulate(RigidFlexible(m2_kg=0.1))
    assert rec.status is Status.OK and rec.message == ""
