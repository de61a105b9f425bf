"""Ctrl-C (and SIGTERM/SIGHUP, which the command line turns into the same KeyboardInterrupt)
must reach the command's "interrupted; N stored" path whenever it lands — also while the
results store is inside a DuckDB query.

Found while checking the Ctrl-C tests (a ``nohup``'d ``impactbench sweep`` sent SIGHUP while
it wrote points ended with ``RuntimeError: Query interrupted``, a traceback and exit 1, not
129): DuckDB turns a KeyboardInterrupt raised in its query (Python runs the signal handler when
DuckDB checks for signals) into ``RuntimeError("Query interrupted")``, which is neither a
KeyboardInterrupt nor a ``duckdb.Error``, so no handler of the store or the command line sees
an interrupt. Measured with duckdb 2.0.1: 5 of 60 to 33 of 100 signals sent at random instants
of back-to-back ``put_points`` calls.
"""

from __future__ import annotations

import os
import signal
import threading
from pathlib import Path

import pandas as pd
import pytest

from impactbench.store import Store

TRIALS = 80
"""Signals sent. At the lowest rate measured (5 of 60 surface as RuntimeError) all 80 would be
KeyboardInterrupts with probability 0.92⁸⁰ = 0.1 %: the strict xfail is not flaky."""


def test_an_interrupt_during_a_store_write_is_a_keyboard_interrupt(tmp_path: Path) -> None:
    if threading.current_thread() is not threading.main_thread():
        pytest.skip("signal handlers are set in the main thread only")
    import duckdb  # noqa: F401  (imported before the signals: its import is not the subject)

    store = Store(tmp_path / "s.duckdb")
    frame = pd.DataFrame({"value": [1.0, 2.0], "peak_force_n": [1.0, 1.0],
                          "pulse_width_s": [1e-3, 1e-3], "contact_time_s": [1e-3, 1e-3],
                          "impulse_ns": [1.0, 1.0], "impacts": [1, 1], "status": ["ok", "ok"]})
    assert store.put_points("k", frame) == 2
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    other: list[str] = []
    try:
        for trial in range(TRIALS):
            timer = threading.Timer(0.02 + 0.03 * trial / TRIALS, os.kill,
                                    (os.getpid(), signal.SIGINT))
            try:
                timer.start()
                while True:
                    store.put_points("k", frame)
            except KeyboardInterrupt:
                pass
            except Exception as exc:  # what the defect raises instead
                other.append(f"{type(exc).__name__}: {exc}")
            timer.join()
            if other:
                break
    finally:
        signal.signal(signal.SIGINT, previous)
    assert not other, other
