"""MuJoCo adapter overhead: adapter wall time against bare stepping *by the same path*.

For each case the adapter runs the scenario (building the model, stepping, recording, and
classifying); the bare run builds the same MJCF model, sets the same contact parameters and
initial state and steps it as many times as the adapter did (``meta["steps"]``), recording
nothing, by the path the adapter used (``meta["stepping"]``): one ``mujoco.rollout.rollout``
call (C++ loop) where the adapter rolls out, a Python ``mj_step`` loop where the adapter needs a
Python call per step (injected schedules, a cubic structure). Comparing the adapter's C++
rollout with a Python loop would credit the adapter with the rollout's speed-up and hide its
own overhead. Both sides run alternately (adapter, bare, adapter, bare, …: the machine is
shared, so a pair sees the same load) and each is reported as its median over the repeats
(:mod:`benchmarks.alternate`; a best-of would reward each side's luckiest run). Target:
ratio ≤ 1.3.

Run: ``python -m benchmarks bench_engine_mujoco`` (or this file directly).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from impactbench.engines.mujoco_adapter import ball_mjcf, rigid_flexible_mjcf
from impactbench.reference.scenarios import BallOnPlate

from benchmarks.alternate import median_pair
from benchmarks.overhead import rerun, table_head, warmed_up

REPEATS = 15


def _median_pair(a: Callable[[], Any], b: Callable[[], Any],
                 repeats: int = REPEATS) -> tuple[float, float]:
    """Median wall times of ``a`` and ``b``, run alternately so both see the same load."""
    return median_pair(a, b, repeats)


_best_pair = _median_pair
"""The old name, still imported by other benchmarks: alternated medians now, not best-of."""


def bare_run(scenario: Any, dt: float, steps: int, solref: list[float] | None,
             path: str) -> None:
    """Build the same model and step it ``steps`` times by ``path`` (``rollout`` or
    ``python loop``), recording nothing."""
    import mujoco
    import mujoco.rollout
    import numpy as np

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
    if path == "rollout":
        spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
        s0 = np.empty(mujoco.mj_stateSize(model, spec))
        mujoco.mj_getState(model, data, s0, spec)
        mujoco.rollout.rollout(model, data, s0[None], nstep=steps)
        return
    step = mujoco.mj_step
    for _ in range(steps):
        step(model, data)


def main() -> None:
    adapter = table_head("mujoco", "MuJoCo", "bare stepping by the same path", REPEATS,
                         f"{'case':36s} {'steps':>7s} {'stepped':>7s} {'adapter ms':>10s} "
                         f"{'bare ms':>8s} {'ratio':>6s}  path")
    # the warm-up also fills the native conversion cache
    for label, scenario, mode, dt, settings, rec in warmed_up(adapter):
        steps, path = rec.meta["steps"], rec.meta["stepping"]
        solref = rec.meta.get("solref")
        t_adapter, t_bare = _median_pair(
            rerun(adapter, scenario, mode, settings),
            lambda s=scenario, h=dt, n=steps, r=solref, w=path: bare_run(s, h, n, r, w))
        print(f"{label:36s} {len(rec):7d} {steps:7d} {t_adapter * 1e3:10.3f} "
              f"{t_bare * 1e3:8.3f} {t_adapter / t_bare:6.2f}  {rec.meta['stepping']}"
              f" [{rec.status}]")


if __name__ == "__main__":
    main()
