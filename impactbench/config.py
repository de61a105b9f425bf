"""The report configuration: a TOML file, validated into a frozen :class:`ReportConfig`.

Schema (every key optional except where noted; defaults in ``impactbench/data/default.toml``):

``[report]`` title (str), engines (list of engine names), modes (list of native, injected,
tuned); one table per scenario (its spec's ``table``, e.g. ``[ball_on_plate]``): each of its
axes as a list (``velocities_m_s`` in m/s > 0; categorical axes such as ``local`` and
``structure`` as lists of names, defaulting to the spec's), any field of its dataclass
(``mass_kg``, …), ``modes`` (the modes its runs take, default the report's) and
``[<table>.timestep_s]`` engine → s (default: each engine's step for the scenario);
``[work_precision]`` velocities_m_s (two or more; ``velocity_m_s`` for one), timesteps_s, modes
(the ball's study), and ``[work_precision.<table>]`` another scenario's at its axes' values
(e.g. ``[work_precision.oblique] angles_deg = [45.0]``; timesteps_s and modes default to the
parent's);
``[engines.<name>]`` the user's own engine parameters by the engine's names (the adapter's
``parameter_keys``, e.g. ``solref = [0.02, 1.0]``): each such engine gets a ``custom`` column;
``[tuned]`` engine → a tuned file written by ``impactbench tune --out`` (relative paths are
relative to the config file), used by ``tuned`` mode instead of the packaged one;
``[practical]`` the section "at practical timesteps": velocities_m_s, modes (default, native,
tuned, custom), ``[practical.timesteps_s]`` engine → list of its customary steps (s) and
``[practical.variants]`` engine → list of parameter tables, each run as ``custom`` and as
``tuned`` with the packaged file fitted with those settings (Drake's discrete approximations).
``[execution]`` scheduler (a Dask address), workers, store (a results-store path) — how to
run, not part of the config hash.

A scenario table may also name the ball's ``material`` (and ``plate_material``,
``youngs_modulus_pa``, ``poisson``): applied as ``--material`` is (mass, Hertz c and the
material's nominal restitution, from which the damping follows at each velocity; an explicit
``damping_s_per_m``, ``nominal_restitution``, ``mass_kg`` wins).

A user's file (:func:`load`) is layered over the packaged default: tables merge key by key, a
key the file sets replaces the default's value (lists are replaced, not appended). So
``[report] engines = ["mujoco"]`` alone is the default report for MuJoCo only. To drop a
default section, empty it: ``[ball_on_plate] velocities_m_s = []``, ``[rigid_flexible]
velocities_m_s = []`` (an empty velocity list drops that scenario), ``[work_precision]
timesteps_s = []``, ``[practical] velocities_m_s = []``, ``[cube_toss] engines = []``.
:func:`parse` of a dict does not layer: the dict is the whole config.

A bad file raises ValueError with one line naming the key (``rigid_flexible.velocities_m_s``),
the value and the rule. The work-precision and practical studies run the first scenario whose
spec lists them in ``studies``.
"""

from __future__ import annotations

import hashlib
import json
import math
import tomllib
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from impactbench import scenarios
from impactbench.engines.registry import MODES, engine_names
from impactbench.plausibility import Limits

DEFAULT_CONFIG = Path(__file__).parent / "data" / "default.toml"


@dataclass(frozen=True)
class ScenarioMatrix:
    """One scenario's part of the matrix: the values of each axis (their product are the
    points), the engines' steps and the scenario fields set."""

    name: str
    axes: tuple[tuple[str, tuple[Any, ...]], ...]
    timestep_s: dict[str, float]
    parameters: dict[str, Any]
    modes: tuple[str, ...] = ()
    """The modes its runs take (the table's ``modes``); () takes the report's."""

    def values(self, axis: str) -> tuple[Any, ...]:
        """The configured values of one axis (() when the scenario has no such axis)."""
        return dict(self.axes).get(axis, ())

    @property
    def velocities_m_s(self) -> tuple[float, ...]:
        return self.values("velocity_m_s")

    def points(self) -> list[scenarios.Point]:
        """Every point: the product of the axes' values, in axis order."""
        import itertools

        names = [a for a, _ in self.axes]
        return [tuple(zip(names, combo, strict=True))
                for combo in itertools.product(*(v for _, v in self.axes))]


