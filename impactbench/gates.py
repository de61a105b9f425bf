"""CI accuracy gates: tolerated relative errors per engine × mode × scenario × metric.

A gate file (TOML) lists gates; each expands into *checks* (one per engine, mode, velocity,
timestep, law pair and metric). A check passes when the engine's metric is within its
tolerance of the reference solution, ``|rel_error| ≤ tolerance`` with
``rel_error = (engine − reference)/|reference|`` (dimensionless), and — when a baseline of
earlier measured values exists — when its *signed* error has not moved away from the
baseline's beyond a band relative to it::

    band = baseline_margin·|e_base| + baseline_floor
    |e − e_base| ≤ band                  pass
    |e| ≤ |e_base| − band                better (shrank by more than the band, either sign)
    otherwise                            worse  (grew, or changed sign without shrinking)

The band is relative, so an accurate check is held to its own accuracy (with the default
margin 0.5 an error of 3e-6 may drift to 4.5e-6, not to the tolerance): the absolute floor
only absorbs round-off (1e-8 by default; errors near round-off, ~1e-13, sit inside it).
Comparing signed errors catches an error that flips sign at the same size (a changed
integrator or contact rule), which |e| alone would not.

Gate file schema::

    [defaults]                      # optional
    baseline_margin = 0.5           # the signed error may move by this fraction of |e_base| …
    baseline_floor = 1e-8           # … plus this absolute amount (dimensionless) before `worse`

    [[gate]]                        # any number of gates
    engine = "mujoco"               # one name or a list (engines.base.ENGINES)
    mode = ["injected", "tuned"]    # one name or a list (engines.base.MODES)
    scenario = "ball-on-plate"      # a registered scenario (impactbench.scenarios)
    velocities_m_s = [1.0, 5.0]     # optional; default: the scenario spec's gate velocities
    timesteps_s = [1e-6]            # optional; default: the adapter's default for scenario and mode
    local = "linear"                # a categorical axis of the scenario (rigid-flexible: local,
    structure = "linear"            # structure); one value or a list; default its first value
    parameters = {m2_kg = 0.3}      # optional scenario fields beyond the papers' defaults
    params = {solref = [0.02, 1.0]} # engine parameters by the engine's names (the adapter's
                                    # parameter_keys): required by mode custom; with mode tuned
                                    # the fixed settings picking the packaged tuned file
    tuned_file = "my_tuned.toml"    # mode tuned: this tuned file (relative to the gate file)
                                    # instead of the packaged one; default timesteps_s: its step
    phases = 8                      # optional: the head-on ball measured at 8 phases of its step
                                    # (impactbench.phases: median value, judged at the worst)
    baseline_margin = 0.5           # optional per-gate overrides of [defaults]
    baseline_floor = 1e-4
    [gate.tolerance]                # metric -> tolerated |relative error| (≥ 0)
    restitution = 0.005
    duration_s = 0.01
    [gate.abs_tolerance]            # optional: metric -> tolerated |engine − reference| in the
    contact_point_ratio = 0.001     # metric's unit, for a reference that may be 0 (the oblique
    regime = 0                      # stick regime's contact-point ratio; regime: 0 equal)

A gate needs ``tolerance``, ``abs_tolerance`` or both (a metric in one of them only). An
absolute check's ``rel_error`` field (tables, baseline) holds its signed absolute error
``engine − reference``; its baseline band works on that error the same way.

A check's id is its run's label and metric (``mujoco-injected-ball-on-plate-v1-dt1e-06-
restitution``); a run with engine parameters or a tuned file of the user's adds them
(``…-dt1e-06-solref=0.02,1-restitution``, ``…-tuned=my_tuned.toml-…``). An unknown key anywhere
is a one-line error listing the valid ones, with a "did you mean".

Two gates that produce the same check are an error (a check has one tolerance). Every error in
the file raises one-line ``ValueError`` ``"<file>:<line>: gate <n>: <key> = <value>: <rule>"``
(malformed TOML: tomllib's own message, which carries line and column).

Marks (asv-style), and whether they fail the run:

========================  ==================================================================
``pass``                  within tolerance and not worse than the baseline (or no baseline)
``better``                passes, and |err| shrank by more than the band: consider
                          ``--update-baseline`` (passes)
``worse``                 within tolerance, but the signed error left the baseline's band
                          other than towards zero (fails)
``fail``                  |err| > tolerance, or the engine produced no value (crashed,
                          diverged, tunneled, no contact …), and the baseline failed too or
                          there is none (fails)
``new-failure``           as ``fail``, but the baseline passed this check (fails)
``not-comparable``        the engine is not installed (``unavailable``) or the mode is not
                          available for it (``unsupported``, e.g. tuned mode with no tuned
                          file); passes unless ``strict`` (a user's machine may lack an
                          engine; the project's own CI installs all and runs ``--strict``)
========================  ==================================================================

Planning deduplicates: one engine run per distinct (engine, mode, scenario, velocity,
timestep, laws), however many checks need it. Runs go to spawned worker processes (default 2)
through :func:`impactbench.matrix.run_jobs`, so an engine that kills its process only marks its
own run ``crashed``.

The baseline (JSON) maps check ids to measured values::

    {"format": 1, "checks": {"<check id>": {"value": …, "reference": …, "rel_error": …,
                                             "status": "ok", "engine_version": "…"}}}

Data gates (a data-driven scenario, one whose spec has no axes and its own ``errors``: the cube
tosses).
Its reference is a measurement, and its metrics are already errors against it (the test
split's median of each toss's time-mean position error as a fraction of the cube's width,
``position_error_median``, and of its rotation error in degrees); a relative error against the
perfect value 0 is undefined. So a data check is **absolute**: its ``value`` is the metric,
its ``reference`` is 0 (the measurement), its ``rel_error`` field holds the metric itself (an
error ≥ 0, in the metric's unit) and ``tolerance`` is the largest value that passes (set from
measurement: ~1.3× the measured median, as for a contact model's error). The baseline band
works on the value the same way (``baseline_margin``·|base| + ``baseline_floor``): a median
that grows beyond it is ``worse``, one that shrinks beyond it is ``better``; replays are
deterministic, so data gates use a narrow margin (0.05). A replay whose tosses did not all
run (a message naming the failed ones, or status ``diverged``) gives no value: ``fail``. Not
the values DAIR or the independent replay reported: those are over all tosses, and DAIR's
parameters were fitted on all of them (no held-out set); the test split's medians are this
suite's own measurement.
Schema::

    [[gate]]
    engine = ["pybullet", "mujoco", "drake"]
    mode = "custom"
    scenario = "cube-toss"
    param_set = "dair2022"          # custom mode: a parameter set published with the data
    params = {"board.mu" = 0.1}     # optional: engine parameters by the replay's own names
    [gate.tolerance]                # metric -> the largest value that passes
    position_error_median = 0.15

on the scenario as it comes (the cube tosses: the packaged data's test split, DAIR's protocol).
Its check id: ``drake-custom-cube-toss-dtdefault-param_set=dair2022-position_error_median``
(``dtdefault``: the protocol's step). Data runs go through the same door as every other run
(the engines' cube-toss builders, the run matrix, the results store).
"""

