"""Every bad input of issue 12 gives one line and exit 2, or a status — never a traceback."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest
from conftest import require_engine

from impactbench import cliutil
from impactbench.cli import main


def run(capsys, *argv: str) -> tuple[int, str, str]:
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def one_line(err: str, *needles: str) -> None:
    assert err.startswith("impactbench: error:") and err.count("\n") == 1, err
    for needle in needles:
        assert needle in err, err


@pytest.fixture
def blocked(tmp_path: Path) -> Path:
    """A path whose parent is a regular file: unwritable even for root."""
    (tmp_path / "file").write_text("")
    return tmp_path / "file" / "sub"


# a config is layered over the default (`[report] engines = ["mujoco"]` alone is the default
# report for MuJoCo): nothing is left to run once every default section is emptied
@pytest.mark.parametrize("text", ['[ball_on_plate]\nvelocities_m_s = []\n'
                                  '[rigid_flexible]\nvelocities_m_s = []\n'
                                  '[oblique]\nvelocities_m_s = []\n'
                                  '[bounce]\nheights_m = []\n'
                                  '[work_precision]\ntimesteps_s = []\n'
                                  '[practical]\nvelocities_m_s = []\n'
                                  '[cube_toss]\nengines = []\n'])
def test_a_config_with_nothing_to_run_is_one_line(capsys, tmp_path: Path, text: str) -> None:
    config = tmp_path / "c.toml"
    config.write_text(text)
    code, _, err = run(capsys, "report", "--config", config, "--out", tmp_path / "rep")
    assert code == 2
    one_line(err, "nothing to run")
    assert not (tmp_path / "rep").exists()


@pytest.mark.parametrize("argv", [
    ["report", "--out", "{blocked}"],
    ["figures", "--out", "{blocked}"],
    ["sweep", "ball-on-plate", "--over", "velocity", "--start", "1", "--stop", "2", "--step",
     "1", "--out", "{blocked}/x.csv"],
    ["sweep", "rigid-flexible", "--over", "velocity", "--start", "1", "--stop", "2", "--step",
     "1", "--out", "{blocked}/x.csv"],
    ["tune", "--engine", "pymunk", "--out", "{blocked}/t.toml"],
    ["gate", "--config", "gates.toml", "--junit", "{blocked}/j.xml"],
    ["gate", "--config", "gates.toml", "--baseline", "{missing}"],
])
def test_unwritable_outputs_and_missing_inputs_are_one_line(capsys, blocked: Path,
                                                           tmp_path: Path, argv) -> None:
    argv = [a.format(blocked=blocked, missing=tmp_path / "none.json") for a in argv]
    code, _, err = run(capsys, *argv)
    assert code == 2
    one_line(err)


def test_costly_runs_and_sweeps_need_yes(capsys, tmp_path: Path) -> None:
    code, _, err = run(capsys, "run", "ball-on-plate", "--engine", "mujoco",
                       "--velocity", "1", "--timestep", "1e-12")
    assert code == 2
    one_line(err, "timestep = 1e-12", "--yes")
    code, _, err = run(capsys, "sweep", "ball-on-plate", "--over", "velocity", "--start",
                       "1e-8", "--stop", "1", "--step", "5e-8", "--out", tmp_path / "x.csv")
    assert code == 2
    one_line(err, "sweep points", "--yes")
    code, _, err = run(capsys, "sweep", "rigid-flexible", "--over", "velocity", "--start",
                       "1", "--stop", "3e6", "--step", "1", "--out", tmp_path / "x.csv")
    assert code == 2  # 3e6 values × 6 law combinations
    one_line(err, "sweep points")
    assert not (tmp_path / "x.csv").exists()


@pytest.mark.parametrize(("flags", "needle"), [
    (["--local", "elastoplastic", "--kt", "2e5"], "kt_n_per_m = 200000.0: must be <= k1"),
    (["--local", "mutation", "--k1-failed", "2e5"], "k1_failed_n_per_m = 200000.0: must be <="),
])
def test_two_dof_laws_that_would_create_energy_are_refused(capsys, flags, needle) -> None:
    code, _, err = run(capsys, "reference", "rigid-flexible", *flags)
    assert code == 2
    one_line(err, needle)
    # the same stiffnesses are fine for a law that does not use them
    assert run(capsys, "reference", "rigid-flexible", "--kt", "2e5", "--k1-failed", "2e5")[0] \
        == 0


def test_velocity_ranges_where_the_physics_breaks(capsys) -> None:
    code, _, err = run(capsys, "reference", "ball-on-plate", "--velocity", "1e-300")
    assert code == 2
    one_line(err, "velocity_m_s = 1e-300", ">= 1e-100")
    code, out, _ = run(capsys, "reference", "ball-on-plate", "--velocity", "1,1e6", "--json")
    rows = json.loads(out)
    assert code == 0 and [(r["velocity_m_s"], r["status"]) for r in rows] == [
        (1.0, "ok"), (1e6, "unsupported")]
    assert "beyond radius_m" in rows[1]["message"]


def test_run_exits_1_unless_the_status_is_ok_or_allowed(capsys) -> None:
    require_engine("pymunk")
    argv = ["run", "ball-on-plate", "--engine", "pymunk", "--velocity", "1e6",
            "--json"]
    code, out, err = run(capsys, *argv)
    assert code == 1 and json.loads(out)["status"] == "unsupported"
    assert "--allow-status" in err
    assert run(capsys, *argv, "--allow-status", "unsupported")[0] == 0
    code, _, err = run(capsys, *argv, "--allow-status", "fine")
    assert code == 2
    one_line(err, "allow-status = 'fine'")


def test_version(capsys) -> None:
    with pytest.raises(SystemExit) as exc:
        main(["--version"])
    assert exc.value.code == 0 and capsys.readouterr().out.startswith("impactbench ")


def test_progress_is_reported_on_stderr_when_not_a_terminal(capsys, monkeypatch) -> None:
    monkeypatch.setattr(cliutil, "PROGRESS_EVERY_S", 0.0)
    update, close = cliutil.progress_bar(3)
    for _ in range(3):
        update(1)
    close()
    err = capsys.readouterr().err.splitlines()
    assert err[0].startswith("impactbench: 1 of 3 runs done")
    assert err[-1].endswith("3 of 3 runs done")


def test_progress_estimates_the_time_left(capsys, monkeypatch) -> None:
    """A line estimates the time left from the rate since the first update: 5 served at
    once, then 2 in ~0.2 s → 3 left in about 0.3 s (#32: an estimate from the first minute)."""
    import time

    monkeypatch.setattr(cliutil, "PROGRESS_EVERY_S", 0.0)
    monkeypatch.setattr(cliutil, "ETA_AFTER_S", 0.0)
    update, close = cliutil.progress_bar(10)
    update(5)  # served by the store: the rate starts here
    for _ in range(2):
        time.sleep(0.1)
        update(1)
    close()
    err = capsys.readouterr().err.splitlines()
    assert "left" not in err[0]  # no rate yet
    left = re.search(r"7 of 10 runs done \(\d+ s, about (\d+) s left\)", err[2])
    assert left and 0 <= int(left.group(1)) <= 5, err