REPLAY_MODES = ("default", "custom", "tuned", "native", "injected")
"""The modes a data-driven scenario's table runs unless it names its own (``modes``)."""


@dataclass(frozen=True)
class WorkPrecision:
    """A work–precision study: error against wall time over ``timesteps_s``, per mode. The
    ``[work_precision]`` table's is the ball's at ``velocities_m_s``; a sub-table
    ``[work_precision.<scenario table>]`` studies that scenario (``scenario``) at ``points``
    (its axes' values, e.g. the oblique impact at 45°)."""

    velocities_m_s: tuple[float, ...]
    timesteps_s: tuple[float, ...]
    modes: tuple[str, ...]
    scenario: str = ""
    points: tuple[scenarios.Point, ...] = ()

    @property
    def velocity_m_s(self) -> float:
        return self.velocities_m_s[0]


Params = tuple[tuple[str, Any], ...]
"""Engine parameters as a sorted, hashable tuple of (key, value) (lists become tuples)."""


@dataclass(frozen=True)
class Practical:
    """The "at practical timesteps" section: each engine at its customary steps."""

    velocities_m_s: tuple[float, ...]
    modes: tuple[str, ...]
    timesteps_s: dict[str, tuple[float, ...]]
    variants: dict[str, tuple[Params, ...]]
    advice: bool = True
    """Run the packaged advice for each engine and step (:mod:`impactbench.advice_files`)."""


@dataclass(frozen=True)
class ReportConfig:
    title: str
    engines: tuple[str, ...]
    modes: tuple[str, ...]
    scenarios: tuple[ScenarioMatrix, ...]
    work_precision: WorkPrecision | None
    engine_params: dict[str, Params] = field(default_factory=dict)
    tuned_files: dict[str, str] = field(default_factory=dict)
    practical: Practical | None = None
    work_precision_more: tuple[WorkPrecision, ...] = ()
    """``[work_precision.<table>]``: the other scenarios' work–precision studies."""
    limits: Limits = field(default_factory=Limits)
    """``[plausibility]``: the limits runs are judged by (:mod:`impactbench.plausibility`)."""
    source: str = field(default="", compare=False)
    raw: dict[str, Any] = field(default_factory=dict, compare=False)
    execution: dict[str, Any] = field(default_factory=dict, compare=False)
    """``[execution]``: scheduler (Dask address), workers, store (path); not in the hash."""

    @property
    def hash(self) -> str:
        """Short hash of the validated content (what produced the results)."""
        content = {k: v for k, v in self.raw.items() if k != "execution"}
        blob = json.dumps(content, sort_keys=True, default=str).encode()
        return hashlib.sha256(blob).hexdigest()[:12]


def _fail(key: str, value: Any, rule: str) -> ValueError:
    return ValueError(f"{key} = {value!r}: {rule}")


def did_you_mean(key: str, valid: Iterable[str]) -> str:
    """`` (did you mean 'solimp'?)`` for the valid name closest to ``key``; '' when none is
    close (difflib's ratio ≥ 0.6)."""
    import difflib

    hint = difflib.get_close_matches(str(key), sorted(valid), n=1)
    return f" (did you mean {hint[0]!r}?)" if hint else ""


def _check_keys(table: dict[str, Any], allowed: set[str], prefix: str) -> None:
    for key in table:
        if key not in allowed:
            raise ValueError(f"{prefix}{key}: unknown key{did_you_mean(key, allowed)}; "
                             f"allowed: {', '.join(sorted(allowed))}")


def _positive_list(key: str, value: Any, zero: bool = False) -> tuple[float, ...]:
    """A list of finite numbers > 0 (>= 0 with ``zero``)."""
    if not isinstance(value, list):
        raise _fail(key, value, "must be a list of numbers")
    for v in value:
        if isinstance(v, bool) or not isinstance(v, int | float):
            raise _fail(key, value, "must be a list of numbers")
        if not (math.isfinite(v) and (v >= 0 if zero else v > 0)):
            raise _fail(key, v, f"must be {'>=' if zero else '>'} 0 and finite")
    return tuple(float(v) for v in value)


