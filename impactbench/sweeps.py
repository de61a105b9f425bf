"""Reference sweeps through the results store and Dask: run only the points not yet stored.

:func:`rigid_flexible` gives exactly :func:`impactbench.reference.two_dof.sweep`'s frame
(same rows, order and values, bit for bit), but:

- points a results store holds (:meth:`impactbench.store.Store.get_points`, keyed by the
  laws, the fixed parameters, the swept value and impactbench's version) are served from it,
  so a rerun or an overlapping range costs only the lookup, and an interrupted sweep resumes;
- the missing points are solved in the solver's fixed chunks on a
  :class:`impactbench.cluster.Runner` (Dask workers, or a user's scheduler); the first two
  chunks run here (the second times the solver, the first having loaded its compiled kernel),
  and the rest stays here when it would take less than :data:`DISPATCH_MIN_S`;
- finished chunks are stored as they arrive (at most every :data:`FLUSH_EVERY_S`); a chunk
  whose worker dies twice gives ``crashed`` points (not stored), never a lost sweep;
- Ctrl-C stores what finished and raises :class:`impactbench.matrix.Interrupted`.
"""

from __future__ import annotations

import contextlib
import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

DISPATCH_MIN_S = 4.0
"""Missing points estimated to solve in less than this (s, in one process) are solved here.
Spawned Dask workers must start (~1 s) and load the compiled kernel (~1 s) before they
solve, so on two cores a sweep of T seconds takes about 2 s + T/2 there: even at T ≈ 4 s."""
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
    from impactbench.cluster import Runner
    from impactbench.matrix import Interrupted
    from impactbench.reference import two_dof
    from impactbench.reference.scenarios import SWEEP_FIELDS

    fld = SWEEP_FIELDS[over]
    tasks = two_dof.sweep_tasks(base, over, values, combos)  # validates everything
    vals = [float(v) for v in np.asarray(values, dtype=float).reshape(-1)]
    scenarios = {(t[0].local, t[0].structure): t[0] for t in tasks}
    keys = {lw: store_mod.sweep_key("two_dof", sc, over, fld) for lw, sc in scenarios.items()}
    done: dict[tuple[str, str, float], dict[str, Any]] = {}
    if store is not None and not fresh:
        for lw, key in keys.items():
            for row in store.get_points(key, vals).to_dict("records"):
                value = row.pop("value")
                done[(*lw, value)] = {"local": lw[0], "structure": lw[1], fld: value, **row}
    served = len(done)
    if progress and served:
        progress(served)
    todo = [task for lw, sc in scenarios.items() for task in two_dof.sweep_tasks(
        sc, over, [v for v in dict.fromkeys(vals) if (*lw, v) not in done], [lw])]
    unstored: dict[tuple[str, str], list[dict[str, Any]]] = {}
    stored = served
    last_flush = time.monotonic()

    def flush() -> None:
        """Write what is not stored yet, one law combination at a time (each leaves
        ``unstored`` once written, so an interrupted flush is finished, not repeated)."""
        nonlocal last_flush, stored
        while store is not None and unstored:
            lw, rows = next(iter(unstored.items()))
            part = pd.DataFrame(rows).drop(columns=["local", "structure"])
            stored += store.put_points(keys[lw], part.rename(columns={fld: "value"}))
            del unstored[lw]
        unstored.clear()
        last_flush = time.monotonic()

    def finished(task: Any, rows: list[dict[str, Any]]) -> None:
        unstored.setdefault((task[0].local, task[0].structure), []).extend(rows)
        done.update(((r["local"], r["structure"], r[fld]), r) for r in rows)
        if time.monotonic() - last_flush > FLUSH_EVERY_S:
            flush()
        if progress:
            progress(len(task[2]))

    def crashed(task: Any, why: str) -> None:
        finished(task, [{"local": task[0].local, "structure": task[0].structure, fld: v,
                         **dict.fromkeys(two_dof.METRIC_KEYS, math.nan), "status": "crashed"}
                        for v in task[2]])

    own = runner is None
    runner = runner or Runner(workers, scheduler, min_dispatch_s=DISPATCH_MIN_S)
    try:
        with runner if own else contextlib.nullcontext(runner):
            dispatched = runner.dispatched
            per_point = 0.0
            for task in todo[:2]:  # here: the first loads the kernel, the second is timed
                t0 = time.perf_counter()
                finished(task, two_dof.sweep_chunk(task))
                per_point = (time.perf_counter() - t0) / len(task[2])
            rest = todo[2:]
            runner.run(two_dof.sweep_chunk, rest, on_result=finished, on_crash=crashed,
                       label="sweep", estimate_s=per_point * sum(len(t[2]) for t in rest))
            where = (runner.describe() if runner.dispatched > dispatched
                     else "in this process")
    except KeyboardInterrupt:
        flush()
        raise Interrupted(stored if store is not None else len(done),
                          len(vals) * len(scenarios), store is not None,
                          unit="points") from None
    flush()
    rows = [done[(*lw, v)] for lw in scenarios for v in vals]
    frame = pd.DataFrame(rows, columns=two_dof.sweep_columns(over))
    return SweepResult(frame, served, len(done) - served, where)
