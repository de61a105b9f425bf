"""A deliberately crashing adapter, plugged in through IMPACTBENCH_ENGINES by the tests of
crash isolation: it kills its own process the way a segfaulting engine would."""

from __future__ import annotations

import os
from typing import ClassVar

from impactbench.engines.base import Adapter, Builder


class CrashingAdapter(Adapter):
    name = "crasher"
    builders: ClassVar[dict[str, Builder]] = {"ball-on-plate": Builder("run_ball", 1e-6)}

    def version(self) -> str:
        return "0"

    def run_ball(self, scenario, mode, settings):
        os.abort()  # SIGABRT: the worker process dies without a Python exception


def square_or_die(x: int) -> int:
    """x², except that 3 kills the worker process (a segfaulting solver, for Runner tests)."""
    if x == 3:
        os.abort()
    return x * x


def pid(_item: object) -> int:
    """The process an item ran in (for Runner tests)."""
    return os.getpid()


SLEEP_ENV = "IMPACTBENCH_TEST_SLEEP_S"
"""How long a :class:`SleepingAdapter` run sleeps (s; default 0.5)."""


class SleepingAdapter(Adapter):
    """A slow engine (for interrupt tests): each run sleeps ``$IMPACTBENCH_TEST_SLEEP_S``
    seconds, then returns a plain record (status ``no_contact``: nothing to compare). Cheap
    on the CPU, unlike a real engine at 0.1 ns steps."""

    name = "sleeper"
    builders: ClassVar[dict[str, Builder]] = {"ball-on-plate": Builder("run_ball", 1e-6)}

    def version(self) -> str:
        return "0"

    def run_ball(self, scenario, mode, settings):
        import time

        from impactbench.reference.record import ImpactRecord, Status

        time.sleep(float(os.environ.get(SLEEP_ENV, "0.5")))
        return ImpactRecord.failed(Status.NO_CONTACT, "slept", engine=self.name, mode=mode)


class HangingAdapter(Adapter):
    """An engine that never returns at 2 m/s (a Python-level hang; at 3 m/s a sleep inside C
    that holds the GIL, which only a signal or a process kill ends; at 4 m/s the same with
    SIGALRM blocked, a C loop no alarm reaches) and sleeps briefly at any other velocity
    (for timeout tests)."""

    name = "hanger"
    builders: ClassVar[dict[str, Builder]] = {"ball-on-plate": Builder("run_ball", 1e-6)}

    def version(self) -> str:
        return "0"

    def run_ball(self, scenario, mode, settings):
        import time

        from impactbench.reference.record import ImpactRecord, Status

        if scenario.velocity_m_s == 2.0:
            while True:
                time.sleep(0.05)
        if scenario.velocity_m_s == 3.0:
            import ctypes

            ctypes.PyDLL(None).sleep(3600)  # PyDLL: the GIL stays held
        if scenario.velocity_m_s == 4.0:  # a C loop that never returns to Python
            import ctypes
            import signal

            signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGALRM})  # no EINTR either
            ctypes.PyDLL(None).sleep(3600)
        time.sleep(0.05)
        return ImpactRecord.failed(Status.NO_CONTACT, "returned", engine=self.name, mode=mode)


def nap(x: float) -> tuple[float, int]:
    """Sleep ``x`` seconds; the process it ran in (for Runner batching tests)."""
    import time

    time.sleep(x)
    return x, os.getpid()
