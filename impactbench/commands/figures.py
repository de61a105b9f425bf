"""``impactbench figures [--out DIR]``: write the papers' figures as PNGs (Agg backend).

Runs ``write(out_dir)`` of every module in :data:`impactbench.figures.FIGURE_MODULES` and prints
the written paths. Default directory: ``reports/figures/``.
"""

from __future__ import annotations

import argparse
import importlib
from pathlib import Path

from impactbench.cliutil import add_execution_flags, check_workers

HELP = "write the reference papers' figures (PNG) into a directory"
DEFAULT_OUT = Path("reports/figures")


def register(top: argparse._SubParsersAction, groups: dict) -> None:
    p = top.add_parser("figures", help=HELP, description=HELP + " (default reports/figures/).")
    p.add_argument("--out", type=Path, default=DEFAULT_OUT, metavar="DIR",
                   help="output directory (default reports/figures/)")
    add_execution_flags(p, yes=False, in_process=True)
    p.set_defaults(func=main)


def write_all(out_dir: Path, execution: dict | None = None) -> list[Path]:
    """Write every registered figure module's PNGs into ``out_dir``; return the paths.
    ``execution`` (store, fresh, workers, scheduler) goes to the modules that solve."""
    import matplotlib

    matplotlib.use("Agg", force=True)
    from impactbench.figures import FIGURE_MODULES, SOLVING_MODULES
    from impactbench.publish import check_dir_target

    check_dir_target(out_dir, "out")
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ValueError(f"out = '{out_dir}': cannot create ({exc.strerror})") from None
    paths: list[Path] = []
    for name in FIGURE_MODULES:
        write = importlib.import_module(name).write
        paths += write(out_dir, execution=execution) if name in SOLVING_MODULES \
            else write(out_dir)
    return paths


def main(args: argparse.Namespace) -> int:
    from impactbench.store import Store, default_path

    check_workers(args.workers)
    execution = {"store": Store(args.store or default_path()), "fresh": args.fresh,
                 "workers": args.workers, "scheduler": args.scheduler}
    for path in write_all(args.out, execution):
        print(path)
    return 0
