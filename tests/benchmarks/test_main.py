"""``python -m benchmarks``: help, and a one-line error for an unknown name (no benchmark runs:
speed targets live in the benchmarks themselves, not in timed tests)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def bench(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "benchmarks", *args], cwd=ROOT,
                          capture_output=True, text=True, timeout=60)


def test_help_lists_the_benchmarks_and_exits_0() -> None:
    out = bench("--help")
    assert out.returncode == 0, out.stderr
    assert "python -m benchmarks" in out.stdout and "two_dof" in out.stdout


def test_an_unknown_name_is_one_line_and_exit_2() -> None:
    out = bench("no_such_bench")
    assert out.returncode == 2 and out.stdout == ""
    assert len(out.stderr.strip().splitlines()) == 1 and "no_such_bench" in out.stderr
