"""PyBullet clients reused between runs (engines/pybullet_clients.py): a run on a reused,
reset client records what it records on a new one, bit for bit, in every scenario and mode —
after a ``custom`` run that set every engine key, sub-steps included, on that client."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import require_engine
from impactbench.engines import pybullet_clients
from impactbench.engines.base import RunSettings, get_adapter
from impactbench.reference.bounce_scenario import Bounce
from impactbench.reference.oblique import Oblique
from impactbench.reference.scenarios import BallOnPlate, RigidFlexible

DIRTY = {"restitution": 0.9, "linearDamping": 0.3, "restitutionVelocityThreshold": 0.7,
         "erp": 0.5, "contactERP": 0.6, "numSolverIterations": 3, "useSplitImpulse": 1,
         "splitImpulsePenetrationThreshold": 0.01, "contactSlop": 0.002,
         "contactBreakingThreshold": 0.05, "numSubSteps": 3}
"""A ``custom`` ball run's keys: every engine key pybullet_adapter passes on, none at its
default, so whatever a reset left behind would show in the next run."""

RUNS = [
    (BallOnPlate(velocity_m_s=2.0), "native", RunSettings(timestep_s=1e-5)),
    (BallOnPlate(velocity_m_s=2.0), "injected", RunSettings(timestep_s=1e-5)),
    (BallOnPlate(velocity_m_s=2.0), "default", RunSettings(timestep_s=1 / 240, phase=0.3)),
    (BallOnPlate(velocity_m_s=0.5), "custom",
     RunSettings(timestep_s=1 / 240, params={"restitution": 0.8})),
    (RigidFlexible(), "native", RunSettings()),
    (Oblique(), "native", RunSettings(timestep_s=1e-5)),
    (Oblique(), "default", RunSettings(timestep_s=1e-4)),
    (Bounce(), "default", RunSettings(timestep_s=1 / 240)),
]


@pytest.fixture(scope="module")
def adapter():
    require_engine("pybullet")
    return get_adapter("pybullet")


def _same(a, b) -> None:
    assert (a.status, a.message) == (b.status, b.message)
    for name in ("time_s", "penetration_m", "penetration_rate_m_s", "normal_force_n",
                 "velocity_1_m_s", "velocity_2_m_s", "displacement_2_m"):
        x, y = getattr(a, name, None), getattr(b, name, None)
        assert (x is None) == (y is None), name
        assert x is None or np.array_equal(x, y, equal_nan=True), name
    strip = ("wall_s", "loop_wall_s")
    assert repr({k: v for k, v in a.meta.items() if k not in strip}) == \
        repr({k: v for k, v in b.meta.items() if k not in strip})


@pytest.mark.parametrize("index", range(len(RUNS)), ids=lambda i: f"{RUNS[i][0].name}-"
                         f"{RUNS[i][1]}")
def test_a_reused_client_records_what_a_new_one_does(adapter, monkeypatch, index) -> None:
    scenario, mode, settings = RUNS[index]
    with monkeypatch.context() as fresh:  # no client kept: each run connects anew
        fresh.setattr(pybullet_clients, "IDLE_MAX", 0)
        fresh.setattr(pybullet_clients, "_idle", [])
        new = adapter.run(scenario, mode, settings)
        assert pybullet_clients.idle_count() == 0
    dirty = adapter.run(BallOnPlate(velocity_m_s=1.0), "custom",
                        RunSettings(timestep_s=1e-3, params=DIRTY))
    assert "engine_defaults" in dirty.meta, dirty.message  # it built its world and ran
    kept = pybullet_clients.idle_count()
    assert kept >= 1  # the dirtied client waits for the next run
    reused = adapter.run(scenario, mode, settings)
    assert pybullet_clients.idle_count() == kept  # taken and given back, none new
    _same(new, reused)


def test_the_kept_clients_are_bounded(adapter) -> None:
    """Runs one after another share one client; a process never keeps more than IDLE_MAX."""
    import pybullet as p

    for _ in range(3):
        adapter.run(BallOnPlate(), "default", RunSettings(timestep_s=1 / 240))
    assert 1 <= pybullet_clients.idle_count() <= pybullet_clients.IDLE_MAX
    extra = [pybullet_clients.acquire(p) for _ in range(pybullet_clients.IDLE_MAX + 2)]
    for cid in extra:
        pybullet_clients.release(p, cid)
    assert pybullet_clients.idle_count() == pybullet_clients.IDLE_MAX
