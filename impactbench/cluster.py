"""Execution on ``dask.distributed``: a local cluster of worker processes, or a user's scheduler.

The local cluster binds to loopback only, has no dashboard and silenced logs, one thread per
worker process (engines are not thread-safe), no memory limit (the nanny must not kill a Drake
worker for its size) and ``allowed-failures = 1``: a run whose worker dies (segfault, abort)
is retried once on a fresh worker; if it kills that one too, Dask gives up on it
(``KilledWorker``) and the caller records it as ``crashed``. ``worker-saturation = 1`` keeps
one run per worker in flight, so a dying worker takes no innocent queued run with it.

Workers ignore SIGINT: Ctrl-C reaches only this process, which stores what finished, cancels
the rest and closes the cluster without worker tracebacks.
"""

from __future__ import annotations

import contextlib
import logging
import os
import signal
import warnings
from collections.abc import Callable, Iterator, Sequence
from typing import Any

SCHEDULER_ENV = "IMPACTBENCH_SCHEDULER"
"""Address of an existing Dask scheduler (like ``--scheduler``)."""

DASK_CONFIG = {
    "distributed.scheduler.allowed-failures": 1,
    "distributed.scheduler.worker-saturation": 1.0,
    "distributed.worker.daemon": False,
    "distributed.admin.system-monitor.gil.enabled": False,
    "distributed.logging.distributed": "critical",
}


def _ignore_sigint() -> None:
    """Run on every worker process (also one restarted after a crash)."""
    import threading

    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, signal.SIG_IGN)


@contextlib.contextmanager
def client(workers: int | None = None, scheduler: str | None = None) -> Iterator[Any]:
    """A Dask client: on ``scheduler`` when given (or ``$IMPACTBENCH_SCHEDULER``), else on
    a fresh local cluster of ``workers`` processes (default: one per core)."""
    import dask
    from distributed import Client, LocalCluster

    scheduler = scheduler or os.environ.get(SCHEDULER_ENV) or None
    with dask.config.set(DASK_CONFIG):
        if scheduler:
            try:
                c = Client(scheduler, timeout="10s")
            except OSError as exc:
                raise ValueError(f"scheduler = {scheduler!r}: cannot connect "
                                 f"({str(exc).splitlines()[0]})") from None
            try:
                yield c
            finally:
                c.close()
            return
        n = workers or os.cpu_count() or 1
        # spawned workers inherit an ignored SIGINT; restarted ones get it from _ignore_sigint
        previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
        try:
            with warnings.catch_warnings():  # its loopback HTTP port moves if 8787 is taken
                warnings.filterwarnings("ignore", message="Port .* is already in use")
                cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                                       host="127.0.0.1", dashboard_address=None,
                                       silence_logs=logging.CRITICAL, memory_limit=0)
            c = Client(cluster)
            c.register_worker_callbacks(_ignore_sigint)
        finally:
            signal.signal(signal.SIGINT, previous)
        try:
            yield c
        finally:
            with contextlib.suppress(Exception):
                c.close(timeout=5)
            with contextlib.suppress(Exception):
                cluster.close(timeout=5)


BATCHES_PER_WORKER = 4
"""Runs go to the workers in batches (about this many per worker): one Dask task per run
costs more than a short engine run (the ball's take milliseconds)."""


def execute_batch(items: Sequence[tuple[Any, tuple]]) -> list[Any]:
    """Run ``execute(job, *extra)`` for every item, in a worker process."""
    from impactbench.matrix import execute

    return [execute(job, *extra) for job, extra in items]


def run_on_dask(jobs: Sequence[Any], args: Sequence[tuple], *, workers: int | None,
                scheduler: str | None, on_result: Callable[[Any], None],
                on_crash: Callable[[Any, str], None]) -> None:
    """Run ``execute(job, *args)`` of :mod:`impactbench.matrix` for every job; report each
    result (or crash) as its batch finishes. A batch whose worker dies twice (or that raises)
    is split into single runs, so only the run that kills its worker becomes ``crashed``.
    A KeyboardInterrupt cancels what is left."""
    import uuid

    from distributed import as_completed
    from distributed.scheduler import KilledWorker

    n = min(workers or os.cpu_count() or 1, len(jobs))
    items = list(zip(jobs, args, strict=True))
    size = max(1, len(items) // (n * BATCHES_PER_WORKER))
    batches = [items[i:i + size] for i in range(0, len(items), size)]
    tag = uuid.uuid4().hex[:8]
    with client(n, scheduler) as c:
        def submit(batch: list) -> Any:
            fut = c.submit(execute_batch, batch, pure=False,
                           key=f"runs-{batch[0][0].id}-{len(batch)}-{tag}")
            futures[fut] = batch
            return fut

        futures: dict[Any, list] = {}
        pending = as_completed([submit(b) for b in batches])
        try:
            for fut in pending:
                batch = futures.pop(fut)
                try:
                    for result in fut.result():
                        on_result(result)
                    continue
                except KilledWorker:
                    why = "the engine's worker process died (twice)"
                except Exception as exc:  # a bug in an adapter must not lose the rest
                    why = f"{type(exc).__name__}: {exc}"
                if len(batch) == 1:
                    on_crash(batch[0][0], why)
                else:  # isolate: each run of the batch alone
                    for item in batch:
                        pending.add(submit([item]))
        except KeyboardInterrupt:
            with contextlib.suppress(Exception):
                c.cancel(list(futures))
            raise
