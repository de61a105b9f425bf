"""``impactbench advise``: the best contact settings for an engine at your step, for your body.

Searches every contact model the engine offers (:mod:`impactbench.advise`), each candidate run
at every speed at 8 phases of the step and judged at its worst. Prints first the settings to
paste in the engine's own words, then a per-speed table (reference e, engine e: median and
range over the phases, worst error, the step's own overlap and the contact's sinking, over the
radius), and writes the trade-off figure (``--figure``: worst restitution error against the
contact's sinking, every candidate). The body: the paper's steel ball by default, or
``--material``, ``--radius``, ``--mass``; the target: its Hunt–Crossley restitution over
``--velocities``, or a measured restitution-vs-speed CSV (``--target``, columns
``velocity_m_s,restitution``). ``--json`` prints the answer as one object: ``params`` (the
engine's own keys: ``impactbench run ball-on-plate --engine E --mode custom --param
KEY=VALUE --timestep S`` reruns it) and ``per_speed``.
"""

from __future__ import annotations

import argparse
import math
from typing import Any

from impactbench.cliutil import number_list, print_json

HELP = "the best contact settings for an engine at your step, for your body"


def register(top: argparse._SubParsersAction, groups: dict) -> None:
    from impactbench.flags import add_parameter_flags
    from impactbench.scenarios.ball_on_plate import NAME as BALL

    p = top.add_parser("advise", help=HELP, description=HELP + ".")
    p.add_argument("--engine", required=True, help="the engine (mujoco, pybullet, …)")
    p.add_argument("--timestep", type=float, dest="advise_timestep_s", metavar="S",
                   help="your step (s; default: the engine's customary one)")
    add_parameter_flags(p, BALL)
    p.add_argument("--velocities", type=number_list, dest="advise_velocities",
                   metavar="V", help="impact speeds (m/s), comma list (default 0.5–5)")
    p.add_argument("--target", metavar="CSV", dest="advise_target",
                   help="measured restitution: a CSV with columns velocity_m_s,restitution")
    p.add_argument("--budget", type=float, default=None, dest="advise_budget_s", metavar="S",
                   help="wall time the search may take (s; default 60)")
    p.add_argument("--figure", metavar="PNG", dest="advise_figure",
                   help="write the trade-off figure (error against sinking) here")
    p.add_argument("--write", nargs="?", const="", default=None, metavar="TOML",
                   dest="advise_write",
                   help="write the answer as an advice file (default: the packaged one, "
                        "impactbench/data/advice/<engine>_dt<step>.toml)")
    p.add_argument("--workers", type=int, default=None, metavar="N", dest="advise_workers",
                   help="local worker processes for the candidates' runs (default one per "
                        "core; 0: in this process)")
    p.add_argument("--json", action="store_true", help="print the answer as JSON")
    p.set_defaults(func=main)


def _pct(x: float) -> str:
    return "—" if not math.isfinite(x) else f"{100.0 * x:.1f} %"


def text(a: Any) -> str:
    """The answer as a person reads it: the snippet, the table, the verdict."""
    head = (f"{a.engine} at dt = {a.timestep_s:.6g} s, contact model: {a.model}"
            + (f" (searched on {a.searched_on}, checked in {a.engine})"
               if a.searched_on != a.engine else ""))
    lines = [head, "", "Paste:", *("    " + s for s in a.snippet.splitlines()), "",
             f"{'V (m/s)':>8} {'ref e':>7} {'e median':>9} {'e range':>15} {'worst err':>10} "
             f"{'step ovl/R':>11} {'sink/R':>8}  status"]
    for r in a.per_speed:
        rng = (f"{r['restitution_min']:.3f}–{r['restitution_max']:.3f}"
               if math.isfinite(r["restitution_min"]) else "—")
        if 0 < r["phases_measured"] < len(a.phases):
            rng += f" ({r['phases_measured']}/{len(a.phases)})"
        lines.append(f"{r['velocity_m_s']:>8g} {r['reference_restitution']:>7.3f} "
                     f"{r['restitution']:>9.3f} {rng:>15} {_pct(r['worst_error']):>10} "
                     f"{r['step_overlap_ratio']:>11.3g} {r['sinking_ratio']:>8.3g}  "
                     f"{r['status']}")
    lines.append("")
    n = len(a.phases)
    if a.plausible:
        lines.append(f"Plausible at every speed and all {n} phases of the step; worst "
                     f"restitution error {_pct(a.worst_error)}.")
    else:
        fb = a.fallback or {}
        lines.append(f"No setting is plausible at every speed and phase at this step "
                     f"({len(a.tried)} candidates).")
        if fb.get("timestep_s"):
            lines.append(f"Run at dt <= {fb['timestep_s']:.4g} s ({fb['model']}: plausible, "
                         f"worst error {_pct(fb['worst_error'])}), or accept a worst error of "
                         f"{_pct(fb['accept'])} with implausible runs.")
        elif fb:
            lines.append(f"Nothing is plausible at any step down to 1e-05 s either; the best "
                         f"here errs by {_pct(fb['accept'])}, with implausible runs.")
    if a.note:
        lines.append(f"The model: {a.note}.")
    lines.append(f"({len(a.tried)} candidates in {a.wall_s:.1f} s, {a.engine} "
                 f"{a.engine_version})")
    return "\n".join(lines)


def main(args: argparse.Namespace) -> int:
    from impactbench.advise import DEFAULT_BUDGET_S, DEFAULT_VELOCITIES_M_S, advise
    from impactbench.flags import scenario_from_args
    from impactbench.scenarios.ball_on_plate import NAME as BALL

    scenario = scenario_from_args(BALL, args)
    a = advise(args.engine, args.advise_timestep_s, scenario,
               DEFAULT_VELOCITIES_M_S if args.advise_velocities is None
               else args.advise_velocities,
               target_csv=args.advise_target,
               budget_s=DEFAULT_BUDGET_S if args.advise_budget_s is None
               else args.advise_budget_s, workers=args.advise_workers)
    if args.advise_figure:
        from impactbench.plots import advice_figure

        advice_figure(a, args.advise_figure)
    if args.advise_write is not None:
        from impactbench.advice_files import advice_path, write

        write(a, args.advise_write or advice_path(a.engine, a.timestep_s))
    if args.json:
        print_json(a.to_json())
    else:
        print(text(a))
    return 0
