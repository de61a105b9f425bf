"""Scenario files: a TOML ``[ball_on_plate]`` table of BallOnPlate fields (SI).

Written by ``impactbench calibrate``; read by ``run``, ``tune`` and ``report`` with
``--scenario-file FILE``. Any other table (e.g. ``[calibration]``, provenance) is ignored. The
impact velocity is not part of a scenario file (each command sets its own velocities).
"""

from __future__ import annotations

import tomllib
from pathlib import Path
from typing import Any

from impactbench.reference.scenarios import BallOnPlate

TABLE = "ball_on_plate"


def load_scenario_file(path: str | Path) -> dict[str, Any]:
    """The validated BallOnPlate fields of a scenario file (a one-line error otherwise)."""
    path = Path(path)
    try:
        data = tomllib.loads(path.read_text())
    except OSError as exc:
        raise ValueError(f"scenario_file = {str(path)!r}: cannot read ({exc.strerror})") from None
    except tomllib.TOMLDecodeError as exc:
        raise ValueError(f"scenario_file = {str(path)!r}: not valid TOML ({exc})") from None
    table = data.get(TABLE)
    if not isinstance(table, dict):
        raise ValueError(f"scenario_file = {str(path)!r}: needs a [{TABLE}] table of "
                         "BallOnPlate fields")
    allowed = set(BallOnPlate.field_names()) - {"velocity_m_s"}
    for key in table:
        if key not in allowed:
            raise ValueError(f"{TABLE}.{key}: unknown key in {str(path)!r}; allowed: "
                             f"{', '.join(sorted(allowed))}")
    try:
        BallOnPlate(**table)
    except ValueError as exc:
        raise ValueError(f"{str(path)!r}: {TABLE}.{exc}") from None
    return dict(table)
