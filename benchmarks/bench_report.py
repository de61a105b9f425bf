"""A fresh default report (the README's ``make report``, install excluded), timed in phases,
beside the previous layout's.

Each build runs in a fresh process, as ``impactbench report`` would: the packaged default
config into a temporary folder with a new, empty results store (``fresh``; the store the
sections use too, ``$IMPACTBENCH_STORE``), on a local cluster of one worker per core. The
phases, each the wall time of the report's own step (the step's function is wrapped with a
timer; nothing else changes):

- ``imports``: ``python -c "import impactbench.report"`` against ``python -c pass``, as
  subprocesses, alternated, medians of :data:`IMPORT_ROUNDS`;
- ``runs``: the report's run (:func:`impactbench.matrix.run_jobs` of its plan; in this
  layout the matrix, the studies and the cube-toss replays together); under it, per
  scenario × engine, the runs' own wall times summed (engine time: on Dask the runs overlap,
  so these add up to more than the phase);
- ``section runs``: runs a report section starts itself (the previous layout replayed the
  cube tosses there, in the main process, one after another);
- ``rendering``: the figures and the documents (:func:`impactbench.report.render`), the
  section runs taken out;
- ``report``: the whole build, and the peak RSS of its process (the workers' apart);
- the time left the progress lines would say, every 10 s, against the runs' real end
  (:func:`time_left_error`: the median and worst factor; this layout's estimate).

The previous layout (:data:`PREVIOUS`, the last landing before issue #32's work; ``--against
REV`` another) is checked out into a temporary git worktree and built the same way, its
packages imported from there (:data:`BOOTSTRAP`), the two alternated round by round (A B A B …,
:data:`ROUNDS`, ``--rounds N``): the ratio printed per phase is the median of the per-round
ratios new / previous. Where the revision is not in the repository (a shallow clone), only
this layout is timed. ``--only`` times this layout alone.

Compile caches (MJX's on disk, warp's kernels) are as they are on this machine: warm after a
first run. ``IMPACTBENCH_BENCH_COLD=1`` gives every build caches in an empty folder
(``XDG_CACHE_HOME``, ``WARP_CACHE_PATH``): the first report of a fresh machine, install
excluded. ``--priors`` writes this layout's measured time ratios per group of work items
(the last round's) to :data:`impactbench.matrix.TIME_PRIORS`, the time-left estimate's prior.
``IMPACTBENCH_BENCH_KEEP=DIR`` copies each build's ``results.csv`` there
(``new-results.csv``, ``previous-results.csv``: the last round's) to compare the two.

Run: ``python -m benchmarks report [--rounds N] [--against REV | --only] [--priors]``
(≈ 2–6 min a build on 2 cores).
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import statistics
import subprocess
import sys
import tempfile
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from benchmarks.alternate import alternate, median_ratio

IMPORT_ROUNDS = 5
ROUNDS = 1
COLD_ENV = "IMPACTBENCH_BENCH_COLD"
PREVIOUS = "fb1ce0e"
"""The last landing before issue #32's work (a first report in two minutes): the layout the
ratios are against."""
ROOT = Path(__file__).resolve().parents[1]

TREE_ENV = "IMPACTBENCH_BENCH_TREE"
FINDER = r'''
import importlib.util, os, sys
from pathlib import Path

_root = os.environ.get("IMPACTBENCH_BENCH_TREE")
if _root:  # this process imports the packages from that tree, not from the install
    _folders = {"impactbench": "impactbench", "impactbench.reference": "reference",
                "impactbench.engines": "engines"}

    class _Tree:
        @staticmethod
        def find_spec(name, path=None, target=None):
            if name in _folders:
                where = Path(_root) / _folders[name]
                return importlib.util.spec_from_file_location(
                    name, where / "__init__.py", submodule_search_locations=[str(where)])
            return None

    sys.meta_path.insert(0, _Tree)
'''
"""A ``sitecustomize`` for the builds of another layout: with :data:`TREE_ENV` set, every
process — the build's and its Dask workers', spawned interpreters that unpickle their work by
module name — imports impactbench from that tree."""

BOOTSTRAP = r'''
import json, resource, sys, tempfile, time
from collections import defaultdict
from pathlib import Path

from impactbench import config, matrix, report
from impactbench.store import Store

phases = defaultdict(float)
results = []
# the report's own run fills a time-left clock where this layout takes one (its ratios)
said, span = [], []
if hasattr(matrix, "TimeLeft"):
    class Clock(matrix.TimeLeft):
        """The estimate as a progress line would hear it, and when: once the run has set its
        workers (its first), then after each finished item."""

        @property
        def workers(self):
            return self._workers

        @workers.setter
        def workers(self, n):
            self._workers = n
            if self.__dict__.get("pending"):
                said.append((time.monotonic(), self.seconds()))

        def finished(self, *args):
            super().finished(*args)
            said.append((time.monotonic(), self.seconds()))

    clock = Clock(1)
else:
    clock = None

def timed(owner, name, key, keep=False):
    original = getattr(owner, name)
    import inspect
    takes_clock = keep and clock is not None and "clock" in inspect.signature(original).parameters
    def wrapper(*args, **kwargs):
        if takes_clock:
            kwargs["clock"] = clock
        t0 = time.perf_counter()
        try:
            out = original(*args, **kwargs)
        finally:
            phases[key] += time.perf_counter() - t0
            if key == "runs":
                span.append(time.monotonic())
        if keep:
            results.append(out)
        return out
    setattr(owner, name, wrapper)

timed(report, "run_jobs", "runs", keep=True)      # the report's own run
timed(matrix, "run_jobs", "section runs")          # a section's (report.run_jobs is apart)
timed(report, "render", "render")
with tempfile.TemporaryDirectory() as tmp:
    import os
    os.environ["IMPACTBENCH_STORE"] = str(Path(tmp) / "store.duckdb")
    t0 = time.perf_counter()
    report.build(config.load(None), Path(tmp) / "report", store=Store(
        Path(tmp) / "store.duckdb"), fresh=True, show_progress=False)
    phases["report"] = time.perf_counter() - t0
    if os.environ.get("IMPACTBENCH_BENCH_KEEP"):  # the build's results.csv, to compare
        import shutil
        label = "previous" if os.environ.get("IMPACTBENCH_BENCH_TREE") else "new"
        shutil.copy(Path(tmp) / "report" / "results.csv",
                    Path(os.environ["IMPACTBENCH_BENCH_KEEP"]) / f"{label}-results.csv")
engine_s = defaultdict(float)
for r in (r for got in results for r in got):
    wall = float(r.run.get("wall_s", float("nan")))
    if wall == wall:
        engine_s[f"{r.job.scenario} × {r.job.engine}"] += wall
phases["rendering"] = phases.pop("render") - phases["section runs"]
print(json.dumps({"phases": dict(phases), "runs_total": sum(len(g) for g in results),
                  "time_ratios": clock.measured() if clock is not None else [],
                  "time_left": {"said": said, "end": span[-1] if span else None},
                  "engine_s": dict(engine_s),
                  "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0}))
'''
"""A build in a fresh process; its phases as one JSON line on stdout."""
PHASES = ("runs", "section runs", "rendering", "report")


@contextmanager
def previous_tree(rev: str) -> Iterator[Path | None]:
    """A temporary git worktree of ``rev`` (None when the repository has no such revision)."""
    with tempfile.TemporaryDirectory() as tmp:
        where = Path(tmp) / "previous"
        made = subprocess.run(["git", "worktree", "add", "--detach", str(where), rev],
                              cwd=ROOT, capture_output=True, text=True)
        if made.returncode != 0:
            yield None
            return
        try:
            yield where
        finally:
            subprocess.run(["git", "worktree", "remove", "--force", str(where)], cwd=ROOT,
                           capture_output=True)


@contextmanager
def layout_env(tree: Path | None) -> Iterator[dict[str, str]]:
    """The environment of a process (and its children) importing ``tree``'s packages (None:
    the installed ones): :data:`FINDER` as the ``sitecustomize`` of a folder on PYTHONPATH."""
    env = {k: v for k, v in os.environ.items() if k != TREE_ENV}
    if tree is None:
        yield env
        return
    with tempfile.TemporaryDirectory() as site:
        (Path(site) / "sitecustomize.py").write_text(FINDER)
        path = os.pathsep.join(x for x in (site, env.get("PYTHONPATH", "")) if x)
        yield {**env, TREE_ENV: str(tree), "PYTHONPATH": path}


def build_in(tree: Path | None, caches: str | None) -> dict[str, Any]:
    """One fresh build in a new process, from ``tree``'s packages (None: the installed)."""
    with layout_env(tree) as env:
        if caches is not None:  # a cold start: compile caches in an empty folder
            env.update(XDG_CACHE_HOME=caches, WARP_CACHE_PATH=str(Path(caches) / "warp"))
        out = subprocess.run([sys.executable, "-c", BOOTSTRAP], env=env,
                             capture_output=True, text=True, cwd=tempfile.gettempdir())
    if out.returncode != 0:
        raise RuntimeError(f"report build ({tree or 'this layout'}) failed: "
                           f"{out.stderr[-3000:]}")
    return json.loads(out.stdout.strip().splitlines()[-1])


