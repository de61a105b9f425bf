"""Execution on ``dask.distributed``: a local cluster of worker processes, or a user's scheduler.

The local cluster binds to loopback only, has no dashboard and silenced logs, one thread per
worker process (engines are not thread-safe), no memory limit (the nanny must not kill a Drake
worker for its size) and ``allowed-failures = 1``: a run whose worker dies (segfault, abort)
is retried once on a fresh worker; if it kills that one too, Dask gives up on it
(``KilledWorker``) and the caller records it as ``crashed``. It has at most one worker per
core available to this process (``os.sched_getaffinity``).

Items go to the workers in small batches formed as workers free up (:meth:`Runner.run`): one
batch per worker in flight (Dask would queue a second on the worker itself, where a dying or
hanging worker takes it along), so every result comes back within seconds. A worker announces
each item it starts (a Dask event), so a per-item timeout knows which item hangs: that item is
reported as timed out, its batch cancelled, its worker restarted, and the batch's other items
run again. (A hang in C that holds the GIL also stops the worker's announcements: the items
from the last one announced then run again one at a time, so the timeout finds the right one;
a batch with no announcement at all is timed from when the scheduler placed it.)

Workers ignore SIGINT and SIGHUP: Ctrl-C (or a closed terminal) reaches only this process,
which stores what finished, cancels the rest and closes the cluster without worker tracebacks.
"""

from __future__ import annotations

import contextlib
import contextvars
import functools
import logging
import math
import os
import queue
import signal
import threading
import time
import warnings
from collections import deque
from collections.abc import Callable, Hashable, Iterator, Sequence
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

BATCH_S = 2.0
"""A batch holds at most about this much predicted work (s): its results come back (are
counted and stored) within seconds."""
MAX_BATCH = 8
"""… and at most this many items (a ball run takes milliseconds, a Dask task ~4 ms)."""
TICK_S = 0.25
"""How often :meth:`Runner.run` checks the timeouts and calls ``on_tick`` while it waits."""
TIMEOUT_MIN_S = 60.0
TIMEOUT_FACTOR = 20.0
"""The default per-run timeout: ``max(TIMEOUT_MIN_S, TIMEOUT_FACTOR × the run's estimated
time)`` (see :func:`default_timeout`)."""
RESTART_TIMEOUT_S = 30.0
"""How long a worker restart (after a timed-out run) may take."""
RESULT_WAIT_S = 1.0
"""How long to wait for the result of a future reported done (a result lost with its
worker is computed again: then the future is watched again)."""
STEP_S = 2e-5
RUN_S = 1e-3
"""A prior for an engine run's time: ``RUN_S + STEP_S × its integration steps`` (Drake's
and MJX's steps cost ~1.5e-5 s, MuJoCo's ~2e-6 s; Newton's more, which the batches learn)."""

_timeout: contextvars.ContextVar[float | None] = contextvars.ContextVar(
    "impactbench_run_timeout", default=None)


def run_estimate_s(steps: float) -> float:
    """The prior estimate of an engine run of ``steps`` integration steps (s)."""
    return RUN_S + STEP_S * max(0.0, steps)


@contextlib.contextmanager
def run_timeout(seconds: float | None) -> Iterator[None]:
    """Within the block, engine runs (:func:`impactbench.matrix.run_jobs`) time out after
    ``seconds`` each instead of :func:`default_timeout` (None: the default)."""
    token = _timeout.set(seconds)
    try:
        yield
    finally:
        _timeout.reset(token)


def configured_timeout() -> float | None:
    """The timeout set by :func:`run_timeout` (None: each run's default)."""
    return _timeout.get()


def first_use_s(engine: str) -> float:
    """What a run of ``engine`` is allowed on top of its timeout for compiling on first use in
    a process (s; its :class:`~impactbench.engines.registry.EngineSpec`'s ``first_use_s``): a
    JIT engine's first compile is no hang, so it does not count against the timeout."""
    from impactbench.engines.registry import spec

    try:
        return float(spec(engine).first_use_s)
    except ValueError:  # not a registered engine: nothing allowed
        return 0.0


