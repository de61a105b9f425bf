"""``impactbench reference rigid-flexible`` and ``impactbench sweep rigid-flexible``.

The rigid–flexible 2-DOF reference (MODELS.md §2): one solve with the paper's base
parameters by default (SI: kg, N/m, m, N/m³, N), or a sweep of one parameter over all 3 × 2
law combinations (or the chosen ones) into a CSV or Parquet file. A sweep reads the points a
results store holds and solves only the others, on Dask workers when that pays
(:mod:`impactbench.sweeps`); Ctrl-C stores what finished, and the rerun resumes.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from impactbench.cliutil import (
    add_execution_flags,
    check_workers,
    grid,
    interruptible,
    number,
    print_json,
    print_table,
    progress_bar,
    table_format,
    write_table,
)
from impactbench.flags import add_axis_flags, add_parameter_flags, scenario_from_args
from impactbench.reference.laws import LOCAL_LAWS, STRUCTURAL_LAWS
from impactbench.reference.scenarios import SWEEP_FIELDS

JSON_HELP = ("print one JSON object: status, peak_force_n, pulse_width_s, contact_time_s, "
             "impulse_ns, impacts")
"""Names ``two_dof.METRIC_KEYS`` without importing the solver (and numpy) for ``--help``."""


def register(top: argparse._SubParsersAction, groups: dict) -> None:
    help_ref = "rigid body hitting a constrained flexible body (Zhou & Xiao 2-DOF model)"
    p = groups["reference"].add_parser("rigid-flexible", help=help_ref, description=help_ref)
    p.add_argument("--velocity", type=number, default=2.0, dest="velocity_m_s", metavar="V",
                   help="impact velocity v1 of body 1 (m/s); default 2")
    add_axis_flags(p, "rigid-flexible")
    add_parameter_flags(p, "rigid-flexible")
    p.add_argument("--json", action="store_true",
                   help=JSON_HELP)
    p.set_defaults(func=reference_main)

    help_sw = "sweep one parameter of the rigid–flexible model over the law combinations"
    s = groups["sweep"].add_parser("rigid-flexible", help=help_sw, description=help_sw)
    s.add_argument("--over", required=True, choices=tuple(SWEEP_FIELDS),
                   help="swept parameter: velocity (m/s), k1, k2 (N/m) or m2 (kg)")
    s.add_argument("--start", type=number, required=True, metavar="A",
                   help="first value of the swept parameter (SI)")
    s.add_argument("--stop", type=number, required=True, metavar="B",
                   help="last value (included when it lies on the grid)")
    s.add_argument("--step", type=number, required=True, metavar="H",
                   help="grid step: values A, A+H, A+2H, … ≤ B")
    s.add_argument("--velocity", type=number, default=2.0, dest="velocity_m_s", metavar="V",
                   help="v1 (m/s) when sweeping another parameter; default 2")
    add_axis_flags(s, "rigid-flexible", default=None)
    add_parameter_flags(s, "rigid-flexible")
    s.add_argument("--out", type=Path, required=True, metavar="FILE",
                   help="output table: .csv or .parquet")
    add_execution_flags(s, in_process=True)
    s.add_argument("--processes", type=int, dest="workers", help=argparse.SUPPRESS)  # old name
    s.set_defaults(func=sweep_main)


def reference_main(args: argparse.Namespace) -> int:
    from impactbench.reference import two_dof

    scenario = scenario_from_args("rigid-flexible", args)
    # in a thread: Ctrl-C stops the command even inside the compiled kernel (up to its step
    # budget, two_dof_fast.MAX_STEPS: seconds, for a body 2 far lighter than body 1)
    out = interruptible(two_dof.solve, scenario)
    message = out.pop("message", "")
    if args.json:
        if message:
            print(f"impactbench: status {out['status']}: {message}", file=sys.stderr)
        print_json({k: out[k] for k in ("status", *two_dof.METRIC_KEYS)})
        return 0
    print(f"rigid-flexible  local {scenario.local}  structure {scenario.structure}  "
          f"v1 {scenario.velocity_m_s:g} m/s  status {out['status']}")
    if message:
        print(f"  ({message})")
    print_table([{"quantity": k, "value": v} for k, v in out.items() if k != "status"])
    return 0


def sweep_main(args: argparse.Namespace) -> int:
    from impactbench.publish import check_file_target

    table_format(args.out)
    check_file_target(args.out, "out")
    combos_n = (1 if args.local else len(LOCAL_LAWS)) * (1 if args.structure
                                                          else len(STRUCTURAL_LAWS))
    values = grid(args.start, args.stop, args.step, yes=args.yes, per_value=combos_n)
    field = SWEEP_FIELDS[args.over]
    # the flags' scenario (not the first grid value): a k1 sweep keeps kt and k1' at their
    # fractions of this k1, so a valid base stays valid (kt ≤ k1, k1' ≤ k1) at every point
    base = scenario_from_args("rigid-flexible", args, local=args.local or "linear",
                              structure=args.structure or "linear")
    for lo in ((args.local,) if args.local else tuple(LOCAL_LAWS)):
        base.replace(local=lo)  # validates the energy rules of every swept law
    locals_ = (args.local,) if args.local else tuple(LOCAL_LAWS)
    structures = (args.structure,) if args.structure else tuple(STRUCTURAL_LAWS)
    combos = [(lo, st) for lo in locals_ for st in structures]
    check_workers(args.workers)
    from impactbench.store import Store, default_path
    from impactbench.sweeps import rigid_flexible

    update, close = progress_bar(len(values) * len(combos), unit="point")
    try:
        result = rigid_flexible(base, args.over, values, combos,
                                store=Store(args.store or default_path()), fresh=args.fresh,
                                workers=args.workers, scheduler=args.scheduler,
                                progress=update)
    finally:
        close()
    df = result.frame
    write_table(df, args.out)
    counts = df["status"].value_counts().to_dict()
    print(f"{len(df)} points ({len(combos)} law combinations × {len(values)} values of "
          f"{field}): {result.served} from the store, {result.solved} solved {result.where} "
          f"→ {args.out}; status: " + ", ".join(f"{k} {v}" for k, v in sorted(counts.items())))
    return 0
