"""``impactbench reference ball-on-plate`` and ``impactbench sweep ball-on-plate``.

Both solve the Hunt–Crossley ball-on-plate impact (MODELS.md §1) with the closed-form reference
(:mod:`impactbench.reference.hunt_crossley`); defaults are the preprint's case (m = 0.1 kg,
c = 1.7135e10 N/m^1.5, n = 1.5, b = 0.1 s/m).

``--model NAME --nominal-restitution E`` picks a contact model of the zoo
(:mod:`impactbench.reference.models`) set from a nominal restitution; ``--material``,
``--radius`` (or ``--youngs-modulus --poisson``) give mass and Hertz c of the user's ball.

``reference ball-on-plate --json`` prints one JSON object with exactly the keys
``velocity_m_s`` (the input), ``restitution, duration_s, peak_force_n, max_penetration_m,
energy_loss_fraction`` (SI), ``status`` and ``message``, or a list of such objects, in input
order, when several velocities are given (repeated ``--velocity`` or a comma list). ``status``
is ``unsupported`` (with the reason in ``message``) when the indentation exceeds the ball's
radius, where no contact law holds.

``sweep ball-on-plate --over velocity --start A --stop B --step H --out FILE`` writes the grid
A, A+H, …, ≤ B as a table (``.csv`` or ``.parquet`` by extension) with ``velocity_m_s`` and the
five metric columns.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from impactbench.cliutil import (
    damping_text,
    grid,
    number,
    number_list,
    print_points,
    table_format,
    write_table,
)
from impactbench.flags import add_parameter_flags, scenario_from_args

REFERENCE_HELP = "ball on a fixed plate (Hunt–Crossley or any --model): closed-form metrics"
SWEEP_HELP = "ball on a fixed plate: metrics over a velocity grid into a table"


def register(top: argparse._SubParsersAction, groups: dict) -> None:
    p = groups["reference"].add_parser("ball-on-plate", help=REFERENCE_HELP,
                                       description=REFERENCE_HELP + ".")
    p.add_argument("--velocity", type=number_list, action="extend", dest="velocities",
                   metavar="V", help="impact velocity V0 in m/s; repeat the flag or give a "
                   "comma list for several (default 1.0)")
    add_parameter_flags(p, "ball-on-plate", with_gravity=False)
    p.add_argument("--json", action="store_true",
                   help="print JSON (one object, or a list for several velocities)")
    p.set_defaults(func=reference_main)

    s = groups["sweep"].add_parser("ball-on-plate", help=SWEEP_HELP,
                                   description=SWEEP_HELP + " (CSV or Parquet by extension). "
                                   "Closed form, so not kept in the results store: a "
                                   "million points compute in about a second.")
    s.add_argument("--over", required=True, choices=("velocity",),
                   help="the swept parameter")
    s.add_argument("--start", type=number, required=True, metavar="A", help="first value")
    s.add_argument("--stop", type=number, required=True, metavar="B",
                   help="last value (included when on the grid)")
    s.add_argument("--step", type=number, required=True, metavar="H", help="grid step")
    s.add_argument("--out", type=Path, required=True, metavar="FILE",
                   help="output table: .csv or .parquet")
    s.add_argument("--yes", action="store_true", help="sweep even over more than 1e7 points")
    add_parameter_flags(s, "ball-on-plate", with_gravity=False)
    s.set_defaults(func=sweep_main)


def reference_main(args: argparse.Namespace) -> int:
    from impactbench.reference.hunt_crossley import solve
    from impactbench.reference.metrics import BALL_METRICS

    velocities = args.velocities or [1.0]
    scenarios = [scenario_from_args("ball-on-plate", args, velocity_m_s=v) for v in velocities]
    results = [_with_status(s, solve(s)) for s in scenarios]
    s = scenarios[0]
    return print_points(results, args.json, f"{s.model} ball on plate: m = {s.mass_kg:g} kg, "
                        f"c = {s.stiffness:g} N/m^n, n = {s.exponent:g}, {damping_text(s)}",
                        ("velocity_m_s", *BALL_METRICS, "status"))


def _with_status(scenario, metrics: dict) -> dict:
    """The JSON object of one velocity: the input velocity, the metrics, status and message
    (``unsupported`` when the indentation exceeds the ball's radius)."""
    problem = scenario.penetration_problem(metrics["max_penetration_m"])
    return {"velocity_m_s": scenario.velocity_m_s, **metrics,
            "status": "unsupported" if problem else "ok", "message": problem}


def sweep_main(args: argparse.Namespace) -> int:
    from impactbench.publish import check_file_target

    table_format(args.out)
    check_file_target(args.out, "out")
    tic = time.perf_counter()
    velocities = grid(args.start, args.stop, args.step, yes=args.yes)
    from impactbench.reference.zoo import sweep_columns

    # columns straight to pyarrow: pandas is never imported (a third of the start-up)
    table = sweep_columns(scenario_from_args("ball-on-plate", args), velocities)
    write_table(table, args.out)
    wall = time.perf_counter() - tic
    print(f"wrote {len(velocities)} rows to {args.out} in {wall:.3g} s", file=sys.stderr)
    return 0