from __future__ import annotations

import json
import math
import re
import tomllib
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from impactbench import phases as phases_mod
from impactbench import scenarios
from impactbench.engines.registry import ENGINES, MODES
from impactbench.matrix import Job, RunKey
from impactbench.reference import validation as check

DEFAULT_MARGIN = 0.5
DEFAULT_FLOOR = 1e-8

PASS, BETTER, WORSE, FAIL, NEW_FAILURE, NOT_COMPARABLE = (
    "pass", "better", "worse", "fail", "new-failure", "not-comparable")
MARKS: tuple[str, ...] = (PASS, BETTER, WORSE, FAIL, NEW_FAILURE, NOT_COMPARABLE)
FAILING: frozenset[str] = frozenset({WORSE, FAIL, NEW_FAILURE})
NOT_COMPARABLE_STATUSES: frozenset[str] = frozenset({"unavailable", "unsupported"})

FIXED_KEYS = ("engine", "mode", "scenario", "velocities_m_s", "timesteps_s", "parameters",
              "params", "tuned_file", "phases", "tolerance", "abs_tolerance",
              "baseline_margin", "baseline_floor")
DEFAULT_KEYS = ("baseline_margin", "baseline_floor")


def gate_keys() -> tuple[str, ...]:
    """The keys a ``[[gate]]`` may have: the fixed ones and every scenario's categorical axes
    (``local``, ``structure``) and further numeric axes (their config keys)."""
    extra = [a.name if a.categorical else a.config_key for s in scenarios.specs()
             for a in s.axes]
    return tuple(dict.fromkeys([*FIXED_KEYS[:5], *extra, *FIXED_KEYS[5:]]))


@dataclass(frozen=True)
class Check:
    """One metric of one run against its tolerance: the largest |relative error|
    (dimensionless), or with ``absolute`` the largest |engine − reference| in the metric's
    unit (``abs_tolerance``: a metric whose reference may be 0)."""

    run: RunKey
    metric: str
    tolerance: float
    margin: float = DEFAULT_MARGIN
    floor: float = DEFAULT_FLOOR
    gate: int = 0
    line: int = 0
    absolute: bool = False

    @property
    def id(self) -> str:
        return f"{run_label(self.run)}-{self.metric}"


@dataclass(frozen=True)
class GateFile:
    """A parsed, validated gate file."""

    path: Path
    checks: tuple[Check, ...]


@dataclass
class Outcome:
    """The judged result of one check."""

    check: Check
    mark: str
    status: str
    value: float = math.nan
    reference: float = math.nan
    rel_error: float = math.nan
    baseline_rel_error: float | None = None
    engine_version: str = ""
    wall_s: float = math.nan
    message: str = ""
    result: Mapping[str, Any] = field(default_factory=dict, repr=False)

    @property
    def failed(self) -> bool:
        return self.mark in FAILING


# ----------------------------------------------------------------------------- gate file


_HEADER = re.compile(r"^\s*(\[\[?)\s*([^\]]+?)\s*\]")
_KEY = re.compile(r"""^\s*("[^"]*"|'[^']*'|[A-Za-z0-9_.\-]+)\s*=""")
_INLINE_KEY = re.compile(r"""[{,]\s*("[^"]*"|'[^']*'|[A-Za-z0-9_\-]+)\s*=""")


