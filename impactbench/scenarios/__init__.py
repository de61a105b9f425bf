"""Scenarios as specs: one :class:`ScenarioSpec` per physical set-up, held in one registry.

A scenario is one module that defines ``SPEC`` (the shape of dm_control's suite and of
Gymnasium's ``EnvSpec``): its physical dataclass and validation, its reference solver, its
metrics (which are headline), its point axes (what one run varies: an impact velocity, a
law pair), its CLI flags and config table, its report labels and plots, its gate defaults.
Every command, the store, the report, the gates and the pytest plugin loop over
:func:`specs`; none of them names a scenario. Engines opt in per scenario with a builder
(:class:`impactbench.engines.base.Builder`).

The packaged scenarios are listed in :data:`BUILTIN` as ``"module:attr"`` strings and imported
on first use. A third-party package adds its own through the entry-point group
``impactbench.scenarios`` (as pytest's ``pytest11`` and Gymnasium's ``gymnasium.envs``)::

    [project.entry-points."impactbench.scenarios"]
    sphere-on-sphere = "my_package.scenario:SPEC"

The scenario's dataclass carries ``name`` (a class attribute, the key adapters find their
builder under) and may carry ``engine_builders`` (engine → builder) for engines whose adapters
do not know it. ``examples/plugin-sphere-on-sphere/`` in the repository is a complete one.

Names used across the suite (so that each means one thing):

- *scenario fields* — the physical parameters of a scenario's dataclass (SI, ``mass_kg``);
- *point* — the values of a scenario's axes for one run, ``(("velocity_m_s", 2.0),)``;
- *engine parameters* — an engine's own settings by its own names (``solref``), set in
  ``custom`` mode (``params``) or fitted in ``tuned`` mode (``tuned``);
- *CLI flags* — the command-line spelling of scenario fields (``--mass``), from the spec.
"""

from __future__ import annotations

import difflib
import importlib
import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from functools import cache
from typing import Any

ENTRY_POINT_GROUP = "impactbench.scenarios"

BUILTIN: dict[str, str] = {
    "ball-on-plate": "impactbench.scenarios.ball_on_plate:SPEC",
    "rigid-flexible": "impactbench.scenarios.rigid_flexible:SPEC",
    "oblique": "impactbench.scenarios.oblique:SPEC",
    "cube-toss": "impactbench.scenarios.cube_toss:SPEC",
}
"""The packaged scenarios, in the report's order (registry name → ``"module:attr"``)."""

Point = tuple[tuple[str, Any], ...]
"""The values of a scenario's axes for one run, in the spec's axis order."""


def load(target: str) -> Any:
    """The object named by ``"module:attr"`` (imported now)."""
    module, _, attr = target.partition(":")
    obj: Any = importlib.import_module(module)
    for part in attr.split("."):
        obj = getattr(obj, part)
    return obj


@dataclass(frozen=True)
class Axis:
    """One coordinate of a scenario's points.

    Attributes:
        name: the scenario field it sets (``velocity_m_s``, ``local``).
        config_key: its key in the scenario's config table (a list of values).
        column: the header of its column in report tables (``V0 (m/s)``).
        choices: for a categorical axis, ``"module:attr"`` of the mapping whose keys are the
            allowed values; "" for a numeric axis (values > 0, SI).
        default: ``"module:attr"`` of the values a config table that omits the key gets
            (categorical axes); "" for none (a numeric axis then needs the key).
        short: the prefix of a numeric value in run ids and gate labels (``v`` → ``v2``).
        zero: a numeric axis that may be 0 (an incidence angle); else its values are > 0.
    """

    name: str
    config_key: str
    column: str
    choices: str = ""
    default: str = ""
    short: str = ""
    zero: bool = False

    @property
    def categorical(self) -> bool:
        return bool(self.choices)

    def allowed(self) -> tuple[str, ...]:
        """The allowed values of a categorical axis."""
        return tuple(load(self.choices)) if self.choices else ()

    def defaults(self) -> tuple[Any, ...]:
        return tuple(load(self.default)) if self.default else ()


@dataclass(frozen=True)
class Flag:
    """A command-line flag that sets one scenario field (``--mass`` → ``mass_kg``)."""

    flag: str
    field: str
    help: str


