"""Fixtures shared by the suite's tests: one small report, built once per session."""

from __future__ import annotations

import pytest

from impactbench import config, report

SMALL = {
    "report": {"engines": ["mujoco", "pybullet", "pymunk", "drake"],
               "modes": ["native", "injected"]},
    "ball_on_plate": {"velocities_m_s": [1.0]},
    "rigid_flexible": {"velocities_m_s": [2.0], "local": ["linear"], "structure": ["linear"]},
    "work_precision": {"velocity_m_s": 1.0, "timesteps_s": [1e-5, 1e-6]},
}
"""A tiny matrix: every engine, two modes, one point per scenario, two work-precision steps."""


@pytest.fixture(scope="session")
def small_report(tmp_path_factory: pytest.TempPathFactory) -> report.Report:
    out = tmp_path_factory.mktemp("report")
    return report.build(config.parse(SMALL), out, show_progress=False)
