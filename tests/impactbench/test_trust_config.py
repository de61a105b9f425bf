"""Engine parameter values in a config or a gate file are checked before any run, by the
engine's own parser: ``[engines.mujoco] solref = "banana"`` used to write a report of crashed
rows and exit 0; a bad value given to one run is one line and exit 2, not ``crashed``."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
from conftest import require_engine

from impactbench import config, gates

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize("engine, table, needle", [
    ("mujoco", {"solref": "banana"}, "param solref = 'banana': must be a list of 2 numbers"),
    ("pybullet", {"contactStiffness": -5.0, "contactDamping": 1.0},
     "param contactStiffness = -5.0: must be >= 0 and finite"),
    ("drake", {"point_stiffness": float("nan")}, "param point_stiffness = nan: must be > 0"),
])
def test_a_config_with_a_bad_value_is_refused_before_any_run(engine, table, needle) -> None:
    require_engine(engine)
    with pytest.raises(ValueError) as info:
        config.parse({"report": {"engines": [engine], "modes": ["custom"]},
                      "ball_on_plate": {"velocities_m_s": [1.0]}, "engines": {engine: table}})
    assert str(info.value) == f"engines.{engine}: {needle}" or needle in str(info.value)
    assert str(info.value).startswith(f"engines.{engine}: ")


def test_a_gate_with_a_bad_value_is_refused() -> None:
    require_engine("mujoco")
    text = ('[[gate]]\nengine = "mujoco"\nmode = "custom"\nscenario = "ball-on-plate"\n'
            'params = {solref = "banana"}\n[gate.tolerance]\nrestitution = 0.1\n')
    with pytest.raises(ValueError, match=r"params: param solref = 'banana': must be a list"):
        gates.parse_gates(text, "g.toml")


def test_one_run_with_a_bad_value_is_exit_2_not_crashed() -> None:
    require_engine("mujoco")
    got = subprocess.run([sys.executable, "-m", "impactbench.cli", "run", "ball-on-plate",
                          "--engine", "mujoco", "--mode", "custom", "--param", "solref=banana",
                          "--velocity", "1"], cwd=ROOT, capture_output=True, text=True,
                         timeout=120)
    assert got.returncode == 2
    assert got.stderr.strip() == ("impactbench: error: param solref = 'banana': must be a "
                                  "list of 2 numbers")
