"""Vectorised Hunt–Crossley reference against per-velocity ODE integration.

In one run, on the paper's ball (m = 0.1 kg, c = 1.7135e10 N/m^1.5, n = 1.5, b = 0.1 s/m):

1. the command ``impactbench sweep ball-on-plate --over velocity --start 0.01 --stop 10.00999
   --step 1e-5 --out FILE.parquet`` (10⁶ velocities, α from 1e-3 to 1) as a subprocess: wall
   time including interpreter start-up, imports and writing the table;
2. ``solve_ivp`` (DOP853, rtol 1e-10) per velocity on ``ODE_POINTS`` velocities taken evenly
   from the same grid, timed per point;
3. the vectorised :func:`impactbench.reference.hunt_crossley.sweep` on those same velocities, in
   process.

Printed: both per-velocity costs, their ratio, velocities per second of the command, and the
largest relative difference between the sweep file's rows and the ODE on every metric. The
ODE's own error is part of that difference (its k is good to ~rtol absolute, so 1 − k² ≈ 4α/3
is good only to ~rtol/α relative): the worst point of each metric is re-integrated at
rtol 1e-13 to show which side the difference belongs to.
Targets: ≥ 1e5 velocities/s, ≥ 300× the per-point ODE, agreement ≤ 1e-8.
Run: ``python -m benchmarks reference_ball``.
"""

from __future__ import annotations

import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd
from impactbench.reference import hunt_crossley as hc
from impactbench.reference.metrics import BALL_METRICS
from impactbench.reference.scenarios import BallOnPlate
from tabulate import tabulate

START, STOP, STEP = 0.01, 10.00999, 1e-5
ODE_POINTS = 200
ODE_RTOL = 1e-10


def run_command(out: Path) -> float:
    """Wall time (s) of the sweep command as a fresh process."""
    cmd = [sys.executable, "-m", "impactbench.cli", "sweep", "ball-on-plate", "--over",
           "velocity", "--start", repr(START), "--stop", repr(STOP), "--step", repr(STEP),
           "--out", str(out)]
    tic = time.perf_counter()
    subprocess.run(cmd, check=True, capture_output=True)
    return time.perf_counter() - tic


def measure() -> dict[str, float]:
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "sweep.parquet"
        wall_cmd = run_command(out)
        table = pd.read_parquet(out)
    rows = len(table)
    pick = np.linspace(0, rows - 1, ODE_POINTS).round().astype(int)
    velocities = table["velocity_m_s"].to_numpy()[pick]
    law = BallOnPlate().law()
    tic = time.perf_counter()
    ode = [hc.solve_ode(law, 0.1, float(v), rtol=ODE_RTOL) for v in velocities]
    wall_ode = time.perf_counter() - tic
    tic = time.perf_counter()
    same = hc.sweep(velocities)
    wall_same = time.perf_counter() - tic
    worst, recheck = {}, {}
    for key in BALL_METRICS:
        errs = [abs(table[key].iloc[i] - o[key]) / abs(o[key])
                for i, o in zip(pick, ode, strict=True)]
        j = int(np.argmax(errs))
        worst[key] = errs[j]
        tight = hc.solve_ode(law, 0.1, float(velocities[j]), rtol=1e-13)[key]
        recheck[key] = abs(table[key].iloc[pick[j]] - tight) / abs(tight)
    return {
        "rows": rows, "wall_cmd_s": wall_cmd, "wall_ode_s": wall_ode,
        "wall_same_s": wall_same, "per_point_cmd_s": wall_cmd / rows,
        "per_point_ode_s": wall_ode / ODE_POINTS, "worst": worst, "recheck": recheck,
        "same_vs_file": float(np.max(np.abs(same[list(BALL_METRICS)].to_numpy()
                                            / table[list(BALL_METRICS)].to_numpy()[pick] - 1))),
    }


def main() -> None:
    r = measure()
    ratio = r["per_point_ode_s"] / r["per_point_cmd_s"]
    rate = r["rows"] / r["wall_cmd_s"]
    print(f"Hunt–Crossley reference: `impactbench sweep ball-on-plate` on {r['rows']} "
          f"velocities vs per-velocity solve_ivp DOP853 rtol {ODE_RTOL:g} on {ODE_POINTS} of "
          "them")
    print(tabulate([
        ["sweep command (incl. start-up, write)", r["rows"], r["wall_cmd_s"],
         r["per_point_cmd_s"] * 1e6],
        ["solve_ivp per velocity", ODE_POINTS, r["wall_ode_s"], r["per_point_ode_s"] * 1e6],
        ["sweep() in process, same velocities", ODE_POINTS, r["wall_same_s"],
         r["wall_same_s"] / ODE_POINTS * 1e6],
    ], headers=["method", "velocities", "wall s", "µs / velocity"], floatfmt=".4g"))
    print(f"command rate: {rate:.3g} velocities/s (target >= 1e5)")
    print(f"speed-up over per-point ODE: {ratio:.4g}x (target >= 300)")
    print("max relative difference, file vs ODE: " + ", ".join(
        f"{k} {v:.2e}" for k, v in r["worst"].items()) + " (target <= 1e-8)")
    print("same worst points vs ODE at rtol 1e-13: " + ", ".join(
        f"{k} {v:.2e}" for k, v in r["recheck"].items()))
    print(f"in-process sweep vs file on the same velocities: {r['same_vs_file']:.2e}")
