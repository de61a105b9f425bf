"""Drake adapter overhead: ``DrakeAdapter.run`` against a bare stepping loop of the same diagram.

For each case the adapter runs once to learn its step count n; then several repeats of:

- adapter: ``adapter.run(scenario, mode, settings)`` — builds the diagram (and, for the native
  ball, solves the two reference problems of the stiffness mapping), steps with the recording
  monitor, classifies;
- bare: ``adapter.build(...)`` (the same diagram), then ``simulator.AdvanceTo(t_k)`` for
  k = 1…n, no monitor, no recording.

Adapter and bare runs alternate, and each reports its median (see ``MIN_SECONDS``): the
machine is shared, and a best-of would reward each side's luckiest run.

The ratio adapter/bare is the adapter's overhead (target ≤ 1.3×). Also printed: the stepping
part alone (bare loop) per step. Run: ``python -m benchmarks bench_engine_drake``.
"""

from __future__ import annotations

import math
import statistics
import time

from impactbench.engines.base import RunSettings, get_adapter
from tabulate import tabulate

from benchmarks.overhead import CASES

REPEATS = 5
MIN_SECONDS = 1.0
"""Each case repeats at least ``REPEATS`` times and at least ``MIN_SECONDS`` of adapter time;
the median over the alternated repeats is robust to the other processes on this 2-core
machine without crediting either side with its luckiest run."""



def _bare(adapter, scenario, mode: str, settings: RunSettings, steps: int) -> tuple[float, float]:
    """(total wall incl. build, stepping-loop wall) of a bare AdvanceTo loop."""
    t0 = time.perf_counter()
    model = adapter.build(scenario, mode, settings)
    model.reset()
    sim, dt = model.simulator, model.timestep_s
    t1 = time.perf_counter()
    for k in range(1, steps + 1):
        sim.AdvanceTo(k * dt)
    t2 = time.perf_counter()
    return t2 - t0, t2 - t1


def measure() -> list[dict]:
    adapter = get_adapter("drake")
    rows = []
    for label, scenario, mode, dt in CASES:  # interleaved repeats share the noise
        settings = RunSettings(timestep_s=dt)
        adapter.run(scenario, mode, settings)  # warm-up (imports, caches)
        rec = adapter.run(scenario, mode, settings)  # the step count and a typical wall time
        steps = len(rec) - 1
        repeats = max(REPEATS, math.ceil(MIN_SECONDS / rec.meta["wall_s"]))
        runs, bares, loops = [], [], []
        for _ in range(repeats):  # alternated: a pair sees the same load; medians
            t0 = time.perf_counter()
            adapter.run(scenario, mode, settings)
            runs.append(time.perf_counter() - t0)
            total, loop = _bare(adapter, scenario, mode, settings, steps)
            bares.append(total)
            loops.append(loop)
        run_wall, bare_wall, loop_wall = map(statistics.median, (runs, bares, loops))
        rows.append({"case": label, "status": str(rec.status), "steps": steps, "repeats": repeats,
                     "adapter_s": run_wall, "bare_s": bare_wall, "ratio": run_wall / bare_wall,
                     "bare_loop_us_per_step": 1e6 * loop_wall / steps})
    return rows


def main() -> None:
    rows = measure()
    print("Drake adapter vs bare AdvanceTo loop (same diagram, same step count; alternated, "
          "median of the repeats; both include building the diagram)")
    print(tabulate(rows, headers="keys", floatfmt=".4g"))
    worst = max(r["ratio"] for r in rows)
    print(f"worst overhead ratio: {worst:.2f}x (target <= 1.3x)")


if __name__ == "__main__":
    main()
