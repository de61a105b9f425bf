"""A broken scenario plug-in (its module missing, failing to import, or not a ScenarioSpec
of its name) is left out and said in one line; the rest of impactbench works. It used to take
down every command, ``reference ball-on-plate`` included."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
from impactbench.engines import registry

from impactbench import scenarios

GROUP = scenarios.ENTRY_POINT_GROUP


def install(site: Path, package: str, entries: dict[str, str],
            modules: dict[str, str] | None = None) -> Path:
    """A distribution ``package`` 0.3.0 with ``entries`` in the scenarios' group (the
    engine registry tests' installer)."""
    from tests.engines.test_registry import install as install_distribution

    return install_distribution(site, package, entries, modules, GROUP, "0.3.0")


@pytest.mark.parametrize("target, modules, why", [
    ("ib_test_nowhere:SPEC", {}, "ModuleNotFoundError: No module named 'ib_test_nowhere'"),
    ("ib_test_raises:SPEC", {"ib_test_raises": "raise RuntimeError('bad plug-in')\n"},
     "RuntimeError: bad plug-in"),
    ("ib_test_notaspec:SPEC", {"ib_test_notaspec": "SPEC = 3\n"},
     "ib_test_notaspec:SPEC is not a ScenarioSpec named 'ghost-scenario'"),
])
def test_a_broken_plugin_is_left_out_in_one_line(tmp_path: Path, target: str,
                                                  modules: dict[str, str], why: str) -> None:
    site = install(tmp_path / "site", "ib-test-scenario", {"ghost-scenario": target}, modules)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(
        [str(site), *filter(None, [os.environ.get("PYTHONPATH")])]),
        "IMPACTBENCH_STORE": str(tmp_path / "store.duckdb")}
    env.pop(registry.WARNED_ENV, None)
    got = subprocess.run([sys.executable, "-m", "impactbench.cli", "reference",
                          "ball-on-plate", "--velocity", "1", "--json"], capture_output=True,
                         text=True, env=env, timeout=300)
    assert got.returncode == 0, got.stderr
    assert json.loads(got.stdout)["restitution"] > 0.9
    lines = got.stderr.splitlines()
    assert len(lines) == 1, lines
    assert lines[0].startswith(f"impactbench: scenario plug-in ghost-scenario = {target} "
                               "(ib-test-scenario 0.3.0) is left out: ")
    assert why in lines[0]
