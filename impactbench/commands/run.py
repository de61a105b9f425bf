"""``impactbench run SCENARIO``: one engine, one scenario, one mode, compared with the reference.

A thin layer over :func:`impactbench.run`: each scenario is a subcommand with its own flags
(``impactbench run cube-toss --help`` lists the cube tosses' only), the flags become the
function's keywords, and the function holds every rule (default mode, mode checks, the step,
tuned files, cost, timeout, plausibility limits). What is left here is the presentation: the
JSON object or the text table, and the exit code (``--allow-status``).

``impactbench run --scenario NAME …``, the spelling before subcommands, still works for one
release (one line on stderr says so): :func:`scenario_first` rewrites it.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

from impactbench import scenarios
from impactbench.cliutil import (
    add_timeout_flag,
    add_yes_flag,
    flag_names,
    key_value,
    number,
    print_json,
    print_table,
)
from impactbench.engines.registry import MODES, engine_names
from impactbench.flags import add_axis_flags, add_parameter_flags

HELP = "run one scenario in one engine and compare it with the reference"
DEPRECATED = "impactbench: --scenario is deprecated; write `impactbench run NAME …`"
"""The note ``run --scenario NAME`` prints on stderr (the spelling goes in the next release)."""


def register(top: argparse._SubParsersAction, groups: dict) -> None:
    p = top.add_parser("run", help=HELP, description=HELP + ": `impactbench run SCENARIO "
                       "--engine E …`; `impactbench run SCENARIO --help` lists that "
                       "scenario's flags.")
    sub = p.add_subparsers(dest="scenario", required=True, metavar="SCENARIO",
                           parser_class=type(p))
    for spec in scenarios.specs():
        s = sub.add_parser(spec.name, help=spec.summary,
                           description=f"{spec.title}: {spec.summary}. {HELP[0].upper()}"
                           f"{HELP[1:]}.")
        add_run_flags(s, spec)


def add_run_flags(p: argparse.ArgumentParser, spec: scenarios.ScenarioSpec) -> None:
    """The flags of ``run NAME``: the engine settings, the scenario's axes, fields and
    further options, and the output. A run flag that does not apply to the scenario
    (``--velocity`` without a velocity axis, ``--param-set`` without published sets, the
    plausibility limits of measured data) is accepted but hidden, so the function's one-line
    error says why."""
    hidden = argparse.SUPPRESS

    def shown(applies: bool, text: str) -> str:
        return text if applies else hidden

    p.add_argument("--engine", required=True, choices=engine_names(), help="the engine to run")
    p.add_argument("--mode", default=None, choices=MODES,
                   help="native: the engine's contact model with mapped parameters; "
                   "injected: the reference law driven through the engine; tuned: fitted "
                   "parameters; default: the engine's out-of-the-box contact; custom: "
                   "default plus your --param" + (" or --param-set" if spec.measured else "")
                   + f" settings (without --mode: {spec.default_mode}; custom with --param"
                   + (" or --param-set" if spec.measured else "") + ", tuned with --tuned)")
    p.add_argument("--param", type=key_value, action="append", default=[], dest="params",
                   metavar="KEY=VALUE",
                   help="custom mode: one engine parameter by the engine's own name "
                   "(repeatable), e.g. " + ("board.contactStiffness=1e5 (the replay's keys)"
                                            if spec.measured
                                            else "solref=0.02,1 or contactStiffness=1e5"))
    p.add_argument("--param-set", default=None, dest="param_set", metavar="NAME",
                   help=shown(spec.measured, "custom mode: a parameter set published with the "
                              "data (e.g. dair2022: DAIR's fitted values), overlaid by --param"))
    p.add_argument("--tuned", default=None, dest="tuned_file", metavar="FILE",
                   help="tuned mode with this tuned file (written by `impactbench tune "
                   "--out`); it applies only to the scenario and timestep it was fitted for")
    velocity = "velocity_m_s" in spec.axis_names
    p.add_argument("--velocity", type=number, default=None, dest="velocity_m_s",
                   metavar="V", required=velocity,
                   help=shown(velocity, f"impact velocity {spec.velocity_symbol} (m/s)"))
    p.add_argument("--timestep", type=number, default=None, dest="timestep_s", metavar="S",
                   help="integration step (s); default: " + (
                       "the scenario steps at a whole fraction of its sample interval "
                       "(cube tosses: 1/148 s / round(1/148 s / S); default 1/1480 s, DAIR's)"
                       if spec.owns_timestep else
                       "in default mode the engine's own default step (MuJoCo 2 ms, PyBullet "
                       "1/240 s, Drake 1 ms, pymunk 1/60 s), otherwise the adapter's for the "
                       "scenario"))
    before = {a.dest for a in p._actions}
    add_axis_flags(p, spec.name)
    add_parameter_flags(p, spec.name)
    fields = tuple(a.dest for a in p._actions if a.dest not in before)
    g = p.add_argument_group("the run")
    add_timeout_flag(g, config=False, help="stop the run after S seconds: status timeout, "
                     "exit 1 (default max(60 s, 20 x the run's estimate); a run stuck inside "
                     "an engine's C code is ended as long again later (at least 5 s) with a "
                     "dump of where it hung)")
    add_yes_flag(g, "the estimate exceeds 1e7 integration steps")
    g.add_argument("--max-penetration-ratio", type=number, default=None, metavar="R",
                   help=shown(not spec.measured, "plausibility: the largest overlap over the "
                              "ball's radius before a run is implausible (default 0.1)"))
    g.add_argument("--max-energy-ratio", type=number, default=None, metavar="E",
                   help=shown(not spec.measured, "plausibility: the largest kinetic energy "
                              "after over before (default 1.01)"))
    g.add_argument("--json", action="store_true", help="print one JSON object")
    g.add_argument("--allow-status", default="", metavar="LIST",
                   help="comma list of non-ok statuses that still exit 0, e.g. "
                   "max_time,unsupported (default: any status but ok exits 1)")
    p.set_defaults(func=main, fields=("velocity_m_s", *fields), flags=flag_names(p))


def main(args: argparse.Namespace) -> int:
    """:func:`impactbench.run` with the flags; the JSON object or a table, exit 0 for ``ok``
    (or an allowed status), else 1."""
    from impactbench import api

    allowed = _allowed_statuses(args.allow_status, ("timeout",))
    fields = {k: getattr(args, k) for k in args.fields if getattr(args, k) is not None}
    with api.command_line(args.flags):
        result = api.run(args.engine, args.scenario, args.mode, params=dict(args.params),
                         param_set=args.param_set, tuned_file=args.tuned_file,
                         timestep_s=args.timestep_s, yes=args.yes, timeout_s=args.timeout_s,
                         max_penetration_ratio=args.max_penetration_ratio,
                         max_energy_ratio=args.max_energy_ratio, **fields)
    said = f" ({result.message})" if result.message else ""
    code = 0 if result.ok or result.status in allowed else 1
    if code:
        print(f"impactbench: run status {result.status}{said}; exit 1 (--allow-status to "
              "accept it)", file=sys.stderr)
    if args.json:
        print_json(result.to_dict())
        return code
    print(f"{result.engine} {result.engine_version}  mode {result.mode}  timestep "
          f"{result.timestep_s} s ({result.timestep_source})  status {result.status}{said}"
          f"  wall {result.wall_s:.3g} s")
    from impactbench.report_render import format_error

    # the errors as the report and the tuner print them (percent); --json keeps fractions
    from impactbench.scenarios import spec_of

    error = "error (absolute)" if spec_of(result.scenario).measured else "error"
    print_table([{"metric": k, "engine": result.metrics.get(k),
                  "reference": result.reference.get(k),
                  error: (format_error(v) if error == "error" else v)
                  if result.resolved.get(k, True) else "not resolved"}
                 for k, v in result.rel_error.items()])
    return code


def scenario_first(argv: Sequence[str]) -> list[str]:
    """``run`` arguments with the scenario first, as the subcommands take it.

    ``run --scenario NAME …`` (the spelling before ``run NAME``, kept for one release)
    becomes ``run NAME …`` with :data:`DEPRECATED` on stderr; ``run --engine E NAME …`` becomes
    ``run NAME --engine E …``; ``run`` with flags and no scenario runs the first registered
    one (the ball, as before), with a note too. Anything else is left as it is."""
    argv = list(argv)
    if argv[:1] != ["run"]:
        return argv
    rest = argv[1:]
    names = scenarios.names()
    for i, word in enumerate(rest):
        if word == "--":
            break
        if word == "--scenario" or word.startswith("--scenario="):
            name = word.partition("=")[2] if "=" in word else (
                rest[i + 1] if i + 1 < len(rest) else None)
            if not name:
                raise ValueError("scenario: --scenario needs a NAME (deprecated: write "
                                 "`impactbench run NAME …`)")
            if rest[:1] and rest[0] in names:
                raise ValueError(f"scenario = {name!r}: given twice (`run {rest[0]}` and "
                                 "--scenario); write `impactbench run NAME …`")
            del rest[i:i + (1 if "=" in word else 2)]
            print(DEPRECATED, file=sys.stderr)
            return ["run", name, *rest]
    if not rest or not rest[0].startswith("-"):
        return argv  # the new spelling (or a bad name, argparse's to refuse)
    named = next((i for i, word in enumerate(rest) if word in names), None)
    if named is not None:
        return ["run", rest[named], *rest[:named], *rest[named + 1:]]
    if {"-h", "--help"} & set(rest):
        return argv
    default = names[0]
    print(f"impactbench: `run` without a scenario is deprecated (it runs {default}); write "
          f"`impactbench run {default} …`", file=sys.stderr)
    return ["run", default, *rest]


def _allowed_statuses(text: str, extra: tuple[str, ...] = ()) -> set[str]:
    """--allow-status: a comma list of Status names (and ``extra`` ones; one-line error for an
    unknown one)."""
    from impactbench.reference.record import Status

    names = {s.strip() for s in text.split(",") if s.strip()}
    valid = [str(s) for s in Status] + list(extra)
    for name in sorted(names):
        if name not in valid:
            raise ValueError(f"allow-status = {name!r}: must be one of {', '.join(valid)}")
    return names
