"""Calibration: recovers known parameters from exact synthetic data, reports intervals, and
rejects bad data with one line (exit 2)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from impactbench.reference import zoo
from impactbench.reference.scenarios import BallOnPlate

from impactbench.calibrate import calibrate, measurements, read_measurements
from impactbench.cli import main
from impactbench.scenario_file import load_scenario_file

EXAMPLE = Path(__file__).resolve().parents[2] / "impactbench/data/examples/synthetic_steel_ball.csv"
VELOCITIES = np.array([0.3, 0.8, 1.5, 2.5, 4.0])


def synthetic(truth: BallOnPlate, columns=("restitution", "duration_s", "peak_force_n"),
              noise: float = 0.0) -> pd.DataFrame:
    table = zoo.sweep(truth, VELOCITIES)[["velocity_m_s", *columns]]
    if noise:
        rng = np.random.default_rng(5)
        for c in columns:
            table[c] = table[c] * (1.0 + noise * rng.standard_normal(len(table)))
    return table


def test_recovers_b_and_c_exactly_with_intervals():
    truth = BallOnPlate(damping_s_per_m=0.23, stiffness=3.1e9, mass_kg=0.05)
    cal = calibrate(measurements(synthetic(truth)), BallOnPlate(mass_kg=0.05))
    assert cal.estimates["damping_s_per_m"] == pytest.approx(0.23, rel=1e-6)
    assert cal.estimates["stiffness"] == pytest.approx(3.1e9, rel=1e-6)
    assert cal.dof == 15 - 2
    for name, (lo, hi) in cal.intervals.items():
        assert lo <= cal.estimates[name] <= hi and math.isfinite(hi - lo)
    assert cal.residuals["rel_residual"].abs().max() < 1e-9


@pytest.mark.parametrize("model", ["lankarani-nikravesh", "flores", "kelvin-voigt-clipped"])
def test_recovers_nominal_restitution_and_stiffness_of_a_model(model):
    linear = model == "kelvin-voigt-clipped"
    extra = {"exponent": 1.0, "stiffness": 4e6} if linear else {"stiffness": 9e9}
    truth = BallOnPlate(model=model, nominal_restitution=0.62, **extra)
    start = truth.replace(nominal_restitution=0.9,
                          stiffness=1e6 if linear else 2e10)
    cal = calibrate(measurements(synthetic(truth, ("restitution", "duration_s"))), start)
    assert cal.estimates["nominal_restitution"] == pytest.approx(0.62, rel=1e-6)
    assert cal.estimates["stiffness"] == pytest.approx(extra["stiffness"], rel=1e-6)


def test_recovers_the_exponent_too():
    truth = BallOnPlate(damping_s_per_m=0.05, stiffness=2e8, exponent=1.3)
    cal = calibrate(measurements(synthetic(truth)), BallOnPlate(stiffness=1e9),
                    fit_exponent=True)
    assert cal.estimates["exponent"] == pytest.approx(1.3, rel=1e-6)
    assert cal.estimates["stiffness"] == pytest.approx(2e8, rel=1e-6)


def test_noisy_data_intervals_cover_the_truth():
    truth = BallOnPlate(damping_s_per_m=0.15)
    cal = calibrate(measurements(synthetic(truth, noise=0.01)), BallOnPlate())
    lo, hi = cal.intervals["damping_s_per_m"]
    assert lo < 0.15 < hi and hi - lo > 1e-4  # noise gives a real width
    lo, hi = cal.intervals["stiffness"]
    assert lo < truth.stiffness < hi


def test_example_data_set_calibrates_and_writes_a_scenario_file(tmp_path, capsys):
    data = read_measurements(EXAMPLE)
    assert data.columns == ("restitution", "duration_s", "peak_force_n")
    out = tmp_path / "steel.toml"
    code = main(["calibrate", "--data", str(EXAMPLE), "--out", str(out), "--json"])
    obj = json.loads(capsys.readouterr().out)
    assert code == 0
    lo, hi = obj["intervals"]["damping_s_per_m"]
    assert lo < 0.1 < hi  # the example's generating b (0.5 % noise)
    assert obj["rms_rel_error"] < 0.01
    fields = load_scenario_file(out)
    assert fields["damping_s_per_m"] == pytest.approx(obj["estimates"]["damping_s_per_m"])
    main(["reference", "ball-on-plate", "--scenario-file", str(out), "--velocity", "2",
          "--json"])
    ref = json.loads(capsys.readouterr().out)
    want = zoo.sweep(BallOnPlate(**fields), [2.0]).iloc[0].drop("velocity_m_s").to_dict()
    assert ref["status"] == "ok"
    assert {k: ref[k] for k in want} == pytest.approx(want, rel=1e-12)


@pytest.mark.parametrize(("rows", "message"), [
    ("velocity_m_s,restitution\n-1.0,0.9\n2.0,0.8\n", "velocity_m_s[row 1] = -1.0: must be > 0"),
    ("velocity_m_s,restitution\n1.0,1.2\n2.0,0.8\n", "restitution[row 1] = 1.2: must be in"),
    ("velocity_m_s,restitution\n1.0,0.0\n", "restitution[row 1] = 0.0: must be in (0, 1]"),
    ("velocity_m_s,restitution,duration_s\n1.0,0.9,1e-4\n",
     "data = 2 values: fewer than the 3 parameters"),
    ("velocity,restitution\n1.0,0.9\n", "missing 'velocity_m_s'"),
    ("velocity_m_s,restitution,mass\n1.0,0.9,1\n", "column 'mass': unknown"),
])
def test_bad_data_is_one_line_exit_2(tmp_path, capsys, rows, message):
    path = tmp_path / "bad.csv"
    path.write_text(rows)
    extra = ["--fit-exponent"] if "3 parameters" in message else []
    code = main(["calibrate", "--data", str(path), "--out", str(tmp_path / "x.toml"), *extra])
    err = capsys.readouterr().err
    assert code == 2
    assert message in err and err.count("\n") == 1
