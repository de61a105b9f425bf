"""The ball's shape in the oblique impact (issue 22): a sphere (k² = 2R²/5) or, for the 2D
engines, a disc (k² = R²/2). The rigid closed form for a disc against the event-switched
integration and against the hand-derived disc formulas; the field, its properties, its flag
and its config key."""

from __future__ import annotations

import json
import math

import pytest
from impactbench.reference import oblique
from impactbench.reference import oblique_integrate as oi
from impactbench.reference.oblique import Oblique
from oblique_checks import LAWS, close

from impactbench.commands.oblique import main
from impactbench.scenarios.oblique import SPEC


def test_shape_properties():
    m, r = 0.1, Oblique().radius_m
    sphere, disc = Oblique(), Oblique(shape="disc")
    assert sphere.shape == "sphere"  # the default: nothing the sphere had moves
    assert (sphere.gyration_ratio, sphere.spin_factor) == (0.4, 3.5)
    assert (disc.gyration_ratio, disc.spin_factor) == (0.5, 3.0)
    assert sphere.moment_of_inertia_kg_m2 == pytest.approx(0.4 * m * r * r, rel=1e-15)
    assert disc.moment_of_inertia_kg_m2 == pytest.approx(0.5 * m * r * r, rel=1e-15)
    assert oblique.SPIN_FACTOR == sphere.spin_factor and oblique.SHAPES == ("sphere", "disc")


def test_bad_shape_is_one_line_naming_field_value_and_rule():
    with pytest.raises(ValueError) as info:
        Oblique(shape="cube")
    msg = str(info.value)
    assert msg == "shape = 'cube': must be one of sphere, disc"
    with pytest.raises(ValueError, match=r"^shape = 'dics': must be one of sphere, disc "
                                         r"\(did you mean 'disc'\?\)$"):
        Oblique(shape="dics")


@pytest.mark.parametrize("law", list(LAWS))
@pytest.mark.parametrize("side", [0.99, 1.01])
def test_disc_closed_form_equals_integration_both_sides_of_the_threshold(law, side):
    """The disc's threshold tan θ_c = μ·(1 + e)·(1 + R²/k²) = 3·μ·(1 + e); 1 % either side the
    closed form and the integration agree to ≤ 1e-8 (as the sphere's)."""
    s = Oblique(shape="disc", **LAWS[law])
    theta_c = oblique.threshold_angle_deg(s)
    e_c = oblique.rigid(s.replace(angle_deg=theta_c))["restitution"]
    assert math.tan(math.radians(theta_c)) == pytest.approx(3.0 * s.friction * (1 + e_c),
                                                            rel=1e-12)
    assert theta_c < oblique.threshold_angle_deg(Oblique(**LAWS[law]))  # slides sooner
    sc = s.replace(angle_deg=theta_c * side)
    ref = oblique.rigid(sc)
    assert close(oi.rigid(sc), ref) == []
    assert ref["regime"] == (oblique.SLIDE if side > 1 else oblique.STICK)


@pytest.mark.parametrize("law", list(LAWS))
@pytest.mark.parametrize(("angle", "spin"), [(10.0, 0.0), (30.0, -150.0), (45.0, 200.0),
                                             (80.0, 0.0), (0.0, 80.0)])
def test_disc_closed_form_equals_integration_elsewhere(law, angle, spin):
    sc = Oblique(angle_deg=angle, spin_rad_s=spin, shape="disc", **LAWS[law])
    assert close(oi.rigid(sc), oblique.rigid(sc)) == []