def imports(trees: dict[str, Path | None]) -> dict[str, float]:
    """Median wall times (s) of importing each layout's report module, and bare Python."""
    def run(env: dict[str, str], code: str) -> Callable[[], Any]:
        return lambda: subprocess.run([sys.executable, "-c", code], check=True, env=env,
                                      cwd=tempfile.gettempdir())

    with contextlib.ExitStack() as stack:
        contenders = {name: run(stack.enter_context(layout_env(tree)),
                                "import impactbench.report") for name, tree in trees.items()}
        contenders["bare"] = run(dict(os.environ), "pass")
        times = alternate(contenders, IMPORT_ROUNDS)
    return {name: statistics.median(t) for name, t in times.items()}


def main(argv: list[str] | None = None) -> None:
    argv = sys.argv[1:] if argv is None else argv
    rounds = int(argv[argv.index("--rounds") + 1]) if "--rounds" in argv else ROUNDS
    rev = argv[argv.index("--against") + 1] if "--against" in argv else PREVIOUS
    cold = bool(os.environ.get(COLD_ENV))
    with previous_tree(rev) if "--only" not in argv else _none() as old:
        trees: dict[str, Path | None] = {"this": None}
        if old is not None:
            trees["previous"] = old
        got: dict[str, list[dict[str, Any]]] = {name: [] for name in trees}
        for _ in range(rounds):
            for name, tree in trees.items():  # A B A B …: both see the same machine
                with tempfile.TemporaryDirectory() as caches:
                    got[name].append(build_in(tree, caches if cold else None))
        imported = imports(trees)
    last = got["this"][-1]
    print(f"Fresh default report ({last['runs_total']} runs, empty results store; compile "
          f"caches {'empty' if cold else 'as on this machine (warm after a run)'}); "
          f"{os.cpu_count()} cores; {rounds} round(s)"
          + (f"; previous layout: {rev}" if "previous" in got else ""))
    head = f"{'phase':24s} {'this (s)':>9s}"
    if "previous" in got:
        head += f" {'previous (s)':>12s} {'this/previous':>14s}"
    print(head)
    line = f"{'imports (report module)':24s} {imported['this']:9.2f}"
    if "previous" in got:
        line += f" {imported['previous']:12.2f} {imported['this'] / imported['previous']:14.2f}"
    print(line + f"   (bare python {imported['bare']:.2f} s)")
    for phase in PHASES:
        this = [g["phases"].get(phase, 0.0) for g in got["this"]]
        line = f"{phase:24s} {statistics.median(this):9.1f}"
        if "previous" in got:
            prev = [g["phases"].get(phase, 0.0) for g in got["previous"]]
            ratio = (f"{median_ratio(this, prev):14.2f}" if min(prev) > 0.5 else f"{'—':>14s}")
            line += f" {statistics.median(prev):12.1f} {ratio}"
        print(line)
    rss = [g["peak_rss_mb"] for g in got["this"]]
    line = f"{'peak RSS, main (MB)':24s} {statistics.median(rss):9.0f}"
    if "previous" in got:
        prev = [g["peak_rss_mb"] for g in got["previous"]]
        line += f" {statistics.median(prev):12.0f} {median_ratio(rss, prev):14.2f}"
    print(line)
    print("\nengine time per scenario × engine, this layout (the runs' own wall times, summed; "
          "on Dask they overlap):")
    ranked = sorted(last["engine_s"].items(), key=lambda kv: -kv[1])
    total = sum(v for _, v in ranked) or 1.0
    for key, seconds in ranked[:15]:
        print(f"  {key:36s} {seconds:8.1f} s  {100 * seconds / total:5.1f} %")
    error = time_left_error(last.get("time_left") or {})
    if error is not None:
        median, worst, samples = error
        print(f"\ntime left as the progress lines say it, against the runs' actual end "
              f"(every {TICK_S:.0f} s while ≥ {MIN_LEFT_S:.0f} s are left): median error "
              f"×{median:.2f}, worst ×{worst:.2f}")
        print("  " + "; ".join(f"at {t:.0f} s: said {s:.0f} s, {a:.0f} s left"
                               for t, s, a in samples))
    if "--priors" in argv:
        write_priors(last["time_ratios"], cold)