class _LineIndex:
    """Line numbers of tables and keys in TOML text (tomllib does not give them)."""

    def __init__(self, text: str) -> None:
        self.gates: list[int] = []
        self.keys: dict[tuple[Any, ...], int] = {}
        block: tuple[Any, ...] = ("",)
        path: tuple[str, ...] = ()
        for n, raw in enumerate(text.splitlines(), start=1):
            line = raw.split("#", 1)[0]
            head = _HEADER.match(line)
            if head:
                parts = tuple(p.strip().strip("\"'") for p in head[2].split("."))
                if head[1] == "[[" and parts == ("gate",):
                    self.gates.append(n)
                    block, path = ("gate", len(self.gates)), ()
                elif parts[0] == "gate" and self.gates:
                    block, path = ("gate", len(self.gates)), parts[1:]
                else:
                    block, path = (parts[0],), parts[1:]
                self.keys.setdefault((*block, *path), n)
                continue
            key = _KEY.match(line)
            if key:
                name = tuple(p.strip().strip("\"'") for p in key[1].split("."))
                self.keys.setdefault((*block, *path, *name), n)
                rest = line[key.end():]
                for inner in _INLINE_KEY.finditer(rest):
                    self.keys.setdefault((*block, *path, *name, inner[1].strip("\"'")), n)

    def line(self, *key: Any) -> int:
        """The line of ``key`` or of its nearest enclosing table (1 if none is found)."""
        for end in range(len(key), 0, -1):
            if key[:end] in self.keys:
                return self.keys[key[:end]]
        if key and key[0] == "gate" and len(key) > 1 and 0 < key[1] <= len(self.gates):
            return self.gates[key[1] - 1]
        return 1


def _label_value(value: Any) -> str:
    if isinstance(value, list | tuple):
        return ",".join(_label_value(v) for v in value)
    if isinstance(value, float):
        return f"{value:g}"
    return str(value)


def run_label(run: RunKey) -> str:
    """A run's label in check ids: :attr:`RunKey.label`, plus the user's engine parameters
    (``-solref=0.02,1``) and tuned file (``-tuned=<file name>``) when the run has them (so the
    ids of runs without them, the baseline's keys, do not change)."""
    extra = "".join(f"-{k}={_label_value(v)}" for k, v in run.params)
    if run.tuned_file:
        extra += f"-tuned={Path(run.tuned_file).name}"
    return run.label + extra


def _names(value: Any, field_name: str, choices: Iterable[str]) -> list[str]:
    items = value if isinstance(value, list) else [value]
    if not items:
        raise ValueError(f"{field_name} = []: must name at least one")
    return [check.one_of(field_name, v, tuple(choices)) for v in items]


def _numbers(value: Any, field_name: str, zero: bool = False) -> list[float]:
    items = value if isinstance(value, list) else [value]
    if not items:
        raise ValueError(f"{field_name} = []: must hold at least one number")
    if zero:
        return [check.non_negative(field_name, v) for v in items]
    return [check.positive(field_name, v) for v in items]


def _parameters(value: Any, spec: scenarios.ScenarioSpec) -> tuple[tuple[str, Any], ...]:
    """A gate's ``parameters`` table, validated by building the scenario with them (numbers,
    or text for a text field such as the oblique impact's ``shape``)."""
    if not isinstance(value, dict) or not value:
        raise ValueError(f"parameters = {value!r}: must be a non-empty table of scenario "
                         "field = value")
    names = [f for f in spec.cls.field_names() if f not in spec.axis_names]
    out: list[tuple[str, Any]] = []
    for key, item in sorted(value.items()):
        check.one_of("parameters key", key, tuple(names))
        if isinstance(item, bool) or not isinstance(item, int | float | str):
            raise ValueError(f"parameters.{key} = {item!r}: must be a number or text")
        out.append((key, item if isinstance(item, str) else float(item)))
    spec.cls(**dict(out))  # the scenario's own validation (one-line ValueError)
    return tuple(out)


SETTINGS_MODES = ("custom", "tuned")
"""The modes a gate's ``params`` apply to (custom: run them; tuned: pick the tuned file)."""


def _engine_params(value: Any, engines: list[str], modes: list[str]
                   ) -> tuple[tuple[str, Any], ...]:
    """A gate's ``params``: the engine's own parameters, checked against each engine's
    ``parameter_keys``; a sorted, hashable tuple (:func:`impactbench.config.frozen_params`)."""
    from impactbench.config import check_values, did_you_mean, frozen_params
    from impactbench.engines.base import parameter_keys

    if not isinstance(value, dict) or not value:
        raise ValueError(f"params = {value!r}: must be a non-empty table of the engine's "
                         "parameters (e.g. params = {solref = [0.02, 1.0]})")
    if not any(m in SETTINGS_MODES for m in modes):
        raise ValueError(f"params = {value!r}: engine parameters are for mode custom (or tuned: "
                         f"the settings that pick the tuned file); this gate runs "
                         f"{', '.join(modes)}")
    for engine in engines:
        valid = parameter_keys(engine)
        for key, v in value.items():
            if key not in valid:
                raise ValueError(f"params.{key}: not a {engine} parameter"
                                 f"{did_you_mean(key, valid)}; valid keys: "
                                 f"{', '.join(valid) or '(none)'}")
            items = v if isinstance(v, list) else [v]
            if not items or not all(isinstance(x, str | int | float) for x in items):
                raise ValueError(f"params.{key} = {v!r}: must be a number, a string, a bool "
                                 "or a list of numbers")
        check_values("params", engine, value)
    return frozen_params(value)


