"""pymunk adapter overhead: ``PymunkAdapter.run`` against a bare ``space.step`` loop.

For each case the adapter runs once to learn its step count n; then ``REPEATS`` rounds of
the two, alternately (medians: the machine is shared, a best-of rewards the luckiest run):

- adapter: ``adapter.run(scenario, mode, settings)`` — builds the space (for the native ball
  also the reference solve behind the elasticity), steps with recording and the stop checks,
  classifies;
- bare: the same space from the same builder (``ball_model`` / ``rigid_flexible_model`` with
  ``measure=False``: the contact model's own callbacks — penalty force, restitution law,
  structural ``force_func`` — stay, the impulse-reading ``post_solve`` goes), then
  ``space.step(dt)`` n times, nothing read, nothing recorded.

The ratio adapter/bare is the adapter's overhead (target ≤ 1.3×). Run:
``python -m benchmarks bench_engine_pymunk``.
"""

from __future__ import annotations

import statistics
import time

from impactbench.engines import pymunk_adapter as pa
from impactbench.engines.base import RunSettings, get_adapter
from impactbench.reference.scenarios import BallOnPlate, RigidFlexible
from tabulate import tabulate

REPEATS = 15

CASES = (
    ("ball V0=5 injected (penalty) dt=1e-7", BallOnPlate(velocity_m_s=5.0), "injected", 1e-7,
     {}),
    ("ball V0=1 injected (penalty) dt=1e-7", BallOnPlate(velocity_m_s=1.0), "injected", 1e-7,
     {}),
    ("ball V0=5 injected (restitution) dt=1e-7", BallOnPlate(velocity_m_s=5.0), "injected",
     1e-7, {"injection": "restitution"}),
    ("ball V0=1 native dt=1e-7", BallOnPlate(velocity_m_s=1.0), "native", 1e-7, {}),
    ("rf linear/linear injected", RigidFlexible(velocity_m_s=3.3), "injected", 1e-5, {}),
    ("rf elastoplastic/linear injected",
     RigidFlexible(velocity_m_s=3.3, local="elastoplastic"), "injected", 1e-5, {}),
    ("rf mutation/softening injected",
     RigidFlexible(velocity_m_s=3.3, local="mutation", structure="softening"), "injected",
     1e-5, {}),
    ("rf linear/linear native", RigidFlexible(velocity_m_s=3.3), "native", 1e-5, {}),
    ("rf linear/softening native", RigidFlexible(velocity_m_s=3.3, structure="softening"),
     "native", 1e-5, {}),
)


def _bare(scenario, mode: str, settings: RunSettings, steps: int) -> tuple[float, float]:
    """(total wall incl. build, stepping-loop wall) of a bare ``space.step`` loop."""
    build = pa.ball_model if isinstance(scenario, BallOnPlate) else pa.rigid_flexible_model
    dt = float(settings.timestep_s)
    t0 = time.perf_counter()
    model, _ = build(scenario, mode, settings, dt, pa._iterations(settings), measure=False)
    step = model.space.step
    t1 = time.perf_counter()
    for _ in range(steps):
        step(dt)
    t2 = time.perf_counter()
    return t2 - t0, t2 - t1


def measure() -> list[dict]:
    adapter = get_adapter("pymunk")
    rows = []
    for label, scenario, mode, dt, options in CASES:
        settings = RunSettings(timestep_s=dt, options=options)
        rec = adapter.run(scenario, mode, settings)  # warm-up, and the step count
        steps = int(rec.meta["steps"])
        runs, bares, loops = [], [], []
        for _ in range(REPEATS):
            t0 = time.perf_counter()
            adapter.run(scenario, mode, settings)
            runs.append(time.perf_counter() - t0)
            total, loop = _bare(scenario, mode, settings, steps)
            bares.append(total)
            loops.append(loop)
        run_wall, bare_wall, loop_wall = map(statistics.median, (runs, bares, loops))
        rows.append({
            "case": label,
            "status": str(rec.status),
            "steps": steps,
            "adapter_ms": 1e3 * run_wall,
            "bare_ms": 1e3 * bare_wall,
            "ratio": run_wall / bare_wall,
            "bare_us_per_step": 1e6 * loop_wall / max(steps, 1),
        })
    return rows


def main() -> None:
    rows = measure()
    print(f"pymunk {get_adapter('pymunk').version()}: adapter.run vs bare space.step loop "
          f"(alternated, median of {REPEATS}; target ratio ≤ 1.3)")
    print(tabulate(rows, headers="keys", floatfmt=".3f"))


if __name__ == "__main__":
    main()
