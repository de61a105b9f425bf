"""``impactbench calibrate --data FILE.csv``: fit a contact model to measured impacts.

Fits the model's damping (b, or the nominal restitution), and its stiffness c (and with
``--fit-exponent`` n) when durations or peak forces are given, by least squares on relative
residuals with 95 % confidence intervals from the Jacobian (:mod:`impactbench.calibrate`);
prints the estimates and the residual of every measured value, and writes a scenario file
(``--out``) that ``run``, ``tune`` and ``report`` accept with ``--scenario-file``. The ball's
fixed fields (mass, radius, model, …) come from the usual ball flags; ``--material`` sets the
ball (mass from its density, Hertz c from E and ν) but not the law fitted. It names the law it
fits and warns (stderr) on a residual trend with velocity, an interval reaching an impossible
value, and an rms residual above ``--max-rms``.
"""

from __future__ import annotations

import argparse
import math
import shlex
import sys
from pathlib import Path

from impactbench.cliutil import number, print_json, print_table
from impactbench.flags import add_parameter_flags, scenario_from_args
from impactbench.scenarios import for_study

HELP = "fit a contact model's damping (and stiffness) to measured impacts, with intervals"


def register(top: argparse._SubParsersAction, groups: dict) -> None:
    p = top.add_parser("calibrate", help=HELP, description=__doc__.split("\n\n")[1])
    p.add_argument("--data", type=Path, required=True, metavar="FILE",
                   help="CSV with velocity_m_s, restitution and optionally duration_s, "
                   "peak_force_n (one impact per row; # comments)")
    p.add_argument("--out", type=Path, default=None, metavar="FILE",
                   help="scenario file to write (default <data name>_scenario.toml in the cwd)")
    p.add_argument("--fit-exponent", action="store_true",
                   help="also fit the exponent n (needs durations or peak forces)")
    p.add_argument("--confidence", type=number, default=0.95, metavar="P",
                   help="confidence level of the intervals; default 0.95")
    p.add_argument("--max-rms", type=number, default=None, dest="max_rms", metavar="R",
                   help="warn when the rms relative residual exceeds R; default "
                   "0.03 (3 %%)")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    add_parameter_flags(p, for_study("calibrate").name, with_gravity=False)
    p.set_defaults(func=main)


def main(args: argparse.Namespace) -> int:
    from impactbench.calibrate import (
        MAX_RMS_REL,
        calibrate,
        read_measurements,
        write_scenario_file,
    )

    data = read_measurements(args.data)
    model = args.model or "hunt-crossley"
    # a model set from a nominal restitution fits that e: any start value will do
    placeholder = {} if model == "hunt-crossley" or args.nominal_restitution is not None \
        else {"nominal_restitution": 0.9}
    base = scenario_from_args(for_study("calibrate").name, args, **placeholder)
    if base.model == "hunt-crossley" and args.nominal_restitution is None \
            and getattr(args, "damping_s_per_m", None) is None and args.material is not None:
        # the material gives the ball (density, E, ν) and, for a run, a damping from its
        # nominal e; fitted, that e would switch the law to a constant restitution: the law
        # stays the one the flags (or the scenario file) name
        kept = None
        if args.scenario_file:
            from impactbench.scenario_file import load_scenario_file

            kept = load_scenario_file(args.scenario_file).get("nominal_restitution")
        base = base.replace(nominal_restitution=kept)
    max_rms = MAX_RMS_REL if args.max_rms is None else args.max_rms
    cal = calibrate(data, base, fit_exponent=args.fit_exponent, confidence=args.confidence,
                    max_rms=max_rms)
    out = args.out or Path(f"{args.data.stem}_scenario.toml")
    command = "impactbench " + " ".join(shlex.quote(a) for a in sys.argv[1:])
    path = write_scenario_file(cal, out, command=command)
    for warning in cal.warnings:
        print(f"impactbench: warning: {warning}", file=sys.stderr)
    if args.json:
        print_json({
            "model": cal.scenario.model, "law": cal.law, "estimates": cal.estimates,
            "intervals": {k: list(v) for k, v in cal.intervals.items()},
            "standard_errors": cal.standard_errors, "confidence": cal.confidence,
            "points": cal.points, "dof": cal.dof, "rms_rel_error": cal.rms_rel_error,
            "max_rms": cal.max_rms, "warnings": cal.warnings,
            "residuals": cal.residuals.to_dict(orient="records"),
            "scenario": {k: v for k, v in cal.scenario.to_dict().items()
                         if k != "velocity_m_s"},
            "scenario_file": str(path)})
        return 0
    pct = f"{100 * cal.confidence:g} %"
    print(f"calibrated {cal.scenario.model} (m = {cal.scenario.mass_kg:g} kg) to "
          f"{cal.points} values of {data.source}; {cal.dof} degrees of freedom")
    print(f"law: {cal.law}")
    rows = [{"parameter": p.name, "unit": p.unit, "estimate": cal.estimates[p.name],
             "std_error": cal.standard_errors[p.name],
             f"{pct} low": cal.intervals[p.name][0], f"{pct} high": cal.intervals[p.name][1]}
            for p in cal.parameters]
    print_table(rows, floatfmt=".6g")
    if cal.dof == 0:
        print("(as many values as parameters: the fit interpolates; no intervals)")
    print(f"\nresiduals (model − measured)/measured; rms {100 * cal.rms_rel_error:.3g} % "
          f"(bound {100 * cal.max_rms:g} %):")
    print_table(cal.residuals.to_dict(orient="records"), floatfmt=".6g")
    eff = cal.scenario.replace(velocity_m_s=1.0)
    if not math.isnan(cal.estimates.get("nominal_restitution", math.nan)):
        from impactbench.reference.zoo import effective_restitution

        print(f"\neffective restitution of the fitted model: "
              f"{effective_restitution(eff.model, eff.nominal_restitution):.6g}")
    print(f"\nscenario file: {path}  (use with run/tune/report --scenario-file)")
    return 0
