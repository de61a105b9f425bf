"""A fresh default report (the README's ``make report``, install excluded), timed in phases.

The packaged default config is built in this process, as ``impactbench report`` builds it,
into a temporary folder with a new, empty results store (``fresh``: nothing is served; the
real-tosses replays, which use the default store, get it through ``$IMPACTBENCH_STORE``), on
a local cluster of one worker per core. The phases, each the wall time of the report's own
step (the step's function is wrapped with a timer; nothing else changes):

- ``imports``: ``python -c "import impactbench.report"`` against ``python -c pass``, as
  subprocesses, alternated, medians of :data:`IMPORT_ROUNDS`;
- ``runs``: the run matrix (:func:`impactbench.matrix.run_jobs` of the report's jobs);
  under it, per scenario × engine, the runs' own wall times summed (engine time: on Dask
  the runs overlap, so these add up to more than the phase);
- ``tosses``: the real-tosses replays (the measured scenario's report part, its
  ``run_jobs`` call);
- ``figures``: the report's figures;
- ``rendering``: the documents, the tosses' replays taken out;
- ``report``: the whole build, and the peak RSS of this process (the workers' apart).

Compile caches (MJX's on disk, warp's kernels) are as they are on this machine: warm after a
first run. ``IMPACTBENCH_BENCH_COLD=1`` runs the build in a subprocess whose caches point at
an empty folder (``XDG_CACHE_HOME``, ``WARP_CACHE_PATH``): the first report of a fresh
machine, install excluded. No earlier layout of this benchmark exists, so no ratio against
one is printed; the numbers are the baseline for #32's work.

Run: ``python -m benchmarks report``.
"""

from __future__ import annotations

import contextlib
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from collections import defaultdict
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

from benchmarks.alternate import alternate

IMPORT_ROUNDS = 5
COLD_ENV = "IMPACTBENCH_BENCH_COLD"
CHILD_ENV = "IMPACTBENCH_BENCH_REPORT_CHILD"


@contextlib.contextmanager
def timed(owner: Any, name: str, into: list[float],
          returns: list[Any] | None = None) -> Iterator[None]:
    """Within the block, every call of ``owner.name`` adds its wall time (s) to ``into`` (and
    its return value to ``returns``)."""
    original = getattr(owner, name)

    def wrapper(*args: Any, **kwargs: Any) -> Any:
        t0 = time.perf_counter()
        try:
            out = original(*args, **kwargs)
        finally:
            into.append(time.perf_counter() - t0)
        if returns is not None:
            returns.append(out)
        return out

    setattr(owner, name, wrapper)
    try:
        yield
    finally:
        setattr(owner, name, original)


@contextlib.contextmanager
def _env(**values: str) -> Iterator[None]:
    """Environment variables set within the block (the replays' store is the default one,
    ``$IMPACTBENCH_STORE``: here the fresh store too)."""
    before = {k: os.environ.get(k) for k in values}
    os.environ.update(values)
    try:
        yield
    finally:
        for k, v in before.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


def imports() -> tuple[float, float]:
    """Median wall times (s) of importing the report module and of a bare interpreter."""
    def run(code: str) -> Callable[[], Any]:
        return lambda: subprocess.run([sys.executable, "-c", code], check=True)

    times = alternate({"report": run("import impactbench.report"), "bare": run("pass")},
                      IMPORT_ROUNDS)
    return statistics.median(times["report"]), statistics.median(times["bare"])


def build() -> dict[str, Any]:
    """Build the default report fresh; the phases' wall times (s) and engine times."""
    from impactbench import config, matrix, report
    from impactbench.store import Store

    phases: dict[str, list[float]] = defaultdict(list)
    engine_s: dict[str, float] = defaultdict(float)
    matrices: list[list[Any]] = []
    with tempfile.TemporaryDirectory() as tmp, \
            _env(IMPACTBENCH_STORE=str(Path(tmp) / "store.duckdb")), \
            timed(report, "run_jobs", phases["runs"], matrices), \
            timed(matrix, "run_jobs", phases["tosses"]), \
            timed(report, "_figures", phases["figures"]), \
            timed(report, "render_documents", phases["documents"]):
        t0 = time.perf_counter()
        report.build(config.load(None), Path(tmp) / "report", store=Store(
            Path(tmp) / "store.duckdb"), fresh=True, show_progress=False)
        total = time.perf_counter() - t0
    runs = [r for results in matrices for r in results]
    for r in runs:
        wall = float(r.run.get("wall_s", float("nan")))
        if wall == wall:  # (not NaN)
            engine_s[f"{r.job.scenario} × {r.job.engine}"] += wall
    tosses, documents = sum(phases["tosses"]), sum(phases["documents"])
    return {"report": total, "runs": sum(phases["runs"]), "tosses": tosses,
            "figures": sum(phases["figures"]), "rendering": documents - tosses,
            "runs_total": len(runs), "engine_s": dict(engine_s),
            "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0}


def measured() -> dict[str, Any]:
    """:func:`build` here, or with cold caches in a subprocess (:data:`COLD_ENV`)."""
    if not os.environ.get(COLD_ENV) or os.environ.get(CHILD_ENV):
        return build()
    with tempfile.TemporaryDirectory() as caches:
        env = {**os.environ, CHILD_ENV: "1", "XDG_CACHE_HOME": caches,
               "WARP_CACHE_PATH": str(Path(caches) / "warp")}
        out = subprocess.run([sys.executable, "-c", "import json; from benchmarks import "
                              "bench_report as b; print(json.dumps(b.build()))"],
                             env=env, check=True, capture_output=True, text=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> None:
    report_s, bare_s = imports()
    got = measured()
    caches = "empty" if os.environ.get(COLD_ENV) else "as on this machine (warm after a run)"
    print(f"Fresh default report ({got['runs_total']} runs, empty results store; compile "
          f"caches {caches}); {os.cpu_count()} cores")
    print(f"{'phase':24s} {'wall s':>9s}")
    print(f"{'imports (report module)':24s} {report_s:9.2f}   (bare python {bare_s:.2f} s, "
          f"×{report_s / bare_s:.1f})")
    for phase in ("runs", "tosses", "figures", "rendering", "report"):
        print(f"{phase:24s} {got[phase]:9.1f}")
    print(f"peak RSS of the main process: {got['peak_rss_mb']:.0f} MB")
    print("\nengine time per scenario × engine (the runs' own wall times, summed; on Dask "
          "they overlap):")
    ranked = sorted(got["engine_s"].items(), key=lambda kv: -kv[1])
    total = sum(v for _, v in ranked) or 1.0
    for key, seconds in ranked[:15]:
        print(f"  {key:36s} {seconds:8.1f} s  {100 * seconds / total:5.1f} %")


if __name__ == "__main__":
    main()
