"""Small helpers shared by the CLI subcommands: number parsing, JSON and table output.

Every parser imports this module (:class:`impactbench.cli.Parser` reads
:data:`NEGATIVE_NUMBER`), ``impactbench --help`` too, so it imports only what is already
loaded at start-up or costs little; the rest (JSON, the engine registry) on first use."""

from __future__ import annotations

import argparse
import math
import re
import sys
from collections.abc import Iterable, Mapping, Sequence
from typing import Any


def __getattr__(name: str) -> Any:
    """``stdout_to_stderr``: re-exported from :mod:`impactbench.engines.registry` on first use
    (importing the registry costs ~10 ms of the start-up budget)."""
    if name == "stdout_to_stderr":
        from impactbench.engines.registry import stdout_to_stderr

        return stdout_to_stderr
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")

NEGATIVE_NUMBER = re.compile(r"^-(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?$|^-(inf|infinity|nan)$",
                             re.IGNORECASE)
"""What a command-line word that starts with ``-`` must look like to be read as a negative
number, not an option: argparse's own pattern (``-1``, ``-.5``) misses the exponent form,
so ``--timestep -1e-3`` read as a missing argument instead of reaching the validator that
names the field and its rule (set on every parser by :class:`impactbench.cli.Parser`)."""


def number(text: str) -> float:
    """argparse type: a finite real number (the scenario checks sign and range)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"{text!r} is not a finite number")
    return value


def number_list(text: str) -> list[float]:
    """argparse type: one number or a comma-separated list (use with ``action='extend'``)."""
    parts = [p for p in text.split(",") if p.strip()]
    if not parts:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number or a comma list of numbers")
    return [number(p.strip()) for p in parts]


def param_value(text: str) -> Any:
    """A ``--param`` value: a TOML literal (``1e6``, ``[0.02, 1.0]``, ``true``, ``"sap"``), a
    comma list of numbers (``0.02,1``) or else a bare string (``sap``)."""
    import tomllib

    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        pass
    if "," in text:
        try:
            return [number(p.strip()) for p in text.split(",")]
        except argparse.ArgumentTypeError:
            pass
    return text.strip()


def key_value(text: str) -> tuple[str, Any]:
    """argparse type: ``KEY=VALUE`` (the value as :func:`param_value` reads it)."""
    key, sep, value = text.partition("=")
    if not sep or not key.strip():
        raise argparse.ArgumentTypeError(f"{text!r} is not KEY=VALUE")
    return key.strip(), param_value(value.strip())


def _jsonable(value: Any) -> Any:
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, Mapping):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    if hasattr(value, "item"):  # numpy scalars
        return _jsonable(value.item())
    return value


def print_json(obj: Any) -> None:
    """Print ``obj`` as JSON (NaN/inf become null, so the output is strict JSON)."""
    import json

    json.dump(_jsonable(obj), sys.stdout, indent=2)
    sys.stdout.write("\n")


def print_table(rows: Iterable[Mapping[str, Any]], columns: Sequence[str] | None = None,
                floatfmt: str = ".6g") -> None:
    """Print rows as a small aligned table."""
    from tabulate import tabulate

    rows = list(rows)
    columns = list(columns or (rows[0].keys() if rows else []))
    print(tabulate([[r.get(c) for c in columns] for r in rows], headers=columns,
                   floatfmt=floatfmt))


def damping_text(scenario: Any) -> str:
    """The damping of a Hunt–Crossley scenario as the reference commands print it
    (``nominal e = 0.8`` when set from a nominal restitution, else ``b = 0.1 s/m``)."""
    if scenario.nominal_restitution is not None:
        return f"nominal e = {scenario.nominal_restitution:g}"
    return f"b = {scenario.damping_s_per_m:g} s/m"


def print_points(results: Sequence[Mapping[str, Any]], as_json: bool, header: str,
                 columns: Sequence[str]) -> int:
    """A reference command's output, exit 0: JSON (one object, or a list for several points)
    or the ``header`` line, a table of ``columns`` and each point's message on stderr."""
    if as_json:
        print_json(results[0] if len(results) == 1 else list(results))
        return 0
    print(header)
    print_table(results, columns, floatfmt=".8g")
    for r in results:
        if r["message"]:
            print(f"{r['status']}: {r['message']}", file=sys.stderr)
    return 0


