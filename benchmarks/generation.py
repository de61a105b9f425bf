"""A tuner's generation through one adapter: :meth:`Adapter.run_many` (the engine's batch:
MJX one ``vmap`` over worlds, Newton one model with a world per run) against one
:meth:`Adapter.run` after another, alternated (medians). The records are checked equal bit
for bit first. Used by :mod:`benchmarks.bench_engine_mjx` and
:mod:`benchmarks.bench_engine_newton`."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from impactbench.engines.base import RunSettings, get_adapter
from impactbench.reference.scenarios import BallOnPlate

from benchmarks.alternate import median_pair

VELOCITIES_M_S = (0.5, 1.0, 3.0)


def generation(engine: str, candidates: Sequence[Mapping[str, Any]], repeats: int) -> None:
    """Print run_many's and one-by-one's medians for ``candidates`` (tuned parameter sets)
    × :data:`VELOCITIES_M_S`, at the adapter's default step, and their ratio."""
    adapter = get_adapter(engine)
    items = [(BallOnPlate(velocity_m_s=v), "tuned", RunSettings(tuned=dict(c)))
             for v in VELOCITIES_M_S for c in candidates]
    many = adapter.run_many(items)  # warm-up (compiles the batch's size once)
    alone = [adapter.run(*item) for item in items]
    assert all(np.array_equal(a.normal_force_n, b.normal_force_n) and a.status == b.status
               for a, b in zip(alone, many, strict=True))
    t_many, t_alone = median_pair(lambda: adapter.run_many(items),
                                  lambda: [adapter.run(*item) for item in items], repeats)
    print(f"\nGeneration: {len(items)} tuned {engine} runs ({len(candidates)} parameter sets × "
          f"{len(VELOCITIES_M_S)} velocities, the adapter's default step; alternated, median "
          f"of {repeats})")
    print(f"run_many (one call)  {t_many * 1e3:9.1f} ms")
    print(f"run one by one       {t_alone * 1e3:9.1f} ms")
    print(f"ratio one-by-one/run_many: {t_alone / t_many:.2f}")
