"""Scenarios as specs: one :class:`ScenarioSpec` per physical set-up, held in one registry.

A scenario is one module that defines ``SPEC``, an instance of its subclass of
:class:`~impactbench.scenarios.spec.ScenarioSpec` (the shape of dm_control's suite and of
Gymnasium's ``EnvSpec``): its data — metrics (which are headline), point axes (what one run
varies: an impact velocity, a law pair), CLI flags, config table, labels, gate defaults — as
fields, its behaviour — physical dataclass, reference solver, metrics of a record,
plausibility, report figures, further flags, subcommands — as methods.
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
from functools import cache
from typing import Any

from impactbench.scenarios.spec import Axis, Flag, Point, ScenarioSpec

ENTRY_POINT_GROUP = "impactbench.scenarios"

BUILTIN: dict[str, str] = {
    "ball-on-plate": "impactbench.scenarios.ball_on_plate:SPEC",
    "rigid-flexible": "impactbench.scenarios.rigid_flexible:SPEC",
    "oblique": "impactbench.scenarios.oblique:SPEC",
    "bounce": "impactbench.scenarios.bounce:SPEC",
    "cube-toss": "impactbench.scenarios.cube_toss:SPEC",
}
"""The packaged scenarios, in the report's order (registry name → ``"module:attr"``): the one
string per scenario, imported on first use (:func:`get`)."""


def load(target: str) -> Any:
    """The object named by ``"module:attr"`` (imported now)."""
    module, _, attr = target.partition(":")
    obj: Any = importlib.import_module(module)
    for part in attr.split("."):
        obj = getattr(obj, part)
    return obj


# ------------------------------------------------------------------------------ registry


@cache
def _plugins() -> dict[str, ScenarioSpec]:
    """Scenario plug-ins installed through the ``impactbench.scenarios`` entry points, loaded
    once. A broken one — its module missing or failing to import, or its object not a
    :class:`ScenarioSpec` of that name — is left out and said in one line on stderr (naming
    the entry point, its package and the error), so the rest of impactbench works."""
    from importlib import metadata

    from impactbench.engines.registry import _warn

    out: dict[str, ScenarioSpec] = {}
    for ep in sorted(metadata.entry_points(group=ENTRY_POINT_GROUP), key=lambda e: e.name):
        if ep.name in BUILTIN:
            continue
        dist = getattr(ep, "dist", None)
        package = f"{dist.name} {dist.version}" if dist is not None else "unknown package"
        try:
            spec = load(ep.value)
        except Exception as exc:  # a plug-in's bug must not take down every command
            why = f"{type(exc).__name__}: {exc}".splitlines()[0]
        else:
            if isinstance(spec, ScenarioSpec) and spec.name == ep.name:
                out[ep.name] = spec
                continue
            why = f"{ep.value} is not a ScenarioSpec named {ep.name!r}"
        _warn(f"scenario:{ep.name}", f"impactbench: scenario plug-in {ep.name} = {ep.value} "
              f"({package}) is left out: {why}")
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
    if name in _plugins():
        return _plugins()[name]
    target = BUILTIN.get(name)
    if target is None:
        raise ValueError(f"scenario = {name!r}: must be one of {', '.join(names())}"
                         f"{_suggest(name)}")
    return load(target)


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



__all__ = ["BUILTIN", "ENTRY_POINT_GROUP", "Axis", "Flag", "Point", "ScenarioSpec", "by_table",
           "for_study", "get", "load", "metric_names", "names", "point_columns", "spec_of",
           "specs"]
