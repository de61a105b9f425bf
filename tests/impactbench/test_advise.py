"""``impactbench advise`` / :func:`impactbench.advise.advise`: bad input is one line naming the
field, the value and the rule (exit 2); a real search answers with settings whose every speed
is plausible at every phase, in the engine's own keys, which ``custom`` runs reproduce; a
measured restitution CSV is a target like the reference."""

from __future__ import annotations

import json
import math

import pytest
from conftest import require_engine

from impactbench import phases
from impactbench.advise import advise, targets_from_csv
from impactbench.cli import main


@pytest.mark.parametrize(("kwargs", "match"), [
    ({"engine": "bullet"}, "engine = 'bullet'"),
    ({"engine": "pybullet", "timestep_s": 0.0}, "timestep_s = 0.0"),
    ({"engine": "pybullet", "timestep_s": -1e-3}, "timestep_s = -0.001"),
    ({"engine": "pybullet", "velocities_m_s": ()}, "velocities = \\[\\]"),
    ({"engine": "pybullet", "velocities_m_s": (1.0, -2.0)}, "velocities\\[1\\] = -2.0"),
    ({"engine": "pybullet", "budget_s": 0.0}, "budget_s = 0.0"),
    ({"engine": "pybullet", "phases": 0}, "phases = 0"),
])
def test_bad_input_is_one_line_naming_the_field(kwargs: dict, match: str) -> None:
    with pytest.raises(ValueError, match=match) as info:
        advise(**kwargs)
    assert "\n" not in str(info.value)


@pytest.mark.parametrize(("text", "match"), [
    ("speed,restitution\n1,0.9\n", "missing column 'velocity_m_s'"),
    ("velocity_m_s,e\n1,0.9\n", "missing column 'restitution'"),
    ("velocity_m_s,restitution\n", "has no rows"),
    ("velocity_m_s,restitution\n1,nan\n", "row 1 restitution = nan"),
    ("velocity_m_s,restitution\n1,0.9\n2,-0.1\n", "row 2 restitution = -0.1"),
    ("velocity_m_s,restitution\n0,0.9\n", "row 1 velocity_m_s = 0.0"),
])
def test_bad_target_csv(tmp_path, text: str, match: str) -> None:
    path = tmp_path / "target.csv"
    path.write_text(text)
    with pytest.raises(ValueError, match=match):
        targets_from_csv(path)


def test_cli_bad_input_exits_2_with_one_line(tmp_path, capsys) -> None:
    for argv in (["advise", "--engine", "bullet"],
                 ["advise", "--engine", "pybullet", "--timestep", "-1"],
                 ["advise", "--engine", "pybullet", "--material", "unobtainium"],
                 ["advise", "--engine", "pybullet", "--target", str(tmp_path / "none.csv")]):
        assert main(argv) == 2
        err = capsys.readouterr().err.strip()
        assert err.startswith("impactbench: error:") and "\n" not in err, argv


@pytest.fixture(scope="module")
def pybullet_advice():
    require_engine("pybullet")
    return advise("pybullet", 1 / 240, velocities_m_s=(0.5, 2.0, 5.0), budget_s=300.0)


def test_pybullet_advice_is_plausible_at_every_speed_and_phase(pybullet_advice) -> None:
    """PyBullet at 1/240 s over 0.5–5 m/s: a constant restitution can at best split the
    reference's 0.968–0.748 (≈ 13 %); the advice must be plausible at every phase and no
    worse than 18 % (the issue's bound: 13 % plus the phase spread). Measured: 13.1 %, the
    rigid restitution without ERP push-out."""
    a = pybullet_advice
    assert a.stop == "searched"  # the budget is a cap only a very slow machine reaches
    assert a.plausible
    assert all(r["status"] == "ok" for r in a.per_speed)
    assert a.worst_error <= 0.18
    assert a.phases == phases.offsets(8)
    assert {r["velocity_m_s"] for r in a.per_speed} == {0.5, 2.0, 5.0}
    assert "p.changeDynamics(ball, -1, restitution=" in a.snippet


def test_advice_params_rerun_as_custom_reproduce_the_claim(pybullet_advice) -> None:
    """The JSON's ``params`` are the engine's own ``custom`` keys: run at each phase they give
    restitutions inside the claimed range, whose ends they reach (the same runs)."""
    from impactbench.engines.base import RunSettings
    from impactbench.reference.scenarios import BallOnPlate

    from impactbench.evaluate import compare

    a = pybullet_advice
    for row in a.per_speed:
        es = []
        for ph in a.phases:
            run, _ = compare("pybullet", BallOnPlate().replace(velocity_m_s=row["velocity_m_s"]),
                             "custom", RunSettings(timestep_s=a.timestep_s, phase=ph,
                                                   params=a.params))
            assert run["status"] == "ok"
            es.append(float(run["restitution"]))
        assert min(es) == pytest.approx(row["restitution_min"], rel=1e-12)
        assert max(es) == pytest.approx(row["restitution_max"], rel=1e-12)


def test_a_measured_target_is_followed(tmp_path) -> None:
    """A user's CSV of a constant e = 0.5: a constant-restitution engine meets it closely
    (measured 0.06 % worst over phases for pymunk at 1/60 s)."""
    require_engine("pymunk")
    path = tmp_path / "measured.csv"
    path.write_text("velocity_m_s,restitution\n1.0,0.5\n3.0,0.5\n")
    a = advise("pymunk", 1 / 60, target_csv=path, budget_s=300.0)
    assert a.target == str(path)
    assert [r["reference_restitution"] for r in a.per_speed] == [0.5, 0.5]
    assert a.plausible and a.worst_error < 0.01


def test_cli_json_carries_params_and_per_speed(capsys, tmp_path) -> None:
    require_engine("pymunk")
    fig = tmp_path / "tradeoff.png"
    assert main(["advise", "--engine", "pymunk", "--velocities", "1,3", "--budget", "300",
                 "--figure", str(fig), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert set(out["params"]) >= {"elasticity"}
    assert [r["velocity_m_s"] for r in out["per_speed"]] == [1.0, 3.0]
    for row in out["per_speed"]:
        assert {"velocity_m_s", "restitution", "reference_restitution", "status"} <= set(row)
        assert math.isfinite(row["reference_restitution"])
    assert fig.stat().st_size > 10_000
