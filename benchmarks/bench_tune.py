"""Tuning cost per engine: one objective evaluation, its overhead, and a full default tuning.

For each installed engine, on the paper's ball at the six velocities 0.5–5 m/s (the packaged
defaults' objective):

- ``eval_ms``: one objective evaluation (six engine runs + metrics + residuals), best of
  ``REPEATS`` (the machine is shared; the minimum is the least noisy estimate);
- ``runs_ms``: the same six ``run_safely`` calls alone, best of ``REPEATS``; the ratio
  eval/runs is the objective's own overhead, the shared metrics path (~0.05 ms per run):
  ≈ 1 where an impact costs milliseconds (MuJoCo, PyBullet, Drake), ~1.5 for pymunk's
  0.1 ms rigid impacts, where it does not matter for the wall time;
- ``tune_s`` and ``evaluations``: a full default tuning in this process
  (``impactbench tune --engine E --workers 0``);
- ``dask_s``: the same tuning with every batch of runs on a fresh local Dask cluster of one
  worker per core (cluster start-up included); ``auto_s``: as ``impactbench tune`` runs it,
  batches estimated under ``DISPATCH_MIN_S`` kept in this process; their ratios to
  ``tune_s``, and ``same``: whether all three found the same parameters (they must: the
  search is the same). Dask pays where a batch costs more than a cluster start and a round
  trip (~10–30 ms on 2 cores): the Sobol scan's slices and each Jacobian's points run at once.
  Two rows at dt = 1e-7 s (runs ten times longer), cut at ``FINE_EVALS`` evaluations.

Run: ``python -m benchmarks tune`` (or this file directly).

``python benchmarks/bench_tune.py cube`` measures the cube-toss fit's batches instead: one CMA-
ES generation of PyBullet candidates (popsize 5) on the first ``CUBE_TOSSES`` training tosses,
evaluated (after a warm-up run) (a) one candidate at a time straight through ``compare`` (no
store, no run matrix), (b) as the tuner hands it over, one ``run_jobs`` batch in this process
with a results store, (c) the same batch on ``CUBE_WORKERS`` local Dask workers (cluster start
included); ``same`` says whether all three give the same objectives (they must).
"""

from __future__ import annotations

import time

import numpy as np
from impactbench.engines.base import available_engines, run_safely
from impactbench.reference.scenarios import PAPER_VELOCITIES_M_S, BallOnPlate

from impactbench.api import TUNE_DISPATCH_MIN_S as DISPATCH_MIN_S
from impactbench.cluster import Runner
from impactbench.tuning import Objective, make_space, parse_weights, tune
from impactbench.tuning.names import VARIANTS

REPEATS = 5
FINE_EVALS = 60
CUBE_TOSSES = 40
CUBE_WORKERS = 2


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
    engines = [e for e in available_engines() if e in VARIANTS]  # the tunable ones
    cases = [(e, None, None) for e in engines]
    cases += [(e, 1e-7, FINE_EVALS) for e in ("mujoco", "pybullet") if e in engines]
    for engine, dt, max_evals in cases:
        space = make_space(engine, s, timestep_s=dt)
        weights = parse_weights(None, None)
        weights = {k: (w if k in space.expressible else 0.0) for k, w in weights.items()}
        obj = Objective(space, s, PAPER_VELOCITIES_M_S, weights, dt)
        x0 = np.asarray(space.start)
        obj.evaluate(x0, count_budget=False)  # warm-up: imports, caches

        def runs(space=space, x0=x0, dt=dt) -> None:
            for v in PAPER_VELOCITIES_M_S:
                run_safely(space.engine, *space.run(x0, s.replace(velocity_m_s=v), dt))

        eval_s = _best(lambda obj=obj, x0=x0: obj.evaluate(x0, count_budget=False))
        runs_s = _best(runs)
        walls, found = [], []
        for min_dispatch_s in (None, 0.0, DISPATCH_MIN_S):
            t0 = time.perf_counter()
            with Runner(0 if min_dispatch_s is None else None,
                        min_dispatch_s=min_dispatch_s or 0.0) as runner:
                res = tune(engine, s, timestep_s=dt, max_evals=max_evals, runner=runner)
            walls.append(time.perf_counter() - t0)
            found.append(res.parameters)
        here_s, dask_s, auto_s = walls
        rows.append([engine, f"{dt or space_dt(engine):g}", 1e3 * eval_s, 1e3 * runs_s,
                     eval_s / runs_s, here_s, dask_s, dask_s / here_s, auto_s,
                     auto_s / here_s, found[0] == found[1] == found[2],
                     res.objective.evaluations, res.stop])
    print(tabulate(rows, headers=["engine", "dt_s", "eval_ms", "runs_ms", "ratio", "tune_s",
                                  "dask_s", "dask/here", "auto_s", "auto/here", "same",
                                  "evaluations", "stop"], floatfmt=".3g"))


def space_dt(engine: str) -> float:
    from impactbench.engines.base import get_adapter

    return get_adapter(engine).default_timestep_s(BallOnPlate(), "tuned")


def cube() -> None:
    """The cube-toss fit's batch paths (module doc)."""
    import tempfile
    from pathlib import Path

    import nevergrad as ng
    from tabulate import tabulate

    import impactbench.cube_tosses.tune as tune_mod
    from impactbench.cube_tosses import load, split
    from impactbench.evaluate import compare
    from impactbench.store import Store
    from impactbench.tuning import search

    engine = "pybullet"
    ids = split(load()["toss"].unique(), "train")[:CUBE_TOSSES]
    scenario = tune_mod.scenario_of(None, ids)
    knobs = tune_mod.space(engine)
    opt = ng.optimizers.registry["CMA"](parametrization=search.parametrization(
        knobs, tune_mod.SEED), budget=20, num_workers=1)
    first = [opt.ask()]
    generation = first + [opt.ask() for _ in range(search.generation_left(opt))]
    params = [tune_mod.engine_params(engine, tune_mod._plain(c.value)) for c in generation]
    from impactbench.engines.base import RunSettings

    compare(engine, scenario, "custom", RunSettings(params=params[0]))  # warm-up: imports, data
    rows, objectives = [], []
    t0 = time.perf_counter()

    direct = [tune_mod.evaluation_of(compare(engine, scenario, "custom",
                                             RunSettings(params=p))[0], ids).objective
              for p in params]
    rows.append(["one by one, compare", time.perf_counter() - t0])
    objectives.append(direct)
    with tempfile.TemporaryDirectory() as folder:
        for label, workers in (("one run_jobs batch, here", 0),
                               (f"one run_jobs batch, {CUBE_WORKERS} Dask workers",
                                CUBE_WORKERS)):
            store = Store(Path(folder) / f"{workers}.duckdb")
            t0 = time.perf_counter()
            runs = tune_mod.replay_runs(engine, scenario, params, store=store, workers=workers)
            rows.append([label, time.perf_counter() - t0])
            objectives.append([tune_mod.evaluation_of(r, ids).objective for r, _ in runs])
    same = objectives[0] == objectives[1] == objectives[2]
    print(f"{engine}: {len(params)} candidates x {len(ids)} tosses; same = {same}")
    print(tabulate(rows, headers=["path", "wall_s"], floatfmt=".3g"))


if __name__ == "__main__":
    import sys

    cube() if sys.argv[1:] == ["cube"] else main()