@dataclass(frozen=True)
class ScenarioSpec:
    """Everything the suite needs to run, compare, report and gate one scenario.

    Attributes:
        name: registry name (``--scenario``, results' ``scenario`` column).
        title: its heading in reports (``Ball on plate``).
        summary: one line for ``--help`` and the report's section intro.
        scenario: ``"module:Class"`` of its frozen dataclass (with a ``name`` class attribute
            equal to ``name``; validated in ``__post_init__``).
        reference: ``"module:function"``: scenario → the reference object (the metrics, the
            same keys as ``impactbench reference NAME --json``).
        reference_history: ``"module:function"``: scenario → the reference's
            :class:`~impactbench.reference.record.ImpactRecord` (for force plots).
        metrics: every metric of its results rows, in table order.
        headline: the metrics of its tables, heatmaps and scoreboard.
        axes: its point axes, in the order of run ids and tables.
        table: its config table (``[ball_on_plate]``).
        flags: its CLI flags for ``run``/``tune``/``reference``.
        gate_velocities_m_s: the impact velocities of a gate that names none.
        native: what ``native`` mode maps, per engine ("" for every other engine).
        history_unit: (seconds per unit, unit label) of its force–time plots.
        figure_stem: file-name stem of its per-point figures (``ball``).
        velocity_symbol: the symbol of its impact velocity in captions (``V0``).
        commands: a module with ``register(top, groups)`` adding its own subcommands
            (``reference NAME``, ``sweep NAME``); "" for none.
        reference_problem: ``"module:function"`` (scenario, reference object) → why the
            reference itself is outside its model ("" when it is not): such a run is
            ``unsupported``; "" when no such limit exists.
        report_figures: ``"module:function"`` (ctx, spec, runs) drawing its extra report
            figures; "" for none.
        options: ``"module:function"`` adding its further flags (``--model``, ``--gravity``)
            to an argument group, ``f(group, with_gravity)``; "" for none.
        from_args: ``"module:function"`` (parsed args, field values) → field values: turns
            its further flags (a material, a scenario file) into fields; "" for none.
        record_metrics: ``"module:function"`` (record, scenario) → its metrics from an
            engine's record, where the one shared path
            (:func:`impactbench.reference.metrics.compute`) does not give them all (the
            oblique impact's tangential metrics); "" for that path.
        plausibility: ``"module:function"`` (scenario, record, metrics) → its plausibility
            measures, ``penetration_ratio`` and ``energy_ratio`` (NaN where a measure does not
            apply; :mod:`impactbench.plausibility`); "" for none.
        descriptions: what each field means (SI units), for the report's parameter table,
            where no flag's help says it.
        studies: the suite's single-scenario studies it serves (``work_precision``,
            ``practical``, ``tuning``, ``calibrate``): each runs the first scenario that lists
            it (:func:`for_study`).
        default_mode: the mode ``run`` takes without ``--mode`` (``native``; the cube
            tosses': ``default``, the engines as they come against the measurement).
        details: ``"module:function"`` (record, scenario, mode) → what a run object carries
            besides the metrics (the cube tosses' per-toss rows, split, protocol); "" for
            nothing.
        errors: ``"module:function"`` (run object, metrics) → the errors tables and gates read,
            for a scenario whose metrics are already errors against a measurement (the cube
            tosses: the metric itself); "" for relative errors against the reference.
        key_inputs: ``"module:function"`` (scenario, mode) → what a run's store key holds
            beside its settings (a data file's SHA-256); "" for nothing.
        with_timestep: ``"module:function"`` (scenario, timestep_s or None) → (the scenario
            the step maps to, where the step comes from), for a scenario whose step is one of
            its own fields (the cube tosses' substeps); "" when the step is the run's.
        tuned_settings: ``"module:function"`` (engine, scenario, tuned file or None) →
            (parameters, provenance) of its tuned files where they differ from the suite's
            (:func:`impactbench.tuned.load_tuned_settings`); provenance's ``mismatch`` says
            why a file does not apply; "" for the suite's.
    """

    name: str
    title: str
    summary: str
    scenario: str
    reference: str
    reference_history: str
    metrics: tuple[str, ...]
    headline: tuple[str, ...]
    axes: tuple[Axis, ...]
    table: str
    flags: tuple[Flag, ...] = ()
    gate_velocities_m_s: tuple[float, ...] = (1.0,)
    native: Mapping[str, str] = field(default_factory=dict)
    history_unit: tuple[float, str] = (1e-6, "µs")
    figure_stem: str = ""
    velocity_symbol: str = "v"
    commands: str = ""
    reference_problem: str = ""
    report_figures: str = ""
    options: str = ""
    from_args: str = ""
    record_metrics: str = ""
    plausibility: str = ""
    descriptions: Mapping[str, str] = field(default_factory=dict)
    studies: tuple[str, ...] = ()
    default_mode: str = "native"
    details: str = ""
    errors: str = ""
    key_inputs: str = ""
    with_timestep: str = ""
    tuned_settings: str = ""

    # ------------------------------------------------------------------ the dataclass
    @property
    def cls(self) -> type:
        """The scenario's dataclass (imported on first use)."""
        return load(self.scenario)

    def build(self, point: Point | Mapping[str, Any] = (), parameters: Iterable = ()) -> Any:
        """The scenario at ``point`` with these fields (``(name, value)`` pairs or a mapping)
        over its defaults; validated (ValueError naming the field)."""
        return self.cls(**dict(parameters), **dict(point))

    def point_of(self, scenario: Any) -> Point:
        """The point of a scenario object (its axes' values)."""
        return tuple((a.name, getattr(scenario, a.name)) for a in self.axes)

    @property
    def measured(self) -> bool:
        """A data-driven scenario: its reference is a measurement and a run replays all its
        recorded trials at once (no axes: one point, ``()``), scored by its own ``errors``."""
        return not self.axes and bool(self.errors)

    @property
    def axis_names(self) -> tuple[str, ...]:
        return tuple(a.name for a in self.axes)

    # ------------------------------------------------------------------ the reference
    def reference_metrics(self, scenario: Any) -> dict[str, Any]:
        """The reference object of ``scenario`` (same keys as ``reference NAME --json``)."""
        return load(self.reference)(scenario)

    def history(self, scenario: Any) -> Any:
        """The reference's time history of ``scenario`` (an ImpactRecord)."""
        return load(self.reference_history)(scenario)

    def metrics_of(self, record: Any, scenario: Any) -> dict[str, Any]:
        """The metrics of a record: the spec's own function, else the shared path."""
        if self.record_metrics:
            return dict(load(self.record_metrics)(record, scenario))
        from impactbench.reference import metrics

        return metrics.compute(record)

    def measure(self, scenario: Any, record: Any, metrics: Mapping[str, Any]) -> dict:
        """The plausibility measures of one run ({} when the spec has none)."""
        return dict(load(self.plausibility)(scenario, record, metrics)) if self.plausibility \
            else {}

    def run_details(self, record: Any, scenario: Any, mode: str) -> dict[str, Any]:
        """What a run object carries besides the metrics ({} when the spec adds nothing)."""
        return dict(load(self.details)(record, scenario, mode)) if self.details else {}

    def run_errors(self, run: Mapping[str, Any], metrics: Mapping[str, Any],
                   reference: Mapping[str, Any], resolved: Mapping[str, bool]
                   ) -> dict[str, float]:
        """The errors of a run's metrics: relative to the reference (an unresolved metric is
        reported, never compared: NaN), or the spec's own (errors against a measurement)."""
        if self.errors:
            return dict(load(self.errors)(run, metrics))
        from impactbench.reference.metrics import relative_error

        return {k: (relative_error(float(metrics[k]), float(reference[k])) if resolved[k]
                    else math.nan) for k in metrics}

    def store_inputs(self, scenario: Any, mode: str) -> dict[str, Any]:
        """What a run's store key holds beside its settings ({} for nothing)."""
        return dict(load(self.key_inputs)(scenario, mode)) if self.key_inputs else {}

    def at_timestep(self, scenario: Any, timestep_s: float | None) -> tuple[Any, str]:
        """(the scenario a step maps to, where the step comes from; "" when the step stays
        the run's own)."""
        return load(self.with_timestep)(scenario, timestep_s) if self.with_timestep \
            else (scenario, "")

    def problem(self, scenario: Any, reference: Mapping[str, Any]) -> str:
        """Why the reference of ``scenario`` is outside its model ("" when it is not)."""
        return load(self.reference_problem)(scenario, reference) if self.reference_problem \
            else ""

    # ------------------------------------------------------------------ labels
    def point_id(self, point: Point) -> str:
        """The point's part of a run id (sortable: numbers zero-padded),
        ``/linear/linear/v0002.0000``."""
        values = dict(point)
        return "".join(f"/{values[a.name]}" if a.categorical
                       else f"/{a.short}{float(values[a.name]):09.4f}" for a in self.axes)

    def point_label(self, point: Point) -> str:
        """The point's part of a gate label: categorical values, then numbers ``-v2``."""
        values = dict(point)
        return "".join(f"-{values[a.name]}" for a in self.axes if a.categorical)

    def numeric_label(self, point: Point) -> str:
        values = dict(point)
        return "".join(f"-{a.short}{float(values[a.name]):g}" for a in self.axes
                       if not a.categorical)

    def point_text(self, point: Point | Mapping[str, Any]) -> str:
        """``V0 = 1 m/s`` or ``elastoplastic/linear, v1 = 2 m/s`` (tables and captions)."""
        values = dict(point)
        cats = "/".join(str(values[a.name]) for a in self.axes if a.categorical)
        nums = ", ".join(self._number_text(a, values[a.name]) for a in self.axes
                         if not a.categorical)
        return f"{cats}, {nums}" if cats else nums

    def _number_text(self, axis: Axis, value: Any) -> str:
        """``V0 = 2 m/s`` (the impact velocity, by the spec's symbol) or, for another axis,
        from its column ``θ (°)``: ``θ = 45°``."""
        if axis.name == "velocity_m_s":
            return f"{self.velocity_symbol} = {float(value):g} m/s"
        symbol, _, unit = axis.column.partition(" (")
        unit = unit.rstrip(")")
        gap = "" if unit in ("°", "%") else " "
        return f"{symbol} = {float(value):g}{gap + unit if unit else ''}"

    def figure_name(self, point: Point) -> str:
        """The file-name part of a per-point figure: ``ball_v2`` or ``rf_linear_linear_v2``."""
        values = dict(point)
        parts = [str(values[a.name]) for a in self.axes if a.categorical]
        parts += [f"{a.short}{float(values[a.name]):g}" for a in self.axes
                  if not a.categorical]
        return "_".join([self.figure_stem or self.name.replace("-", "_"), *parts])