def _names(key: str, value: Any, allowed: tuple[str, ...]) -> tuple[str, ...]:
    if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
        raise _fail(key, value, "must be a list of strings")
    for v in value:
        if v not in allowed:
            raise _fail(key, v, f"must be one of {', '.join(allowed)}")
    return tuple(value)


def _timesteps(key: str, value: Any, engines: tuple[str, ...]) -> dict[str, float]:
    if not isinstance(value, dict):
        raise _fail(key, value, "must be a table of engine = seconds")
    _check_keys(value, set(engine_names()), f"{key}.")
    out = {}
    for engine, dt in value.items():
        out[engine] = _positive_list(f"{key}.{engine}", [dt])[0]
    return out


def _scenario(spec: scenarios.ScenarioSpec, table: dict[str, Any],
              engines: tuple[str, ...]) -> ScenarioMatrix | None:
    from impactbench.scenario_file import apply_options, option_keys

    name = spec.table
    fields = set(spec.cls.field_names()) - set(spec.axis_names)
    if spec.measured:
        # A data-driven scenario (its spec's ``measured``): its fields, and the runs of the
        # report's "Against real tosses" section: ``engines`` (default the report's),
        # ``modes`` (default :data:`REPLAY_MODES`), ``model`` (the reference model's row,
        # default true), ``trajectories`` (best: the measured-vs-simulated figure of each
        # engine's lowest-median run; all: of every run) and ``param_sets`` (custom mode's
        # published parameter sets, default none; each must belong to one of the engines).
        # Paths (``data``) are relative to the working directory. The matrix gets no points of
        # it (one empty axis): its runs are the section's, not the builders'.
        _check_keys(table, fields | {"engines", "modes", "param_sets", "model", "trajectories"},
                    f"{name}.")
        if table.get("trajectories", "best") not in ("best", "all"):
            raise _fail(f"{name}.trajectories", table["trajectories"], "must be best (each "
                        "engine's lowest median) or all (every engine and mode)")
        if not isinstance(table.get("model", True), bool):
            raise _fail(f"{name}.model", table["model"], "must be true or false (the "
                        "reference model's row)")
        params = {k: table[k] for k in sorted(fields) if k in table}
        try:
            scenario = spec.cls(**params)
        except ValueError as exc:
            raise ValueError(f"{name}.{exc}") from None
        except TypeError as exc:
            raise ValueError(f"{name}: {exc}") from None
        own = _names(f"{name}.engines", table.get("engines", list(engines)), engine_names())
        if "engines" in table and not own:
            return None  # ``engines = []``: the section dropped (the model's row with it)
        _names(f"{name}.modes", table.get("modes", list(REPLAY_MODES)), MODES)
        for set_name in _names(f"{name}.param_sets", table.get("param_sets", []),
                               tuple(map(str, table.get("param_sets", [])))):
            errors = []
            for engine in own:
                try:
                    scenario.engine_parameters(engine, "custom", {"param_set": set_name}, None)
                    break  # an engine that has it
                except ValueError as exc:
                    errors.append(str(exc))
            else:
                raise ValueError(f"{name}.param_sets: " + (errors[0] if errors else
                                 f"{set_name!r}: none of {', '.join(own)} replays it"))
        return ScenarioMatrix(spec.name, (("velocity_m_s", ()),), {}, params)
    options = set(option_keys(spec))  # the ball's material, plate_material, E, ν
    allowed = {"timestep_s", "modes"} | fields | options | {a.config_key for a in spec.axes}
    _check_keys(table, allowed, f"{name}.")
    modes = _names(f"{name}.modes", table["modes"], MODES) if "modes" in table else ()
    params = {k: table[k] for k in sorted(fields | options) if k in table}
    try:
        # a material is applied as --material is (mass, c, nominal restitution)
        params = apply_options(spec, params)
        spec.cls(**params)  # validates values (one line naming the field)
    except ValueError as exc:
        raise ValueError(f"{name}.{exc}") from None
    except TypeError as exc:
        raise ValueError(f"{name}: {exc}") from None
    axes = []
    for a in spec.axes:
        key = f"{name}.{a.config_key}"
        if a.categorical:
            axes.append((a.name, _names(key, table.get(a.config_key, list(a.defaults())),
                                        a.allowed())))
        else:
            axes.append((a.name, _positive_list(key, table.get(a.config_key, []), a.zero)))
    return ScenarioMatrix(
        name=spec.name,
        axes=tuple(axes),
        timestep_s=_timesteps(f"{name}.timestep_s", table.get("timestep_s", {}), engines),
        parameters=params,
        modes=modes,
    )


