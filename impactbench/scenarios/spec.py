"""The scenario spec: what the suite needs to run, compare, report and gate one scenario.

A scenario's module subclasses :class:`ScenarioSpec` and defines ``SPEC``, one instance: its
data (name, title, metrics, axes, CLI flags, config table, labels) are the dataclass's fields,
its behaviour the methods it overrides — :attr:`~ScenarioSpec.cls` (its physical dataclass),
:meth:`~ScenarioSpec.reference_metrics`, :meth:`~ScenarioSpec.history`,
:meth:`~ScenarioSpec.metrics_of`, :meth:`~ScenarioSpec.measure` (plausibility),
:meth:`~ScenarioSpec.report_figures`, :meth:`~ScenarioSpec.add_options`, … (the shape of
dm_control's ``Task`` and Gymnasium's ``EnvSpec``). A method the scenario does not override
has the default every scenario with a reference solution shares. Nothing here is named by a
``"module:attr"`` string: the registry (:mod:`impactbench.scenarios`) holds one such string
per scenario, loaded once.

This module imports nothing heavy: the command line builds its parser from the specs.
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

Point = tuple[tuple[str, Any], ...]
"""The values of a scenario's axes for one run, in the spec's axis order."""
HISTORY_POINTS = 1500
"""A run's force history kept for plots is thinned to about this many samples."""


def contact_steps(reference: Mapping[str, Any], timestep_s: float | None) -> float:
    """Rough integration steps of one run: twice the reference contact time over the
    timestep (adapters record from just before contact until separation). 0 with the
    adapter's default step (those are sized for the scenario)."""
    duration = reference.get("duration_s", reference.get("contact_time_s"))
    if not timestep_s or not isinstance(duration, float | int) or not math.isfinite(duration):
        return 0.0
    return 2.0 * float(duration) / timestep_s


def thinned_history(record: Any, points: int = HISTORY_POINTS) -> dict[str, Any]:
    """A record's force history for plots: ``time_s``, ``normal_force_n``, ``penetration_m``
    (s, N, m) thinned to about ``points`` samples, its peak force and last sample kept;
    {} for a record without samples."""
    import numpy as np

    n = len(record)
    if n == 0:
        return {}
    step = max(1, math.ceil(n / points))
    idx = np.unique(np.r_[np.arange(0, n, step), np.argmax(record.normal_force_n), n - 1])
    return {"time_s": record.time_s[idx], "normal_force_n": record.normal_force_n[idx],
            "penetration_m": record.penetration_m[idx]}


@dataclass(frozen=True)
class Axis:
    """One coordinate of a scenario's points.

    Attributes:
        name: the scenario field it sets (``velocity_m_s``, ``local``).
        config_key: its key in the scenario's config table (a list of values).
        column: the header of its column in report tables (``V0 (m/s)``).
        choices: for a categorical axis, a function returning the allowed values (imported
            when called); None for a numeric axis (values > 0, SI).
        default: a function returning the values a config table that omits the key gets
            (categorical axes); None for none (a numeric axis then needs the key).
        short: the prefix of a numeric value in run ids and gate labels (``v`` → ``v2``).
        zero: a numeric axis that may be 0 (an incidence angle); else its values are > 0.
    """

    name: str
    config_key: str
    column: str
    choices: Callable[[], Iterable[str]] | None = None
    default: Callable[[], Iterable[Any]] | None = None
    short: str = ""
    zero: bool = False

    @property
    def categorical(self) -> bool:
        return self.choices is not None

    def allowed(self) -> tuple[str, ...]:
        """The allowed values of a categorical axis."""
        return tuple(self.choices()) if self.choices is not None else ()

    def defaults(self) -> tuple[Any, ...]:
        return tuple(self.default()) if self.default is not None else ()


@dataclass(frozen=True)
class Flag:
    """A command-line flag that sets one scenario field (``--mass`` → ``mass_kg``)."""

    flag: str
    field: str
    help: str


