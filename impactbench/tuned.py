"""Tuned-parameter files: fitted native contact parameters per engine and scenario.

A file is TOML with a ``[parameters]`` table in the engine's own form (the keys each adapter
documents for ``tuned`` mode), plus provenance. The package ships defaults for the paper's
case in ``impactbench/data/tuned/<engine>_<scenario>.toml``; ``impactbench tune`` writes new ones
(:func:`write_tuned`): ``[parameters]``, ``[start]`` (the closed-form starting point),
``[provenance]`` (engine version, velocities, targets, weights, objective before/after,
timestep; no date or wall time, so the same tuning writes the same bytes) and ``[residuals]``.
"""

from __future__ import annotations

import json
import math
import re
import tomllib
from collections.abc import Mapping
from pathlib import Path
from typing import Any

TUNED_DIR = Path(__file__).parent / "data" / "tuned"
_BARE_KEY = re.compile(r"^[A-Za-z0-9_-]+$")


def tuned_path(engine: str, scenario: str) -> Path:
    """Where the packaged tuned file for ``engine`` and ``scenario`` lives."""
    return TUNED_DIR / f"{engine}_{scenario.replace('-', '_')}.toml"


def load_tuned(engine: str, scenario: str, path: Path | None = None) -> dict[str, Any] | None:
    """The ``[parameters]`` table of a tuned file; None when no file exists."""
    data = load_tuned_file(path if path is not None else tuned_path(engine, scenario))
    return None if data is None else data["parameters"]


def load_tuned_file(path: Path | str) -> dict[str, Any] | None:
    """All tables of a tuned file (``[parameters]`` checked); None when it does not exist."""
    path = Path(path)
    if not path.is_file():
        return None
    try:
        data = tomllib.loads(path.read_text())
    except tomllib.TOMLDecodeError as exc:
        raise ValueError(f"{path}: not valid TOML ({exc})") from None
    params = data.get("parameters")
    if not isinstance(params, dict):
        raise ValueError(f"{path}: [parameters] table is missing")
    return data


def _key(key: str) -> str:
    return key if _BARE_KEY.match(key) else json.dumps(key)


def _value(value: Any) -> str:
    """A TOML value: string, bool, int, float (inf/nan allowed) or a list of those."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return json.dumps(value, ensure_ascii=False)  # JSON escapes are valid TOML ones
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float) or hasattr(value, "item"):
        v = float(value)
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(value, list | tuple):
        return "[" + ", ".join(_value(v) for v in value) + "]"
    raise ValueError(f"tuned-file value {value!r}: must be a string, number, bool or list")


def dumps_tuned(tables: Mapping[str, Mapping[str, Any]], header: str = "") -> str:
    """TOML text of flat ``tables`` (``{table: {key: value}}``), in the given order."""
    lines = [f"# {line}".rstrip() for line in header.splitlines()]
    for name, table in tables.items():
        if lines:
            lines.append("")
        lines.append(f"[{_key(name)}]")
        lines.extend(f"{_key(k)} = {_value(v)}" for k, v in table.items())
    return "\n".join(lines) + "\n"


def write_tuned(path: Path | str, tables: Mapping[str, Mapping[str, Any]],
                header: str = "") -> Path:
    """Write a tuned file (``tables`` must include ``parameters``); checks it reads back."""
    if "parameters" not in tables:
        raise ValueError("tables: must include a [parameters] table")
    text = dumps_tuned(tables, header)
    tomllib.loads(text)  # never write a file the loader would reject
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)
    return path
