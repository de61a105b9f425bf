"""Rigid–flexible 2-DOF reference: the paper's full v1 sweep, fresh through the CLI and by path.

In one run, with the paper's base parameters (MODELS.md §2), the sweep over v1 = 0.1 … 1000
m/s step 0.1 (10,000 points) × the 3 local × 2 structural laws = 60,000 solves with the
compiled kernel of :mod:`impactbench.reference.two_dof_fast` (compiled beforehand and cached
on disk; the one-off compile time is printed apart):

1. fresh through the CLI: ``impactbench sweep rigid-flexible --over velocity --start 0.1
   --stop 1000 --step 0.1 --fresh --store (new file) --out FILE.parquet`` as a fresh process
   (start-up, imports, kernel load, the sweep, the store, the table) against the floor
   process :mod:`benchmarks.floor_two_dof` (the kernel on the same 60,000 points straight
   from arrays, on as many threads, and the table: no scenarios, validation or store). The
   two alternate, ``ROUNDS`` times; printed: their medians, the median per-round ratio and
   the command against its target (≤ 2 s);
2. by path, in this process, alternated over ``PATH_ROUNDS`` rounds (medians):
   :func:`impactbench.reference.two_dof.sweep` (one thread);
   :func:`impactbench.sweeps.rigid_flexible` with its default placement (here, a thread per
   core) and with ``workers = 0`` (this thread), on a fresh local Dask cluster of one worker
   per core (start-up included), the fork pool Dask replaced (kept here only for the
   comparison), and a rerun served from a results store. All must give the same frame;
3. :func:`impactbench.reference.two_dof.solve_slow` — scipy ``solve_ivp`` (DOP853, rtol
   1e-11) per piece with event location, then the shared metrics on the record — on
   ``ODE_POINTS`` rows taken evenly from the same 60,000: its per-point time (alternated
   with the in-process sweep of the same rows, medians) scaled up to 60,000, and the largest
   relative difference on the subsample for each metric (``impacts`` and ``status`` must be
   equal). Targets: differences ≤ 1e-6.

Run: ``python -m benchmarks two_dof``.
"""

from __future__ import annotations

import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd
from impactbench.reference import two_dof, two_dof_fast
from impactbench.reference.scenarios import RigidFlexible
from tabulate import tabulate

from benchmarks.alternate import alternate, median_ratio, process
from impactbench import sweeps
from impactbench.cluster import Runner
from impactbench.store import Store

START, STOP, STEP = 0.1, 1000.0, 0.1
ROUNDS = 5
PATH_ROUNDS = 3
ODE_POINTS = 200
ODE_TIMED = 30
"""Rows per round of the ODE timing (the accuracy check uses all ``ODE_POINTS``)."""
TARGET_S = 2.0
ROOT = Path(__file__).resolve().parents[1]


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


def fresh_cli(tmp: Path) -> dict[str, list[float]]:
    """Wall times (s) of the fresh CLI sweep (a new store each time) and the floor process,
    alternated."""
    runs = iter(range(1 << 30))

    def cli() -> None:
        n = next(runs)
        process([sys.executable, "-m", "impactbench.cli", "sweep", "rigid-flexible", "--over",
                 "velocity", "--start", repr(START), "--stop", repr(STOP), "--step",
                 repr(STEP), "--fresh", "--store", str(tmp / f"s{n}.duckdb"), "--out",
                 str(tmp / "cli.parquet")])()

    return alternate({
        "impactbench sweep rigid-flexible --fresh": cli,
        "floor process (kernel on arrays, Parquet)":
            process([sys.executable, "-m", "benchmarks.floor_two_dof",
                     str(tmp / "floor.parquet")], cwd=str(ROOT)),
    }, ROUNDS)


def by_path(base: RigidFlexible, values: np.ndarray
            ) -> tuple[dict[str, list[float]], dict[str, bool], pd.DataFrame]:
    """Wall times (s) of every path, alternated over ``PATH_ROUNDS`` rounds, whether each
    gave the in-process sweep's frame, and that frame."""
    frames: dict[str, pd.DataFrame] = {}
    with tempfile.TemporaryDirectory() as tmp:
        store = Store(Path(tmp) / "s.duckdb")
        sweeps.rigid_flexible(base, "velocity", values, store=store)  # for the rerun

        def on_dask() -> pd.DataFrame:
            with Runner(min_dispatch_s=0.0) as runner:
                return sweeps.rigid_flexible(base, "velocity", values, runner=runner).frame

        paths = {
            "two_dof.sweep, in this process": lambda: two_dof.sweep(base, "velocity", values),
            "sweeps.rigid_flexible, default placement, no store":
                lambda: sweeps.rigid_flexible(base, "velocity", values).frame,
            "sweeps.rigid_flexible, workers = 0, no store":
                lambda: sweeps.rigid_flexible(base, "velocity", values, workers=0).frame,
            "sweeps.rigid_flexible on Dask (cluster start included)": on_dask,
            "the replaced fork pool": lambda: fork_pool(base, values),
            "rerun served from the store":
                lambda: sweeps.rigid_flexible(base, "velocity", values, store=store).frame,
        }

        def keep(name: str):
            return lambda: frames.__setitem__(name, paths[name]())

        times = alternate({name: keep(name) for name in paths}, PATH_ROUNDS)
    df = frames["two_dof.sweep, in this process"]
    return times, {name: frame.equals(df) for name, frame in frames.items()}, df


