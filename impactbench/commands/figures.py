"""``impactbench figures [--out DIR]``: write the papers' figures as PNGs (Agg backend).

Draws the figures of every module in :data:`impactbench.figures.FIGURE_MODULES` (each module's
``draw``: one task a figure) on a pool of worker processes, one per core available
(:mod:`impactbench.figures.pool`; ``--workers 0``: here), and prints the written paths in the
modules' order. Default directory: ``reports/figures/``.

A folder whose ``figures_manifest.json`` (:mod:`impactbench.figures.manifest`) says its
figures were drawn from the same impactbench source, libraries and modules, every file as
written, is left as it is: the paths are printed, one line on stderr says so, nothing is
rewritten. ``--force`` (or ``--fresh``) draws them again.
"""

from __future__ import annotations

import argparse
import importlib
import sys
from pathlib import Path

from impactbench.cliutil import add_execution_flags, check_workers

HELP = "write the reference papers' figures (PNG) into a directory"
DEFAULT_OUT = Path("reports/figures")


def register(top: argparse._SubParsersAction, groups: dict) -> None:
    p = top.add_parser("figures", help=HELP, description=HELP + " (default reports/figures/).")
    p.add_argument("--out", type=Path, default=DEFAULT_OUT, metavar="DIR",
                   help="output directory (default reports/figures/)")
    p.add_argument("--force", action="store_true",
                   help="draw every figure again even when the folder's figures_manifest.json "
                   "says nothing they depend on changed (source, libraries)")
    add_execution_flags(p, yes=False, in_process=True)
    p.set_defaults(func=main)


def write_all(out_dir: Path, execution: dict | None = None, *, force: bool = True
              ) -> list[Path]:
    """Draw every registered figure module's files into ``out_dir`` (on ``execution``'s
    ``workers`` processes, default one per core; 0: here) and record them in its manifest;
    return the paths. With ``force`` False, a folder whose manifest has the same key is left
    as it is (its paths returned, one line on stderr). ``execution`` (store, fresh, workers,
    scheduler) goes to the modules that solve."""
    from impactbench.figures import FIGURE_MODULES, SOLVING_MODULES, manifest
    from impactbench.publish import check_dir_target

    check_dir_target(out_dir, "out")
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ValueError(f"out = '{out_dir}': cannot create ({exc.strerror})") from None
    key = manifest.key(FIGURE_MODULES)
    if not force:
        kept = manifest.unchanged(out_dir, key)
        if kept is not None:
            print(f"impactbench: figures in {out_dir}/ unchanged (the same source and "
                  f"libraries as {manifest.MANIFEST} records); --force draws them again",
                  file=sys.stderr)
            return kept
    manifest.forget(out_dir)
    import matplotlib

    matplotlib.use("Agg", force=True)
    from impactbench.figures.pool import figure_pool

    modules = {name: importlib.import_module(name) for name in FIGURE_MODULES}
    # the solving modules last: their draw solves the sweeps here while the workers draw
    queue = sorted(FIGURE_MODULES, key=lambda name: name in SOLVING_MODULES)
    collect = {}
    with figure_pool((execution or {}).get("workers"), preload=queue) as pool:
        for name in queue:
            collect[name] = modules[name].draw(out_dir, pool, execution=execution) \
                if name in SOLVING_MODULES else modules[name].draw(out_dir, pool)
        paths: list[Path] = []
        for name in FIGURE_MODULES:
            paths += collect[name]()
    side = [p for name in FIGURE_MODULES
            for p in getattr(modules[name], "side_files", lambda _: [])(out_dir)]
    manifest.record(out_dir, key, paths, side)
    return paths


def main(args: argparse.Namespace) -> int:
    from impactbench.store import Store, default_path

    workers = check_workers(args.workers)
    execution = {"store": Store(args.store or default_path()), "fresh": args.fresh,
                 "workers": workers, "scheduler": args.scheduler}
    for path in write_all(args.out, execution, force=args.force or args.fresh):
        print(path)
    return 0
