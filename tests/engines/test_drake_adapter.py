"""Drake adapter against the reference solvers (real Drake, no mocks).

Tolerances are the issue's: injected ball at dt = 1e-7 s — restitution ≤ 0.5 %, duration and
peak force ≤ 1 %; rigid–flexible at v1 = 3.3 m/s — peak, pulse width and impulse ≤ 1 %.
"""

from __future__ import annotations

import math

import pytest
from conftest import assert_escaped_after_whole_contact, require_engine

require_engine("drake")

from impactbench.engines.base import RunSettings, get_adapter  # noqa: E402
from impactbench.engines.drake_adapter import DrakeAdapter, native_ball_point_contact  # noqa: E402
from impactbench.reference import hunt_crossley, two_dof  # noqa: E402
from impactbench.reference.metrics import compute, relative_error  # noqa: E402
from impactbench.reference.record import Status  # noqa: E402
from impactbench.reference.scenarios import BallOnPlate, RigidFlexible  # noqa: E402

RF_METRICS = ("peak_force_n", "pulse_width_s", "impulse_ns")


@pytest.fixture(scope="module")
def drake() -> DrakeAdapter:
    adapter = get_adapter("drake")
    assert isinstance(adapter, DrakeAdapter)
    return adapter


def _errors(measured: dict, reference: dict, keys: tuple[str, ...]) -> dict[str, float]:
    return {k: abs(relative_error(measured[k], reference[k])) for k in keys}


@pytest.mark.parametrize("velocity", [1.0, 5.0])
def test_injected_ball_reproduces_reference(drake: DrakeAdapter, velocity: float) -> None:
    scenario = BallOnPlate(velocity_m_s=velocity)
    rec = drake.run(scenario, "injected", RunSettings(timestep_s=1e-7))
    assert rec.status is Status.OK, rec.message
    assert rec.mass_2_kg == math.inf and not rec.velocity_2_m_s.any()
    err = _errors(compute(rec), hunt_crossley.solve(scenario),
                  ("restitution", "duration_s", "peak_force_n"))
    # measured at 1e-7 s (RK3; 1 / 5 m/s): restitution 4.8e-9 / 6.1e-8, duration 7.4e-10 /
    # 1.0e-9, peak 1.7e-6 / 2.7e-6 (a sampled maximum: the peak falls between samples)
    assert err["restitution"] <= 1.8e-7, err
    assert err["duration_s"] <= 3.2e-9, err
    assert err["peak_force_n"] <= 8.1e-6, err


@pytest.mark.parametrize("velocity", [1.0, 5.0])
def test_injected_ball_error_falls_with_timestep(drake: DrakeAdapter, velocity: float) -> None:
    scenario = BallOnPlate(velocity_m_s=velocity)
    ref = hunt_crossley.solve(scenario)
    errors = []
    for dt in (4e-6, 2e-6, 1e-6):
        rec = drake.run(scenario, "injected", RunSettings(timestep_s=dt))
        assert rec.status is Status.OK, rec.message
        errors.append(abs(relative_error(compute(rec)["restitution"], ref["restitution"])))
    assert errors[0] > errors[1] > errors[2], errors


@pytest.mark.parametrize("velocity", [0.5, 1.0, 5.0])
def test_native_ball_restitution_exact_and_duration_matched_at_reference_velocity(
        drake: DrakeAdapter, velocity: float) -> None:
    """Point contact is linear Hunt–Crossley with d = b: restitution k(α) at every velocity;
    the stiffness matches the duration at the reference velocity (1 m/s) only."""
    scenario = BallOnPlate(velocity_m_s=velocity)
    rec = drake.run(scenario, "native", RunSettings(timestep_s=1e-7))
    assert rec.status is Status.OK, rec.message
    m, ref = compute(rec), hunt_crossley.solve(scenario)
    # measured at 1e-7 s: restitution 7.2e-7 / 2.6e-7 / 8.8e-7 (0.5 / 1 / 5 m/s); duration
    # against linear HC 9.5e-11 / 3.6e-10 / 8.2e-9
    assert abs(relative_error(m["restitution"], ref["restitution"])) <= 2.7e-6
    native = rec.meta["native_parameters"]
    k, d = native_ball_point_contact(scenario)
    assert native["point_stiffness_n_per_m"] == k
    assert native["geometry_point_stiffness_n_per_m"] == 2 * k
    assert native["hunt_crossley_dissipation_s_per_m"] == scenario.damping_s_per_m == d
    assert rec.meta["reference_velocity_m_s"] == 1.0
    # the pair has exactly stiffness k: the linear-HC duration equals T(k) = √(m/k)·τ(α)
    linear = scenario.replace(stiffness=k, exponent=1.0)
    assert abs(relative_error(m["duration_s"], hunt_crossley.solve(linear)["duration_s"])) \
        <= 2.5e-8
    if velocity == 1.0:
        assert abs(relative_error(m["duration_s"], ref["duration_s"])) <= 1.1e-9


