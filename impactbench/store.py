"""The results store: finished engine runs kept in one DuckDB file, so nothing is run twice.

One row per run and metric (table ``results``, for queries and ``impactbench history``), the
run's whole comparison object as JSON (table ``runs``, what a rerun reads back) and the thinned
force history of runs that feed plots (table ``histories``). A run is keyed by
:func:`run_key`, a SHA-256 of everything that determines it: the scenario's physical
parameters (SI), the mode, the run settings (timestep, tuned parameters, custom engine
parameters, options), the engine and its installed version, and impactbench's version with a
hash of its source (so an edited adapter or metric never serves a stale result). ``report``
and ``gate`` look runs up here and run only what is missing; an interrupted report resumes
from what it stored.

Reference sweeps (``impactbench sweep rigid-flexible`` and the paper figures) keep their
points in ``sweep_points``: one row per point, keyed by :func:`sweep_key` (the solver, its
law combination, the fixed parameters and impactbench's version) and the swept value, read
and written a whole sweep at a time through Arrow, so a 60,000-point lookup takes well under a
second while solving takes seconds (``python -m benchmarks two_dof``). Overlapping ranges share
their points. (The closed-form ball sweep is not stored: 10⁶ points compute in 0.65 s, the
per-point Kelvin–Voigt models in 3.8 s, so a store would save little on a rerun and cost a
write on every first run.)

Default location: ``$IMPACTBENCH_STORE``, else ``$XDG_CACHE_HOME/impactbench/results.duckdb``
(``~/.cache/impactbench/results.duckdb``): a per-user cache shared by every report folder, never
inside a committed report. ``crashed`` runs are not stored (a dying worker may be transient:
they rerun next time); every other status is.

DuckDB lets one process hold the file at a time, so the store opens it per lookup or write
and waits (up to :data:`LOCK_WAIT_S`, saying so on stderr after a second) when another process
has it open. A write still locked out after the wait is not lost: the runs go to a side file
beside the store (``results.duckdb.staged-<pid>-<time>.duckdb``, the same tables), merged into
the store by its next open (any command's), then removed.

A store DuckDB cannot read (truncated, overwritten) is a one-line error naming it; with
``--store-reset`` (:data:`RESET_CORRUPT`) it is moved aside to
``results.duckdb.corrupt-<time>`` and a new store started. An I/O fault (a full disk) is a
one-line error; DuckDB's transactions leave the file as it was.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import re
import sys
import time
from collections.abc import Callable, Iterable, Iterator, Mapping
from dataclasses import asdict
from functools import cache
from pathlib import Path
from typing import Any

from impactbench.engines.registry import SPECS, is_builtin

STORE_ENV = "IMPACTBENCH_STORE"
LOCK_WAIT_S = 30.0
"""How long to wait for another process to release the store file."""
SAY_WAIT_AFTER_S = 1.0
"""A wait for the lock longer than this is announced on stderr (once per store)."""
RESET_CORRUPT = False
"""Move a corrupt store aside and start a new one (``--store-reset``) instead of failing."""
STAGED = ".staged-"
CORRUPT = ".corrupt-"
TABLES = ("results", "runs", "histories", "history_series", "sweep_points")
_CORRUPT_SIGNS = ("not a valid duckdb", "could not read enough bytes", "checksum", "corrupt",
                  "serialization error", "truncated to")
"""Words of a DuckDB error that mean the file's content is damaged (not a full disk, a
permission, a lock or a newer DuckDB's file: those are one-line errors, never moved aside)."""


def _has_table(con: Any, name: str) -> bool:
    """Whether the connected store has table ``name`` (a store written by an older
    impactbench may lack a newer table until its next write creates it)."""
    return bool(con.execute("SELECT count(*) FROM information_schema.tables WHERE "
                            "table_name = ?", [name]).fetchone()[0])


class StoreLocked(ValueError):
    """The store file stayed locked by another process for :data:`LOCK_WAIT_S`."""


