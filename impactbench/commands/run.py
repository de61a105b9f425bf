"""``impactbench run``: one engine, one scenario, one mode, compared with the reference."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from impactbench import scenarios
from impactbench.cliutil import (
    check_cost,
    key_value,
    number,
    print_json,
    print_table,
    stdout_to_stderr,
    timeout_option,
)
from impactbench.engines.registry import MODES, engine_names
from impactbench.flags import add_axis_flags, add_parameter_flags, scenario_from_args

HELP = "run one scenario in one engine and compare it with the reference"


def register(top: argparse._SubParsersAction, groups: dict) -> None:
    p = top.add_parser("run", help=HELP, description=HELP + ". Parameter flags of every "
                       "scenario are accepted; those of the other scenarios are ignored.")
    p.add_argument("--engine", required=True, choices=engine_names(),
                   help="the engine to run")
    names = scenarios.names()
    p.add_argument("--scenario", required=True, choices=names,
                   help="; ".join(f"{n}: {scenarios.get(n).summary}" for n in names))
    p.add_argument("--mode", default=None, choices=MODES,
                   help="native: the engine's contact model with mapped parameters; "
                   "injected: the reference law driven through the engine; tuned: fitted "
                   "parameters; default: the engine's out-of-the-box contact; custom: "
                   "default plus your --param (or --param-set) settings (default native; "
                   "tuned with --tuned; a data-driven scenario: default)")
    p.add_argument("--param", type=key_value, action="append", default=[], dest="params",
                   metavar="KEY=VALUE",
                   help="custom mode: one engine parameter by the engine's own name "
                   "(repeatable), e.g. solref=0.02,1 or contactStiffness=1e5; a data-driven "
                   "scenario takes its replay's keys, e.g. board.contactStiffness=1e5")
    p.add_argument("--param-set", default=None, dest="param_set", metavar="NAME",
                   help="custom mode of a data-driven scenario: a parameter set published "
                   "with the data (e.g. dair2022: DAIR's fitted values), overlaid by --param")
    p.add_argument("--tuned", type=Path, default=None, dest="tuned_file", metavar="FILE",
                   help="tuned mode with this tuned file (written by `impactbench tune "
                   "--out`); it applies only to the scenario and timestep it was fitted for")
    with_v = ", ".join(n for n in names if "velocity_m_s" in scenarios.get(n).axis_names)
    p.add_argument("--velocity", type=number, default=None, dest="velocity_m_s",
                   metavar="V", help=f"impact velocity V0 or v1 (m/s); required by the "
                   f"scenarios with a velocity axis ({with_v})")
    p.add_argument("--timestep", type=number, default=None, dest="timestep_s", metavar="S",
                   help="integration step (s); default: in default mode the engine's own "
                   "default step (MuJoCo 2 ms, PyBullet 1/240 s, Drake 1 ms, pymunk 1/60 s), "
                   "otherwise the adapter's for the scenario; a data-driven scenario steps "
                   "at a whole fraction of its sample interval (cube tosses: 1/148 s / "
                   "round(1/148 s / S); default 1/1480 s, DAIR's)")
    axes: set[str] = set()
    flags: set[str] = set()
    for name in names:
        add_axis_flags(p, name, added=axes)
    for name in names:
        add_parameter_flags(p, name, added=flags)
    p.add_argument("--timeout", type=number, default=None, metavar="S", dest="timeout",
                   help="stop the run after S seconds: status timeout, exit 1 (default "
                   "max(60 s, 20 x the run's estimate); a run stuck inside an engine's C code "
                   "is ended as long again later (at least 5 s) with a dump of where it hung)")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.add_argument("--allow-status", default="", metavar="LIST",
                   help="comma list of non-ok statuses that still exit 0, e.g. "
                   "max_time,unsupported (default: any status but ok exits 1)")
    p.add_argument("--yes", action="store_true",
                   help="run even when the estimate exceeds 1e7 integration steps")
    p.add_argument("--max-penetration-ratio", type=number, default=None, metavar="R",
                   help="plausibility: the largest overlap over the body's size before a run "
                   "is implausible (default 0.1)")
    p.add_argument("--max-energy-ratio", type=number, default=None, metavar="E",
                   help="plausibility: the largest kinetic energy after over before "
                   "(default 1.01)")
    p.set_defaults(func=main)


def main(args: argparse.Namespace) -> int:
    from impactbench.engines.base import RunSettings
    from impactbench.evaluate import compare

    spec = scenarios.get(args.scenario)
    if "velocity_m_s" in spec.axis_names and args.velocity_m_s is None:
        raise ValueError(f"velocity: --velocity V (m/s) is required for {spec.name}")
    if "velocity_m_s" not in spec.axis_names and args.velocity_m_s is not None:
        raise ValueError(f"velocity = {args.velocity_m_s:g}: {spec.name} has no impact "
                         "velocity (drop --velocity)")
    scenario = scenario_from_args(args.scenario, args)
    mode = args.mode or ("tuned" if args.tuned_file else spec.default_mode)
    if args.params and mode != "custom":
        raise ValueError(f"param = {args.params[0][0]}: --param needs --mode custom "
                         f"(got {mode})")
    if args.tuned_file and mode != "tuned":
        raise ValueError(f"tuned = {str(args.tuned_file)!r}: --tuned needs --mode tuned "
                         f"(got {mode})")
    params = dict(args.params)
    if args.param_set is not None:
        if not spec.measured:
            raise ValueError(f"param-set = {args.param_set!r}: {spec.name} has no parameter "
                             "sets (they come with a data-driven scenario's measurements)")
        params["param_set"] = args.param_set  # the builder says which modes take it
    if spec.measured:
        for flag, value in (("max-penetration-ratio", args.max_penetration_ratio),
                            ("max-energy-ratio", args.max_energy_ratio)):
            if value is not None:
                raise ValueError(f"{flag} = {value:g}: {spec.name} is judged against its "
                                 "measurements, not by plausibility limits")
    own_step = spec.owns_timestep  # the scenario's fields carry the step (cube tosses)
    if own_step:
        timestep_s, timestep_source = args.timestep_s, ""
    else:
        _check_param_keys(args.engine, args.params)
        timestep_s, timestep_source = run_timestep(args.engine, mode, args.timestep_s)
    settings = RunSettings(timestep_s=timestep_s, params=params or None)
    if mode == "tuned":  # bound to the scenario at this step (a replay's substeps)
        from impactbench.tuned import tuned_settings

        tuned, provenance = tuned_settings(args.engine, spec.at_timestep(scenario, timestep_s)[0],
                                           timestep_s, args.tuned_file)
        settings = RunSettings(timestep_s=timestep_s, tuned=tuned, tuned_for=provenance,
                               params=params or None)
    allowed = _allowed_statuses(args.allow_status, ("timeout",))
    from impactbench import cluster
    from impactbench.evaluate import reference_metrics
    from impactbench.matrix import estimated_steps_of

    reference = reference_metrics(spec.at_timestep(scenario, timestep_s)[0])
    steps = estimated_steps_of(reference, timestep_s)
    check_cost(steps, f"timestep = {timestep_s!r}", args.yes, "integration steps")
    # a run without an estimate (a replay, whose length varies with its tosses) has no
    # default timeout
    limit = timeout_option(args) or (cluster.default_timeout(cluster.run_estimate_s(steps))
                                     if steps or not own_step else None)
    with stdout_to_stderr():
        out, _ = compare(args.engine, scenario, mode, settings, reference, timeout_s=limit,
                         backstop=True)
    limits = {k: v for k, v in (("max_penetration_ratio", args.max_penetration_ratio),
                                ("max_energy_ratio", args.max_energy_ratio)) if v is not None}
    if limits:
        from impactbench.plausibility import Limits, judge

        out = judge(out, Limits(**limits))
    timestep_source = out.pop("timestep_source", "") or timestep_source
    at = list(out).index("timestep_s") + 1  # beside the step it explains
    out = dict([*list(out.items())[:at], ("timestep_source", timestep_source),
                *list(out.items())[at:]])
    code = 0 if out["status"] == "ok" or out["status"] in allowed else 1
    if code:
        print(f"impactbench: run status {out['status']}"
              + (f" ({out['message']})" if out["message"] else "")
              + "; exit 1 (--allow-status to accept it)", file=sys.stderr)
    if args.json:
        print_json(out)
        return code
    print(f"{out['engine']} {out['engine_version']}  mode {out['mode']}  "
          f"timestep {out['timestep_s']} s ({timestep_source})  status {out['status']}"
          + (f" ({out['message']})" if out["message"] else "")
          + f"  wall {out['wall_s']:.3g} s")
    rows = [{"metric": k, "engine": out[k], "reference": out["reference"][k],
             "rel_error": out["rel_error"][k] if out["resolved"][k] else "not resolved"}
            for k in out["rel_error"]]
    print_table(rows)
    return code


ENGINE_DEFAULT, GIVEN, ADAPTER_DEFAULT = ("engine default", "given",
                                         "adapter default for the scenario")
"""The values of ``timestep_source`` in ``run``'s output."""


def run_timestep(engine: str, mode: str, timestep_s: float | None
                 ) -> tuple[float | None, str]:
    """(step, where it comes from): the given step; in ``default`` mode without one the
    engine's own default step (the first of its spec's ``customary_timesteps_s``: MuJoCo 2 ms,
    PyBullet 1/240 s, Drake 1 ms, pymunk 1/60 s), so "default" means the engine as it comes;
    otherwise None, the adapter's step for the scenario (engines without customary steps)."""
    if timestep_s is not None:
        return timestep_s, GIVEN
    if mode == "default":
        from impactbench.engines.registry import spec

        customary = spec(engine).customary_timesteps_s
        if customary:
            return float(customary[0]), ENGINE_DEFAULT
    return None, ADAPTER_DEFAULT


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


def _check_param_keys(engine: str, params: list[tuple[str, object]]) -> None:
    """An unknown --param key is a one-line error listing the engine's keys."""
    from impactbench.config import did_you_mean
    from impactbench.engines.base import parameter_keys

    valid = parameter_keys(engine)
    for key, _ in params:
        if key not in valid:
            raise ValueError(f"param = {key!r}: not a {engine} parameter; valid keys: "
                             f"{', '.join(valid) or '(none)'}{did_you_mean(key, valid)}")
