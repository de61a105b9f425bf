"""Reference sweeps through the results store and Dask: run only the points not yet stored.

:func:`rigid_flexible` gives exactly :func:`impactbench.reference.two_dof.sweep`'s frame
(same rows, order and values, bit for bit), but:

- points a results store holds (:meth:`impactbench.store.Store.get_points`, keyed by the
  laws, the fixed parameters, the swept value and impactbench's version) are served from it,
  so a rerun or an overlapping range costs only the lookup, and an interrupted sweep resumes;
- the missing points are solved in the solver's fixed chunks, each one call of the compiled
  kernel on its parameters as arrays (:func:`impactbench.reference.two_dof.sweep_block`; the
  points validated once per sweep, no scenario built per point); the first two chunks run
  here (the second times the solver, the first having loaded its compiled kernel), and the
  rest stays here, on one thread per core, when it would take less than
  :data:`DISPATCH_MIN_S`, else goes to a :class:`impactbench.cluster.Runner` (Dask workers,
  or a user's scheduler);
- finished chunks are stored as they arrive: a law combination once all its chunks are
  in, and everything at least every :data:`FLUSH_EVERY_S`; a chunk whose worker dies twice
  gives ``crashed`` points (not stored), never a lost sweep;
- Ctrl-C stores what finished and raises :class:`impactbench.matrix.Interrupted`, at once
  even inside a chunk solved here (the chunk runs in a thread of its own; the compiled kernel
  releases the GIL).
"""

from __future__ import annotations

import contextlib
import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

DISPATCH_MIN_S = 4.0
"""Missing points estimated to solve in less than this here (s: their CPU time, measured on
one chunk, shared out over the threads that solve them here) are solved here. Spawned Dask
workers must start (~1 s) and load the compiled kernel (~1 s) before they solve, so they
pay off only for long sweeps, with their crash isolation; here the compiled kernel runs on
one thread per core (it releases the GIL), unless ``workers = 0`` asks for this thread."""
FLUSH_EVERY_S = 2.0
"""New points are written to the store at least this often (and at the end)."""


@dataclass
class SweepResult:
    """A sweep's frame, how many of its points came from the store, and where it ran."""

    frame: Any
    served: int
    solved: int
    where: str


def rigid_flexible(base: Any, over: str, values: Any, combos: Any = None, *,
                   store: Any = None, fresh: bool = False, workers: int | None = None,
                   scheduler: str | None = None,
                   progress: Callable[[int], None] | None = None,
                   runner: Any = None) -> SweepResult:
    """The 2-DOF sweep of ``base`` over ``over`` (velocity, k1, k2, m2) at ``values`` (SI)
    for ``combos`` (None: all 3 × 2 law combinations); see the module docstring.
    ``runner``: a :class:`~impactbench.cluster.Runner` shared by several sweeps (its cluster
    starts once); else one of ``workers`` local processes or on ``scheduler``."""
    import numpy as np
    import pandas as pd

    from impactbench import store as store_mod
    from impactbench.cliutil import interruptible
    from impactbench.cluster import Runner
    from impactbench.matrix import Interrupted
    from impactbench.reference import two_dof
    from impactbench.reference.scenarios import SWEEP_FIELDS

    fld = SWEEP_FIELDS[over]
    tasks = two_dof.sweep_tasks(base, over, values, combos)  # validates everything
    vals = np.asarray(values, dtype=float).reshape(-1)
    # a point is (combo, value): the distinct values, sorted, and where each value sits
    uniq, first_at, where_in = np.unique(vals, return_index=True, return_inverse=True)
    scenarios = {(t[0].local, t[0].structure): t[0] for t in tasks}
    keys = {lw: store_mod.sweep_key("two_dof", sc, over, fld) for lw, sc in scenarios.items()}
    # one column set per law combination over the distinct values; ``have`` marks the
    # points served or solved
    cols = {lw: {"have": np.zeros(uniq.size, dtype=bool),
                 **{k: np.full(uniq.size, np.nan) for k in two_dof.METRIC_KEYS},
                 "status": np.full(uniq.size, None, dtype=object)} for lw in scenarios}

    def put(lw: tuple[str, str], at: np.ndarray, block: dict[str, Any]) -> None:
        c = cols[lw]
        c["have"][at] = True
        for k in (*two_dof.METRIC_KEYS, "status"):
            c[k][at] = block[k]

    if store is not None and not fresh:
        for lw, key in keys.items():
            got = store.get_points(key, uniq.tolist())
            if len(got):
                at = np.searchsorted(uniq, got["value"].to_numpy(dtype=float))
                put(lw, at, {k: got[k].to_numpy() for k in (*two_dof.METRIC_KEYS, "status")})
    served = int(sum(c["have"].sum() for c in cols.values()))
    if progress and served:
        progress(served)
    appear = np.sort(first_at)  # each distinct value once, in input order
    todo = [task for lw, sc in scenarios.items() for task in two_dof.sweep_tasks(
        sc, over, vals[appear][~cols[lw]["have"][where_in[appear]]].tolist(), [lw])]
    unstored: dict[tuple[str, str], list[dict[str, Any]]] = {}  # solved blocks to store
    left = {lw: sum(1 for t in todo if (t[0].local, t[0].structure) == lw) for lw in scenarios}
    stored = served
    solved = 0
    last_flush = time.monotonic()

    def flush() -> None:
        """Write what is not stored yet, one law combination at a time (each leaves
        ``unstored`` once written, so an interrupted flush is finished, not repeated)."""
        nonlocal last_flush, stored
        while store is not None and unstored:
            lw, parts = next(iter(unstored.items()))
            part = pd.DataFrame({
                "value": np.concatenate([p[fld] for p in parts]),
                **{k: np.concatenate([np.asarray(p[k]) for p in parts])
                   for k in two_dof.METRIC_KEYS},
                "status": [x for p in parts for x in p["status"]]})
            stored += store.put_points(keys[lw], part)
            del unstored[lw]
        unstored.clear()
        last_flush = time.monotonic()

    def finished(task: Any, block: dict[str, Any]) -> None:
        nonlocal solved
        lw = (task[0].local, task[0].structure)
        at = np.searchsorted(uniq, np.asarray(block[fld], dtype=float))
        put(lw, at, block)
        solved += len(at)
        unstored.setdefault(lw, []).append(block)
        left[lw] -= 1
        # a law combination is stored once complete (here, while the threads solve the
        # next), and everything at least every FLUSH_EVERY_S
        if left[lw] == 0 or time.monotonic() - last_flush > FLUSH_EVERY_S:
            flush()
        if progress:
            progress(len(task[2]))

    def crashed(task: Any, why: str) -> None:
        n = len(task[2])
        finished(task, {"local": task[0].local, "structure": task[0].structure,
                        fld: np.asarray(task[2], dtype=float),
                        **{k: np.full(n, math.nan) for k in two_dof.METRIC_KEYS},
                        "status": ["crashed"] * n})

    own = runner is None
    runner = runner or Runner(workers, scheduler, min_dispatch_s=DISPATCH_MIN_S)
    try:
        with runner if own else contextlib.nullcontext(runner):
            dispatched = runner.dispatched
            per_point = 0.0
            for task in todo[:2]:  # here: the first loads the kernel, the second is timed
                block, cpu_s = interruptible(_timed_block, two_dof.sweep_block, task)
                finished(task, block)
                per_point = cpu_s / len(task[2])
            rest = todo[2:]
            estimate = per_point * sum(len(t[2]) for t in rest)
            threads = _threads(runner)
            if rest and (runner.in_process or estimate / threads < runner.min_dispatch_s):
                _solve_here(two_dof.sweep_block, rest, finished, threads)
            else:
                runner.run(two_dof.sweep_block, rest, on_result=finished, on_crash=crashed,
                           label="sweep", estimate_s=estimate)
            where = (runner.describe() if runner.dispatched > dispatched
                     else "in this process")
    except KeyboardInterrupt:
        flush()
        raise Interrupted(stored if store is not None else served + solved,
                          len(vals) * len(scenarios), store is not None,
                          unit="points") from None
    flush()
    return SweepResult(_frame(two_dof, over, scenarios, cols, vals, where_in), served,
                       solved, where)


