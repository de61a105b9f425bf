"""The Python API: the ``run``, ``reference``, ``tune`` and ``report`` commands as functions.

Each function is exported from the package (``impactbench.run``, ``impactbench.reference``,
``impactbench.tune``, ``impactbench.report``), loaded on first use so that ``import
impactbench`` stays light. They call the machinery the commands call
(:func:`impactbench.evaluate.compare`, :func:`impactbench.tuning.optimize.tune`,
:func:`impactbench.report.build`), so a function and its command give the same numbers.

Keyword arguments, the same for every function:

- *scenario fields* by their dataclass names (``mass_kg``, ``radius_m``, ``damping_s_per_m``,
  ``model``, ``nominal_restitution``, ``gravity_m_s2`` …; SI, as in
  ``impactbench.reference.scenarios``) and the scenario's *point* axes (``velocity_m_s``, and
  ``local`` and ``structure`` for ``rigid-flexible``). Unset ones keep the papers' values;
- the scenario's further options, as its command-line flags have them (the ball's
  ``material``, ``plate_material``, ``youngs_modulus_pa``, ``poisson``, ``scenario_file``);
- *engine settings*: ``params`` (``custom`` mode: a dict by the engine's own names, as
  ``run --param``), ``param_set`` (``custom`` mode of a measured scenario: a parameter set
  published with its data), ``tuned_file`` (``tuned`` mode) and ``timestep_s`` (default: in
  ``default`` mode the engine's own step, else the adapter's for the scenario; a measured
  scenario's own step).

The commands are a thin layer over these functions: ``impactbench run`` translates its flags
into :func:`run`'s keywords and calls it inside :func:`command_line`, under which errors name
the flags (``timestep = …``, ``--mode custom``) instead of the keywords; every rule (default
mode, mode checks, the step, tuned files, cost, timeout, plausibility limits) lives here once.

An unknown keyword is a one-line ``ValueError`` that names it, suggests the nearest valid one
and lists them all, as are bad values (the scenario's own validation):

>>> import impactbench
>>> impactbench.run(engine="pymunk", scenario="ball-on-plate", velocity=2.0)
Traceback (most recent call last):
...
ValueError: impactbench.run(scenario='ball-on-plate'): unknown keyword 'velocity' (did you
mean 'velocity_m_s'?); valid: engine, scenario, mode, ...
>>> impactbench.reference_solution(scenario="ball-on-plate", velocity_m_s=-1.0)
Traceback (most recent call last):
...
ValueError: velocity_m_s = -1.0: must be > 0...

A run in one line, compared with the reference:

>>> r = impactbench.run(engine="mujoco", scenario="ball-on-plate", mode="default",
...                     velocity_m_s=2.0, timestep_s=2e-3)
>>> r.engine, r.mode, r.timestep_s, r.timestep_source
('mujoco', 'default', 0.002, 'given')
>>> round(r.metrics["restitution"], 2), round(r.reference["restitution"], 2)
(0.13, 0.88)
>>> round(r.rel_error["restitution"], 2)
-0.86
>>> r.params, r.engine_defaults["solref"]
({}, [0.02, 1.0])
"""

from __future__ import annotations

import contextlib
import difflib
from collections.abc import Iterable, Iterator, Mapping, Sequence
from contextvars import ContextVar
from dataclasses import dataclass, field
from pathlib import Path
from types import SimpleNamespace
from typing import Any

from impactbench import scenarios

__all__ = ["RunResult", "TuneFit", "build_report", "command_line", "reference_solution",
           "run", "run_timestep", "tune"]

RUN_KEYWORDS = ("engine", "scenario", "mode", "params", "param_set", "tuned_file",
                "timestep_s", "yes", "timeout_s", "max_penetration_ratio", "max_energy_ratio")
"""The keywords of :func:`run` besides the scenario's fields and options."""
TUNE_KEYWORDS = ("engine", "scenario", "velocities_m_s", "targets", "weights", "parameters",
                 "solref_form", "timestep_s", "budget_s", "max_evals", "params", "out", "plot",
                 "store", "fresh", "workers", "scheduler", "yes", "phases")
"""The keywords of :func:`tune` besides the scenario's fields and options."""
TUNE_DISPATCH_MIN_S = 0.5
"""A tuning batch of runs estimated (from the runs so far) below this runs in this process: on
two cores a cluster start costs ~1 s and a round trip ~10–30 ms (``python -m benchmarks
tune``)."""


# ------------------------------------------------------------------------------ results


_RUN_HEAD = ("status", "message", "engine", "engine_version", "mode", "timestep_s", "wall_s")
_RUN_TAIL = ("not_comparable", "resolved", "params", "engine_defaults", "reference",
             "rel_error")