_SCHEMA = """
CREATE TABLE IF NOT EXISTS results (
    run_key VARCHAR NOT NULL,
    metric VARCHAR NOT NULL,
    value DOUBLE,
    reference DOUBLE,
    rel_error DOUBLE,
    not_comparable VARCHAR,
    status VARCHAR NOT NULL,
    message VARCHAR,
    engine VARCHAR NOT NULL,
    engine_version VARCHAR,
    mode VARCHAR NOT NULL,
    scenario VARCHAR NOT NULL,
    point VARCHAR,
    timestep_s DOUBLE,
    wall_s DOUBLE,
    impactbench_version VARCHAR NOT NULL,
    inputs VARCHAR NOT NULL,
    stored_at DOUBLE NOT NULL,
    study VARCHAR,
    PRIMARY KEY (run_key, metric)
);
ALTER TABLE results ADD COLUMN IF NOT EXISTS study VARCHAR;
ALTER TABLE results ADD COLUMN IF NOT EXISTS point VARCHAR;
CREATE TABLE IF NOT EXISTS runs (
    run_key VARCHAR PRIMARY KEY,
    run VARCHAR NOT NULL
);
CREATE TABLE IF NOT EXISTS sweep_points (
    base_key VARCHAR NOT NULL,
    value DOUBLE NOT NULL,
    peak_force_n DOUBLE,
    pulse_width_s DOUBLE,
    contact_time_s DOUBLE,
    impulse_ns DOUBLE,
    impacts BIGINT,
    status VARCHAR NOT NULL,
    stored_at DOUBLE NOT NULL,
    PRIMARY KEY (base_key, value)
);
CREATE TABLE IF NOT EXISTS histories (
    run_key VARCHAR PRIMARY KEY,
    time_s DOUBLE[],
    normal_force_n DOUBLE[],
    penetration_m DOUBLE[]
);
CREATE TABLE IF NOT EXISTS history_series (
    run_key VARCHAR NOT NULL,
    name VARCHAR NOT NULL,
    series DOUBLE[],
    PRIMARY KEY (run_key, name)
);
"""
_MIGRATE_POINT = """
UPDATE results SET point = CASE WHEN local IS NULL OR local = ''
    THEN json_object('velocity_m_s', velocity_m_s)
    ELSE json_object('local', local, 'structure', structure, 'velocity_m_s', velocity_m_s) END
    WHERE point IS NULL;
ALTER TABLE results DROP COLUMN local;
ALTER TABLE results DROP COLUMN structure;
ALTER TABLE results DROP COLUMN velocity_m_s;
"""
"""A store written before scenarios became specs kept a run's point in three columns
(``local``, ``structure``, ``velocity_m_s``); one JSON ``point`` column holds any scenario's."""
HISTORY_KEYS = ("time_s", "normal_force_n", "penetration_m")
SERIES = "series"
"""The key of a ``histories`` row's other series, on their way to ``history_series``."""
"""The force history's series, the columns of ``histories``. A history's other series (the
cube tosses' picked trajectories: :meth:`~impactbench.scenarios.spec.ScenarioSpec.
kept_history`) are rows of ``history_series``, one per run and name."""
POINT_KEYS = ("peak_force_n", "pulse_width_s", "contact_time_s", "impulse_ns", "impacts")
"""The metric columns of ``sweep_points``: the 2-DOF solver's ``METRIC_KEYS`` (tested equal)."""
CANDIDATE = "tune"
"""The ``study`` of a run stored by a tuning search: a candidate parameter point, not a
setting anyone runs, so ``impactbench history`` leaves it out. (A report never shares its
key: a tuned file's run carries the file's provenance in its settings.)"""


def default_path() -> Path:
    """``$IMPACTBENCH_STORE``, else the per-user cache ``…/impactbench/results.duckdb``."""
    if os.environ.get(STORE_ENV):
        return Path(os.environ[STORE_ENV]).expanduser()
    from impactbench.engines.compile_caches import cache_home

    return cache_home() / "impactbench" / "results.duckdb"


