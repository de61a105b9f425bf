"""The cube-toss scenario's side of a replay: what the scenario prepares for the engines'
builders, how it scores their records against the measurement, and what it shows besides.

An engine run goes through the one door: :meth:`~impactbench.engines.base.Adapter.run` of
the engine's adapter, whose cube-toss builder (:func:`impactbench.engines.cube_toss.replay_tosses`)
asks the scenario object (:class:`~impactbench.scenarios.cube_toss.CubeToss`) for its inputs
— :func:`starts` (each selected toss's start from the measurement, DAIR's protocol),
:func:`box_of`, :func:`engine_parameters` (by mode) and :func:`injected_law` — and returns a
record of the replayed poses. The spec scores it: :func:`record_metrics` (each toss's time
mean position and rotation errors, :func:`~impactbench.cube_tosses.protocol.toss_errors`, and
their median, quartiles and mean) and :func:`details` (the per-toss rows, the split, the
protocol, what the engine built). The metrics are errors against the measurement, so a run's
``rel_error`` is the metric itself (the spec's ``absolute_errors``).

Modes: ``default`` (the engine's own contact), ``custom`` (a published parameter set,
``param_set = "dair2022"``, and/or engine parameters by the builder's own names,
``board.``/``cube.``-prefixed), ``tuned`` (the engine's parameters fitted to the training tosses,
:mod:`~impactbench.cube_tosses.tune`: the packaged tuned file or a given one; bound to the
protocol's step and the cube's half width, :func:`tuned_settings`), ``native`` (the reference
model's fitted corner contact mapped into the engine's own parameters,
:func:`~impactbench.cube_tosses.model_modes.native_mapping`) and ``injected`` (the engine's
box–board contact off and the model's corner forces applied every step; ``unsupported`` in
MJX and Newton, which step in compiled batches). The 2D engines (pymunk, Box2D) have no
cube-toss builder (``unsupported``, saying why).

Step: the protocol's, ``sample_dt_s / substeps`` (DAIR: 1/148 s / 10). A given ``timestep_s``
sets ``substeps = max(1, round(sample_dt_s / timestep_s))`` (:func:`with_timestep`): the engine
steps at the nearest step that divides the sample interval (the run says which,
``timestep_source``), since the replay records the pose at every sample.

Store key: beside the engine, its version, the scenario's fields (box, data path, selection,
protocol), the mode and the settings, :func:`key_inputs` adds the data file's SHA-256 and, in
``native`` and ``injected`` modes, the fitted reference model's.
"""

from __future__ import annotations

import functools
import hashlib
import math
import time
from collections.abc import Mapping
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

import impactbench.cube_tosses.data as data_mod
from impactbench.cube_tosses.protocol import (
    SAMPLE_DT_S,
    Box,
    Protocol,
    rotation_angle,
    summarize,
    toss_errors,
)
from impactbench.cube_tosses.selection import frame_of, outcome, prepared, select

METRIC_KEYS = ("position_error_median", "position_error_q1", "position_error_q3",
               "position_error_mean", "rotation_error_deg_median", "rotation_error_deg_q1",
               "rotation_error_deg_q3", "rotation_error_deg_mean")


# ------------------------------------------------------------------------------ the scenario


def protocol_of(scenario: Any) -> Protocol:
    """The replay protocol of a :class:`~impactbench.scenarios.cube_toss.CubeToss`."""
    return Protocol(substeps=scenario.substeps, start_rule=scenario.start_rule,
                    samples_before=scenario.samples_before, refit=scenario.refit,
                    min_preceding=scenario.min_preceding, velocity_fit=scenario.velocity_fit,
                    sample_dt_s=scenario.sample_dt_s, board_z_m=scenario.board_z_m,
                    half_width_m=scenario.half_width_m)


def data_path(scenario: Any) -> Path:
    """The scenario's data file (the packaged tosses when it names none)."""
    return Path(scenario.data) if scenario.data else data_mod.DEFAULT_PATH


_HASHES: dict[tuple[str, int, int], str] = {}


