"""Newton adapter overhead: adapter wall time against a bare Featherstone stepping loop.

For each shared case (:data:`benchmarks.overhead.CASES`) the adapter runs the scenario
(building the model, stepping, reading the joint state, the m·Δv/dt force, the end search and
the record); the bare loop builds the same model (same contact parameters, same initial state)
and calls ``collide`` and ``SolverFeatherstone.step`` for as many steps
as the adapter's record holds, reading nothing. Both are timed as the best of a few alternating
repeats (the machine is shared). Kernel compilation is excluded (a warm-up run first).

Run: ``python -m benchmarks bench_engine_newton``.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from impactbench.engines.base import RunSettings, get_adapter
from impactbench.engines.common import NATIVE_REFERENCE_VELOCITY_M_S
from impactbench.engines.newton_adapter import (
    _newton,
    ball_model,
    contact_parameters,
    native_ball,
    rigid_flexible_model,
)
from impactbench.reference.scenarios import BallOnPlate

from benchmarks.bench_engine_mujoco import _best_pair
from benchmarks.overhead import CASES

REPEATS = 3  # a Python-stepped engine at ~10³ steps/s: a few repeats already take minutes


def bare_loop(scenario: Any, mode: str, dt: float, steps: int) -> None:
    """The same model and initial state, stepped ``steps`` times with nothing recorded."""
    newton = _newton()[1]
    ball = isinstance(scenario, BallOnPlate)
    values = {"ke": 0.0, "kd": 0.0, "kf": 0.0, "mu": 0.0}  # injected: ke is set per step
    if mode != "injected":
        native = native_ball(scenario.replace(
            velocity_m_s=NATIVE_REFERENCE_VELOCITY_M_S)) if ball else None
        values, _ = contact_parameters(
            mode, RunSettings(), (native.stiffness_n_per_m, native.damping_ns_per_m) if ball
            else (scenario.k1_n_per_m, 0.0))
    v0, gap = scenario.velocity_m_s, 2.5 * scenario.velocity_m_s * dt
    model = ball_model(scenario, values) if ball else rigid_flexible_model(scenario, values)
    s0, s1, control = model.state(), model.state(), model.control()
    s0.joint_q.assign(np.array([gap] if ball else [-gap, 0.0], dtype=np.float32))
    s0.joint_qd.assign(np.array([-v0] if ball else [v0, 0.0], dtype=np.float32))
    newton.eval_fk(model, s0.joint_q, s0.joint_qd, s0)
    solver = newton.solvers.SolverFeatherstone(model)
    pipeline = newton.CollisionPipeline(model)
    contacts = pipeline.contacts()
    for _ in range(steps):
        s0.clear_forces()
        pipeline.collide(s0, contacts)
        solver.step(s0, s1, control, contacts, dt)
        s0, s1 = s1, s0


def main() -> None:
    adapter = get_adapter("newton")
    print(f"Newton {adapter.version()}: adapter vs bare Featherstone loop (best of {REPEATS})")
    header = f"{'case':36s} {'steps':>7s} {'adapter ms':>10s} {'bare ms':>8s} {'ratio':>6s} " \
             f"{'steps/s':>8s}"
    print(header)
    print("-" * len(header))
    for label, scenario, mode, dt in CASES:
        settings = RunSettings(timestep_s=dt)
        rec = adapter.run(scenario, mode, settings)  # warm-up: kernels load or compile
        steps = rec.meta["steps"]
        t_adapter, t_bare = _best_pair(
            lambda s=scenario, m=mode, st=settings: adapter.run(s, m, st),
            lambda s=scenario, m=mode, h=dt, n=steps: bare_loop(s, m, h, n), REPEATS)
        print(f"{label:36s} {steps:7d} {t_adapter * 1e3:10.1f} {t_bare * 1e3:8.1f} "
              f"{t_adapter / t_bare:6.2f} {steps / t_adapter:8.0f} [{rec.status}]")


if __name__ == "__main__":
    main()