def _tuned_file(value: Any, engines: list[str], modes: list[str], base: Path
                ) -> tuple[str, float | None]:
    """A gate's ``tuned_file`` (relative to the gate file's folder): its path, checked (it
    exists, it is one engine's and its keys are that engine's tuned keys), and the step it was
    fitted at (None when its provenance has none)."""
    from impactbench.tuned import check_tuned_keys, load_tuned_file

    if not isinstance(value, str) or not value:
        raise ValueError(f"tuned_file = {value!r}: must be the path of a tuned file "
                         "(impactbench tune --out)")
    if "tuned" not in modes:
        raise ValueError(f"tuned_file = {value!r}: a tuned file is for mode tuned; this gate "
                         f"runs {', '.join(modes)}")
    path = Path(value) if Path(value).is_absolute() else base / value
    try:
        data = load_tuned_file(path)
    except ValueError as exc:
        raise ValueError(f"tuned_file = {value!r}: {exc}") from None
    if data is None:
        raise ValueError(f"tuned_file = {value!r}: no such file (relative to the gate file's "
                         f"folder: {str(path)!r})")
    prov = data.get("provenance") if isinstance(data.get("provenance"), dict) else {}
    fitted = prov.get("engine")
    if len(engines) > 1 or (fitted is not None and fitted != engines[0]):
        raise ValueError(f"tuned_file = {value!r}: fitted for "
                         f"{repr(fitted) if fitted else 'one engine'}; the gate names "
                         f"{', '.join(engines)} (one engine per tuned file)")
    check_tuned_keys(engines[0], data["parameters"], value, prov.get("scenario"))
    dt = prov.get("timestep_s")
    return str(path.resolve()), (float(dt) if isinstance(dt, int | float) else None)


def _default_timestep(engine: str, mode: str, scenario: Any) -> float | None:
    """The adapter's default step (s), or None when the adapter cannot be loaded here."""
    try:
        from impactbench.engines.base import get_adapter

        dt = get_adapter(engine).default_timestep_s(scenario, mode)
        return None if dt is None else float(dt)
    except Exception:
        return None


class _GateError(ValueError):
    """A bad value in one ``[[gate]]``: ``keys`` locate it (its line)."""

    def __init__(self, keys: tuple[str, ...], exc: ValueError) -> None:
        super().__init__(str(exc))
        self.keys = keys


def _field(key: str, parse: Callable[[], Any]) -> Any:
    """``parse()``, its ValueError tagged with the gate key it is about."""
    try:
        return parse()
    except _GateError:
        raise
    except ValueError as exc:
        raise _GateError((key,), exc) from None


def _expand_gate(n: int, gate: Mapping[str, Any], defaults: Mapping[str, float],
                 where: Callable[..., int], base: Path = Path()) -> list[Check]:
    """Validate one ``[[gate]]`` table and expand it into checks (``base``: the gate file's
    folder, which a ``tuned_file`` is relative to). One expander for every scenario: a
    measured one (the cube tosses) has no axes, takes a published ``param_set`` and judges
    absolute errors (module doc, "Data gates")."""
    try:
        return _expand(gate, defaults, base, where("gate", n), n)
    except _GateError as exc:
        raise ValueError(f"line {where('gate', n, *exc.keys)}: gate {n}: {exc}") from None


def _expand(gate: Mapping[str, Any], defaults: Mapping[str, float], base: Path, line: int,
            n: int) -> list[Check]:
    from impactbench.config import did_you_mean

    measured = gate.get("scenario") in scenarios.names() and \
        scenarios.get(gate["scenario"]).measured
    keys = DATA_KEYS if measured else gate_keys()
    for key in gate:
        if key not in keys:
            what = " for a data scenario" if measured else ""
            raise _GateError((key,), ValueError(
                f"key {key!r}: unknown{what}{did_you_mean(key, keys)}; must be one of "
                f"{', '.join(keys)}"))
    for key in ("engine", "mode", "scenario"):
        if key not in gate:
            raise _GateError((), ValueError(f"{key}: missing (required in every [[gate]])"))
    if "tolerance" not in gate and ("abs_tolerance" not in gate or measured):
        raise _GateError((), ValueError("tolerance: missing (required in every [[gate]]"
                                        + ("" if measured else " without abs_tolerance")
                                        + ")"))
    engines = _field("engine", lambda: _names(gate["engine"], "engine", ENGINES))
    modes = _field("mode", lambda: _names(gate["mode"], "mode", MODES))
    name = _field("scenario", lambda: check.one_of("scenario", gate["scenario"],
                                                    scenarios.names()))
    spec = scenarios.get(name)
    timesteps: list[float | None] = _field("timesteps_s", lambda: list(
        _numbers(gate["timesteps_s"], "timesteps_s")) if "timesteps_s" in gate else [None])
    points = _gate_points(gate, spec)
    params = _field("parameters", lambda: _parameters(gate["parameters"], spec)
                    if "parameters" in gate else ())
    settings = _gate_settings(gate, spec, engines, modes)
    tuned_file = ""
    if "tuned_file" in gate:
        tuned_file, fitted_dt = _field("tuned_file", lambda: _tuned_file(
            gate["tuned_file"], engines, modes, base))
        timesteps = _field("tuned_file", lambda: _fitted_steps(gate, timesteps, fitted_dt))
    n_phases = _field("phases", lambda: len(phases_mod.offsets(gate["phases"]))) \
        if "phases" in gate else 1
    margins = {**defaults, **{k: _field(k, lambda k=k: check.non_negative(k, gate[k]))
                              for k in DEFAULT_KEYS if k in gate}}
    tol = {m: (t, False) for m, t in (_gate_tolerance(gate["tolerance"], spec)
                                      if "tolerance" in gate else {}).items()}
    if "abs_tolerance" in gate:
        absolute = _gate_tolerance(gate["abs_tolerance"], spec, "abs_tolerance")
        both = sorted(set(absolute) & set(tol))
        if both:
            raise _GateError(("abs_tolerance", both[0]), ValueError(
                f"abs_tolerance.{both[0]}: also in tolerance; a metric has one tolerance"))
        tol.update((m, (t, True)) for m, t in absolute.items())
    out = []
    for engine in engines:
        for mode in modes:
            # the user's settings go with the modes that use them
            user = settings if mode in SETTINGS_MODES and not (
                mode == "tuned" and tuned_file) else ()
            own_file = tuned_file if mode == "tuned" else ""
            for point in points:
                for dt in timesteps:
                    run = RunKey(engine, spec.name, point, mode, dt, params, user, own_file,
                                 n_phases)
                    if dt is None and not spec.owns_timestep:
                        dt = _default_timestep(engine, mode, run.build_scenario())
                        run = RunKey(engine, spec.name, point, mode, dt, params, user, own_file,
                                     n_phases)
                    out.extend(Check(run, m, t, margins["baseline_margin"],
                                     margins["baseline_floor"], n, line, absolute)
                               for m, (t, absolute) in tol.items())
    return out