def default_timeout(estimate_s: float) -> float:
    """The default timeout of a run estimated at ``estimate_s`` seconds: 20 × the estimate,
    at least 60 s (a cold worker imports its engine, JAX and Warp compile, a shared machine
    is slow: none of that is a hang)."""
    return max(TIMEOUT_MIN_S, TIMEOUT_FACTOR * estimate_s)


def available_cores() -> int:
    """The cores this process may run on (its CPU affinity; else the machine's count)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):
        return os.cpu_count() or 1


def _ignore_sigint() -> None:
    """Run on every worker process (also one restarted after a crash): SIGINT and SIGHUP
    are for the main process, which closes the cluster."""
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        signal.signal(signal.SIGHUP, signal.SIG_IGN)


@contextlib.contextmanager
def _quiet_start() -> Iterator[None]:
    """While the local cluster starts: SIGINT ignored (the spawned workers inherit that, so a
    Ctrl-C never gives worker tracebacks; one pressed in these ~2 s is lost), SIGTERM and
    SIGHUP held back and delivered once the cluster is up (its closing is then in place)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    held: list[int] = []
    previous = {signal.SIGINT: signal.signal(signal.SIGINT, signal.SIG_IGN)}
    for sig in (signal.SIGTERM, signal.SIGHUP):
        previous[sig] = signal.signal(sig, lambda signum, _frame: held.append(signum))
    try:
        yield
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)
    for sig in dict.fromkeys(held):
        signal.raise_signal(sig)


def _worker_pids(cluster: Any) -> set[int]:
    """The processes of a local cluster's workers (its nannies live in this process)."""
    pids = set()
    with contextlib.suppress(Exception):
        for nanny in list(cluster.workers.values()):
            pid = getattr(getattr(nanny, "process", None), "pid", None)
            if pid:
                pids.add(pid)
    return pids


def _reap(pids: set[int]) -> None:
    """Terminate those of ``pids`` (worker processes) that a cluster failed to close, so
    that no worker outlives the command; only this process's own children."""
    import multiprocessing

    for child in multiprocessing.active_children():
        if child.pid not in pids:
            continue
        with contextlib.suppress(Exception):
            child.terminate()
            child.join(2)
            if child.is_alive():
                child.kill()
                child.join(1)


def _end_workers(cluster: Any, pids: set[int]) -> None:
    """End a local cluster's worker processes at once (SIGKILL, their nannies told not to
    restart them), before the cluster closes: everything they did has come back by then (a
    run's result, or its crash), and a worker with the engines loaded takes ~2.5 s to close
    itself (measured: the cluster's close 2.6 s after the workers load MuJoCo, MJX, Drake,
    PyBullet, SAPIEN and Newton, 0.05 s with the workers ended first). What the engines keep
    on disk (XLA's and warp's compile caches, MJX's kept loops) is written when compiled."""
    for nanny in list(getattr(cluster, "workers", {}).values()):
        with contextlib.suppress(Exception):
            nanny.auto_restart = False
    for pid in pids:
        with contextlib.suppress(OSError):
            os.kill(pid, signal.SIGKILL)


def _refused(address: str) -> str:
    """Why a ``tcp://host:port`` scheduler address refuses a connection outright (nothing
    listens on the port: the machine answers at once), "" when it does not, or cannot be
    told in a second (another protocol, a slow or filtered host: Dask's own connect decides)."""
    import socket
    from urllib.parse import urlsplit

    try:
        parts = urlsplit(address if "://" in address else f"tcp://{address}")
        if parts.scheme != "tcp" or not parts.hostname or not parts.port:
            return ""
        with socket.create_connection((parts.hostname, parts.port), timeout=1.0):
            return ""
    except ConnectionRefusedError:
        return "connection refused: nothing listens on that port"
    except (OSError, ValueError):
        return ""