def frozen_params(params: dict[str, Any]) -> Params:
    """Engine parameters as a sorted tuple, lists as tuples (hashable, deterministic)."""
    def freeze(v: Any) -> Any:
        return tuple(freeze(x) for x in v) if isinstance(v, list | tuple) else v

    return tuple(sorted((k, freeze(v)) for k, v in params.items()))


def thawed(params: Params) -> dict[str, Any]:
    """The inverse of :func:`frozen_params` (tuples back to lists)."""
    def thaw(v: Any) -> Any:
        return [thaw(x) for x in v] if isinstance(v, tuple) else v

    return {k: thaw(v) for k, v in params}


def _engine_params(key: str, engine: str, table: Any) -> Params:
    """A table of the engine's own parameters, keys checked against the adapter's."""
    from impactbench.engines.base import parameter_keys

    if not isinstance(table, dict):
        raise _fail(key, table, "must be a table of the engine's parameters")
    valid = parameter_keys(engine)
    for k in table:
        if k not in valid:
            raise ValueError(f"{key}.{k}: not a {engine} parameter; valid keys: "
                             f"{', '.join(valid) or '(none)'}{did_you_mean(k, valid)}")
    check_values(key, engine, table)
    return frozen_params(table)


def check_values(key: str, engine: str, table: dict[str, Any]) -> None:
    """The values of ``engine``'s parameters, by the adapter's own parser, before any run
    (``solref = "banana"`` is a one-line error naming the table, not a report of crashed
    rows). The parser is the adapter class's (:func:`impactbench.engines.base.check_params`):
    reading a config imports no engine (importing pydrake was 0.2 s of the 0.7 s the default
    config took to load)."""
    from impactbench.engines.base import check_params

    try:
        check_params(engine, dict(table))
    except ValueError as exc:
        raise ValueError(f"{key}: {exc}") from None


def _practical(t: dict[str, Any]) -> Practical | None:
    _check_keys(t, {"velocities_m_s", "modes", "timesteps_s", "variants", "advice"},
                "practical.")
    advice = t.get("advice", True)
    if not isinstance(advice, bool):
        raise _fail("practical.advice", advice, "must be true or false")
    velocities = _positive_list("practical.velocities_m_s", t.get("velocities_m_s", []))
    steps = t.get("timesteps_s", {})
    if not isinstance(steps, dict):
        raise _fail("practical.timesteps_s", steps, "must be a table of engine = [seconds]")
    _check_keys(steps, set(engine_names()), "practical.timesteps_s.")
    timesteps = {e: _positive_list(f"practical.timesteps_s.{e}", v if isinstance(v, list)
                                   else [v]) for e, v in steps.items()}
    variants_t = t.get("variants", {})
    if not isinstance(variants_t, dict):
        raise _fail("practical.variants", variants_t, "must be a table of engine = [tables]")
    _check_keys(variants_t, set(engine_names()), "practical.variants.")
    variants = {}
    for e, lst in variants_t.items():
        if not isinstance(lst, list):
            raise _fail(f"practical.variants.{e}", lst, "must be a list of tables")
        variants[e] = tuple(_engine_params(f"practical.variants.{e}[{i}]", e, v)
                            for i, v in enumerate(lst))
    if not (velocities and timesteps):
        return None
    modes = _names("practical.modes", t.get("modes", ["default", "native", "tuned"]),
                   ("default", "native", "tuned", "custom", "injected"))
    return Practical(velocities, modes, timesteps, variants, advice)


