"""The tuned-file binding at its tolerance's edge (``impactbench.tuned``).

A tuned file binds to the timestep and the scenario it was fitted for; ``_close`` compares
them with ``TIMESTEP_RTOL = 1e-9`` relative (room for a step written as 1/240 and read back,
nothing more). The other tests use 28 % and 2× differences, which a tolerance loosened to
0.2 would still call mismatches; here a difference of 2e-9 relative must be a mismatch and one
of 5e-10 must not, for the timestep and for a scenario field, in both directions.
"""

from __future__ import annotations

import math

import pytest
from impactbench.reference.scenarios import BallOnPlate

from impactbench import tuned

DT = 1e-6
OFF = 2e-9  # relative: beyond TIMESTEP_RTOL = 1e-9 → a mismatch
ON = 5e-10  # relative: within it → the same step


def provenance(**changes) -> dict:
    s = BallOnPlate()
    prov = {"engine": "mujoco", "scenario": "ball-on-plate", "timestep_s": DT,
            **{f"scenario_{k}": v for k, v in s.to_dict().items()}}
    prov.update(changes)
    return prov


def mismatch(prov: dict, dt: float = DT, scenario: BallOnPlate | None = None) -> str:
    return tuned.binding_mismatch(prov, "mujoco", scenario or BallOnPlate(), dt)


def test_the_tolerance_is_one_part_in_a_billion() -> None:
    assert tuned.TIMESTEP_RTOL == 1e-9


@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_timestep_boundary(sign: float) -> None:
    assert mismatch(provenance()) == ""
    assert mismatch(provenance(timestep_s=DT * (1 + sign * ON))) == ""
    assert mismatch(provenance(), dt=DT * (1 + sign * ON)) == ""
    why = mismatch(provenance(timestep_s=DT * (1 + sign * OFF)))
    assert "timestep_s = " in why and f"(this run: {DT!r})" in why
    assert "impactbench tune --engine mujoco" in why and "--timestep 1e-06" in why
    assert "timestep_s" in mismatch(provenance(), dt=DT * (1 + sign * OFF))


@pytest.mark.parametrize("field", ["mass_kg", "stiffness", "radius_m", "damping_s_per_m"])
@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_scenario_field_boundary(field: str, sign: float) -> None:
    value = getattr(BallOnPlate(), field)
    assert mismatch(provenance(**{f"scenario_{field}": value * (1 + sign * ON)})) == ""
    why = mismatch(provenance(**{f"scenario_{field}": value * (1 + sign * OFF)}))
    assert why.startswith(f"the tuned file was fitted for {field} = "), why
    assert f"(this run: {value!r})" in why
    assert "timestep_s" not in why  # only the differing field is named


def test_velocity_is_not_bound_and_absent_keys_are_not_checked() -> None:
    assert mismatch(provenance(scenario_velocity_m_s=5.0)) == ""
    assert mismatch({"engine": "mujoco"}) == ""  # a file without provenance fields binds nothing
    assert mismatch({}, dt=1.0) == ""


def test_engine_and_scenario_names_are_compared_exactly() -> None:
    assert "engine = 'drake' (this run: 'mujoco')" in mismatch(provenance(engine="drake"))
    assert "scenario = 'rigid-flexible'" in mismatch(provenance(scenario="rigid-flexible"))
    assert tuned._close("a", "a") and not tuned._close("a", "b")
    assert not tuned._close(None, DT) and not tuned._close("1e-6", "x")


def test_close_is_symmetric_and_relative() -> None:
    for scale in (1e-9, 1e-3, 1.0, 1.7135e10):
        for a, b in ((scale, scale * (1 + ON)), (scale * (1 + ON), scale)):
            assert tuned._close(a, b)
        for a, b in ((scale, scale * (1 + OFF)), (scale * (1 - OFF), scale)):
            assert not tuned._close(a, b)
    assert tuned._close(0.0, 0.0) and not tuned._close(0.0, 1e-300)
    assert tuned._close(1.0 / 240.0, float(repr(1.0 / 240.0)))


def test_find_tuned_picks_the_file_of_this_step_only(tmp_path, monkeypatch) -> None:
    """A packaged file fitted at 1 ms is found for 1 ms (and 1 ms·(1 ± 5e-10)), not for a step
    2e-9 off, which falls back to the main file (whose binding then reports the mismatch)."""
    monkeypatch.setattr(tuned, "TUNED_DIR", tmp_path)
    main = tuned.write_tuned(tuned.tuned_path("mujoco", "ball-on-plate"), {
        "parameters": {"solref": [0.02, 1.0]}, "provenance": {"timestep_s": DT}})
    one_ms = tuned.write_tuned(tmp_path / "mujoco_ball_on_plate_dt1ms.toml", {
        "parameters": {"solref": [0.01, 1.0]}, "provenance": {"timestep_s": 1e-3}})
    assert tuned.find_tuned("mujoco", "ball-on-plate", 1e-3) == one_ms
    for sign in (1.0, -1.0):
        assert tuned.find_tuned("mujoco", "ball-on-plate", 1e-3 * (1 + sign * ON)) == one_ms
        assert tuned.find_tuned("mujoco", "ball-on-plate", 1e-3 * (1 + sign * OFF)) == main
    assert tuned.find_tuned("mujoco", "ball-on-plate") == main


def test_close_at_exactly_the_tolerance() -> None:
    """|a − b| = 1e-9·max(|a|, |b|) exactly (b = 2⁻³⁰·10⁹, a = b − 2⁻³⁰, both exact in
    binary and the product rounds to 2⁻³⁰): still the same step (≤, not <)."""
    b = 2.0**-30 * 1e9
    a = b - 2.0**-30
    assert abs(a - b) == tuned.TIMESTEP_RTOL * max(a, b)
    assert tuned._close(a, b) and tuned._close(b, a)
    assert not tuned._close(math.nextafter(a, 0.0), b)
    assert mismatch(provenance(timestep_s=a), dt=b) == ""


def test_mismatch_names_the_file_and_every_difference_in_order() -> None:
    why = mismatch(provenance(file="my_tuned.toml", timestep_s=2e-6, scenario_mass_kg=0.2))
    assert why.startswith("my_tuned.toml was fitted for mass_kg = 0.2 (this run: 0.1); "
                          "timestep_s = 2e-06 (this run: 1e-06): its parameters do not apply "
                          "here; fit them with `impactbench tune --engine mujoco "), why
