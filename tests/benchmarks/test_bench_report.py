"""``python -m benchmarks report``'s bookkeeping (no report runs here): the time-left priors'
columns written one at a time, and the time left's error as a progress line shows it."""

from __future__ import annotations

import json
import statistics
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
if str(ROOT) not in sys.path:  # the benchmarks package sits beside the installed ones
    sys.path.insert(0, str(ROOT))

from benchmarks import bench_report  # noqa: E402


def test_writing_one_column_of_priors_keeps_the_other(tmp_path, monkeypatch) -> None:
    from impactbench import matrix

    path = tmp_path / "time_priors.json"
    monkeypatch.setattr(matrix, "TIME_PRIORS", path)
    bench_report.write_priors([["mjx", "oblique", True, 197.43]], cold=True)
    bench_report.write_priors([["mjx", "oblique", True, 57.891234], ["dart", "bounce", False, 3]],
                              cold=False)
    data = json.loads(path.read_text())
    assert data["cold"] == [["mjx", "oblique", True, 197.4]]       # 4 significant digits
    assert data["warm"] == [["mjx", "oblique", True, 57.89], ["dart", "bounce", False, 3.0]]
    assert set(data["measured_on"]) == {"cold", "warm"}
    assert "compile caches empty" in data["measured_on"]["cold"]
    bench_report.write_priors([["mjx", "oblique", True, 200.0]], cold=True)  # again: replaced
    data = json.loads(path.read_text())
    assert data["cold"] == [["mjx", "oblique", True, 200.0]] and len(data["warm"]) == 2
    # and the estimator reads what was written, column by column
    monkeypatch.setattr(matrix, "_packaged_priors", matrix._packaged_priors.__wrapped__)
    assert matrix.time_priors(["mjx"])[("mjx", "oblique", True)] == 200.0
    assert matrix.time_priors([])[("mjx", "oblique", True)] == 57.89


def test_the_time_lefts_error_is_the_shown_countdown_against_the_real_end() -> None:
    # said 100 s at 0, then 60 s at 35 s; the runs ended at 100 s
    got = bench_report.time_left_error({"said": [(0.0, 100.0), (35.0, 60.0)], "end": 100.0})
    assert got is not None
    median, worst, samples = got
    # shown at 10, 20, 30 s: 90, 80, 70 (exact); at 40…80 s: 55, 45, 35, 25, 15 against
    # 60, 50, 40, 30, 20 left; the worst 20/15
    factors = [1.0, 1.0, 1.0, 60 / 55, 50 / 45, 40 / 35, 30 / 25, 20 / 15]
    assert worst == pytest.approx(max(factors))
    assert median == pytest.approx(statistics.median(factors))
    assert [(round(t), round(s), round(a)) for t, s, a in samples] == [(10, 90, 90),
                                                                       (30, 70, 70),
                                                                       (60, 35, 40)]
    assert bench_report.time_left_error({"said": [], "end": 10.0}) is None