@dataclass(frozen=True)
class RunResult:
    """One engine run compared with the reference (what :func:`run` returns).

    Attributes:
        status: ``ok``, or why the run failed or is not to be trusted (``no_contact``,
            ``tunneled``, ``diverged``, ``max_time``, ``implausible``, ``unsupported``,
            ``unavailable``, ``crashed``, …; the values ``impactbench run`` prints).
        message: what went wrong ("" when nothing did).
        engine, engine_version, mode: what ran.
        timestep_s: the integration step used (s).
        timestep_source: where the step came from: ``given``, ``engine default`` (``default``
            mode without a step: the engine's own, MuJoCo 2 ms, pymunk 1/60 s, …) or
            ``adapter default for the scenario``.
        wall_s: the engine's wall time (s).
        metrics: the engine's metrics, by the scenario's metric names (NaN where not
            measured).
        reference: the reference's metrics of the same scenario.
        rel_error: signed relative error per metric (NaN where a metric is not resolved or
            the run failed).
        resolved: per metric, whether the step resolves it in time (a step about as long as
            the contact leaves duration and peak force unresolved: no error is given).
        params: the engine parameters the run used (``custom`` and ``tuned`` modes).
        not_comparable: metric → why the engine's value says nothing about the physics.
        engine_defaults: the engine's own defaults in force (``default`` mode).
        extra: any further keys of the ``run --json`` object (e.g. ``plausibility``).
        scenario: the scenario object that ran (its dataclass).
        record: the engine's :class:`~impactbench.reference.record.ImpactRecord` (time
            histories: ``t_s``, forces, positions).
        data: the whole ``run --json`` object, in its key order (:meth:`to_dict`).
    """

    status: str
    message: str
    engine: str
    engine_version: str
    mode: str
    timestep_s: float | None
    wall_s: float
    metrics: dict[str, Any]
    reference: dict[str, Any]
    rel_error: dict[str, float]
    resolved: dict[str, bool] = field(default_factory=dict)
    params: dict[str, Any] = field(default_factory=dict)
    not_comparable: dict[str, str] = field(default_factory=dict)
    engine_defaults: dict[str, Any] = field(default_factory=dict)
    extra: dict[str, Any] = field(default_factory=dict)
    timestep_source: str = ""
    scenario: Any = field(default=None, repr=False, compare=False)
    record: Any = field(default=None, repr=False, compare=False)
    data: dict[str, Any] = field(default_factory=dict, repr=False, compare=False)

    @property
    def ok(self) -> bool:
        """True when the status is ``ok``."""
        return self.status == "ok"

    @classmethod
    def from_compare(cls, out: Mapping[str, Any], metric_names: Iterable[str],
                     scenario: Any = None, record: Any = None,
                     timestep_source: str = "") -> RunResult:
        """From the object :func:`impactbench.evaluate.compare` returns (``run --json``'s);
        ``timestep_source`` (where it is not in ``out`` already) goes beside the step."""
        out = dict(out)
        source = str(out.pop("timestep_source", "") or timestep_source)
        at = list(out).index("timestep_s") + 1 if "timestep_s" in out else len(out)
        out = dict([*list(out.items())[:at], ("timestep_source", source),
                    *list(out.items())[at:]])
        names = [k for k in metric_names if k in out]
        known = {*_RUN_HEAD, *_RUN_TAIL, *names, "timestep_source"}
        return cls(**{k: out.get(k) for k in _RUN_HEAD},
                   metrics={k: out[k] for k in names},
                   **{k: dict(out.get(k) or {}) for k in _RUN_TAIL},
                   extra={k: v for k, v in out.items() if k not in known},
                   timestep_source=source, scenario=scenario, record=record, data=out)

    def to_dict(self) -> dict[str, Any]:
        """The object ``impactbench run --json`` prints: JSON-ready (NaN and inf are None,
        numpy scalars plain numbers), the metrics at the top level.

        >>> import json
        >>> r = run(engine="pymunk", scenario="ball-on-plate", velocity_m_s=1.0,
        ...         timestep_s=1e-3)
        >>> d = r.to_dict()
        >>> d["engine"], d["mode"], d["restitution"] == r.metrics["restitution"]
        ('pymunk', 'native', True)
        >>> json.loads(json.dumps(d)) == d
        True
        """
        from impactbench.cliutil import _jsonable

        if self.data:  # the comparison's own key order (details before rel_error)
            return _jsonable(self.data)
        head = {k: getattr(self, k) for k in _RUN_HEAD}
        at = list(head).index("timestep_s") + 1  # beside the step it explains
        head = dict([*list(head.items())[:at], ("timestep_source", self.timestep_source),
                     *list(head.items())[at:]])
        obj = {**head, **self.metrics, **{k: getattr(self, k) for k in _RUN_TAIL},
               **self.extra}
        return _jsonable(obj)


@dataclass(frozen=True)
class TuneFit:
    """A tuning run's outcome (what :func:`tune` returns).

    Attributes:
        engine, engine_version: what was tuned.
        parameter_set: the engine's parameter set fitted (``elasticity``, ``solref``, …).
        parameters: the fitted parameters by the adapter's tuned keys (a tuned file's
            ``[parameters]``, what ``run(mode="tuned")`` reads).
        snippet: the same parameters in the engine's own form (MJCF, ``changeDynamics``,
            pymunk shape settings, Drake ``AddContactMaterial``).
        start_parameters: the closed-form start (the native conversion).
        objective_start, objective_tuned: the weighted sum of squared relative errors.
        residuals: per velocity and metric: reference, start and tuned values and errors.
        summary: per metric: start and tuned largest |relative error| and the linear floor.
        honesty: what the engine cannot express, excluded targets, bounds hit, early stops.
        stop: why the search ended (``converged`` or the budget that ran out).
        timestep_s: the step fitted at (s).
        files: what was written (``tuned``, ``plot``) → its path.
        result: the :class:`impactbench.tuning.optimize.TuneResult` itself.
    """

    engine: str
    engine_version: str
    parameter_set: str
    parameters: dict[str, Any]
    snippet: str
    start_parameters: dict[str, Any]
    objective_start: float
    objective_tuned: float
    residuals: list[dict[str, Any]]
    summary: list[dict[str, Any]]
    honesty: list[str]
    stop: str
    timestep_s: float
    files: dict[str, str]
    result: Any = field(default=None, repr=False, compare=False)
    data: dict[str, Any] = field(default_factory=dict, repr=False, compare=False)
    ran_on: str = field(default="", compare=False)
    """Where the engine runs went (:meth:`impactbench.cluster.Runner.describe`)."""
    """The whole ``tune --json`` object (:func:`impactbench.tuning.output.as_json`)."""

    def to_dict(self) -> dict[str, Any]:
        """The object ``impactbench tune --json`` prints (JSON-ready)."""
        from impactbench.cliutil import _jsonable

        return _jsonable(self.data)


