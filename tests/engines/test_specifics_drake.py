"""Drake's own checks (real Drake, no mocks): the point contact is linear Hunt–Crossley, the
continuous plant's RK3 and its time cap, and the discrete plant's settings read back from the
plant Drake built. The shapes every adapter shares are in test_conformance.py. Tolerances are
about 3× the error measured on this machine (drake 1.51.1), written beside them.
"""

from __future__ import annotations

import pytest
from conftest import require_engine
from impactbench.engines.base import RunSettings, get_adapter
from impactbench.reference import hunt_crossley, two_dof
from impactbench.reference.metrics import compute, relative_error
from impactbench.reference.oblique import Oblique
from impactbench.reference.record import Status
from impactbench.reference.scenarios import BallOnPlate, RigidFlexible

from impactbench.evaluate import compare

RF_METRICS = ("peak_force_n", "pulse_width_s", "impulse_ns")


@pytest.fixture(scope="module")
def drake():
    require_engine("drake")
    return get_adapter("drake")


def _errors(measured: dict, reference: dict, keys: tuple[str, ...]) -> dict[str, float]:
    return {k: abs(relative_error(measured[k], reference[k])) for k in keys}


@pytest.mark.parametrize("velocity", [0.5, 1.0, 5.0])
def test_native_ball_duration_is_the_linear_hunt_crossley_of_the_mapped_stiffness(drake,
                                                                                 velocity):
    """The pair has exactly stiffness k: the linear-HC duration equals T(k) = √(m/k)·τ(α).
    Measured at 1e-7 s against linear HC: 9.5e-11 / 3.6e-10 / 8.2e-9 (0.5 / 1 / 5 m/s)."""
    from impactbench.engines.drake_adapter import native_ball_point_contact

    scenario = BallOnPlate(velocity_m_s=velocity)
    rec = drake.run(scenario, "native", RunSettings(timestep_s=1e-7))
    assert rec.status is Status.OK, rec.message
    k, _ = native_ball_point_contact(scenario)
    linear = scenario.replace(stiffness=k, exponent=1.0)
    assert abs(relative_error(compute(rec)["duration_s"],
                              hunt_crossley.solve(linear)["duration_s"])) <= 2.5e-8


@pytest.mark.parametrize(("local", "velocity"), [("elastoplastic", 20.0), ("mutation", 3.3)])
def test_native_linear_contact_misses_the_laws_memory(drake, local: str, velocity: float):
    """Beyond yield / failure the law's memory matters; linear native contact misses it
    (measured 0.59 and 0.44; injected reproduces it: test_conformance.py)."""
    scenario = RigidFlexible(velocity_m_s=velocity, local=local)
    native = compute(drake.run(scenario, "native"))
    ref = two_dof.solve(scenario)
    assert max(_errors(native, ref, RF_METRICS).values()) > 0.15  # the law really differs


def test_time_cap_gives_max_time(drake) -> None:
    rec = drake.run(RigidFlexible(velocity_m_s=3.3), "native", RunSettings(max_time_s=0.01))
    assert rec.status is Status.MAX_TIME
    assert rec.time_s[-1] == pytest.approx(0.01, abs=2e-5)


def test_gravity_accelerates_the_ball_before_contact(drake) -> None:
    """The first 2.5 steps are free flight: v = V0 + g·t exactly (RK3 is exact there)."""
    scenario = BallOnPlate(velocity_m_s=1.0, gravity_m_s2=9.81)
    rec = drake.run(scenario, "native", RunSettings(timestep_s=1e-3))
    assert not rec.normal_force_n[:3].any()
    for k in (1, 2):
        t, v = rec.time_s[k], rec.velocity_1_m_s[k]
        assert v == pytest.approx(1.0 + 9.81 * t, rel=1e-12)
    still = drake.run(scenario.replace(gravity_m_s2=0.0), "native", RunSettings(timestep_s=1e-3))
    assert still.velocity_1_m_s[2] == pytest.approx(1.0, rel=1e-12)