def _gate_points(gate: Mapping[str, Any], spec: scenarios.ScenarioSpec) -> list[tuple]:
    """The points a gate runs: every combination of its axes' values (the scenario's gate
    velocities when it names none); ``[()]`` for a scenario without axes."""
    import itertools

    own = {a.name if a.categorical else a.config_key for a in spec.axes}
    fixed = set(FIXED_KEYS) | set(DATA_KEYS)
    for key in gate:
        if (key not in fixed or key == "velocities_m_s") and key not in own:
            raise _GateError((key,), ValueError(
                f"{key} = {gate[key]!r}: not an axis of {spec.name} (its axes: "
                f"{', '.join(sorted(own)) or 'none'})"))
    axis_values: list[tuple[str, list[Any]]] = []
    for a in spec.axes:
        key = a.name if a.categorical else a.config_key
        if a.categorical:
            values = _field(key, lambda a=a, key=key: _names(
                gate.get(key, a.defaults()[0]), key, a.allowed()))
        elif key in gate:
            values = _field(key, lambda a=a, key=key: _numbers(gate[key], key, a.zero))
        elif a.name == "velocity_m_s":
            values = list(spec.gate_velocities_m_s)
        else:
            raise _GateError((key,), ValueError(f"{key}: missing (required for {spec.name})"))
        axis_values.append((a.name, values))
    names = [a for a, _ in axis_values]
    return [tuple(zip(names, combo, strict=True))
            for combo in itertools.product(*(v for _, v in axis_values))]


def _gate_settings(gate: Mapping[str, Any], spec: scenarios.ScenarioSpec, engines: list[str],
                   modes: list[str]) -> tuple[tuple[str, Any], ...]:
    """A gate's engine settings: ``params`` (the engine's own keys) and, for a measured
    scenario, a published ``param_set``; checked against each engine without running it."""
    from impactbench.config import frozen_params

    if not spec.measured:
        if "params" in gate:
            return _field("params", lambda: _engine_params(gate["params"], engines, modes))
        if "custom" in modes:
            raise _GateError(("mode",), ValueError(
                "mode = 'custom': needs params, the engine parameters to run (e.g. params = "
                "{solref = [0.02, 1.0]}); without them custom is the engine's defaults, mode "
                "default"))
        return ()
    param_set = gate.get("param_set")
    if param_set is not None and not isinstance(param_set, str):
        raise _GateError(("param_set",), ValueError(
            f"param_set = {param_set!r}: must be a name"))
    params = gate.get("params", {})
    if not isinstance(params, dict):
        raise _GateError(("params",), ValueError(
            f"params = {params!r}: must be a table of the builder's engine parameters"))
    given = {**params, **({"param_set": param_set} if param_set is not None else {})}
    if "custom" in modes and not given:
        raise _GateError(("mode",), ValueError(
            "mode = 'custom': needs param_set (a published set) or params (the engine's "
            "board./cube. keys)"))
    scenario = spec.build()
    for engine in engines if given else ():  # the engine's own (no engine imported)
        for mode in modes:
            try:
                scenario.engine_parameters(engine, mode, given, {"checked": True})
            except ValueError as exc:
                key = "param_set" if param_set is not None else "params"
                raise _GateError((key,), ValueError(f"{engine} {mode}: {exc}")) from None
    return frozen_params(given)


def _fitted_steps(gate: Mapping[str, Any], timesteps: list[float | None],
                  fitted_dt: float | None) -> list[float | None]:
    """The steps of a gate with a tuned file: the one it was fitted at unless the gate names
    steps, which must then be that one."""
    if "timesteps_s" not in gate and fitted_dt is not None:
        return [fitted_dt]  # the step the file was fitted for
    if fitted_dt is not None and any(dt is None or abs(dt - fitted_dt) > 1e-9 * fitted_dt
                                     for dt in timesteps):
        raise ValueError(f"tuned_file = {gate['tuned_file']!r}: fitted at timestep_s = "
                         f"{fitted_dt:g}; the gate's timesteps_s = {timesteps}: it applies "
                         "only at its own step")
    return timesteps


