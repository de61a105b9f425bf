"""``impactbench report``: the default comparison report (the README's first command).

Finished runs come from the results store (see :mod:`impactbench.store`), so a rerun with an
unchanged config costs only the rendering and an interrupted report resumes; ``--fresh`` runs
everything again. Missing runs execute on Dask (:mod:`impactbench.cluster`). The folder is
written atomically under a writer lock (:mod:`impactbench.publish`).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from impactbench.cliutil import add_execution_flags, flag_names

HELP = "run the comparison matrix and write the report (tables, plots, CSV/Parquet)"


def register(top: argparse._SubParsersAction, groups: dict) -> None:
    p = top.add_parser("report", help=HELP, description=HELP + ". The default matrix is the "
                       "packaged config (impactbench/data/default.toml). Finished runs are "
                       "read from the results store; only missing ones run.")
    p.add_argument("--config", type=Path, default=None, metavar="FILE",
                   help="TOML config replacing the default matrix")
    p.add_argument("--out", type=Path, default=Path("reports"), metavar="DIR",
                   help="output folder (default reports/)")
    p.add_argument("--engines", default=None, metavar="LIST",
                   help="comma list restricting the config's engines, e.g. mujoco,drake")
    p.add_argument("--scenario-file", type=Path, default=None, metavar="FILE",
                   help="TOML [ball_on_plate] scenario fields (e.g. from impactbench "
                   "calibrate) replacing the config's ball parameters")
    p.add_argument("--keep-unchanged", action="store_true",
                   help="leave the folder as it is when its report has the same results "
                   "apart from wall times (make report: a committed report stays unchanged)")
    add_execution_flags(p, in_process=True, timeout=True)
    p.set_defaults(func=main, flags=flag_names(p))


def main(args: argparse.Namespace) -> int:
    """``impactbench.build_report`` with the flags, then one summary line."""
    from impactbench import api

    with api.command_line(args.flags):
        rep = api.build_report(args.config, args.out, engines=args.engines,
                               workers=args.workers, scheduler=args.scheduler,
                               store=args.store, fresh=args.fresh, yes=args.yes,
                               timeout_s=args.timeout_s, scenario_file=args.scenario_file,
                               keep_unchanged=args.keep_unchanged)
    from impactbench.report_sections import run_keys

    keys = [c for c in run_keys() if c in rep.results.columns]
    counts = rep.results.drop_duplicates(keys).status.value_counts().to_dict() \
        if len(rep.results) else {}
    done = ("kept as it was (the same results apart from wall times)" if rep.kept
            else f"written ({len(rep.files)} files)")
    print(f"report {args.out}/ {done} in {rep.wall_s:.1f} s; "
          "runs: " + (", ".join(f"{n} {s}" for s, n in sorted(counts.items())) or "none"))
    return 0
