"""``RunSettings.phase`` on every engine's head-on ball: the ball starts
:func:`~impactbench.engines.base.ball_gap_m` (2 + phase steps of flight) above the plate in
every mode, batched runs included, the phase is recorded in ``meta["phase"]``, and no phase
(None) is the default phase 0.5 bit for bit (the records the suite stored before phases)."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import require_engine
from impactbench.engines.base import (
    DEFAULT_PHASE,
    RunSettings,
    SettingsError,
    ball_gap_m,
    get_adapter,
)
from impactbench.reference.scenarios import BallOnPlate

ENGINES = ("mujoco", "mjx", "newton", "pybullet", "pymunk", "drake", "sapien", "dart", "box2d")
MODES = ("native", "injected", "default")
PHASES = (0.0, 0.25, 0.75)
V0 = 2.0
DT = 1e-3
"""A coarse step: the gap is millimetres and every engine runs its few steps in well under a
second (the native and injected contacts diverge at it in some engines: the start is what is
tested here, not the outcome)."""

FLOAT32 = frozenset({"newton", "sapien", "box2d"})
"""Engines that keep the ball's position in float32."""
TOLERANCE = {True: 1.5e-7, False: 1.5e-15}
"""|x_0 + gap| / gap allowed, float32 engine or not. Measured (2 m/s, phases 0, 0.25, 0.75,
0.999, steps 1e-3 and 1e-5 s, modes native, injected, default): float32 positions (Newton,
SAPIEN, Box2D) ≤ 4.8e-8, half a float32 ulp; the other engines 0 (MuJoCo, MJX, pymunk, DART)
or ≤ 4.4e-16 at 1e-3 s (PyBullet and Drake: x = R − (R + gap), one rounding of R + gap)."""

TIMING_KEYS = ("wall_s", "loop_wall_s")
"""Meta keys that differ between two runs of the same record (wall-clock times)."""


def _run(engine: str, mode: str, phase: float | None):
    return get_adapter(engine).run(BallOnPlate(velocity_m_s=V0), mode,
                                   RunSettings(timestep_s=DT, phase=phase))


@pytest.fixture(scope="module", params=ENGINES)
def runs(request: pytest.FixtureRequest):
    """(engine, {(mode, phase): record}) for every mode and phase of the tests (each engine
    built and run once per module)."""
    engine = request.param
    require_engine(engine)
    return engine, {(mode, phase): _run(engine, mode, phase)
                    for mode in MODES for phase in (*PHASES, DEFAULT_PHASE, None)}


def _untimed(meta: dict) -> str:
    return repr({k: v for k, v in meta.items() if k not in TIMING_KEYS})


def _same_record(a, b) -> None:
    """The same record exactly: status, every sample, the meta but its wall-clock times."""
    assert a.status == b.status
    for name in ("time_s", "penetration_m", "penetration_rate_m_s", "normal_force_n",
                 "velocity_1_m_s", "velocity_2_m_s"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)
    assert _untimed(a.meta) == _untimed(b.meta)


def test_the_ball_starts_at_the_gap_of_its_phase(runs) -> None:
    engine, recs = runs
    tol = TOLERANCE[engine in FLOAT32]
    for mode in MODES:
        for phase in PHASES:
            rec = recs[mode, phase]
            gap = ball_gap_m(V0, DT, phase)
            x0 = float(rec.penetration_m[0])
            assert abs(x0 + gap) <= tol * gap, (mode, phase, x0, -gap)
            assert rec.meta["phase"] == phase, (mode, phase)


def test_no_phase_is_the_default_phase_bit_for_bit(runs) -> None:
    _, recs = runs
    for mode in MODES:
        none, half = recs[mode, None], recs[mode, DEFAULT_PHASE]
        assert none.meta["phase"] == half.meta["phase"] == 0.5
        _same_record(none, half)
        # the start sits 2.5 steps of flight away, as before phases
        gap = 2.5 * V0 * DT
        assert abs(float(none.penetration_m[0]) + gap) <= 1.5e-7 * gap


@pytest.mark.parametrize("engine", ["mjx", "newton"])
def test_a_batch_gives_each_world_its_own_phase(engine: str) -> None:
    """MJX and Newton step a batch of ball runs together: each world starts at its own run's
    phase, and its record is the lone run's."""
    require_engine(engine)
    adapter = get_adapter(engine)
    ball = BallOnPlate(velocity_m_s=V0)
    phases = (0.0, 0.75, None)
    items = [(ball, "default", RunSettings(timestep_s=DT, phase=p)) for p in phases]
    batch = adapter.run_many(items)
    for phase, rec, item in zip(phases, batch, items, strict=True):
        gap = ball_gap_m(V0, DT, phase)
        assert abs(float(rec.penetration_m[0]) + gap) <= TOLERANCE[engine in FLOAT32] * gap
        assert rec.meta["phase"] == (DEFAULT_PHASE if phase is None else phase)
        _same_record(rec, adapter.run(*item))


@pytest.mark.parametrize("phase", [1.0, -0.1, float("nan")])
def test_a_phase_outside_a_step_is_refused(phase: float) -> None:
    with pytest.raises(SettingsError, match="phase"):
        RunSettings(timestep_s=DT, phase=phase)