def _gate_tolerance(tolerance: Any, spec: scenarios.ScenarioSpec,
                    key: str = "tolerance") -> dict[str, float]:
    """A gate's ``tolerance`` table: metric → the largest |relative error| that passes (a
    measured scenario's: the largest absolute error against the measurement); its
    ``abs_tolerance`` table (``key``): metric → the largest |engine − reference|."""
    if not isinstance(tolerance, dict) or not tolerance:
        what = ("tolerated value (an absolute error against the measurement)" if spec.measured
                else "tolerated |engine − reference| (the metric's unit)"
                if key == "abs_tolerance" else "tolerated |relative error|")
        raise _GateError((key,), ValueError(
            f"{key}: must be a non-empty table of metric = {what}"))
    tol: dict[str, float] = {}
    for metric, value in tolerance.items():
        try:
            check.one_of(f"{key} key", metric, spec.metrics)
            tol[metric] = check.non_negative(f"{key}.{metric}", value)
        except ValueError as exc:
            raise _GateError((key, metric), exc) from None
    return tol


DATA_KEYS = ("engine", "mode", "scenario", "param_set", "params", "tolerance",
             "baseline_margin", "baseline_floor")
"""The keys of a data gate's ``[[gate]]`` (module doc, "Data gates")."""


def parse_gates(text: str, path: str | Path = "<gates>") -> GateFile:
    """Validate gate-file text and expand it into checks (see the module docstring)."""
    path = Path(path)
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ValueError(f"{path}: malformed TOML: {exc}") from None
    lines = _LineIndex(text)
    for key in data:
        if key not in ("defaults", "gate"):
            from impactbench.config import did_you_mean

            raise ValueError(f"{path}:{lines.line(key)}: {key}: unknown table or key"
                             f"{did_you_mean(key, ('defaults', 'gate'))}; must be [defaults] "
                             "or [[gate]]")
    defaults = {"baseline_margin": DEFAULT_MARGIN, "baseline_floor": DEFAULT_FLOOR}
    raw_defaults = data.get("defaults", {})
    if not isinstance(raw_defaults, dict):
        raise ValueError(f"{path}:{lines.line('defaults')}: defaults: must be a table")
    for key, value in raw_defaults.items():
        try:
            check.one_of("defaults key", key, DEFAULT_KEYS)
            defaults[key] = check.non_negative(f"defaults.{key}", value)
        except ValueError as exc:
            raise ValueError(f"{path}:{lines.line('defaults', key)}: {exc}") from None
    gates = data.get("gate")
    if not isinstance(gates, list) or not gates:
        raise ValueError(f"{path}:1: gate: no [[gate]] tables; a gate file needs at least one")
    checks: list[Check] = []
    seen: dict[str, Check] = {}
    for n, gate in enumerate(gates, start=1):
        try:
            expanded = _expand_gate(n, gate, defaults, lines.line, path.parent)
        except ValueError as exc:
            raise ValueError(f"{path}:{str(exc).removeprefix('line ')}") from None
        for c in expanded:
            if c.id in seen:
                raise ValueError(f"{path}:{c.line}: gate {n}: check {c.id} repeats gate "
                                 f"{seen[c.id].gate} (line {seen[c.id].line}); one tolerance "
                                 "per check")
            seen[c.id] = c
        checks.extend(expanded)
    return GateFile(path, tuple(checks))


def load_gates(path: str | Path) -> GateFile:
    """Read and validate a gate file."""
    path = Path(path)
    try:
        text = path.read_text()
    except OSError as exc:
        raise ValueError(f"gate file {path}: cannot be read ({exc.strerror})") from None
    except UnicodeDecodeError:
        raise ValueError(f"gate file {path}: not a gate file (not UTF-8 text)") from None
    return parse_gates(text, path)


# ----------------------------------------------------------------------------- running


def plan(checks: Iterable[Check]) -> list[RunKey]:
    """The distinct engine runs the checks need, in a stable order."""
    runs = {c.run for c in checks}
    return sorted(runs, key=lambda r: (r.engine, r.scenario, r.mode, r.point,
                                        r.timestep_s or 0.0, r.parameters))


def _job(run: RunKey) -> Job:
    return Job(run.engine, run.scenario, run.point, run.mode, run.timestep_s, run.parameters,
               run.params, run.tuned_file, run.phases, study="gate")


def execute(runs: Iterable[RunKey], jobs: int | None = None,
            progress: Callable[[int], None] | None = None,
            **run_options: Any) -> dict[RunKey, dict[str, Any]]:
    """Run every run and compare it with the reference: run → ``evaluate.compare``'s object.

    Built on :func:`impactbench.matrix.run_jobs` (``jobs`` local workers, default one per
    core, or the ``scheduler``'s; an engine that kills its worker process becomes a
    ``crashed`` run, the others are unaffected);
    ``jobs = 0`` runs in this process (no crash isolation; for debugging). ``run_options``
    (store, fresh, scheduler, yes, timeout_s) go to ``run_jobs``: stored runs are not run
    again; ``yes = False`` refuses runs estimated above ``cliutil.COST_LIMIT`` steps in all
    (one line); a run that outlasts its timeout is a ``timeout`` result (a failed check).
    """
    from impactbench import matrix

    runs = list(runs)
    by_job = {_job(run): run for run in runs}
    results = matrix.run_jobs(list(by_job), workers=jobs, progress=progress,
                              **run_options)
    out = {by_job[r.job]: r.run for r in results}
    return {run: out[run] for run in runs}