TICK_S = 10.0
MIN_LEFT_S = 15.0


def time_left_error(record: dict[str, Any]) -> tuple[float, float, list] | None:
    """How far the time left a progress line shows is from the truth: every :data:`TICK_S`
    from the run's first estimate, the last estimate counted down since it was made (as
    :func:`impactbench.cliutil.progress_bar` shows it, to a fifth of it at most) against the
    seconds until the runs ended; the median and worst factor (×, either way) while at least
    :data:`MIN_LEFT_S` are left, and the lines at 10, 30, 60 and 90 s. None without
    estimates (a layout without them)."""
    said, end = record.get("said") or [], record.get("end")
    if not said or end is None:
        return None
    start, k, t = said[0][0], 0, said[0][0] + TICK_S
    factors, samples = [], []
    while end - t >= MIN_LEFT_S:
        while k + 1 < len(said) and said[k + 1][0] <= t:
            k += 1
        at, value = said[k]
        shown = max(0.2 * value, value - (t - at))
        factors.append(math.exp(abs(math.log(max(shown, 1e-3) / (end - t)))))
        if round(t - start) in (10, 30, 60, 90):
            samples.append((t - start, shown, end - t))
        t += TICK_S
    if not factors:
        return None
    return statistics.median(factors), max(factors), samples