def data_sha256(path: Path) -> str:
    """SHA-256 of a data file (cached by path, size and modification time)."""
    st = path.stat()
    key = (str(path.resolve()), st.st_size, st.st_mtime_ns)
    if key not in _HASHES:
        _HASHES[key] = hashlib.sha256(path.read_bytes()).hexdigest()
    return _HASHES[key]


def _interval(dt: float) -> str:
    """``1/148 s`` for a whole rate, else the seconds."""
    rate = 1.0 / dt
    return f"1/{round(rate)} s" if abs(rate - round(rate)) <= 1e-6 * rate else f"{dt:.6g} s"


def with_timestep(scenario: Any, timestep_s: float | None) -> tuple[Any, str]:
    """(the scenario with the substeps a given step maps to, where the step comes from)."""
    if timestep_s is None:
        dt = scenario.sample_dt_s
        every = f"the {_interval(dt)}" if dt is not None else "each toss's"
        return scenario, (f"protocol: 1/{scenario.substeps} of {every} sample interval"
                          + (" (DAIR's)" if scenario.substeps == 10 and dt == SAMPLE_DT_S
                             else ""))
    if not (isinstance(timestep_s, int | float) and math.isfinite(timestep_s)
            and timestep_s > 0):
        raise ValueError(f"timestep = {timestep_s!r}: must be > 0 (s)")
    if scenario.sample_dt_s is None:
        raise ValueError(f"timestep = {timestep_s!r}: maps to substeps of the protocol's "
                         "sample interval; this scenario has sample_dt_s = none (each toss's "
                         "own): set sample_dt_s or substeps instead")
    substeps = max(1, round(scenario.sample_dt_s / timestep_s))
    step = scenario.sample_dt_s / substeps
    exact = abs(step - timestep_s) <= 1e-9 * timestep_s
    return replace(scenario, substeps=substeps), (
        "given" if exact else f"given {timestep_s:g} s, rounded to 1/{substeps} of the "
        f"{_interval(scenario.sample_dt_s)} sample interval")


@functools.lru_cache(maxsize=8)
def _prepared(scenario: Any) -> tuple[tuple[Any, ...], tuple[dict[str, Any], ...],
                                      tuple[int, ...], str, str]:
    df, source = frame_of(str(data_path(scenario)) if scenario.data else None)
    ids, split_name, starts, failed = prepared(df, scenario.selection, protocol_of(scenario))
    return tuple(starts), tuple(failed), tuple(ids), split_name, source


def starts(scenario: Any) -> tuple[list[Any], list[dict[str, Any]]]:
    """(each selected toss's replay start, a ``failed`` row per toss the protocol cannot
    start) of the scenario (cached per scenario: a frozen dataclass)."""
    got = _prepared(scenario)
    return list(got[0]), [dict(r) for r in got[1]]


def step_s(scenario: Any) -> float:
    """The engine step (s) when no toss could start (the protocol's, else the first toss's
    median sample interval over the substeps)."""
    from impactbench.cube_tosses.protocol import sample_dt

    protocol = protocol_of(scenario)
    if protocol.sample_dt_s is not None:
        return protocol.sample_dt_s / protocol.substeps
    df, _ = frame_of(str(data_path(scenario)) if scenario.data else None)
    ids = select(df, scenario.selection)
    return sample_dt(next(data_mod.tosses(df, ids[:1])).t, protocol) / protocol.substeps


def box_of(scenario: Any) -> Box:
    """The scenario's cube as the engines build it."""
    return Box(scenario.half_width_m, scenario.mass_kg, scenario.inertia_kg_m2)


_WHY_NO_PARAMS = {
    "default": "sets no engine parameters (the engine's own contact)",
    "tuned": "takes its parameters from the tuned file (--tuned FILE)",
    "native": "maps the reference model's fitted contact into the engine's parameters",
    "injected": "applies the reference model's corner forces (the engine's contact off)",
}
"""Why a mode other than ``custom`` takes no engine parameters (its one-line error)."""