def interruptible(fn: Any, *args: Any) -> Any:
    """``fn(*args)`` in a daemon thread while this (main) thread waits in short joins, so
    Ctrl-C (and SIGTERM or SIGHUP, routed to KeyboardInterrupt by the CLI) stops the command
    at once even while compiled code that releases the GIL computes (the 2-DOF kernel: a
    signal handler runs only between Python bytecodes, so a call into it from this thread
    could not be interrupted before it returned). Its exception, if any, is re-raised here."""
    import threading

    box: dict[str, Any] = {}

    def target() -> None:
        try:
            box["value"] = fn(*args)
        except BaseException as exc:
            box["error"] = exc

    thread = threading.Thread(target=target, daemon=True, name="impactbench-solve")
    thread.start()
    while thread.is_alive():
        thread.join(0.05)
    if "error" in box:
        raise box["error"]
    return box["value"]


MAX_GRID_POINTS = 100_000_000
TABLE_FORMATS = (".csv", ".parquet")


def grid(start: float, stop: float, step: float, *, yes: bool = True, per_value: int = 1):
    """The sweep grid start, start + step, …, ≤ stop (stop included within 1e-9 of a step),
    computed as start + i·step. Every swept quantity (velocity, stiffness, mass) is > 0.

    ``yes = False`` refuses more than :data:`COST_LIMIT` points (``per_value`` solves per
    grid value, e.g. law combinations) before anything is allocated."""
    import math

    import numpy as np

    from impactbench.reference import validation as check

    check.positive("start", start)
    check.positive("step", step)
    check.positive("stop", stop)
    if stop < start:
        raise ValueError(f"stop = {stop!r}: must be >= start ({start!r})")
    count = math.floor((stop - start) / step + 1e-9) + 1
    if count > MAX_GRID_POINTS:
        raise ValueError(f"step = {step!r}: gives {count} points, must give <= "
                         f"{MAX_GRID_POINTS}")
    check_cost(count * per_value, f"step = {step!r}", yes, "sweep points")
    return start + step * np.arange(count, dtype=float)


def table_format(path) -> str:
    """``csv`` or ``parquet`` from the file's extension; one-line error otherwise."""
    suffix = path.suffix.lower()
    if suffix not in TABLE_FORMATS:
        raise ValueError(f"out = {str(path)!r}: must end in .csv or .parquet")
    return suffix[1:]


