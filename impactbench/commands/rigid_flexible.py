"""``impactbench reference rigid-flexible`` and ``impactbench sweep rigid-flexible``.

The rigid–flexible 2-DOF reference (MODELS.md §2): one solve with the paper's base
parameters by default (SI: kg, N/m, m, N/m³, N), or a sweep of one parameter over all 3 × 2
law combinations (or the chosen ones), in parallel over the cores, into a CSV or Parquet file.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from impactbench.cliutil import number, print_json, print_table
from impactbench.params import add_law_flags, add_parameter_flags, scenario_from_args
from reference import two_dof
from reference.laws import LOCAL_LAWS, STRUCTURAL_LAWS

JSON_KEYS = ("status", *two_dof.METRIC_KEYS)
MAX_SWEEP_POINTS = 10_000_000


def register(top: argparse._SubParsersAction, groups: dict) -> None:
    help_ref = "rigid body hitting a constrained flexible body (Zhou & Xiao 2-DOF model)"
    p = groups["reference"].add_parser("rigid-flexible", help=help_ref, description=help_ref)
    p.add_argument("--velocity", type=number, default=2.0, dest="velocity_m_s", metavar="V",
                   help="impact velocity v1 of body 1 (m/s); default 2")
    add_law_flags(p)
    add_parameter_flags(p, "rigid-flexible")
    p.add_argument("--json", action="store_true",
                   help="print one JSON object: " + ", ".join(JSON_KEYS))
    p.set_defaults(func=reference_main)

    help_sw = "sweep one parameter of the rigid–flexible model over the law combinations"
    s = groups["sweep"].add_parser("rigid-flexible", help=help_sw, description=help_sw)
    s.add_argument("--over", required=True, choices=tuple(two_dof.SWEEP_FIELDS),
                   help="swept parameter: velocity (m/s), k1, k2 (N/m) or m2 (kg)")
    s.add_argument("--start", type=number, required=True, metavar="A")
    s.add_argument("--stop", type=number, required=True, metavar="B",
                   help="last value (included when it lies on the grid)")
    s.add_argument("--step", type=number, required=True, metavar="H")
    s.add_argument("--velocity", type=number, default=2.0, dest="velocity_m_s", metavar="V",
                   help="v1 (m/s) when sweeping another parameter; default 2")
    add_law_flags(s, default=None)
    add_parameter_flags(s, "rigid-flexible")
    s.add_argument("--processes", type=int, default=None, metavar="N",
                   help="worker processes; default: all cores")
    s.add_argument("--out", type=Path, required=True, metavar="FILE",
                   help="output table: .csv or .parquet")
    s.set_defaults(func=sweep_main)


def reference_main(args: argparse.Namespace) -> int:
    scenario = scenario_from_args("rigid-flexible", args)
    out = two_dof.solve(scenario)
    if args.json:
        print_json({k: out[k] for k in JSON_KEYS})
        return 0
    print(f"rigid-flexible  local {scenario.local}  structure {scenario.structure}  "
          f"v1 {scenario.velocity_m_s:g} m/s  status {out['status']}")
    print_table([{"quantity": k, "value": v} for k, v in out.items() if k != "status"])
    return 0


def grid(start: float, stop: float, step: float) -> np.ndarray:
    """start, start + step, … ≤ stop (+ a relative 1e-9 of slack), computed as start + i·step."""
    if not step > 0.0:
        raise ValueError(f"step = {step!r}: must be > 0")
    if stop < start:
        raise ValueError(f"stop = {stop!r}: must be >= start ({start!r})")
    n = int(np.floor((stop - start) / step * (1.0 + 1e-12) + 1e-9)) + 1
    if n > MAX_SWEEP_POINTS:
        raise ValueError(f"step = {step!r}: gives {n} points, more than {MAX_SWEEP_POINTS}")
    return start + step * np.arange(n)


def sweep_main(args: argparse.Namespace) -> int:
    values = grid(args.start, args.stop, args.step)
    field = two_dof.SWEEP_FIELDS[args.over]
    base = scenario_from_args("rigid-flexible", args, local=args.local or "linear",
                              structure=args.structure or "linear",
                              **{field: float(values[0])})
    locals_ = (args.local,) if args.local else tuple(LOCAL_LAWS)
    structures = (args.structure,) if args.structure else tuple(STRUCTURAL_LAWS)
    combos = [(lo, st) for lo in locals_ for st in structures]
    suffix = args.out.suffix.lower()
    if suffix not in (".csv", ".parquet"):
        raise ValueError(f"out = {str(args.out)!r}: must end in .csv or .parquet")
    if args.processes is not None and args.processes < 1:
        raise ValueError(f"processes = {args.processes!r}: must be >= 1")
    bar = None
    if sys.stderr.isatty():
        from tqdm import tqdm

        bar = tqdm(total=len(values) * len(combos), unit="solve", file=sys.stderr)
    try:
        df = two_dof.sweep(base, args.over, values, combos=combos, processes=args.processes,
                           progress=bar.update if bar else None)
    finally:
        if bar:
            bar.close()
    args.out.parent.mkdir(parents=True, exist_ok=True)
    if suffix == ".csv":
        df.to_csv(args.out, index=False)
    else:
        df.to_parquet(args.out, index=False)
    counts = df["status"].value_counts().to_dict()
    print(f"{len(df)} solves ({len(combos)} law combinations × {len(values)} values of "
          f"{field}) → {args.out}; status: "
          + ", ".join(f"{k} {v}" for k, v in sorted(counts.items())))
    return 0
