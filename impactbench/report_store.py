"""The report's hold on its results store: a disk that fills up while a report runs costs the
store the rest of its writes, never the report.

:class:`KeepWhatFits` wraps a :class:`~impactbench.store.Store`. Reads go through. The first
write that finds the disk full (DuckDB's ``No space left on device``, measured with DuckDB 2.0
on a full ext4 as a ``TransactionException`` at commit, or an ``OSError`` ENOSPC) is the last
one tried: DuckDB's transaction leaves the file as it was, later writes are skipped, the runs
stay in memory and the report is written from them; :meth:`KeepWhatFits.say_full` says so in
one line on stderr. Any other store error is raised as before.
"""

from __future__ import annotations

import errno
import os
import sys
from collections.abc import Iterable
from pathlib import Path
from typing import Any


def disk_full(exc: BaseException) -> bool:
    """True when ``exc`` (or what it was raised from or during) is a full disk: an OSError
    ENOSPC, or an error whose text is the system's words for it (DuckDB's)."""
    words = os.strerror(errno.ENOSPC).lower()
    seen: set[int] = set()
    at: BaseException | None = exc
    while at is not None and id(at) not in seen:
        seen.add(id(at))
        if isinstance(at, OSError) and at.errno == errno.ENOSPC:
            return True
        if words in str(at).lower():
            return True
        at = at.__cause__ or at.__context__
    return False


class KeepWhatFits:
    """A results store that stops writing, and keeps the report going, once its disk is full.

    ``kept``: the run keys found in the store or written to it by this wrapper; ``full``:
    the store's error when a write found the disk full (None until then)."""

    def __init__(self, store: Any) -> None:
        self.store = store
        self.kept: set[str] = set()
        self.full: str | None = None
        self._said = False

    @property
    def path(self) -> Path:
        return Path(self.store.path)

    def __getattr__(self, name: str) -> Any:
        return getattr(self.store, name)

    def get(self, keys: Iterable[str], **kwargs: Any) -> dict[str, Any]:
        found = self.store.get(keys, **kwargs)
        self.kept.update(found)
        return found

    def put(self, entries: Iterable[tuple]) -> int:
        """The store's ``put``; 0 (nothing written) once the disk was found full."""
        if self.full is not None:
            return 0
        entries = list(entries)
        try:
            n = self.store.put(entries)
        except (ValueError, OSError) as exc:
            if not disk_full(exc):
                raise
            self.full = (str(exc).splitlines() or [type(exc).__name__])[0]
            return 0
        self.kept.update(key for key, _inputs, _job, run, _history in entries
                         if run.get("status") not in ("crashed", "timeout"))
        return n

    def kept_of(self, jobs: Iterable[Any]) -> int:
        """How many of ``jobs`` (:class:`~impactbench.matrix.Job`) have their run in the
        store: those whose store key, as :func:`impactbench.matrix.run_jobs` computes it, is
        in the file (read back: a full disk still reads) or was found or written here."""
        from impactbench import store as store_mod
        from impactbench.matrix import job_inputs, job_settings

        keys = [store_mod.run_key(job_inputs(job, job_settings(job))) for job in jobs]
        there = set(self.kept)
        try:
            there.update(self.store.get(keys))
        except (ValueError, OSError):
            pass  # unreadable now: what this report found or wrote
        return sum(key in there for key in keys)

    def say_full(self, kept: int, total: int, unit: str = "runs") -> None:
        """The stderr line of a full store (once): how many of this report's ``total`` runs it
        keeps."""
        if self.full is None or self._said:
            return
        self._said = True
        print(f"impactbench: store '{self.path}': full after {kept} of {total} {unit} kept; "
              "the report is written from this run's results", file=sys.stderr, flush=True)