def test_native_ball_reference_velocity_option(drake: DrakeAdapter) -> None:
    scenario = BallOnPlate(velocity_m_s=5.0)
    settings = RunSettings(timestep_s=1e-7, options={"reference_velocity_m_s": 5.0})
    rec = drake.run(scenario, "native", settings)
    assert rec.meta["reference_velocity_m_s"] == 5.0
    ref = hunt_crossley.solve(scenario)
    # measured 1.5e-8
    assert abs(relative_error(compute(rec)["duration_s"], ref["duration_s"])) <= 4.5e-8


@pytest.mark.parametrize("local", ["linear", "elastoplastic"])
def test_injected_rigid_flexible_reproduces_reference(drake: DrakeAdapter, local: str) -> None:
    scenario = RigidFlexible(velocity_m_s=3.3, local=local)
    rec = drake.run(scenario, "injected")
    assert rec.status is Status.OK, rec.message
    assert rec.meta["timestep_s"] == 1e-5 and rec.mass_2_kg == scenario.m2_kg
    ref = two_dof.solve(scenario)
    m = compute(rec)
    assert m["impacts"] == ref["impacts"]
    err = _errors(m, ref, RF_METRICS)
    # measured (both laws, 1e-5 s): peak 6.2e-8, pulse width 2.0e-9, impulse 7.6e-8
    assert max(err.values()) <= 2.3e-7, err


# measured worst injected error: elastoplastic at 20 m/s 5.2e-8, mutation 4.8e-5; native
# (linear k1) 0.59 and 0.44
@pytest.mark.parametrize(("local", "velocity", "tol"), [("elastoplastic", 20.0, 1.6e-7),
                                                        ("mutation", 3.3, 1.5e-4)])
def test_injected_local_law_memory_is_driven_through_drake(drake: DrakeAdapter, local: str,
                                                           velocity: float, tol: float) -> None:
    """Beyond yield / failure the law's memory matters; linear native contact misses it."""
    scenario = RigidFlexible(velocity_m_s=velocity, local=local)
    ref = two_dof.solve(scenario)
    injected = compute(drake.run(scenario, "injected"))
    native = compute(drake.run(scenario, "native"))
    assert max(_errors(injected, ref, RF_METRICS).values()) <= tol
    assert injected["impacts"] == ref["impacts"]
    assert max(_errors(native, ref, RF_METRICS).values()) > 0.15  # the law really differs


@pytest.mark.parametrize("structure", ["linear", "softening"])
def test_native_linear_rigid_flexible_matches_reference(drake: DrakeAdapter,
                                                          structure: str) -> None:
    scenario = RigidFlexible(velocity_m_s=3.3, structure=structure)
    rec = drake.run(scenario, "native")
    assert rec.status is Status.OK, rec.message
    assert rec.meta["native_parameters"]["point_stiffness_n_per_m"] == scenario.k1_n_per_m
    assert rec.displacement_2_m is not None and rec.displacement_2_m.size == len(rec)
    err = _errors(compute(rec), two_dof.solve(scenario), RF_METRICS)
    assert max(err.values()) <= 2.5e-7, err  # measured 7.6e-8 (linear), 8.3e-8 (softening)


@pytest.mark.parametrize("mode", ["native", "injected"])
def test_softening_collapse_is_a_status(drake: DrakeAdapter, mode: str) -> None:
    scenario = RigidFlexible(velocity_m_s=40.0, structure="softening")
    assert two_dof.solve(scenario)["status"] == Status.STRUCTURE_COLLAPSED
    rec = drake.run(scenario, mode)
    assert rec.status is Status.STRUCTURE_COLLAPSED, rec.message
    assert_escaped_after_whole_contact(rec, scenario)