# ------------------------------------------------------------------------------ spelling


@dataclass(frozen=True)
class _Caller:
    """Who calls: Python (errors name the keywords, ``timestep_s = 0.0``, ``mode='custom'``)
    or the command line (:func:`command_line`: errors name its flags, ``timestep = 0.0``,
    ``--mode custom``, and a lone run stuck in an engine's C code ends the process)."""

    flags: Mapping[str, str] = field(default_factory=dict)
    """keyword → its flag (``timestep_s`` → ``--timestep``); empty: Python's keywords."""

    @property
    def command(self) -> bool:
        return bool(self.flags)

    def name(self, keyword: str) -> str:
        """What a value is called in ``NAME = value: rule`` (``timestep`` / ``timestep_s``)."""
        return self.flags[keyword].lstrip("-") if keyword in self.flags else keyword

    def option(self, keyword: str) -> str:
        """How the caller gives it (``--param`` / ``params``)."""
        return self.flags.get(keyword, keyword)

    def setting(self, keyword: str, value: Any) -> str:
        """How the caller sets it to ``value`` (``--mode custom`` / ``mode='custom'``;
        ``True``: ``--yes`` / ``yes=True``)."""
        if keyword not in self.flags:
            return f"{keyword}={value!r}"
        return self.flags[keyword] if value is True else f"{self.flags[keyword]} {value}"

    def value(self, value: Any) -> str:
        """A value as the caller writes it (``native`` / ``'native'``)."""
        return str(value) if self.command else repr(value)


_PYTHON = _Caller()
_CALLER: ContextVar[_Caller | None] = ContextVar("impactbench_api_caller", default=None)


def _say() -> _Caller:
    """The caller of the function running now (:func:`command_line`, else Python)."""
    return _CALLER.get() or _PYTHON


@contextlib.contextmanager
def command_line(flags: Mapping[str, str]) -> Iterator[None]:
    """Within the block the functions serve the command line: an error names the flag a
    value came from (``flags``: keyword → flag, e.g. ``{"timestep_s": "--timestep"}``) and a
    lone run stuck in an engine's C code past its timeout ends the process
    (:func:`impactbench.cluster.deadline`). The commands call the API inside it."""
    token = _CALLER.set(_Caller(dict(flags)))
    try:
        yield
    finally:
        _CALLER.reset(token)


def _g(value: Any) -> str:
    """A number as ``%g`` (anything else as its repr), for error messages."""
    return f"{value:g}" if isinstance(value, int | float) else repr(value)


# ------------------------------------------------------------------------------ keywords


def _hint(name: str, valid: Iterable[str]) -> str:
    close = difflib.get_close_matches(name, list(valid), n=1)
    return f" (did you mean {close[0]!r}?)" if close else ""


def _one_of(what: str, value: Any, allowed: Sequence[str]) -> None:
    """One-line ValueError unless ``value`` is in ``allowed`` (with a "did you mean")."""
    if value not in allowed:
        hint = _hint(value, allowed) if isinstance(value, str) else ""
        raise ValueError(f"{_say().name(what)} = {value!r}: must be one of "
                         f"{', '.join(allowed)}{hint}")


def _scenario_name(scenario: str | None, study: str = "") -> str:
    """The registered scenario ``scenario`` (default: the first, or the first serving
    ``study``); a ValueError with a "did you mean" otherwise."""
    if scenario is None:
        return scenarios.for_study(study).name if study else scenarios.names()[0]
    if not isinstance(scenario, str):
        raise ValueError(f"scenario = {scenario!r}: must be a scenario name, one of "
                         f"{', '.join(scenarios.names())}")
    return scenarios.get(scenario).name


def scenario_keywords(name: str, *, point: bool = True) -> tuple[str, ...]:
    """The scenario keywords of scenario ``name``: its fields (axes first; ``point = False``
    leaves the axes out) and its further options (:func:`impactbench.flags.option_names`)."""
    from impactbench.flags import option_names

    spec = scenarios.get(name)
    axes = spec.axis_names if point else ()
    fields = [f for f in spec.cls.field_names() if f not in spec.axis_names]
    return tuple(dict.fromkeys([*axes, *fields, *option_names(name)]))


def _check_keywords(where: str, given: Mapping[str, Any], valid: Sequence[str]) -> None:
    for key in given:
        if key not in valid:
            raise ValueError(f"{where}: unknown keyword {key!r}{_hint(key, valid)}; valid: "
                             f"{', '.join(valid)}")


