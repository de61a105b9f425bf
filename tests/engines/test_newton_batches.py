"""Newton's batches (real engine: warp on CPU, float32, Featherstone; no mocks).

``Adapter.run_many`` hands every head-on, 2-DOF, oblique and bounce run to the scenario's
batch builder, which steps the runs at one step (and gravity) as the worlds of one model,
each world driven by its lone run's plan and end rule; an injected world's law is evaluated
in Python between the steps on its own state and written into its own shapes. Each record
must be its lone run's (``Adapter.run``) to the last bit: every array of the record, its
status and message, and every number of its meta (compared through ``repr``: a float's repr
round-trips exactly, NaN as ``nan``), ``wall_s`` aside. The cases mix every mode, points,
steps (a step with a lone run in it runs alone), phases, worlds that end at different steps
(and some that diverge or are cut by their time cap) and softening structures (the cubic
force on the device per world).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import require_engine
from impactbench.engines.base import RunSettings, get_adapter
from impactbench.engines.mujoco_adapter import GAP_STEPS
from impactbench.engines.newton_adapter import NewtonAdapter, pair_plan
from impactbench.reference.bounce_scenario import Bounce
from impactbench.reference.oblique_scenario import Oblique
from impactbench.reference.record import Status
from impactbench.reference.scenarios import BallOnPlate, RigidFlexible

from impactbench import evaluate


@pytest.fixture(autouse=True, scope="module")
def _newton_installed() -> None:
    """Newton is imported when this file's tests run, not when it is collected: every test
    process collects every file, and importing Newton costs ~3 s of CPU."""
    require_engine("newton")


ARRAYS = ("time_s", "penetration_m", "penetration_rate_m_s", "normal_force_n",
          "velocity_1_m_s", "velocity_2_m_s", "displacement_2_m", "tangential_velocity_m_s",
          "spin_rad_s", "tangential_force_n")


@pytest.fixture(scope="module")
def newton() -> NewtonAdapter:
    adapter = get_adapter("newton")
    assert isinstance(adapter, NewtonAdapter)
    return adapter


def _meta(rec) -> str:
    return repr({k: v for k, v in rec.meta.items() if k != "wall_s"})


def assert_batch_is_lone(adapter: NewtonAdapter, items: list) -> list:
    """run_many's records against one run after another, bit for bit; the lone records."""
    many = adapter.run_many(items)
    alone = [adapter.run(*item) for item in items]
    assert len(many) == len(alone) == len(items)
    for k, (a, b) in enumerate(zip(alone, many, strict=True)):
        where = f"item {k}: {items[k][1]} {items[k][2]}"
        assert (a.status, a.message) == (b.status, b.message), where
        assert (a.mass_1_kg, a.mass_2_kg) == (b.mass_1_kg, b.mass_2_kg), where
        for name in ARRAYS:
            x, y = getattr(a, name), getattr(b, name)
            if x is None or y is None:
                assert x is None and y is None, (where, name)
                continue
            assert x.dtype == y.dtype and x.shape == y.shape, (where, name)
            # bit for bit: the same float64 patterns (NaN only where NaN)
            assert np.array_equal(x, y, equal_nan=True), (where, name)
        assert _meta(a) == _meta(b), where
    return alone


