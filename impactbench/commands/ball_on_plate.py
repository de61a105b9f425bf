"""``impactbench reference ball-on-plate`` and ``impactbench sweep ball-on-plate``.

Both solve the Hunt–Crossley ball-on-plate impact (MODELS.md §1) with the closed-form reference
(:mod:`reference.hunt_crossley`); defaults are the preprint's case (m = 0.1 kg,
c = 1.7135e10 N/m^1.5, n = 1.5, b = 0.1 s/m).

``reference ball-on-plate --json`` prints one JSON object with exactly the keys
``restitution, duration_s, peak_force_n, max_penetration_m, energy_loss_fraction`` (SI), or a
list of such objects, in input order, when several velocities are given (repeated
``--velocity`` or a comma list).

``sweep ball-on-plate --over velocity --start A --stop B --step H --out FILE`` writes the grid
A, A+H, …, ≤ B as a table (``.csv`` or ``.parquet`` by extension) with ``velocity_m_s`` and the
five metric columns.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

from impactbench.cliutil import number, number_list, print_json, print_table

REFERENCE_HELP = "Hunt–Crossley ball on a fixed plate: closed-form metrics"
SWEEP_HELP = "Hunt–Crossley ball on a fixed plate: metrics over a velocity grid into a table"
FORMATS = {".csv": "csv", ".parquet": "parquet", ".pq": "parquet"}
MAX_ROWS = 100_000_000


def _add_law_flags(p: argparse.ArgumentParser) -> None:
    p.add_argument("--mass", type=number, default=0.1, dest="mass_kg", metavar="KG",
                   help="ball mass m in kg (default 0.1)")
    p.add_argument("--stiffness", type=number, default=1.7135e10, metavar="C",
                   help="contact stiffness c in N/m^n (default 1.7135e10)")
    p.add_argument("--exponent", type=number, default=1.5, metavar="N",
                   help="force exponent n (default 1.5, Hertz)")
    p.add_argument("--damping", type=number, default=0.1, dest="damping_s_per_m",
                   metavar="B", help="Hunt–Crossley damping b in s/m (default 0.1; 0 = Hertz)")


def register(top: argparse._SubParsersAction, groups: dict) -> None:
    p = groups["reference"].add_parser("ball-on-plate", help=REFERENCE_HELP,
                                       description=REFERENCE_HELP + ".")
    p.add_argument("--velocity", type=number_list, action="extend", dest="velocities",
                   metavar="V", help="impact velocity V0 in m/s; repeat the flag or give a "
                   "comma list for several (default 1.0)")
    _add_law_flags(p)
    p.add_argument("--json", action="store_true",
                   help="print JSON (one object, or a list for several velocities)")
    p.set_defaults(func=reference_main)

    s = groups["sweep"].add_parser("ball-on-plate", help=SWEEP_HELP,
                                   description=SWEEP_HELP + " (CSV or Parquet by extension).")
    s.add_argument("--over", required=True, choices=("velocity",),
                   help="the swept parameter")
    s.add_argument("--start", type=number, required=True, metavar="A", help="first value")
    s.add_argument("--stop", type=number, required=True, metavar="B",
                   help="last value (included when on the grid)")
    s.add_argument("--step", type=number, required=True, metavar="H", help="grid step")
    s.add_argument("--out", type=Path, required=True, metavar="FILE",
                   help="output table: .csv or .parquet")
    _add_law_flags(s)
    s.set_defaults(func=sweep_main)


def reference_main(args: argparse.Namespace) -> int:
    from reference.hunt_crossley import solve
    from reference.metrics import BALL_METRICS
    from reference.scenarios import BallOnPlate

    velocities = args.velocities or [1.0]
    results = []
    for v in velocities:
        scenario = BallOnPlate(velocity_m_s=v, mass_kg=args.mass_kg, stiffness=args.stiffness,
                               exponent=args.exponent, damping_s_per_m=args.damping_s_per_m)
        results.append(solve(scenario))
    if args.json:
        print_json(results[0] if len(results) == 1 else results)
        return 0
    print(f"Hunt–Crossley ball on plate: m = {args.mass_kg:g} kg, c = {args.stiffness:g} N/m^n, "
          f"n = {args.exponent:g}, b = {args.damping_s_per_m:g} s/m")
    rows = [{"velocity_m_s": v, **r} for v, r in zip(velocities, results, strict=True)]
    print_table(rows, ("velocity_m_s", *BALL_METRICS), floatfmt=".8g")
    return 0


def grid(start: float, stop: float, step: float):
    """The grid start, start+step, …, ≤ stop (stop included within 1e-9 of a step)."""
    import numpy as np

    from reference import validation as check

    check.positive("start", start)
    check.positive("step", step)
    check.positive("stop", stop)
    if stop < start:
        raise ValueError(f"stop = {stop!r}: must be >= start ({start!r})")
    count = math.floor((stop - start) / step + 1e-9) + 1
    if count > MAX_ROWS:
        raise ValueError(f"step = {step!r}: gives {count} rows, must give <= {MAX_ROWS}")
    return start + step * np.arange(count, dtype=float)


def sweep_main(args: argparse.Namespace) -> int:
    fmt = FORMATS.get(args.out.suffix.lower())
    if fmt is None:
        raise ValueError(f"out = '{args.out}': must end in .csv or .parquet")
    tic = time.perf_counter()
    velocities = grid(args.start, args.stop, args.step)
    from reference.hunt_crossley import sweep

    table = sweep(velocities, mass_kg=args.mass_kg, stiffness=args.stiffness,
                  exponent=args.exponent, damping_s_per_m=args.damping_s_per_m)
    _write(table, args.out, fmt)
    wall = time.perf_counter() - tic
    print(f"wrote {len(table)} rows to {args.out} in {wall:.3g} s", file=sys.stderr)
    return 0


def _write(table, path: Path, fmt: str) -> None:
    """Write with pyarrow (full float64 precision; CSV round-trips exactly)."""
    import pyarrow as pa

    path.parent.mkdir(parents=True, exist_ok=True)
    arrow = pa.Table.from_pandas(table, preserve_index=False)
    if fmt == "parquet":
        import pyarrow.parquet as pq

        pq.write_table(arrow, path)
    else:
        import pyarrow.csv as pacsv

        pacsv.write_csv(arrow, path)
