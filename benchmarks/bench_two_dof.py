"""Rigid–flexible 2-DOF reference: the paper's full v1 sweep against per-point solve_ivp.

In one run, with the paper's base parameters (MODELS.md §2):

1. the sweep over v1 = 0.1 … 1000 m/s step 0.1 (10,000 points) × the 3 local × 2 structural
   laws = 60,000 solves with the compiled kernel of
   :mod:`impactbench.reference.two_dof_fast` (compiled beforehand and cached on disk; the
   one-off compile time is printed apart), side by side: in this process
   (:func:`impactbench.reference.two_dof.sweep`); through
   :func:`impactbench.sweeps.rigid_flexible` on a fresh local Dask cluster of one worker per
   core (start-up included; its default would keep a sweep this short in process); the same
   with its default placement; the fork pool it replaced (kept here only for the
   comparison); and a rerun served from a results store. All must give the same frame;
2. :func:`impactbench.reference.two_dof.solve_slow` — scipy ``solve_ivp`` (DOP853, rtol 1e-11) per
   piece
   with event location, then the shared metrics on the record — on ``ODE_POINTS`` rows taken
   evenly from the same 60,000, timed per point and scaled up to 60,000.

Printed: the wall times and their ratios to the in-process sweep, the ODE path's time, and
the largest relative difference on the subsample for each metric (``impacts`` and ``status``
must be equal). Targets: 60,000 solves ≤ 10 s on 2 cores; differences ≤ 1e-6.
Run: ``python -m benchmarks two_dof``.
"""

from __future__ import annotations

import os
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd
from impactbench.reference import two_dof, two_dof_fast
from impactbench.reference.scenarios import RigidFlexible
from tabulate import tabulate

from impactbench import sweeps
from impactbench.cluster import Runner
from impactbench.store import Store

START, STOP, STEP = 0.1, 1000.0, 0.1
ODE_POINTS = 200
TARGET_S = 10.0


def fork_pool(base: RigidFlexible, values: np.ndarray) -> pd.DataFrame:
    """The sweep's previous parallel path: a fork pool over the solver's chunks (no crash
    isolation, no store, no user cluster), for the comparison only."""
    import multiprocessing as mp

    tasks = two_dof.sweep_tasks(base, "velocity", values)
    rows: list[dict] = []
    with mp.get_context("fork").Pool(os.cpu_count() or 1) as pool:
        for part in pool.imap(two_dof.sweep_chunk, tasks):
            rows.extend(part)
    return pd.DataFrame(rows, columns=two_dof.sweep_columns("velocity"))


def main() -> None:
    t0 = time.perf_counter()
    two_dof_fast.run(RigidFlexible())
    compile_s = time.perf_counter() - t0
    values = START + STEP * np.arange(round((STOP - START) / STEP) + 1)
    base = RigidFlexible()
    timings: list[tuple[str, float, bool]] = []

    def timed(label: str, fn) -> pd.DataFrame:
        t0 = time.perf_counter()
        frame = fn()
        timings.append((label, time.perf_counter() - t0, frame.equals(df) if timings else True))
        return frame

    df = timed("two_dof.sweep, in this process", lambda: two_dof.sweep(base, "velocity", values))
    with tempfile.TemporaryDirectory() as tmp:
        store = Store(Path(tmp) / "s.duckdb")

        def on_dask() -> pd.DataFrame:
            with Runner(min_dispatch_s=0.0) as runner:
                return sweeps.rigid_flexible(base, "velocity", values, store=store,
                                             runner=runner).frame

        timed("sweeps.rigid_flexible on Dask (cluster start included)", on_dask)
        timed("sweeps.rigid_flexible, default placement, no store",
              lambda: sweeps.rigid_flexible(base, "velocity", values).frame)
        timed("the replaced fork pool", lambda: fork_pool(base, values))
        timed("rerun served from the store",
              lambda: sweeps.rigid_flexible(base, "velocity", values, store=store).frame)
    sweep_s = timings[0][1]
    n = len(df)

    rows = np.linspace(0, n - 1, ODE_POINTS).round().astype(int)
    diffs = dict.fromkeys(two_dof.METRIC_KEYS, 0.0)
    mismatched = 0
    t0 = time.perf_counter()
    for i in rows:
        r = df.iloc[i]
        sc = base.replace(velocity_m_s=float(r["velocity_m_s"]), local=r["local"],
                          structure=r["structure"])
        slow = two_dof.solve_slow(sc)
        mismatched += int(slow["status"] != r["status"] or slow["impacts"] != r["impacts"])
        for k in two_dof.METRIC_KEYS:
            diffs[k] = max(diffs[k], abs(r[k] - slow[k]) / abs(slow[k]))
    ode_each = (time.perf_counter() - t0) / ODE_POINTS
    ode_total = ode_each * n

    print(f"{n} solves ({len(values)} velocities × 6 law combinations), "
          f"{os.cpu_count()} cores; kernel compile/load {compile_s:.2f} s (once)")
    print(tabulate([[label, f"{wall:.2f}", f"{wall / n * 1e6:.1f}", f"{wall / sweep_s:.2f}",
                     "yes" if same else "NO"] for label, wall, same in timings]
                   + [[f"solve_ivp per point ({ODE_POINTS} rows, scaled)", f"{ode_total:.0f}",
                       f"{ode_each * 1e6:.0f}", f"{ode_total / sweep_s:.0f}", ""]],
                   headers=["path", "wall s (60,000)", "µs / solve", "÷ in-process",
                            "same frame"]))
    best = min(wall for label, wall, _ in timings[:4])
    print(f"fastest way to solve them: {best:.2f} s; ≤ {TARGET_S:g} s: "
          + ("yes" if best <= TARGET_S else "NO"))
    print(tabulate([[k, f"{v:.2e}", "yes" if v <= 1e-6 else "NO"] for k, v in diffs.items()],
                   headers=["metric", "max rel diff (subsample)", "≤ 1e-6"]))
    print(f"status or impact-count mismatches on the subsample: {mismatched}")
    counts = df["status"].value_counts().to_dict()
    print("statuses of the sweep: " + ", ".join(f"{k} {v}" for k, v in sorted(counts.items())))


if __name__ == "__main__":
    main()