def test_rigid_flexible_batch_is_run_bit_for_bit(newton: NewtonAdapter) -> None:
    """Every mode, the three local laws (elastoplastic's memory, injected), both structures
    (softening: β·x2³ per world on the device), two velocities and two steps, a time cap
    that cuts one world, and a run alone at its step."""
    tuned = RunSettings(timestep_s=2e-5, tuned={"ke": 3e5, "kd": 5.0})
    items = [(RigidFlexible(velocity_m_s=v, local=local, structure=structure), mode,
              RunSettings(timestep_s=1e-5))
             for local, structure, v, mode in (
                 ("linear", "linear", 2.0, "native"), ("elastoplastic", "softening", 10.0,
                                                       "native"),
                 ("mutation", "linear", 10.0, "injected"), ("elastoplastic", "linear", 10.0,
                                                            "injected"),
                 ("linear", "softening", 2.0, "injected"), ("mutation", "softening", 2.0,
                                                            "native"))]
    items += [(RigidFlexible(velocity_m_s=3.3, local="elastoplastic"), "default",
               RunSettings(timestep_s=1e-5)),
              (RigidFlexible(velocity_m_s=3.3), "custom",
               RunSettings(timestep_s=1e-5, params={"ke": 2e5, "kd": 1.0})),
              (RigidFlexible(velocity_m_s=2.0, structure="softening"), "tuned", tuned),
              (RigidFlexible(velocity_m_s=10.0, local="mutation"), "tuned", tuned),
              (RigidFlexible(velocity_m_s=2.0, structure="softening"), "native",
               RunSettings(timestep_s=2e-5, max_time_s=0.01)),
              (RigidFlexible(velocity_m_s=2.0), "native", RunSettings(timestep_s=3e-5))]
    alone = assert_batch_is_lone(newton, items)
    steps = {r.meta["steps"] for r in alone[:8]}
    assert len(steps) >= 4  # the 1e-5 s worlds end at different steps
    statuses = {r.status for r in alone}
    assert Status.OK in statuses and Status.MAX_TIME in statuses  # the cut world
    assert any(r.meta["stepping"].endswith("in Python)") for r in alone)


def test_pair_plan_is_drive_pairs() -> None:
    """The batch's worlds are planned as drive_pair plans a lone run: checked through the
    numbers themselves here (the step cap, the first look, the chunk), and through the
    records in the test above."""
    s = RigidFlexible(velocity_m_s=2.0)
    m_eff = s.m1_kg * s.m2_kg / (s.m1_kg + s.m2_kg)
    t_c = math.pi * math.sqrt(m_eff / min(s.k1_n_per_m, s.k2_n_per_m))
    n_max, first, chunk = pair_plan(s, 1e-5, None, False)
    assert n_max == math.ceil(s.max_time_s / 1e-5)
    assert chunk == max(64, math.ceil(0.1 * t_c / 1e-5))
    assert first == math.ceil(GAP_STEPS) + math.ceil(2.0 * t_c / 1e-5)
    assert pair_plan(s, 1e-5, 0.02, True) == (2000, chunk, chunk)


def test_oblique_batch_is_run_bit_for_bit(newton: NewtonAdapter) -> None:
    """Every mode (tuned: the shapes' mu and kf read back from each world's own shapes) at
    four angles and two steps, two worlds that diverge after a few steps (1e-3 s), and a run
    alone at its step."""
    tuned = {"mu": 0.31, "kf": 1.4e4}
    items = [(Oblique(angle_deg=a), mode, RunSettings(timestep_s=1e-6, tuned=tuned
                                                      if mode == "tuned" else None))
             for a in (20.0, 80.0) for mode in ("native", "injected", "tuned")]
    items += [(Oblique(angle_deg=45.0), "default", RunSettings(timestep_s=1e-6)),
              (Oblique(angle_deg=60.0), "custom",
               RunSettings(timestep_s=1e-6, params={"ke": 1e6, "kd": 20.0, "kf": 50.0})),
              (Oblique(angle_deg=45.0), "native",
               RunSettings(timestep_s=1e-6, options={"reference_velocity_m_s": 2.0})),
              (Oblique(angle_deg=45.0), "native", RunSettings(timestep_s=1e-3)),
              (Oblique(angle_deg=45.0), "injected", RunSettings(timestep_s=1e-3)),
              (Oblique(angle_deg=30.0), "native", RunSettings(timestep_s=1e-5))]
    alone = assert_batch_is_lone(newton, items)
    assert len({r.meta["steps"] for r in alone[:9]}) >= 4
    assert [r.status for r in alone[9:11]] == [Status.DIVERGED] * 2
    tuned_meta = alone[2].meta["engine_defaults"]
    assert tuned_meta["shape_material_mu"] == pytest.approx([0.31, 0.31], rel=1e-7)