# ----------------------------------------------------------------------------- judging


def _float(value: Any) -> float:
    try:
        return float(value)
    except (TypeError, ValueError):
        return math.nan


def judge(check_: Check, result: Mapping[str, Any],
          baseline: Mapping[str, Mapping[str, Any]] | None = None) -> Outcome:
    """Mark one check from its run's result and the baseline entry (if any)."""
    status = str(result.get("status", "crashed"))
    value = _float(result.get(check_.metric))
    reference = _float(result.get("reference", {}).get(check_.metric))
    err = (value - reference if check_.absolute
           else _float(result.get("rel_error", {}).get(check_.metric)))
    out = Outcome(check_, PASS, status, value=value, reference=reference,
                  rel_error=err, engine_version=str(result.get("engine_version", "")),
                  wall_s=_float(result.get("wall_s")), result=result)
    base = (baseline or {}).get(check_.id)
    base_err = _float(base.get("rel_error")) if base else math.nan
    out.baseline_rel_error = base_err if math.isfinite(base_err) else None
    if status in NOT_COMPARABLE_STATUSES:
        out.mark = NOT_COMPARABLE
        out.message = f"{status}: {result.get('message', '')}".strip(": ")
        return out
    base_passed = math.isfinite(base_err) and abs(base_err) <= check_.tolerance
    if status == "implausible":  # its error may be small: its contact is not usable
        out.mark = NEW_FAILURE if base_passed else FAIL
        out.message = str(result.get("message", "implausible"))
        return out
    if not (math.isfinite(err) and abs(err) <= check_.tolerance):
        out.mark = NEW_FAILURE if base_passed else FAIL
        what = "error" if check_.absolute else "rel error"
        out.message = (f"|{what}| {abs(err):.3g} > tolerance {check_.tolerance:g}"
                       if math.isfinite(err) else
                       f"no value (status {status}: {result.get('message', '')})")
        return out
    if math.isfinite(base_err):
        out.mark, out.message = drift(err, base_err, check_.margin, check_.floor,
                                      "error" if check_.absolute else "rel error")
    return out


def drift(err: float, base_err: float, margin: float, floor: float,
          what: str = "rel error") -> tuple[str, str]:
    """Mark a signed error against its baseline (module docstring): pass, better or worse."""
    band = margin * abs(base_err) + floor
    if abs(err - base_err) <= band:
        return PASS, ""
    if abs(err) <= abs(base_err) - band:
        return BETTER, f"{what} {err:+.3g} shrank from baseline {base_err:+.3g}"
    return WORSE, (f"{what} {err:+.3g} moved from baseline {base_err:+.3g} by "
                   f"{err - base_err:+.3g}, beyond ±{band:.3g} ({margin:g}·|base| + {floor:g})")


def evaluate(checks: Iterable[Check], baseline: Mapping[str, Mapping[str, Any]] | None = None,
             jobs: int | None = None, progress: Callable[[int], None] | None = None,
             **run_options: Any) -> list[Outcome]:
    """Plan, run (deduplicated, in parallel) and judge ``checks``, in their order."""
    checks = list(checks)
    results = execute(plan(checks), jobs=jobs, progress=progress, **run_options)
    return [judge(c, results[c.run], baseline) for c in checks]


def rejudge(outcomes: Iterable[Outcome],
            baseline: Mapping[str, Mapping[str, Any]] | None) -> list[Outcome]:
    """Judge the same measurements again against another baseline (no engine runs)."""
    return [judge(o.check, o.result, baseline) for o in outcomes]


def exit_code(outcomes: Iterable[Outcome], strict: bool = False) -> int:
    """0 when every check passes, 1 when any fails (``strict``: not-comparable fails too)."""
    for o in outcomes:
        if o.failed or (strict and o.mark == NOT_COMPARABLE):
            return 1
    return 0


# ----------------------------------------------------------------------------- baseline


def load_baseline(path: str | Path | None) -> dict[str, dict[str, Any]]:
    """Check id → measured entry; empty when ``path`` is None or does not exist."""
    if path is None or not Path(path).is_file():
        return {}
    try:
        data = json.loads(Path(path).read_text())
    except UnicodeDecodeError:
        raise ValueError(f"baseline {path}: not a baseline (not UTF-8 text; a file of "
                         "`impactbench gate --update-baseline`)") from None
    except json.JSONDecodeError as exc:
        raise ValueError(f"baseline {path}:{exc.lineno}: not valid JSON ({exc.msg})") from None
    if not isinstance(data, dict) or not isinstance(data.get("checks"), dict):
        raise ValueError(f"baseline {path}: checks: missing (expected {{\"checks\": {{…}}}})")
    for check_id, entry in data["checks"].items():
        # a NaN or missing baseline error would turn the regression check off for that check
        error = entry.get("rel_error") if isinstance(entry, dict) else None
        if isinstance(error, bool) or not isinstance(error, int | float) \
                or not math.isfinite(error):
            raise ValueError(f"baseline {path}: checks.{check_id}.rel_error = {error!r}: must "
                             "be a finite number (a measured error; a check without one is "
                             "left out of the baseline)")
    return data["checks"]


