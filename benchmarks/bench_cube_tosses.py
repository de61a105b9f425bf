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

3. The report's replays (:func:`impactbench.cube_tosses.report_part.replay_jobs`: every
   engine × mode of the default config's measured scenario, ``custom`` once per published
   set), each through the report's own door (``run_safely``, the adapter's cube-toss
   builder), all in one process, the jobs alternating over :data:`ROUNDS` rounds: per
   replay the median of the replay's own time (``meta["replay_s"]``: the tosses, the
   engine built before) and of the whole run (the build, MJX's tracing), the first round's
   whole run apart (compilation, imports), and the sums.

Run: ``python -m benchmarks cube_tosses`` (about ten minutes on 2 cores); options:
``--only engines|mjx|replays`` (one part), ``--rounds N``, ``--engines a,b`` (the replays of
these engines only), e.g. ``python -m benchmarks cube_tosses --only replays --rounds 5``.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from collections.abc import Callable, Sequence
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
    from impactbench.engines.cube_toss_more import MJX_BATCH, MjxCube, MujocoPlaneCube

    for which in ("test",):
        starts = _starts(which)
        step = starts[0].step_s
        c = MujocoPlaneCube({}, step)
        batched = MjxCube({}, step, batch=MJX_BATCH)
        whole = MjxCube({}, step, batch=None)
        runners = {"C MuJoCo (plane), per toss": _runner(c, starts),
                   f"MJX vmap, {MJX_BATCH} world slots": _runner(batched, starts),
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


UNSUPPORTED_REPLAYS = {("mjx", "injected"), ("newton", "injected")}
"""Replays the report lists that build nothing (refused: MJX and Newton have no injected
mode; pymunk and Box2D no cube at all, :data:`impactbench.engines.cube_toss_more.
UNSUPPORTED`)."""


def _replay_jobs(only: Sequence[str] | None = None) -> list[Any]:
    """The report's cube-toss replays of the default config that an engine builds, as
    (label, job); ``only``: these engines'."""
    from impactbench.engines.cube_toss import ENGINES as CUBE_ENGINES

    from impactbench import config, scenarios
    from impactbench.cube_tosses.report_part import replay_jobs

    cfg = config.load(None)
    sm = next(s for s in cfg.scenarios if scenarios.get(s.name).measured)
    out = []
    for job in replay_jobs(cfg, scenarios.get(sm.name), sm):
        if job.engine not in CUBE_ENGINES or (job.engine, job.mode) in UNSUPPORTED_REPLAYS:
            continue
        if only and job.engine not in only:
            continue
        label = job.mode if not job.params else f"{job.mode} {dict(job.params)['param_set']}"
        out.append((f"{job.engine} {label}", job))
    return out


def replays(rounds: int = ROUNDS, only: Sequence[str] | None = None) -> None:
    """The report's replays, one after another in one process, alternating (module doc)."""
    from impactbench.engines.base import run_safely

    from impactbench.matrix import job_settings

    jobs = _replay_jobs(only)
    replay: dict[str, list[float]] = {label: [] for label, _ in jobs}
    whole: dict[str, list[float]] = {label: [] for label, _ in jobs}
    for _ in range(rounds):
        for label, job in jobs:
            t0 = time.perf_counter()
            rec = run_safely(job.engine, job.build_scenario(), job.mode, job_settings(job))
            whole[label].append(time.perf_counter() - t0)
            if rec.status.value != "ok":
                raise RuntimeError(f"{label}: {rec.status.value}: {rec.message}")
            replay[label].append(float(rec.meta["replay_s"]))
    print(f"\nThe report's {len(jobs)} cube-toss replays (89 test tosses each), s: median of "
          f"{rounds} alternating rounds in one process")
    print(f"{'replay':24s} {'replay_s':>9s} {'min–max':>15s} {'whole':>7s} {'1st whole':>10s}")
    for label, _ in jobs:
        r, w = replay[label], whole[label]
        print(f"{label:24s} {statistics.median(r):9.2f} {min(r):7.2f}–{max(r):<7.2f} "
              f"{statistics.median(w):7.2f} {w[0]:10.2f}")
    total = [sum(t[i] for t in whole.values()) for i in range(rounds)]
    print(f"{'sum':24s} {sum(statistics.median(r) for r in replay.values()):9.2f} "
          f"{'':15s} {statistics.median(total):7.2f} {total[0]:10.2f}")


def main(argv: Sequence[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog="python -m benchmarks cube_tosses")
    parser.add_argument("--only", choices=("engines", "mjx", "replays"))
    parser.add_argument("--rounds", type=int, default=ROUNDS)
    parser.add_argument("--engines", default="", help="the replays of these engines (a,b)")
    args = parser.parse_args(sys.argv[1:] if argv is None else argv)
    if args.only in (None, "engines"):
        engines()
    if args.only in (None, "mjx"):
        mjx_against_mujoco()
    if args.only in (None, "replays"):
        replays(args.rounds, [e for e in args.engines.split(",") if e] or None)


if __name__ == "__main__":
    main()