@dataclass(frozen=True)
class ScenarioSpec:
    """Everything the suite needs to run, compare, report and gate one scenario.

    Data (fields):
        name: registry name (``run NAME``, results' ``scenario`` column).
        title: its heading in reports (``Ball on plate``).
        summary: one line for ``--help`` and the report's section intro.
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
        descriptions: what each field means (SI units), for the report's parameter table,
            where no flag's help says it.
        studies: the suite's single-scenario studies it serves (``work_precision``,
            ``practical``, ``tuning``, ``calibrate``): each runs the first scenario that lists
            it (:func:`impactbench.scenarios.for_study`).
        default_mode: the mode ``run`` takes without ``--mode`` (``native``; the cube
            tosses': ``default``, the engines as they come against the measurement).

    Behaviour (methods; a subclass overrides what its scenario needs): see each method.
    """

    name: str
    title: str
    summary: str
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
    descriptions: Mapping[str, str] = field(default_factory=dict)
    studies: tuple[str, ...] = ()
    default_mode: str = "native"
    tuned_from: str = ""
    """The scenario whose tuned files this one's ``tuned`` runs take, fitted at the run's
    step ("": its own; the bounce takes the ball's: the same body and contact)."""
    step_cost: float = 1.0
    """What one of its runs' steps (:meth:`estimated_steps`) costs, in the suite's prior
    step (:data:`impactbench.cluster.STEP_S`): a run's time estimate, hence its timeout and
    the time left, scale with steps × this."""

    # ------------------------------------------------------------------ the dataclass
    @property
    def cls(self) -> type:
        """The scenario's frozen dataclass (a ``name`` class attribute equal to the spec's;
        validated in ``__post_init__``); imported when first asked for."""
        raise NotImplementedError(f"scenario {self.name!r}: its spec must define cls")

    def build(self, point: Point | Mapping[str, Any] = (), parameters: Iterable = ()) -> Any:
        """The scenario at ``point`` with these fields (``(name, value)`` pairs or a mapping)
        over its defaults; validated (ValueError naming the field)."""
        return self.cls(**dict(parameters), **dict(point))

    def point_of(self, scenario: Any) -> Point:
        """The point of a scenario object (its axes' values)."""
        return tuple((a.name, getattr(scenario, a.name)) for a in self.axes)

    @property
    def axis_names(self) -> tuple[str, ...]:
        return tuple(a.name for a in self.axes)

    @property
    def measured(self) -> bool:
        """A data-driven scenario: its reference is a measurement, a run replays all its
        recorded trials at once (no axes: one point, ``()``) and its metrics are already
        errors against the measurement (:meth:`run_errors`). False for a scenario with a
        reference solution."""
        return False

    # ------------------------------------------------------------------ the reference
    def reference_metrics(self, scenario: Any) -> dict[str, Any]:
        """The reference object of ``scenario`` (same keys as ``reference NAME --json``)."""
        raise NotImplementedError(f"scenario {self.name!r}: its spec must define "
                                  "reference_metrics")

    def history(self, scenario: Any) -> Any:
        """The reference's time history of ``scenario`` (an ImpactRecord, for force plots)."""
        raise ValueError(f"scenario = {self.name!r}: its reference has no force history")

    @property
    def has_history(self) -> bool:
        """The reference has a force history (:meth:`history`): the report draws F(t)."""
        return type(self).history is not ScenarioSpec.history

    def problem(self, scenario: Any, reference: Mapping[str, Any]) -> str:
        """Why the reference of ``scenario`` is outside its model ("" when it is not): such a
        run is ``unsupported``."""
        return ""

    # ------------------------------------------------------------------ a run
    def metrics_of(self, record: Any, scenario: Any) -> dict[str, Any]:
        """The metrics of an engine's record: the one shared path
        (:func:`impactbench.reference.metrics.compute`) unless the scenario needs more."""
        from impactbench.reference import metrics

        return metrics.compute(record)

    def measure(self, scenario: Any, record: Any, metrics: Mapping[str, Any]) -> dict:
        """The plausibility measures of one run, ``penetration_ratio`` and ``energy_ratio``
        (NaN where one does not apply; :mod:`impactbench.plausibility`); {} for none."""
        return {}

    def run_details(self, record: Any, scenario: Any, mode: str) -> dict[str, Any]:
        """What a run object carries besides the metrics ({} when the scenario adds
        nothing; the cube tosses' per-toss rows, split, protocol)."""
        return {}

    def run_errors(self, run: Mapping[str, Any], metrics: Mapping[str, Any],
                   reference: Mapping[str, Any], resolved: Mapping[str, bool]
                   ) -> dict[str, float]:
        """The errors tables and gates read: relative to the reference (an unresolved metric
        is reported, never compared: NaN)."""
        from impactbench.reference.metrics import relative_error

        return {k: (relative_error(float(metrics[k]), float(reference[k])) if resolved[k]
                    else math.nan) for k in metrics}

    def store_inputs(self, engine: str, scenario: Any, mode: str) -> dict[str, Any]:
        """What a run's store key holds beside its settings (a data file's SHA-256); {}."""
        return {}

    def at_timestep(self, scenario: Any, timestep_s: float | None) -> tuple[Any, str]:
        """(the scenario a step maps to, where the step comes from; "" when the step stays
        the run's own — every scenario whose step is not one of its fields)."""
        return scenario, ""

    @property
    def owns_timestep(self) -> bool:
        """The scenario's fields carry the step (:meth:`at_timestep` maps a given one)."""
        return type(self).at_timestep is not ScenarioSpec.at_timestep

    def load_tuned(self, engine: str, scenario: Any, timestep_s: float | None,
                   tuned_file: str | Path | None = None,
                   variant: Mapping[str, Any] | None = None
                   ) -> tuple[dict[str, Any] | None, dict[str, Any] | None] | None:
        """(parameters, provenance) of ``engine``'s tuned file for a scenario with tuned files
        of its own (the cube tosses'); provenance's ``mismatch`` says why a file does not
        apply. None: the suite's tuned files (:func:`impactbench.tuned.tuned_settings`)."""
        return None

    # ------------------------------------------------------------------ the command line
    def add_options(self, group: argparse._ArgumentGroup, with_gravity: bool = True) -> None:
        """Add the scenario's further flags (``--model``, ``--material``) to a group; none."""

    @property
    def has_options(self) -> bool:
        return type(self).add_options is not ScenarioSpec.add_options

    def from_args(self, args: argparse.Namespace, values: dict[str, Any]) -> dict[str, Any]:
        """Field values from parsed flags: turns its further flags (a material, a scenario
        file) into fields; the values as given when it has none."""
        return values

    def register_commands(self, top: Any, groups: Mapping[str, Any]) -> None:
        """Add its own subcommands (``reference NAME``, ``sweep NAME``) to the parser."""

    # ------------------------------------------------------------------ the report
    def report_part(self, ctx: Any, table: Any) -> dict[str, Any]:
        """A measured scenario's part of the report's "Against real tosses" section (its
        config ``table``: engines, modes, parameter sets, fields): title, intro, table, notes,
        figures."""
        raise NotImplementedError(f"scenario {self.name!r}: a measured scenario's spec must "
                                  "define report_part")

    def report_tables(self, ctx: Any, runs: list) -> list[dict[str, Any]]:
        """Further tables of its report section after the engines' (``runs``: its matrix
        runs), each ``{"title", "note", "table"}``; none."""
        return []

    def report_figures(self, ctx: Any, runs: list, loops: list) -> None:
        """Draw its extra report figures (``ctx``: the report's context; ``runs``: its
        matrix runs; ``loops``: its force–penetration loops); none."""

    def report_jobs(self, cfg: Any, table: Any, engines: Iterable[str]) -> list:
        """A measured scenario's runs in a report (its config ``table``: engines, modes,
        parameter sets, fields), as jobs (:class:`~impactbench.matrix.Job`) planned with the
        matrix's (:func:`impactbench.matrix.plan`), so they run beside it on the same workers
        and store; [] for a scenario whose runs are the matrix's own points."""
        return []

    def report_background(self, cfg: Any, table: Any, store: Any) -> dict[str, Any]:
        """Work of a measured scenario's report part that needs none of the engines' runs,
        to start in a process of its own while they run (its config ``table``; ``store``:
        the part's results store): name → a picklable callable of no arguments, whose
        result :meth:`report_part` finds as ``ctx.background[name].result()``; none."""
        return {}

    def estimated_steps(self, scenario: Any, reference: Mapping[str, Any],
                        timestep_s: float | None) -> float:
        """Rough integration steps of one run (what its timeout and the time-left estimate
        scale with: :func:`impactbench.cluster.run_estimate_s`): :func:`contact_steps`."""
        return contact_steps(reference, timestep_s)

    def kept_history(self, record: Any, run: Mapping[str, Any], scenario: Any
                     ) -> dict[str, Any]:
        """What a run the report plots keeps of its record (named 1-D float arrays, stored
        with the run): the force history, thinned (:func:`thinned_history`); a measured
        scenario keeps what its figures draw (the cube tosses: the picked tosses'
        trajectories). ``run``: the run's comparison object."""
        return thinned_history(record)

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
        return self.values_text(axis, (value,))

    def values_text(self, axis: Axis, values: Iterable[Any]) -> str:
        """``V0 = 0.5, 2 m/s`` (the impact velocity, by the spec's symbol) or, for another
        numeric axis, from its column ``θ (°)``: ``θ = 45°``, ``h (m)``: ``h = 0.05, 0.2 m``."""
        numbers = ", ".join(f"{float(v):g}" for v in values)
        if axis.name == "velocity_m_s":
            return f"{self.velocity_symbol} = {numbers} m/s"
        symbol, _, unit = axis.column.partition(" (")
        unit = unit.rstrip(")")
        gap = "" if unit in ("°", "%") else " "
        return f"{symbol} = {numbers}{gap + unit if unit else ''}"

    def figure_name(self, point: Point) -> str:
        """The file-name part of a per-point figure: ``ball_v2`` or ``rf_linear_linear_v2``."""
        values = dict(point)
        parts = [str(values[a.name]) for a in self.axes if a.categorical]
        parts += [f"{a.short}{float(values[a.name]):g}" for a in self.axes
                  if not a.categorical]
        return "_".join([self.figure_stem or self.name.replace("-", "_"), *parts])
