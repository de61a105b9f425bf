"""``impactbench reference oblique``: a sphere hitting a plate at an angle (MODELS.md §3).

Solves the oblique impact with the scenario's reference: the rigid tangential theory in closed
form (``--tangential rigid``, the default) or the tangentially compliant Mindlin law, integrated
(``--tangential mindlin``). Defaults are the preprint's steel ball at V = 2 m/s, θ = 45°,
μ = 0.3; ``--case kharaz2001`` is Kharaz et al. (2001)'s alumina sphere (flags given override
it).

``reference oblique --json`` prints one JSON object with exactly the keys ``velocity_m_s``,
``angle_deg`` (the inputs), the nine oblique metrics (``restitution, tangential_restitution,
contact_point_ratio, rebound_angle_deg, spin_out_rad_s, regime, duration_s, peak_force_n,
peak_tangential_force_n``; SI, angles in degrees, ``regime`` 1 = slide, 0 = stick), ``status``
and ``message`` — or a list of such objects, angles outer and speeds inner, when several are
given (repeated ``--angle-deg``/``--velocity`` or comma lists). ``status`` is ``unsupported``
(the reason in ``message``) when the indentation exceeds the ball's radius. NaN (a tangential
restitution at θ = 0) prints as null.

The scenario need not be registered: :func:`main` runs this command on a parser of its own
(the tests use it); once the spec is in the registry, ``impactbench.cli`` adds it through the
spec's ``commands``.
"""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from impactbench.cliutil import damping_text, number, number_list, print_points

REFERENCE_HELP = ("sphere hitting a plate at an angle, with friction and spin: rigid-Coulomb "
                  "closed form or Mindlin reference")


def _spec():
    from impactbench.scenarios.oblique import SPEC

    return SPEC


def add_flags(parser: argparse.ArgumentParser) -> None:
    """The scenario's field flags and options from its spec (as
    :func:`impactbench.flags.add_parameter_flags` does for a registered scenario; defaults
    None, so an explicit value can be told from the default)."""

    spec = _spec()
    defaults = spec.cls()
    group = parser.add_argument_group(f"{spec.title.lower()}: physical parameters (SI; "
                                      "defaults are the paper's)")
    for f in spec.flags:
        if f"--{f.flag}" in parser._option_string_actions:
            continue
        group.add_argument(f"--{f.flag}", type=number, default=None, dest=f.field,
                           metavar="X", help=f"{f.help}; default {getattr(defaults, f.field):g}")
    spec.add_options(group, False)


def scenario_from_args(args: argparse.Namespace, **overrides: Any) -> Any:
    """Build and validate the scenario from parsed flags (``overrides`` win)."""
    spec = _spec()
    fields = set(spec.cls.field_names())
    values = {k: v for k, v in vars(args).items() if k in fields and v is not None}
    values = spec.from_args(args, values)  # a method of the spec (scenarios/spec.py)
    values.update(overrides)
    return spec.cls(**values)


def register(top: argparse._SubParsersAction, groups: dict) -> None:
    spec = _spec()
    p = groups["reference"].add_parser(spec.name, help=REFERENCE_HELP,
                                       description=REFERENCE_HELP + ".")
    p.add_argument("--velocity", type=number_list, action="extend", dest="velocities",
                   metavar="V", help="impact speed V in m/s; repeat the flag or give a comma "
                   "list for several (default 2.0, or the --case's)")
    p.add_argument("--angle-deg", type=number_list, action="extend", dest="angles",
                   metavar="DEG", help="incidence angle θ from the plate normal in degrees, in "
                   "[0, 90); repeat the flag or give a comma list for several (default 45)")
    add_flags(p)
    p.add_argument("--json", action="store_true",
                   help="print JSON (one object, or a list for several points)")
    p.set_defaults(func=reference_main)

    help_sweep = "oblique impact: the metrics over an incidence-angle grid into a table"
    s = groups["sweep"].add_parser(spec.name, help=help_sweep,
                                   description=help_sweep + " (CSV or Parquet by extension).")
    s.add_argument("--over", required=True, choices=("angle-deg",), help="the swept parameter")
    s.add_argument("--start", type=number, required=True, metavar="A", help="first angle (°)")
    s.add_argument("--stop", type=number, required=True, metavar="B",
                   help="last angle (°, included when on the grid; < 90)")
    s.add_argument("--step", type=number, required=True, metavar="H", help="grid step (°)")
    s.add_argument("--velocity", type=number, default=None, dest="velocity_m_s", metavar="V",
                   help="impact speed V (m/s); default 2.0, or the --case's")
    s.add_argument("--out", type=Path, required=True, metavar="FILE",
                   help="output table: .csv or .parquet")
    s.add_argument("--yes", action="store_true", help="sweep even over more than 1e7 points")
    add_flags(s)
    s.set_defaults(func=sweep_main)


