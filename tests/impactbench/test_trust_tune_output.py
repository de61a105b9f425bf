"""``tune``'s summary: a velocity whose run did not compare (implausible, failed) no longer
turns every start/tuned/floor error into nan under a residual table that has the numbers —
the max is over the runs that compared, and the table says how many did; a fit where no run
compared ends with its reasons and an honest plot, not a matplotlib traceback."""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

from conftest import require_engine
from impactbench.reference.metrics import BALL_METRICS

from impactbench.tuning.optimize import TuneResult

ROOT = Path(__file__).resolve().parents[2]


def errors(*restitution: float) -> list[dict[str, float]]:
    return [{**dict.fromkeys(BALL_METRICS, math.nan), "restitution": e} for e in restitution]


def test_the_max_is_over_the_runs_that_compared() -> None:
    result = SimpleNamespace(start=SimpleNamespace(rel_errors=errors(0.05, math.nan, -0.08)),
                             tuned=SimpleNamespace(rel_errors=errors(0.01, math.nan, -0.02)),
                             velocities_m_s=(0.5, 1.0, 2.0))
    assert TuneResult.max_abs_error(result, "start")["restitution"] == 0.08
    assert TuneResult.max_abs_error(result, "tuned")["restitution"] == 0.02
    assert math.isnan(TuneResult.max_abs_error(result, "tuned")["duration_s"])
    assert TuneResult.compared(result, "restitution") == "2/3"


def test_a_fit_where_no_run_compared_ends_with_its_reasons(tmp_path: Path) -> None:
    require_engine("mujoco")
    got = subprocess.run([sys.executable, "-m", "impactbench.cli", "tune", "--engine",
                          "mujoco", "--velocities", "0.5,2", "--max-evals", "3",
                          "--timestep", "1e-3", "--out", str(tmp_path / "t.toml"), "--plot",
                          str(tmp_path / "t.png")], cwd=ROOT, capture_output=True, text=True,
                         timeout=600, env={**__import__("os").environ,
                                           "IMPACTBENCH_STORE": str(tmp_path / "s.duckdb")})
    assert got.returncode == 0, got.stderr
    assert "no plausible run at 0.5, 2 m/s" in got.stdout
    assert (tmp_path / "t.png").stat().st_size > 1000
