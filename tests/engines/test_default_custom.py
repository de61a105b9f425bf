"""``default`` and ``custom`` modes of every adapter, on the real engines, at the engines'
customary (practical) timesteps: the engine's out-of-the-box contact is measured, its defaults
are recorded, and the user's parameters (engine's own names) reach the engine."""

from __future__ import annotations

import pytest
from conftest import require_engine
from impactbench.engines.base import RunSettings, get_adapter, parameter_keys
from impactbench.reference.scenarios import BallOnPlate, RigidFlexible

from impactbench.evaluate import compare

CUSTOMARY_S = {"mujoco": 2e-3, "pybullet": 1.0 / 240.0, "drake": 1e-3, "pymunk": 1.0 / 60.0}


@pytest.mark.parametrize("engine", sorted(CUSTOMARY_S))
def test_default_mode_at_the_customary_step_is_ok_and_records_defaults(engine):
    require_engine(engine)
    out, rec = compare(engine, BallOnPlate(velocity_m_s=2.0), "default",
                       RunSettings(timestep_s=CUSTOMARY_S[engine]))
    # measured either way; at its customary step the 14.5 mm ball may sink deeper than a tenth
    # of its radius (impactbench.plausibility): then it is implausible, its numbers kept
    assert out["status"] in ("ok", "implausible"), out["message"]
    assert (out["status"] == "implausible") == (out["plausibility"]["penetration_ratio"] > 0.1)
    assert 0.0 <= out["restitution"] < 1.0
    assert rec.meta["engine_defaults"], "the engine's defaults must be recorded"
    assert out["timestep_s"] == CUSTOMARY_S[engine]


@pytest.mark.parametrize(("engine", "params", "meta_key", "expected"), [
    ("mujoco", {"solref": [0.01, 0.5]}, "solref", [0.01, 0.5]),
    ("pybullet", {"restitution": 0.8}, "params", {"restitution": 0.8}),
    ("pymunk", {"elasticity": 0.9}, "params", {"elasticity": 0.9}),
    ("drake", {"discrete_contact_approximation": "tamsi"}, "engine_defaults", None),
])
def test_custom_parameters_reach_the_engine(engine, params, meta_key, expected):
    require_engine(engine)
    s = BallOnPlate(velocity_m_s=2.0)
    dt = CUSTOMARY_S[engine]
    default, _ = compare(engine, s, "default", RunSettings(timestep_s=dt))
    custom, rec = compare(engine, s, "custom", RunSettings(timestep_s=dt, params=params))
    assert custom["status"] in ("ok", "implausible"), custom["message"]  # measured
    if expected is not None:
        assert rec.meta[meta_key] == expected
    else:
        assert rec.meta["engine_defaults"]["discrete_contact_approximation"] == "tamsi"
    if engine in ("pybullet", "pymunk"):
        # out of the box the pair restitution is 0; the user's value makes the ball bounce
        assert default["restitution"] < 0.1 < 0.75 < custom["restitution"]


def test_pymunk_custom_elasticity_is_the_measured_restitution_at_one_sixtieth():
    require_engine("pymunk")
    out, _ = compare("pymunk", BallOnPlate(velocity_m_s=5.0), "custom",
                     RunSettings(timestep_s=1 / 60, params={"elasticity": 0.9}))
    assert out["restitution"] == pytest.approx(0.9, rel=1e-9)
    assert not out["resolved"]["duration_s"] and out["resolved"]["restitution"]


@pytest.mark.parametrize("engine", sorted(CUSTOMARY_S))
def test_unknown_custom_key_is_one_line_listing_the_valid_keys(engine):
    require_engine(engine)
    with pytest.raises(ValueError, match="valid keys: ") as info:
        get_adapter(engine).run(BallOnPlate(), "custom", RunSettings(params={"nope": 1}))
    assert "\n" not in str(info.value)
    assert all(k in str(info.value) for k in parameter_keys(engine))


@pytest.mark.parametrize("engine", sorted(CUSTOMARY_S))
def test_default_mode_on_rigid_flexible_is_unsupported_not_a_crash(engine):
    require_engine(engine)
    out, _ = compare(engine, RigidFlexible(velocity_m_s=2.0), "default")
    assert out["status"] == "unsupported"


def test_mujoco_stiff_custom_solref_at_two_ms_is_a_divergence_status():
    require_engine("mujoco")
    out, _ = compare("mujoco", BallOnPlate(velocity_m_s=2.0), "custom",
                     RunSettings(timestep_s=2e-3, params={"solref": [-1e8, -1e3]}))
    assert out["status"] == "diverged"


@pytest.mark.parametrize("engine", sorted(CUSTOMARY_S))
def test_every_engine_runs_at_ten_ms(engine):
    """The practical range: a 1e-2 s step gives a status or a measured bounce, never a crash;
    the contact is shorter than the step, so duration and peak force are flagged."""
    require_engine(engine)
    out, _ = compare(engine, BallOnPlate(velocity_m_s=1.0), "default",
                     RunSettings(timestep_s=1e-2))
    assert out["status"] in ("ok", "implausible", "tunneled", "diverged", "max_time")
    native, _ = compare(engine, BallOnPlate(velocity_m_s=1.0), "native",
                        RunSettings(timestep_s=1e-2))
    assert native["status"] != "crashed", native["message"]
    if native["status"] in ("ok", "implausible"):
        assert not native["resolved"]["peak_force_n"]