def _build(name: str, values: Mapping[str, Any]) -> Any:
    """The scenario ``name`` with ``values`` (fields, axes, further options; None: unset)
    over its defaults, validated as the commands build it
    (:func:`impactbench.flags.scenario_from_args`: a material gives mass and stiffness; the
    spec reads its options from a plain namespace). Bad values are a one-line ValueError."""
    from impactbench.flags import scenario_from_args

    try:
        return scenario_from_args(name, SimpleNamespace(**values))
    except ValueError as exc:  # (validation's own subclasses: the plain type, one line)
        raise ValueError(str(exc)) from None


ENGINE_DEFAULT, GIVEN, ADAPTER_DEFAULT = ("engine default", "given",
                                         "adapter default for the scenario")
"""The values of ``timestep_source`` (``run --json``) the step rule gives."""


def run_timestep(engine: str, mode: str, timestep_s: float | None
                 ) -> tuple[float | None, str]:
    """(step, where it comes from): the given step; in ``default`` mode without one the
    engine's own default step (the first of its spec's ``customary_timesteps_s``: MuJoCo 2 ms,
    PyBullet 1/240 s, Drake 1 ms, pymunk 1/60 s), so "default" means the engine as it comes;
    otherwise None, the adapter's step for the scenario (engines without customary steps).
    (A measured scenario steps by its own fields: :meth:`ScenarioSpec.at_timestep`.)"""
    if timestep_s is not None:
        return timestep_s, GIVEN
    if mode == "default":
        from impactbench.engines.registry import spec

        customary = spec(engine).customary_timesteps_s
        if customary:
            return float(customary[0]), ENGINE_DEFAULT
    return None, ADAPTER_DEFAULT


def _yes(fn, *args: Any) -> Any:
    """Call something that checks the cost; its ``--yes`` advice in the caller's spelling
    (``yes=True`` from Python)."""
    try:
        return fn(*args)
    except ValueError as exc:
        yes = _say().setting("yes", True)
        raise ValueError(str(exc).replace("pass --yes", f"pass {yes}")) from None


def _run_mode(spec: Any, mode: str | None, params: Mapping[str, Any], param_set: str | None,
              tuned_file: Any) -> str:
    """The mode of a run and its checks: the given one, else ``custom`` with engine
    parameters (or a parameter set), ``tuned`` with a tuned file, else the scenario's
    default (``native``; a measured scenario's ``default``)."""
    from impactbench.engines.registry import MODES

    say = _say()
    mode = mode or ("custom" if params or param_set is not None
                    else "tuned" if tuned_file is not None else spec.default_mode)
    _one_of("mode", mode, MODES)
    if params and mode != "custom":
        raise ValueError(f"{say.name('params')} = {next(iter(params))}: "
                         f"{say.option('params')} needs {say.setting('mode', 'custom')} "
                         f"(got {say.value(mode)})")
    if tuned_file is not None and mode != "tuned":
        raise ValueError(f"{say.name('tuned_file')} = {str(tuned_file)!r}: "
                         f"{say.option('tuned_file')} needs {say.setting('mode', 'tuned')} "
                         f"(got {say.value(mode)})")
    return mode


def _run_checks(engine: str, spec: Any, params: Mapping[str, Any], param_set: str | None,
                limits: Mapping[str, float]) -> None:
    """What a run's engine settings must satisfy for this scenario: a parameter set and no
    plausibility limits only for a measured scenario (its replay checks its own keys), the
    engine's own parameter names for every other."""
    from impactbench.engines.base import parameter_keys

    say = _say()
    if param_set is not None and not spec.measured:
        raise ValueError(f"{say.name('param_set')} = {param_set!r}: {spec.name} has no "
                         "parameter sets (they come with a data-driven scenario's "
                         "measurements)")
    if spec.measured:
        for key, value in limits.items():
            raise ValueError(f"{say.name(key)} = {_g(value)}: {spec.name} is judged against "
                             "its measurements, not by plausibility limits")
        return
    valid = parameter_keys(engine)
    for key in params:
        if key not in valid:
            raise ValueError(f"{say.name('params')} = {key!r}: not a {engine} parameter; "
                             f"valid keys: {', '.join(valid) or '(none)'}{_hint(key, valid)}")


def _timeout(timeout_s: float | None, steps: float, spec: Any, engine: str) -> float | None:
    """The run's timeout (s): the given one, else max(60 s, 20 × the run's estimate), plus
    the engine's first-use compile allowance (:func:`impactbench.cluster.first_use_s`); a
    replay without an estimate (its length varies with its tosses) has none."""
    from impactbench import cluster
    from impactbench.cliutil import timeout_option

    given = timeout_option(timeout_s, name=_say().name("timeout_s"))
    if given is not None:
        return given + cluster.first_use_s(engine)
    if steps or not spec.owns_timestep:
        return cluster.default_timeout(cluster.run_estimate_s(steps)) + \
            cluster.first_use_s(engine)
    return None


# ------------------------------------------------------------------------------ functions


