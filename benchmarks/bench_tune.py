"""Tuning cost per engine: one objective evaluation, its overhead, and a full default tuning.

For each installed engine, on the paper's ball at the six velocities 0.5–5 m/s (the packaged
defaults' objective):

- ``eval_ms``: one objective evaluation (six engine runs + metrics + residuals), best of
  ``REPEATS`` (the machine is shared; the minimum is the least noisy estimate);
- ``runs_ms``: the same six ``run_safely`` calls alone, best of ``REPEATS``; the ratio
  eval/runs is the objective's own overhead, the shared metrics path (~0.05 ms per run):
  ≈ 1 where an impact costs milliseconds (MuJoCo, PyBullet, Drake), ~1.5 for pymunk's
  0.1 ms rigid impacts, where it does not matter for the wall time;
- ``tune_s`` and ``evaluations``: a full default tuning (``impactbench tune --engine E``).

Run: ``python -m benchmarks tune`` (or this file directly).
"""

from __future__ import annotations

import time

import numpy as np
from impactbench.engines.base import available_engines, run_safely
from impactbench.reference.scenarios import PAPER_VELOCITIES_M_S, BallOnPlate

from impactbench.tuning import Objective, make_space, parse_weights, tune

REPEATS = 5


def _best(fn, repeats: int = REPEATS) -> float:
    best = float("inf")
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def main() -> None:
    from tabulate import tabulate

    s = BallOnPlate()
    rows = []
    for engine in available_engines():
        space = make_space(engine, s)
        weights = parse_weights(None, None)
        weights = {k: (w if k in space.expressible else 0.0) for k, w in weights.items()}
        obj = Objective(space, s, PAPER_VELOCITIES_M_S, weights)
        x0 = np.asarray(space.start)
        obj.evaluate(x0, count_budget=False)  # warm-up: imports, caches

        def runs(space=space, x0=x0) -> None:
            for v in PAPER_VELOCITIES_M_S:
                run_safely(space.engine, *space.run(x0, s.replace(velocity_m_s=v), None))

        eval_s = _best(lambda obj=obj, x0=x0: obj.evaluate(x0, count_budget=False))
        runs_s = _best(runs)
        t0 = time.perf_counter()
        res = tune(engine, s)
        rows.append([engine, space.variant, 1e3 * eval_s, 1e3 * runs_s, eval_s / runs_s,
                     time.perf_counter() - t0, res.objective.evaluations, res.stop])
    print(tabulate(rows, headers=["engine", "parameters", "eval_ms", "runs_ms", "ratio",
                                  "tune_s", "evaluations", "stop"], floatfmt=".3g"))


if __name__ == "__main__":
    main()
