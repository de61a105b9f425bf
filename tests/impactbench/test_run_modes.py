"""``impactbench run`` with default, custom and tuned modes; tuned files bound to the scenario
and timestep they were fitted for (real engines)."""

from __future__ import annotations

import json
import math

import pytest
from conftest import require_engine
from impactbench.engines.base import RunSettings
from impactbench.reference.scenarios import BallOnPlate

from impactbench.cli import main
from impactbench.cliutil import param_value
from impactbench.evaluate import compare
from impactbench.tuned import binding_mismatch, load_tuned_settings

CUSTOMARY = [("mujoco", "2e-3"), ("pybullet", "0.004166666666666667"), ("drake", "1e-3"),
             ("pymunk", "0.016666666666666666")]


def run(capsys, *argv: str) -> tuple[int, str, str]:
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def run_json(capsys, engine: str, *argv: str) -> tuple[int, dict]:
    """``impactbench run ball-on-plate --engine ENGINE ARGV --json`` (skipped where the engine
    is not installed): the exit code and the parsed output."""
    require_engine(engine)
    code, out, _ = run(capsys, "run", "ball-on-plate", "--engine", engine, *argv, "--json")
    return code, json.loads(out)


@pytest.mark.parametrize(("engine", "dt"), CUSTOMARY)
def test_default_mode_json_at_the_customary_step(capsys, engine, dt):
    code, obj = run_json(capsys, engine, "--mode", "default", "--velocity", "2",
                         "--timestep", dt)
    # measured either way; out of the box at these steps the paper's 14.5 mm ball often sinks
    # deeper than a tenth of its radius (MuJoCo's 20 ms default contact: about one radius)
    deep = obj["plausibility"]["penetration_ratio"] > 0.1
    assert obj["status"] == ("implausible" if deep else "ok")
    assert code == (1 if deep else 0)
    assert isinstance(obj["restitution"], float) and obj["engine_defaults"]


def test_custom_param_reaches_mujoco(capsys):
    code, obj = run_json(capsys, "mujoco", "--mode", "custom", "--param", "solref=0.01,0.5",
                         "--velocity", "2", "--timestep", "2e-3")
    assert obj["params"] == {"solref": [0.01, 0.5]}
    assert code == (0 if obj["status"] == "ok" else 1)


@pytest.mark.parametrize("argv", [
    ["--mode", "custom", "--param", "solrf=1"],
    ["--mode", "native", "--param", "solref=1,1"],
    ["--mode", "native", "--tuned", "x.toml"],
    ["--mode", "custom", "--param", "novalue"],
])
def test_bad_param_use_exits_2_with_one_line(capsys, argv):
    code, out, err = run(capsys, "run", "ball-on-plate", "--engine", "mujoco",
                         "--velocity", "1", *argv)
    assert code == 2 and out == "" and len(err.strip().splitlines()) == 1


def test_unknown_key_lists_the_valid_ones(capsys):
    _, _, err = run(capsys, "run", "ball-on-plate", "--engine", "pybullet",
                    "--mode", "custom", "--param", "stiffness=1", "--velocity", "1")
    assert "contactStiffness" in err and "restitutionVelocityThreshold" in err


def test_param_values():
    assert param_value("0.02,1") == [0.02, 1.0]
    assert param_value("[0.02, 1.0]") == [0.02, 1.0]
    assert param_value("1e6") == 1e6
    assert param_value("sap") == "sap"
    assert param_value("true") is True


def test_tuned_with_a_changed_scenario_is_unsupported_naming_the_field(capsys):
    _, obj = run_json(capsys, "mujoco", "--mode", "tuned", "--velocity", "2", "--mass", "0.072",
                      "--stiffness", "1.4e6")
    assert obj["status"] == "unsupported"
    assert "mass_kg" in obj["message"] and "stiffness" in obj["message"]
    assert "impactbench tune --engine mujoco --mass 0.072" in obj["message"]


def test_tuned_at_another_timestep_is_unsupported_naming_the_timestep():
    require_engine("drake")
    tuned, prov = load_tuned_settings("drake", "ball-on-plate")  # fitted at 1e-6 s
    out, _ = compare("drake", BallOnPlate(velocity_m_s=1.0), "tuned",
                     RunSettings(timestep_s=2e-6, tuned=tuned, tuned_for=prov))
    assert out["status"] == "unsupported" and "timestep_s" in out["message"]
    assert "--timestep 2e-06" in out["message"]