def engine_parameters(engine: str, scenario: Any, mode: str,
                      params: Mapping[str, Any] | None, tuned: Mapping[str, Any] | None
                      ) -> dict[str, Any]:
    """The engine parameters a replay sets: none in ``default`` and ``injected`` modes; in
    ``custom`` mode the published set ``params["param_set"]`` (:data:`~impactbench.engines.
    cube_toss.PARAM_SETS`) overlaid with the other keys; in ``tuned`` mode the fitted ones; in
    ``native`` mode the reference model's contact mapped into the engine for the scenario's
    cube. One-line ValueError for a set the engine lacks or a custom run without any."""
    from impactbench.engines.cube_toss import PARAM_SETS

    given = dict(params or {})
    if mode != "custom" and given:
        name = given.get("param_set")
        what = f"param-set = {name!r}" if name is not None else f"param = {next(iter(given))!r}"
        raise ValueError(f"{what}: {mode} mode {_WHY_NO_PARAMS.get(mode, '')}; use --mode "
                         "custom to set engine parameters")
    if mode == "tuned":
        if not tuned:
            raise ValueError("tuned: tuned mode needs the fitted parameters (a tuned file)")
        return dict(tuned)
    if mode == "native":
        from impactbench.cube_tosses.model_modes import native_parameters

        return native_parameters(engine, None, box_of(scenario))
    if mode != "custom":
        return {}
    params = dict(params or {})
    name = params.pop("param_set", None)
    sets = PARAM_SETS.get(engine, {})
    if name is None and not params:
        raise ValueError(f"mode = 'custom': needs --param-set ({', '.join(sets) or 'none for '}"
                         f"{'' if sets else engine}) or --param KEY=VALUE (the engine's board./"
                         "cube. keys)")
    if name is not None and name not in sets:
        import difflib

        hint = difflib.get_close_matches(str(name), list(sets), n=1)
        raise ValueError(f"param-set = {name!r}: {engine} has "
                         f"{', '.join(sets) or 'no parameter sets'}"
                         + (f" (did you mean {hint[0]!r}?)" if hint else ""))
    return (dict(sets[name]) if name is not None else {}) | params


def injected_law(scenario: Any) -> Any:
    """The reference model's fitted contact (``injected`` mode's law: its corner forces)."""
    from impactbench.cube_tosses.model_modes import load_model

    return load_model()


# ------------------------------------------------------------------------------ the spec's hooks


def _per_toss(record: Any, scenario: Any) -> list[dict[str, Any]]:
    """Each toss's row: its errors against the measurement (the replayed ones) or why it
    failed, in the selection's order (kept on the record: metrics and details share it)."""
    if "per_toss" not in record.meta:
        protocol = protocol_of(scenario)
        got, _, ids, _, _ = _prepared(scenario)
        poses = record.meta.get("poses", {})
        rows = [{"status": "ok", **toss_errors(s, *poses[int(s.toss)], protocol)}
                for s in got if int(s.toss) in poses]
        rows += [dict(r) for r in record.meta.get("failed_tosses", [])]
        outcome(rows, list(ids))
        record.meta["per_toss"] = rows
    return record.meta["per_toss"]


def record_metrics(record: Any, scenario: Any) -> dict[str, Any]:
    """Over the replayed tosses: the median, quartiles and mean of each toss's time-mean
    position error |Δp|/(2h) and rotation error (degrees)."""
    return summarize(_per_toss(record, scenario))