# ------------------------------------------------------------------------------ registry


@cache
def _plugins() -> dict[str, str]:
    """Scenario plug-ins installed through the ``impactbench.scenarios`` entry points."""
    from importlib import metadata

    out: dict[str, str] = {}
    for ep in sorted(metadata.entry_points(group=ENTRY_POINT_GROUP), key=lambda e: e.name):
        if ep.name not in BUILTIN:
            out[ep.name] = ep.value
    return out


def names() -> tuple[str, ...]:
    """Registered scenario names: the packaged ones, then plug-ins (sorted)."""
    return (*BUILTIN, *_plugins())


def _suggest(name: str) -> str:
    hint = difflib.get_close_matches(name, names(), n=1)
    return f" (did you mean {hint[0]!r}?)" if hint else ""


@cache
def get(name: str) -> ScenarioSpec:
    """The spec registered as ``name``; ValueError (with a "did you mean") otherwise."""
    target = BUILTIN.get(name) or _plugins().get(name)
    if target is None:
        raise ValueError(f"scenario = {name!r}: must be one of {', '.join(names())}"
                         f"{_suggest(name)}")
    spec = load(target)
    if not isinstance(spec, ScenarioSpec) or spec.name != name:
        raise ValueError(f"scenario plug-in {name!r} ({target}): must be a ScenarioSpec "
                         f"named {name!r}")
    return spec