def test_binding_accepts_the_fitted_case():
    _, prov = load_tuned_settings("mujoco", "ball-on-plate")
    assert binding_mismatch(prov, "mujoco", BallOnPlate(velocity_m_s=3.0), 1e-6) == ""
    assert "engine" in binding_mismatch(prov, "drake", BallOnPlate(), 1e-6)


def test_tuned_file_from_tune_out_runs_with_run_tuned(capsys, tmp_path):
    require_engine("pymunk")
    path = tmp_path / "t.toml"
    code, _, _ = run(capsys, "tune", "--engine", "pymunk", "--velocities", "1,2",
                     "--targets", "restitution", "--timestep", "1e-3", "--max-evals", "3",
                     "--out", str(path), "--no-plot")
    assert code == 0
    code, out, _ = run(capsys, "run", "ball-on-plate", "--engine", "pymunk",
                       "--tuned", str(path), "--velocity", "2", "--timestep", "1e-3", "--json")
    assert json.loads(out)["status"] == "ok"
    code, out, _ = run(capsys, "run", "ball-on-plate", "--engine", "pymunk",
                       "--tuned", str(path), "--velocity", "2", "--timestep", "1e-4", "--json")
    assert json.loads(out)["status"] == "unsupported"


PACKAGED = [("mujoco", 2e-3, None), ("mujoco", 1e-3, None), ("pybullet", 1 / 240, None),
            ("pymunk", 1 / 60, None), ("pymunk", 1e-3, None),
            *[("drake", 1e-3, a) for a in ("lagged", "tamsi", "sap", "similar")]]


@pytest.mark.parametrize(("engine", "dt", "approximation"), PACKAGED)
def test_packaged_tuned_file_fits_its_customary_step(engine, dt, approximation):
    """Each packaged file fitted at a practical step applies there (its provenance matches):
    at the velocities its provenance lists as plausible the run is ok and its restitution
    within the recorded worst error; at any others it would be implausible, its contact
    sinking the ball more than 0.1 of its radius beyond the step's own overlap."""
    require_engine(engine)
    variant = {"discrete_contact_approximation": approximation} if approximation else None
    tuned, prov = load_tuned_settings(engine, "ball-on-plate", dt, variant=variant)
    assert prov["timestep_s"] == pytest.approx(dt, rel=1e-12)
    plausible = prov["plausible_velocities_m_s"]
    worst = prov.get("max_abs_rel_error_restitution_plausible", math.nan)
    for v in prov["velocities_m_s"]:
        out, _ = compare(engine, BallOnPlate(velocity_m_s=v), "tuned",
                         RunSettings(timestep_s=dt, tuned=tuned, tuned_for=prov))
        if v in plausible:
            assert out["status"] == "ok", (v, out["message"])
            assert abs(out["rel_error"]["restitution"]) <= worst * (1 + 1e-6)
        else:
            assert out["status"] == "implausible", (v, out["status"], out["message"])
            assert out["plausibility"]["penetration_ratio"] > 0.1
    # fitted on the worst of 8 phases of the step, judged by sinking beyond the step's own
    # overlap (#29): every packaged file is plausible at every speed of its fit (the run here,
    # at the adapters' phase ½, is one of the 8); before, pymunk at 1/60 s was plausible at
    # none (its 8 mm step overlap counted as sinking)
    assert plausible == list(prov["velocities_m_s"])


def test_tune_at_a_coarse_step_fits_restitution_only_and_keeps_fixed_settings():
    require_engine("drake")
    from impactbench.tuning.optimize import tune

    result = tune("drake", BallOnPlate(), (1.0, 5.0), timestep_s=1e-3,
                  parameters="stiffness+relaxation", max_evals=4,
                  fixed={"discrete_contact_approximation": "sap"})
    assert "not resolved at dt = 0.001 s" in result.excluded["duration_s"]
    assert result.objective.weights["peak_force_n"] == 0.0
    assert result.parameters["discrete_contact_approximation"] == "sap"
    assert "relaxation_time_s" in result.parameters