def details(record: Any, scenario: Any, mode: str) -> dict[str, Any]:
    """What a replay's run object carries besides the metrics: ``split``, ``tosses``,
    ``failed`` (ids), ``per_toss``, ``protocol``, ``engine_setup`` (with the native mapping in
    ``native`` mode), ``data``, ``substeps``, ``box`` and a note when tuned, native or injected
    runs replay training tosses (not held out)."""
    rows = _per_toss(record, scenario)
    _, ids, split_name, source = _prepared(scenario)[1:]
    _, failed = outcome(rows, list(ids))
    setup = dict(record.meta.get("engine_setup", {}))
    if mode == "native":
        from impactbench.cube_tosses.model_modes import native_mapping

        setup["native"] = native_mapping(record.meta.get("engine", ""), None,
                                         box_of(scenario)).describe()
    out = {"param_set": record.meta.get("param_set"),
           "split": split_name, "tosses": len(rows), "failed": failed, "per_toss": rows,
           "protocol": protocol_of(scenario).describe(), "engine_setup": setup,
           "data": source, "substeps": scenario.substeps, "box": _box_of(scenario),
           "elapsed_s": record.meta.get("replay_s", math.nan)}
    out["tosses_per_s"] = (len(rows) - len(failed)) / out["elapsed_s"] \
        if out["elapsed_s"] > 0 else math.nan
    if mode in ("native", "injected"):
        import impactbench.cube_tosses.reference_model as reference_model

        out["model_file"] = str(reference_model.FITTED_PATH)
    if mode in ("tuned", "native", "injected") and not scenario.data \
            and scenario.selection != "test":
        seen = len(data_mod.split([int(r["toss"]) for r in rows], "train"))
        what = ("the parameters were fitted on" if mode == "tuned" else
                "the reference model's fit drew on")
        if seen:
            out["note"] = (f"{seen} of the {len(rows)} tosses are training tosses {what} "
                           "(not held out)")
    return out


def errors(run: Mapping[str, Any], metrics: Mapping[str, Any]) -> dict[str, float]:
    """The errors a gate and a table read: the metrics themselves (they are errors against the
    measurement), NaN unless every selected toss replayed."""
    whole = run.get("status") == "ok" and not run.get("failed")
    return {k: (float(v) if whole else math.nan) for k, v in metrics.items()}


def key_inputs(engine: str, scenario: Any, mode: str) -> dict[str, Any]:
    """What a replay's store key holds beside the run's settings: the data file's SHA-256 and,
    in ``native`` and ``injected`` modes, the fitted reference model's (and in ``native`` mode
    the parameters its contact maps to in ``engine``)."""
    out: dict[str, Any] = {"data_sha256": data_sha256(data_path(scenario))}
    if mode == "native":
        from impactbench.cube_tosses.model_modes import NATIVE_ENGINES, native_parameters

        if engine in NATIVE_ENGINES:  # (another engine's run is unsupported: nothing mapped)
            out["mapped"] = native_parameters(engine, None, box_of(scenario))
    if mode in ("native", "injected"):
        import impactbench.cube_tosses.reference_model as reference_model

        out["model_sha256"] = hashlib.sha256(reference_model.FITTED_PATH.read_bytes()
                                             ).hexdigest()
    return out


def tuned_settings(engine: str, scenario: Any, tuned_file: str | Path | None = None
                   ) -> tuple[dict[str, Any] | None, dict[str, Any] | None]:
    """(parameters, provenance) of ``engine``'s cube-toss tuned file (the packaged one unless
    ``tuned_file``): provenance in the shape :func:`impactbench.tuned.binding_mismatch` reads
    (engine, scenario, the fields it binds, ``file``) plus ``mismatch``, why it does not apply
    to ``scenario`` ("" when it does; with no packaged file, that none exists and the command
    that fits one)."""
    params, path, why = tuned_binding(engine, scenario, tuned_file)
    return params, {"engine": engine, "scenario": type(scenario).name, "file": str(path),
                    "mismatch": why}


