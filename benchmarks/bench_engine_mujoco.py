"""MuJoCo adapter overhead: adapter wall time against a bare ``mj_step`` loop.

For each case the adapter runs the scenario (building the model, stepping, recording, and
classifying); the bare loop builds the same MJCF model, sets the same contact parameters and
initial state and calls ``mujoco.mj_step`` in a Python loop for as many steps as the adapter's
record holds, recording nothing. Both are timed as the best of several repeats (the machine is
shared, so the two alternate and the minimum is the least noisy estimate). Target: ratio ≤ 1.3.

Run: ``python -m benchmarks bench_engine_mujoco`` (or this file directly).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

from impactbench.engines.base import RunSettings, get_adapter
from impactbench.engines.mujoco_adapter import ball_mjcf, rigid_flexible_mjcf
from impactbench.reference.scenarios import BallOnPlate

from benchmarks.overhead import CASES

REPEATS = 15



def _best_pair(a: Callable[[], Any], b: Callable[[], Any],
               repeats: int = REPEATS) -> tuple[float, float]:
    """Best wall times of ``a`` and ``b``, run alternately so both see the same load."""
    best_a = best_b = float("inf")
    for _ in range(repeats):
        t0 = time.perf_counter()
        a()
        t1 = time.perf_counter()
        b()
        t2 = time.perf_counter()
        best_a, best_b = min(best_a, t1 - t0), min(best_b, t2 - t1)
    return best_a, best_b


def bare_loop(scenario: Any, dt: float, steps: int, solref: list[float] | None) -> None:
    """Build the same model and step it ``steps`` times with no recording."""
    import mujoco

    if isinstance(scenario, BallOnPlate):
        model = mujoco.MjModel.from_xml_string(ball_mjcf(scenario, dt))
        data = mujoco.MjData(model)
        data.qpos[0], data.qvel[0] = 2.5 * scenario.velocity_m_s * dt, -scenario.velocity_m_s
    else:
        model = mujoco.MjModel.from_xml_string(rigid_flexible_mjcf(scenario, dt))
        data = mujoco.MjData(model)
        data.qpos[:] = (-2.5 * scenario.velocity_m_s * dt, 0.0)
        data.qvel[:] = (scenario.velocity_m_s, 0.0)
    if solref is not None:
        model.geom_solref[:] = solref
    step = mujoco.mj_step
    for _ in range(steps):
        step(model, data)


def main() -> None:
    adapter = get_adapter("mujoco")
    print(f"MuJoCo {adapter.version()}: adapter vs bare mj_step loop (best of {REPEATS})")
    header = f"{'case':36s} {'steps':>7s} {'stepped':>7s} {'adapter ms':>10s} " \
             f"{'bare ms':>8s} {'ratio':>6s}  path"
    print(header)
    print("-" * len(header))
    for label, scenario, mode, dt in CASES:
        settings = RunSettings(timestep_s=dt)
        rec = adapter.run(scenario, mode, settings)  # warm-up (and the native conversion cache)
        steps = len(rec)
        solref = rec.meta.get("solref")
        t_adapter, t_bare = _best_pair(
            lambda s=scenario, m=mode, st=settings: adapter.run(s, m, st),
            lambda s=scenario, h=dt, n=steps, r=solref: bare_loop(s, h, n, r))
        print(f"{label:36s} {steps:7d} {rec.meta['steps']:7d} {t_adapter * 1e3:10.3f} "
              f"{t_bare * 1e3:8.3f} {t_adapter / t_bare:6.2f}  {rec.meta['stepping']}"
              f" [{rec.status}]")


if __name__ == "__main__":
    main()
