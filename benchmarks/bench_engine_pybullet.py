"""PyBullet adapter overhead: adapter wall time against a bare ``stepSimulation`` loop.

For each case the adapter runs the scenario (world building, the native conversion, stepping,
reading the state and the contact force each step, recording, classifying). The bare loop
builds the same world (the adapter's own ``BallWorld`` / ``FlexWorld``, same contact
parameters and initial state) and calls ``stepSimulation`` as many times as the adapter's
record has samples, reading nothing; for rigid–flexible it also applies the structural force
each step, which is part of the model. The two run alternately (adapter, bare, adapter,
bare, …: the machine is shared, so a pair sees the same load) and each is reported as its
median over the repeats (:mod:`benchmarks.alternate`); a best-of of each side timed apart
reported 4.26× where alternated medians give 1.31×. Target: ratio ≤ 1.3.

``p.connect(DIRECT)`` and building the world cost ~10 ms, more than a whole ball impact, so
the table also shows the loops alone: the adapter's stepping-and-recording loop
(``meta["loop_wall_s"]``) against the bare stepping loop, per step, which is what reading the
state and the contact force and recording them cost.

Run: ``python -m benchmarks bench_engine_pybullet`` (or this file directly).
"""

from __future__ import annotations

import statistics
import time
from collections.abc import Callable
from typing import Any

from impactbench.engines.pybullet_adapter import BallWorld, FlexWorld, _import_engine
from impactbench.reference.scenarios import BallOnPlate

from benchmarks.alternate import alternate
from benchmarks.overhead import table_head, warmed_up

REPEATS = 15


def bare_loop(scenario: Any, dt: float, steps: int, k: float, d: float) -> float:
    """Build the same world and step it ``steps`` times, recording nothing; returns the
    stepping loop's own wall time (s)."""
    p = _import_engine()
    if isinstance(scenario, BallOnPlate):
        world = BallWorld(p, scenario, dt, k, d)
        try:
            step, cid = p.stepSimulation, world.cid
            t0 = time.perf_counter()
            for _ in range(steps):
                step(physicsClientId=cid)
            return time.perf_counter() - t0
        finally:
            world.close()
    world = FlexWorld(p, scenario, dt, k, d)
    try:
        step, cid, body = p.stepSimulation, world.cid, world.body
        state, motor, torque = p.getJointState, p.setJointMotorControl2, p.TORQUE_CONTROL
        spring = scenario.structural_law().force
        t0 = time.perf_counter()
        for _ in range(steps):
            motor(body, 1, torque, force=-spring(state(body, 1, physicsClientId=cid)[0]),
                  physicsClientId=cid)
            step(physicsClientId=cid)
        return time.perf_counter() - t0
    finally:
        world.close()


def _median_pair(adapter: Callable[[], float], bare: Callable[[], float],
                 repeats: int = REPEATS) -> tuple[float, float, float, float]:
    """(adapter's whole wall time, its loop's, bare whole, bare loop), each the median over
    ``repeats`` rounds of adapter then bare (s); each callable returns its loop's time."""
    loops: dict[str, list[float]] = {"adapter": [], "bare": []}

    def keep(name: str, fn: Callable[[], float]) -> Callable[[], None]:
        return lambda: loops[name].append(fn())

    whole = alternate({"adapter": keep("adapter", adapter), "bare": keep("bare", bare)},
                      repeats)
    med = statistics.median
    return (med(whole["adapter"]), med(loops["adapter"]), med(whole["bare"]),
            med(loops["bare"]))


def main() -> None:
    adapter = table_head("pybullet", "PyBullet", "bare stepSimulation loop", REPEATS,
                         f"{'case':36s} {'steps':>7s} {'adapter ms':>10s} {'bare ms':>8s} "
                         f"{'ratio':>6s} {'loop µs/step':>12s} {'bare µs/step':>12s} "
                         f"{'ratio':>6s}")
    for label, scenario, mode, dt, settings, rec in warmed_up(adapter):
        steps = len(rec)
        k = rec.meta.get("contact_stiffness", 0.0)
        d = rec.meta.get("contact_damping", 0.0)
        t_adapter, loop_adapter, t_bare, loop_bare = _median_pair(
            lambda s=scenario, m=mode, st=settings: adapter.run(s, m, st).meta["loop_wall_s"],
            lambda s=scenario, h=dt, n=steps, kk=k, dd=d: bare_loop(s, h, n, kk, dd))
        print(f"{label:36s} {steps:7d} {t_adapter * 1e3:10.3f} {t_bare * 1e3:8.3f} "
              f"{t_adapter / t_bare:6.2f} {loop_adapter / steps * 1e6:12.2f} "
              f"{loop_bare / steps * 1e6:12.2f} {loop_adapter / loop_bare:6.2f}  [{rec.status}]")


if __name__ == "__main__":
    main()
