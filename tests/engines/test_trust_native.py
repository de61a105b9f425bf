"""A nearly dead ball has no native mapping: a clipped linear spring–damper cannot bounce
below e(ζ = 0.7). That is bad input naming the field and the rule (it used to surface as
scipy's "f(a) and f(b) must have different signs", status ``crashed``); inside a report's
matrix it is one row that says why, the other runs kept."""

from __future__ import annotations

import pytest
from conftest import require_engine
from impactbench.engines.base import RunSettings, run_safely
from impactbench.engines.common import MAX_MATCHED_ZETA, clipped_restitution
from impactbench.reference.scenarios import BallOnPlate

DEAD = BallOnPlate(velocity_m_s=2.0, damping_s_per_m=100.0)
"""b·V0 = 200: the reference restitution is about 0.01."""


def test_the_floor_is_the_searched_bracket_end() -> None:
    floor = clipped_restitution(MAX_MATCHED_ZETA)
    assert 0.2 < floor < 0.22  # e(0.7) = 0.2103 (the clipped phase at ζ = 0.7)


@pytest.mark.parametrize("engine", ["mujoco", "pybullet"])
def test_a_dead_ball_native_is_one_line_naming_restitution(engine: str) -> None:
    require_engine(engine)
    with pytest.raises(ValueError) as info:
        run_safely(engine, DEAD, "native", RunSettings(timestep_s=1e-6))
    text = str(info.value)
    assert text.startswith("restitution = 0.01") and "\n" not in text
    assert "matches restitution >= 0.2103" in text


def test_in_a_matrix_it_is_a_row_not_a_lost_report() -> None:
    require_engine("mujoco")
    from impactbench.matrix import Job, execute

    job = Job("mujoco", "ball-on-plate", (("velocity_m_s", 2.0),), "native", 1e-6,
              (("damping_s_per_m", 100.0),))
    result = execute(job)
    assert result.run["status"] == "crashed"
    assert result.run["message"].startswith("bad settings: restitution = 0.01")
