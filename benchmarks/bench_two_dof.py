"""Rigid–flexible 2-DOF reference: the paper's full v1 sweep against per-point solve_ivp.

In one run, with the paper's base parameters (MODELS.md §2):

1. :func:`impactbench.reference.two_dof.sweep` over v1 = 0.1 … 1000 m/s step 0.1 (10,000 points) ×
   the
   3 local × 2 structural laws = 60,000 solves, in parallel over all cores (the compiled
   kernel of :mod:`impactbench.reference.two_dof_fast`, compiled beforehand and cached on disk; the
   one-off compile time is printed apart);
2. :func:`impactbench.reference.two_dof.solve_slow` — scipy ``solve_ivp`` (DOP853, rtol 1e-11) per
   piece
   with event location, then the shared metrics on the record — on ``ODE_POINTS`` rows taken
   evenly from the same 60,000, timed per point and scaled up to 60,000.

Printed: both wall times, their ratio, and the largest relative difference on the subsample
for each metric (``impacts`` and ``status`` must be equal). Targets: 60,000 solves ≤ 10 s on
2 cores; differences ≤ 1e-6. Run: ``python -m benchmarks two_dof``.
"""

from __future__ import annotations

import os
import time

import numpy as np
from impactbench.reference import two_dof, two_dof_fast
from impactbench.reference.scenarios import RigidFlexible
from tabulate import tabulate

START, STOP, STEP = 0.1, 1000.0, 0.1
ODE_POINTS = 200
TARGET_S = 10.0


def main() -> None:
    t0 = time.perf_counter()
    two_dof_fast.run(RigidFlexible())
    compile_s = time.perf_counter() - t0
    values = START + STEP * np.arange(round((STOP - START) / STEP) + 1)
    base = RigidFlexible()
    t0 = time.perf_counter()
    df = two_dof.sweep(base, "velocity", values)
    sweep_s = time.perf_counter() - t0
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
    print(tabulate([
        ["two_dof.sweep (compiled kernel, parallel)", f"{sweep_s:.2f}", f"{sweep_s / n * 1e6:.1f}",
         "≤ 10 s: " + ("yes" if sweep_s <= TARGET_S else "NO")],
        [f"solve_ivp per point ({ODE_POINTS} rows, scaled)", f"{ode_total:.0f}",
         f"{ode_each * 1e6:.0f}", ""],
        ["ratio", f"{ode_total / sweep_s:.0f}×", "", ""],
    ], headers=["path", "wall s (60,000)", "µs / solve", "target"]))
    print(tabulate([[k, f"{v:.2e}", "yes" if v <= 1e-6 else "NO"] for k, v in diffs.items()],
                   headers=["metric", "max rel diff (subsample)", "≤ 1e-6"]))
    print(f"status or impact-count mismatches on the subsample: {mismatched}")
    counts = df["status"].value_counts().to_dict()
    print("statuses of the sweep: " + ", ".join(f"{k} {v}" for k, v in sorted(counts.items())))


if __name__ == "__main__":
    main()
