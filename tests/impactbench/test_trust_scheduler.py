"""A scheduler the user named gets the work, and one that nothing listens on is said, naming
where the address came from: before, work estimated below a second ran in this process while
the output claimed the scheduler (``tune --scheduler``), and an unreachable
``$IMPACTBENCH_SCHEDULER`` was ignored without a word."""

from __future__ import annotations

import os
import socket
import subprocess
import sys
from pathlib import Path

from impactbench import cluster

ROOT = Path(__file__).resolve().parents[2]


def closed_port() -> str:
    """An address on this machine that nothing listens on."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    return f"tcp://127.0.0.1:{port}"


def test_a_named_scheduler_gets_even_small_work() -> None:
    runner = cluster.Runner(None, "tcp://127.0.0.1:1", min_dispatch_s=1.0)
    assert runner.min_dispatch_s == 0.0 and not runner.in_process
    assert runner.scheduler_source == "--scheduler"
    local = cluster.Runner(None, None, min_dispatch_s=1.0)
    assert local.min_dispatch_s == 1.0


def test_an_unreachable_environment_scheduler_is_an_error_naming_it(tmp_path: Path) -> None:
    address = closed_port()
    env = {**os.environ, cluster.SCHEDULER_ENV: address}
    got = subprocess.run([sys.executable, "-m", "impactbench.cli", "sweep", "rigid-flexible",
                          "--over", "velocity", "--start", "1", "--stop", "2", "--step", "1",
                          "--out", str(tmp_path / "s.csv")], cwd=ROOT, env=env,
                         capture_output=True, text=True, timeout=300)
    assert got.returncode == 2, got.stderr
    last = got.stderr.strip().splitlines()[-1]
    assert f"scheduler = '{address}': cannot connect" in last
    assert f"(from ${cluster.SCHEDULER_ENV})" in last
    assert not (tmp_path / "s.csv").exists()
