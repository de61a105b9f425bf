"""``impactbench tune``: fit an engine's native contact parameters to Hunt–Crossley.

Output, in this order: the fitted parameters in the engine's own form (MJCF, changeDynamics,
pymunk settings, Drake AddContactMaterial), a residual table per velocity and metric (start
vs tuned), an honesty section (what the engine cannot express; best achieved vs start max
relative error per metric, and the floor no linear contact can beat), and the files written.

Files:
- tuned file: ``--out FILE``; with ``--write-default`` the packaged
  ``impactbench/data/tuned/<engine>_ball_on_plate.toml`` that ``run --mode tuned`` and the
  report read; otherwise ``tuned_<engine>.toml`` in the current directory.
- residual plot: ``--plot FILE``; default next to the tuned file (same name, ``.png``), or
  ``reports/figures/tune_<engine>.png`` of the repository with ``--write-default``.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from impactbench import scenarios
from impactbench.cliutil import (
    add_execution_flags,
    check_workers,
    flag_names,
    key_value,
    number,
    number_list,
    print_json,
    print_table,
)
from impactbench.engines.registry import ENGINES
from impactbench.flags import add_parameter_flags
from impactbench.reference import validation as check
from impactbench.reference.scenarios import PAPER_VELOCITIES_M_S

HELP = ("fit an engine's native contact parameters to the reference (Hunt–Crossley, or any "
        "--model)")
REPO_FIGURES = Path(__file__).resolve().parents[2] / "reports" / "figures"


def own_fit(scenario: str) -> str | None:
    """``impactbench.commands.tune_<scenario>`` when it exists: the scenario is fitted by a
    module of its own (``main(args)``; the oblique friction knobs); else None."""
    from importlib.util import find_spec

    name = f"impactbench.commands.tune_{scenario.replace('-', '_')}"
    return name if find_spec(name) is not None else None


def name_list(text: str) -> list[str]:
    """argparse type: a comma-separated list of names (empty entries dropped)."""
    return [p.strip() for p in text.split(",") if p.strip()]


def register(top: argparse._SubParsersAction, groups: dict) -> None:
    from impactbench.tuning.names import (
        DEFAULT_BUDGET_S,
        DEFAULT_TARGETS,
        SOLREF_FORMS,
        TARGETS,
        VARIANTS,
    )

    p = top.add_parser("tune", help=HELP, description=HELP + ". " + __doc__.split("\n\n")[1])
    p.add_argument("--engine", required=True, metavar="E", help=f"one of {', '.join(ENGINES)}")
    tunable = [s.name for s in scenarios.specs() if "tuning" in s.studies]
    data_driven = [s.name for s in scenarios.specs() if s.measured]
    own = [s.name for s in scenarios.specs() if own_fit(s.name)]
    p.add_argument("--scenario", default=tunable[0], metavar="S",
                   help=f"{' | '.join(tunable + data_driven + own)} (the scenarios that serve "
                   "tuning; a data-driven one is fitted to its training measurements, oblique's "
                   "friction knobs to its reference over --angles)")
    p.add_argument("--velocities", type=number_list, default=None,
                   dest="velocities_m_s", metavar="V,…",
                   help="impact velocities (m/s); default the paper's 0.5,1,2,3,4,5 (oblique: "
                   "2)")
    p.add_argument("--angles", type=number_list, default=None, dest="angles_deg",
                   metavar="A,…", help="oblique: the incidence angles of the fit (degrees, in "
                   "(0, 90)); default 20,45,60,80")
    p.add_argument("--targets", type=name_list, default=list(DEFAULT_TARGETS), metavar="T,…",
                   help=f"metrics to fit, from {', '.join(TARGETS)}; default "
                   f"{','.join(DEFAULT_TARGETS)}")
    p.add_argument("--weights", type=number_list, default=None, metavar="W,…",
                   help="one weight ≥ 0 per target (use --weights=… for a leading minus); "
                   "default all 1")
    params_help = "; ".join(f"{e}: {'|'.join(v)}" for e, v in VARIANTS.items())
    p.add_argument("--parameters", default=None, metavar="SET",
                   help=f"the engine's parameter set (first is the default) — {params_help}")
    p.add_argument("--solref-form", default="direct", choices=SOLREF_FORMS,
                   help="MuJoCo solref form: direct (−stiffness, −damping) or timeconst "
                   "(timeconst, dampratio); default direct")
    p.add_argument("--timestep", type=number, default=None, dest="timestep_s", metavar="S",
                   help="integration step (s); default the adapter's (1e-6 s for the ball)")
    p.add_argument("--budget-s", type=number, default=DEFAULT_BUDGET_S, metavar="S",
                   help=f"wall-time budget (s), stops cleanly keeping the best; default "
                   f"{DEFAULT_BUDGET_S:g}")
    p.add_argument("--max-evals", "--budget", type=int, default=None, metavar="N",
                   dest="max_evals",
                   help="evaluation budget (one evaluation = one run per velocity; for "
                   "cube-toss one replay of the training tosses, default 160)")
    p.add_argument("--seed", type=int, default=None, metavar="N",
                   help="cube-toss: the optimiser's seed (default 20240607)")
    p.add_argument("--optimizer", default=None, metavar="NAME",
                   help="cube-toss: a nevergrad optimiser (default CMA; NGOpt is DAIR's)")
    out = p.add_mutually_exclusive_group()
    out.add_argument("--out", type=Path, default=None, metavar="FILE",
                     help="tuned file to write; default tuned_<engine>.toml in the cwd")
    out.add_argument("--write-default", action="store_true",
                     help="write the packaged default impactbench/data/tuned/"
                     "<engine>_<scenario>.toml (read by run --mode tuned and the report)")
    p.add_argument("--plot", type=Path, default=None, metavar="FILE",
                   help="residual plot PNG; default next to the tuned file")
    p.add_argument("--no-plot", action="store_true", help="do not draw the residual plot")
    p.add_argument("--param", type=key_value, action="append", default=[], dest="fixed",
                   metavar="KEY=VALUE",
                   help="an engine setting held fixed and written with the fit (repeatable), "
                   "e.g. Drake's discrete_contact_approximation=sap for a discrete plant")
    p.add_argument("--phases", type=int, default=None, metavar="N",
                   help="phases of the step each velocity is run at, judged at the worst "
                        "(default: 8 at a step not much shorter than the contact, else 1)")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    add_execution_flags(p, in_process=True)
    added: set[str] = set()
    for name in tunable + data_driven + own:
        add_parameter_flags(p, name, added=added)
    p.set_defaults(func=main, flags={**flag_names(p), "params": "--param"})


def _paths(args: argparse.Namespace) -> tuple[Path, Path | None]:
    from impactbench.tuned import tuned_path

    if args.write_default:
        tuned = tuned_path(args.engine, args.scenario)
        plot = args.plot or REPO_FIGURES / f"tune_{args.engine}.png"
    else:
        tuned = args.out or Path(f"tuned_{args.engine}.toml")
        plot = args.plot or tuned.with_suffix(".png")
    return tuned, (None if args.no_plot else plot)


def main(args: argparse.Namespace) -> int:
    from impactbench import api
    from impactbench.engines.base import EngineUnavailable

    check.one_of("engine", args.engine, tuple(ENGINES))
    check.one_of("scenario", args.scenario, scenarios.names())
    if scenarios.get(args.scenario).measured:
        from impactbench.commands import tune_tosses

        args.seed = 20240607 if args.seed is None else args.seed
        args.optimizer = args.optimizer or "CMA"
        return tune_tosses.main(args)
    fitted_by = own_fit(args.scenario)
    if fitted_by is not None:
        import importlib

        return importlib.import_module(fitted_by).main(args)
    if args.angles_deg is not None:
        raise ValueError(f"angles = {args.angles_deg}: only the oblique fit sweeps angles")
    if args.velocities_m_s is None:
        args.velocities_m_s = list(PAPER_VELOCITIES_M_S)
    for flag in ("seed", "optimizer"):
        if getattr(args, flag) is not None:
            raise ValueError(f"{flag} = {getattr(args, flag)!r}: only the cube-toss fit "
                             "takes it (the ball's fit is deterministic, scipy)")
    spec = scenarios.get(args.scenario)
    if spec.tuned_from:  # its tuned runs take another scenario's files (the bounce: the ball's)
        which = "" if "tuning" in scenarios.get(spec.tuned_from).studies \
            else f" --scenario {spec.tuned_from}"
        raise ValueError(f"scenario = {args.scenario!r}: its tuned runs take the "
                         f"{spec.tuned_from} files fitted at the run's step; fit that one "
                         f"(impactbench tune{which} --engine {args.engine} --timestep S)")
    if "tuning" not in spec.studies:
        tunable = [s.name for s in scenarios.specs() if "tuning" in s.studies]
        raise ValueError(f"scenario = {args.scenario!r}: tuning is not supported yet for it "
                         f"({', '.join(tunable)} only)")
    tuned_file, plot_file = _paths(args)
    check_workers(args.workers)
    fields = {k: getattr(args, k) for k in api.scenario_keywords(args.scenario, point=False)
              if getattr(args, k, None) is not None}
    try:
        with api.command_line(args.flags):
            fit = api.tune(args.engine, args.scenario, velocities_m_s=args.velocities_m_s,
                           targets=args.targets, weights=args.weights,
                           parameters=args.parameters, solref_form=args.solref_form,
                           timestep_s=args.timestep_s, budget_s=args.budget_s,
                           max_evals=args.max_evals, params=dict(args.fixed) or None,
                           out=tuned_file, plot=plot_file, store=args.store,
                           fresh=args.fresh, workers=args.workers, scheduler=args.scheduler,
                           yes=args.yes, phases=args.phases, **fields)
    except EngineUnavailable as exc:
        print(f"impactbench: error: {exc}")
        return 1
    if args.json:
        print_json(fit.data)
        return 0
    _print_text(fit.result, fit.files, fit.ran_on)
    return 0


def _print_text(result, files: dict[str, str], where: str) -> None:
    from impactbench.tuning import output

    obj = result.objective
    print(f"{result.space.engine} {result.engine_version}  parameters {result.space.variant}  "
          f"mode {result.space.mode}  timestep {result.timestep_s:g} s")
    print(f"velocities {', '.join(f'{v:g}' for v in obj.velocities_m_s)} m/s; targets "
          + ", ".join(f"{k} (w {w:g})" for k, w in obj.weights.items()))
    print(f"{obj.evaluations} evaluations × {len(obj.velocities_m_s)} runs in "
          f"{result.wall_s:.1f} s ({result.stop}) {where}; {obj.served} runs from the store, "
          f"{obj.stored} stored")
    for line in result.stages:
        print(f"  {line}")
    if result.excluded:
        for why in dict.fromkeys(result.excluded.values()):
            keys = [k for k, w in result.excluded.items() if w == why]
            print(f"note: {', '.join(keys)} excluded from the objective (weight 0): {why}")
    print("\nfitted parameters (the engine's own form):")
    print(result.space.snippet(result.parameters))
    print(f"tuned keys: {result.parameters}")
    print(f"start (closed-form native conversion): {result.start_parameters}")
    print("\nresiduals per velocity and metric (relative errors vs the reference):")
    print_table(output.residual_rows(result),
                ["velocity_m_s", "metric", "weight", "reference", "start", "start_rel_error",
                 "tuned", "tuned_rel_error"])
    print("\nhonesty:")
    for line in output.honesty_lines(result):
        print(f"- {line}")
    print_table(output.summary_rows(result), floatfmt=".4g")
    if result.space.engine == "drake":
        print(f"\ntrade-off: {result.space.parameters[0].name} scaled around the tuned value "
              f"(dissipation kept; restitution depends on it alone):")
        print_table(output.tradeoff_rows(result), floatfmt=".4g")
    print()
    for kind, path in files.items():
        print(f"{kind}: {path}")
