"""Command-line flags of the scenarios' fields and axes, shared by every subcommand.

Each scenario's spec (:mod:`impactbench.scenarios`) lists its flags (``--mass`` sets
``mass_kg``) and may add further options (a material, a scenario file); its categorical axes
become flags of their own (``--local``). So ``reference``, ``sweep``, ``run`` and ``tune``
accept the same flags with the same defaults (the papers'), and a scenario is built and
validated in one place, for them and for the Python API (:mod:`impactbench.api`):
:func:`scenario_from_args`.
"""

from __future__ import annotations

import argparse
from typing import Any

from impactbench.cliutil import number
from impactbench.scenarios import get


def add_parameter_flags(parser: argparse.ArgumentParser, scenario: str, *,
                        with_gravity: bool = True, added: set[str] | None = None) -> None:
    """Add the field flags of ``scenario`` (defaults: the scenario's, i.e. the paper's).

    A flag left unset is None, so that a further option (a material) can tell an explicit
    value from the default. ``with_gravity`` is passed to the spec's options (the ball's
    ``--gravity``: engines only, the reference is the paper's gravity-free impact).
    ``added``: flags already on ``parser`` (from another scenario; a scenario that shares a
    field shares its flag), updated."""
    spec = get(scenario)
    defaults = spec.cls()
    added = added if added is not None else set()
    group = parser.add_argument_group(f"{spec.title.lower()}: physical parameters (SI; "
                                      "defaults are the paper's)")
    for f in spec.flags:
        # a flag another scenario (or its options, e.g. the ball's --poisson) already added
        # sets the same field: it is shared, not added twice
        if f.flag in added or f"--{f.flag}" in parser._option_string_actions:
            continue
        added.add(f.flag)
        group.add_argument(f"--{f.flag}", type=number, default=None, dest=f.field,
                           metavar="X", help=f"{f.help}; default {getattr(defaults, f.field):g}")
    options = f"options:{type(spec).add_options.__qualname__}"  # shared options: added once
    if spec.has_options and options not in added:
        added.add(options)
        spec.add_options(group, with_gravity)


def add_axis_flags(parser: argparse.ArgumentParser, scenario: str, *,
                   default: str | None = "linear", added: set[str] | None = None) -> None:
    """Add one flag per categorical axis of ``scenario`` (``--local``, ``--structure``)."""
    which = f"default {default}" if default else "default: every one, in turn"
    added = added if added is not None else set()
    for axis in get(scenario).axes:
        if axis.categorical and axis.name not in added:
            added.add(axis.name)
            parser.add_argument(f"--{axis.name.replace('_', '-')}", choices=axis.allowed(),
                                default=default, dest=axis.name,
                                help=f"{axis.column} law; {which}")


class _OptionNames:
    """Stands in for an argument group to read which keywords a scenario's further options
    take (its :meth:`~impactbench.scenarios.spec.ScenarioSpec.add_options`): each flag's
    ``dest``, in order. Nothing is parsed and no parser is built."""

    def __init__(self) -> None:
        self.names: list[str] = []
        self._option_string_actions: dict[str, str] = {}  # (what add_options may look up)

    def add_argument(self, *flags: str, dest: str | None = None, **_: Any) -> None:
        name = dest or flags[0].lstrip("-").replace("-", "_")
        self.names.append(name)
        self._option_string_actions.update(dict.fromkeys(flags, name))


def option_names(scenario: str) -> tuple[str, ...]:
    """The keywords of ``scenario``'s further options (the ball's ``material``,
    ``scenario_file``, …; the cube tosses' ``data``, ``tosses``), as its flags name them."""
    spec = get(scenario)
    if not spec.has_options:
        return ()
    names = _OptionNames()
    spec.add_options(names, True)  # type: ignore[arg-type]  # (only add_argument is used)
    return tuple(names.names)


def scenario_from_args(scenario: str, args: Any, **overrides: Any) -> Any:
    """Build and validate the scenario from parsed flags, or from a plain namespace of the
    Python API's keywords (its fields, axes and further options; None: unset; overrides
    win)."""
    spec = get(scenario)
    fields = set(spec.cls.field_names())
    values = {k: v for k, v in vars(args).items() if k in fields and v is not None}
    values = spec.from_args(args, values)
    values.update(overrides)
    return spec.cls(**values)
