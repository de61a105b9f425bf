"""Issue 21, goal 1: a material carries its damping (its nominal restitution e).

``--material rubber`` used to keep the steel ball's b = 0.1 s/m, so rubber bounced like steel
(0.882 at 2 m/s). Now the material's e sets the damping through the Hunt–Crossley model
(b = 3(1 − e)/(2·V0) at each V0), whose effective restitution is k(3(1 − e)/2) — a known,
velocity-independent error against e (+0.033 at e = 0.8, +0.009 at 0.9).
"""

from __future__ import annotations

import json
import tomllib
from pathlib import Path

import pytest
from conftest import require_engine
from impactbench.reference import hunt_crossley
from impactbench.reference.materials import ball_parameters, material, materials
from impactbench.reference.models import HuntCrossleyModel

from impactbench import config
from impactbench.cli import main
from impactbench.scenario_file import load_scenario_file

BALL = ("--radius", "0.03", "--mass", "0.05", "--velocity", "2")


def cli_json(capsys, *argv: str) -> dict:
    code = main([str(a) for a in argv])
    out = capsys.readouterr().out
    assert code == 0, out
    return json.loads(out)


def reference(capsys, *flags: str) -> float:
    return cli_json(capsys, "reference", "ball-on-plate", *flags, *BALL, "--json")["restitution"]


def known(e: float) -> float:
    """The Hunt–Crossley model's bounce at nominal e (any V0, c, n, m)."""
    return float(hunt_crossley.restitution(HuntCrossleyModel.alpha(e)))


def test_every_material_has_a_nominal_restitution_inside_its_range() -> None:
    for m in materials().values():
        assert m.restitution is not None
        assert m.restitution_range[0] <= m.restitution <= m.restitution_range[1], m.name
    assert ball_parameters(0.03, material_name="rubber")["nominal_restitution"] == 0.8
    assert ball_parameters(0.03, youngs_modulus_pa=3e9, poisson=0.4,
                           mass_kg=0.01)["nominal_restitution"] is None


def test_rubber_bounces_at_its_own_restitution_not_steels(capsys) -> None:
    got = {name: reference(capsys, "--material", name) for name in ("rubber", "steel", "glass")}
    assert got["rubber"] < got["steel"] < got["glass"]
    for name, e in got.items():
        nominal = material(name).restitution
        # exactly the model's known bounce, and within its known error of e
        assert e == pytest.approx(known(nominal), rel=1e-9), name
        assert abs(e - nominal) <= 0.04, name
    # the same at any velocity: b = α(e)/V0
    slow = cli_json(capsys, "reference", "ball-on-plate", "--material", "rubber", "--radius",
                    "0.03", "--mass", "0.05", "--velocity", "0.5", "--json")["restitution"]
    assert slow == pytest.approx(got["rubber"], rel=1e-9)


def test_explicit_damping_or_nominal_restitution_wins(capsys) -> None:
    plain = reference(capsys, "--damping", "0.1", "--stiffness", "6.078e5")
    with_b = reference(capsys, "--material", "rubber", "--damping", "0.1")
    assert with_b == pytest.approx(plain, rel=1e-9)  # b = 0.1 s/m: the steel ball's 0.882
    assert with_b == pytest.approx(0.8822, abs=1e-4)
    with_e = reference(capsys, "--material", "rubber", "--nominal-restitution", "0.6")
    assert with_e == pytest.approx(known(0.6), rel=1e-9)


def test_engine_run_of_a_rubber_ball_bounces_at_the_rubber_reference(capsys) -> None:
    require_engine("mujoco")
    out = cli_json(capsys, "run", "--engine", "mujoco", "--scenario", "ball-on-plate",
                   "--mode", "injected", "--material", "rubber", *BALL, "--timestep", "1e-5",
                   "--json")
    assert out["status"] == "ok", out["message"]
    assert out["reference"]["restitution"] == pytest.approx(known(0.8), rel=1e-9)
    assert out["restitution"] == pytest.approx(known(0.8), abs=2e-3)


def test_config_and_scenario_file_take_a_material(tmp_path: Path) -> None:
    cfg = tmp_path / "rubber.toml"
    cfg.write_text('[report]\nengines = ["mujoco"]\n[ball_on_plate]\nmaterial = "rubber"\n'
                   "radius_m = 0.03\nmass_kg = 0.05\n")
    ball = config.load(cfg).scenarios[0]
    assert ball.parameters["nominal_restitution"] == 0.8
    model = ball.points()[0]
    from impactbench.scenarios import get

    built = get("ball-on-plate").build(model, ball.parameters)
    assert hunt_crossley.solve(built)["restitution"] == pytest.approx(known(0.8), rel=1e-9)
    # an explicit damping in the table wins over the material's e
    plain = config.parse(tomllib.loads('[ball_on_plate]\nmaterial = "rubber"\n'
                                       "damping_s_per_m = 0.1\n")).scenarios[0]
    assert "nominal_restitution" not in plain.parameters
    scenario_file = tmp_path / "ball.toml"
    scenario_file.write_text('[ball_on_plate]\nmaterial = "glass"\nplate_material = "steel"\n'
                             "radius_m = 0.01\n")
    fields = load_scenario_file(scenario_file)
    assert fields["nominal_restitution"] == 0.95 and fields["mass_kg"] > 0


@pytest.mark.parametrize("where", ["cli", "config", "scenario_file"])
def test_a_misspelt_material_is_one_line_with_did_you_mean(capsys, tmp_path: Path,
                                                          where: str) -> None:
    if where == "cli":
        assert main(["reference", "ball-on-plate", "--material", "rubbr", *BALL]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and err.startswith("impactbench: error:"), err
    else:
        path = tmp_path / "c.toml"
        path.write_text('[ball_on_plate]\nmaterial = "rubbr"\n')
        with pytest.raises(ValueError) as info:
            config.load(path) if where == "config" else load_scenario_file(path)
        err = str(info.value)
        assert "\n" not in err
        assert "ball_on_plate.material = 'rubbr'" in err
    assert "material = 'rubbr'" in err and "(did you mean 'rubber'?)" in err