def specs() -> tuple[ScenarioSpec, ...]:
    """Every registered spec, in :func:`names` order."""
    return tuple(get(n) for n in names())


def spec_of(scenario: Any) -> ScenarioSpec:
    """The spec of a scenario object (by its class's ``name``)."""
    name = getattr(type(scenario), "name", None)
    if not isinstance(name, str):
        raise ValueError(f"scenario = {type(scenario).__name__}: a scenario dataclass needs a "
                         "class attribute `name` (its registry name)")
    return get(name)


def by_table(table: str) -> ScenarioSpec | None:
    """The spec whose config table is ``table`` (None when none is)."""
    return next((s for s in specs() if s.table == table), None)


def for_study(study: str) -> ScenarioSpec:
    """The scenario a single-scenario study runs: the first spec listing it in ``studies``."""
    for spec in specs():
        if study in spec.studies:
            return spec
    raise ValueError(f"study = {study!r}: no registered scenario serves it")


def point_columns() -> tuple[list[str], list[str]]:
    """(categorical, numeric) point columns of results rows: every registered scenario's
    axes, each once, in registration order (categorical after ``scenario``, numeric after
    ``mode``)."""
    cats: list[str] = []
    nums: list[str] = []
    for s in specs():
        for a in s.axes:
            target = cats if a.categorical else nums
            if a.name not in target:
                target.append(a.name)
    return cats, nums


def metric_names() -> dict[str, tuple[str, ...]]:
    """scenario → its metrics."""
    return {s.name: s.metrics for s in specs()}