def sweep_main(args: argparse.Namespace) -> int:
    """The reference over the angle grid (rigid: one vectorised closed form; mindlin: one
    integration per angle), written as a table."""
    from impactbench.cliutil import table_format, write_table
    from impactbench.publish import check_file_target
    from impactbench.reference import oblique
    from impactbench.reference.oblique_scenario import CASE_POINTS

    table_format(args.out)
    check_file_target(args.out, "out")
    case_point = CASE_POINTS.get(args.case, {}) if args.case else {}
    v = args.velocity_m_s if args.velocity_m_s is not None else case_point.get("velocity_m_s")
    base = scenario_from_args(args, **({"velocity_m_s": v} if v is not None else {}))
    angles = angle_grid(args.start, args.stop, args.step, yes=args.yes)
    table = oblique.sweep(base, angles)
    write_table(table, args.out)
    print(f"wrote {len(table)} rows to {args.out}", file=sys.stderr)
    return 0


def angle_grid(start: float, stop: float, step: float, *, yes: bool = True) -> list[float]:
    """The incidence angles start, start + step, …, ≤ stop (°): :func:`cliutil.grid`, but an
    angle may start at 0 (normal incidence). One-line errors name the bad field: step > 0,
    start ≥ 0, stop ≥ start."""
    from impactbench.cliutil import grid
    from impactbench.reference import validation as check

    check.positive("step", step)
    check.non_negative("start", start)
    if stop < start:
        raise ValueError(f"stop = {stop!r}: must be >= start ({start!r})")
    if start > 0:
        return list(grid(start, stop, step, yes=yes))
    # from 0: 0 then step, 2·step, … (grid's values from step, as before)
    return [0.0, *(grid(step, stop, step, yes=yes) if stop >= step else [])]


def _with_status(scenario: Any, metrics: dict) -> dict:
    """The JSON object of one point: the inputs, the metrics, status and message."""
    problem = _spec().problem(scenario, metrics)
    return {"velocity_m_s": scenario.velocity_m_s, "angle_deg": scenario.angle_deg, **metrics,
            "status": "unsupported" if problem else "ok", "message": problem}


def reference_main(args: argparse.Namespace) -> int:
    from impactbench.reference.oblique_scenario import CASE_POINTS

    spec = _spec()
    case_point = CASE_POINTS.get(args.case, {}) if args.case else {}
    angles = args.angles or [case_point.get("angle_deg")]
    velocities = args.velocities or [case_point.get("velocity_m_s")]
    scenarios = []
    for a in angles:
        for v in velocities:
            point = {k: x for k, x in (("angle_deg", a), ("velocity_m_s", v)) if x is not None}
            scenarios.append(scenario_from_args(args, **point))
    results = [_with_status(s, spec.reference_metrics(s)) for s in scenarios]
    s = scenarios[0]
    return print_points(results, args.json, f"oblique impact, {s.tangential} tangential "
                        f"contact: m = {s.mass_kg:g} kg, R = {s.radius_m:g} m, c = "
                        f"{s.stiffness:g} N/m^n, n = {s.exponent:g}, {s.model} "
                        f"{damping_text(s)}, μ = {s.friction:g}, ω0 = {s.spin_rad_s:g} rad/s",
                        ("angle_deg", "velocity_m_s", *spec.metrics, "status"))


def build_parser() -> argparse.ArgumentParser:
    """An ``impactbench`` parser with only this command (the scenario need not be
    registered)."""
    from impactbench.cli import Parser, add_commands

    parser = Parser(prog="impactbench")
    register(*add_commands(parser))
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """``impactbench reference oblique …`` without the registry; returns the exit code
    (bad input: one line ``impactbench: error: …`` on stderr, exit 2, as the CLI)."""
    try:
        args = build_parser().parse_args(argv)
        return int(args.func(args) or 0)
    except ValueError as exc:
        if os.environ.get("IMPACTBENCH_DEBUG"):
            raise
        print(f"impactbench: error: {exc}", file=sys.stderr)
        return 2