def main() -> None:
    t0 = time.perf_counter()
    two_dof_fast.run(RigidFlexible())
    two_dof_fast.run_many(0, np.asarray([two_dof_fast.kernel_params(RigidFlexible())[1]]))
    compile_s = time.perf_counter() - t0
    values = START + STEP * np.arange(round((STOP - START) / STEP) + 1)
    base = RigidFlexible()

    with tempfile.TemporaryDirectory() as tmp:
        fresh = fresh_cli(Path(tmp))
    names = list(fresh)
    cli_s = statistics.median(fresh[names[0]])
    print(f"{len(values) * 6} solves ({len(values)} velocities × 6 law combinations), "
          f"{os.cpu_count()} cores; kernel compile/load {compile_s:.2f} s (once)")
    print(f"fresh processes, alternated, {ROUNDS} rounds:")
    print(tabulate([[name, statistics.median(t), min(t), max(t),
                     median_ratio(t, fresh[names[1]])] for name, t in fresh.items()],
                   headers=["process", "median wall s", "min", "max", "÷ floor (median)"],
                   floatfmt=".2f"))
    print(f"fresh CLI sweep: {cli_s:.2f} s (target <= {TARGET_S:g} s: "
          + ("yes" if cli_s <= TARGET_S else "NO") + f"), "
          f"{median_ratio(fresh[names[0]], fresh[names[1]]):.2f}× the floor process")

    times, same, df = by_path(base, values)
    n = len(df)
    sweep_s = statistics.median(times["two_dof.sweep, in this process"])
    rows = np.linspace(0, n - 1, ODE_POINTS).round().astype(int)
    scenarios = [base.replace(velocity_m_s=float(df.iloc[i]["velocity_m_s"]),
                              local=df.iloc[i]["local"], structure=df.iloc[i]["structure"])
                 for i in rows]
    timed = scenarios[::max(1, ODE_POINTS // ODE_TIMED)][:ODE_TIMED]
    each = alternate({"ode": lambda: [two_dof.solve_slow(sc) for sc in timed],
                      "kernel": lambda: [two_dof.solve(sc) for sc in timed]}, PATH_ROUNDS)
    ode_each = statistics.median(each["ode"]) / len(timed)
    print(f"\nby path, in this process, alternated, {PATH_ROUNDS} rounds (medians):")
    print(tabulate([[label, f"{statistics.median(t):.2f}",
                     f"{statistics.median(t) / n * 1e6:.1f}",
                     f"{median_ratio(t, times['two_dof.sweep, in this process']):.2f}",
                     "yes" if same[label] else "NO"] for label, t in times.items()]
                   + [[f"solve_ivp per point ({len(timed)} rows, scaled)",
                       f"{ode_each * n:.0f}", f"{ode_each * 1e6:.0f}",
                       f"{ode_each * n / sweep_s:.0f}", ""]],
                   headers=["path", "wall s (60,000)", "µs / solve", "÷ in-process",
                            "same frame"]))

    diffs = dict.fromkeys(two_dof.METRIC_KEYS, 0.0)
    mismatched = 0
    for i, sc in zip(rows, scenarios, strict=True):
        r = df.iloc[i]
        slow = two_dof.solve_slow(sc)
        mismatched += int(slow["status"] != r["status"] or slow["impacts"] != r["impacts"])
        for k in two_dof.METRIC_KEYS:
            diffs[k] = max(diffs[k], abs(r[k] - slow[k]) / abs(slow[k]))
    print(tabulate([[k, f"{v:.2e}", "yes" if v <= 1e-6 else "NO"] for k, v in diffs.items()],
                   headers=["metric", "max rel diff (subsample)", "≤ 1e-6"]))
    print(f"status or impact-count mismatches on the subsample: {mismatched}")
    counts = df["status"].value_counts().to_dict()
    print("statuses of the sweep: " + ", ".join(f"{k} {v}" for k, v in sorted(counts.items())))


if __name__ == "__main__":
    main()
