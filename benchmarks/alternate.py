"""Side-by-side timing for the benchmarks: alternate the contenders, report medians.

The machine is shared, so its speed drifts while a benchmark runs: timing A's repeats and
then B's credits either with the drift, and a best-of rewards the luckiest run of each
(the PyBullet overhead measured 4.26× that way where alternated medians gave 1.31×). So
every contender runs once per round, in turn (A B A B …), and what is reported is each
one's median and the median of the per-round ratios (a pair shares the machine's state).
"""

from __future__ import annotations

import os
import statistics
import subprocess
import time
from collections.abc import Callable, Mapping, Sequence
from typing import Any


def alternate(contenders: Mapping[str, Callable[[], Any]], rounds: int
              ) -> dict[str, list[float]]:
    """Wall times (s) of every contender, each called once per round in the given order
    (A B …, A B …): ``rounds`` times per name."""
    times: dict[str, list[float]] = {name: [] for name in contenders}
    for _ in range(rounds):
        for name, fn in contenders.items():
            t0 = time.perf_counter()
            fn()
            times[name].append(time.perf_counter() - t0)
    return times


def median_ratio(a: Sequence[float], b: Sequence[float]) -> float:
    """The median of the per-round ratios a[i] / b[i]."""
    return statistics.median(x / y for x, y in zip(a, b, strict=True))


def median_pair(a: Callable[[], Any], b: Callable[[], Any], rounds: int
                ) -> tuple[float, float]:
    """Median wall times (s) of ``a`` and ``b``, run alternately (A B A B …)."""
    times = alternate({"a": a, "b": b}, rounds)
    return statistics.median(times["a"]), statistics.median(times["b"])


def process(cmd: Sequence[str], env: Mapping[str, str] | None = None,
            cwd: str | None = None) -> Callable[[], None]:
    """A contender that runs ``cmd`` as a fresh process (start-up, imports and all), its
    output discarded; a failure raises with the command's stderr."""
    full_env = {**os.environ, **env} if env else None

    def run() -> None:
        out = subprocess.run(list(cmd), capture_output=True, text=True, env=full_env, cwd=cwd)
        if out.returncode != 0:
            raise RuntimeError(f"{' '.join(cmd)}: exit {out.returncode}: {out.stderr[-2000:]}")

    return run


def summary(times: Mapping[str, Sequence[float]], baseline: str) -> list[list[Any]]:
    """Table rows: name, median s, min s, max s, median per-round ratio to ``baseline``."""
    return [[name, statistics.median(t), min(t), max(t), median_ratio(t, times[baseline])]
            for name, t in times.items()]
