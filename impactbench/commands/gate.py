"""``impactbench gate``: run the accuracy gates of a gate file (see :mod:`impactbench.gates`).

Exit codes: 0 all checks pass, 1 any check fails (``--strict``: or is not comparable),
2 a bad gate or baseline file. Writes JUnit XML with ``--junit`` and appends a Markdown summary
to ``$GITHUB_STEP_SUMMARY`` when that variable is set.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

from impactbench.cliutil import add_execution_flags

HELP = "check engines against the reference with the tolerances of a gate file (CI)"


def register(top: argparse._SubParsersAction, groups: dict) -> None:
    p = top.add_parser("gate", help=HELP, description=HELP + ". Marks: pass, better, worse "
                       "(the signed error left the baseline's relative band: fails), fail, "
                       "new-failure (fails now, passed in the baseline), not-comparable (engine "
                       "or mode "
                       "unavailable: passes unless --strict).")
    p.add_argument("--config", type=Path, default=Path("gates.toml"), metavar="FILE",
                   help="gate file (TOML); default gates.toml")
    p.add_argument("--baseline", type=Path, default=None, metavar="FILE",
                   help="baseline of measured values (JSON); default <config>_baseline.json "
                   "beside the gate file, when it exists")
    p.add_argument("--update-baseline", action="store_true",
                   help="rewrite the baseline with this run's measured values")
    p.add_argument("--junit", type=Path, default=None, metavar="FILE",
                   help="write JUnit XML (one testcase per check)")
    p.add_argument("--strict", action="store_true",
                   help="not-comparable checks (missing engine, unsupported mode) fail too")
    p.add_argument("--select", action="append", default=[], metavar="TEXT",
                   help="only checks whose id contains TEXT (repeatable)")
    add_execution_flags(p, in_process=True, timeout=True, config=False,
                        workers_aliases=("--jobs",))
    p.set_defaults(func=main)


def _where(args: argparse.Namespace) -> str:
    from impactbench.cluster import Runner

    return Runner(args.workers, args.scheduler).describe()


def _check_cost(runs: list, yes: bool) -> dict:
    """Refuse (one line, before anything runs) runs estimated above ``COST_LIMIT``
    integration steps in all unless ``--yes``; the reference metrics computed for the
    estimate (the runs use them)."""
    from impactbench.cliutil import check_cost
    from impactbench.evaluate import reference_metrics
    from impactbench.matrix import estimated_steps_of

    references: dict = {}
    steps = 0.0
    for run in runs:
        if run.reference_key not in references:
            references[run.reference_key] = reference_metrics(run.build_scenario())
        steps += estimated_steps_of(references[run.reference_key], run.timestep_s)
    check_cost(steps, f"{len(runs)} runs", yes, "integration steps")
    return references


def _write_junit(path: Path, text: str) -> None:
    from impactbench.publish import atomic_write

    atomic_write(path, text, "junit")


def default_baseline(config: Path) -> Path:
    """``gates.toml`` → ``gates_baseline.json`` in the same folder."""
    return config.with_name(f"{config.stem}_baseline.json")


def main(args: argparse.Namespace) -> int:
    from impactbench import gates  # here: `gate --help` stays light
    from impactbench.cliutil import check_workers, timeout_option
    from impactbench.publish import check_file_target
    from impactbench.store import Store, default_path

    args.workers = check_workers(args.workers, args.scheduler)
    timeout_s = timeout_option(args.timeout_s)
    if args.baseline is not None and not args.baseline.is_file() and not args.update_baseline:
        raise ValueError(f"baseline = '{args.baseline}': no such file (omit --baseline for "
                         "the default, or add --update-baseline to create it)")
    if args.junit is not None:
        check_file_target(args.junit, "junit")
    if args.update_baseline and args.baseline is not None:
        check_file_target(args.baseline, "baseline")
    gate_file = gates.load_gates(args.config)
    checks = [c for c in gate_file.checks
              if not args.select or any(s in c.id for s in args.select)]
    if not checks:
        raise ValueError(f"--select = {args.select}: matches no check of {args.config}")
    baseline_path = args.baseline or default_baseline(args.config)
    baseline = gates.load_baseline(baseline_path)
    runs = gates.plan(checks)
    references = _check_cost(runs, args.yes)
    print(f"impactbench gate: {len(checks)} checks need {len(runs)} engine runs "
          f"({_where(args)})", file=sys.stderr)

    from impactbench.cliutil import progress_bar

    update, close = progress_bar(len(runs), unit="gate run")
    try:
        outcomes = gates.evaluate(checks, baseline, jobs=args.workers, progress=update,
                                  store=Store(args.store or default_path()), fresh=args.fresh,
                                  scheduler=args.scheduler, yes=args.yes, timeout_s=timeout_s,
                                  references=references)
    finally:
        close()
    if args.update_baseline:
        baseline = gates.updated_baseline(outcomes, baseline)
        gates.save_baseline(baseline_path, baseline)
        outcomes = gates.rejudge(outcomes, baseline)
        print(f"impactbench gate: baseline written to {baseline_path}", file=sys.stderr)
    print(gates.format_table(outcomes))
    print(gates.summary_line(outcomes, args.strict))
    if args.junit:
        _write_junit(args.junit, gates.junit_xml(outcomes, args.strict))
    summary = os.environ.get("GITHUB_STEP_SUMMARY")
    if summary:
        try:
            with open(summary, "a", encoding="utf-8") as fh:
                fh.write(gates.markdown_summary(outcomes, args.strict) + "\n")
        except OSError as exc:
            raise ValueError(f"GITHUB_STEP_SUMMARY = '{summary}': cannot append "
                             f"({exc.strerror or exc})") from None
    return gates.exit_code(outcomes, args.strict)

