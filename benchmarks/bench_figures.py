"""``impactbench figures``: drawn in this process, on the worker pool, and skipped unchanged.

Three contenders, each ``impactbench figures`` as a fresh process into its own temporary
folder, alternated round by round (:func:`benchmarks.alternate.alternate`, :data:`ROUNDS`,
``--rounds N``):

- ``serial``: ``--workers 0 --force``, every figure drawn here, one after another (the
  command before the pool);
- ``pool``: ``--force``, one worker process per core available, one task a figure;
- ``unchanged``: a rerun into the pool's folder, whose manifest
  (``figures_manifest.json``) has the same key: nothing drawn or rewritten.

The rigid–flexible sweeps come from one private results store, filled by a first, untimed
run, so every timed run serves them (``make report`` on a machine that ran it before). The
printed ratios are medians of the per-round ratios to ``serial``; every run's PNGs are
checked equal to the first's, byte for byte. Run: ``python -m benchmarks figures
[--rounds N]`` (≈ 1–2 min a round on 2 cores).
"""

from __future__ import annotations

import statistics
import subprocess
import sys
import tempfile
from collections.abc import Callable
from pathlib import Path

from benchmarks.alternate import alternate, median_ratio

ROUNDS = 3


def _cli() -> list[str]:
    script = Path(sys.executable).with_name("impactbench")
    return [str(script)] if script.is_file() else [sys.executable, "-m", "impactbench.cli"]


def _pngs(folder: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(folder.glob("*.png"))}


def _figures(out: Path, store: Path, flags: list[str], reference: dict[str, bytes] | None
             ) -> Callable[[], None]:
    """A contender: ``impactbench figures --out OUT --store STORE FLAGS``; a failure, or a PNG
    not equal to ``reference``'s, raises."""

    def run() -> None:
        done = subprocess.run([*_cli(), "figures", "--out", str(out), "--store", str(store),
                               *flags], capture_output=True, text=True)
        if done.returncode != 0:
            raise RuntimeError(f"figures {' '.join(flags)}: exit {done.returncode}: "
                               f"{done.stderr[-2000:]}")
        if reference is not None and _pngs(out) != reference:
            raise RuntimeError(f"figures {' '.join(flags)}: PNGs differ from the first run's")

    return run


def main() -> None:
    rounds = ROUNDS
    if "--rounds" in sys.argv[1:]:
        rounds = int(sys.argv[sys.argv.index("--rounds") + 1])
    with tempfile.TemporaryDirectory(prefix="bench_figures_") as tmp:
        root = Path(tmp)
        store = root / "store.duckdb"
        _figures(root / "first", store, ["--force"], None)()  # fills the store, untimed
        reference = _pngs(root / "first")
        contenders = {
            "serial": _figures(root / "serial", store, ["--workers", "0", "--force"],
                               reference),
            "pool": _figures(root / "pool", store, ["--force"], reference),
            "unchanged": _figures(root / "pool", store, [], reference),
        }
        times = alternate(contenders, rounds)
    print(f"{len(reference)} PNGs, {rounds} rounds (every run's bytes equal to the first's)")
    print(f"{'contender':10s} {'median (s)':>10s} {'min (s)':>8s} {'/ serial':>9s}")
    for name, t in times.items():
        print(f"{name:10s} {statistics.median(t):10.2f} {min(t):8.2f} "
              f"{median_ratio(t, times['serial']):9.3f}")


if __name__ == "__main__":
    main()