@cache
def impactbench_version() -> str:
    """``<release>+<source hash>``: the package version and a hash of every Python source
    file of impactbench (suite, reference solvers, adapters). Any code change is a new
    version, so the store never serves a result an edited adapter would not give."""
    from importlib import metadata

    import impactbench
    import impactbench.engines
    import impactbench.reference

    try:
        release = metadata.version("impactbench")
    except metadata.PackageNotFoundError:
        release = "0+unknown"
    digest = hashlib.sha256()
    for package in (impactbench, impactbench.reference, impactbench.engines):
        _hash_sources(digest, Path(package.__file__).parent)
    return f"{release}+{digest.hexdigest()[:10]}"


def _hash_sources(digest: Any, root: Path) -> None:
    for path in sorted(root.rglob("*.py")):
        digest.update(str(path.relative_to(root)).encode())
        digest.update(path.read_bytes())


@cache
def source_version(package: str) -> str:
    """A hash of a plug-in package's Python source (its scenario and builders), so an edited
    plug-in is never served a stale stored run."""
    import importlib

    module = importlib.import_module(package)
    digest = hashlib.sha256()
    if getattr(module, "__path__", None):
        _hash_sources(digest, Path(module.__file__).parent)
    else:
        digest.update(Path(module.__file__).read_bytes())
    return digest.hexdigest()[:10]


@cache
def engine_version(engine: str) -> str:
    """The installed version of ``engine`` without starting it (package metadata); a plug-in
    adapter's own ``version()``; ``not installed`` when its package is missing."""

    from impactbench.engines.base import DISABLE_ENV, EngineUnavailable, get_adapter

    disabled = {x.strip() for x in os.environ.get(DISABLE_ENV, "").split(",")}
    if engine in disabled:
        return "disabled"
    if engine_is_builtin(engine):
        spec = SPECS[engine]
        version = _installed_version(spec.distribution, spec.module.partition(".")[0])
        if version is not None:
            return version
    try:
        from impactbench.engines.registry import stdout_to_stderr

        with stdout_to_stderr():
            return get_adapter(engine).version()
    except (EngineUnavailable, ImportError):
        return "not installed"


def _installed_version(dist: str, module: str) -> str | None:
    """The distribution's version when ``module`` would be imported from that distribution;
    None when unsure (e.g. another module of that name shadows it on ``sys.path``)."""
    import importlib.util
    from importlib import metadata

    try:
        version = metadata.version(dist)
        spec = importlib.util.find_spec(module)
        root = Path(metadata.distribution(dist).locate_file("")).resolve()
    except (metadata.PackageNotFoundError, ImportError, ValueError):
        return None
    if spec is None or not spec.origin:
        return None
    return version if Path(spec.origin).resolve().is_relative_to(root) else None


def engine_is_builtin(engine: str) -> bool:
    """True when ``engine`` is one of the packaged adapters (not replaced by a plug-in)."""
    return is_builtin(engine)


def _canonical(value: Any) -> Any:
    """JSON-stable form: floats by repr (exact), NaN/inf as strings, mappings sorted."""
    if isinstance(value, float):
        return repr(value)
    if isinstance(value, Mapping):
        return {str(k): _canonical(v) for k, v in sorted(value.items(), key=lambda kv: str(kv[0]))}
    if isinstance(value, (list, tuple)):
        return [_canonical(v) for v in value]
    if hasattr(value, "item"):
        return _canonical(value.item())
    return value


def run_inputs(engine: str, scenario_name: str, scenario: Any, mode: str,
               settings: Any) -> dict[str, Any]:
    """Everything that determines one run, as a JSON-able dict (hashed by :func:`run_key`).

    ``settings`` is the :class:`~impactbench.engines.base.RunSettings` the run gets: its every
    field (timestep_s, max_time_s, tuned, params, options, and whatever is added later) is in.
    """
    inputs = {
        "engine": engine,
        "engine_version": engine_version(engine),
        "impactbench_version": impactbench_version(),
        "scenario": scenario_name,
        "physics": scenario.to_dict(),
        "mode": mode,
        "settings": asdict(settings),
    }
    from impactbench.scenarios import get

    more = get(scenario_name).store_inputs(engine, scenario, mode)
    if more:  # what the settings do not hold (a data file's content)
        inputs["inputs"] = more
    package = type(scenario).__module__.partition(".")[0]
    if package != "impactbench":  # a plug-in's scenario and builders: its source counts too
        inputs["plugin_version"] = source_version(package)
    return _canonical(inputs)