def reference_solution(scenario: str | None = None, **fields: Any) -> dict[str, Any]:
    """The reference (ground truth) of a scenario: its metrics, status and message.

    The keys are those of ``impactbench reference ball-on-plate --json``: the point's values
    (``velocity_m_s``), the scenario's metrics, ``status`` (``unsupported`` where the
    reference is outside its model, e.g. a ball indented beyond its radius) and ``message``.
    ``scenario`` defaults to the first registered one (``ball-on-plate``); ``fields`` are its
    fields, axes and further options (see the module's docstring).

    >>> import impactbench
    >>> ref = impactbench.reference_solution(scenario="ball-on-plate", velocity_m_s=2.0)
    >>> list(ref)
    ['velocity_m_s', 'restitution', 'duration_s', 'peak_force_n', 'max_penetration_m',
     'energy_loss_fraction', 'status', 'message']
    >>> round(ref["restitution"], 4), round(ref["duration_s"] * 1e6, 1), ref["status"]
    (0.8822, 91.2, 'ok')

    Your own ball, from a material (mass from the density, Hertz stiffness on a steel plate):

    >>> rubber = impactbench.reference_solution(velocity_m_s=2.0, material="rubber",
    ...                                         radius_m=0.03)
    >>> rubber["duration_s"] > 10 * ref["duration_s"]  # a soft ball stays in contact longer
    True

    The 2-DOF rigid–flexible model, one law pair:

    >>> rf = impactbench.reference_solution(scenario="rigid-flexible", velocity_m_s=10.0,
    ...                            local="elastoplastic", structure="linear")
    >>> rf["local"], rf["status"], rf["impacts"] >= 1
    ('elastoplastic', 'ok', True)
    """
    name = _scenario_name(scenario)
    _check_keywords(f"impactbench.reference_solution(scenario={name!r})", fields,
                    ("scenario", *scenario_keywords(name)))
    spec = scenarios.get(name)
    built = _build(name, fields)
    ref = dict(spec.reference_metrics(built))
    problem = spec.problem(built, ref)
    status, message = ref.pop("status", "ok"), ref.pop("message", "")
    return {**dict(spec.point_of(built)), **ref, "status": "unsupported" if problem else status,
            "message": problem or message}


def run(engine: str, scenario: str | None = None, mode: str | None = None, *,
        params: Mapping[str, Any] | None = None, param_set: str | None = None,
        tuned_file: str | Path | None = None, timestep_s: float | None = None,
        yes: bool = False, timeout_s: float | None = None,
        max_penetration_ratio: float | None = None, max_energy_ratio: float | None = None,
        **fields: Any) -> RunResult:
    """Run one scenario in one engine and compare it with the reference (``impactbench run``).

    Args:
        engine: the engine's registry name (``mujoco``, ``pybullet``, ``pymunk``, ``drake``,
            and the extras').
        scenario: the scenario's registry name (default: the first, ``ball-on-plate``).
        mode: ``native``, ``injected``, ``tuned``, ``default`` or ``custom`` (default:
            ``custom`` with ``params`` or ``param_set``, ``tuned`` with ``tuned_file``, else
            the scenario's: ``native``, a measured scenario's ``default``).
        params: ``custom`` mode: engine parameters by the engine's own names (``run
            --param``'s keys: ``solref``, ``contactStiffness``, ``elasticity``, …; a measured
            scenario's replay keys, ``board.contactStiffness``).
        param_set: ``custom`` mode of a measured scenario: a parameter set published with its
            data (the cube tosses' ``dair2022``), overlaid by ``params``.
        tuned_file: ``tuned`` mode: a tuned file (``tune(out=...)``); default the packaged
            one fitted at ``timestep_s``. It applies only to the scenario and step it was
            fitted for (else the status is ``unsupported``, naming the difference).
        timestep_s: the integration step (s); default: in ``default`` mode the engine's own
            default step (MuJoCo 2 ms, PyBullet 1/240 s, Drake 1 ms, pymunk 1/60 s), otherwise
            the adapter's for the scenario (:func:`run_timestep`). A measured scenario maps
            it to its own step (the cube tosses: a whole fraction of the sample interval).
        yes: run even when the estimate exceeds 1e7 integration steps.
        timeout_s: stop a run still going after this many seconds (status ``timeout``, no
            record; SIGALRM, so only from the main thread and only Python code: an engine
            stuck in C is stopped when it returns). Default: max(60 s, 20 × the run's
            estimate); none for a replay of measured data.
        max_penetration_ratio, max_energy_ratio: the plausibility limits (default 0.1 and
            1.01; :mod:`impactbench.plausibility`); a measured scenario has none.
        **fields: the scenario's fields, axes and further options (``velocity_m_s``,
            ``mass_kg``, ``material``, …).

    Returns a :class:`RunResult`; a failed run is a status, never an exception (bad input
    is a one-line ``ValueError``).

    >>> import impactbench
    >>> r = impactbench.run(engine="pymunk", scenario="ball-on-plate", velocity_m_s=2.0,
    ...                     timestep_s=1e-3)
    >>> r.status, r.mode, round(r.rel_error["restitution"], 3)
    ('ok', 'native', 0.063)
    >>> r.resolved["restitution"], r.resolved["duration_s"]
    (True, False)

    ``custom`` mode with the engine's own parameters, and ``tuned`` mode with the packaged
    file fitted at 1 ms:

    >>> c = impactbench.run(engine="pymunk", scenario="ball-on-plate", velocity_m_s=2.0,
    ...                     timestep_s=1e-3, params={"elasticity": 0.8})
    >>> c.mode, c.params["elasticity"], round(c.metrics["restitution"], 2)
    ('custom', 0.8, 0.8)
    >>> t = impactbench.run(engine="pymunk", scenario="ball-on-plate", mode="tuned",
    ...                     velocity_m_s=2.0, timestep_s=1e-3)
    >>> t.status, abs(t.rel_error["restitution"]) < abs(r.rel_error["restitution"])
    ('ok', True)
    """
    from impactbench.cliutil import check_cost
    from impactbench.engines.base import RunSettings
    from impactbench.engines.registry import engine_names, stdout_to_stderr
    from impactbench.evaluate import compare, reference_metrics
    from impactbench.matrix import estimated_steps_of

    say = _say()
    name = _scenario_name(scenario)
    spec = scenarios.get(name)
    velocity = fields.get("velocity_m_s")
    if velocity is not None and "velocity_m_s" not in spec.axis_names:
        raise ValueError(f"{say.name('velocity_m_s')} = {_g(velocity)}: {name} has no impact "
                         f"velocity (drop {say.option('velocity_m_s')})")
    _check_keywords(f"impactbench.run(scenario={name!r})", fields,
                    (*RUN_KEYWORDS, *scenario_keywords(name)))
    _one_of("engine", engine, engine_names())
    params = dict(params or {})
    mode = _run_mode(spec, mode, params, param_set, tuned_file)
    limits = {k: v for k, v in (("max_penetration_ratio", max_penetration_ratio),
                                ("max_energy_ratio", max_energy_ratio)) if v is not None}
    _run_checks(engine, spec, params, param_set, limits)
    if param_set is not None:
        params["param_set"] = param_set  # the replay's builder says which modes take it
    built = _build(name, fields)
    if spec.owns_timestep:  # the scenario's fields carry the step (a replay's substeps)
        timestep_s, timestep_source = timestep_s, ""
    else:
        timestep_s, timestep_source = run_timestep(engine, mode, timestep_s)
    at_step = spec.at_timestep(built, timestep_s)[0]
    settings = RunSettings(timestep_s=timestep_s, params=params or None)
    if mode == "tuned":  # bound to the scenario at this step
        from impactbench.tuned import tuned_settings

        tuned, provenance = tuned_settings(engine, at_step, timestep_s, tuned_file)
        settings = RunSettings(timestep_s=timestep_s, tuned=tuned, tuned_for=provenance,
                               params=params or None)
    if limits:
        from impactbench.plausibility import Limits, judge

        judged = Limits(**limits)  # (validated before the run)
    ref = reference_metrics(at_step)
    steps = estimated_steps_of(ref, timestep_s)
    check_cost(steps, f"{say.name('timestep_s')} = {timestep_s!r}", yes, "integration steps",
               yes_flag=say.setting("yes", True))
    limit = _timeout(timeout_s, steps, spec, engine)
    with stdout_to_stderr():  # engines print banners on stdout
        out, record = compare(engine, built, mode, settings, ref, timeout_s=limit,
                              backstop=say.command)
    if limits:
        out = judge(out, judged)
    return RunResult.from_compare(out, spec.metrics, built, record, timestep_source)