def test_tuned_stiffness_sets_the_duration_and_the_2dof_peak(drake) -> None:
    """Tuned with the native pair is native (test_conformance.py); four times the stiffness
    halves the duration (T ∝ 1/√k), and a tuned 2-DOF contact of k1 is the linear law."""
    from impactbench.engines.drake_adapter import native_ball_point_contact

    scenario = BallOnPlate(velocity_m_s=2.0)
    k, d = native_ball_point_contact(scenario)
    b = compute(drake.run(scenario, "native"))
    stiffer = {"point_stiffness_n_per_m": 4 * k, "hunt_crossley_dissipation_s_per_m": d}
    c = compute(drake.run(scenario, "tuned", RunSettings(tuned=stiffer)))
    # T ∝ 1/√k: measured within 8.0e-7 (RK3 at the default 1e-6 s)
    assert c["duration_s"] == pytest.approx(b["duration_s"] / 2, rel=2.4e-6)
    rf = RigidFlexible(velocity_m_s=3.3)
    rec = drake.run(rf, "tuned", RunSettings(tuned={"point_stiffness_n_per_m": 1e5}))
    assert compute(rec)["peak_force_n"] == pytest.approx(two_dof.solve(rf)["peak_force_n"],
                                                         rel=1.9e-7)  # measured 6.2e-8


def test_other_integrator_and_provenance(drake) -> None:
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


def _plant_approximation(drake, mode: str, **settings) -> str:
    from pydrake.multibody.plant import DiscreteContactApproximation

    model = drake.build(BallOnPlate(velocity_m_s=2.0), mode, RunSettings(timestep_s=1e-3,
                                                                          **settings))
    assert model.plant.time_step() == 1e-3  # the discrete plant, at the run's step
    got = model.plant.get_discrete_contact_approximation()
    names = {getattr(DiscreteContactApproximation, v): k for k, v in APPROXIMATIONS.items()}
    return names[got]


@pytest.mark.parametrize("approximation", sorted(APPROXIMATIONS))
def test_custom_discrete_approximation_reaches_the_plant(drake, approximation: str) -> None:
    params = {"discrete_contact_approximation": approximation}
    assert _plant_approximation(drake, "custom", params=params) == approximation
    rec = drake.run(BallOnPlate(velocity_m_s=2.0), "custom",
                    RunSettings(timestep_s=1e-3, params=params))
    assert rec.meta["plant"].endswith(approximation)  # what the record says is what ran


def test_older_solver_name_and_tuned_variant_reach_the_plant(drake) -> None:
    from impactbench.engines.drake_adapter import native_ball_point_contact

    for solver in ("sap", "tamsi"):
        assert _plant_approximation(drake, "custom",
                                    params={"discrete_contact_solver": solver}) == solver
    k, d = native_ball_point_contact(BallOnPlate(velocity_m_s=2.0))
    for approximation in ("sap", "tamsi"):
        tuned = {"point_stiffness_n_per_m": k, "hunt_crossley_dissipation_s_per_m": d,
                 "discrete_contact_approximation": approximation}
        assert _plant_approximation(drake, "tuned", tuned=tuned) == approximation


def test_default_plant_has_drakes_default_approximation(drake) -> None:
    from pydrake.multibody.plant import MultibodyPlantConfig

    assert _plant_approximation(drake, "default") == \
        MultibodyPlantConfig().discrete_contact_approximation  # "lagged" in Drake 1.51


def test_sap_and_tamsi_bounce_differently_at_the_same_step(drake) -> None:
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


# --------------------------------------------------------------------------------- oblique


@pytest.mark.parametrize("angle", [20.0, 60.0])
def test_oblique_native_regularised_friction_chatters_at_mu(drake, angle):
    """The contact force sampled at step starts is the engine's output: in the stick phase
    the regularised friction chatters between ±μ·F_n (documented in the adapter); the
    errors against the reference are in test_conformance.py."""
    out, rec = compare("drake", Oblique(angle_deg=angle), "native", RunSettings())
    assert out["status"] == "ok", out["message"]
    ratio = rec.tangential_force_n[rec.normal_force_n > 0] / rec.normal_force_n[
        rec.normal_force_n > 0]
    assert max(abs(ratio)) == pytest.approx(0.3, rel=1e-6)


def test_oblique_custom_keys_reach_the_plant(drake):
    import pydrake.all as d

    params = {"discrete_contact_approximation": "sap", "stiction_tolerance": 1e-2}
    model = drake.build(Oblique(angle_deg=20.0), "custom",
                        RunSettings(timestep_s=1e-3, params=params))
    assert model.plant.get_discrete_contact_approximation() == \
        d.DiscreteContactApproximation.kSap
    assert model.plant.time_step() == 1e-3
