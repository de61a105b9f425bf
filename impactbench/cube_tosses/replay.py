"""``replay(engine, mode, …)``: the cube tosses replayed in one engine, scored against the data.

The result is the dict ``impactbench run --engine E --scenario cube-toss --mode M --json``
is meant to print (keys in :data:`RESULT_KEYS`):

- ``status``: "ok" (every toss replayed), "partial" (some failed), "failed" (none ran),
  "unsupported" (a 2D engine, pymunk or Box2D, or injected mode in MJX or Newton: every
  other key None or empty, ``reason`` says why);
- ``engine``, ``mode``, ``param_set``, ``split``, ``tosses`` (how many were replayed),
  ``failed`` (the ids that failed: an engine error or a non-finite state);
- ``position_error_mean``/``_median``/``_q1``/``_q3``: over tosses, each toss's time-mean
  of |Δp| / (2h); ``rotation_error_deg_…`` likewise for the rotation angle (degrees);
- ``per_toss``: one dict per toss (``toss``, ``status``, ``start_sample``, ``samples``,
  ``refit``, the two errors and their final values; ``error`` when it failed);
- ``protocol``: the replay options (:class:`~impactbench.cube_tosses.protocol.Protocol`);
- ``engine_setup``: the engine's version, the parameters set, the effective friction and
  contact values with their combination rules, the cube's inertia, the board; in ``native``
  mode also ``native`` (the mapping's rule and inputs: the model's parameters, the operating
  point, the corner impact there), in ``injected`` mode ``injected`` (the law applied and how
  the engine's own contact was switched off);
- ``elapsed_s``, ``tosses_per_s`` (engine build excluded), ``data`` (the file replayed).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Iterable, Mapping
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

import impactbench.cube_tosses.data as data_mod
import impactbench.cube_tosses.engines as engines_mod
from impactbench.cube_tosses.protocol import (
    DAIR_BOX,
    Box,
    Protocol,
    prepare,
    sample_dt,
    summarize,
    toss_errors,
)

MODES = ("default", "custom", "tuned", "native", "injected")

RESULT_KEYS = ("status", "engine", "mode", "param_set", "split", "tosses", "failed",
               "position_error_mean", "position_error_median", "position_error_q1",
               "position_error_q3", "rotation_error_deg_mean", "rotation_error_deg_median",
               "rotation_error_deg_q1", "rotation_error_deg_q3", "per_toss", "protocol",
               "engine_setup", "elapsed_s", "tosses_per_s", "data")


def engine_parameters(engine: str, mode: str, param_set: str | None = None,
                      params: Mapping[str, Any] | None = None, *, box: Box = DAIR_BOX,
                      model: Any = None) -> dict[str, Any]:
    """The engine parameters of a run: none in ``default`` mode; in ``custom`` mode the named
    set (``param_set``) overlaid with ``params``; in ``tuned`` mode ``params`` (a tuned
    file's ``[parameters]``, :func:`impactbench.cube_tosses.tune.load_tuned`); in ``native``
    mode the reference model's contact (``model``, the packaged fit when None) mapped into the
    engine for the cube ``box`` (:func:`impactbench.cube_tosses.model_modes.native_parameters`);
    none in ``injected`` mode (the engine's contact is off, the model's forces act)."""
    if engine not in engines_mod.ENGINES:
        raise ValueError(f"engine = {engine!r}: the cube tosses run on "
                         f"{', '.join(engines_mod.ENGINES)}")
    if mode not in MODES:
        raise ValueError(f"mode = {mode!r}: must be one of {', '.join(MODES)}")
    if mode in ("default", "native", "injected"):
        if param_set is not None or params:
            what = ("sets no engine parameters" if mode == "default" else
                    "maps the reference model's contact" if mode == "native" else
                    "applies the reference model's corner forces")
            raise ValueError(f"param_set = {param_set!r}: {mode} mode {what}; use mode "
                             "'custom' to set engine parameters")
        if mode == "native":
            from impactbench.cube_tosses.model_modes import native_parameters

            return native_parameters(engine, model, box)
        return {}
    if mode == "tuned":
        if param_set is not None:
            raise ValueError(f"param_set = {param_set!r}: tuned mode takes the fitted "
                             "parameters (params = load_tuned(engine)), no parameter set")
        if not params:
            raise ValueError(f"params = {params!r}: tuned mode needs the fitted parameters "
                             "(params = load_tuned(engine))")
        return dict(params)
    if param_set is None and not params:
        raise ValueError(f"param_set = None: custom mode needs a parameter set ("
                         f"{', '.join(engines_mod.PARAM_SETS.get(engine, {})) or 'none'}) "
                         "or params")
    out = engines_mod.param_set(engine, param_set) if param_set is not None else {}
    return out | dict(params or {})


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


def replay(engine: str, mode: str = "default", tosses: str | int | Iterable[int] = "all",
           param_set: str | None = None, data: pd.DataFrame | str | Path | None = None, *,
           params: Mapping[str, Any] | None = None, protocol: Protocol | None = None,
           progress: Callable[[int, int], None] | None = None, box: Box = DAIR_BOX,
           model: Any = None) -> dict[str, Any]:
    """Replay ``tosses`` (a split name, an id or ids) of ``data`` (a DataFrame from
    :func:`~impactbench.cube_tosses.data.load`, a CSV path, or None for the packaged tosses)
    in ``engine`` ("pybullet", "mujoco", "drake", "sapien", "dart", "newton", "mjx") under
    ``protocol`` (DAIR's by default).

    ``mode``: "default" (the engine's own contact settings), "custom" (``param_set``, a
    name from :data:`~impactbench.cube_tosses.engines.PARAM_SETS` such as "dair2022", and/or
    ``params``, engine parameters by the engine's own names) or "tuned" (``params`` fitted to
    the training tosses, :mod:`~impactbench.cube_tosses.tune`), "native" (the reference
    model's contact mapped into the engine's parameters) or "injected" (the engine's contact
    off, the model's corner forces applied every step), both with ``model`` (the reference
    model's :class:`~impactbench.reference.box_contact.BoxContactParams`, the packaged fit
    when None; :mod:`~impactbench.cube_tosses.model_modes`). One engine instance serves every
    toss. ``box``: the cube (DAIR's by default). Returns the dict described in the module
    doc."""
    protocol = protocol or Protocol()
    from impactbench.cube_tosses.engines_more import UNSUPPORTED

    why = UNSUPPORTED.get(engine, "")
    if not why and mode == "injected" and engine in engines_mod.ENGINES:
        from impactbench.cube_tosses.model_modes import injected_reason

        why = injected_reason(engine)
    if why:
        return {**dict.fromkeys(RESULT_KEYS), "status": "unsupported", "engine": engine,
                "mode": mode, "param_set": param_set, "tosses": 0, "failed": [],
                "per_toss": [], "protocol": protocol.describe(), "reason": why}
    eparams = engine_parameters(engine, mode, param_set, params, box=box, model=model)
    law = None
    if mode in ("native", "injected"):
        from impactbench.cube_tosses.model_modes import load_model

        model = load_model() if model is None else model
        law = model if mode == "injected" else None
    df, source = frame_of(data)
    ids, split_name, starts, per_toss = prepared(df, tosses, protocol)
    steps = {round(s.step_s, 15) for s in starts}
    if len(steps) > 1:
        raise ValueError(f"data: the tosses' sample intervals differ ({sorted(steps)[:3]} s "
                         "engine steps); give Protocol(sample_dt_s=…)")
    step_s = starts[0].step_s if starts else (
        (protocol.sample_dt_s or sample_dt(next(data_mod.tosses(df, ids[:1])).t, protocol))
        / protocol.substeps)

    sim = engines_mod.make(engine, eparams, step_s, protocol.board_z_m, box, law=law)
    try:
        setup = sim.describe()
        if mode == "native":
            from impactbench.cube_tosses.model_modes import native_mapping

            setup["native"] = native_mapping(engine, model, box).describe()
        elif mode == "injected":
            setup["injected"] = sim.injected_setup()
        t0 = time.perf_counter()
        # a batched engine (Newton, MJX) replays every toss in one call
        batch = sim.run_many(starts) if getattr(sim, "batched", False) else None
        for n, start in enumerate(starts):
            try:
                if batch is not None and isinstance(batch[n], Exception):
                    raise batch[n]
                p, q = batch[n] if batch is not None else sim.run(start)
                if not (np.all(np.isfinite(p)) and np.all(np.isfinite(q))):
                    raise FloatingPointError("non-finite state")
                row = {"status": "ok", **toss_errors(start, p, q, protocol)}
            except (RuntimeError, FloatingPointError, ValueError) as exc:
                row = {"toss": start.toss, "status": "failed",
                       "error": f"{type(exc).__name__}: {str(exc).splitlines()[0]}"}
            per_toss.append(row)
            if progress is not None:
                progress(n + 1, len(starts))
        elapsed = time.perf_counter() - t0
    finally:
        sim.close()

    status, failed = outcome(per_toss, ids)
    return {"status": status, "engine": engine, "mode": mode, "param_set": param_set,
            "split": split_name, "tosses": len(per_toss), "failed": failed,
            **summarize(per_toss), "per_toss": per_toss, "protocol": protocol.describe(),
            "engine_setup": setup, "elapsed_s": elapsed,
            "tosses_per_s": len(starts) / elapsed if elapsed > 0 else math.nan,
            "data": source}
