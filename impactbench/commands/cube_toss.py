"""``impactbench reference cube-toss``: what the measurement holds for the selected tosses.

The cube tosses' reference is the measurement itself (MODELS.md §4): this prints the data file
(and its SHA-256), the selection (``--tosses``, default the test split; with ``--data``, every
toss of the file) and its ids, the split's sizes in the file, samples, the sample interval, the
tosses' initial speed and spin and resting height (medians) and the box. Engines replay the
tosses with ``impactbench run cube-toss``.
"""

from __future__ import annotations

import argparse

from impactbench.cliutil import print_json, print_table
from impactbench.flags import add_parameter_flags, scenario_from_args
from impactbench.scenarios.cube_toss import NAME


def register(top: argparse._SubParsersAction, groups: dict) -> None:
    help_ref = "real cube tosses (DAIR's ContactNets data): what the selected tosses hold"
    p = groups["reference"].add_parser(NAME, help=help_ref, description=help_ref + ". The "
                                       "measurement is the reference; `impactbench run "
                                       f"{NAME}` replays it in an engine.")
    add_parameter_flags(p, NAME)
    p.add_argument("--json", action="store_true",
                   help="print one JSON object: data, data_sha256, selection, tosses, ids, "
                   "tosses_in_file, train_in_file, test_in_file, samples, …, the box")
    p.set_defaults(func=reference_main)


def reference_main(args: argparse.Namespace) -> int:
    from impactbench.scenarios import get

    scenario = scenario_from_args(NAME, args)
    out = get(NAME).reference_metrics(scenario)
    if args.json:
        print_json(out)
        return 0
    ids = out["ids"]
    shown = ", ".join(str(i) for i in ids[:12]) + (" …" if len(ids) > 12 else "")
    print(f"cube tosses  {out['data']}  selection {out['selection']}: {out['tosses']} tosses "
          f"({shown})")
    print_table([{"quantity": k, "value": v} for k, v in out.items()
                 if k not in ("ids", "data", "selection", "tosses")])
    return 0