def tuned_binding(engine: str, scenario: Any, tuned_file: str | Path | None = None
                  ) -> tuple[dict[str, Any], str, str]:
    """(parameters, the file, why it does not apply or "") of ``engine``'s tuned
    file for ``scenario``: the packaged one (``impactbench/data/tuned/cube_toss/<engine>.toml``)
    unless ``tuned_file``. A file applies to the engine it was fitted in, at the engine step
    and for the cube half-width of its protocol (``[provenance.protocol]``: the contact
    parameters of a stepped engine are fitted for its step). A given file that does not
    exist or is not a tuned file is a one-line ValueError; a missing packaged one a reason."""
    import tomllib

    from impactbench.cube_tosses.tune import load_tuned, tuned_path

    path = Path(tuned_file) if tuned_file is not None else tuned_path(engine)
    if not path.is_file():
        if tuned_file is not None:
            raise ValueError(f"tuned = {str(tuned_file)!r}: no such file")
        return {}, str(path), (f"no packaged tuned file for {engine} (fit one: "
                                   f"impactbench tune --scenario cube-toss --engine {engine})")
    try:
        doc = tomllib.loads(path.read_text())
        params = load_tuned(engine, path)
    except (tomllib.TOMLDecodeError, ValueError, UnicodeDecodeError) as exc:
        raise ValueError(f"tuned = {str(path)!r}: not a cube-toss tuned file "
                         f"({str(exc).splitlines()[0]})") from None
    prov = doc.get("provenance", {})
    proto = prov.get("protocol", {})
    if prov.get("scenario") != "cube-toss" or prov.get("engine") != engine:
        return params, str(path), (f"tuned file {path.name} was fitted for "
                                        f"{prov.get('engine')!r} on {prov.get('scenario')!r}, "
                                        f"not {engine!r} on 'cube-toss'")
    want = protocol_of(scenario).describe()
    for key, what, unit in (("step_s", "engine step", " s"),
                            ("half_width_m", "cube half-width", " m")):
        a, b = proto.get(key), want.get(key)
        if a is None or b is None:
            if a != b:
                return params, str(path), (f"tuned file {path.name}: fitted with "
                                                f"{key} = {a}, this run has {b}")
            continue
        if not math.isclose(float(a), float(b), rel_tol=1e-9):
            return params, str(path), (f"tuned file {path.name} was fitted at {what} "
                                            f"{float(a):.6g}{unit}, this run has "
                                            f"{float(b):.6g}{unit}")
    return params, str(path), ""


def _box_of(scenario: Any) -> dict[str, float]:
    return {"half_width_m": scenario.half_width_m, "mass_kg": scenario.mass_kg,
            "inertia_kg_m2": scenario.inertia_kg_m2}


def _stored(store: Any, key: str, fresh: bool) -> dict[str, Any] | None:
    """A replay kept in ``store`` under ``key`` (None when absent or ``fresh``)."""
    if store is None or fresh:
        return None
    got = store.get([key])
    if key not in got:
        return None
    stored = dict(got[key][0])
    stored.pop("rel_error", None)
    return stored


def _keep(store: Any, key: str, inputs: Mapping[str, Any], engine: str, mode: str,
          scenario: Any, result: Mapping[str, Any]) -> None:
    """Keep a replay's result in ``store`` (a replay has no relative errors: NaN)."""
    if store is None:
        return
    job = {"engine": engine, "mode": mode, "scenario": type(scenario).name, "point": (),
           "study": "replay"}
    store.put([(key, inputs, job, {**result, "rel_error": dict.fromkeys(METRIC_KEYS, math.nan)},
                {})])


def _message(out: Mapping[str, Any]) -> str:
    failed = [r for r in out.get("per_toss", []) if r.get("status") != "ok"]
    if not failed:
        return ""
    ids = ", ".join(str(r["toss"]) for r in failed[:5]) + (" …" if len(failed) > 5 else "")
    return f"{len(failed)} of {out['tosses']} tosses failed ({ids}): {failed[0].get('error')}"


MODEL_LABEL = "reference model"
"""How the report names the reference model's row (:mod:`~impactbench.cube_tosses.
reference_model`: a rigid box with compliant corners, fitted on training tosses)."""


def model_run(scenario: Any, *, store: Any = None, fresh: bool = False,
              computed: Any = None) -> dict[str, Any]:
    """The reference model's replay of ``scenario``'s tosses with its packaged fit (the model
    floor of the comparison: what a converged continuous contact model reaches, no time
    step in the way): :func:`model_replay`'s dict, kept in ``store`` keyed by
    :func:`model_key`. ``computed``: that replay already under way elsewhere (an object
    whose ``result()`` is its dict: the report starts it in a process of its own while the
    engines run, :meth:`~impactbench.scenarios.spec.ScenarioSpec.report_background`), used
    when the store has none."""
    key = inputs = None
    if store is not None:
        key, inputs = model_key(scenario)
        if (stored := _stored(store, key, fresh)) is not None:
            return stored
    result = computed.result() if computed is not None else model_replay(scenario)
    if key is not None:
        import impactbench.cube_tosses.reference_model as model

        _keep(store, key, inputs, model.ENGINE, "fitted", scenario, result)
    return result