@contextlib.contextmanager
def client(workers: int | None = None, scheduler: str | None = None) -> Iterator[Any]:
    """A Dask client: on ``scheduler`` when given (or ``$IMPACTBENCH_SCHEDULER``), else on
    a fresh local cluster of ``workers`` processes (default and at most: one per core
    available)."""
    import dask
    from distributed import Client, LocalCluster

    scheduler = scheduler or os.environ.get(SCHEDULER_ENV) or None
    with dask.config.set(DASK_CONFIG):
        if scheduler:
            refused = _refused(scheduler)
            if refused:  # nothing listens there: say so now, not after Dask's 10 s of retries
                raise ValueError(f"scheduler = {scheduler!r}: cannot connect ({refused})")
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
        n = min(workers or available_cores(), available_cores())
        cluster = c = None
        # distributed applies silence_logs only while the cluster starts; its scheduler runs
        # in this process and would log INFO lines (start, workers leaving) through a root
        # handler an engine installs (pydrake): quiet for the cluster's whole life
        quiet = logging.getLogger("distributed")
        level = quiet.level
        quiet.setLevel(logging.ERROR)
        try:
            with _quiet_start():
                with warnings.catch_warnings():  # its loopback HTTP port moves if 8787 is taken
                    warnings.filterwarnings("ignore", message="Port .* is already in use")
                    cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                                           host="127.0.0.1", dashboard_address=None,
                                           silence_logs=logging.CRITICAL, memory_limit=0)
                c = Client(cluster)
                c.register_worker_callbacks(_ignore_sigint)
            yield c
        finally:
            pids = _worker_pids(cluster) if cluster is not None else set()
            if cluster is not None:
                _end_workers(cluster, pids)
            if c is not None:
                with contextlib.suppress(BaseException):
                    c.close(timeout=5)
            if cluster is not None:
                with contextlib.suppress(BaseException):
                    cluster.close(timeout=5)
            _reap(pids)
            quiet.setLevel(level)


def apply_batch(fn: Callable[[Any], Any], batch: Sequence[Any], topic: str | None = None,
                batch_id: int | None = None,
                prepare: Callable[[Any], None] | None = None) -> list[Any]:
    """``[fn(item) for item in batch]``, in a worker process. With ``topic``, each item's
    start is announced as a Dask event ``{"b": batch_id, "k": index, "w": worker address}``
    (what the caller's per-item timeout measures from), after ``prepare(item)``: loading
    what the item needs (an engine's modules: seconds on a fresh or restarted worker under
    load) is not the item's work and not on its clock."""
    worker = None
    if topic is not None:
        with contextlib.suppress(ImportError, ValueError):  # ValueError: not on a worker
            from distributed import get_worker

            worker = get_worker()
    out = []
    for k, item in enumerate(batch):
        if prepare is not None:
            prepare(item)
        if worker is not None:
            worker.log_event(topic, {"b": batch_id, "k": k, "w": worker.address})
        out.append(fn(item))
    return out


WORKER_START_S = 30.0
"""What a batch that announced no start is allowed on top of its first item's timeout, counted
from when it was placed, on a worker that has announced nothing yet: a fresh or restarted
worker unpickles the work (importing the suite, seconds under load) before it can announce
anything."""

HARD_GRACE_MIN_S = 5.0
""":func:`deadline`'s backstop: a lone in-process run stuck in C (where SIGALRM cannot reach
it) is given ``max(HARD_GRACE_MIN_S, its timeout)`` more before the process dumps where it
hangs and exits."""


class RunTimeout(BaseException):
    """Raised in this process by SIGALRM when an in-process item outlasts its timeout (a
    BaseException: an adapter's ``except Exception`` must not turn it into a result)."""


@contextlib.contextmanager
def alarm(seconds: float | None) -> Iterator[None]:
    """Raise :class:`RunTimeout` in this (main) thread after ``seconds``. It interrupts
    Python code only: a call into C that does not return (a solver loop in an engine's
    extension) is interrupted when it returns to Python, if ever. No-op off the main thread
    or without ``seconds``."""
    if (not seconds or not math.isfinite(seconds) or not hasattr(signal, "setitimer")
            or threading.current_thread() is not threading.main_thread()):
        yield
        return

    def ring(_signum: int, _frame: Any) -> None:
        raise RunTimeout(seconds)

    previous = signal.signal(signal.SIGALRM, ring)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


