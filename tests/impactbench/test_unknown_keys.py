"""Issue 21, goal 4: an unknown key anywhere is a one-line error with the valid keys and a
"did you mean" — tuned files, ``tune --param``, ``run --param``, gate files and configs."""

from __future__ import annotations

from pathlib import Path

import pytest
from conftest import require_engine

from impactbench.cli import main
from impactbench.gates import parse_gates
from impactbench.tuned import TUNED_DIR, load_tuned_file, tuned_keys


def one_line(capsys, argv: list[str], *needles: str) -> str:
    assert main([str(a) for a in argv]) == 2
    err = capsys.readouterr().err
    assert err.startswith("impactbench: error:") and err.count("\n") == 1, err
    for needle in needles:
        assert needle in err, err
    return err


def test_tuned_keys_are_what_each_engines_tuned_mode_reads() -> None:
    assert tuned_keys("mujoco") == ("solref", "solimp")
    assert set(tuned_keys("pybullet")) == {"contact_stiffness", "contact_damping"}
    # Drake's discrete approximation is held fixed by a fit at a practical step
    assert "discrete_contact_approximation" in tuned_keys("drake")
    assert {"restitution_law", "restitution_damping_s_per_m"} <= set(tuned_keys("pymunk"))


def test_every_packaged_tuned_file_has_only_known_keys() -> None:
    for path in sorted(TUNED_DIR.glob("*.toml")):
        data = load_tuned_file(path)
        engine = data.get("provenance", {}).get("engine") or path.name.split("_")[0]
        scenario = data.get("provenance", {}).get("scenario")  # oblique: its friction knobs
        assert set(data["parameters"]) <= set(tuned_keys(engine, scenario)), path.name


def test_a_misspelt_tuned_key_is_refused_not_ignored(capsys, tmp_path: Path) -> None:
    require_engine("mujoco")
    good = TUNED_DIR / "mujoco_ball_on_plate_dt2ms.toml"
    bad = tmp_path / "mine.toml"
    bad.write_text(good.read_text().replace("\nsolimp =", "\nsolimpp ="))
    assert "solimpp" in bad.read_text()
    one_line(capsys, ["run", "ball-on-plate", "--engine", "mujoco", "--tuned",
                      bad, "--velocity", "2", "--timestep", "2e-3"],
             "parameters.solimpp: not a mujoco tuned key (did you mean 'solimp'?)",
             "valid keys: solref, solimp")
    # the good file still runs
    assert main(["run", "ball-on-plate", "--engine", "mujoco", "--tuned",
                 str(good), "--velocity", "2", "--timestep", "2e-3", "--json"]) in (0, 1)
    capsys.readouterr()


def test_tune_param_must_be_a_tuned_key(capsys, tmp_path: Path) -> None:
    out = tmp_path / "t.toml"
    one_line(capsys, ["tune", "--engine", "drake", "--param", "discrete_contact_aproximation=sap",
                      "--out", out],
             "param = 'discrete_contact_aproximation': not a drake tuned key (did you mean "
             "'discrete_contact_approximation'?)", "valid keys: ")
    one_line(capsys, ["tune", "--engine", "mujoco", "--param", "bogus=1", "--out", out],
             "param = 'bogus': not a mujoco tuned key; valid keys: solref, solimp")
    assert not out.exists()


def test_run_param_says_did_you_mean(capsys) -> None:
    one_line(capsys, ["run", "ball-on-plate", "--engine", "mujoco", "--mode",
                      "custom", "--param", "solreff=0.02,1", "--velocity", "2"],
             "param = 'solreff': not a mujoco parameter",
             "valid keys: solref, solimp, integrator", "(did you mean 'solref'?)")


GATE = """[[gate]]
engine = "mujoco"
mode = "injected"
scenario = "ball-on-plate"
{extra}
[gate.tolerance]
restitution = 0.1
"""


@pytest.mark.parametrize(("extra", "needles"), [
    ("velocity_m_s = [1.0]", ("key 'velocity_m_s': unknown (did you mean 'velocities_m_s'?)",
                              "must be one of engine, mode")),
    ("tolerances = 1", ("key 'tolerances': unknown (did you mean 'tolerance'?)",)),
])
def test_gate_keys_say_did_you_mean(extra: str, needles: tuple[str, ...]) -> None:
    with pytest.raises(ValueError) as info:
        parse_gates(GATE.format(extra=extra), "g.toml")
    err = str(info.value)
    assert "\n" not in err and err.startswith("g.toml:5: gate 1:"), err
    for needle in needles:
        assert needle in err, err


def test_gate_file_tables_say_did_you_mean() -> None:
    with pytest.raises(ValueError, match=r"default: unknown table or key \(did you mean "
                                         r"'defaults'\?\); must be \[defaults\] or \[\[gate\]\]"):
        parse_gates("[default]\nbaseline_floor = 1e-8\n" + GATE.format(extra=""), "g.toml")
    with pytest.raises(ValueError, match=r"defaults key = 'baseline_flor': must be one of "
                                         r"baseline_margin, baseline_floor \(did you mean "
                                         r"'baseline_floor'\?\)"):
        parse_gates("[defaults]\nbaseline_flor = 1e-8\n" + GATE.format(extra=""), "g.toml")


def test_config_engine_parameters_say_did_you_mean(tmp_path: Path) -> None:
    from impactbench import config

    with pytest.raises(ValueError, match=r"engines.mujoco.solrf: not a mujoco parameter; "
                                         r"valid keys: solref, solimp, integrator, .* \(did "
                                         r"you mean 'solref'\?\)"):
        config.parse({"engines": {"mujoco": {"solrf": [0.02, 1.0]}}})


def test_scenario_file_keys_say_did_you_mean(tmp_path: Path) -> None:
    from impactbench.scenario_file import load_scenario_file

    path = tmp_path / "s.toml"
    path.write_text("[ball_on_plate]\nmass_k = 0.1\n")
    with pytest.raises(ValueError, match=r"ball_on_plate.mass_k: unknown key in .*\(did you "
                                         r"mean 'mass_kg'\?\); allowed: "):
        load_scenario_file(path)
