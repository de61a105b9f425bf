"""Hand-edited and foreign files are bad input: one line naming the file (and, for a baseline,
the check and the rule), exit 2 — never a traceback, and never a baseline that quietly turns
its regression check off."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from impactbench import gates

ROOT = Path(__file__).resolve().parents[2]
RANDOM = bytes(range(128, 256)) * 3
"""Not UTF-8 (every byte a lone continuation or lead byte): what a binary file reads as."""


def cli(*argv: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "impactbench.cli", *argv], cwd=ROOT,
                          capture_output=True, text=True, timeout=120)


@pytest.mark.parametrize("bad", [float("nan"), float("inf"), None, "0.1"])
def test_a_baseline_error_must_be_a_finite_number(tmp_path: Path, bad) -> None:
    """A NaN error compares false with every band, so the check would pass whatever it
    measures: the baseline is refused, naming the check."""
    path = tmp_path / "b.json"
    path.write_text(json.dumps({"format": 1, "checks": {"x-rel": {"rel_error": bad}}}))
    with pytest.raises(ValueError, match=r"checks\.x-rel\.rel_error = .*must be a finite"):
        gates.load_baseline(path)


def test_a_finite_baseline_loads(tmp_path: Path) -> None:
    path = tmp_path / "b.json"
    path.write_text(json.dumps({"format": 1, "checks": {"x": {"rel_error": -0.01}}}))
    assert gates.load_baseline(path) == {"x": {"rel_error": -0.01}}


def test_the_shipped_baseline_is_finite() -> None:
    assert len(gates.load_baseline(ROOT / "gates_baseline.json")) > 1000


@pytest.mark.parametrize("argv, needle", [
    (["gate", "--config", "gates.toml", "--baseline", "{f}"], "baseline {f}: not a baseline"),
    (["gate", "--config", "{f}"], "gate file {f}: not a gate file"),
    (["run", "--engine", "mujoco", "--scenario", "ball-on-plate", "--velocity", "1",
      "--mode", "tuned", "--tuned", "{f}"], "tuned = '{f}': not a tuned file"),
])
def test_random_bytes_name_the_file(tmp_path: Path, argv: list[str], needle: str) -> None:
    path = tmp_path / "junk.bin"
    path.write_bytes(RANDOM)
    got = cli(*(a.format(f=path) for a in argv))
    assert got.returncode == 2, got.stderr
    lines = [x for x in got.stderr.splitlines() if x.strip() and "deprecated" not in x]
    assert len(lines) == 1 and needle.format(f=path) in lines[0], got.stderr
