"""Scenario files: a TOML table of scenario fields (SI), the calibrated scenario's
(``[ball_on_plate]`` for the ball, the scenario whose spec serves ``calibrate``).

Written by ``impactbench calibrate``; read by ``run``, ``tune`` and ``report`` with
``--scenario-file FILE``. Any other table (e.g. ``[calibration]``, provenance) is ignored. The
impact velocity is not part of a scenario file (each command sets its own velocities).
"""

from __future__ import annotations

import tomllib
from pathlib import Path
from typing import Any

from impactbench.scenarios import for_study


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
    allowed = set(cls.field_names()) - set(spec.axis_names)
    for key in table:
        if key not in allowed:
            raise ValueError(f"{table_name}.{key}: unknown key in {str(path)!r}; allowed: "
                             f"{', '.join(sorted(allowed))}")
    try:
        cls(**table)
    except ValueError as exc:
        raise ValueError(f"{str(path)!r}: {table_name}.{exc}") from None
    return dict(table)