def test_bounce_batch_is_run_bit_for_bit(newton: NewtonAdapter) -> None:
    """Every mode at the customary step (a world that settles, one cut by its time cap, one
    stopped for energy gained, an injected one), and a run alone at another step."""
    b = Bounce()
    items = [(b, "native", RunSettings()), (b, "default", RunSettings(max_time_s=0.3)),
             (b, "tuned", RunSettings(tuned={"ke": 130.7, "kd": 221.4})),
             (b, "custom", RunSettings(params={"ke": 1e3, "kd": 5.0})),
             (b, "injected", RunSettings()), (b, "native", RunSettings(timestep_s=1e-3))]
    alone = assert_batch_is_lone(newton, items)
    statuses = [r.status for r in alone]
    assert {Status.OK, Status.MAX_TIME, Status.DIVERGED} <= set(statuses)
    assert len({r.meta["steps"] for r in alone[:5]}) >= 4


def test_ball_batch_takes_the_reports_mix(newton: NewtonAdapter) -> None:
    """What a report sends the ball's batch at once: native, injected, tuned, default and
    custom runs at several velocities, phases and steps (a large step whose runs diverge
    among them), now with the injected worlds in the batch too."""
    tuned = {"ke": 1.4e8, "kd": 504.0}
    items = [(BallOnPlate(velocity_m_s=v), mode,
              RunSettings(timestep_s=1e-6, tuned=tuned if mode == "tuned" else None))
             for v in (0.5, 4.0) for mode in ("native", "injected", "tuned")]
    soft = {"ke": 130.7, "kd": 221.4}
    items += [(BallOnPlate(velocity_m_s=v), mode,
               RunSettings(timestep_s=1 / 1200, phase=phase, tuned=soft if mode == "tuned"
                           else None, params={"ke": 1e3} if mode == "custom" else None))
              for v, phase, mode in ((1.0, 0.0, "native"), (1.0, 0.375, "native"),
                                     (3.0, 0.125, "default"), (0.5, 0.875, "custom"),
                                     (2.0, 0.5, "tuned"), (2.0, 0.25, "injected"))]
    items += [(BallOnPlate(velocity_m_s=v), mode, RunSettings(timestep_s=1e-2))
              for v in (1.0, 5.0) for mode in ("native", "injected")]
    alone = assert_batch_is_lone(newton, items)
    statuses = {r.status for r in alone}
    assert Status.OK in statuses and Status.DIVERGED in statuses
    assert {r.meta["phase"] for r in alone[6:12]} == {0.0, 0.375, 0.125, 0.875, 0.5, 0.25}


def _same(a, b) -> bool:
    """compare()'s objects equal to the last bit, NaN = NaN, wall_s aside."""
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(_same(a[k], b[k]) for k in a if k != "wall_s")
    if isinstance(a, float) and isinstance(b, float):
        return (math.isnan(a) and math.isnan(b)) or (a == b and math.copysign(1.0, a)
                                                     == math.copysign(1.0, b))
    if isinstance(a, (list, tuple)) and isinstance(b, (list, tuple)):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b, strict=True))
    return type(a) is type(b) and a == b


def test_compare_many_is_compare(newton: NewtonAdapter) -> None:
    """The suite's path (evaluate.compare_many: one call per engine, each scenario to its
    batch) gives compare's objects, metrics and all, failed runs' NaN included."""
    items = [(BallOnPlate(velocity_m_s=1.0), "native", RunSettings(timestep_s=1e-2)),
             (BallOnPlate(velocity_m_s=1.0), "injected", RunSettings(timestep_s=1e-2)),
             (RigidFlexible(velocity_m_s=2.0), "native", RunSettings(timestep_s=2e-5)),
             (RigidFlexible(velocity_m_s=2.0, local="elastoplastic"), "injected",
              RunSettings(timestep_s=2e-5)),
             (Oblique(angle_deg=45.0), "native", RunSettings(timestep_s=1e-4)),
             (Oblique(angle_deg=45.0), "injected", RunSettings(timestep_s=1e-4)),
             (Bounce(), "native", RunSettings(max_time_s=0.5)),
             (Bounce(), "tuned", RunSettings(max_time_s=0.5, tuned={"ke": 130.7, "kd": 221.4}))]
    full = [(s, mode, st, evaluate.reference_metrics(s)) for s, mode, st in items]
    many = evaluate.compare_many("newton", full)
    alone = [evaluate.compare("newton", *item)[0] for item in full]
    assert any(math.isnan(v) for r in alone for v in r.values() if isinstance(v, float))
    for k, (a, b) in enumerate(zip(alone, many, strict=True)):
        assert _same(a, b), (k, items[k][1])