def parse(data: dict[str, Any], source: str = "") -> ReportConfig:
    """Validate a parsed TOML document into a :class:`ReportConfig`."""
    tables = {s.table: s for s in scenarios.specs()}
    _check_keys(data, {"report", *tables, "work_precision", "engines", "tuned", "practical",
                       "plausibility", "execution"}, "")
    for key, value in data.items():
        if not isinstance(value, dict):
            raise _fail(key, value, "must be a table")
    report = data.get("report", {})
    _check_keys(report, {"title", "engines", "modes"}, "report.")
    title = report.get("title", "impactbench report")
    if not isinstance(title, str):
        raise _fail("report.title", title, "must be a string")
    engines = _names("report.engines", report.get("engines", list(engine_names())),
                     engine_names())
    modes = _names("report.modes", report.get("modes", list(MODES)), MODES)
    matrices = tuple(m for name, spec in tables.items() if name in data
                     if (m := _scenario(spec, data[name], engines)) is not None)
    wp = None
    wp_more: tuple[WorkPrecision, ...] = ()
    if "work_precision" in data:
        t = data["work_precision"]
        subs = {k: v for k, v in t.items() if isinstance(v, dict)}
        _check_keys(t, {"velocity_m_s", "velocities_m_s", "timesteps_s", "modes"}
                    | {spec.table for spec in scenarios.specs() if spec.axes
                       and not spec.measured and "work_precision" not in spec.studies},
                    "work_precision.")
        wp_more = tuple(w for name, sub in subs.items()
                        if (w := _work_precision_of(name, sub, t, data)) is not None)
        timesteps = _positive_list("work_precision.timesteps_s", t.get("timesteps_s", []))
        if "velocities_m_s" in t:
            velocities = _positive_list("work_precision.velocities_m_s", t["velocities_m_s"])
        else:
            velocities = _positive_list("work_precision.velocity_m_s",
                                        [t.get("velocity_m_s", 1.0)])
        if timesteps and velocities:
            wp = WorkPrecision(
                velocities_m_s=velocities,
                timesteps_s=timesteps,
                modes=_names("work_precision.modes", t.get("modes", ["native", "injected"]),
                             ("native", "injected", "default")),
            )
    eng = data.get("engines", {})
    _check_keys(eng, set(engine_names()), "engines.")
    engine_params = {e: _engine_params(f"engines.{e}", e, table) for e, table in eng.items()}
    tuned = data.get("tuned", {})
    _check_keys(tuned, set(engine_names()), "tuned.")
    base = Path(source).parent if source and not source.startswith("impactbench/") else Path()
    tuned_files = {}
    for e, path in tuned.items():
        if not isinstance(path, str):
            raise _fail(f"tuned.{e}", path, "must be a path to a tuned file")
        full = (base / path) if not Path(path).is_absolute() else Path(path)
        if not full.is_file():
            raise _fail(f"tuned.{e}", path, "no such file (write one with impactbench tune "
                        "--out)")
        tuned_files[e] = str(full)
    practical = _practical(data["practical"]) if "practical" in data else None
    return ReportConfig(title, engines, modes, matrices, wp, engine_params, tuned_files,
                        practical, work_precision_more=wp_more,
                        limits=_limits(data.get("plausibility", {})),
                        source=source, raw=data,
                        execution=_execution(data.get("execution", {})))


def _work_precision_of(table_name: str, sub: dict[str, Any], parent: dict[str, Any],
                       data: dict[str, Any]) -> WorkPrecision | None:
    """``[work_precision.<table>]``: that scenario's work–precision study. Keys: its axes
    (lists, e.g. ``angles_deg``; an axis it omits takes the scenario table's values, then the
    axis's defaults), ``timesteps_s`` and ``modes`` (default the ``[work_precision]`` ones).
    None when a list is empty (the study dropped)."""
    import itertools

    spec = next(sp for sp in scenarios.specs() if sp.table == table_name)
    where = f"work_precision.{table_name}."
    _check_keys(sub, {a.config_key for a in spec.axes} | {"timesteps_s", "modes"}, where)
    timesteps = _positive_list(where + "timesteps_s",
                               sub.get("timesteps_s", parent.get("timesteps_s", [])))
    modes = _names(where + "modes", sub.get("modes", parent.get("modes",
                                                              ["native", "injected"])),
                   ("native", "injected", "default"))
    own = data.get(table_name, {})
    axes = []
    for a in spec.axes:
        values = sub.get(a.config_key, own.get(a.config_key))
        if a.categorical:
            axes.append(_names(where + a.config_key,
                               list(a.defaults()) if values is None else values, a.allowed()))
        else:
            axes.append(_positive_list(where + a.config_key, values or [], a.zero))
    points = tuple(tuple(zip(spec.axis_names, combo, strict=True))
                   for combo in itertools.product(*axes))
    if not (timesteps and points):
        return None
    velocities = sorted({v for p in points if (v := dict(p).get("velocity_m_s")) is not None})
    return WorkPrecision(velocities_m_s=tuple(velocities), timesteps_s=timesteps, modes=modes,
                         scenario=spec.name, points=points)


