"""Cube tosses: replayed tosses per second per engine, and MJX batched against C MuJoCo.

1. Every engine replays the same tosses (the test split, 89, out of the box, DAIR's protocol:
   about 900 steps of 1/1480 s each) with one engine instance, built before the clock starts;
   PyBullet, MuJoCo, Drake, SAPIEN and DART one toss after another, Newton and MJX all tosses
   in one batched call (Newton: one world per toss; MJX: ``jax.vmap`` in batches). Rounds
   alternate the engines; each prints the median (and min–max) of :data:`ROUNDS` rounds.
2. MJX against C MuJoCo on the **same** model (the cube on a plane, :class:`MujocoPlaneCube`;
   MuJoCo's own replay uses a box board), alternating: C MuJoCo toss by toss
   (``mj_step`` in a Python loop), MJX in batches of 64 and in one call of all tosses; a
   warm-up call compiles MJX first (compilation excluded, reported apart).

Run: ``python -m benchmarks cube_tosses`` (about two minutes on 2 cores).
"""

from __future__ import annotations

import statistics
import time
from collections.abc import Callable
from typing import Any

from impactbench.engines.cube_toss import make

from benchmarks.alternate import alternate
from impactbench.cube_tosses import load, split
from impactbench.cube_tosses.data import tosses
from impactbench.cube_tosses.protocol import Protocol, prepare

ROUNDS = 3
ENGINES = ("pybullet", "mujoco", "drake", "sapien", "dart", "newton", "mjx")


def _starts(which: str = "test") -> list[Any]:
    df = load()
    return [prepare(t, Protocol()) for t in tosses(df, split(df["toss"].unique(), which))]


def _runner(sim: Any, starts: list[Any]) -> Callable[[], None]:
    if getattr(sim, "batched", False):
        return lambda: sim.run_many(starts)
    return lambda: [sim.run(s) for s in starts]


def _alternate(runners: dict[str, Callable[[], None]], n: int) -> dict[str, list[float]]:
    """Tosses per second of each runner (``n`` tosses a call) over :data:`ROUNDS` rounds,
    the runners alternating (:func:`benchmarks.alternate.alternate`)."""
    return {name: [n / s for s in times] for name, times in alternate(runners, ROUNDS).items()}


def _row(name: str, rates: list[float], note: str = "") -> str:
    return (f"{name:28s} {statistics.median(rates):10.1f} {min(rates):8.1f}–{max(rates):<8.1f}"
            f" {note}")


def engines() -> None:
    starts = _starts()
    steps = sum(int(s.record_steps[-1]) for s in starts)
    print(f"{len(starts)} test tosses, {steps} steps, out of the box; tosses/s "
          f"(median of {ROUNDS} alternating rounds)")
    print(f"{'engine':28s} {'tosses/s':>10s} {'min–max':>17s}")
    runners, sims, warm = {}, [], {}
    for name in ENGINES:
        try:
            sim = make(name, {}, starts[0].step_s)
        except ImportError as exc:
            print(f"{name:28s} unavailable: {exc}")
            continue
        sims.append(sim)
        run = _runner(sim, starts)
        t0 = time.perf_counter()
        run()   # warm-up: MJX compiles, Newton loads its kernels
        warm[name] = time.perf_counter() - t0
        runners[name] = run
    for name, rates in _alternate(runners, len(starts)).items():
        print(_row(name, rates, f"(first call {warm[name]:.1f} s)"))
    for sim in sims:
        sim.close()


def mjx_against_mujoco() -> None:
    from impactbench.engines.cube_toss_more import MjxCube, MujocoPlaneCube

    for which in ("test",):
        starts = _starts(which)
        step = starts[0].step_s
        c = MujocoPlaneCube({}, step)
        batched = MjxCube({}, step, batch=64)
        whole = MjxCube({}, step, batch=None)
        runners = {"C MuJoCo (plane), per toss": _runner(c, starts),
                   "MJX vmap, batches of 64": _runner(batched, starts),
                   f"MJX vmap, one call of {len(starts)}": _runner(whole, starts)}
        warm = {}
        for name, run in runners.items():
            t0 = time.perf_counter()
            run()
            warm[name] = time.perf_counter() - t0
        print(f"\nMJX against C MuJoCo on the plane model, {len(starts)} {which} tosses "
              f"(tosses/s, median of {ROUNDS} alternating rounds)")
        rates = _alternate(runners, len(starts))
        for name, r in rates.items():
            print(_row(name, r, f"(first call {warm[name]:.1f} s, with compilation)"))
        base = statistics.median(rates["C MuJoCo (plane), per toss"])
        for name, r in rates.items():
            if name.startswith("MJX"):
                print(f"  {name}: {statistics.median(r) / base:.3f} × C MuJoCo")


def main() -> None:
    engines()
    mjx_against_mujoco()


if __name__ == "__main__":
    main()