def model_stored(scenario: Any, store: Any) -> bool:
    """Whether ``store`` holds the reference model's replay of ``scenario``."""
    return store is not None and _stored(store, model_key(scenario)[0], False) is not None


def model_key(scenario: Any) -> tuple[str, dict[str, Any]]:
    """The store key and inputs of the reference model's replay of ``scenario``: the box,
    data, selection, protocol, the fitted file's SHA-256, scipy's and impactbench's versions."""
    from importlib import metadata

    import impactbench.cube_tosses.reference_model as model
    from impactbench.store import _canonical, impactbench_version, run_key

    inputs = _canonical({"engine": model.ENGINE,
                         "engine_version": f"scipy {metadata.version('scipy')}",
                         "impactbench_version": impactbench_version(),
                         "scenario": type(scenario).name, "physics": scenario.to_dict(),
                         "mode": "fitted", "data_sha256": data_sha256(data_path(scenario)),
                         "fitted_sha256": hashlib.sha256(
                             model.FITTED_PATH.read_bytes()).hexdigest()})
    return run_key(inputs), inputs


def model_replay(scenario: Any) -> dict[str, Any]:
    """The reference model's replay of ``scenario``'s tosses, computed (no store):
    :func:`~impactbench.cube_tosses.reference_model.replay_reference`'s dict plus
    ``message``, ``engine_version`` (scipy's), ``timestep_s`` (none: adaptive), ``box`` and
    ``wall_s``. A module-level function of a picklable scenario: it runs in another process."""
    from importlib import metadata

    import impactbench.cube_tosses.reference_model as model

    path = data_path(scenario)
    t0 = time.perf_counter()
    out = model.replay_reference(scenario.selection, None, str(path) if scenario.data else None,
                                 protocol_of(scenario), box=box_of(scenario))
    return {**out, "message": _message(out),
            "engine_version": f"scipy {metadata.version('scipy')}",
            "timestep_s": None, "timestep_source": "adaptive (scipy LSODA)",
            "substeps": None, "box": _box_of(scenario), "wall_s": time.perf_counter() - t0}


def measurement(scenario: Any) -> dict[str, Any]:
    """What the selected measurement holds: the data file, the selection and its ids, the
    split's sizes in the file, samples, the sample interval, the tosses' initial speed and spin
    and the resting height (medians), the box, and the metrics' reference values (0: the
    measurement agrees with itself; a replay's metrics are absolute errors against it)."""
    path = data_path(scenario)
    df = data_mod.load(path)
    ids = select(df, scenario.selection)
    every = data_mod.toss_ids(df)
    tosses = list(data_mod.tosses(df, ids))
    samples = np.array([len(t) for t in tosses])
    dt = np.concatenate([np.diff(t.t) for t in tosses])
    return {
        "data": str(path) if scenario.data else "packaged: impactbench/data/cube_tosses/"
                                                 + path.name,
        "data_sha256": data_sha256(path),
        "selection": scenario.tosses, "tosses": len(ids), "ids": ids,
        "tosses_in_file": len(every), "train_in_file": len(data_mod.split(every, "train")),
        "test_in_file": len(data_mod.split(every, "test")),
        "samples": int(samples.sum()), "samples_per_toss_median": float(np.median(samples)),
        "sample_dt_s_median": float(np.median(dt)),
        "duration_s_median": float(np.median([t.t[-1] - t.t[0] for t in tosses])),
        "initial_speed_m_s_median": float(np.median([np.linalg.norm(t.v[0]) for t in tosses])),
        "initial_spin_rad_s_median": float(np.median([np.linalg.norm(t.w_body[0])
                                                      for t in tosses])),
        "rest_height_m_median": float(np.median([t.p[-1, 2] for t in tosses])),
        **_box_of(scenario),
        # the measurement's own errors: what a replay's metrics are compared with
        **dict.fromkeys(METRIC_KEYS, 0.0),
    }


# ------------------------------------------------------------------------------ trajectories