def sweep_key(solver: str, scenario: Any, over: str, swept_field: str) -> str:
    """Key of a sweep's points (a point is this key and its swept value): SHA-256 of the
    solver, impactbench's version, ``over`` and the scenario's physics without the swept
    field (so sweeps that differ only in their ranges share points). A k1 sweep keeps k1:
    the solver scales kt and k1' with the swept k1 by their ratios to it."""
    physics = scenario.to_dict()
    if over != "k1":
        physics.pop(swept_field)
    return run_key(_canonical({"solver": solver, "impactbench_version": impactbench_version(),
                               "over": over, "physics": physics}))


def run_key(inputs: Mapping[str, Any]) -> str:
    """SHA-256 (32 hex digits) of the canonical JSON of :func:`run_inputs`."""
    blob = json.dumps(inputs, sort_keys=True, separators=(",", ":")).encode()
    return hashlib.sha256(blob).hexdigest()[:32]


def _float(value: Any) -> float | None:
    if value is None:
        return None
    try:
        return float(value)
    except (TypeError, ValueError):
        return None


def _plain(value: Any) -> Any:
    """JSON fallback for numpy scalars and other odd values in a run object."""
    if hasattr(value, "item"):
        return value.item()
    return str(value)


def _first_line(exc: BaseException) -> str:
    return (str(exc).splitlines() or [type(exc).__name__])[0]


def _holder(text: str) -> str:
    """`` (PID 1234)`` from DuckDB's lock error, '' when it does not say."""
    m = re.search(r"PID (\d+)", text)
    return f" (pid {m.group(1)})" if m else ""


def _stamp() -> str:
    return time.strftime("%Y%m%dT%H%M%S")


class _Interruptible:
    """A DuckDB connection whose calls hand an interrupt on as one: DuckDB turns a
    KeyboardInterrupt raised while a query runs (Ctrl-C, or SIGTERM/SIGHUP, which the command
    line routes the same way) into ``RuntimeError("Query interrupted")``, which neither the
    store's nor the command line's Ctrl-C path would see (measured with duckdb 2.0.1: 5 of 60
    to 33 of 100 signals at random instants of back-to-back writes)."""

    def __init__(self, con: Any) -> None:
        self._con = con

    def __getattr__(self, name: str) -> Any:
        attr = getattr(self._con, name)
        return _interruptible(attr) if callable(attr) else attr


def _interruptible(function: Any) -> Any:
    """``function`` with DuckDB's ``RuntimeError("Query interrupted")`` (and an error that
    wraps a KeyboardInterrupt raised while DuckDB read a registered table's schema) raised as
    the KeyboardInterrupt it was (:class:`_Interruptible`); a DuckDB object it returns (the
    connection ``execute`` returns, a relation) is wrapped alike, so that its ``fetchall``
    hands an interrupt on too (measured: 1 of 400 signals came through one raw)."""

    def call(*args: Any, **kwargs: Any) -> Any:
        try:
            got = function(*args, **kwargs)
            return _Interruptible(got) if type(got).__module__.startswith(("duckdb", "_duckdb")) \
                else got
        except Exception as exc:  # RuntimeError, or a duckdb.Error that wraps the interrupt
            text = str(exc)
            if "Query interrupted" in text or "KeyboardInterrupt" in text:
                raise KeyboardInterrupt from None
            raise

    return call


