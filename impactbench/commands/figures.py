"""``impactbench figures [--out DIR]``: write the papers' figures as PNGs (Agg backend).

Runs ``write(out_dir)`` of every module in :data:`impactbench.figures.FIGURE_MODULES` and prints
the written paths. Default directory: ``reports/figures/``.
"""

from __future__ import annotations

import argparse
import importlib
from pathlib import Path

HELP = "write the reference papers' figures (PNG) into a directory"
DEFAULT_OUT = Path("reports/figures")


def register(top: argparse._SubParsersAction, groups: dict) -> None:
    p = top.add_parser("figures", help=HELP, description=HELP + " (default reports/figures/).")
    p.add_argument("--out", type=Path, default=DEFAULT_OUT, metavar="DIR",
                   help="output directory (default reports/figures/)")
    p.set_defaults(func=main)


def write_all(out_dir: Path) -> list[Path]:
    """Write every registered figure module's PNGs into ``out_dir``; return the paths."""
    import matplotlib

    matplotlib.use("Agg", force=True)
    from impactbench.figures import FIGURE_MODULES
    from impactbench.publish import check_dir_target

    check_dir_target(out_dir, "out")
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ValueError(f"out = '{out_dir}': cannot create ({exc.strerror})") from None
    paths: list[Path] = []
    for name in FIGURE_MODULES:
        paths += importlib.import_module(name).write(out_dir)
    return paths


def main(args: argparse.Namespace) -> int:
    for path in write_all(args.out):
        print(path)
    return 0