@pytest.mark.parametrize("mode", ["native", "injected"])
def test_huge_timestep_is_not_a_number(drake: DrakeAdapter, mode: str) -> None:
    rec = drake.run(BallOnPlate(velocity_m_s=5.0), mode, RunSettings(timestep_s=1e-3))
    assert rec.status in (Status.TUNNELED, Status.DIVERGED), rec.status
    rec = drake.run(RigidFlexible(velocity_m_s=3.3), mode, RunSettings(timestep_s=0.1))
    assert rec.status in (Status.TUNNELED, Status.DIVERGED), rec.status


def test_time_cap_gives_max_time(drake: DrakeAdapter) -> None:
    rec = drake.run(RigidFlexible(velocity_m_s=3.3), "native", RunSettings(max_time_s=0.01))
    assert rec.status is Status.MAX_TIME
    assert rec.time_s[-1] == pytest.approx(0.01, abs=2e-5)


def test_gravity_accelerates_the_ball_before_contact(drake: DrakeAdapter) -> None:
    """The first 2.5 steps are free flight: v = V0 + g·t exactly (RK3 is exact there)."""
    scenario = BallOnPlate(velocity_m_s=1.0, gravity_m_s2=9.81)
    rec = drake.run(scenario, "native", RunSettings(timestep_s=1e-3))
    assert not rec.normal_force_n[:3].any()
    for k in (1, 2):
        t, v = rec.time_s[k], rec.velocity_1_m_s[k]
        assert v == pytest.approx(1.0 + 9.81 * t, rel=1e-12)
    still = drake.run(scenario.replace(gravity_m_s2=0.0), "native", RunSettings(timestep_s=1e-3))
    assert still.velocity_1_m_s[2] == pytest.approx(1.0, rel=1e-12)


def test_tuned_mode(drake: DrakeAdapter) -> None:
    scenario = BallOnPlate(velocity_m_s=2.0)
    rec = drake.run(scenario, "tuned")
    assert rec.status is Status.UNSUPPORTED and "tuned" in rec.message
    k, d = native_ball_point_contact(scenario)
    tuned = {"point_stiffness_n_per_m": k, "hunt_crossley_dissipation_s_per_m": d}
    a = compute(drake.run(scenario, "tuned", RunSettings(tuned=tuned)))
    b = compute(drake.run(scenario, "native"))
    assert a == pytest.approx(b, rel=1e-12)
    stiffer = dict(tuned, point_stiffness_n_per_m=4 * k)
    c = compute(drake.run(scenario, "tuned", RunSettings(tuned=stiffer)))
    # T ∝ 1/√k: measured within 8.0e-7 (RK3 at the default 1e-6 s)
    assert c["duration_s"] == pytest.approx(b["duration_s"] / 2, rel=2.4e-6)
    rf = RigidFlexible(velocity_m_s=3.3)
    rec = drake.run(rf, "tuned", RunSettings(tuned={"point_stiffness_n_per_m": 1e5}))
    assert compute(rec)["peak_force_n"] == pytest.approx(two_dof.solve(rf)["peak_force_n"],
                                                         rel=1.9e-7)  # measured 6.2e-8


def test_bad_options_raise_one_line_value_errors(drake: DrakeAdapter) -> None:
    scenario = BallOnPlate()
    with pytest.raises(ValueError, match=r"^integrator = 'rk9': must be one of"):
        drake.run(scenario, "native", RunSettings(options={"integrator": "rk9"}))
    with pytest.raises(ValueError, match=r"^point_stiffness_n_per_m = -1.0: must be > 0"):
        drake.run(scenario, "tuned", RunSettings(tuned={"point_stiffness_n_per_m": -1.0}))
    with pytest.raises(ValueError, match=r"^reference_velocity_m_s = 0: must be > 0"):
        drake.run(scenario, "native", RunSettings(options={"reference_velocity_m_s": 0}))


