"""Issue 21, goal 3: a user's config file is layered over the packaged default.

Tables merge key by key, a key the user sets replaces the default's value, lists replace; a
default section is dropped by emptying it. ``config.parse`` of a dict does not layer (tests and
callers that build a whole config inline keep their meaning).
"""

from __future__ import annotations

from pathlib import Path

import pytest
from conftest import require_engine

from impactbench import config, matrix
from impactbench.cli import main

DROP_ALL = """
[ball_on_plate]
velocities_m_s = []
[rigid_flexible]
velocities_m_s = []
[oblique]
velocities_m_s = []
[bounce]
heights_m = []
[work_precision]
timesteps_s = []
[practical]
velocities_m_s = []
[cube_toss]
engines = []
"""


def write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "my.toml"
    path.write_text(text)
    return path


def test_engines_alone_is_the_default_report_for_that_engine(tmp_path: Path) -> None:
    mine = config.load(write(tmp_path, '[report]\nengines = ["mujoco"]\n'))
    default = config.load()
    assert mine.engines == ("mujoco",)
    assert mine.modes == default.modes and mine.title == default.title
    assert mine.scenarios == default.scenarios
    assert mine.work_precision == default.work_precision
    assert mine.practical == default.practical
    jobs = matrix.plan(mine)
    assert jobs and jobs == [j for j in matrix.plan(default) if j.engine == "mujoco"]
    assert {j.study for j in jobs} == {"matrix", "real_tosses", "practical", "work_precision"}


def test_tables_merge_key_by_key_and_lists_replace(tmp_path: Path) -> None:
    cfg = config.load(write(tmp_path, "[ball_on_plate]\nvelocities_m_s = [2.0]\n"
                                      "[ball_on_plate.timestep_s]\nmujoco = 1e-5\n"
                                      "[practical.timesteps_s]\nmujoco = [1e-3]\n"))
    ball, rf, _oblique, _bounce, _cube = cfg.scenarios
    assert ball.velocities_m_s == (2.0,)  # replaced, not appended
    assert ball.timestep_s["mujoco"] == 1e-5 and ball.timestep_s["drake"] == 1e-6  # merged
    assert rf.velocities_m_s == (2.0, 10.0)  # the default's
    assert cfg.practical.timesteps_s["mujoco"] == (1e-3,)
    assert cfg.practical.timesteps_s["pybullet"] == (1 / 240,)
    assert cfg.raw["ball_on_plate"]["velocities_m_s"] == [2.0]  # the hash is of the merge


def test_every_default_section_can_be_dropped(tmp_path: Path) -> None:
    cfg = config.load(write(tmp_path, '[report]\nengines = ["mujoco"]\n' + DROP_ALL))
    assert all(not s.points() for s in cfg.scenarios)
    assert "cube-toss" not in {s.name for s in cfg.scenarios}  # engines = []: dropped
    assert cfg.work_precision is None and cfg.practical is None
    assert matrix.plan(cfg) == []


def test_parse_of_a_dict_does_not_layer() -> None:
    cfg = config.parse({"report": {"engines": ["mujoco"]}})
    assert cfg.scenarios == () and cfg.work_precision is None and cfg.practical is None


def test_layered_does_not_touch_its_inputs() -> None:
    base = {"a": {"b": 1, "c": [1, 2]}, "d": 1}
    over = {"a": {"c": [3]}, "e": 2}
    assert config.layered(base, over) == {"a": {"b": 1, "c": [3]}, "d": 1, "e": 2}
    assert base == {"a": {"b": 1, "c": [1, 2]}, "d": 1} and over == {"a": {"c": [3]}, "e": 2}


def test_errors_still_name_the_users_key(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match=r"report.engins: unknown key \(did you mean "
                                         r"'engines'\?\)"):
        config.load(write(tmp_path, '[report]\nengins = ["mujoco"]\n'))


def test_report_of_mujoco_alone_runs_the_mujoco_rows(tmp_path: Path, capsys,
                                                    monkeypatch) -> None:
    """End to end through `report` on the real engine: the layered default, cut down to one
    ball point by the user's file (everything else dropped), runs MuJoCo only."""
    require_engine("mujoco")
    monkeypatch.setenv("IMPACTBENCH_STORE", str(tmp_path / "store.duckdb"))
    path = write(tmp_path, '[report]\nengines = ["mujoco"]\nmodes = ["injected"]\n'
                 + DROP_ALL.replace("[ball_on_plate]\nvelocities_m_s = []",
                                    "[ball_on_plate]\nvelocities_m_s = [1.0]"))
    out = tmp_path / "rep"
    assert main(["report", "--config", str(path), "--out", str(out), "--workers", "1"]) == 0
    import csv

    with (out / "results.csv").open() as fh:
        rows = list(csv.DictReader(fh))
    assert {(r["engine"], r["mode"], r["scenario"]) for r in rows} == {
        ("mujoco", "injected", "ball-on-plate")}
    assert {float(r["timestep_s"]) for r in rows} == {1e-6}  # the default's [..timestep_s]


def test_a_single_work_precision_velocity_replaces_the_defaults_list(tmp_path: Path) -> None:
    cfg = config.load(write(tmp_path, "[work_precision]\nvelocity_m_s = 2.0\n"))
    assert cfg.work_precision.velocities_m_s == (2.0,)
    assert cfg.work_precision.timesteps_s == config.load().work_precision.timesteps_s