@contextlib.contextmanager
def deadline(seconds: float | None) -> Iterator[None]:
    """:func:`alarm` for a lone run in this process (``impactbench run``), with a backstop
    for what SIGALRM cannot reach: if the run is still inside C code
    ``max(HARD_GRACE_MIN_S, seconds)`` after ``seconds``, :mod:`faulthandler`'s watchdog
    thread (it needs no GIL) prints where every thread hangs on stderr and exits the process
    with status 1. Not for :meth:`Runner.run`'s in-process batches, whose finished runs may
    not be stored yet."""
    if not seconds or not math.isfinite(seconds):
        yield
        return
    import faulthandler
    import sys

    try:
        sys.stderr.fileno()
        stream = sys.stderr
    except (AttributeError, OSError, ValueError):  # a captured stderr (pytest, notebooks)
        stream = sys.__stderr__
    faulthandler.dump_traceback_later(seconds + max(HARD_GRACE_MIN_S, seconds), exit=True,
                                      file=stream)
    try:
        with alarm(seconds):
            yield
    finally:
        faulthandler.cancel_dump_traceback_later()


def _per_item(value: Any) -> Callable[[Any], float | None]:
    if value is None:
        return lambda _item: None
    if callable(value):
        return value
    return lambda _item: float(value)


class _Batch:
    """A batch in flight: its id and items, when it was submitted, when its first item
    started, and the last item a worker announced (index, worker address, when)."""

    __slots__ = ("alone", "begun", "id", "items", "placed", "started", "submitted")

    def __init__(self, bid: int, items: list[Any], alone: bool) -> None:
        self.id, self.items, self.alone = bid, items, alone
        self.submitted = time.monotonic()
        self.begun: float | None = None
        self.started: tuple[int, str, float] | None = None
        self.placed: tuple[str, float] | None = None
        """Without a start announced: the worker the scheduler placed it on, and since when
        it is seen there."""


