"""``impactbench run``: one engine, one scenario, one mode, compared with the reference."""

from __future__ import annotations

import argparse

from impactbench.cliutil import number, print_json, print_table, stdout_to_stderr
from impactbench.engines.base import ENGINES, MODES, RunSettings
from impactbench.evaluate import compare
from impactbench.params import add_law_flags, add_parameter_flags, scenario_from_args

HELP = "run one scenario in one engine and compare it with the reference"


def register(top: argparse._SubParsersAction, groups: dict) -> None:
    p = top.add_parser("run", help=HELP, description=HELP + ". Parameter flags of both "
                       "scenarios are accepted; those of the other scenario are ignored.")
    p.add_argument("--engine", required=True, choices=tuple(ENGINES))
    p.add_argument("--scenario", required=True, choices=("ball-on-plate", "rigid-flexible"))
    p.add_argument("--mode", default="native", choices=MODES,
                   help="native: the engine's contact model with mapped parameters; "
                   "injected: the reference law driven through the engine; tuned: fitted "
                   "parameters (default native)")
    p.add_argument("--velocity", type=number, required=True, dest="velocity_m_s",
                   metavar="V", help="impact velocity V0 or v1 (m/s)")
    p.add_argument("--timestep", type=number, default=None, dest="timestep_s", metavar="S",
                   help="integration step (s); default: the adapter's for the scenario")
    add_law_flags(p)
    add_parameter_flags(p, "ball-on-plate")
    add_parameter_flags(p, "rigid-flexible")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=main)


def main(args: argparse.Namespace) -> int:
    scenario = scenario_from_args(args.scenario, args)
    settings = RunSettings(timestep_s=args.timestep_s)
    if args.mode == "tuned":
        from impactbench.tuned import load_tuned

        settings = RunSettings(timestep_s=args.timestep_s,
                               tuned=load_tuned(args.engine, args.scenario))
    with stdout_to_stderr():
        out, _ = compare(args.engine, scenario, args.mode, settings)
    if args.json:
        print_json(out)
        return 0
    print(f"{out['engine']} {out['engine_version']}  mode {out['mode']}  "
          f"timestep {out['timestep_s']} s  status {out['status']}"
          + (f" ({out['message']})" if out["message"] else "")
          + f"  wall {out['wall_s']:.3g} s")
    rows = [{"metric": k, "engine": out[k], "reference": out["reference"][k],
             "rel_error": out["rel_error"][k]} for k in out["rel_error"]]
    print_table(rows)
    return 0