def updated_baseline(outcomes: Iterable[Outcome],
                     previous: Mapping[str, Mapping[str, Any]] | None = None,
                     ) -> dict[str, dict[str, Any]]:
    """The previous baseline with every measured check replaced by its new value.

    Checks that produced no number (not comparable, crashed) keep their previous entry, so a
    machine without an engine does not erase that engine's baseline.
    """
    out = {k: dict(v) for k, v in (previous or {}).items()}
    for o in outcomes:
        if o.mark == NOT_COMPARABLE or not math.isfinite(o.rel_error):
            continue
        out[o.check.id] = {"value": o.value, "reference": o.reference,
                           "rel_error": o.rel_error, "status": o.status,
                           "engine_version": o.engine_version}
    return dict(sorted(out.items()))


def save_baseline(path: str | Path, checks: Mapping[str, Mapping[str, Any]]) -> None:
    """Write the baseline JSON (sorted, stable across runs), atomically: a full disk or a
    read-only folder is a one-line ValueError and leaves the previous baseline intact."""
    from impactbench.publish import atomic_write

    atomic_write(Path(path), json.dumps({"format": 1, "checks": checks}, indent=1,
                                        sort_keys=True) + "\n", "baseline")


# ----------------------------------------------------------------------------- reports


def _fmt(value: float | None, spec: str = ".4g") -> str:
    if value is None or not math.isfinite(value):
        return "—"
    return format(value, spec)


def rows(outcomes: Iterable[Outcome]) -> list[dict[str, str]]:
    """One table row per check (strings, for the terminal table and the Markdown summary)."""
    return [{"mark": o.mark, "check": o.check.id, "value": _fmt(o.value),
             "reference": _fmt(o.reference), "rel_error": _fmt(o.rel_error, "+.3g"),
             "tolerance": _fmt(o.check.tolerance, "g"),
             "baseline": _fmt(o.baseline_rel_error, "+.3g"), "note": o.message}
            for o in outcomes]


def counts(outcomes: Iterable[Outcome]) -> dict[str, int]:
    out = dict.fromkeys(MARKS, 0)
    for o in outcomes:
        out[o.mark] += 1
    return out


def summary_line(outcomes: list[Outcome], strict: bool = False) -> str:
    c = counts(outcomes)
    verdict = "FAILED" if exit_code(outcomes, strict) else "OK"
    return (f"gates {verdict}: {len(outcomes)} checks, "
            + ", ".join(f"{n} {m}" for m, n in c.items() if n))


def format_table(outcomes: list[Outcome], fmt: str = "simple") -> str:
    from tabulate import tabulate

    table = rows(outcomes)
    return tabulate([list(r.values()) for r in table], headers=list(table[0]) if table else [],
                    tablefmt=fmt, disable_numparse=True)


def markdown_summary(outcomes: list[Outcome], strict: bool = False) -> str:
    """A GitHub step summary: the verdict, failing checks first, then all in a fold."""
    bad = [o for o in outcomes if o.failed or o.mark == NOT_COMPARABLE]
    parts = [f"### impactbench accuracy gates\n\n**{summary_line(outcomes, strict)}**\n"]
    if bad:
        parts.append(format_table(bad, "github") + "\n")
    parts.append("<details><summary>all checks</summary>\n\n"
                 + format_table(outcomes, "github") + "\n\n</details>\n")
    return "\n".join(parts)


def junit_xml(outcomes: list[Outcome], strict: bool = False,
              suite: str = "impactbench-gates") -> str:
    """JUnit XML: one testcase per check; failing marks are <failure>, not comparable is
    <skipped> (a <failure> under ``strict``)."""
    import xml.etree.ElementTree as ET

    c = counts(outcomes)
    n_fail = sum(c[m] for m in FAILING) + (c[NOT_COMPARABLE] if strict else 0)
    n_skip = 0 if strict else c[NOT_COMPARABLE]
    total = sum(o.wall_s for o in outcomes if math.isfinite(o.wall_s))
    root = ET.Element("testsuites")
    ts = ET.SubElement(root, "testsuite", name=suite, tests=str(len(outcomes)),
                       failures=str(n_fail), errors="0", skipped=str(n_skip),
                       time=f"{total:.3f}")
    for o, row in zip(outcomes, rows(outcomes), strict=True):
        tc = ET.SubElement(ts, "testcase", classname=f"{suite}.{o.check.run.engine}",
                           name=o.check.id,
                           time=f"{o.wall_s:.3f}" if math.isfinite(o.wall_s) else "0")
        text = ", ".join(f"{k}={v}" for k, v in row.items() if k != "check")
        if o.failed or (strict and o.mark == NOT_COMPARABLE):
            ET.SubElement(tc, "failure", message=f"{o.mark}: {o.message}", type=o.mark).text = text
        elif o.mark == NOT_COMPARABLE:
            ET.SubElement(tc, "skipped", message=o.message)
        ET.SubElement(tc, "system-out").text = text
    ET.indent(root)
    return '<?xml version="1.0" encoding="utf-8"?>\n' + ET.tostring(root, encoding="unicode")