def write_priors(ratios: list[list[Any]], cold: bool) -> None:
    """One column of the time-left priors (:data:`impactbench.matrix.TIME_PRIORS`: ``cold``
    with ``IMPACTBENCH_BENCH_COLD=1``, else ``warm``) from a build's measured ratios, with where
    they were measured; the other column is kept."""
    import platform

    from impactbench.matrix import TIME_PRIORS

    column = "cold" if cold else "warm"
    try:
        old = json.loads(TIME_PRIORS.read_text())
    except (OSError, ValueError):
        old = {}
    measured_on = old.get("measured_on") if isinstance(old.get("measured_on"), dict) else {}
    measured_on[column] = (f"{platform.machine()}, {os.cpu_count()} cores, compile caches "
                           f"{'empty' if cold else 'warm'}")
    columns = {c: old[c] for c in ("cold", "warm") if isinstance(old.get(c), list)}
    columns[column] = [[e, sc, b, float(f"{r:.4g}")] for e, sc, b, r in ratios]
    head = {"about": "what each (engine, scenario, batched) group of a fresh default report's "
                     "work items took over its estimate (impactbench.matrix.TimeLeft's prior), "
                     "cold (compile caches empty) and warm; written by python -m benchmarks "
                     "report --priors (IMPACTBENCH_BENCH_COLD=1 for the cold column)",
            "measured_on": {c: measured_on[c] for c in ("cold", "warm") if c in measured_on}}
    parts = [json.dumps(head, indent=1)[:-2]]
    for c in ("cold", "warm"):
        if c in columns:
            rows = ",\n".join("  " + json.dumps(row) for row in columns[c])
            parts.append(f' "{c}": [\n{rows}\n ]')
    TIME_PRIORS.write_text(",\n".join(parts) + "\n}\n")
    print(f"\ntime-left priors: {len(ratios)} groups written to {TIME_PRIORS} ({column})")


@contextmanager
def _none() -> Iterator[None]:
    yield None


if __name__ == "__main__":
    main()
