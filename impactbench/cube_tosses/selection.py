"""Which tosses a replay runs, and how its per-toss rows become one result.

:func:`select` (a split name, an id or ids), :func:`frame_of` (the validated tosses and their
source), :func:`prepared` (each selected toss's replay start, and a ``failed`` row for a toss
the protocol cannot start) and :func:`outcome` (the rows in selection order, the status and the
failed ids) serve the engines' replays (:mod:`impactbench.cube_tosses.scenario`, through the
adapters' cube-toss builders) and the reference model's
(:mod:`impactbench.cube_tosses.reference_model`) alike. :data:`RESULT_KEYS` are the keys of
the reference model's replay result.
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

import impactbench.cube_tosses.data as data_mod
from impactbench.cube_tosses.protocol import (
    Protocol,
    prepare,
)

RESULT_KEYS = ("status", "engine", "mode", "param_set", "split", "tosses", "failed",
               "position_error_mean", "position_error_median", "position_error_q1",
               "position_error_q3", "rotation_error_deg_mean", "rotation_error_deg_median",
               "rotation_error_deg_q1", "rotation_error_deg_q3", "per_toss", "protocol",
               "engine_setup", "elapsed_s", "tosses_per_s", "data")


def select(df: pd.DataFrame, tosses: str | int | Iterable[int] = "all") -> list[int]:
    """Toss ids: a split name ("all", "train", "test"), one id, or ids (kept in order)."""
    available = data_mod.toss_ids(df)
    if isinstance(tosses, str):
        return data_mod.split(available, tosses)
    wanted = [int(tosses)] if isinstance(tosses, int | np.integer) else [int(i) for i in tosses]
    known = set(available)
    missing = [i for i in wanted if i not in known]
    if missing:
        raise ValueError(f"tosses: toss {missing[0]} not in the data ({len(available)} tosses, "
                         f"ids {available[0]}–{available[-1]})")
    if not wanted:
        raise ValueError("tosses: no toss selected")
    return wanted


def frame_of(data: pd.DataFrame | str | Path | None) -> tuple[pd.DataFrame, str]:
    """The tosses (validated) and where they came from: a DataFrame, a CSV path, or None for
    the packaged file."""
    if isinstance(data, pd.DataFrame):
        return data_mod.validate(data), "DataFrame"
    df = data_mod.load(data)
    return df, (str(data) if data is not None else "packaged: " + str(
        data_mod.DEFAULT_PATH.relative_to(data_mod.DATA_DIR.parents[1])))


def prepared(df: pd.DataFrame, tosses: str | int | Iterable[int], protocol: Protocol
             ) -> tuple[list[int], str, list[Any], list[dict[str, Any]]]:
    """(ids, split name, the replay starts, a ``failed`` row per toss the protocol cannot
    start) of the selected tosses."""
    ids = select(df, tosses)
    starts, per_toss = [], []
    for toss in data_mod.tosses(df, ids):
        try:
            starts.append(prepare(toss, protocol))
        except ValueError as exc:
            per_toss.append({"toss": toss.toss, "status": "failed", "error": str(exc)})
    return ids, (tosses if isinstance(tosses, str) else "ids"), starts, per_toss


def outcome(per_toss: list[dict[str, Any]], ids: list[int]) -> tuple[str, list[int]]:
    """Sort ``per_toss`` into the order of ``ids`` (in place); the replay's status (ok, partial,
    failed) and the failed ids."""
    order = {i: k for k, i in enumerate(ids)}
    per_toss.sort(key=lambda r: order[r["toss"]])
    failed = [r["toss"] for r in per_toss if r["status"] != "ok"]
    ran = len(per_toss) - len(failed)
    return ("ok" if not failed else ("failed" if ran == 0 else "partial")), failed
