"""``impactbench tune --scenario cube-toss``: fit an engine's contact parameters to the
measured tosses (training split only; :mod:`impactbench.cube_tosses.tune`).

Output: the start's and the fit's errors on the training tosses (what the optimiser saw), then
on the held-out test tosses beside the engine out of the box and its published parameter sets
(``dair2022``, …), the fitted parameters in the engine's own keys, and the file written
(``--out FILE``, else ``tuned_<engine>_cube_toss.toml``; ``--write-default`` the packaged
``impactbench/data/tuned/cube_toss/<engine>.toml`` that ``run --mode tuned`` and the report
read). Every evaluation is a stored run in the results store (``--store``, default
``$IMPACTBENCH_STORE``), so a rerun, or a longer ``--budget``, evaluates only what it has not
seen; ``--workers N`` runs each generation's candidates on N Dask workers.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import Any

from impactbench.cliutil import print_json, print_table, stdout_to_stderr

DEFAULT_BUDGET = 160
"""Evaluations (the start included) of the packaged fits: CMA-ES on 5–8 knobs settles within
~100–150 evaluations on the tosses (the packaged files' histories)."""


def _out_path(args: argparse.Namespace) -> Path:
    from impactbench.cube_tosses.tune import tuned_path

    if args.write_default:
        return tuned_path(args.engine)
    return args.out or Path(f"tuned_{args.engine}_cube_toss.toml")


def _reference_sets(engine: str, protocol: Any, store: Any, workers: int | None,
                    scheduler: str | None) -> dict[str, dict[str, Any]]:
    """The engine out of the box and its published parameter sets, scored on the held-out
    test tosses (what the fit is compared with; stored runs, as the fit's evaluations are)."""
    import impactbench.engines.cube_toss as engines_mod
    from impactbench.cube_tosses.tune import score_params

    return {name: score_params(engine, params, None, "test", protocol, store,
                               workers=workers, scheduler=scheduler)
            for name, params in {"default": {},
                                 **engines_mod.PARAM_SETS.get(engine, {})}.items()}


def _row(name: str, summary: dict[str, Any] | None) -> dict[str, Any]:
    s = summary or {}
    return {"parameters": name, "tosses": s.get("tosses", 0),
            "position error median": s.get("position_error_median", math.nan),
            "position error mean": s.get("position_error_mean", math.nan),
            "rotation error median (°)": s.get("rotation_error_deg_median", math.nan),
            "failed": len(s.get("failed") or [])}


def main(args: argparse.Namespace) -> int:
    """The cube-toss branch of ``impactbench tune`` (called by :mod:`.tune`)."""
    from impactbench.cliutil import check_workers
    from impactbench.cube_tosses import tune as tune_mod
    from impactbench.cube_tosses.scenario import protocol_of
    from impactbench.flags import scenario_from_args
    from impactbench.publish import check_file_target
    from impactbench.reference import validation as check
    from impactbench.store import Store, default_path

    check.one_of("engine", args.engine, tuple(tune_mod.SPACES))
    budget = args.max_evals if args.max_evals is not None else DEFAULT_BUDGET
    if isinstance(budget, bool) or not isinstance(budget, int) or budget < 2:
        raise ValueError(f"budget = {budget!r}: must be an integer >= 2 (evaluations, the "
                         "start included)")
    scenario = scenario_from_args("cube-toss", args)
    if scenario.data:
        raise ValueError(f"data = {scenario.data!r}: tuning fits the packaged tosses' "
                         "training split; score a tuned file on your tosses with run --mode "
                         "tuned --data FILE")
    given = getattr(args, "tosses", None)
    tosses = "train" if given is None else scenario.selection
    if tosses in ("test", "all"):
        raise ValueError(f"tosses = {given!r}: tuning sees training tosses only (train, or "
                         "training-toss ids)")
    out_file = _out_path(args)
    check_file_target(out_file, "out")  # before minutes of fitting, not after
    check_workers(args.workers)
    protocol = protocol_of(scenario)
    store = Store(args.store or default_path())

    def progress(done: int, total: int, objective: float, best: float) -> None:
        if not args.json:
            print(f"\r  evaluation {done}/{total}: objective {objective:.4f}, best "
                  f"{best:.4f}", end="", file=sys.stderr, flush=True)

    with stdout_to_stderr():
        fit = tune_mod.tune(args.engine, budget, seed=args.seed, protocol=protocol,
                            tosses=tosses, optimizer=args.optimizer, store=store,
                            fresh=args.fresh, workers=args.workers, scheduler=args.scheduler,
                            progress=progress)
        refs = _reference_sets(args.engine, protocol, store, args.workers, args.scheduler)
    if not args.json:
        print(file=sys.stderr)
    path = tune_mod.write_tuned(fit, out_file, {k: {"test": v} for k, v in refs.items()})
    result = {"engine": fit.engine, "engine_version": fit.engine_version,
              "scenario": "cube-toss", "optimizer": fit.optimizer, "budget": fit.budget,
              "evaluations": fit.evaluations, "cache_hits": fit.cache_hits, "seed": fit.seed,
              "objective_start": fit.objective_start, "objective_tuned": fit.objective,
              "parameters": fit.params, "knobs": fit.knobs,
              "train": tune_mod._short(fit.train), "test": tune_mod._short(fit.test),
              "references_test": {k: tune_mod._short(v) for k, v in refs.items()},
              "wall_time_s": fit.wall_time_s, "files": {"tuned": str(path)}}
    if args.json:
        print_json(result)
        return 0
    print(f"impactbench tune: {fit.engine} {fit.engine_version} fitted to the cube tosses "
          f"(training split, {len(fit.train_ids)} tosses; {fit.optimizer}, {fit.evaluations} "
          f"evaluations, {fit.cache_hits} from the store, seed {fit.seed}, "
          f"{fit.wall_time_s:.0f} s)")
    print(f"objective (mean position error / width, training tosses): "
          f"start {fit.objective_start:.4f} -> tuned {fit.objective:.4f}")
    print("\nheld-out test tosses:")
    print_table([_row("tuned", fit.test),
                 *(_row(name, r) for name, r in refs.items())])
    print("\nparameters (the engine's own keys, as run --mode custom --param takes them):")
    print_table([{"key": k, "value": v} for k, v in fit.params.items()])
    print(f"\nwrote {path}  (run --scenario cube-toss --engine {fit.engine} --mode tuned"
          + ("" if args.write_default else f" --tuned {path}") + ")")
    return 0
