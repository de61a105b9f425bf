"""Newton's own checks (real engine: warp on CPU, float32, Featherstone; no mocks).

The closed form of Newton's contact law (damping only while approaching) is checked against a
direct integration first; the engine runs then check that law, the force derived from the
momentum change, the law's memory, and the device-side stepping (one captured CPU graph per
step) against the step-by-step path and the Python-loop records. The shapes every adapter
shares are in test_conformance.py. Warp compiles its kernels once per machine into its kernel
cache; the runs here are short.

Tolerances are about 3× the error measured on this machine (warp on CPU, float32), the
measured number in a comment next to each.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import require_engine
from impactbench.engines import newton_adapter
from impactbench.engines.base import RunSettings, get_adapter
from impactbench.engines.common import clipped_restitution
from impactbench.engines.newton_adapter import (
    NewtonAdapter,
    approach_damped_duration_s,
    approach_damped_matching,
    approach_damped_restitution,
)
from impactbench.reference import two_dof
from impactbench.reference.metrics import compute, contacts
from impactbench.reference.oblique import Oblique
from impactbench.reference.record import Status
from impactbench.reference.scenarios import BallOnPlate, RigidFlexible
from scipy.integrate import solve_ivp


@pytest.fixture(autouse=True, scope="module")
def _newton_installed() -> None:
    """Newton is imported when this file's tests run, not when it is collected: every test
    process collects every file, and importing Newton costs ~3 s of CPU."""
    require_engine("newton")


K, D = 1.0e8, 316.2  # the engines note's target contact (N/m, N·s/m)


@pytest.mark.parametrize(("ke", "kd", "mass"), [(K, D, 0.1), (2.5e3, 100.0, 0.1),
                                                (1e5, 10.0, 10.0)])
def test_approach_damped_law_closed_form(ke: float, kd: float, mass: float) -> None:
    """e and T of m·ẍ = −(ke·x + kd·max(ẋ, 0)) from (0, 1 m/s) against an ODE solve, for
    under- and overdamped approach."""
    def rhs(t: float, y: list[float]) -> list[float]:
        return [y[1], -(ke * y[0] + kd * max(y[1], 0.0)) / mass]

    def out(t: float, y: list[float]) -> float:
        return y[0]

    out.terminal, out.direction = True, -1
    sol = solve_ivp(rhs, (0.0, 10.0), [0.0, 1.0], events=out, rtol=1e-12, atol=1e-16,
                    first_step=1e-9, max_step=1e-3 * math.sqrt(mass / ke))
    duration = approach_damped_duration_s(ke, kd, mass)
    assert sol.t_events[0][0] == pytest.approx(duration, rel=1e-7)
    zeta = kd / (2.0 * math.sqrt(ke * mass))
    if zeta < 1.0:
        assert -sol.y_events[0][0][1] == pytest.approx(approach_damped_restitution(zeta),
                                                       rel=1e-7)
        sd = approach_damped_matching(mass, approach_damped_restitution(zeta), duration)
        assert sd.stiffness_n_per_m == pytest.approx(ke, rel=1e-9)
        assert sd.damping_ns_per_m == pytest.approx(kd, rel=1e-9)


def test_matching_rejects_restitution_below_the_laws_floor() -> None:
    with pytest.raises(ValueError, match="restitution"):
        approach_damped_matching(0.1, 0.3, 1e-4)


@pytest.fixture(scope="module")
def newton() -> NewtonAdapter:
    adapter = get_adapter("newton")
    assert isinstance(adapter, NewtonAdapter)
    return adapter


def test_contact_damps_only_while_approaching(newton: NewtonAdapter) -> None:
    """ke = 1e8, kd = 316.2 gives the one-sided law's e = 0.9267, not the two-sided
    spring–damper's 0.8588; the recorded force (m·Δv/dt) is the law's ke·x + kd·max(ẋ, 0)."""
    scenario = BallOnPlate(velocity_m_s=1.0)
    rec = newton.run(scenario, "custom", RunSettings(timestep_s=1e-7,
                                                     params={"ke": K, "kd": D}))
    assert rec.status is Status.OK, rec.message
    assert rec.meta["float"] == "float32" and rec.meta["solver"] == "featherstone"
    zeta = D / (2.0 * math.sqrt(K * scenario.mass_kg))
    e = compute(rec)["restitution"]
    assert e == pytest.approx(approach_damped_restitution(zeta), rel=2.7e-4)  # measured 8.9e-5
    assert abs(e - clipped_restitution(zeta)) > 0.05
    inside = rec.penetration_m > 1e-6
    law = K * rec.penetration_m + D * np.maximum(rec.penetration_rate_m_s, 0.0)
    # measured worst sample 4.8e-4 (float32 state, force from m·Δv/dt)
    np.testing.assert_allclose(rec.normal_force_n[inside], law[inside], rtol=1.5e-3)
    assert np.all(rec.normal_force_n[rec.penetration_m <= 0.0] == 0.0)


def test_default_duration_is_the_closed_form_of_newtons_defaults(newton: NewtonAdapter
                                                                 ) -> None:
    """ShapeConfig defaults (ke = 2.5e3 N/m, kd = 100 N·s/m: overdamped approach, recorded:
    test_conformance.py) and their closed-form contact duration."""
    scenario = BallOnPlate(velocity_m_s=1.0)
    rec = newton.run(scenario, "default", RunSettings(timestep_s=1e-5))
    assert rec.status is Status.OK, rec.message
    defaults = rec.meta["engine_defaults"]
    duration = approach_damped_duration_s(defaults["ke"], defaults["kd"], scenario.mass_kg)
    # measured 1.07e-3 (the 1e-5 s step against the overdamped closed form)
    assert compute(rec)["duration_s"] == pytest.approx(duration, rel=3.2e-3)


def test_elastoplastic_contact_yields_and_recontacts_at_its_permanent_set(
        newton: NewtonAdapter) -> None:
    """The law's memory at work: at 10 m/s the reference passes the yield point (a 'yield'
    event), the engine's contact penetrates beyond εs = 0.07 m, and the second contact starts
    and ends at the permanent set Δx_m − F_m/k1 = (1 − kt/k1)·(Δx_m − εs) of the engine's
    own largest penetration Δx_m (≈ 1.65 mm; a law without memory would re-contact at 0)."""
    scenario = RigidFlexible(velocity_m_s=10.0, local="elastoplastic")
    reference = two_dof.simulate(scenario)
    assert "yield" in [kind for _, kind, _ in reference.meta["events"]]
    rec = newton.run(scenario, "injected", RunSettings(timestep_s=2e-5))
    assert rec.status is Status.OK, rec.message
    eps, k1, kt = scenario.eps_s_m, scenario.k1_n_per_m, scenario.kt_n_per_m
    dx_max = float(rec.penetration_m.max())
    assert dx_max > eps
    permanent = (1.0 - kt / k1) * (dx_max - eps)
    ref_permanent = (1.0 - kt / k1) * (float(reference.penetration_m.max()) - eps)
    assert permanent == pytest.approx(ref_permanent, rel=2e-4)  # measured 6.5e-5
    second = contacts(rec)[1]
    at = np.interp([second.start_s, second.end_s], rec.time_s, rec.penetration_m)
    assert at[0] == pytest.approx(permanent, rel=1.1e-3)  # measured 3.5e-4
    assert at[1] == pytest.approx(permanent, rel=3.2e-3)  # measured 1.06e-3


# --------------------------------------------------------------------------- device-side stepping

RECORD_FIELDS = ("time_s", "penetration_m", "penetration_rate_m_s", "normal_force_n",
                 "velocity_1_m_s", "velocity_2_m_s", "displacement_2_m")


def _assert_same_record(a, b) -> None:
    assert (a.status, a.meta["steps"]) == (b.status, b.meta["steps"])
    for name in RECORD_FIELDS:
        x, y = getattr(a, name), getattr(b, name)
        if x is None or y is None:
            assert x is None and y is None, name
        else:
            np.testing.assert_array_equal(x, y, err_msg=name)


@pytest.mark.parametrize(("scenario", "mode", "dt"), [
    (BallOnPlate(velocity_m_s=5.0), "injected", 1e-7),  # ke from the law in Python per step
    (RigidFlexible(velocity_m_s=10.0, local="elastoplastic"), "injected", 2e-5),  # yields
    (RigidFlexible(velocity_m_s=2.0, structure="softening"), "native", 2e-5),  # β·q2³ kernel
])
def test_graph_replay_records_as_the_step_by_step_path(monkeypatch: pytest.MonkeyPatch,
                                                       scenario, mode: str, dt: float) -> None:
    """One captured CPU graph per step gives the record of the same kernels launched eagerly
    step by step, bit for bit; a small device record (several copies per chunk, blocks of
    odd length) changes nothing either."""
    run = (newton_adapter.run_ball if isinstance(scenario, BallOnPlate)
           else newton_adapter.run_rigid_flexible)
    settings = RunSettings(timestep_s=dt)
    graph = run(scenario, mode, settings)
    assert graph.status is Status.OK, graph.message
    assert graph.meta["stepping"].startswith("warp CPU graph")
    eager = run(scenario, mode, settings, graphs=False)
    assert eager.meta["stepping"].startswith("python loop")
    _assert_same_record(graph, eager)
    monkeypatch.setattr(newton_adapter, "RECORD_CAPACITY", 37)
    _assert_same_record(run(scenario, mode, settings), graph)


# Measured with the Python-loop stepping (commit 9d3db3b, one .numpy().tolist() per state and
# the force in Python per step) on this machine kind: steps, samples, peak force (N), force sum
# (N), final penetration rate (m/s), final u2 (m/s). The device-side stepping reproduced the
# records of 69 runs bit for bit (the default report's 24 rigid–flexible runs at 1e-5 s, one at
# 2e-5 s; ball native, injected and tuned at 0.5–5 m/s, native at 1e-4 to 3e-7 s, default,
# custom); rel=1e-6 leaves room for another CPU's float32 code generation only.
PINNED = [
    (BallOnPlate(velocity_m_s=5.0), "injected", 1e-7,
     (792, 780, 22328.972816467285, 8742174.863815308, -3.7421748638153076, 0.0)),
    (BallOnPlate(velocity_m_s=1.0), "native", 1e-6,
     (109, 108, 2806.8915009498596, 193685.1441860199, -0.936851441860199, 0.0)),
    (RigidFlexible(velocity_m_s=3.3, local="elastoplastic"), "injected", 2e-5,
     (2897, 2815, 2377.033233642578, 3208425.0450134277, -3.1142376696225256,
      -0.0026124680880457163)),
    (RigidFlexible(velocity_m_s=2.0, structure="softening"), "native", 1e-5,
     (5798, 5641, 1440.6442642211912, 3889442.801475525, -1.8924092394299805,
      0.002966437954455614)),
]


@pytest.mark.parametrize(("scenario", "mode", "dt", "expected"), PINNED)
def test_records_match_the_python_loop_stepping(newton: NewtonAdapter, scenario, mode: str,
                                                dt: float, expected: tuple) -> None:
    rec = newton.run(scenario, mode, RunSettings(timestep_s=dt))
    assert rec.status is Status.OK, rec.message
    steps, samples, *values = expected
    assert (rec.meta["steps"], len(rec.time_s)) == (steps, samples)
    measured = (rec.normal_force_n.max(), rec.normal_force_n.sum(),
                rec.penetration_rate_m_s[-1], rec.velocity_2_m_s[-1])
    assert measured == pytest.approx(values, rel=1e-6, abs=1e-12)


def test_without_cpu_graph_capture_steps_eagerly(monkeypatch: pytest.MonkeyPatch) -> None:
    """A warp that cannot capture on CPU (before 1.19: 'Must be a CUDA device') gets the same
    record from the eager launches, and the meta says so."""
    scenario, settings = BallOnPlate(velocity_m_s=1.0), RunSettings(timestep_s=1e-6)
    graph = newton_adapter.run_ball(scenario, "native", settings)
    wp = newton_adapter._newton()[0]

    def no_capture(*args, **kwargs):
        raise RuntimeError("Must be a CUDA device")

    monkeypatch.setattr(wp, "capture_begin", no_capture)
    eager = newton_adapter.run_ball(scenario, "native", settings)
    assert eager.meta["stepping"] == "python loop (no CPU graph capture in this warp)"
    _assert_same_record(eager, graph)


def test_pipelines_share_their_narrow_phase_kernels(monkeypatch: pytest.MonkeyPatch) -> None:
    """Two runs' collision pipelines hold the same narrow-phase kernel objects (warp hashes
    their modules once per process, not once per run), and a run through Newton's own
    factories — every kernel defined anew, as Newton does — records the same bits."""
    from newton._src.geometry import narrow_phase

    _, newton = newton_adapter._newton()
    model = newton_adapter.ball_model(BallOnPlate(), newton_adapter.newton_contact_defaults())
    kernels = [(p.narrow_phase.primitive_kernel, p.narrow_phase.narrow_phase_kernel)
               for p in (newton.CollisionPipeline(model), newton.CollisionPipeline(model))]
    assert kernels[0][0] is kernels[1][0] and kernels[0][1] is kernels[1][1]
    scenario, settings = BallOnPlate(velocity_m_s=2.0), RunSettings(timestep_s=1e-6)
    shared = newton_adapter.run_ball(scenario, "injected", settings)
    for name in newton_adapter.NARROW_PHASE_FACTORIES:
        monkeypatch.setattr(narrow_phase, name, getattr(narrow_phase, name).__wrapped__)
    own = newton_adapter.run_ball(scenario, "injected", settings)
    _assert_same_record(own, shared)


# --------------------------------------------------------------------------------- oblique


def test_oblique_graph_and_step_by_step_records_are_identical():
    s = Oblique(angle_deg=60.0)
    settings = RunSettings(timestep_s=1e-6)
    for mode in ("native", "injected"):
        a = newton_adapter.run_oblique(s, mode, settings)
        b = newton_adapter.run_oblique(s, mode, settings, graphs=False)
        for name in ("penetration_m", "normal_force_n", "tangential_velocity_m_s",
                     "spin_rad_s", "tangential_force_n"):
            assert np.array_equal(getattr(a, name), getattr(b, name)), (mode, name)


def test_run_many_is_run_bit_for_bit() -> None:
    """A tuner's generation as one Newton model, a world per run (Adapter.run_many →
    run_ball_batch): every world's record is its lone run's to the last bit — soft and stiff
    contacts at two velocities, worlds that end at different steps, and an injected run among
    them (a world whose ke is set in Python every step; the other scenarios' batches and the
    report's mix: test_newton_batches.py). Measured: 21 runs, no difference, 4.4x faster
    than one by one."""
    adapter = get_adapter("newton")
    items = [(BallOnPlate(velocity_m_s=v), "tuned", RunSettings(tuned={"ke": ke, "kd": kd}))
             for v in (0.5, 3.0) for ke, kd in ((1e4, 1.0), (1e6, 30.0), (1e8, 300.0))]
    items.insert(3, (BallOnPlate(velocity_m_s=1.0), "injected", RunSettings()))
    many = adapter.run_many(items)
    alone = [adapter.run(*item) for item in items]
    assert len({r.time_s.size for r in alone}) > 3  # the worlds end at different steps
    for a, b in zip(alone, many, strict=True):
        assert (a.status, a.message) == (b.status, b.message)
        for name in ("time_s", "penetration_m", "penetration_rate_m_s", "normal_force_n"):
            assert np.array_equal(getattr(a, name), getattr(b, name), equal_nan=True), name
        assert repr({k: v for k, v in a.meta.items() if k != "wall_s"}) == \
            repr({k: v for k, v in b.meta.items() if k != "wall_s"})