def tune(engine: str, scenario: str | None = None, *,
         velocities_m_s: Sequence[float] | None = None,
         targets: Sequence[str] | None = None, weights: Sequence[float] | None = None,
         parameters: str | None = None, solref_form: str = "direct",
         timestep_s: float | None = None, budget_s: float | None = None,
         max_evals: int | None = None, params: Mapping[str, Any] | None = None,
         out: str | Path | None = None, plot: str | Path | None = None,
         store: str | Path | bool | None = None, fresh: bool = False, workers: int | None = 0,
         scheduler: str | None = None, yes: bool = False, phases: int | None = None,
         **fields: Any) -> TuneFit:
    """Fit an engine's contact parameters to the reference (``impactbench tune``).

    Args:
        engine: the engine's registry name.
        scenario: a scenario that serves tuning (default: the first, ``ball-on-plate``).
        velocities_m_s: the impact velocities of the objective (default the paper's 0.5–5).
        targets, weights: the metrics fitted (default restitution, duration, peak force)
            and a weight ≥ 0 for each (default 1).
        parameters: the engine's parameter set (``tune --parameters``; default its first).
        solref_form: MuJoCo's solref form, ``direct`` or ``timeconst``.
        timestep_s: the step to fit at (s); default the adapter's (1e-6 s for the ball). At
            a step too coarse to resolve the contact only restitution is fitted.
        budget_s, max_evals: wall-time (default 600 s) and evaluation budgets: the search
            stops cleanly and keeps the best.
        params: engine settings held fixed and written with the fit (``tune --param``).
        out: write the tuned file here (``run(tuned_file=...)`` and reports read it).
        plot: draw the residual plot (PNG) here.
        store: the results store: a path, None for ``$IMPACTBENCH_STORE`` or the per-user
            cache (as the command), False for none.
        fresh: run everything again instead of serving stored runs.
        workers, scheduler: where engine runs execute: 0 (default) in this process, N local
            Dask workers, or an existing Dask scheduler. The fit is the same wherever it runs.
        yes: fit even when one evaluation (a run per velocity) is estimated above 1e7
            integration steps (the budget is checked between evaluations only).
        phases: the phases of the step each velocity is run at, judged at the worst
            (:mod:`impactbench.phases`); None: 8 at a step not much shorter than the
            contact, else 1.
        **fields: the scenario's fields and further options (``mass_kg``, ``material``, …).

    Returns a :class:`TuneFit`.

    >>> import impactbench, pathlib, tempfile
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "pymunk_1ms.toml"
    >>> fit = impactbench.tune(engine="pymunk", timestep_s=1e-3, velocities_m_s=(1.0, 2.0),
    ...                        targets=("restitution",), max_evals=5, out=path)
    >>> fit.parameter_set, round(fit.parameters["elasticity"], 2), fit.stop
    ('elasticity', 0.91, 'evaluation budget spent')
    >>> print(fit.snippet)
    ball_shape.elasticity = 0.91...
    >>> [(row["velocity_m_s"], row["metric"]) for row in fit.residuals]
    [(1.0, 'restitution'), (2.0, 'restitution')]
    >>> fit.objective_tuned < fit.objective_start, fit.files["tuned"] == str(path)
    (True, True)
    >>> r = impactbench.run(engine="pymunk", tuned_file=path, velocity_m_s=2.0,
    ...                     timestep_s=1e-3)
    >>> e = fit.parameters["elasticity"]  # pymunk's restitution: the ball's, the plate's is 1
    >>> r.mode, r.status, abs(r.metrics["restitution"] - e) < 1e-9
    ('tuned', 'ok', True)
    """
    from impactbench.cluster import Runner
    from impactbench.engines.base import get_adapter
    from impactbench.engines.registry import engine_names, stdout_to_stderr
    from impactbench.evaluate import reference_metrics
    from impactbench.publish import check_file_target
    from impactbench.reference import validation as check
    from impactbench.tuned import write_tuned
    from impactbench.tuning import optimize, output
    from impactbench.tuning.names import DEFAULT_BUDGET_S

    name = _scenario_name(scenario, "tuning")
    _check_keywords(f"impactbench.tune(scenario={name!r})", fields,
                    (*TUNE_KEYWORDS, *scenario_keywords(name, point=False)))
    _one_of("engine", engine, engine_names())
    from numbers import Integral

    if max_evals is not None and (isinstance(max_evals, bool)
                                  or not isinstance(max_evals, Integral) or max_evals < 1):
        # "5" or 2.5 would fail deep in the search
        raise ValueError(f"max_evals = {max_evals!r}: must be an integer >= 1 (None: no "
                         "evaluation budget)")
    if params:  # a key the engine's tuned mode does not read would be written and ignored
        from impactbench.tuned import tuned_keys

        valid = tuned_keys(engine)
        for key in params:
            if valid is not None and key not in valid:
                raise ValueError(f"{_say().name('params')} = {key!r}: not a {engine} tuned key"
                                 f"{_hint(key, valid)}; valid keys: {', '.join(valid)}")
    built = _build(name, fields)
    if isinstance(velocities_m_s, int | float):
        velocities_m_s = (float(velocities_m_s),)
    if velocities_m_s is not None and not velocities_m_s:
        raise ValueError(f"{_say().name('velocities_m_s')} = []: must list at least one "
                         "impact velocity")
    if timestep_s is not None:  # one evaluation (a run per velocity) must fit the cost limit
        from impactbench.cliutil import check_cost
        from impactbench.matrix import estimated_steps_of
        from impactbench.reference.scenarios import PAPER_VELOCITIES_M_S

        check.positive(_say().name("timestep_s"), timestep_s)
        steps = sum(estimated_steps_of(reference_metrics(built.replace(velocity_m_s=v)),
                                       timestep_s)
                    for v in (velocities_m_s or PAPER_VELOCITIES_M_S))  # (the fit's default)
        _yes(check_cost, steps, f"{_say().name('timestep_s')} = {timestep_s!r}", yes,
             "integration steps per evaluation")
    if isinstance(targets, str):
        targets = (targets,)
    files_to = {"tuned": Path(out) if out is not None else None,
                "plot": Path(plot) if plot is not None else None}
    for what, path in files_to.items():
        if path is not None:
            check_file_target(path, "out" if what == "tuned" else what)  # before the fit
    if store is False:
        results_store = None
    else:
        from impactbench.store import Store, default_path

        results_store = Store(Path(store) if store not in (None, True) else default_path())
    with stdout_to_stderr(), Runner(workers, scheduler,
                                    min_dispatch_s=TUNE_DISPATCH_MIN_S) as runner:
        get_adapter(engine).version()  # its import banner before any output, on stderr
        ran_on = runner.describe()
        result = optimize.tune(
            engine, built, None if velocities_m_s is None else list(velocities_m_s),
            None if targets is None else list(targets),
            None if weights is None else list(weights), parameters=parameters,
            solref_form=solref_form, timestep_s=timestep_s,
            budget_s=DEFAULT_BUDGET_S if budget_s is None else budget_s, max_evals=max_evals,
            fixed=dict(params) if params else None, store=results_store, fresh=fresh,
            runner=runner, phases=phases)
    files: dict[str, str] = {}
    if files_to["tuned"] is not None:
        model = getattr(built, "model", name)
        if getattr(built, "nominal_restitution", None) is not None:
            model += f" (nominal e = {built.nominal_restitution:g})"
        header = (f"impactbench tune: {result.space.engine} ({result.space.variant}) fitted "
                  f"to {model} on {name}.\nRead by `impactbench run --mode tuned` and the "
                  "report; [parameters] uses the adapter's tuned keys.")
        files["tuned"] = str(write_tuned(files_to["tuned"], output.tuned_tables(result),
                                         header))
    if files_to["plot"] is not None:
        files["plot"] = str(output.plot(result, files_to["plot"]))
    data = output.as_json(result, files)
    return TuneFit(engine=data["engine"], engine_version=data["engine_version"],
                   parameter_set=data["parameter_set"], parameters=data["parameters"],
                   snippet=data["snippet"], start_parameters=data["start_parameters"],
                   objective_start=data["objective_start"],
                   objective_tuned=data["objective_tuned"], residuals=data["residuals"],
                   summary=data["summary"], honesty=data["honesty"], stop=data["stop"],
                   timestep_s=data["timestep_s"], files=files, result=result, data=data,
                   ran_on=ran_on)


