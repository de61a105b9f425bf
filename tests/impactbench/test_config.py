"""Report config validation: one line naming the key; the CLI exits 2."""

from __future__ import annotations

import tomllib
from pathlib import Path

import pytest
from impactbench.engines.registry import engine_names

from impactbench import config
from impactbench.cli import main


def test_default_config_is_the_issue_matrix() -> None:
    cfg = config.load()
    ball, rf, oblique, bounce, cube = cfg.scenarios
    assert bounce.values("height_m") == (0.2,) and bounce.modes == ("default", "native", "tuned")
    assert cube.name == "cube-toss" and cube.points() == []  # the real tosses' section
    assert oblique.values("angle_deg") == (20.0, 45.0, 60.0, 80.0)
    assert oblique.parameters == {"friction": 0.3}
    assert ball.velocities_m_s == (0.5, 1.0, 2.0, 3.0, 4.0, 5.0)
    assert rf.velocities_m_s == (2.0, 10.0)
    assert set(rf.values("local")) == {"linear", "elastoplastic", "mutation"}
    assert set(rf.values("structure")) == {"linear", "softening"}
    # every registered engine has its row in the default report
    assert set(engine_names()) <= set(cfg.engines)
    assert all(ball.timestep_s[e] > 0 for e in cfg.engines)
    assert cfg.work_precision is not None and min(cfg.work_precision.timesteps_s) == 1e-7


@pytest.mark.parametrize(
    ("text", "needle"),
    [
        ("[report]\nengins = ['mujoco']", "report.engins: unknown key (did you mean 'engines'?)"),
        ("[ball_on_plate]\nvelocities_m_s = [1.0, -2.0]",
         "ball_on_plate.velocities_m_s = -2.0: must be > 0"),
        ("[ball_on_plate]\nvelocities_m_s = 'fast'", "must be a list of numbers"),
        ("[ball_on_plate]\nmass_kg = 'heavy'", "ball_on_plate.mass_kg = 'heavy'"),
        ("[rigid_flexible]\nlocal = ['plastic']", "rigid_flexible.local = 'plastic'"),
        ("[rigid_flexible.timestep_s]\nmujoco = 0", "rigid_flexible.timestep_s.mujoco = 0"),
        ("[work_precision]\ntimesteps_s = [1e-6]\nmodes = ['tuned']",
         "work_precision.modes = 'tuned'"),
        ("colour = 'red'", "colour: unknown key"),
    ],
)
def test_bad_config_names_the_key(text: str, needle: str) -> None:
    with pytest.raises(ValueError) as err:
        config.parse(tomllib.loads(text))
    assert needle in str(err.value)
    assert "\n" not in str(err.value)


def test_cli_exits_2_with_one_line(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text("[ball_on_plate]\nvelocities_m_s = [-1.0]\n")
    assert main(["report", "--config", str(bad), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "ball_on_plate.velocities_m_s = -1.0" in err
    broken = tmp_path / "broken.toml"
    broken.write_text("[report\n")
    assert main(["report", "--config", str(broken)]) == 2
    assert "not valid TOML" in capsys.readouterr().err


def test_hash_follows_content() -> None:
    a = config.parse({"ball_on_plate": {"velocities_m_s": [1.0]}})
    b = config.parse({"ball_on_plate": {"velocities_m_s": [2.0]}})
    assert a.hash != b.hash
    assert a.hash == config.parse({"ball_on_plate": {"velocities_m_s": [1.0]}}).hash
