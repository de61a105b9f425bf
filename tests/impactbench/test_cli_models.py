"""``reference ball-on-plate --model NAME --nominal-restitution E`` for every model of the zoo."""

from __future__ import annotations

import json

import pytest
from impactbench.reference.models import LINEAR_MODELS, MODELS, effective_restitution

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
