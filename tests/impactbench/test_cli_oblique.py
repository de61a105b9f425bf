"""The CLI contract of ``reference oblique`` and the oblique scenario's spec.

The scenario is not in the registry yet (no engine builds it), so the command runs on its own
parser (:func:`impactbench.commands.oblique.main`), the path ``impactbench.cli`` takes once
the spec is registered.
"""

from __future__ import annotations

import argparse
import json
import math

import pytest
from impactbench.reference import oblique
from impactbench.reference import oblique_integrate as oi
from impactbench.reference.oblique import OBLIQUE_METRICS, Oblique

from impactbench.commands.oblique import main
from impactbench.scenarios.oblique import SPEC


def run(capsys, *argv: str) -> tuple[int, str, str]:
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


JSON_KEYS = ["velocity_m_s", "angle_deg", *OBLIQUE_METRICS, "status", "message"]


def test_json_one_point_has_the_inputs_nine_metrics_and_status(capsys):
    code, out, _ = run(capsys, "reference", "oblique", "--velocity", "2", "--angle-deg", "45",
                       "--friction", "0.3", "--json")
    assert code == 0
    obj = json.loads(out)
    assert list(obj) == JSON_KEYS
    assert (obj["velocity_m_s"], obj["angle_deg"], obj["status"], obj["message"]) == (
        2.0, 45.0, "ok", "")
    want = oblique.rigid(Oblique(velocity_m_s=2.0, angle_deg=45.0, friction=0.3))
    for key in OBLIQUE_METRICS:
        assert obj[key] == pytest.approx(want[key], rel=1e-15, abs=1e-300)
    assert obj["tangential_restitution"] == pytest.approx(5 / 7, rel=1e-14)
    assert obj["regime"] == 0.0


def test_json_several_points_angles_outer(capsys):
    _, out, _ = run(capsys, "reference", "oblique", "--angle-deg", "30,60", "--velocity", "1",
                    "--velocity", "2", "--json")
    rows = json.loads(out)
    assert [(r["angle_deg"], r["velocity_m_s"]) for r in rows] == [
        (30.0, 1.0), (30.0, 2.0), (60.0, 1.0), (60.0, 2.0)]
    assert all(list(r) == JSON_KEYS for r in rows)


def test_head_on_tangential_restitution_is_null(capsys):
    _, out, _ = run(capsys, "reference", "oblique", "--angle-deg", "0", "--json")
    obj = json.loads(out)
    assert obj["tangential_restitution"] is None and obj["contact_point_ratio"] is None
    assert obj["rebound_angle_deg"] == 0.0


def test_case_spin_and_mindlin_reach_the_solver(capsys):
    _, out, _ = run(capsys, "reference", "oblique", "--case", "kharaz2001", "--angle-deg",
                    "20", "--spin", "-50", "--tangential", "mindlin", "--json")
    obj = json.loads(out)
    want = oi.mindlin(Oblique.kharaz2001(angle_deg=20.0, spin_rad_s=-50.0,
                                         tangential="mindlin"))
    assert obj["velocity_m_s"] == 3.9
    for key in OBLIQUE_METRICS:
        assert obj[key] == pytest.approx(want[key], rel=1e-12)


def test_flags_override_the_case(capsys):
    _, out, _ = run(capsys, "reference", "oblique", "--case", "kharaz2001", "--velocity", "2",
                    "--friction", "0.2", "--json")
    obj = json.loads(out)
    want = oblique.rigid(Oblique.kharaz2001(velocity_m_s=2.0, friction=0.2))
    assert obj["velocity_m_s"] == 2.0
    assert obj["spin_out_rad_s"] == pytest.approx(want["spin_out_rad_s"], rel=1e-15)


def test_human_table(capsys):
    code, out, _ = run(capsys, "reference", "oblique", "--angle-deg", "45,80")
    assert code == 0
    assert "rebound_angle_deg" in out and "spin_out_rad_s" in out and "rigid" in out
    assert "0.71428571" in out  # e_t = 5/7 at 45°


def test_unsupported_beyond_the_radius(capsys):
    _, out, _ = run(capsys, "reference", "oblique", "--velocity", "2000", "--stiffness", "1e6",
                    "--json")
    obj = json.loads(out)
    assert obj["status"] == "unsupported" and "radius_m" in obj["message"]


@pytest.mark.parametrize("argv", [
    ["--angle-deg", "90"], ["--angle-deg", "-5"], ["--angle-deg", "nan"],
    ["--angle-deg", "abc"], ["--angle-deg", ""], ["--velocity", "0"], ["--friction", "-1"],
    ["--spin", "inf"], ["--tangential", "soft"], ["--case", "nope"],
    ["--model", "kelvin-voigt"], ["--model", "flores"], ["--poisson", "0.7"],
    ["--tangential", "mindlin", "--exponent", "1"], ["--mass", "0"],
])
def test_bad_input_exits_2_with_one_line(capsys, argv):
    code, out, err = run(capsys, "reference", "oblique", *argv)
    assert code == 2
    assert out == ""
    assert err.startswith("impactbench: error:") and err.count("\n") == 1
    assert "Traceback" not in err