def build_report(config: str | Path | Mapping[str, Any] | None = None,
                 out: str | Path = "reports", *, engines: Sequence[str] | str | None = None,
                 workers: int | None = None, scheduler: str | None = None,
                 store: str | Path | bool | None = None, fresh: bool = False,
                 yes: bool = False, progress: bool = True, timeout_s: float | None = None,
                 scenario_file: str | Path | None = None,
                 keep_unchanged: bool = False) -> Any:
    """Run a comparison matrix and write its report (``impactbench report``).

    Args:
        config: the matrix: None for the packaged default
            (``impactbench/data/default.toml``), a TOML file (read as ``report --config``
            reads it), or its tables as a dict (:func:`impactbench.config.parse`: the dict
            is the whole matrix).
        out: the report folder (written whole, atomically).
        engines: restrict the config's engines (a list, or a comma string).
        workers: local worker processes (default: ``[execution]``'s, else one per core;
            0 runs everything in this process, without crash isolation).
        scheduler: an existing Dask scheduler's address instead.
        store: the results store: a path, None for ``[execution]``'s, ``$IMPACTBENCH_STORE``
            or the per-user cache (as the command), False for none.
        fresh: run everything again instead of serving stored runs.
        yes: run even when the missing runs exceed 1e7 integration steps in all.
        progress: show progress on stderr.
        timeout_s: the per-run timeout (a run outlasting it is a ``timeout`` row, its worker
            restarted; default ``[execution] timeout_s``, else max(60 s, 20 × the run's
            estimate)).
        scenario_file: a TOML file of scenario fields (``impactbench calibrate``'s) replacing
            the config's ball parameters (the calibration study's scenario table).
        keep_unchanged: leave the folder as it is when its report has the same results apart
            from wall times.

    Returns the :class:`impactbench.report.Report`: ``results`` (the tidy DataFrame, one row
    per run and metric, as ``results.csv``), ``files`` (every file written), ``out_dir``,
    ``wall_s`` and ``kept``.

    >>> import impactbench, tempfile
    >>> small = {"report": {"engines": ["pymunk"], "modes": ["native"]},
    ...          "ball_on_plate": {"velocities_m_s": [1.0, 2.0],
    ...                            "timestep_s": {"pymunk": 1e-3}}}
    >>> rep = impactbench.build_report(config=small, out=tempfile.mkdtemp(), workers=0,
    ...                          store=False, progress=False)
    >>> sorted(set(rep.results.engine)), sorted(set(rep.results.velocity_m_s))
    (['pymunk'], [1.0, 2.0])
    >>> sorted(f.name for f in rep.files if f.parent == rep.out_dir)
    ['README.md', 'index.html', 'metadata.json', 'results.csv', 'results.parquet']
    """
    from impactbench import config as config_mod
    from impactbench import publish
    from impactbench import report as report_mod
    from impactbench.cliutil import execution_options, timeout_option
    from impactbench.cluster import run_timeout
    from impactbench.engines.registry import engine_names

    say = _say()
    out = Path(out)
    publish.check_dir_target(out, "out")
    if isinstance(config, Mapping):
        cfg = config_mod.parse(dict(config))
    elif config is None or isinstance(config, str | Path):
        cfg = config_mod.load(config)
    else:
        raise ValueError(f"config = {config!r}: must be None, a TOML file's path or a dict "
                         "of its tables")
    if scenario_file is not None:
        from impactbench.scenario_file import load_scenario_file

        table = scenarios.for_study("calibrate").table
        raw = dict(cfg.raw)
        raw[table] = {**raw.get(table, {}), **load_scenario_file(scenario_file)}
        cfg = config_mod.parse(raw, source=f"{cfg.source} + {scenario_file}")
    chosen = None
    if engines is not None:
        chosen = [e.strip() for e in engines.split(",") if e.strip()] \
            if isinstance(engines, str) else list(engines)
        for e in chosen:
            _one_of("engines", e, engine_names())
    opts = execution_options(cfg, workers=workers, scheduler=scheduler, fresh=fresh, yes=yes,
                             store=None if store in (None, True, False) else Path(store))
    if store is False:
        opts["store"] = None
    limit = timeout_option(timeout_s, cfg, name=say.name("timeout_s"))
    with run_timeout(limit):
        return _yes(lambda: report_mod.build(cfg, out, engines=chosen, show_progress=progress,
                                             keep_unchanged=keep_unchanged, **opts))
