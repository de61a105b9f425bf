"""The CLI contract of ``reference ball-on-plate`` and ``sweep ball-on-plate``."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pandas as pd
import pytest
from impactbench.reference import hunt_crossley as hc
from impactbench.reference.metrics import BALL_METRICS
from impactbench.reference.scenarios import BallOnPlate

from impactbench.cli import main


def run(capsys, *argv: str) -> tuple[int, str, str]:
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


JSON_KEYS = ["velocity_m_s", *BALL_METRICS, "status", "message"]


def test_json_one_velocity_has_the_input_five_metrics_and_status(capsys):
    code, out, _ = run(capsys, "reference", "ball-on-plate", "--velocity", "5", "--json")
    assert code == 0
    obj = json.loads(out)
    assert list(obj) == JSON_KEYS
    assert obj["velocity_m_s"] == 5.0 and obj["status"] == "ok" and obj["message"] == ""
    want = hc.solve(BallOnPlate(velocity_m_s=5.0))
    for key in BALL_METRICS:
        assert obj[key] == pytest.approx(want[key], rel=1e-15)


def test_json_several_velocities_in_order(capsys):
    _, comma, _ = run(capsys, "reference", "ball-on-plate", "--velocity", "2,0.5", "--velocity",
                      "3", "--json")
    _, repeated, _ = run(capsys, "reference", "ball-on-plate", "--velocity", "2",
                         "--velocity", "0.5", "--velocity", "3", "--json")
    rows = json.loads(comma)
    assert rows == json.loads(repeated)
    assert [(r["velocity_m_s"], r["status"]) for r in rows] == [(2.0, "ok"), (0.5, "ok"),
                                                                (3.0, "ok")]
    assert [r["max_penetration_m"] for r in rows] == [
        hc.solve(BallOnPlate(velocity_m_s=v))["max_penetration_m"] for v in (2.0, 0.5, 3.0)]


def test_parameters_reach_the_solver(capsys):
    _, out, _ = run(capsys, "reference", "ball-on-plate", "--velocity", "1.5", "--mass", "0.3",
                    "--stiffness", "2e9", "--exponent", "1", "--damping", "0", "--json")
    obj = json.loads(out)
    assert obj["restitution"] == 1.0
    assert obj["duration_s"] == pytest.approx(np.pi * np.sqrt(0.3 / 2e9), rel=1e-13)


def test_human_table(capsys):
    code, out, _ = run(capsys, "reference", "ball-on-plate", "--velocity", "0.5,5")
    assert code == 0
    assert "restitution" in out and "duration_s" in out
    assert "0.96773858" in out and "0.74843493" in out


@pytest.mark.parametrize("flag", ["--velocity", "--mass", "--stiffness", "--exponent",
                                  "--damping"])
@pytest.mark.parametrize("value", ["0", "-1", "nan", "inf", "abc", ""])
def test_bad_values_exit_2_with_one_line(capsys, flag, value):
    if flag == "--damping" and value == "0":
        return  # b = 0 is the valid Hertz limit
    code, out, err = run(capsys, "reference", "ball-on-plate", "--velocity", "1", flag, value)
    assert code == 2
    assert out == ""
    assert err.startswith("impactbench: error:") and err.count("\n") == 1
    assert "Traceback" not in err


def test_sweep_csv_and_parquet(capsys, tmp_path):
    csv, pq = tmp_path / "s.csv", tmp_path / "sub" / "s.parquet"
    for path in (csv, pq):
        code, _, err = run(capsys, "sweep", "ball-on-plate", "--over", "velocity", "--start",
                           "0.5", "--stop", "5", "--step", "0.5", "--out", str(path))
        assert code == 0, err
    a, b = pd.read_csv(csv), pd.read_parquet(pq)
    assert list(a.columns) == ["velocity_m_s", *BALL_METRICS]
    np.testing.assert_allclose(a["velocity_m_s"], np.arange(1, 11) * 0.5, rtol=1e-15)
    pd.testing.assert_frame_equal(a, b, check_exact=True)  # CSV round-trips float64
    want = hc.sweep(a["velocity_m_s"].to_numpy())
    pd.testing.assert_frame_equal(a, want, check_exact=False, rtol=1e-14)


def test_sweep_grid_stops_at_or_below_stop(capsys, tmp_path):
    out = tmp_path / "g.csv"
    run(capsys, "sweep", "ball-on-plate", "--over", "velocity", "--start", "0.1", "--stop",
        "0.35", "--step", "0.1", "--out", str(out), "--damping", "0.2")
    np.testing.assert_allclose(pd.read_csv(out)["velocity_m_s"], [0.1, 0.2, 0.3], rtol=1e-15)


@pytest.mark.parametrize("args", [
    ["--start", "1", "--stop", "0.5", "--step", "0.1", "--out", "x.csv"],
    ["--start", "0", "--stop", "1", "--step", "0.1", "--out", "x.csv"],
    ["--start", "1", "--stop", "2", "--step", "0", "--out", "x.csv"],
    ["--start", "1", "--stop", "2", "--step", "-1", "--out", "x.csv"],
    ["--start", "1", "--stop", "2", "--step", "nan", "--out", "x.csv"],
    ["--start", "1", "--stop", "2", "--step", "0.5", "--out", "x.txt"],
    ["--start", "1", "--stop", "2", "--step", "0.5", "--out", "x.csv", "--mass", "-2"],
])
def test_sweep_bad_input_exit_2(capsys, tmp_path, monkeypatch, args):
    monkeypatch.chdir(tmp_path)
    code, _, err = run(capsys, "sweep", "ball-on-plate", "--over", "velocity", *args)
    assert code == 2
    assert err.startswith("impactbench: error:") and err.count("\n") == 1
    assert not (tmp_path / "x.csv").exists()


def test_console_script_exit_code():
    """The installed entry point, as other tools call it."""
    bad = subprocess.run([sys.executable, "-m", "impactbench.cli", "reference", "ball-on-plate",
                          "--velocity", "nan", "--json"], capture_output=True, text=True)
    assert bad.returncode == 2 and "Traceback" not in bad.stderr
    good = subprocess.run([sys.executable, "-m", "impactbench.cli", "reference",
                           "ball-on-plate", "--velocity", "1", "--json"], capture_output=True,
                          text=True)
    assert good.returncode == 0 and list(json.loads(good.stdout)) == JSON_KEYS