def test_disc_hand_derived_formulas():
    """By hand for a disc (I = m·R²/2, so a tangential impulse J changes the slip by 3·J/m):
    below the threshold the slip stops, v_t' = v_t − s0/3 (2/3 of v_t without spin) and it
    rolls, ω' = v_t'/R; above it, Δv_t = −μ·(1 + e)·v_n and Δω = 2·μ·(1 + e)·v_n/R."""
    s = Oblique(shape="disc", velocity_m_s=2.0, friction=0.3)
    r = s.radius_m
    stick = oblique.rigid(s.replace(angle_deg=45.0))
    v_t = 2.0 * math.sin(math.pi / 4)
    assert stick["tangential_restitution"] == pytest.approx(2.0 / 3.0, rel=1e-14)
    assert stick["spin_out_rad_s"] == pytest.approx(2.0 / 3.0 * v_t / r, rel=1e-14)
    assert stick["contact_point_ratio"] == pytest.approx(0.0, abs=1e-14)
    backspin = s.replace(angle_deg=45.0, spin_rad_s=-50.0)  # still below the threshold
    got = oblique.rigid(backspin)
    s0 = v_t + 50.0 * r
    assert got["tangential_restitution"] * v_t == pytest.approx(v_t - s0 / 3.0, rel=1e-13)
    slide = s.replace(angle_deg=80.0)
    got = oblique.rigid(slide)
    e, v_n = got["restitution"], slide.normal_velocity_m_s
    impulse = 0.3 * (1.0 + e) * v_n
    assert got["tangential_restitution"] * slide.tangential_velocity_m_s == pytest.approx(
        slide.tangential_velocity_m_s - impulse, rel=1e-14)
    assert got["spin_out_rad_s"] == pytest.approx(2.0 * impulse / r, rel=1e-14)
    assert got["regime"] == oblique.SLIDE


def test_disc_compliant_references_use_the_disc():
    """Both compliant laws spin a disc up less than a sphere (its larger inertia), with the
    same normal part."""
    for tangential in ("mindlin", "mindlin-deresiewicz"):
        sphere = Oblique.kharaz2001(angle_deg=20.0, tangential=tangential)
        a, b = oblique.solve(sphere), oblique.solve(sphere.replace(shape="disc"))
        assert b["spin_out_rad_s"] < a["spin_out_rad_s"]
        for k in ("restitution", "duration_s", "peak_force_n"):
            assert b[k] == pytest.approx(a[k], rel=1e-9)


def test_plausibility_energy_uses_the_shapes_inertia():
    s = Oblique(shape="disc", angle_deg=45.0)
    ref = oblique.rigid(s)

    np = __import__("numpy")

    class Rec:  # a record's fields the measures read (one contact sample at a 1 µs step)
        penetration_m = np.asarray([0.0, 1e-5])
        penetration_rate_m_s = np.asarray([1.0, 0.0])
        normal_force_n = np.asarray([0.0, 1.0])

        @property
        def meta(self) -> dict:
            return {"timestep_s": 1e-6}

        def __len__(self) -> int:
            return 2

    got = SPEC.measure(s, Rec(), ref)
    v_n, v_t = s.normal_velocity_m_s, s.tangential_velocity_m_s
    after = (s.mass_kg * ((ref["restitution"] * v_n) ** 2
                          + (ref["tangential_restitution"] * v_t) ** 2)
             + 0.5 * s.mass_kg * s.radius_m**2 * ref["spin_out_rad_s"] ** 2)
    assert got["energy_ratio"] == pytest.approx(after / (s.mass_kg * s.velocity_m_s**2),
                                                rel=1e-14)


def test_shape_flag_and_config_key(capsys):
    """``--shape disc`` reaches the reference; ``shape`` is a config key of ``[oblique]`` and
    a field of the run key (``RunKey.parameters``, the store's ``physics``), so sphere and disc
    results never share a key."""
    code = main(["reference", "oblique", "--angle-deg", "45", "--shape", "disc", "--json"])
    obj = json.loads(capsys.readouterr().out)
    assert code == 0 and obj["tangential_restitution"] == pytest.approx(2.0 / 3.0, rel=1e-14)
    assert main(["reference", "oblique", "--shape", "cube"]) == 2
    assert "--shape: invalid choice: 'cube'" in capsys.readouterr().err
    from impactbench import config

    cfg = config.parse({"oblique": {"shape": "disc", "angles_deg": [30.0],
                                    "velocities_m_s": [2.0]}})
    oblique_table = next(s for s in cfg.scenarios if s.name == "oblique")
    assert oblique_table.parameters == {"shape": "disc"}
    with pytest.raises(ValueError, match=r"^oblique\.shape = 'cube': must be one of"):
        config.parse({"oblique": {"shape": "cube"}})
    point = (("angle_deg", 30.0), ("velocity_m_s", 2.0))
    disc = SPEC.build(point, (("shape", "disc"),))
    assert disc.shape == "disc" and SPEC.build(point).shape == "sphere"
    assert disc.to_dict()["shape"] == "disc" and SPEC.build(point).to_dict()["shape"] == "sphere"
