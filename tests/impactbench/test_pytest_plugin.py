"""The pytest plugin through pytester: one item per gate check, real engine runs."""

from __future__ import annotations

from importlib.metadata import entry_points

import pytest
from impactbench.engines.base import ENGINES, run_safely
from impactbench.reference.scenarios import RigidFlexible

pytest_plugins = ("pytester",)


def _plugin_args() -> list[str]:
    """Load the plugin by module until the ``pytest11`` entry point is installed."""
    installed = any(ep.value.startswith("impactbench.pytest_plugin")
                    for ep in entry_points(group="pytest11"))
    return [] if installed else ["-p", "impactbench.pytest_plugin"]


@pytest.fixture(autouse=True, scope="module")
def _dask_imported_outside_the_runs() -> None:
    """pytester's in-process runs drop the modules a run imported but not what they added to
    ``sys.meta_path``: the first run's Dask brings in the ``importlib_metadata`` backport and
    its finder, and the next runs' pytest header then found no metadata for pluggy
    (``PackageNotFoundError``: these tests failed whenever this file was the first in its
    process to use Dask, e.g. run alone). Imported here first, it outlives the runs."""
    import distributed  # noqa: F401


@pytest.fixture(scope="module")
def engine() -> str:
    for name in ENGINES:
        if run_safely(name, RigidFlexible(velocity_m_s=2.0), "injected").ok:
            return name
    pytest.skip("no engine runs the rigid-flexible case in injected mode here")


GATES = """
[[gate]]
engine = "{engine}"
mode = "injected"
scenario = "rigid-flexible"
velocities_m_s = [2.0]
[gate.tolerance]
peak_force_n = 0.01   # the injected law reproduces the reference: passes
impulse_ns = 0        # no floating-point run is exact: fails
"""


def test_one_passing_and_one_failing_item(pytester: pytest.Pytester, engine: str) -> None:
    pytester.makefile(".toml", gates=GATES.format(engine=engine))
    result = pytester.runpytest(*_plugin_args(), "--impactbench-gates=gates.toml",
                                "--impactbench-jobs=1", "-v")
    result.assert_outcomes(passed=1, failed=1)
    result.stdout.fnmatch_lines([
        f"*gates.toml::gate[[]{engine}-injected-rigid-flexible-linear-linear-v2-dt*"
        "-peak_force_n[]] PASSED*",
        f"*gates.toml::gate[[]{engine}-injected-rigid-flexible-linear-linear-v2-dt*"
        "-impulse_ns[]] FAILED*",
        "*fail: |rel error|*> tolerance 0*",
    ])


def test_k_selects_checks(pytester: pytest.Pytester, engine: str) -> None:
    pytester.makefile(".toml", gates=GATES.format(engine=engine))
    result = pytester.runpytest(*_plugin_args(), "--impactbench-gates=gates.toml",
                                "--impactbench-jobs=0", "-k", "peak_force")
    result.assert_outcomes(passed=1, deselected=1)


def test_bad_gate_file_is_a_usage_error(pytester: pytest.Pytester) -> None:
    path = pytester.makefile(".toml", gates=GATES.format(engine="mujoco").replace(
        "impulse_ns = 0 ", "impulse_ns = -1 "))
    line = 1 + next(i for i, text in enumerate(path.read_text().splitlines())
                    if text.startswith("impulse_ns"))
    result = pytester.runpytest(*_plugin_args(), "--impactbench-gates=gates.toml")
    assert result.ret == pytest.ExitCode.USAGE_ERROR
    result.stderr.fnmatch_lines([f"*gates.toml:{line}: gate 1: tolerance.impulse_ns = -1*"])
