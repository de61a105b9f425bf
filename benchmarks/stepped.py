"""Adapter overhead for the engines run by :mod:`impactbench.engines.stepping` (SAPIEN/PhysX,
DART, Box2D): ``adapter.run`` against a bare stepping loop over the same model.

For each case of :data:`benchmarks.overhead.CASES` (plus the ball in default mode) the adapter
runs once to learn its step count n; then, alternately, ``REPEATS`` rounds of the two
(medians: the machine is shared, a best-of rewards the luckiest run):

- adapter: ``adapter.run(scenario, mode, settings)`` — reads the engine defaults, maps the
  parameters, builds the model, steps it reading state and contact force every step, records,
  classifies;
- bare: the same model built by the adapter's own ``BallModel``/``PairModel`` from the same
  parameters, then n calls of its ``advance()``: the forces that are part of the model (the
  injected law in injected mode — that force *is* the contact model there, as in the pymunk
  benchmark's bare loop — and the softening structure's cubic term) and the engine's step;
  no state or contact read, nothing recorded.

The ratio adapter/bare is the adapter's overhead (target ≤ 1.3×).
"""

from __future__ import annotations

import statistics
import time
from types import ModuleType
from typing import Any

from impactbench.engines.base import RunSettings, get_adapter
from impactbench.reference.scenarios import BallOnPlate
from tabulate import tabulate

from benchmarks.overhead import CASES

REPEATS = 7

EXTRA_CASES = (
    ("ball V0=1 default dt=1e-6", BallOnPlate(velocity_m_s=1.0), "default", 1e-6),
    ("ball V0=5 native dt=1e-7", BallOnPlate(velocity_m_s=5.0), "native", 1e-7),
)


def _bare(module: ModuleType, scenario: Any, mode: str, settings: RunSettings,
          steps: int) -> None:
    ball = isinstance(scenario, BallOnPlate)
    params, _ = module.parameters(scenario, mode, settings, ball)
    dt = float(settings.timestep_s)
    law = None
    if mode == "injected":
        law = scenario.law() if ball else scenario.local_law()
    model = (module.BallModel if ball else module.PairModel)(scenario, params, dt, law)
    advance = model.advance
    for _ in range(steps):
        advance()


def measure(engine: str, module: ModuleType) -> list[dict[str, Any]]:
    """One row per case: steps, adapter and bare wall times (ms), their ratio, µs per step."""
    adapter = get_adapter(engine)
    rows = []
    for label, scenario, mode, dt in CASES + EXTRA_CASES:
        settings = RunSettings(timestep_s=dt)
        rec = adapter.run(scenario, mode, settings)  # warm-up, and the step count
        steps = int(rec.meta["steps"])
        runs, bares = [], []
        for _ in range(REPEATS):
            t0 = time.perf_counter()
            adapter.run(scenario, mode, settings)
            t1 = time.perf_counter()
            _bare(module, scenario, mode, settings, steps)
            t2 = time.perf_counter()
            runs.append(t1 - t0)
            bares.append(t2 - t1)
        med_run, med_bare = statistics.median(runs), statistics.median(bares)
        rows.append({"case": label, "status": str(rec.status), "steps": steps,
                     "adapter_ms": 1e3 * med_run, "bare_ms": 1e3 * med_bare,
                     "ratio": med_run / med_bare,
                     "adapter_us_per_step": 1e6 * med_run / max(steps, 1)})
    return rows


def main(engine: str, module: ModuleType) -> None:
    rows = measure(engine, module)
    print(f"{engine} {get_adapter(engine).version()}: adapter.run vs bare stepping loop "
          f"(alternated, median of {REPEATS}; target ratio ≤ 1.3)")
    print(tabulate(rows, headers="keys", floatfmt=".3f"))
