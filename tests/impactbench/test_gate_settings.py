"""Issue 21, goal 5: a gate takes the user's settings — engine parameters (``params``, custom
mode) or a tuned file of theirs (``tuned_file``, tuned mode) — and the ids of gates without
them (the committed baseline's keys) do not change."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest
from conftest import require_engine

from impactbench.cli import main
from impactbench.gates import execute, load_gates, parse_gates
from impactbench.store import Store
from impactbench.tuned import TUNED_DIR

ROOT = Path(__file__).resolve().parents[2]
TUNED_2MS = TUNED_DIR / "mujoco_ball_on_plate_dt2ms.toml"


def gate(body: str, tolerance: str = "restitution = 1.0") -> str:
    return ('[[gate]]\nengine = "mujoco"\nscenario = "ball-on-plate"\nvelocities_m_s = [2.0]\n'
            f"{body}\n[gate.tolerance]\n{tolerance}\n")


def test_existing_check_ids_do_not_change() -> None:
    ids = {c.id for c in load_gates(ROOT / "gates.toml").checks}
    baseline = json.loads((ROOT / "gates_baseline.json").read_text())["checks"]
    assert ids == set(baseline)


def test_params_run_custom_with_a_distinguishing_label() -> None:
    checks = parse_gates(gate('mode = "custom"\nparams = {solref = [0.02, 1.0]}'),
                         "g.toml").checks
    (c,) = checks
    assert c.run.mode == "custom" and c.run.params == (("solref", (0.02, 1.0)),)
    assert c.id == "mujoco-custom-ball-on-plate-v2-dt1e-06-solref=0.02,1-restitution"
    # the same gate without params would be another check: both may stand in one file
    both = parse_gates(gate('mode = "custom"\nparams = {solref = [0.02, 1.0]}')
                       + gate('mode = "custom"\nparams = {solref = [0.01, 1.0]}'), "g.toml")
    assert len({c.id for c in both.checks}) == 2


def test_a_text_scenario_field_gets_a_label() -> None:
    """A gate on the disc (``shape``, a text field) names it in its id (it crashed: the
    label formatted every field as a number)."""
    body = ('[[gate]]\nengine = "pymunk"\nmode = "injected"\nscenario = "oblique"\n'
            'angles_deg = [20.0]\nvelocities_m_s = [2.0]\ntimesteps_s = [1e-6]\n'
            'parameters = {friction = 0.3, shape = "disc"}\n[gate.tolerance]\n'
            'restitution = 1.0\n')
    (c,) = parse_gates(body, "g.toml").checks
    assert c.id == "pymunk-injected-oblique-friction0.3-shapedisc-a20-v2-dt1e-06-restitution"


@pytest.mark.parametrize(("body", "needle"), [
    ('mode = "custom"', "gate 1: mode = 'custom': needs params"),
    ('mode = ["native", "custom"]', "mode = 'custom': needs params"),
    ('mode = "custom"\nparams = {solreff = [0.02, 1.0]}',
     "params.solreff: not a mujoco parameter (did you mean 'solref'?); valid keys: solref, "
     "solimp, integrator"),
    ('mode = "injected"\nparams = {solref = [0.02, 1.0]}',
     "engine parameters are for mode custom"),
    ('mode = "custom"\nparams = {}', "params = {}: must be a non-empty table"),
    ('mode = "native"\ntuned_file = "x.toml"', "a tuned file is for mode tuned"),
    ('mode = "tuned"\ntuned_file = "missing.toml"', "no such file"),
])
def test_bad_settings_are_one_line(body: str, needle: str) -> None:
    with pytest.raises(ValueError) as info:
        parse_gates(gate(body), "g.toml")
    err = str(info.value)
    assert "\n" not in err and err.startswith("g.toml:"), err
    assert needle in err, err


def test_tuned_file_is_relative_to_the_gate_file_and_bound_to_its_step(tmp_path: Path) -> None:
    shutil.copy(TUNED_2MS, tmp_path / "mine.toml")
    path = tmp_path / "gates.toml"
    path.write_text(gate('mode = "tuned"\ntuned_file = "mine.toml"'))
    (c,) = load_gates(path).checks
    assert c.run.tuned_file == str((tmp_path / "mine.toml").resolve())
    assert c.run.timestep_s == 2e-3  # the step the file was fitted at
    assert c.id == "mujoco-tuned-ball-on-plate-v2-dt0.002-tuned=mine.toml-restitution"
    path.write_text(gate('mode = "tuned"\ntuned_file = "mine.toml"\ntimesteps_s = [1e-3]'))
    with pytest.raises(ValueError, match=r"fitted at timestep_s = 0\.002"):
        load_gates(path)
    path.write_text(gate('mode = "tuned"\ntuned_file = "mine.toml"').replace(
        'engine = "mujoco"', 'engine = "pybullet"'))
    with pytest.raises(ValueError, match="fitted for 'mujoco'; the gate names pybullet"):
        load_gates(path)
    (tmp_path / "bad.toml").write_text(TUNED_2MS.read_text().replace("\nsolimp =", "\nsolimpp ="))
    path.write_text(gate('mode = "tuned"\ntuned_file = "bad.toml"'))
    with pytest.raises(ValueError, match=r"parameters.solimpp: not a mujoco tuned key \(did "
                                         r"you mean 'solimp'\?\)"):
        load_gates(path)


def run_json(capsys, *argv: str) -> dict:
    main(["run", "--engine", "mujoco", "--scenario", "ball-on-plate", "--velocity", "2",
          "--json", *argv])
    return json.loads(capsys.readouterr().out)


def test_the_gates_settings_reach_the_engine(tmp_path: Path, capsys) -> None:
    """On MuJoCo: the gate's custom run is `run --mode custom --param …`, its tuned run is
    `run --tuned FILE` (the same values), and both differ from the engine's defaults."""
    require_engine("mujoco")
    shutil.copy(TUNED_2MS, tmp_path / "mine.toml")
    path = tmp_path / "gates.toml"
    path.write_text(gate('mode = "custom"\nparams = {solref = [0.005, 1.0]}\n'
                         "timesteps_s = [1e-5]")
                    + gate('mode = "default"\ntimesteps_s = [1e-5]')
                    + gate('mode = "tuned"\ntuned_file = "mine.toml"'))
    checks = load_gates(path).checks
    got = execute([c.run for c in checks], jobs=0, store=Store(tmp_path / "s.duckdb"))
    custom, default, tuned = (got[c.run] for c in checks)
    assert custom["params"]["solref"] == [0.005, 1.0]
    want = run_json(capsys, "--mode", "custom", "--param", "solref=0.005,1", "--timestep",
                    "1e-5")
    assert custom["restitution"] == pytest.approx(want["restitution"], rel=1e-12)
    assert custom["restitution"] != pytest.approx(default["restitution"], rel=1e-3)
    want = run_json(capsys, "--tuned", str(tmp_path / "mine.toml"), "--timestep", "2e-3")
    assert tuned["timestep_s"] == 2e-3
    assert tuned["restitution"] == pytest.approx(want["restitution"], rel=1e-12)
