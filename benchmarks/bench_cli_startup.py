"""CLI start-up: ``impactbench --help`` (and some subcommand ``--help``) against ``python -c pass``.

In one run, interleaved so both sides see the same machine load: each command is started
``REPEATS`` times as a fresh process; the minimum and the median wall times are printed, with
the ratio of the minima to the bare interpreter's. Target: ``impactbench --help`` ≤ 0.25 s
(minimum). Building the argparse tree imports only light modules (no scipy, pandas,
matplotlib, numba or engine packages; ``tests/impactbench/test_cli_startup.py`` checks that).
Run: ``python -m benchmarks cli_startup``.
"""

from __future__ import annotations

import statistics
import subprocess
import sys
import time
from pathlib import Path

REPEATS = 9
TARGET_S = 0.25


def commands() -> dict[str, list[str]]:
    script = Path(sys.executable).with_name("impactbench")
    cli = [str(script)] if script.is_file() else [sys.executable, "-m", "impactbench.cli"]
    return {
        "python -c pass": [sys.executable, "-c", "pass"],
        "impactbench --help": [*cli, "--help"],
        "impactbench run --help": [*cli, "run", "--help"],
        "impactbench tune --help": [*cli, "tune", "--help"],
        "impactbench sweep rigid-flexible --help": [*cli, "sweep", "rigid-flexible", "--help"],
    }


def main() -> None:
    cmds = commands()
    times: dict[str, list[float]] = {name: [] for name in cmds}
    for _ in range(REPEATS):
        for name, cmd in cmds.items():
            t0 = time.perf_counter()
            subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=True)
            times[name].append(time.perf_counter() - t0)
    base = min(times["python -c pass"])
    print(f"{'command':42s} {'min (s)':>8s} {'median (s)':>10s} {'min / pass':>10s}")
    for name, t in times.items():
        print(f"{name:42s} {min(t):8.3f} {statistics.median(t):10.3f} {min(t) / base:10.1f}")
    best = min(times["impactbench --help"])
    verdict = "meets" if best <= TARGET_S else "MISSES"
    print(f"impactbench --help: {best:.3f} s, {verdict} the target of {TARGET_S} s "
          f"({best / base:.1f}× python -c pass)")