class Store:
    """A DuckDB results file. ``get`` and ``put`` open it briefly (one process at a time)."""

    def __init__(self, path: str | Path, *, staging: bool = False) -> None:
        self.path = Path(path)
        self._staging = staging
        """A side file of another store (no merging into it, no staging of its own)."""
        self._side: Path | None = None
        self._said_wait = False
        self.staged = 0
        """Runs (or sweep points) this store wrote to its side file (store locked)."""

    def _say(self, line: str) -> None:
        print(f"impactbench: {line}", file=sys.stderr, flush=True)

    def _open(self, read_only: bool):
        """``duckdb.connect``, waiting up to :data:`LOCK_WAIT_S` for another process's lock
        (announced after :data:`SAY_WAIT_AFTER_S`); :class:`StoreLocked` after that."""
        import duckdb

        t0 = time.monotonic()
        while True:
            try:
                return _Interruptible(_interruptible(duckdb.connect)(str(self.path),
                                                                    read_only=read_only))
            except duckdb.IOException as exc:
                text = _first_line(exc)
                if "lock" not in text.lower():
                    raise
                waited = time.monotonic() - t0
                if waited > LOCK_WAIT_S or (self.staged and not read_only):
                    # once a write was staged, the next ones go there without waiting
                    raise StoreLocked(f"store = '{self.path}': locked by another process"
                                      f"{_holder(text)} for {LOCK_WAIT_S:g} s") from None
                if waited > SAY_WAIT_AFTER_S and not self._said_wait:
                    self._said_wait = True
                    self._say(f"store '{self.path}' is locked by another process"
                              f"{_holder(text)}; waiting up to {LOCK_WAIT_S:g} s")
                time.sleep(0.1)

    def _connect(self, read_only: bool = False):
        import duckdb

        if not self._staging:
            self._merge_staged()
        if read_only and not self.path.exists():
            return None
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise ValueError(f"store = '{self.path}': cannot create its folder "
                             f"({exc.strerror})") from None
        try:
            con = self._open(read_only)
            self._check_size(con)
        except StoreLocked:
            raise
        except duckdb.Error as exc:
            self._broken(exc)  # raises, unless the store was moved aside
            if read_only:
                return None
            con = self._open(read_only)
        if not read_only:
            try:
                self._prepare(con)
            except duckdb.Error as exc:
                con.close()
                self._broken(exc)
                con = self._open(read_only)
                self._prepare(con)
        return con

    def _check_size(self, con: Any) -> None:
        """A file shorter than its blocks in use (truncated: a full disk, a copy cut short)
        is damaged, though DuckDB opens it and fails only on the missing blocks."""
        import duckdb

        block, blocks = con.execute("SELECT block_size, used_blocks FROM "
                                    "pragma_database_size()").fetchone()
        size = self.path.stat().st_size
        if size < block * blocks:  # a healthy file holds at least every block in use
            con.close()
            raise duckdb.IOException(f"truncated to {size} bytes, its {blocks} blocks in use "
                                     f"need {block * blocks}")

    @staticmethod
    def _prepare(con: Any) -> None:
        con.execute(_SCHEMA)
        columns = {r[0] for r in con.execute(
            "SELECT column_name FROM information_schema.columns WHERE table_name = "
            "'results'").fetchall()}
        if "local" in columns:  # written before points: a one-time migration
            con.execute(_MIGRATE_POINT)

    def _broken(self, exc: BaseException) -> None:
        """A DuckDB error opening or using the file: a one-line ValueError, or (a damaged
        file and :data:`RESET_CORRUPT`) the file moved aside for a new store."""
        text = _first_line(exc)
        if not any(sign in text.lower() for sign in _CORRUPT_SIGNS):
            raise ValueError(f"store = '{self.path}': cannot use it ({text})") from None
        if not RESET_CORRUPT:
            raise ValueError(f"store = '{self.path}': damaged, not a readable results store "
                             f"({text}); --store-reset moves it aside and starts a new "
                             "one") from None
        aside = self.path.with_name(f"{self.path.name}{CORRUPT}{_stamp()}")
        try:
            os.replace(self.path, aside)
            wal = self.path.with_name(self.path.name + ".wal")
            if wal.exists():
                os.replace(wal, aside.with_name(aside.name + ".wal"))
        except OSError as err:
            raise ValueError(f"store = '{self.path}': damaged ({text}) and cannot be moved "
                             f"aside ({err.strerror})") from None
        self._say(f"store '{self.path}' was damaged ({text}); moved aside to '{aside}', "
                  "starting a new one")

    def _guarded(self, op: Callable[[], Any], again: Callable[[], Any]) -> Any:
        """``op()``; a damaged file found while using it is :meth:`_broken`'s (then
        ``again()`` on the new store)."""
        import duckdb

        try:
            return op()
        except StoreLocked:
            raise
        except duckdb.Error as exc:
            self._broken(exc)
            return again()

    def _staged_files(self) -> list[Path]:
        try:
            return sorted(p for p in self.path.parent.glob(f"{self.path.name}{STAGED}*")
                          if p.suffix == ".duckdb")
        except OSError:
            return []

    def _merge_staged(self) -> None:
        """Merge the side files of writes that found the store locked (then remove them).
        A side file still open by its writer (or the store itself locked) waits for the
        next open."""
        sides = self._staged_files()
        if not sides:
            return
        import duckdb

        try:
            con = duckdb.connect(str(self.path))
        except duckdb.Error:
            return  # locked or damaged: the next open tries again
        try:
            self._prepare(con)
            for side in sides:
                quoted = str(side).replace("'", "''")
                try:
                    con.execute(f"ATTACH '{quoted}' AS staged (READ_ONLY)")
                except duckdb.Error:
                    continue  # its writer holds it right now
                try:
                    have = {r[0] for r in con.execute(
                        "SELECT table_name FROM duckdb_tables() WHERE database_name = "
                        "'staged'").fetchall()}
                    con.execute("BEGIN")
                    for table in TABLES:
                        if table in have:
                            con.execute(f"INSERT OR REPLACE INTO main.{table} BY NAME "
                                        f"SELECT * FROM staged.{table}")
                    con.execute("COMMIT")
                except duckdb.Error:
                    with contextlib.suppress(duckdb.Error):
                        con.execute("ROLLBACK")
                    continue
                finally:
                    con.execute("DETACH staged")
                for path in (side, side.with_name(side.name + ".wal")):
                    path.unlink(missing_ok=True)
        except duckdb.Error:
            pass  # the store itself is damaged: the open that follows says so
        finally:
            con.close()

    def _side_store(self) -> Store:
        if self._side is None:
            self._side = self.path.with_name(
                f"{self.path.name}{STAGED}{os.getpid()}-{_stamp()}.duckdb")
        return Store(self._side, staging=True)

    def _stage(self, locked: StoreLocked, write: Callable[[Store], int], unit: str) -> int:
        """The store stayed locked: ``write`` into this process's side file instead."""
        if self._staging:
            raise locked
        side = self._side_store()
        n = write(side)
        if n and not self.staged:
            self._say(f"{locked}; {n} {unit} kept in '{side.path}' (merged into the store "
                      "when it is next opened)")
        self.staged += n
        return n

    @contextlib.contextmanager
    def _reader(self, *tables: str) -> Iterator[Any]:
        """A read-only connection, or None when the file or any of ``tables`` is missing
        (nothing stored yet)."""
        con = self._connect(read_only=True)
        if con is None:
            yield None
            return
        try:
            have = {r[0] for r in con.execute("SELECT table_name FROM information_schema"
                                              ".tables").fetchall()}
            yield con if set(tables) <= have else None
        finally:
            con.close()

    def get(self, keys: Iterable[str], *, with_history: Iterable[str] = ()
            ) -> dict[str, tuple[dict[str, Any], dict[str, Any]]]:
        """Stored runs among ``keys``: key → (run fields, history). A key in
        ``with_history`` counts as stored only when its history is stored too."""
        keys, with_history = list(keys), list(with_history)
        return self._guarded(lambda: self._get(keys, with_history), dict)

    def _get(self, keys: list[str], with_history: list[str]
             ) -> dict[str, tuple[dict[str, Any], dict[str, Any]]]:
        import numpy as np
        import pyarrow as pa

        keys = list(dict.fromkeys(keys))
        need_history = set(with_history)
        if not keys:
            return {}
        with self._reader("runs") as con:
            if con is None:
                return {}
            con.register("wanted", pa.table({"run_key": pa.array(keys, pa.string())}))
            rows = con.execute("SELECT r.run_key, run FROM runs r JOIN wanted USING (run_key)"
                               ).fetchall()
            hist_rows = con.execute(
                "SELECT h.run_key, time_s, normal_force_n, penetration_m FROM histories h "
                "JOIN wanted USING (run_key)").fetchall() if need_history else []
            series = con.execute(
                "SELECT s.run_key, name, series FROM history_series s "
                "JOIN wanted USING (run_key)").fetchall() if need_history and _has_table(
                    con, "history_series") else []  # (a store from before the table)
        histories = {key: {name: np.asarray(arr, dtype=float)
                           for name, arr in zip(HISTORY_KEYS, arrays, strict=True)}
                     if len(arrays[0]) else {}  # a run that recorded nothing
                     for key, *arrays in hist_rows}
        for key, name, arr in series:
            histories.setdefault(key, {})[name] = np.asarray(arr, dtype=float)
        out = {}
        for key, run in rows:
            if key in need_history and key not in histories:
                continue  # stored by a job that kept no history: run it again
            out[key] = (json.loads(run), histories.get(key, {}))
        return out

    def get_points(self, key: str, values: Iterable[float]):
        """Stored sweep points of ``key`` among ``values``: a DataFrame with ``value``,
        :data:`POINT_KEYS` and ``status`` (empty when none)."""
        import pandas as pd

        values = list(values)
        return self._guarded(lambda: self._get_points(key, values), lambda: pd.DataFrame(
            columns=["value", *POINT_KEYS, "status"]))

    def _get_points(self, key: str, values: list[float]):
        import pandas as pd
        import pyarrow as pa

        columns = ["value", *POINT_KEYS, "status"]
        with self._reader("sweep_points") as con:
            if con is None:
                return pd.DataFrame(columns=columns)
            con.register("wanted", pa.table({"value": pa.array(list(values), pa.float64())}))
            return con.execute(
                f"SELECT DISTINCT {', '.join(columns)} FROM sweep_points "
                "JOIN wanted USING (value) WHERE base_key = ?", [key]).df()

    def put_points(self, key: str, frame) -> int:
        """Store sweep points of ``key``: ``frame`` with ``value``, :data:`POINT_KEYS` and
        ``status``; ``crashed`` points are skipped. Returns the number written."""
        import pyarrow as pa

        frame = frame[frame["status"] != "crashed"]
        if frame.empty:
            return 0
        points = pa.Table.from_pandas(
            frame.assign(base_key=key, stored_at=time.time()), preserve_index=False)
        try:
            return self._guarded(lambda: self._put_points(points),
                                 lambda: self._put_points(points))
        except StoreLocked as locked:
            return self._stage(locked, lambda side: side._put_points(points), "points")

    def _put_points(self, points: Any) -> int:
        con = self._connect()
        try:
            con.register("points", points)
            con.execute("INSERT OR REPLACE INTO sweep_points BY NAME SELECT * FROM points")
        finally:
            con.close()
        return points.num_rows

    def runs_of(self, engine: str, impactbench_version: str) -> dict[str, dict[str, Any]]:
        """Every stored run of ``engine`` made by ``impactbench_version`` (key → run fields):
        one query for a search that looks up thousands of runs one batch at a time."""
        return self._guarded(lambda: self._runs_of(engine, impactbench_version), dict)

    def _runs_of(self, engine: str, impactbench_version: str) -> dict[str, dict[str, Any]]:
        with self._reader("runs", "results") as con:
            if con is None:
                return {}
            rows = con.execute(
                "SELECT run_key, run FROM runs WHERE run_key IN (SELECT run_key FROM results "
                "WHERE engine = ? AND impactbench_version = ?)",
                [engine, impactbench_version]).fetchall()
        return {key: json.loads(run) for key, run in rows}

    def put(self, entries: Iterable[tuple[str, Mapping[str, Any], Any,
                                          Mapping[str, Any], Mapping[str, Any]]]) -> int:
        """Store runs: (key, inputs, job, run object, history). The job is a
        :class:`~impactbench.matrix.RunKey` (or :class:`~impactbench.matrix.Job`) or a mapping
        with its ``engine``, ``mode``, ``scenario``, ``point`` and optionally ``study`` and
        ``keep_history``. ``crashed`` and ``timeout`` runs are skipped. Returns the number of
        runs written (to the store, or to its side file when it stayed locked)."""
        rows, runs, hist = self._rows(entries)
        if not rows:
            return 0
        try:
            return self._guarded(lambda: self._put(rows, runs, hist),
                                 lambda: self._put(rows, runs, hist))
        except StoreLocked as locked:
            return self._stage(locked, lambda side: side._put(rows, runs, hist), "runs")

    @staticmethod
    def _rows(entries: Iterable[tuple]) -> tuple[list[dict], list[dict], list[dict]]:
        rows: list[dict[str, Any]] = []
        runs: list[dict[str, Any]] = []
        hist: list[dict[str, Any]] = []
        now = time.time()
        for key, inputs, job_obj, run, history in entries:
            if run["status"] in ("crashed", "timeout"):
                continue
            job = job_obj if isinstance(job_obj, Mapping) else vars(job_obj)
            skip = run.get("not_comparable", {})
            runs.append({"run_key": key, "run": json.dumps(
                {k: v for k, v in run.items() if k != "reference"}, default=_plain)})
            for metric, rel in run["rel_error"].items():
                rows.append({
                    "run_key": key, "metric": metric, "value": _float(run.get(metric)),
                    "reference": _float(run.get("reference", {}).get(metric)),
                    "rel_error": _float(rel), "not_comparable": skip.get(metric),
                    "status": run["status"], "message": run.get("message", ""),
                    "engine": job["engine"], "engine_version": run.get("engine_version", ""),
                    "mode": job["mode"], "scenario": job["scenario"],
                    "point": json.dumps(dict(job.get("point", ())), separators=(",", ":"),
                                        default=_plain),
                    "timestep_s": _float(run.get("timestep_s")),
                    "wall_s": _float(run.get("wall_s")),
                    "impactbench_version": inputs["impactbench_version"],
                    "inputs": json.dumps(inputs, sort_keys=True), "stored_at": now,
                    "study": job.get("study", ""),
                })
            if history or job.get("keep_history"):  # none recorded (a failed run): empty
                # its other series ride along (``_put`` writes them to history_series)
                hist.append({"run_key": key, **{k: [float(x) for x in history.get(k, ())]
                                                for k in HISTORY_KEYS},
                             SERIES: [{"run_key": key, "name": k,
                                       "series": [float(x) for x in v]}
                                      for k, v in history.items() if k not in HISTORY_KEYS]})
        return rows, runs, hist

    def _put(self, rows: list[dict], runs: list[dict], hist: list[dict]) -> int:
        import pyarrow as pa

        con = self._connect()
        try:
            con.execute("BEGIN")
            con.register("results_table", pa.Table.from_pylist(rows))
            con.execute("INSERT OR REPLACE INTO results BY NAME SELECT * FROM results_table")
            con.register("runs_table", pa.Table.from_pylist(runs))
            con.execute("INSERT OR REPLACE INTO runs BY NAME SELECT * FROM runs_table")
            series = [one for h in hist for one in h.get(SERIES, ())]
            if hist:
                schema = pa.schema([("run_key", pa.string())]
                                   + [(k, pa.list_(pa.float64())) for k in HISTORY_KEYS])
                con.register("histories_table", pa.Table.from_pylist(
                    [{k: v for k, v in h.items() if k != SERIES} for h in hist], schema=schema))
                con.execute("INSERT OR REPLACE INTO histories BY NAME "
                            "SELECT * FROM histories_table")
            if series:
                con.register("series_table", pa.Table.from_pylist(
                    series, schema=pa.schema([("run_key", pa.string()), ("name", pa.string()),
                                              ("series", pa.list_(pa.float64()))])))
                con.execute("INSERT OR REPLACE INTO history_series BY NAME "
                            "SELECT * FROM series_table")
            con.execute("COMMIT")
        finally:
            con.close()
        return len({r["run_key"] for r in rows})

    def frame(self, engine: str | None = None):
        """Every stored row (one per run and metric) as a DataFrame, optionally one engine's."""
        import pandas as pd

        return self._guarded(lambda: self._frame(engine), pd.DataFrame)

    def _frame(self, engine: str | None):
        import pandas as pd

        with self._reader("results") as con:
            if con is None:
                return pd.DataFrame()
            query = "SELECT * EXCLUDE (inputs) FROM results"
            params: list[Any] = []
            if engine:
                query += " WHERE engine = ?"
                params.append(engine)
            return con.execute(query, params).df()