class _DaskRun:
    """One :meth:`Runner.run` on Dask: the queue of items (``todo``: (item, alone)), the
    batches in flight, their start announcements (a worker publishes ``(batch, item, worker)``
    on the run's topic), the per-group time ratios that size the batches, and the timeouts
    (module doc)."""

    def __init__(self, runner: Runner, c: Any, fn: Callable[[Any], Any], items: Sequence[Any],
                 label: str, batch_size: int | None, cost: Callable[[Any], float | None],
                 group: Callable[[Any], Hashable],
                 timeout_of: Callable[[Any], float | None],
                 prepare: Callable[[Any], None] | None = None) -> None:
        import uuid

        self.runner, self.c, self.fn, self.label = runner, c, fn, label
        self.prepare = prepare
        self.batch_size, self.cost, self.group, self.timeout_of = (batch_size, cost, group,
                                                                   timeout_of)
        self.tag = uuid.uuid4().hex[:8]
        self.topic = f"impactbench-{label}-{self.tag}"
        self.todo: deque[tuple[Any, bool]] = deque((item, False) for item in items)
        self.flying: dict[Any, _Batch] = {}
        self.by_id: dict[int, _Batch] = {}
        self.done: queue.SimpleQueue = queue.SimpleQueue()
        self.counter = iter(range(1 << 62))
        self.unfetched: dict[Any, float] = {}
        """Futures done whose result could not be fetched: when to try again."""
        self.placed_at = 0.0
        self.warm: set[str] = set()
        """Workers that have announced a start: their imports are done."""
        self.killed: dict[str, float] = {}
        """Workers this run killed (a timed-out item), and when: not counted as free while
        the scheduler still lists them."""
        self.recount_until = 0.0
        """Until then (after a kill) the free workers are counted on the scheduler itself at
        each submission, not from the client's view (refreshed every 2 s)."""

    # -- announcements and batch sizes
    def started(self, event: Any) -> None:  # on the client's event-loop thread
        msg = event[1] if isinstance(event, tuple) else event
        batch = self.by_id.get(msg.get("b"))
        if batch is not None:
            now = time.monotonic()
            batch.started = (int(msg["k"]), str(msg["w"]), now)
            self.warm.add(str(msg["w"]))
            if msg["k"] == 0:
                batch.begun = now

    def predicted(self, item: Any) -> float | None:
        ratio = self.runner._ratio.get(self.group(item))
        if ratio is None:
            return None  # the group's first batch: one item, to measure it
        est = self.cost(item)
        return ratio * (est if est is not None else 1.0)

    def next_batch(self) -> tuple[list[Any], bool]:
        todo = self.todo
        item, alone = todo.popleft()
        if alone:
            return [item], True
        batch = [item]
        if self.batch_size:
            while todo and len(batch) < self.batch_size and not todo[0][1]:
                batch.append(todo.popleft()[0])
            return batch, False
        total = self.predicted(item)
        if total is None:
            return batch, False
        g, taken = self.group(item), []
        for n, (other, other_alone) in enumerate(todo):
            if len(batch) >= MAX_BATCH:
                break
            if other_alone or self.group(other) != g:
                continue
            more = self.predicted(other) or 0.0
            if total + more > BATCH_S:
                break
            taken.append(n)
            batch.append(other)
            total += more
        if taken:
            skip = set(taken)
            rest = [entry for n, entry in enumerate(todo) if n not in skip]
            todo.clear()
            todo.extend(rest)
        return batch, False

    def submit(self) -> None:
        batch_items, alone = self.next_batch()
        batch = _Batch(next(self.counter), batch_items, alone)
        self.by_id[batch.id] = batch
        fut = self.c.submit(apply_batch, self.fn, batch_items, self.topic, batch.id,
                            self.prepare, pure=False,
                            key=f"{self.label}-{batch.id}-{len(batch_items)}-{self.tag}")
        self.flying[fut] = batch
        fut.add_done_callback(self.done.put)

    def forget(self, fut: Any) -> _Batch:
        self.unfetched.pop(fut, None)
        batch = self.flying.pop(fut)
        self.by_id.pop(batch.id, None)
        return batch

    def learn(self, batch: _Batch) -> None:
        """What the batch took over what it was predicted to take, per group."""
        g = self.group(batch.items[0])
        if any(self.group(i) != g for i in batch.items[1:]):
            return
        took = time.monotonic() - (batch.begun or batch.submitted)
        est = sum(e if (e := self.cost(i)) is not None else 1.0 for i in batch.items)
        ratio = took / max(est, 1e-3)
        old = self.runner._ratio.get(g)
        self.runner._ratio[g] = ratio if old is None else 0.5 * (old + ratio)

    def drop(self, fut: Any) -> _Batch:
        batch = self.forget(fut)
        with contextlib.suppress(Exception):
            self.c.cancel([fut])
        return batch

    # -- timeouts
    def placed(self, now: float) -> None:
        """Where the scheduler has the batches that announced no start (polled every second,
        only while there are such batches): their fallback clock starts when they are placed
        on a worker, again when moved to another (their worker restarted)."""
        waiting = [b for b in self.flying.values() if b.started is None
                   and now - b.submitted > 1.0]
        if not waiting or now - self.placed_at < 1.0:
            return
        self.placed_at = now
        with contextlib.suppress(Exception):
            where = {key: w for w, keys in self.c.processing().items() for key in keys}
            running = {b.started[1] for f, b in self.flying.items()
                       if b.started is not None and not f.done()}
            for fut, batch in self.flying.items():
                if batch.started is not None:
                    continue
                worker = where.get(fut.key)
                if worker is None or worker in running:  # queued behind a batch that runs
                    batch.placed = None
                elif batch.placed is None or batch.placed[0] != worker:
                    batch.placed = (worker, now)

    def kill(self, address: str) -> None:
        """Restart the worker at ``address`` (its item timed out): until its replacement has
        registered, it is not a free slot, or the next batch would be queued behind a hung
        one on the other worker, its clock running and the kill of that worker counted
        against it (``allowed-failures``)."""
        self.runner._restart(self.c, address)
        now = time.monotonic()
        self.killed[address] = now
        self.recount_until = now + RESTART_TIMEOUT_S

    def slots(self, now: float, counted: int) -> int:
        """How many batches may be in flight: ``counted`` (the client's view of the workers)
        except shortly after a kill, when the workers the scheduler lists now, less those
        killed, are counted (a round trip of ~1 ms)."""
        if now >= self.recount_until:
            return counted
        try:
            listed = set(self.c.nthreads())
        except Exception:  # the cluster may be closing: the client's view
            return counted
        self.killed = {a: t for a, t in self.killed.items()
                       if a in listed and now - t < RESTART_TIMEOUT_S}
        return len(listed - self.killed.keys())

    def requeue(self, fut: Any, address: str, alone: list[Any], before: list[Any],
                batch: _Batch) -> None:
        """Cancel a batch, restart its worker, and queue ``alone`` items one at a time after
        ``before`` (the batch's items that ran) as they were."""
        self.drop(fut)
        self.kill(address)
        self.todo.extendleft((i, True) for i in reversed(alone))
        self.todo.extendleft((i, batch.alone) for i in reversed(before))

    def overdue(self, now: float, timed_out: Callable[[Any, str], None]) -> None:
        self.placed(now)
        for fut, batch in list(self.flying.items()):
            if fut.done():  # ran to the end: no timeout (its result may be on its way)
                continue
            if batch.started is not None:
                k, address, since = batch.started
                limit = self.timeout_of(batch.items[k])
                if limit is None or now - since <= limit:
                    continue
                if k < len(batch.items) - 1:
                    # item k, or a later one whose start could not be announced (a hang in C
                    # holding the GIL stops the worker's event loop): each alone
                    self.requeue(fut, address, batch.items[k:], batch.items[:k], batch)
                    continue
            elif batch.placed is not None:
                # no start announced: its first item's allowance from when it was placed (a
                # worker has one batch at a time), then (a hang holding the GIL before the
                # announcement got out, or announcements lost) each item alone
                address, since = batch.placed
                limit = self.timeout_of(batch.items[0])
                cold = 0.0 if address in self.warm else WORKER_START_S
                if limit is None or now - since <= limit + cold:
                    continue
                if len(batch.items) > 1:  # which item hangs is unknown: one at a time
                    self.requeue(fut, address, batch.items, [], batch)
                    continue
                k = 0
            else:
                continue
            self.drop(fut)
            self.kill(address)
            timed_out(batch.items[k], f"timed out after {limit:.3g} s (cancelled; its worker "
                      "was restarted)")
            self.todo.extendleft((i, batch.alone) for i in reversed(batch.items[:k]))

    # -- results
    def collect(self, on_result: Callable[[Any, Any], None],
                on_crash: Callable[[Any, str], None]) -> None:
        """Hand on every batch that is done (a lost result, its worker restarted, is
        computed again; a batch that raised or whose worker died is split into its items)."""
        from concurrent.futures import CancelledError

        from distributed.scheduler import KilledWorker

        now = time.monotonic()
        for fut in [f for f in self.flying if f.done() and now >= self.unfetched.get(f, 0.0)]:
            try:
                results = fut.result(timeout=RESULT_WAIT_S)
            except TimeoutError:  # its worker hangs (in the next task) with the data
                self.unfetched[fut] = time.monotonic() + 2.0
                continue
            except CancelledError:
                why = "cancelled on the cluster"
            except KilledWorker:
                why = "the worker process died (twice)"
            except Exception as exc:  # a bug in an adapter must not lose the rest
                why = f"{type(exc).__name__}: {exc}"
            else:
                why = None
            batch = self.forget(fut)
            if why is None:
                self.learn(batch)
                for item, result in zip(batch.items, results, strict=True):
                    on_result(item, result)
            elif len(batch.items) == 1:
                on_crash(batch.items[0], why)
            else:  # isolate: each item of the batch alone
                self.todo.extendleft((i, True) for i in reversed(batch.items))

    def run(self, on_result: Callable[[Any, Any], None], on_crash: Callable[[Any, str], None],
            timed_out: Callable[[Any, str], None], on_tick: Callable[[], None] | None) -> None:
        # one batch per worker: a second would wait on the worker (Dask queues only large
        # groups of tasks), die with it, and sit behind a hang
        size, counted = self.runner.size, time.monotonic()
        self.c.subscribe_topic(self.topic, self.started)
        try:
            while self.todo or self.flying:
                now = time.monotonic()
                if now - counted > 2.0:  # workers may come and go
                    size, counted = self.runner.size, now
                while self.todo and len(self.flying) < self.slots(now, size):
                    self.submit()
                with contextlib.suppress(queue.Empty):  # a wake-up: any future may be done
                    self.done.get(timeout=TICK_S)
                self.collect(on_result, on_crash)
                self.overdue(time.monotonic(), timed_out)
                if on_tick:
                    on_tick()
        except KeyboardInterrupt:
            with contextlib.suppress(Exception):
                self.c.cancel(list(self.flying))
            raise
        finally:
            with contextlib.suppress(Exception):
                self.c.unsubscribe_topic(self.topic)


