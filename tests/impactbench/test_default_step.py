"""Issue 21, goal 2: ``run --mode default`` without ``--timestep`` is the engine as it comes,
at its own default step (the first of its spec's ``customary_timesteps_s``), and says so."""

from __future__ import annotations

import json

import pytest
from conftest import require_engine
from impactbench.engines.registry import spec

from impactbench.api import ADAPTER_DEFAULT, ENGINE_DEFAULT, GIVEN, run_timestep
from impactbench.cli import main


def run(capsys, *argv: str) -> tuple[int, str]:
    """(exit code, stdout); the code is 1 for a non-ok status (a 2 ms MuJoCo default contact
    sinks far into the plate), which these tests do not judge."""
    code = main(["run", "ball-on-plate", "--velocity", "2", *argv])
    return code, capsys.readouterr().out


@pytest.mark.parametrize(("engine", "step"), [("mujoco", 2e-3), ("pybullet", 1 / 240)])
def test_default_mode_runs_at_the_engines_own_step(capsys, engine: str, step: float) -> None:
    require_engine(engine)
    assert spec(engine).customary_timesteps_s[0] == step
    _, out = run(capsys, "--engine", engine, "--mode", "default", "--json")
    got = json.loads(out)
    assert got["timestep_s"] == step
    assert got["timestep_source"] == ENGINE_DEFAULT == "engine default"
    assert list(got).index("timestep_source") == list(got).index("timestep_s") + 1
    _, text = run(capsys, "--engine", engine, "--mode", "default")
    assert f"timestep {step} s (engine default)" in text.splitlines()[0]


def test_a_given_step_and_other_modes_keep_theirs(capsys) -> None:
    require_engine("mujoco")
    _, out = run(capsys, "--engine", "mujoco", "--mode", "default", "--timestep", "1e-3",
                 "--json")
    got = json.loads(out)
    assert (got["timestep_s"], got["timestep_source"]) == (1e-3, GIVEN)
    _, out = run(capsys, "--engine", "mujoco", "--mode", "injected", "--json")
    got = json.loads(out)
    assert (got["timestep_s"], got["timestep_source"]) == (1e-6, ADAPTER_DEFAULT)


def test_an_engine_without_customary_steps_keeps_the_adapters() -> None:
    assert not spec("sapien").customary_timesteps_s
    assert run_timestep("sapien", "default", None) == (None, ADAPTER_DEFAULT)
    assert run_timestep("drake", "default", None) == (1e-3, ENGINE_DEFAULT)
    assert run_timestep("pymunk", "default", None) == (1 / 60, ENGINE_DEFAULT)
    assert run_timestep("pymunk", "native", None) == (None, ADAPTER_DEFAULT)
