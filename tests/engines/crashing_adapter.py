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
