"""An empty toss selection is an error, not the test split: ``--tosses ''`` used to replay
the 89 test tosses as if nothing had been given."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from impactbench import scenarios

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize("given", ["", "  ", ","])
def test_an_empty_selection_is_refused(given: str) -> None:
    with pytest.raises(ValueError, match=r"tosses = .*: must be test, train, all or toss ids"):
        scenarios.get("cube-toss").build(parameters={"tosses": given})


def test_no_selection_is_the_test_split_and_a_users_file_is_all_of_it(tmp_path: Path) -> None:
    spec = scenarios.get("cube-toss")
    assert spec.build().tosses == "test"
    data = tmp_path / "t.csv"
    data.write_text("x\n")
    assert spec.build(parameters={"data": str(data)}).tosses == "all"


def test_the_command_line_refuses_an_empty_selection() -> None:
    got = subprocess.run([sys.executable, "-m", "impactbench.cli", "run", "cube-toss",
                          "--engine", "pybullet", "--tosses", ""], cwd=ROOT,
                         capture_output=True, text=True, timeout=120)
    assert got.returncode == 2
    assert got.stderr.strip().endswith("tosses = '': must be test, train, all or toss ids "
                                       "separated by commas (0,1,57)")