def _limits(table: dict[str, Any]) -> Limits:
    """``[plausibility]``: max_penetration_ratio, max_energy_ratio (:mod:`impactbench.
    plausibility`; the defaults where absent)."""
    fields = ("max_penetration_ratio", "max_energy_ratio")
    _check_keys(table, set(fields), "plausibility.")
    for key, value in table.items():
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise _fail(f"plausibility.{key}", value, "must be a number")
    try:
        return Limits(**{k: float(v) for k, v in table.items()})
    except ValueError as exc:
        raise ValueError(f"plausibility.{exc}") from None


def _execution(table: dict[str, Any]) -> dict[str, Any]:
    """Validate ``[execution]``: scheduler (str address), workers (int ≥ 0; 0: in this
    process), store (path), timeout_s (seconds > 0 per engine run)."""
    _check_keys(table, {"scheduler", "workers", "store", "timeout_s"}, "execution.")
    for key in ("scheduler", "store"):
        if key in table and not (isinstance(table[key], str) and table[key]):
            raise _fail(f"execution.{key}", table[key], "must be a non-empty string")
    workers = table.get("workers")
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, int)
                                or workers < 0):
        raise _fail("execution.workers", workers,
                    "must be an integer >= 0 (0: in this process)")
    timeout = table.get("timeout_s")
    if timeout is not None and (isinstance(timeout, bool) or not isinstance(timeout, int | float)
                                or not math.isfinite(timeout) or timeout <= 0):
        raise _fail("execution.timeout_s", timeout, "must be a number of seconds > 0")
    return dict(table)


def layered(base: dict[str, Any], over: dict[str, Any]) -> dict[str, Any]:
    """``over`` deep-merged over ``base`` (new dicts; neither is changed): tables merge key by
    key, any other value ``over`` sets (a number, a string, a list) replaces ``base``'s."""
    out = dict(base)
    for key, value in over.items():
        if isinstance(value, dict) and isinstance(out.get(key), dict):
            out[key] = layered(out[key], value)
        else:
            out[key] = value
    return out


def _read(path: Path) -> dict[str, Any]:
    try:
        text = path.read_text()
    except OSError as exc:
        raise ValueError(f"config {str(path)!r}: cannot read ({exc.strerror})") from None
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ValueError(f"config {str(path)!r}: not valid TOML ({exc})") from None


def load(path: str | Path | None = None) -> ReportConfig:
    """Read and validate a config file layered over the packaged default (the default alone
    when ``path`` is None): see :func:`layered` and the module docstring. :func:`parse` of a
    dict does not layer (the dict is the whole config)."""
    default = _read(DEFAULT_CONFIG)
    if path is None or Path(path) == DEFAULT_CONFIG:
        return parse(default, source="impactbench/data/default.toml (packaged)")
    path = Path(path)
    mine = _read(path)
    for table, (one, many) in ALIASES.items():
        # the user's one value replaces the default's list given under the other name
        if isinstance(mine.get(table), dict) and one in mine[table] \
                and many not in mine[table] and isinstance(default.get(table), dict):
            default[table] = {k: v for k, v in default[table].items() if k != many}
    return parse(layered(default, mine), source=str(path))


ALIASES: dict[str, tuple[str, str]] = {"work_precision": ("velocity_m_s", "velocities_m_s")}
"""Table → (key, key): two spellings of one setting, the second winning in :func:`parse`."""
