"""The results store and Dask: what a cached rerun costs, and what Dask costs over a plain pool.

On the default report (``impactbench/data/default.toml``, every installed engine), one run:

1. ``fresh``: ``report.build`` with an empty store (every run executes and is stored);
   ``cached rerun``: the same report again into the same folder (every run served by the
   store; the inputs of the rendering are unchanged, so the rendered files are kept and only
   metadata.json is written). Target: ≤ 10 % of fresh. Also printed: the same cached runs
   rendered into a new folder (store lookups + every plot and page: the rendering's own cost).
2. ``dask_s``: the default matrix through :func:`impactbench.matrix.run_jobs` (a fresh local
   Dask cluster, no store); ``pool_s``: the same jobs through the hand-written pool that
   ``run_jobs`` replaced (a ``ProcessPoolExecutor`` of spawned workers, kept only here for the
   comparison; it has no crash retry). Target: Dask ≤ 1.2 × the pool.

Both pools get the same number of workers (one per core) and both pay their start-up.
Run: ``python -m benchmarks store``.
"""

from __future__ import annotations

import os
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from multiprocessing import get_context
from pathlib import Path

from impactbench import config, report
from impactbench.evaluate import reference_metrics
from impactbench.matrix import Job, execute, plan, run_jobs
from impactbench.store import Store


def old_pool(jobs: list[Job], workers: int) -> int:
    """The pre-Dask execution: spawned ProcessPoolExecutor, results as they complete."""
    refs = {}
    for job in jobs:
        if job.reference_key not in refs:
            refs[job.reference_key] = reference_metrics(job.build_scenario())
    pending = sorted(jobs, key=lambda j: (j.scenario != "rigid-flexible", j.id))
    done = 0
    with ProcessPoolExecutor(max_workers=workers, mp_context=get_context("spawn")) as pool:
        futures = [pool.submit(execute, j, refs[j.reference_key]) for j in pending]
        for fut in as_completed(futures):
            fut.result()
            done += 1
    return done


def json_runs_stored(out: Path) -> list[bool]:
    import json

    return [r["stored"] for r in json.loads((out / "metadata.json").read_text())["runs"]]


def main() -> None:
    cfg = config.load()
    workers = os.cpu_count() or 1
    jobs = plan(cfg)
    print(f"default report: {len(jobs)} runs, {workers} workers")
    with tempfile.TemporaryDirectory() as tmp:
        store = Store(Path(tmp) / "store.duckdb")
        t0 = time.perf_counter()
        report.build(cfg, Path(tmp) / "fresh", show_progress=False, store=store)
        fresh = time.perf_counter() - t0
        t0 = time.perf_counter()
        rep = report.build(cfg, Path(tmp) / "fresh", show_progress=False, store=store)
        cached = time.perf_counter() - t0
        assert all(json_runs_stored(Path(tmp) / "fresh"))
        t0 = time.perf_counter()
        rep = report.build(cfg, Path(tmp) / "new", show_progress=False, store=store)
        rendered = time.perf_counter() - t0
        assert len(rep.results)
        print(f"fresh report                  {fresh:8.2f} s\n"
              f"cached rerun (same folder)    {cached:8.2f} s\n"
              f"cached runs, new folder       {rendered:8.2f} s  (rendering every plot/page)\n"
              f"cached rerun / fresh = {cached / fresh:.3f}  (target <= 0.10); "
              f"new folder / fresh = {rendered / fresh:.3f}")

    t0 = time.perf_counter()
    run_jobs(jobs, workers=workers)
    dask = time.perf_counter() - t0
    t0 = time.perf_counter()
    old_pool(jobs, workers)
    pool = time.perf_counter() - t0
    print(f"matrix on Dask     {dask:8.2f} s\nmatrix on the pool {pool:8.2f} s\n"
          f"Dask / pool = {dask / pool:.3f}  (target <= 1.2)")


if __name__ == "__main__":
    main()
