"""``reference ball-on-plate --model NAME --nominal-restitution E`` for every model of the zoo."""

from __future__ import annotations

import json

import pytest
from impactbench.reference.models import LINEAR_MODELS, MODELS
from impactbench.reference.zoo import effective_restitution

from impactbench.cli import main


@pytest.mark.parametrize("model", MODELS)
def test_every_model_through_the_cli(capsys, model):
    linear = ["--exponent", "1", "--stiffness", "1e7"] if model in LINEAR_MODELS else []
    code = main(["reference", "ball-on-plate", "--model", model, "--nominal-restitution",
                 "0.5", "--velocity", "1,3", "--json", *linear])
    rows = json.loads(capsys.readouterr().out)
    assert code == 0 and len(rows) == 2
    for row in rows:  # nominal-restitution models: the same k at every velocity
        assert row["restitution"] == pytest.approx(effective_restitution(model, 0.5),
                                                   rel=1e-13)
    assert rows[1]["peak_force_n"] > rows[0]["peak_force_n"]


def test_default_model_keeps_the_damping_flag(capsys):
    main(["reference", "ball-on-plate", "--damping", "0.2", "--velocity", "2", "--json"])
    plain = json.loads(capsys.readouterr().out)
    main(["reference", "ball-on-plate", "--model", "hunt-crossley", "--damping", "0.2",
          "--velocity", "2", "--json"])
    assert json.loads(capsys.readouterr().out) == plain


@pytest.mark.parametrize(("argv", "message"), [
    (["--model", "gonthier"], "nominal_restitution = None: model 'gonthier' needs"),
    (["--model", "gonthier", "--nominal-restitution", "1.5"], "nominal_restitution = 1.5"),
    (["--model", "kelvin-voigt", "--nominal-restitution", "0.5"], "exponent = 1.5"),
])
def test_bad_model_input_exits_2_with_one_line(capsys, argv, message):
    assert main(["reference", "ball-on-plate", *argv]) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1


def test_sweep_with_a_model(tmp_path, capsys):
    import pandas as pd
    from impactbench.reference import zoo
    from impactbench.reference.scenarios import BallOnPlate

    out = tmp_path / "ln.csv"
    assert main(["sweep", "ball-on-plate", "--over", "velocity", "--start", "0.5", "--stop",
                 "2", "--step", "0.5", "--model", "lankarani-nikravesh",
                 "--nominal-restitution", "0.7", "--out", str(out)]) == 0
    table = pd.read_csv(out)
    want = zoo.sweep(BallOnPlate(model="lankarani-nikravesh", nominal_restitution=0.7),
                     [0.5, 1.0, 1.5, 2.0])
    assert table["duration_s"].to_numpy() == pytest.approx(want["duration_s"].to_numpy(),
                                                           rel=1e-12)
    assert table["restitution"].nunique() == 1


def test_scenario_file_errors_are_one_line(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text("[ball_on_plate]\nmass_kg = -1.0\n")
    for argv in (["reference", "ball-on-plate", "--scenario-file", str(bad)],
                 ["report", "--scenario-file", str(bad), "--out", str(tmp_path / "r")]):
        assert main(argv) == 2
        err = capsys.readouterr().err
        assert "ball_on_plate.mass_kg = -1.0: must be > 0" in err and err.count("\n") == 1
    bad.write_text("[ball_on_plate]\nvelocity_m_s = 3.0\n")
    assert main(["reference", "ball-on-plate", "--scenario-file", str(bad)]) == 2
    assert "ball_on_plate.velocity_m_s: unknown key" in capsys.readouterr().err