def write_table(table, path) -> None:
    """Write a DataFrame, or a mapping of column name to 1-D array (no pandas needed), as CSV
    or Parquet by extension, with pyarrow (full float64 precision: the CSV round-trips
    exactly). Atomic: written beside ``path`` and renamed, so an interrupted write never
    leaves half a table."""
    import os
    from collections.abc import Mapping

    import pyarrow as pa

    fmt = table_format(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    if isinstance(table, Mapping):
        import numpy as np

        def column(values):
            arr = np.asarray(values)
            if arr.ndim != 1 or arr.dtype != np.float64:
                return pa.array(arr)
            # pa.array would import pandas (~0.2 s) to check the type: wrap the buffer
            arr = np.ascontiguousarray(arr)
            return pa.Array.from_buffers(pa.float64(), len(arr), [None, pa.py_buffer(arr)])

        arrow = pa.Table.from_arrays([column(v) for v in table.values()],
                                     names=[str(k) for k in table])
    else:
        arrow = pa.Table.from_pandas(table, preserve_index=False)
    part = path.with_name(f".{path.name}.part")
    try:
        if fmt == "parquet":
            import pyarrow.parquet as pq

            pq.write_table(arrow, part)
        else:
            import pyarrow.csv as pacsv

            pacsv.write_csv(arrow, part)
        os.replace(part, path)
    finally:
        part.unlink(missing_ok=True)


def progress_bar(total: int, unit: str = "run"):
    """Progress of ``total`` items on stderr; returns (update, close).

    On a terminal a tqdm bar; elsewhere (CI logs, pipes) a line at the first item done, then
    one at most every :data:`PROGRESS_EVERY_S` seconds (``update(0)``, a heartbeat, prints
    one even when nothing finished) and a last one at the end, so a long run is never silent.
    Each line says the time left: the work's own estimate where the caller gives one,
    ``update.left(seconds)`` (a run matrix's, :class:`impactbench.matrix.TimeLeft`: each
    run's estimated cost, learnt as runs finish, so a line has it from the start), counted
    down between calls (to a fifth of it at most); else, from :data:`ETA_AFTER_S` on, the
    items not done at the rate of those done since the first update (what a store served at
    once does not count). On a terminal the caller's estimate is the bar's postfix.
    """
    import time

    said_left: dict[str, float] = {}

    def left(seconds: float) -> None:
        """The caller's estimate of the seconds left, now."""
        said_left.update(seconds=max(0.0, float(seconds)), at=time.monotonic())

    def given(now: float) -> float | None:
        # counted down since it was given, to no less than a fifth of it (a run that takes
        # longer than estimated leaves its time left there until the next estimate)
        if not said_left:
            return None
        return max(0.2 * said_left["seconds"], said_left["seconds"] - (now - said_left["at"]))

    if sys.stderr.isatty():
        from tqdm import tqdm

        bar = tqdm(total=total, unit=unit, file=sys.stderr)

        def update_bar(n: int) -> None:
            est = given(time.monotonic())
            if est is not None:
                bar.set_postfix_str(f"about {_duration(est)} left", refresh=False)
            bar.update(n)

        update_bar.left = left  # type: ignore[attr-defined]
        return update_bar, bar.close

    state: dict[str, Any] = {"done": 0, "last": time.monotonic(), "start": time.monotonic(),
                             "said": None, "first": None}

    def update(n: int) -> None:
        """``n`` more done (0: nothing new; a line still every PROGRESS_EVERY_S)."""
        state["done"] += n
        now = time.monotonic()
        if n and state["first"] is None:  # the rate counts from here (a store serves at once)
            state["first"] = (now, state["done"])
        if (n and state["said"] is None) or now - state["last"] >= PROGRESS_EVERY_S:
            state["last"] = now
            state["said"] = state["done"]
            est = given(now)
            more = (f", about {_duration(est)} left" if est is not None and
                    state["done"] < total else _left(state, total, now))
            print(f"impactbench: {state['done']} of {total} {unit}s done "
                  f"({now - state['start']:.0f} s{more})", file=sys.stderr, flush=True)

    def close() -> None:
        if state["said"] is not None:
            print(f"impactbench: {state['done']} of {total} {unit}s done", file=sys.stderr,
                  flush=True)

    update.left = left  # type: ignore[attr-defined]
    return update, close


PROGRESS_EVERY_S = 10.0
ETA_AFTER_S = 10.0
"""How long a progress line waits before estimating the time left from its own rate (a rate
from fewer seconds says little)."""


def _duration(seconds: float) -> str:
    """``37 s`` below two minutes, else ``4 min``."""
    return f"{seconds:.0f} s" if seconds < 120 else f"{seconds / 60:.0f} min"


def _left(state: Mapping[str, Any], total: int, now: float) -> str:
    """``", about 3 min left"``: the items not done at the rate of those done since the
    first update; "" before :data:`ETA_AFTER_S` or without a rate."""
    if state["first"] is None or now - state["start"] < ETA_AFTER_S:
        return ""
    since, at = state["first"]
    rate = (state["done"] - at) / (now - since) if now > since else 0.0
    if rate <= 0.0 or state["done"] >= total:
        return ""
    return f", about {_duration((total - state['done']) / rate)} left"


COST_LIMIT = 10_000_000
"""Runs over this many integration steps, or sweeps over this many points, need ``--yes``."""


def check_cost(count: float, what: str, yes: bool, detail: str = "",
               yes_flag: str = "--yes") -> None:
    """Refuse (one line, exit 2) a job of more than :data:`COST_LIMIT` steps or points
    unless ``--yes`` was given (``yes_flag``: how the caller says yes, ``yes=True`` in
    Python)."""
    if count > COST_LIMIT and not yes:
        more = f" ({detail})" if detail else ""
        raise ValueError(f"{what}: about {count:.3g}{more}, more than {COST_LIMIT:.0e}; "
                         f"pass {yes_flag} to run it anyway")


def add_execution_flags(p: argparse.ArgumentParser, *, yes: bool = True,
                        in_process: bool = False, timeout: bool = False,
                        config: bool = True, workers_aliases: Sequence[str] = ()) -> None:
    """``--workers`` (and ``workers_aliases``), ``--scheduler``, ``--fresh``, ``--store``,
    ``--store-reset``, (``yes``) ``--yes`` and (``timeout``) ``--timeout`` (``config``: a
    config's ``[execution] timeout_s`` is its default); ``in_process``: ``--workers 0`` runs
    in this process."""
    g = p.add_argument_group("execution and results store")
    g.add_argument("--workers", *workers_aliases, type=int, default=None, dest="workers",
                   metavar="N",
                   help="local worker processes (default and at most: one per core available"
                   + ("; 0: in this process, without crash isolation)" if in_process else ")"))
    if timeout:
        add_timeout_flag(g, config)
    g.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="run on an existing Dask scheduler, e.g. tcp://10.0.0.5:8786 "
                   "(default: a local cluster; also $IMPACTBENCH_SCHEDULER)")
    g.add_argument("--fresh", action="store_true",
                   help="ignore stored runs and run everything again (results are stored)")
    g.add_argument("--store", type=_path, default=None, metavar="FILE",
                   help="results store (DuckDB); default $IMPACTBENCH_STORE or "
                   "~/.cache/impactbench/results.duckdb")
    add_store_reset_flag(g)
    if yes:
        add_yes_flag(g, f"the estimate exceeds {COST_LIMIT:.0e} steps (or sweep points)")


