"""The cube-toss builder of the adapters (the one door): a user's cube reaches the engine, and
an engine that ignored it would be caught, not scored."""

from __future__ import annotations

import pytest
from conftest import require_engine
from impactbench.engines.base import RunSettings, get_adapter, run_safely
from impactbench.reference.record import Status

from impactbench import scenarios

BOX = {"half_width_m": 0.05, "mass_kg": 0.5, "inertia_kg_m2": 0.0009, "tosses": "0"}
"""A cube other than DAIR's (h, m, I of a 10 cm, 0.5 kg box, not uniform: I ≠ m(2h)²/6)."""


def test_a_users_cube_reaches_the_engine() -> None:
    require_engine("pybullet")
    cube = scenarios.get("cube-toss").build(parameters=BOX)
    rec = get_adapter("pybullet").run(cube, "default", RunSettings())
    assert rec.status is Status.OK, rec.message
    assert rec.meta["engine_setup"]["cube_inertia_kg_m2"] == pytest.approx(0.0009, rel=1e-9)
    assert list(rec.meta["poses"]) == [0]


def test_an_engine_that_ignores_the_cube_is_a_crash_not_a_score(monkeypatch) -> None:
    require_engine("pybullet")
    from impactbench.engines import cube_toss

    built = cube_toss.PyBulletCube.describe

    def wrong(self):  # the engine built DAIR's inertia whatever it was given
        return {**built(self), "cube_inertia_kg_m2": 0.00081}

    monkeypatch.setattr(cube_toss.PyBulletCube, "describe", wrong)
    cube = scenarios.get("cube-toss").build(parameters=BOX)
    rec = run_safely("pybullet", cube, "default", RunSettings())
    assert rec.status is Status.CRASHED
    assert "built the cube with I = 0.00081 kg·m², not the given 0.0009" in rec.message
