"""The materials table and the Hertz stiffness of a sphere from E, ν, R."""

from __future__ import annotations

import json
import math

import pytest
from impactbench.reference import materials as mat
from impactbench.reference.scenarios import PAPER_STIFFNESS, BallOnPlate

from impactbench.cli import main


def test_table_has_the_six_materials_with_sources():
    table = mat.materials()
    assert {"steel", "aluminium", "glass", "alumina", "brass", "rubber"} <= set(table)
    for m in table.values():
        assert m.youngs_modulus_pa > 0 and -1 < m.poisson < 0.5 and m.density_kg_m3 > 0
        assert 0 < m.restitution_range[0] <= m.restitution_range[1] <= 1
        assert m.source and m.restitution_source


def test_hertz_stiffness_reproduces_the_papers_c():
    # the preprint: E = 2e11 Pa, ν = 0.25 for ball and plate, R = 1.4517 cm → c = 1.7135e10
    steel = mat.Material("paper", "", 2e11, 0.25, 7800.0, "", (0.9, 1.0), "")
    c = mat.sphere_on_plate(0.014517, steel, steel)
    assert c == pytest.approx(PAPER_STIFFNESS, rel=1e-4)
    e_star = 2e11 / (2 * (1 - 0.25**2))
    assert c == pytest.approx(4 / 3 * e_star * math.sqrt(0.014517), rel=1e-14)


def test_sphere_on_sphere_tends_to_the_plate_and_is_symmetric():
    glass, steel = mat.material("glass"), mat.material("steel")
    assert mat.sphere_on_sphere(0.01, glass, 1e9, steel) == pytest.approx(
        mat.sphere_on_plate(0.01, glass, steel), rel=1e-9)
    assert mat.sphere_on_sphere(0.01, glass, 0.02, steel) == pytest.approx(
        mat.sphere_on_sphere(0.02, steel, 0.01, glass), rel=1e-15)
    # equal spheres: R* = R/2
    c = mat.sphere_on_sphere(0.01, steel, 0.01, steel)
    assert c == pytest.approx(mat.sphere_on_plate(0.005, steel, steel), rel=1e-14)


def test_ball_parameters_mass_from_density_and_explicit_mass_wins():
    p = mat.ball_parameters(0.01, material_name="brass")
    assert p["mass_kg"] == pytest.approx(8530.0 * 4 / 3 * math.pi * 1e-6, rel=1e-14)
    assert p["exponent"] == 1.5
    assert mat.ball_parameters(0.01, material_name="brass", mass_kg=0.02)["mass_kg"] == 0.02
    mine = mat.ball_parameters(0.01, youngs_modulus_pa=3e9, poisson=0.4, mass_kg=0.005)
    assert mine["stiffness"] < p["stiffness"]


@pytest.mark.parametrize(("kwargs", "message"), [
    ({"material_name": "wood"}, "material = 'wood': must be one of"),
    ({"youngs_modulus_pa": 1e9, "mass_kg": 0.1}, "poisson = None"),
    ({"youngs_modulus_pa": 1e9, "poisson": 0.3}, "mass_kg = None"),
    ({"material_name": "steel", "poisson": 0.7}, "poisson = 0.7: must be in"),
])
def test_bad_material_input_is_one_line(kwargs, message):
    with pytest.raises(ValueError, match=message):
        mat.ball_parameters(0.01, **kwargs)


def test_cli_my_rubber_ball_needs_no_hand_calculation(capsys):
    code = main(["reference", "ball-on-plate", "--material", "rubber", "--radius", "0.03",
                 "--mass", "0.05", "--model", "hunt-crossley", "--nominal-restitution", "0.8",
                 "--velocity", "2", "--json"])
    got = json.loads(capsys.readouterr().out)
    assert code == 0
    c = mat.sphere_on_plate(0.03, mat.material("rubber"), mat.material("steel"))
    from impactbench.reference import hunt_crossley as hc

    want = hc.solve(BallOnPlate(velocity_m_s=2.0, mass_kg=0.05, stiffness=c, radius_m=0.03,
                                model="hunt-crossley", nominal_restitution=0.8))
    assert got["status"] == "ok" and got["velocity_m_s"] == 2.0
    assert {k: got[k] for k in want} == pytest.approx(want, rel=1e-15)
    assert main(["reference", "ball-on-plate", "--material", "rubber",
                 "--stiffness", "1e6"]) == 2
    assert "give either --stiffness or" in capsys.readouterr().err
