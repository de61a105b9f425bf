"""Scenario files: a TOML table of scenario fields (SI), the calibrated scenario's
(``[ball_on_plate]`` for the ball, the scenario whose spec serves ``calibrate``).

Written by ``impactbench calibrate``; read by ``run``, ``tune`` and ``report`` with
``--scenario-file FILE``. Any other table (e.g. ``[calibration]``, provenance) is ignored. The
impact velocity is not part of a scenario file (each command sets its own velocities).

Besides fields, the table may hold the scenario's further options by their flags' names
(:func:`option_keys`; the ball's ``material``, ``plate_material``, ``youngs_modulus_pa``,
``poisson``): they are applied as the flags are, through the spec's ``from_args``
(``material = "rubber"`` sets mass, Hertz c and the nominal restitution). The report config's
scenario tables take them the same way (:func:`apply_options`).
"""

from __future__ import annotations

import argparse
import tomllib
from functools import cache
from pathlib import Path
from typing import Any

from impactbench.scenarios import ScenarioSpec, for_study, get


@cache
def _option_keys(name: str) -> tuple[str, ...]:
    spec = get(name)
    fields = tuple(spec.cls.field_names())
    parser = argparse.ArgumentParser(add_help=False)
    spec.add_options(parser.add_argument_group(), False)
    return tuple(a.dest for a in parser._actions
                 if a.dest not in fields and a.dest != "scenario_file")


def option_keys(spec: ScenarioSpec) -> tuple[str, ...]:
    """The keys a scenario table may hold besides the scenario's fields: the destinations of
    its further options (:meth:`~ScenarioSpec.add_options`) that its
    :meth:`~ScenarioSpec.from_args` turns into fields, a scenario file itself excepted; () for
    a scenario without them."""
    if not spec.has_options or type(spec).from_args is ScenarioSpec.from_args:
        return ()
    return _option_keys(spec.name)


def apply_options(spec: ScenarioSpec, table: dict[str, Any], prefix: str = ""
                  ) -> dict[str, Any]:
    """The scenario fields of ``table``: its fields, with its option keys (a material) applied
    through the spec's ``from_args`` as the command-line flags are; a one-line error is prefixed
    with ``prefix`` (``ball_on_plate.``)."""
    keys = option_keys(spec)
    given = {k: v for k, v in table.items() if k in keys}
    fields = {k: v for k, v in table.items() if k not in keys}
    if not given:
        return fields
    try:
        return spec.from_args(argparse.Namespace(**{**dict.fromkeys(keys), **given}),
                                    fields)
    except ValueError as exc:
        raise ValueError(f"{prefix}{exc}") from None


def load_scenario_file(path: str | Path) -> dict[str, Any]:
    """The validated scenario fields of a scenario file (a one-line error otherwise)."""
    spec = for_study("calibrate")
    table_name, cls = spec.table, spec.cls
    path = Path(path)
    try:
        data = tomllib.loads(path.read_text())
    except OSError as exc:
        raise ValueError(f"scenario_file = {str(path)!r}: cannot read ({exc.strerror})") from None
    except tomllib.TOMLDecodeError as exc:
        raise ValueError(f"scenario_file = {str(path)!r}: not valid TOML ({exc})") from None
    table = data.get(table_name)
    if not isinstance(table, dict):
        raise ValueError(f"scenario_file = {str(path)!r}: needs a [{table_name}] table of "
                         f"{cls.__name__} fields")
    allowed = (set(cls.field_names()) - set(spec.axis_names)) | set(option_keys(spec))
    for key in table:
        if key not in allowed:
            import difflib

            hint = difflib.get_close_matches(key, sorted(allowed), n=1)
            raise ValueError(f"{table_name}.{key}: unknown key in {str(path)!r}"
                             f"{f' (did you mean {hint[0]!r}?)' if hint else ''}; allowed: "
                             f"{', '.join(sorted(allowed))}")
    try:
        fields = apply_options(spec, dict(table))
        cls(**fields)
    except ValueError as exc:
        raise ValueError(f"{str(path)!r}: {table_name}.{exc}") from None
    return fields
