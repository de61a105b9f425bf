"""``impactbench tune --scenario oblique``: fit an engine's friction knobs to the oblique
reference over an angle sweep at one step (:mod:`impactbench.tuning.oblique`).

Output: the objective of the native run and of the fit, the worst error per metric, the native
and tuned values per angle and metric, the parameters (the engine's own keys, with the space
searched), and the file written (``--out FILE``, else ``tuned_<engine>_oblique.toml``;
``--write-default`` the packaged ``impactbench/data/tuned/<engine>_oblique.toml`` that
``run --scenario oblique --mode tuned`` and the report read).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from impactbench.cliutil import print_json, print_table, stdout_to_stderr

CUSTOM_TARGETS_HINT = "weight them with --weights W1,W2,W3"


def _out_path(args: argparse.Namespace) -> Path:
    from impactbench.tuned import tuned_path

    if args.write_default:
        return tuned_path(args.engine, args.scenario)
    return args.out or Path(f"tuned_{args.engine}_oblique.toml")


def _refuse_ball_options(args: argparse.Namespace) -> None:
    """The ball's fit options that mean nothing here: a one-line error each (never ignored)."""
    from impactbench.tuning.names import DEFAULT_BUDGET_S, DEFAULT_TARGETS
    from impactbench.tuning.oblique import TARGETS

    if list(args.targets) != list(DEFAULT_TARGETS):
        raise ValueError(f"targets = {','.join(args.targets)}: the oblique fit's targets are "
                         f"{', '.join(TARGETS)}; {CUSTOM_TARGETS_HINT}")
    given = {"parameters": args.parameters,
             "param": ",".join(f"{k}={v}" for k, v in args.fixed) or None,
             "plot": None if args.plot is None else str(args.plot),
             "optimizer": args.optimizer,
             "solref-form": None if args.solref_form == "direct" else args.solref_form,
             "budget-s": None if args.budget_s == DEFAULT_BUDGET_S else args.budget_s,
             "angle-deg": getattr(args, "angle_deg", None)}
    why = {"parameters": "the oblique knobs are the engine's friction keys, all fitted",
           "param": "the oblique fit holds nothing fixed",
           "plot": "the oblique fit prints its residuals (use --json for the numbers)",
           "optimizer": "the oblique fit uses the one tuner's Nelder-Mead (a seeded Sobol "
                        "scan, then scipy's Nelder-Mead)",
           "solref-form": "MuJoCo's oblique knobs are cone, impratio and friction",
           "budget-s": "the oblique fit's budget is --max-evals (deterministic)",
           "angle-deg": "the fit sweeps --angles"}
    for flag, value in given.items():
        if value is not None:
            raise ValueError(f"{flag} = {value!r}: not an option of the oblique fit ({why[flag]})")


def main(args: argparse.Namespace) -> int:
    """The oblique branch of ``impactbench tune`` (called by :mod:`.tune`)."""
    from impactbench.cliutil import check_cost
    from impactbench.engines import oblique_tuned
    from impactbench.engines.base import EngineUnavailable, get_adapter
    from impactbench.evaluate import reference_metrics
    from impactbench.flags import scenario_from_args
    from impactbench.matrix import estimated_steps_of
    from impactbench.publish import check_file_target
    from impactbench.reference import validation as check
    from impactbench.tuning import oblique

    check.one_of("engine", args.engine, tuple(oblique_tuned.SPACES))
    _refuse_ball_options(args)
    angles = oblique.check_angles(oblique.DEFAULT_ANGLES_DEG if args.angles_deg is None
                                  else args.angles_deg)
    speeds = [oblique.DEFAULT_VELOCITY_M_S] if args.velocities_m_s is None \
        else list(args.velocities_m_s)
    if not speeds:
        raise ValueError("velocities = []: must list at least one impact speed")
    for v in speeds:
        check.positive("velocities", v)
    budget = oblique.DEFAULT_MAX_EVALS if args.max_evals is None else args.max_evals
    if budget < 1:
        raise ValueError(f"max-evals = {budget!r}: must be an integer >= 1 (evaluations, the "
                         "start included)")
    seed = oblique.SEED if args.seed is None else args.seed
    if seed < 0:
        raise ValueError(f"seed = {seed!r}: must be an integer >= 0")
    weights = oblique.check_weights(args.weights) if args.weights is not None else None
    if args.timestep_s is not None:
        check.positive("timestep", args.timestep_s)
    scenario = scenario_from_args(args.scenario, args)
    if args.timestep_s is not None:
        steps = sum(estimated_steps_of(reference_metrics(scenario.replace(
            angle_deg=a, velocity_m_s=v)), args.timestep_s) for v in speeds for a in angles)
        check_cost(steps, f"timestep = {args.timestep_s!r}", args.yes,
                   "integration steps per evaluation")
    out_file = _out_path(args)
    check_file_target(out_file, "out")  # before the fit, not after

    def progress(done: int, total: int, objective: float, best: float) -> None:
        if not args.json:
            print(f"\r  evaluation {done}/{total}: J {objective:.6g}, best {best:.6g}   ",
                  end="", file=sys.stderr, flush=True)

    try:
        with stdout_to_stderr():
            get_adapter(args.engine).version()  # its import banner before any output
            result = oblique.fit(args.engine, scenario, angles, speeds,
                                 timestep_s=args.timestep_s,
                                 weights=None if weights is None else list(weights.values()),
                                 max_evals=budget, seed=seed, progress=progress)
    except EngineUnavailable as exc:
        print(f"impactbench: error: {exc}")
        return 1
    if not args.json:
        print(file=sys.stderr)
    path = oblique.write(result, out_file)
    files = {"tuned": str(path)}
    if args.json:
        print_json(oblique.as_json(result, files))
        return 0
    _print_text(result, files, args.write_default)
    return 0


def _print_text(result, files: dict[str, str], packaged: bool) -> None:
    from impactbench.tuning import oblique

    s = result.scenario
    print(f"impactbench tune: {result.engine} {result.engine_version}, oblique friction knobs "
          f"fitted to the {s.tangential} reference at dt = {result.timestep_s:g} s: angles "
          f"{', '.join(f'{a:g}' for a in result.angles_deg)}°, V = "
          f"{', '.join(f'{v:g}' for v in result.velocities_m_s)} m/s, μ = {s.friction:g}")
    print(f"{result.evaluations} evaluations (budget {result.budget}, seed {result.seed}, "
          f"{result.stop}) × {len(result.points)} runs in {result.wall_s:.1f} s")
    for line in result.stages:
        print(f"  {line}")
    print(f"objective ({oblique.OBJECTIVE}): native {result.native.objective:.6g} -> tuned "
          f"{result.tuned.objective:.6g}")
    print()
    print_table(oblique.summary_rows(result), floatfmt=".4g")
    print("\nper angle and metric (relative errors against the reference):")
    print_table(oblique.residual_rows(result),
                ["angle_deg", "metric", "reference", "native", "native_rel_error", "tuned",
                 "tuned_rel_error"], floatfmt=".5g")
    print("\nparameters (the engine's own keys; native = the start):")
    print_table(oblique.parameter_rows(result))
    for line in oblique.notes(result):
        print(f"note: {line}")
    print(f"\nwrote {files['tuned']}  (run --scenario oblique --engine {result.engine} "
          f"--mode tuned" + ("" if packaged else f" --tuned {files['tuned']}")
          + f" --timestep {result.timestep_s:g})")