def test_other_integrator_and_provenance(drake: DrakeAdapter) -> None:
    scenario = BallOnPlate(velocity_m_s=1.0)
    rec = drake.run(scenario, "injected",
                    RunSettings(timestep_s=1e-7, options={"integrator": "runge_kutta2"}))
    assert rec.meta["integrator"] == "runge_kutta2, fixed step"
    assert rec.meta["engine"] == "drake" and rec.meta["engine_version"] == drake.version()
    ref = hunt_crossley.solve(scenario)
    # measured 3.5e-7 (RK2 at 1e-7 s)
    assert abs(relative_error(compute(rec)["restitution"], ref["restitution"])) <= 1.1e-6
    assert drake.default_timestep_s(scenario, "native") == 1e-6
    assert drake.default_timestep_s(RigidFlexible(), "injected") == 1e-5


# ------------------------------------------------------------------ the discrete plant's settings
# The discrete plant's settings are read back from the plant Drake built (``DrakeAdapter.build``
# returns it), not from ``meta["engine_defaults"]``, which echoes the adapter's own config: an
# adapter that built the plant from a fresh MultibodyPlantConfig would still report "sap" there.

APPROXIMATIONS = {"tamsi": "kTamsi", "sap": "kSap", "similar": "kSimilar", "lagged": "kLagged"}


def _plant_approximation(drake: DrakeAdapter, mode: str, **settings) -> str:
    from pydrake.multibody.plant import DiscreteContactApproximation

    model = drake.build(BallOnPlate(velocity_m_s=2.0), mode, RunSettings(timestep_s=1e-3,
                                                                          **settings))
    assert model.plant.time_step() == 1e-3  # the discrete plant, at the run's step
    got = model.plant.get_discrete_contact_approximation()
    names = {getattr(DiscreteContactApproximation, v): k for k, v in APPROXIMATIONS.items()}
    return names[got]


@pytest.mark.parametrize("approximation", sorted(APPROXIMATIONS))
def test_custom_discrete_approximation_reaches_the_plant(drake: DrakeAdapter,
                                                         approximation: str) -> None:
    params = {"discrete_contact_approximation": approximation}
    assert _plant_approximation(drake, "custom", params=params) == approximation
    rec = drake.run(BallOnPlate(velocity_m_s=2.0), "custom",
                    RunSettings(timestep_s=1e-3, params=params))
    assert rec.meta["plant"].endswith(approximation)  # what the record says is what ran


def test_older_solver_name_and_tuned_variant_reach_the_plant(drake: DrakeAdapter) -> None:
    for solver in ("sap", "tamsi"):
        assert _plant_approximation(drake, "custom",
                                    params={"discrete_contact_solver": solver}) == solver
    k, d = native_ball_point_contact(BallOnPlate(velocity_m_s=2.0))
    for approximation in ("sap", "tamsi"):
        tuned = {"point_stiffness_n_per_m": k, "hunt_crossley_dissipation_s_per_m": d,
                 "discrete_contact_approximation": approximation}
        assert _plant_approximation(drake, "tuned", tuned=tuned) == approximation


def test_default_plant_has_drakes_default_approximation(drake: DrakeAdapter) -> None:
    from pydrake.multibody.plant import MultibodyPlantConfig

    assert _plant_approximation(drake, "default") == \
        MultibodyPlantConfig().discrete_contact_approximation  # "lagged" in Drake 1.51


def test_sap_and_tamsi_bounce_differently_at_the_same_step(drake: DrakeAdapter) -> None:
    """The setting changes the physics, not only the label: Drake's default point contact at
    1 ms, ball at 2 m/s. Measured (Drake 1.51): SAP e = 0.0025043, TAMSI e = 0.0100000 (and
    lagged, the default, 0.0100000), so a plant that ignored "sap" would bounce 4× higher."""
    scenario = BallOnPlate(velocity_m_s=2.0)
    e = {}
    for approximation in ("sap", "tamsi"):
        rec = drake.run(scenario, "custom", RunSettings(
            timestep_s=1e-3, params={"discrete_contact_approximation": approximation}))
        assert rec.status is Status.OK, rec.message
        e[approximation] = compute(rec)["restitution"]
    assert e["sap"] == pytest.approx(0.0025043, rel=1e-4)  # measured 0.00250428547
    assert e["tamsi"] == pytest.approx(0.0100000, rel=1e-4)  # measured 0.01000000000
    assert e["tamsi"] > 3.0 * e["sap"]