def _timed_block(solve: Callable[[Any], Any], task: Any) -> tuple[Any, float]:
    """``solve(task)`` and the CPU time (s) it took on its thread (deaf to other processes'
    load, and measured where it runs: the chunk solves in a thread of its own)."""
    t0 = time.thread_time()
    block = solve(task)
    return block, time.thread_time() - t0


def _threads(runner: Any) -> int:
    """Threads for the chunks solved here: one with ``workers = 0`` (in this process, as it
    always was), else as many as the runner would start workers (one per core available)."""
    if runner.in_process:
        return 1
    from impactbench.cluster import available_cores

    return max(1, min(runner.workers or available_cores(), available_cores()))


def _solve_here(solve: Callable[[Any], Any], tasks: list, finished: Callable[[Any, Any], None],
                threads: int) -> None:
    """``finished(task, solve(task))`` for every task, in order, solved in this process on
    ``threads`` threads (the compiled kernel releases the GIL; no process to start, nothing
    to pickle). Ctrl-C drops the chunks not started and propagates at once, also inside a
    chunk (each solves in a thread of its own, :func:`impactbench.cliutil.interruptible`:
    a chunk of points at the kernel's step budget takes minutes)."""
    if threads <= 1 or len(tasks) <= 1:
        from impactbench.cliutil import interruptible

        for task in tasks:
            finished(task, interruptible(solve, task))
        return
    from concurrent.futures import ThreadPoolExecutor

    pool = ThreadPoolExecutor(max_workers=threads, thread_name_prefix="impactbench-sweep")
    try:
        futures = [pool.submit(solve, task) for task in tasks]
        for task, future in zip(tasks, futures, strict=True):
            finished(task, future.result())
    finally:
        pool.shutdown(wait=False, cancel_futures=True)


def _frame(two_dof: Any, over: str, scenarios: dict, cols: dict, vals: Any,
           where_in: Any) -> Any:
    """The sweep's frame (:func:`impactbench.reference.two_dof.sweep`'s, bit for bit and
    dtype for dtype) from the per-combination columns: every value, in input order, per
    combination."""
    import numpy as np

    blocks = []
    for lw in scenarios:
        c = cols[lw]
        impacts = c["impacts"][where_in]
        if not np.isnan(impacts).any():  # as rows of Python ints would give: int64
            impacts = impacts.astype(np.int64)
        blocks.append({"local": lw[0], "structure": lw[1], two_dof.SWEEP_FIELDS[over]: vals,
                       **{k: c[k][where_in] for k in two_dof.METRIC_KEYS},
                       "impacts": impacts, "status": c["status"][where_in].tolist()})
    return two_dof.sweep_frame(over, blocks)
