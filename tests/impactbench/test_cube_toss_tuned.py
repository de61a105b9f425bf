"""``tuned`` mode of the cube tosses and ``impactbench tune --scenario cube-toss`` (issue 23):
the fitted parameters reach the engine (read back from its setup), a tuned file binds to its
engine, step and cube, and a CLI fit writes a file that ``run --mode tuned --tuned`` replays.

Tosses 0, 7 and 9 are test tosses (``data.split``); each replay here is well under a second.
"""

from __future__ import annotations

import json
import math
import tomllib
from pathlib import Path

import pytest
from conftest import require_engine

from impactbench.cli import main
from impactbench.cube_tosses import data as data_mod
from impactbench.cube_tosses.replays import replay
from impactbench.cube_tosses.tune import load_tuned, tuned_path

NAME = "cube-toss"
TEST_IDS = [0, 7, 9]
TRAIN_IDS = [1, 2, 4]


def run_json(capsys, *argv: str) -> tuple[int, dict]:
    code = main(["run", NAME, *argv, "--json"])
    out = capsys.readouterr().out
    return code, json.loads(out)


def test_the_ids_used_here_are_in_their_splits() -> None:
    every = data_mod.toss_ids(data_mod.load())
    assert data_mod.split(TEST_IDS, "test") == TEST_IDS
    assert data_mod.split(TRAIN_IDS, "train") == TRAIN_IDS
    assert set(TEST_IDS + TRAIN_IDS) <= set(every)


def test_tuned_mode_replays_the_packaged_fit_and_it_reaches_the_engine(capsys) -> None:
    require_engine("pybullet")
    code, got = run_json(capsys, "--engine", "pybullet", "--mode", "tuned", "--tosses",
                         ",".join(map(str, TEST_IDS)))
    assert code == 0 and got["status"] == "ok" and got["mode"] == "tuned"
    params = load_tuned("pybullet")
    assert got["tuned_file"] == str(tuned_path("pybullet"))
    assert got["params"] == {k: list(v) if isinstance(v, tuple) else v
                             for k, v in params.items()}
    # read back from the engine (getDynamicsInfo of both bodies, combined by Bullet's rules:
    # stiffness in series with the cube's unset 1e30 N/m, friction the product)
    eff = got["engine_setup"]["effective"]
    assert math.isclose(eff["contact_stiffness_n_per_m"], params["board.contactStiffness"],
                        rel_tol=1e-9), eff
    assert math.isclose(eff["friction"], params["board.lateralFriction"]
                        * params["cube.lateralFriction"], rel_tol=1e-12), eff
    want = replay("pybullet", "custom", tosses=TEST_IDS, params=params)
    assert got["position_error_median"] == want["position_error_median"]
    assert got["message"] == ""  # test tosses: held out, nothing to say


def test_a_tuned_file_binds_to_its_engine_step_and_cube(capsys) -> None:
    require_engine("mujoco")
    ids = ",".join(map(str, TEST_IDS))
    code, got = run_json(capsys, "--engine", "pybullet", "--mode", "tuned", "--tosses", ids,
                         "--timestep", "1e-3")
    assert (code, got["status"]) == (1, "unsupported")
    assert "fitted at engine step 0.000675676 s, this run has 0.000965251 s" in got["message"]
    code, got = run_json(capsys, "--engine", "pybullet", "--mode", "tuned", "--tosses", ids,
                         "--half-width", "0.05")
    assert (code, got["status"]) == (1, "unsupported")
    assert "cube half-width 0.0524 m, this run has 0.05 m" in got["message"]
    code, got = run_json(capsys, "--engine", "mujoco", "--mode", "tuned", "--tosses", ids,
                         "--tuned", str(tuned_path("pybullet")))
    assert (code, got["status"]) == (1, "unsupported")
    assert "fitted for 'pybullet' on 'cube-toss', not 'mujoco'" in got["message"]


@pytest.mark.parametrize("argv, needle", [
    (["--engine", "mujoco", "--mode", "tuned", "--param-set", "dair2022"],
     "tuned mode takes its parameters from the tuned file"),
    (["--engine", "mujoco", "--mode", "custom", "--param-set", "dair2022", "--tuned",
      "x.toml"], "--tuned needs --mode tuned"),
    (["--engine", "mujoco", "--mode", "tuned", "--tuned", "/nonexistent.toml"],
     "tuned = '/nonexistent.toml': no such file"),
])
def test_bad_tuned_input_is_one_line(capsys, argv: list[str], needle: str) -> None:
    assert main(["run", NAME, *argv]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and needle in err, err


def test_a_file_that_is_not_a_tuned_file_is_one_line(capsys, tmp_path: Path) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text("[parameters\n")
    assert main(["run", NAME, "--engine", "mujoco", "--mode", "tuned",
                 "--tuned", str(bad)]) == 2
    err = capsys.readouterr().err
    assert "not a cube-toss tuned file" in err and err.count("\n") == 1


def test_tune_cli_fits_on_training_tosses_and_run_replays_the_file(
        capsys, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A 3-evaluation fit on three training tosses: the file's [parameters] are the best
    candidate's, `run --mode tuned --tuned FILE` replays exactly them, and a rerun is served
    from the evaluation cache."""
    require_engine("pybullet")
    monkeypatch.setenv("IMPACTBENCH_TUNE_CACHE", str(tmp_path / "cache.sqlite"))
    out = tmp_path / "pb.toml"
    argv = ["tune", "--scenario", NAME, "--engine", "pybullet", "--budget", "3", "--tosses",
            ",".join(map(str, TRAIN_IDS)), "--out", str(out), "--json"]
    assert main(argv) == 0
    first = json.loads(capsys.readouterr().out)
    doc = tomllib.loads(out.read_text())
    prov = doc["provenance"]
    assert (prov["engine"], prov["scenario"], prov["budget"], prov["train_tosses"]) == (
        "pybullet", NAME, 3, 3)
    assert first["objective_tuned"] <= first["objective_start"]
    assert set(first["references_test"]) == {"default", "dair2022"}
    assert first["test"]["tosses"] == 89
    assert main(argv) == 0
    again = json.loads(capsys.readouterr().out)
    assert again["cache_hits"] == 3 and again["parameters"] == first["parameters"]
    code, got = run_json(capsys, "--engine", "pybullet", "--mode", "tuned", "--tuned",
                         str(out), "--tosses", ",".join(map(str, TEST_IDS)))
    assert code == 0 and got["params"] == first["parameters"]


@pytest.mark.parametrize("argv, needle", [
    (["--engine", "pymunk"], "engine = 'pymunk'"),
    (["--engine", "pybullet", "--budget", "1"], "budget = 1: must be an integer >= 2"),
    (["--engine", "pybullet", "--tosses", "test"], "tuning sees training tosses only"),
    (["--engine", "pybullet", "--tosses", "0"], "test toss"),
    (["--engine", "pybullet", "--data", str(data_mod.DEFAULT_PATH)],
     "score a tuned file on your tosses"),
])
def test_tune_cube_toss_bad_input(capsys, argv: list[str], needle: str) -> None:
    assert main(["tune", "--scenario", NAME, *argv]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and needle in err, err


def test_ball_only_flags_are_refused_for_the_ball_and_vice_versa(capsys) -> None:
    assert main(["tune", "--engine", "pymunk", "--seed", "3"]) == 2
    assert "only the cube-toss fit takes it" in capsys.readouterr().err
