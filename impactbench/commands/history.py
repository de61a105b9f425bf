"""``impactbench history``: each metric's error across engine and impactbench versions.

Reads the results store (:mod:`impactbench.store`), like asv does for speed: one row per
engine × engine version × impactbench version × scenario × mode × metric with the number of
``ok`` runs and their median and largest |relative error| against the reference; a plot of the
largest error per metric against the versions in the order they were first stored.

Runs a tuning search stored as candidates (``store.CANDIDATE``: parameter points it tried, not
settings anyone runs) are left out, and counted.
"""

from __future__ import annotations

import argparse
from pathlib import Path

HELP = "show each metric's error across engine and impactbench versions held in the store"
GROUP = ["engine", "engine_version", "impactbench_version", "scenario", "mode", "metric"]


def register(top: argparse._SubParsersAction, groups: dict) -> None:
    p = top.add_parser("history", help=HELP, description=HELP + ".")
    p.add_argument("--engine", default=None, metavar="E", help="only this engine")
    p.add_argument("--store", type=Path, default=None, metavar="FILE",
                   help="results store; default $IMPACTBENCH_STORE or "
                   "~/.cache/impactbench/results.duckdb")
    p.add_argument("--plot", type=Path, default=Path("history.png"), metavar="FILE",
                   help="plot PNG (default history.png)")
    p.add_argument("--no-plot", action="store_true", help="table only")
    p.set_defaults(func=main)


def candidates(df):
    """Rows of runs a tuning search stored as candidates (a boolean Series)."""
    from impactbench.store import CANDIDATE

    return df.study == CANDIDATE if "study" in df else df.status != df.status


def summarize(df):
    """The history table of a store frame (see the module docstring)."""
    import pandas as pd

    if df.empty:
        return pd.DataFrame(columns=[*GROUP, "runs", "median_abs_rel_error",
                                     "max_abs_rel_error", "first_stored"])
    ok = df[(df.status == "ok") & ~candidates(df)].copy()
    ok["abs_err"] = ok.rel_error.abs()
    first = df.groupby(["engine", "engine_version", "impactbench_version"]).stored_at.min()
    table = (ok.groupby(GROUP).agg(runs=("run_key", "nunique"),
                                   median_abs_rel_error=("abs_err", "median"),
                                   max_abs_rel_error=("abs_err", "max")).reset_index())
    table["first_stored"] = [first.get((e, v, i)) for e, v, i in
                             zip(table.engine, table.engine_version, table.impactbench_version,
                                 strict=True)]
    return table.sort_values(["engine", "scenario", "mode", "metric", "first_stored"],
                             kind="stable").reset_index(drop=True)


def plot(table, path: Path) -> Path:
    """Largest |relative error| per metric (one panel each) over versions, one line per
    engine × scenario × mode."""
    import matplotlib

    matplotlib.use("Agg", force=True)
    import matplotlib.pyplot as plt

    metrics = sorted(table.metric.unique())
    fig, axes = plt.subplots(len(metrics), 1, figsize=(8, 2.4 * len(metrics)), squeeze=False)
    for ax, metric in zip(axes[:, 0], metrics, strict=True):
        m = table[table.metric == metric]
        for (engine, scenario, mode), g in m.groupby(["engine", "scenario", "mode"]):
            g = g.sort_values("first_stored")
            labels = [f"{e} {v}\n{i}" for e, v, i in zip(g.engine, g.engine_version,
                                                          g.impactbench_version, strict=True)]
            ax.plot(labels, g.max_abs_rel_error.clip(lower=1e-16), marker="o",
                    label=f"{engine} {scenario} {mode}")
        ax.set_yscale("log")
        ax.set_ylabel(f"max |rel error|\n{metric}")
        ax.tick_params(axis="x", labelsize=6)
    axes[0, 0].legend(fontsize=6, ncol=2)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


def main(args: argparse.Namespace) -> int:
    from impactbench.cliutil import print_table
    from impactbench.publish import check_file_target
    from impactbench.store import Store, default_path

    path = args.store or default_path()
    if not path.exists():
        raise ValueError(f"store = '{path}': no such file (run a report or gate first)")
    if not args.no_plot:
        check_file_target(args.plot, "plot")
    frame = Store(path).frame(args.engine)
    table = summarize(frame)
    if not frame.empty and candidates(frame).any():
        print(f"({frame[candidates(frame)].run_key.nunique()} runs stored by tuning searches "
              "are candidates, not shown)")
    if table.empty:
        print(f"no stored ok runs{' of ' + args.engine if args.engine else ''} in {path}")
        return 0
    print_table(table.drop(columns="first_stored").to_dict("records"), floatfmt=".3g")
    if not args.no_plot:
        print(f"plot: {plot(table, args.plot)}")
    return 0