def test_elastic_constants_give_the_hertz_stiffness():
    """--youngs-modulus/--poisson (and the plate's) set Mindlin's G* and, without --stiffness,
    the Hertz c; with --stiffness c is kept; a --damping drops a case's nominal e."""
    derived = SPEC.from_args(argparse.Namespace(), {"youngs_modulus_pa": 3.8e11, "poisson": 0.23,
                                                "plate_youngs_modulus_pa": math.inf})
    assert derived["stiffness"] == pytest.approx(Oblique.kharaz2001().stiffness *
                                                 (0.01452 / 0.0025) ** 0.5, rel=1e-14)
    kept = SPEC.from_args(argparse.Namespace(), {"youngs_modulus_pa": 3.8e11, "stiffness": 1e9})
    assert kept["stiffness"] == 1e9
    damped = SPEC.from_args(argparse.Namespace(case="kharaz2001"), {"damping_s_per_m": 0.1})
    assert "nominal_restitution" not in damped and damped["damping_s_per_m"] == 0.1
    with pytest.raises(ValueError, match=r"^material = 'steel': --material does not apply"):
        SPEC.from_args(argparse.Namespace(material="steel"), {})
    with pytest.raises(ValueError, match=r"^gravity_m_s2 = 9.81"):
        SPEC.from_args(argparse.Namespace(gravity_m_s2=9.81), {})


# ------------------------------------------------------------------ the spec


def test_spec_matches_the_reference():
    assert SPEC.name == Oblique.name == "oblique"
    assert SPEC.cls is Oblique
    assert SPEC.metrics == OBLIQUE_METRICS
    assert set(SPEC.headline) <= set(SPEC.metrics)
    assert {f.field for f in SPEC.flags} <= set(Oblique.field_names())
    assert set(SPEC.axis_names) <= set(Oblique.field_names())
    s = SPEC.build((("angle_deg", 30.0), ("velocity_m_s", 2.0)))
    assert SPEC.point_of(s) == (("angle_deg", 30.0), ("velocity_m_s", 2.0))
    assert SPEC.reference_metrics(s) == oblique.rigid(s)
    rec = SPEC.history(s)
    assert oblique.record_metrics(rec, s)["spin_out_rad_s"] == pytest.approx(
        oblique.rigid(s)["spin_out_rad_s"], rel=1e-9)
    assert SPEC.problem(s, {}) == ""


def test_spec_labels_with_two_numeric_axes():
    """Both numeric axes appear in run ids (sortable, zero-padded; θ = 0 is valid), gate
    labels, figure names and captions (``point_text`` names the angle by its field,
    ``angle_deg = 0``, until the core labels a non-velocity axis by its column)."""
    point = (("angle_deg", 0.0), ("velocity_m_s", 2.0))
    assert SPEC.point_id(point) == "/a0000.0000/v0002.0000"
    ids = [SPEC.point_id((("angle_deg", a), ("velocity_m_s", 2.0))) for a in (0, 5, 45, 85.5)]
    assert ids == sorted(ids)
    assert SPEC.numeric_label(point) == "-a0-v2"
    assert SPEC.figure_name(point) == "oblique_a0_v2"
    text = SPEC.point_text(point)
    assert text.endswith("V = 2 m/s") and "0" in text.split(",")[0]


def test_plausibility_of_the_reference():
    s = Oblique(angle_deg=30.0, spin_rad_s=-100.0)
    rec = SPEC.history(s)
    m = SPEC.reference_metrics(s)
    got = SPEC.measure(s, rec, m)
    assert 0.0 < got["penetration_ratio"] < 0.01
    assert 0.5 < got["energy_ratio"] < 1.0
    frictionless = s.replace(friction=0.0, spin_rad_s=0.0)
    got = SPEC.measure(frictionless, SPEC.history(frictionless),
                       SPEC.reference_metrics(frictionless))
    e = SPEC.reference_metrics(frictionless)["restitution"]
    # only the normal motion loses energy: (e²·cos²θ + sin²θ)
    assert got["energy_ratio"] == pytest.approx(e * e * 0.75 + 0.25, rel=1e-12)


def test_a_case_sets_no_axis_field():
    """A case (``--case``, a config's ``case = …``) sets physical fields only, so a config
    table's points never collide with it; its own speed is the reference command's default."""
    params = SPEC.from_args(argparse.Namespace(case="kharaz2001"), {})
    assert not set(params) & set(SPEC.axis_names)
    s = SPEC.build((("angle_deg", 20.0), ("velocity_m_s", 3.9)), params)
    assert s == Oblique.kharaz2001(angle_deg=20.0)


def test_sweep_over_the_angle_writes_the_reference_table(tmp_path) -> None:
    """``sweep oblique --over angle-deg``: one row per angle, the closed form's values (the
    contact sticks below the 63.9° threshold of the steel ball at μ = 0.3, slides above)."""
    import pandas as pd
    from impactbench.reference import oblique
    from impactbench.reference.oblique_scenario import Oblique

    from impactbench.cli import main

    out = tmp_path / "a.csv"
    assert main(["sweep", "oblique", "--over", "angle-deg", "--start", "0", "--stop", "80",
                 "--step", "20", "--friction", "0.3", "--out", str(out)]) == 0
    table = pd.read_csv(out)
    assert list(table.angle_deg) == [0.0, 20.0, 40.0, 60.0, 80.0]
    want = oblique.sweep(Oblique(velocity_m_s=2.0, friction=0.3), [0.0, 20.0, 40.0, 60.0, 80.0])
    assert (table.spin_out_rad_s - want.spin_out_rad_s).abs().max() < 1e-9
    assert list(table.regime) == [0.0, 0.0, 0.0, 0.0, 1.0]