def trajectories(engine: str, scenario: Any, mode: str, toss_ids: list[int], *,
                 params: Mapping[str, Any] | None = None,
                 tuned: Mapping[str, Any] | None = None) -> list[dict[str, Any]]:
    """Measured and simulated trajectories of ``toss_ids`` (for plots), replayed through the
    engine's adapter: per toss ``toss``, ``t_s`` (from the replay's start),
    ``z_ref_m``/``z_sim_m`` (the centre's height) and ``angle_ref_deg``/``angle_sim_deg`` (the
    rotation from the start orientation)."""
    from impactbench.engines.base import RunSettings, run_safely

    if not toss_ids:
        return []
    picked = replace(scenario, tosses=",".join(str(i) for i in toss_ids))
    rec = run_safely(engine, picked, mode, RunSettings(params=dict(params) if params else None,
                                                        tuned=dict(tuned) if tuned else None))
    return trajectories_of_record(picked, rec, toss_ids)


def trajectories_of_record(scenario: Any, record: Any, toss_ids: list[int]
                           ) -> list[dict[str, Any]]:
    """:func:`trajectories` of ``toss_ids`` from a replay's record (its ``poses``), in the
    order given; a toss the record did not replay is left out."""
    poses = record.meta.get("poses", {})
    by_id = {int(s.toss): s for s in starts(scenario)[0]}
    out = []
    for toss in toss_ids:
        s = by_id.get(int(toss))
        if s is None or int(toss) not in poses:
            continue
        p, q = poses[int(toss)]
        out.append({"toss": s.toss, "t_s": s.t_ref - s.t_ref[0],
                    "z_ref_m": s.p_ref[:, 2], "z_sim_m": p[:, 2],
                    "angle_ref_deg": np.degrees(rotation_angle(s.q_ref[0], s.q_ref)),
                    "angle_sim_deg": np.degrees(rotation_angle(q[0], q))})
    return out


def picks(per_toss: list[dict[str, Any]]) -> list[tuple[str, int]]:
    """(label, toss) of the best, the median and the worst toss by position error (each toss
    once)."""
    ok = sorted((r for r in per_toss if r.get("status", "ok") == "ok"),
                key=lambda r: float(r["position_error"]))
    if not ok:
        return []
    chosen = [("best", ok[0]), ("median", ok[len(ok) // 2]), ("worst", ok[-1])]
    seen: set[int] = set()
    return [(label, int(r["toss"])) for label, r in chosen
            if not (int(r["toss"]) in seen or seen.add(int(r["toss"])))]


TRAJECTORY_SERIES = ("t_s", "z_ref_m", "z_sim_m", "angle_ref_deg", "angle_sim_deg")
"""The series of one toss's trajectories (:func:`trajectories`), s, m and degrees."""


def kept_history(record: Any, run: Mapping[str, Any], scenario: Any) -> dict[str, Any]:
    """What a replay the report plots keeps: the trajectories (:func:`trajectories_of_record`)
    of its best, median and worst toss (:func:`picks`), as named arrays — ``picks`` (the toss
    ids), ``sizes`` (samples per toss) and each of :data:`TRAJECTORY_SERIES` concatenated over
    the picks ({} for a replay without numbers)."""
    if not run.get("per_toss") or not record.meta.get("poses"):
        return {}
    got = trajectories_of_record(scenario, record, [t for _, t in picks(run["per_toss"])])
    if not got:
        return {}
    return {"picks": np.array([float(g["toss"]) for g in got]),
            "sizes": np.array([float(len(g["t_s"])) for g in got]),
            **{name: np.concatenate([np.asarray(g[name], dtype=float) for g in got])
               for name in TRAJECTORY_SERIES}}


def trajectories_of_history(history: Mapping[str, Any]) -> list[dict[str, Any]]:
    """:func:`kept_history`'s arrays back as :func:`trajectories`' list ([] for none)."""
    if "picks" not in history or "sizes" not in history:
        return []
    ends = np.cumsum(np.asarray(history["sizes"], dtype=int))
    out = []
    for toss, stop, start in zip(history["picks"], ends, np.r_[0, ends[:-1]], strict=True):
        out.append({"toss": int(toss), **{name: np.asarray(history[name][start:stop])
                                          for name in TRAJECTORY_SERIES}})
    return out
