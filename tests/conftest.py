"""Shared test helpers and fixtures."""

from __future__ import annotations

import sys
import types
from pathlib import Path

import pytest

# dartpy (the `dart` extra) installs a top-level package named `tests` into site-packages,
# which would shadow this folder in `from tests.conftest import …`: bind the name here first.
if str(Path(__file__).parent) not in list(getattr(sys.modules.get("tests"), "__path__", [])):
    _tests = types.ModuleType("tests")
    _tests.__path__ = [str(Path(__file__).parent)]
    sys.modules["tests"] = _tests

SMALL_REPORT = {
    "report": {"engines": ["mujoco", "pybullet", "pymunk", "drake"],
               "modes": ["native", "injected"]},
    "ball_on_plate": {"velocities_m_s": [1.0]},
    "rigid_flexible": {"velocities_m_s": [2.0], "local": ["linear"], "structure": ["linear"]},
    "work_precision": {"velocity_m_s": 1.0, "timesteps_s": [1e-5, 1e-6]},
}
"""A tiny report matrix: every engine, two modes, one point per scenario, two steps."""


@pytest.fixture(scope="session")
def small_report(tmp_path_factory: pytest.TempPathFactory):
    """The report of :data:`SMALL_REPORT`, built once per session (real engines)."""
    from impactbench import config, report

    return report.build(config.parse(SMALL_REPORT), tmp_path_factory.mktemp("report"),
                        show_progress=False)


def require_engine(name: str):
    """Import an engine's module or skip with the pip command that fixes it."""
    from impactbench.engines.registry import SPECS

    spec = SPECS[name]
    return pytest.importorskip(spec.module, reason=f"{name} not installed: run `{spec.pip}`")


def assert_escaped_after_whole_contact(rec, scenario) -> None:
    """A collapsed 2-DOF engine run ends by the reference's rule: out of contact, body 2 past
    the softening potential's peak and outrunning body 1 (``laws.escaped``); its metrics then
    cover the whole contact, as the reference's do (pulse width and impulse within 0.2 %)."""
    from impactbench.reference import metrics, two_dof
    from impactbench.reference.laws import escaped

    assert rec.normal_force_n[-1] == 0.0
    assert escaped(rec.velocity_1_m_s[-1], rec.displacement_2_m[-1], rec.velocity_2_m_s[-1],
                   scenario.structural_law())
    got, ref = metrics.compute(rec), two_dof.solve(scenario)
    assert got["impacts"] == ref["impacts"]
    for k in ("pulse_width_s", "impulse_ns"):
        assert abs(got[k] - ref[k]) <= 2e-3 * ref[k], (k, got[k], ref[k])


@pytest.fixture(autouse=True, scope="session")
def _private_results_store(tmp_path_factory: pytest.TempPathFactory) -> None:
    """Commands run by the tests use a results store and a tuning cache of their own (one per
    test process), never the user's."""
    import os

    os.environ["IMPACTBENCH_STORE"] = str(tmp_path_factory.mktemp("store") / "results.duckdb")
    os.environ["IMPACTBENCH_TUNE_CACHE"] = str(tmp_path_factory.mktemp("tune")
                                               / "cube_toss_tune.sqlite")


def rel(value: float, reference: float) -> float:
    """|value − reference| / |reference|."""
    return abs(value - reference) / abs(reference)
