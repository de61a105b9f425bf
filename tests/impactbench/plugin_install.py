"""An example plug-in made visible as if pip-installed, for ``test_engine_plugin.py`` and
``test_scenario_plugin.py``: a ``*.dist-info`` folder (METADATA and entry_points.txt, what pip
would write) in ``tmp_path`` and the example's source folder go on ``sys.path`` (this process)
and ``PYTHONPATH`` (the CLI subprocesses and their workers)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest


def installed(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, example: Path,
              distribution: str, group: str, entry_point: str,
              forget: Callable[[], None]) -> Iterator[dict[str, str]]:
    """For a fixture to ``yield from``: ``example``'s folder registered as the distribution
    ``distribution`` 0.1.0 with the one entry point ``entry_point`` ("name = module:attr") in
    ``group``; yields the subprocesses' environment (PYTHONPATH, a private results store).
    ``forget`` (the registry's caches and the plug-in's modules) runs before and after."""
    site = tmp_path / "site"
    info = site / f"{distribution.replace('-', '_')}-0.1.0.dist-info"
    info.mkdir(parents=True)
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {distribution}\n"
                                   "Version: 0.1.0\n")
    (info / "entry_points.txt").write_text(f"[{group}]\n{entry_point}\n")
    monkeypatch.syspath_prepend(str(example))
    monkeypatch.syspath_prepend(str(site))
    forget()
    env = {**os.environ,
           "PYTHONPATH": os.pathsep.join([str(site), str(example),
                                          *filter(None, [os.environ.get("PYTHONPATH")])]),
           "IMPACTBENCH_STORE": str(tmp_path / "store.duckdb")}
    env.pop("GITHUB_STEP_SUMMARY", None)
    yield env
    forget()


def cli(env: dict[str, str], *args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "impactbench.cli", *args],
                          capture_output=True, text=True, env=env, timeout=600)


def gate_passes_and_fails(env: dict[str, str], tmp_path: Path, gate: str,
                          tolerance: dict[str, float], *first_args: str) -> list[str]:
    """``gate`` (a ``[[gate]]`` table at 1 and 5 m/s, less its tolerances) with ``tolerance``:
    recording the baseline (``first_args`` added) passes, with one check per metric and
    velocity; the same gate passes again against it (10 checks); tolerances of 1e-12 fail.
    Returns the baseline's check names."""
    def gate_file(name: str, tol: dict[str, float]) -> Path:
        path = tmp_path / name
        path.write_text(gate + "[gate.tolerance]\n"
                        + "".join(f"{m} = {t!r}\n" for m, t in tol.items()))
        return path

    baseline = tmp_path / "baseline.json"
    measured = gate_file("gates.toml", tolerance)
    first = cli(env, "gate", "--config", str(measured), "--baseline", str(baseline),
                "--update-baseline", *first_args)
    assert first.returncode == 0, first.stdout + first.stderr
    checks = json.loads(baseline.read_text())["checks"]
    assert len(checks) == 2 * len(tolerance)

    again = cli(env, "gate", "--config", str(measured), "--baseline", str(baseline),
                "--workers", "0")
    assert again.returncode == 0, again.stdout + again.stderr
    assert "gates OK: 10 checks, 10 pass" in again.stdout

    tight = gate_file("tight.toml", dict.fromkeys(tolerance, 1e-12))
    failed = cli(env, "gate", "--config", str(tight), "--baseline", str(baseline),
                 "--workers", "0")
    assert failed.returncode == 1, failed.stdout + failed.stderr
    assert "gates FAILED" in failed.stdout
    return checks