def add_yes_flag(g: Any, what: str) -> None:
    """``--yes``: run even when ``what`` (the cost check, :func:`check_cost`)."""
    g.add_argument("--yes", action="store_true", help=f"run even when {what}")


def add_timeout_flag(g: Any, config: bool = True, help: str | None = None) -> None:
    """``--timeout S`` (``timeout_s``): the per-run timeout of engine runs (``config``: a
    config's ``[execution] timeout_s`` is the default; ``help``: another text)."""
    g.add_argument("--timeout", type=number, default=None, metavar="S", dest="timeout_s",
                   help=help or "cancel an engine run after S seconds (a `timeout` row; its "
                   "worker is restarted); default " + ("[execution] timeout_s, else "
                                                       if config else "")
                   + "max(60 s, 20 x the run's estimate)")


def add_store_reset_flag(g: Any) -> None:
    """``--store-reset``: a damaged store is moved aside (``impactbench.store``)."""
    g.add_argument("--store-reset", action="store_true",
                   help="if the results store is damaged (truncated, not DuckDB), move it "
                   "aside (FILE.corrupt-<time>) and start a new one")


def check_workers(workers: int | None, scheduler: str | None = None) -> int | None:
    """``--workers``: None or >= 0 (0: in this process). More than the cores available are
    capped at them (a local cluster; one line on stderr says so)."""
    if workers is None:
        return None
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 0:
        raise ValueError(f"workers = {workers!r}: must be an integer >= 0 (0: in this "
                         "process)")
    import os

    from impactbench.cluster import SCHEDULER_ENV, available_cores

    cores = available_cores()
    if workers > cores and not (scheduler or os.environ.get(SCHEDULER_ENV)):
        print(f"impactbench: workers = {workers}: capped at {cores}, the cores available",
              file=sys.stderr)
        return cores
    return workers


def flag_names(parser: argparse.ArgumentParser) -> dict[str, str]:
    """Each option's keyword (its ``dest``) → its flag (``timestep_s`` → ``--timestep``): how
    :func:`impactbench.api.command_line` names the flags in errors."""
    return {a.dest: a.option_strings[0] for a in parser._actions
            if a.option_strings and a.dest != argparse.SUPPRESS}


def timeout_option(value: float | None, cfg: Any = None, name: str = "timeout"
                   ) -> float | None:
    """The per-run timeout (s): ``value`` (``--timeout``), else the config's ``[execution]
    timeout_s``, else None (each run's default, :func:`impactbench.cluster.default_timeout`);
    ``name`` is what a bad value is called in the error."""
    if value is None:
        value = dict(getattr(cfg, "execution", {}) or {}).get("timeout_s")
    if value is not None and (isinstance(value, bool) or not isinstance(value, int | float)
                              or not (math.isfinite(value) and value > 0)):
        raise ValueError(f"{name} = {value!r}: must be a number of seconds > 0")
    return None if value is None else float(value)


def _path(text: str):
    from pathlib import Path

    return Path(text)


def execution_options(cfg: Any = None, *, workers: int | None = None,
                      scheduler: str | None = None, store: Any = None, fresh: bool = False,
                      yes: bool = False) -> dict[str, Any]:
    """Keyword arguments for :func:`impactbench.matrix.run_jobs`: the given ones (the flags),
    then the config's ``[execution]`` table (scheduler, workers, store), then the defaults.
    (The timeout: :func:`timeout_option`.)"""
    from impactbench.store import Store, default_path

    table = dict(getattr(cfg, "execution", {}) or {})
    scheduler = scheduler or table.get("scheduler")
    workers = check_workers(workers if workers is not None else table.get("workers"),
                            scheduler)
    path = store or (table.get("store") and _path(table["store"])) or default_path()
    return {"workers": workers, "scheduler": scheduler,
            "store": Store(path), "fresh": bool(fresh), "yes": bool(yes)}
