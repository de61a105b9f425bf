"""Vectorised Hunt–Crossley reference: the sweep command against its floor and the per-point ODE.

In one run, on the paper's ball (m = 0.1 kg, c = 1.7135e10 N/m^1.5, n = 1.5, b = 0.1 s/m):

1. speed, end to end: the command ``impactbench sweep ball-on-plate --over velocity --start
   0.001 --stop 1000 --step 0.001 --out FILE`` (10⁶ velocities, α from 1e-4 to 100) writing
   Parquet and CSV, each a fresh process (interpreter start-up, imports, the sweep, the
   table), against the floor process :mod:`benchmarks.floor_ball` (numpy, scipy and pandas
   imported, Lambert W on the same 10⁶ points, the same shape of table written as Parquet).
   The three run alternately, ``ROUNDS`` times; printed: their medians and the median of the
   per-round ratios command / floor. Target ≤ 2;
2. against the per-point ODE: ``solve_ivp`` (DOP853, rtol 1e-10) per velocity on
   ``ODE_POINTS`` velocities taken evenly from the grid of 1. alternated with the vectorised
   :func:`impactbench.reference.hunt_crossley.sweep` on those same velocities, in process
   (medians), and the command's per-velocity cost (its median over 10⁶). Target ≥ 300×;
3. accuracy: the largest relative difference between the command's file and the ODE on
   every metric. The ODE's own error is part of that difference (its k is good to ~rtol
   absolute, so 1 − k² ≈ 4α/3 is good only to ~rtol/α relative): the worst point of each
   metric is re-integrated at rtol 1e-13 to show which side the difference belongs to.
   Target ≤ 1e-8.

Run: ``python -m benchmarks reference_ball``.
"""

from __future__ import annotations

import statistics
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

from benchmarks.alternate import alternate, median_ratio, process

START, STOP, STEP = 0.001, 1000.0, 0.001
ROUNDS = 7
ODE_POINTS = 200
ODE_TIMED = 40
"""ODE solves per round of the timing (the accuracy check uses all ``ODE_POINTS``)."""
ODE_RTOL = 1e-10
ROOT = Path(__file__).resolve().parents[1]


def command(out: Path) -> list[str]:
    return [sys.executable, "-m", "impactbench.cli", "sweep", "ball-on-plate", "--over",
            "velocity", "--start", repr(START), "--stop", repr(STOP), "--step", repr(STEP),
            "--out", str(out)]


def floor(out: Path) -> list[str]:
    return [sys.executable, "-m", "benchmarks.floor_ball", str(out)]


def speed(tmp: Path) -> dict[str, list[float]]:
    """Wall times (s) of the command (Parquet, CSV) and the floor, alternated."""
    return alternate({
        "sweep command → .parquet": process(command(tmp / "sweep.parquet")),
        "sweep command → .csv": process(command(tmp / "sweep.csv")),
        "floor process (numpy, scipy, pandas, lambertw, Parquet)":
            process(floor(tmp / "floor.parquet"), cwd=str(ROOT)),
    }, ROUNDS)


def accuracy(table: pd.DataFrame) -> dict[str, dict[str, float]]:
    rows = len(table)
    pick = np.linspace(0, rows - 1, ODE_POINTS).round().astype(int)
    velocities = table["velocity_m_s"].to_numpy()[pick]
    law = BallOnPlate().law()
    ode = [hc.solve_ode(law, 0.1, float(v), rtol=ODE_RTOL) for v in velocities]
    worst, recheck = {}, {}
    for key in BALL_METRICS:
        errs = [abs(table[key].iloc[i] - o[key]) / abs(o[key])
                for i, o in zip(pick, ode, strict=True)]
        j = int(np.argmax(errs))
        worst[key] = errs[j]
        tight = hc.solve_ode(law, 0.1, float(velocities[j]), rtol=1e-13)[key]
        recheck[key] = abs(table[key].iloc[pick[j]] - tight) / abs(tight)
    same = hc.sweep(velocities)
    same_vs_file = float(np.max(np.abs(same[list(BALL_METRICS)].to_numpy()
                                       / table[list(BALL_METRICS)].to_numpy()[pick] - 1)))
    return {"worst": worst, "recheck": recheck, "same_vs_file": {"all": same_vs_file}}


def per_point(table: pd.DataFrame) -> dict[str, list[float]]:
    """Wall times (s) of the per-point ODE and the in-process sweep on ``ODE_TIMED``
    velocities of the grid, alternated."""
    pick = np.linspace(0, len(table) - 1, ODE_TIMED).round().astype(int)
    velocities = table["velocity_m_s"].to_numpy()[pick]
    law = BallOnPlate().law()
    return alternate({
        "solve_ivp per velocity": lambda: [hc.solve_ode(law, 0.1, float(v), rtol=ODE_RTOL)
                                           for v in velocities],
        "sweep() in process, same velocities": lambda: hc.sweep(velocities),
    }, ROUNDS)


def main() -> None:
    with tempfile.TemporaryDirectory() as tmp:
        times = speed(Path(tmp))
        table = pd.read_parquet(Path(tmp) / "sweep.parquet")
    rows = len(table)
    names = list(times)
    floor_name = names[-1]
    print(f"Hunt–Crossley reference: `impactbench sweep ball-on-plate` on {rows} velocities "
          f"against the floor process, each a fresh process, alternated, {ROUNDS} rounds")
    print(tabulate([[name, statistics.median(t), min(t), max(t),
                     median_ratio(t, times[floor_name])] for name, t in times.items()],
                   headers=["process", "median wall s", "min", "max", "÷ floor (median)"],
                   floatfmt=".3f"))
    for name in names[:-1]:
        ratio = median_ratio(times[name], times[floor_name])
        print(f"CLI vs floor, {name.split('→ ')[1]}: {ratio:.2f}× (target <= 2): "
              + ("yes" if ratio <= 2.0 else "NO"))

    t0 = time.perf_counter()
    each = per_point(table)
    ode_s = statistics.median(each["solve_ivp per velocity"]) / ODE_TIMED
    same_s = statistics.median(each["sweep() in process, same velocities"]) / ODE_TIMED
    cmd_s = statistics.median(times[names[0]]) / rows
    print(f"\nper velocity (medians; ODE and in-process sweep alternated on {ODE_TIMED} "
          f"velocities, {time.perf_counter() - t0:.0f} s):")
    print(tabulate([["sweep command → .parquet (incl. start-up, write)", cmd_s * 1e6],
                    [f"solve_ivp DOP853 rtol {ODE_RTOL:g}", ode_s * 1e6],
                    ["sweep() in process, same velocities", same_s * 1e6]],
                   headers=["method", "µs / velocity"], floatfmt=".4g"))
    print(f"command rate: {1 / cmd_s:.3g} velocities/s (target >= 1e5)")
    print(f"speed-up over per-point ODE: {ode_s / cmd_s:.4g}x (target >= 300)")

    r = accuracy(table)
    print("max relative difference, file vs ODE: " + ", ".join(
        f"{k} {v:.2e}" for k, v in r["worst"].items()))
    worst = max(r["recheck"].values())
    print("same worst points vs ODE at rtol 1e-13: " + ", ".join(
        f"{k} {v:.2e}" for k, v in r["recheck"].items())
        + f" (target <= 1e-8: {'yes' if worst <= 1e-8 else 'NO'}; at rtol {ODE_RTOL:g} the "
        "ODE's own error, ~rtol/α in 1 − k², shows at small α)")
    print(f"in-process sweep vs file on the same velocities: {r['same_vs_file']['all']:.2e}")


if __name__ == "__main__":
    main()
