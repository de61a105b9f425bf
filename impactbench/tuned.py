"""Tuned-parameter files: fitted native contact parameters per engine and scenario.

A file is TOML with a ``[parameters]`` table in the engine's own form (the keys each adapter
documents for ``tuned`` mode), plus provenance. The package ships defaults for the paper's
case in ``impactbench/data/tuned/<engine>_<scenario>.toml``; ``impactbench tune`` writes new ones.
"""

from __future__ import annotations

import tomllib
from pathlib import Path
from typing import Any

TUNED_DIR = Path(__file__).parent / "data" / "tuned"


def tuned_path(engine: str, scenario: str) -> Path:
    """Where the packaged tuned file for ``engine`` and ``scenario`` lives."""
    return TUNED_DIR / f"{engine}_{scenario.replace('-', '_')}.toml"


def load_tuned(engine: str, scenario: str, path: Path | None = None) -> dict[str, Any] | None:
    """The ``[parameters]`` table of a tuned file; None when no file exists."""
    path = Path(path) if path is not None else tuned_path(engine, scenario)
    if not path.is_file():
        return None
    try:
        data = tomllib.loads(path.read_text())
    except tomllib.TOMLDecodeError as exc:
        raise ValueError(f"{path}: not valid TOML ({exc})") from None
    params = data.get("parameters")
    if not isinstance(params, dict):
        raise ValueError(f"{path}: [parameters] table is missing")
    return params
