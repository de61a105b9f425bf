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
import functools
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
"""Items go to the workers in batches (about this many per worker): one Dask task per item
costs more than a short engine run (the ball's take milliseconds)."""


def apply_batch(fn: Callable[[Any], Any], batch: Sequence[Any]) -> list[Any]:
    """``[fn(item) for item in batch]``, in a worker process."""
    return [fn(item) for item in batch]


class Runner:
    """Where a command's work runs: in this process (``workers = 0``, no crash isolation) or
    on Dask, a local cluster of ``workers`` processes (default one per core) or the user's
    ``scheduler``. The cluster starts on first use and lives until the runner is closed, so a
    search that submits many small batches (tuning) pays its start-up once.

    :meth:`run` applies a picklable module-level ``fn`` to every item and reports each result
    as its batch finishes. A batch whose worker dies twice (or that raises) is split into
    single items, so only the item that kills its worker is reported as crashed.
    """

    def __init__(self, workers: int | None = None, scheduler: str | None = None, *,
                 min_dispatch_s: float = 0.0) -> None:
        if workers is not None and (isinstance(workers, bool) or workers < 0):
            raise ValueError(f"workers = {workers!r}: must be an integer >= 0")
        self.workers = workers
        self.min_dispatch_s = min_dispatch_s
        """Work estimated below this (s) runs in this process: a cluster start (~1 s) and a
        round trip to a worker (~10–30 ms) would cost more than it saves."""
        self.scheduler = scheduler or os.environ.get(SCHEDULER_ENV) or None
        self._stack: contextlib.ExitStack | None = None
        self._client: Any = None
        self.dispatched = 0
        """Items sent to Dask so far (the others ran in this process)."""

    @property
    def in_process(self) -> bool:
        """True when items run in this process (``workers = 0`` and no scheduler)."""
        return self.workers == 0 and not self.scheduler

    @property
    def size(self) -> int:
        """How many items run at once: 1 in process, else the cluster's workers once it is
        started, before that the local worker count it will have."""
        if self.in_process:
            return 1
        if self._client is not None:
            return max(1, len(self._client.scheduler_info().get("workers", {})))
        return self.workers or os.cpu_count() or 1

    def describe(self) -> str:
        """Where items run, for output: ``in this process``, ``on N local workers`` or
        ``on the scheduler ADDRESS``."""
        if self.in_process:
            return "in this process"
        if self.scheduler:
            return f"on the scheduler {self.scheduler}"
        return f"on {self.size} local worker{'s' if self.size != 1 else ''}"

    def __enter__(self) -> Runner:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        if self._stack is not None:
            self._stack.close()
        self._stack, self._client = None, None

    def client(self, at_most: int | None = None) -> Any:
        """The Dask client, started on first call (a local cluster of at most ``at_most``
        workers when that is fewer than :attr:`size`)."""
        if self._client is None:
            n = self.size if at_most is None else max(1, min(self.size, at_most))
            stack = contextlib.ExitStack()
            self._client = stack.enter_context(client(n, self.scheduler))
            self._stack = stack
        return self._client

    def run(self, fn: Callable[[Any], Any], items: Sequence[Any], *,
            on_result: Callable[[Any, Any], None], on_crash: Callable[[Any, str], None],
            label: str = "items", batch_size: int | None = None,
            estimate_s: float | None = None) -> None:
        """``on_result(item, fn(item))`` for every item (``on_crash(item, why)`` for one
        whose worker died twice or that raised on Dask). Order of the calls: completion.
        ``estimate_s``: the work's estimated time in one process; below
        :attr:`min_dispatch_s` it runs here. A KeyboardInterrupt cancels what is left and
        propagates."""
        items = list(items)
        if not items:
            return
        if self.in_process or (estimate_s is not None and estimate_s < self.min_dispatch_s):
            for item in items:
                on_result(item, fn(item))
            return
        import uuid

        from distributed import as_completed
        from distributed.scheduler import KilledWorker

        c = self.client(at_most=len(items))
        self.dispatched += len(items)
        n = self.size
        size = batch_size or max(1, len(items) // (n * BATCHES_PER_WORKER))
        batches = [items[i:i + size] for i in range(0, len(items), size)]
        tag = uuid.uuid4().hex[:8]
        futures: dict[Any, list] = {}
        counter = iter(range(1 << 62))

        def submit(batch: list) -> Any:
            fut = c.submit(apply_batch, fn, batch, pure=False,
                           key=f"{label}-{next(counter)}-{len(batch)}-{tag}")
            futures[fut] = batch
            return fut

        pending = as_completed([submit(b) for b in batches])
        try:
            for fut in pending:
                batch = futures.pop(fut)
                try:
                    results = fut.result()
                except KilledWorker:
                    why = "the worker process died (twice)"
                except Exception as exc:  # a bug in an adapter must not lose the rest
                    why = f"{type(exc).__name__}: {exc}"
                else:
                    for item, result in zip(batch, results, strict=True):
                        on_result(item, result)
                    continue
                if len(batch) == 1:
                    on_crash(batch[0], why)
                else:  # isolate: each item of the batch alone
                    for item in batch:
                        pending.add(submit([item]))
        except KeyboardInterrupt:
            with contextlib.suppress(Exception):
                c.cancel(list(futures))
            raise

    def map(self, fn: Callable[[Any], Any], items: Sequence[Any], *,
            on_crash: Callable[[Any, str], Any], label: str = "items",
            batch_size: int | None = None, estimate_s: float | None = None) -> list[Any]:
        """``[fn(item) for item in items]`` in input order; an item whose worker died
        twice (or that raised on Dask) gives ``on_crash(item, why)`` instead."""
        out: list[Any] = [None] * len(items)

        def done(pair: tuple[int, Any], result: tuple[int, Any]) -> None:
            out[pair[0]] = result[1]

        def crashed(pair: tuple[int, Any], why: str) -> None:
            out[pair[0]] = on_crash(pair[1], why)

        self.run(functools.partial(_indexed, fn), list(enumerate(items)), on_result=done,
                 on_crash=crashed, label=label, batch_size=batch_size,
                 estimate_s=estimate_s)
        return out


def _indexed(fn: Callable[[Any], Any], pair: tuple[int, Any]) -> tuple[int, Any]:
    return pair[0], fn(pair[1])