class Runner:
    """Where a command's work runs: in this process (``workers = 0``, no crash isolation) or
    on Dask, a local cluster of ``workers`` processes (default one per core, at most one per
    core available) or the user's ``scheduler``. The cluster starts on first use and lives
    until the runner is closed, so a search that submits many small batches (tuning) pays its
    start-up once.

    :meth:`run` applies a picklable module-level ``fn`` to every item and reports each result
    as its batch finishes. A batch whose worker dies twice (or that raises) is split into
    single items, so only the item that kills its worker is reported as crashed; an item that
    outlasts its timeout is reported as timed out and its worker restarted.
    """

    def __init__(self, workers: int | None = None, scheduler: str | None = None, *,
                 min_dispatch_s: float = 0.0) -> None:
        if workers is not None and (isinstance(workers, bool) or workers < 0):
            raise ValueError(f"workers = {workers!r}: must be an integer >= 0")
        self.workers = workers
        self.scheduler = scheduler or os.environ.get(SCHEDULER_ENV) or None
        self.scheduler_source = ("" if not self.scheduler else "--scheduler" if scheduler
                                 else f"${SCHEDULER_ENV}")
        """Where the scheduler address came from (what a connection error names)."""
        self.min_dispatch_s = 0.0 if self.scheduler else min_dispatch_s
        """Work estimated below this (s) runs in this process: a cluster start (~1 s) and a
        round trip to a worker (~10–30 ms) would cost more than it saves. A scheduler the user
        named (``--scheduler`` or ``$IMPACTBENCH_SCHEDULER``) gets all the work: so it runs
        where the user said, and an address nothing listens on is an error, not ignored."""
        self._stack: contextlib.ExitStack | None = None
        self._client: Any = None
        self.dispatched = 0
        """Items sent to Dask so far (the others ran in this process)."""
        self.restarted = 0
        """Workers restarted after a timed-out item."""
        self._ratio: dict[Hashable, float] = {}
        """Per group of items: measured time over predicted time (batches are sized by it)."""
        self._restarts: list[threading.Thread] = []

    @property
    def in_process(self) -> bool:
        """True when items run in this process (``workers = 0`` and no scheduler)."""
        return self.workers == 0 and not self.scheduler

    @property
    def started(self) -> bool:
        """Whether its Dask client (a local cluster, or the scheduler's) is up."""
        return self._client is not None

    @property
    def size(self) -> int:
        """How many items run at once: 1 in process, else the cluster's workers once it is
        started, before that the local worker count it will have (``workers``, at most the
        cores available)."""
        if self.in_process:
            return 1
        if self._client is not None:
            return max(1, len(self._client.scheduler_info().get("workers", {})))
        return min(self.workers or available_cores(), available_cores())

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
        self._restarts = []  # a restart still under way ends with the cluster
        if self._stack is not None:
            self._stack.close()
        self._stack, self._client = None, None

    def client(self, at_most: int | None = None) -> Any:
        """The Dask client, started on first call (a local cluster of at most ``at_most``
        workers when that is fewer than :attr:`size`)."""
        if self._client is None:
            n = self.size if at_most is None else max(1, min(self.size, at_most))
            stack = contextlib.ExitStack()
            try:
                self._client = stack.enter_context(client(n, self.scheduler))
            except ValueError as exc:
                if self.scheduler_source.startswith("$"):  # say where the address came from
                    raise ValueError(f"{exc} (from {self.scheduler_source})") from None
                raise
            self._stack = stack
        return self._client

    def _restart(self, c: Any, address: str) -> None:
        """Restart the worker at ``address``: one of our local cluster's is killed (SIGKILL:
        a hung worker cannot close itself; its nanny starts a fresh one at once); one of a
        user's scheduler is restarted through it (in the background: it takes seconds)."""
        self.restarted += 1
        pid = None
        with contextlib.suppress(Exception):
            pid = next(n.process.pid for n in c.cluster.workers.values()
                       if n.worker_address == address)
        if pid:
            with contextlib.suppress(OSError):
                os.kill(pid, signal.SIGKILL)
            return

        def restart() -> None:
            with contextlib.suppress(Exception):  # the cluster may be closing
                c.restart_workers([address], timeout=RESTART_TIMEOUT_S, raise_for_error=False)

        thread = threading.Thread(target=restart, daemon=True)
        thread.start()
        self._restarts.append(thread)

    def run(self, fn: Callable[[Any], Any], items: Sequence[Any], *,
            on_result: Callable[[Any, Any], None], on_crash: Callable[[Any, str], None],
            on_timeout: Callable[[Any, str], None] | None = None, label: str = "items",
            batch_size: int | None = None, estimate_s: float | None = None,
            cost: Callable[[Any], float] | None = None,
            group: Callable[[Any], Hashable] | None = None,
            timeout_s: float | Callable[[Any], float | None] | None = None,
            on_tick: Callable[[], None] | None = None,
            prepare: Callable[[Any], None] | None = None) -> None:
        """``on_result(item, fn(item))`` for every item (``on_crash(item, why)`` for one
        whose worker died twice or that raised on Dask; ``on_timeout(item, why)``, default
        ``on_crash``, for one that outlasted ``timeout_s(item)`` seconds). Order of the
        calls: completion. ``estimate_s``: the work's estimated time in one process; below
        :attr:`min_dispatch_s` it runs here. ``on_tick()`` is called at least every
        :data:`TICK_S` while the work runs on Dask (and after every item here).

        Batches: ``batch_size`` items each when given; else formed as workers free up, one
        ``group(item)`` at a time, of at most :data:`MAX_BATCH` items and about
        :data:`BATCH_S` of predicted work: ``cost(item)`` (else ``estimate_s`` shared out)
        scaled by what the group's batches took so far; a group's first batch is one item.

        ``prepare(item)`` loads what an item needs before its clock starts (on Dask; in this
        process it is loaded once and for all by the first item).

        In this process a timeout is a SIGALRM (:func:`alarm`: Python code only). A
        KeyboardInterrupt cancels what is left and propagates."""
        items = list(items)
        if not items:
            return
        timeout_of = _per_item(timeout_s)
        timed_out = on_timeout or on_crash
        if self.in_process or (estimate_s is not None and estimate_s < self.min_dispatch_s):
            for item in items:
                limit = timeout_of(item)
                try:
                    with alarm(limit):
                        result = fn(item)
                except RunTimeout:
                    timed_out(item, f"timed out after {limit:.3g} s (in this process)")
                else:
                    on_result(item, result)
                if on_tick:
                    on_tick()
            return
        self._run_on_dask(fn, items, on_result, on_crash, timed_out, label, batch_size,
                          estimate_s, cost, group, timeout_of, on_tick, prepare)

    def _run_on_dask(self, fn, items, on_result, on_crash, timed_out, label, batch_size,
                     estimate_s, cost, group, timeout_of, on_tick, prepare) -> None:
        c = self.client(at_most=len(items))
        self.dispatched += len(items)
        if cost is None:
            share = (estimate_s / len(items)) if estimate_s else None
            cost = (lambda _item: share) if share is not None else (lambda _item: None)
        _DaskRun(self, c, fn, items, label, batch_size, cost, group or (lambda _item: None),
                 timeout_of, prepare).run(on_result, on_crash, timed_out, on_tick)

    def map(self, fn: Callable[[Any], Any], items: Sequence[Any], *,
            on_crash: Callable[[Any, str], Any], label: str = "items",
            batch_size: int | None = None, estimate_s: float | None = None,
            timeout_s: float | Callable[[Any], float | None] | None = None) -> list[Any]:
        """``[fn(item) for item in items]`` in input order; an item whose worker died
        twice (or that raised on Dask, or outlasted ``timeout_s``) gives
        ``on_crash(item, why)`` instead."""
        out: list[Any] = [None] * len(items)

        def done(pair: tuple[int, Any], result: tuple[int, Any]) -> None:
            out[pair[0]] = result[1]

        def crashed(pair: tuple[int, Any], why: str) -> None:
            out[pair[0]] = on_crash(pair[1], why)

        limit = _per_item(timeout_s)
        self.run(functools.partial(_indexed, fn), list(enumerate(items)), on_result=done,
                 on_crash=crashed, label=label, batch_size=batch_size,
                 estimate_s=estimate_s, timeout_s=lambda pair: limit(pair[1]))
        return out


def _indexed(fn: Callable[[Any], Any], pair: tuple[int, Any]) -> tuple[int, Any]:
    return pair[0], fn(pair[1])
