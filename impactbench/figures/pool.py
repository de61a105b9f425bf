"""Where ``impactbench figures`` draws: worker processes, one per core, or this process.

Each figure is one task: a module-level function and its arguments (paths, numbers, a small
DataFrame), drawn with Agg in a worker and saved there, its return value (the path, or the
numbers of a reading) sent back. Agg's output depends only on the figure, the installed
libraries and the fonts, not on the process that draws it, so a figure drawn in a worker is
byte for byte the one drawn here (``tests/impactbench/test_figures_pool.py``).

The workers are forked from a fork server that has imported the figure modules once
(matplotlib, NumPy, SciPy, pandas: ~2 s a process), not from this process (which may hold
threads: a Dask cluster's, BLAS's); where the platform has no fork server they are spawned.
They ignore SIGINT: Ctrl-C stops this process, which ends them (:func:`figure_pool`).
"""

from __future__ import annotations

import contextlib
import multiprocessing
import signal
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import Executor, Future, ProcessPoolExecutor
from typing import Any


class InProcess(Executor):
    """An executor that runs each task here, at once, in submission order (``--workers 0``,
    and the modules' ``write``): a task's exception is raised by ``submit`` itself."""

    def submit(self, fn: Callable[..., Any], /, *args: Any, **kwargs: Any) -> Future:
        done: Future = Future()
        done.set_result(fn(*args, **kwargs))
        return done


IN_PROCESS = InProcess()


def _worker_start() -> None:
    """A worker's set-up: SIGINT ignored (this process handles Ctrl-C and ends the workers),
    the Agg backend."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    import matplotlib

    matplotlib.use("Agg")


def _context(preload: Sequence[str]) -> Any:
    """A fork server that has imported ``preload`` (and this module), else spawn."""
    if "forkserver" not in multiprocessing.get_all_start_methods():
        return multiprocessing.get_context("spawn")
    ctx = multiprocessing.get_context("forkserver")
    ctx.set_forkserver_preload([__name__, "matplotlib", *preload])
    return ctx


def worker_count(workers: int | None) -> int:
    """The pool's size: ``workers`` (0: this process), default one per core available to
    this process (``os.sched_getaffinity``)."""
    if workers is not None:
        return workers
    from impactbench.cluster import available_cores

    return available_cores()


@contextlib.contextmanager
def figure_pool(workers: int | None = None, preload: Sequence[str] = ()
                ) -> Iterator[Executor]:
    """An executor for the figure tasks: ``workers`` processes (default one per core; 0:
    :data:`IN_PROCESS`), their fork server preloading the modules ``preload``. On leaving,
    the tasks submitted are waited for; on an exception (Ctrl-C included) the queued ones
    are cancelled and the workers ended at once."""
    n = worker_count(workers)
    if n == 0:
        yield IN_PROCESS
        return
    pool = process_pool(n, preload)
    try:
        yield pool
    except BaseException:
        end_now(pool)
        raise
    pool.shutdown(wait=True)


def process_pool(n: int, preload: Sequence[str] = ()) -> ProcessPoolExecutor:
    """``n`` figure worker processes: forked from a fork server that preloads ``preload``
    (else spawned), SIGINT ignored, the Agg backend (the report's figure pool's too)."""
    return ProcessPoolExecutor(n, mp_context=_context(preload), initializer=_worker_start)


def end_now(pool: ProcessPoolExecutor) -> None:
    """Cancel ``pool``'s queued tasks and end its workers at once (a running figure: no use
    finishing it)."""
    processes = list((getattr(pool, "_processes", None) or {}).values())
    pool.shutdown(wait=False, cancel_futures=True)
    for process in processes:
        process.terminate()
