"""The cube-toss scenario's engine runs: the spec's ``replay`` hook (:func:`run`), the
measurement summary its reference shows (:func:`measurement`) and the trajectories the report
draws (:func:`trajectories`).

A run replays the scenario's tosses (:class:`~impactbench.scenarios.cube_toss.CubeToss`: box,
data, selection, protocol options) in one engine through
:func:`~impactbench.cube_tosses.replay.replay` and returns its dict with a few keys more
(``message``, ``engine_version``, ``timestep_s``, ``timestep_source``, ``substeps``, ``box``,
``wall_s``). Modes: ``default`` (the engine's own contact) and ``custom`` (a published
parameter set such as ``dair2022`` and/or engine parameters by the replay's own names,
``board.``/``cube.``-prefixed) and ``tuned`` (the engine's parameters fitted to the training
tosses, :mod:`~impactbench.cube_tosses.tune`: the packaged tuned file or ``tuned_file``; it
applies only at the step and to the cube half-width it was fitted for, else the run is
``unsupported`` naming the difference), ``native`` (the reference model's fitted corner contact
mapped into the engine's own parameters, :func:`~impactbench.cube_tosses.model_modes.
native_mapping`: custom mode with the mapped parameters, which the result's ``params`` and
``engine_setup["native"]`` record with the mapping's inputs) and ``injected`` (the engine's
box–board contact off and the model's corner forces applied at every step; ``unsupported`` in
MJX and Newton, which step in compiled batches: :mod:`~impactbench.cube_tosses.model_modes`).
The 2D engines (pymunk, Box2D) and engines without a cube replay are ``unsupported``.

Step: the protocol's, ``sample_dt_s / substeps`` (DAIR: 1/148 s / 10). A given ``timestep_s``
sets ``substeps = max(1, round(sample_dt_s / timestep_s))``: the engine steps at the nearest
step that divides the sample interval (the run says which, ``timestep_s`` and
``timestep_source``), since the replay records the pose at every sample.

Results store: with ``store``, a run is looked up by
:func:`~impactbench.store.run_inputs` of (engine, scenario, scenario object, mode,
:class:`ReplaySettings`): the engine and its version, impactbench's version, the scenario's
fields (box, data path, selection, protocol), the mode, the parameter set, the engine
parameters and the SHA-256 of the data file (``native``: the mapped parameters and the
fitted model file's SHA-256; ``injected``: the model's parameters and that SHA-256); a stored
run is returned as stored.

The box: DAIR's cube by default (h, m, I: :class:`~impactbench.cube_tosses.protocol.Box`); a
box of the user's is passed to :func:`~impactbench.cube_tosses.engines.make`
(:func:`box_of`) and its inertia read back from the built engine (:func:`_check_box`).
"""

from __future__ import annotations

import hashlib
import math
import os
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

import impactbench.cube_tosses.data as data_mod
import impactbench.cube_tosses.engines as engines_mod
from impactbench.cube_tosses.protocol import (
    SAMPLE_DT_S,
    Box,
    Protocol,
    prepare,
    rotation_angle,
)
from impactbench.cube_tosses.replay import engine_parameters, replay, select

MODES = ("default", "custom", "tuned", "native", "injected")
"""The modes a cube replay has."""

TWO_D = {
    "pymunk": "pymunk is a 2D engine (bodies move in a plane with one rotation angle): a cube "
              "tumbling in 3D cannot be expressed",
    "box2d": "Box2D is a 2D engine (bodies move in a plane with one rotation angle): a cube "
             "tumbling in 3D cannot be expressed",
}
"""Engines the tosses cannot run on, and why."""

METRIC_KEYS = ("position_error_median", "position_error_q1", "position_error_q3",
               "position_error_mean", "rotation_error_deg_median", "rotation_error_deg_q1",
               "rotation_error_deg_q3", "rotation_error_deg_mean")


@dataclass(frozen=True)
class ReplaySettings:
    """What determines a replay besides the engine, the scenario object and the mode (hashed
    into its store key with them)."""

    param_set: str | None = None
    params: dict[str, Any] = field(default_factory=dict)
    data_sha256: str = ""
    tuned_sha256: str = ""
    """The tuned file's SHA-256 (tuned mode) or the fitted reference model's (native,
    injected)."""


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


# ------------------------------------------------------------------------------ the box


def box_of(scenario: Any) -> Box:
    """The scenario's cube as the engines build it."""
    return Box(scenario.half_width_m, scenario.mass_kg, scenario.inertia_kg_m2)


def _dair_box(scenario: Any) -> bool:
    from impactbench.cube_tosses.protocol import HALF_WIDTH_M, INERTIA_KG_M2, MASS_KG

    return (scenario.half_width_m, scenario.mass_kg, scenario.inertia_kg_m2) == (
        HALF_WIDTH_M, MASS_KG, INERTIA_KG_M2)


# ------------------------------------------------------------------------------ settings


def _unsupported_reason(engine: str, mode: str) -> str:
    if engine in TWO_D:
        return TWO_D[engine]
    if engine not in engines_mod.ENGINES:
        return (f"no cube-toss replay for {engine} yet (replays: "
                f"{', '.join(engines_mod.ENGINES)})")
    if mode not in MODES:
        return f"mode {mode}: no such cube-toss mode (available: {', '.join(MODES)})"
    if mode == "injected":
        from impactbench.cube_tosses.model_modes import injected_reason

        why = injected_reason(engine)
        return f"mode injected in {engine}: {why}" if why else ""
    return ""


def check(engine: str, mode: str, param_set: str | None = None,
          params: Mapping[str, Any] | None = None) -> str:
    """Validate a run's settings: "" when the run can go, the reason when it is
    ``unsupported``; a one-line ValueError for bad input (a parameter set in default mode, an
    unknown set with the valid names and a "did you mean")."""
    why = _unsupported_reason(engine, mode)
    if why:
        return why
    if mode == "tuned" and (param_set is not None or params):
        what = f"param-set = {param_set!r}" if param_set is not None else \
            f"param = {next(iter(params))!r}"
        raise ValueError(f"{what}: tuned mode takes its parameters from the tuned file "
                         "(--tuned FILE); use --mode custom to set them")
    if mode in ("default", "native", "injected") and (param_set is not None or params):
        what = f"param-set = {param_set!r}" if param_set is not None else \
            f"param = {next(iter(params))!r}"
        how = {"default": "sets no engine parameters (the engine's own contact)",
               "native": "maps the reference model's fitted contact into the engine's "
                         "parameters",
               "injected": "applies the reference model's corner forces (the engine's "
                           "contact off)"}[mode]
        raise ValueError(f"{what}: {mode} mode {how}; use --mode custom")
    sets = engines_mod.PARAM_SETS.get(engine, {})
    if mode == "custom" and param_set is None and not params:
        raise ValueError(f"mode = 'custom': needs --param-set ({', '.join(sets) or 'none for '}"
                         f"{'' if sets else engine}) or --param KEY=VALUE (the engine's "
                         "board./cube. keys)")
    if param_set is not None and param_set not in sets:
        import difflib

        hint = difflib.get_close_matches(str(param_set), list(sets), n=1)
        raise ValueError(f"param-set = {param_set!r}: {engine} has "
                         f"{', '.join(sets) or 'no parameter sets'}"
                         + (f" (did you mean {hint[0]!r}?)" if hint else ""))
    return ""


# ------------------------------------------------------------------------------ tuned files


def tuned_binding(engine: str, scenario: Any, tuned_file: str | Path | None = None
                  ) -> tuple[dict[str, Any], str, str, str]:
    """(parameters, the file, its SHA-256, why it does not apply or "") of ``engine``'s tuned
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
        return {}, str(path), "", (f"no packaged tuned file for {engine} (fit one: "
                                   f"impactbench tune --scenario cube-toss --engine {engine})")
    try:
        doc = tomllib.loads(path.read_text())
        params = load_tuned(engine, path)
    except (tomllib.TOMLDecodeError, ValueError, UnicodeDecodeError) as exc:
        raise ValueError(f"tuned = {str(path)!r}: not a cube-toss tuned file "
                         f"({str(exc).splitlines()[0]})") from None
    sha = hashlib.sha256(path.read_bytes()).hexdigest()
    prov = doc.get("provenance", {})
    proto = prov.get("protocol", {})
    if prov.get("scenario") != "cube-toss" or prov.get("engine") != engine:
        return params, str(path), sha, (f"tuned file {path.name} was fitted for "
                                        f"{prov.get('engine')!r} on {prov.get('scenario')!r}, "
                                        f"not {engine!r} on 'cube-toss'")
    want = protocol_of(scenario).describe()
    for key, what, unit in (("step_s", "engine step", " s"),
                            ("half_width_m", "cube half-width", " m")):
        a, b = proto.get(key), want.get(key)
        if a is None or b is None:
            if a != b:
                return params, str(path), sha, (f"tuned file {path.name}: fitted with "
                                                f"{key} = {a}, this run has {b}")
            continue
        if not math.isclose(float(a), float(b), rel_tol=1e-9):
            return params, str(path), sha, (f"tuned file {path.name} was fitted at {what} "
                                            f"{float(a):.6g}{unit}, this run has "
                                            f"{float(b):.6g}{unit}")
    return params, str(path), sha, ""


# ------------------------------------------------------------------------------ the hook


def _empty(engine: str, mode: str, param_set: str | None, status: str, message: str,
           scenario: Any, timestep_s: float | None, source: str) -> dict[str, Any]:
    return {"status": status, "message": message, "engine": engine, "engine_version": "",
            "mode": mode, "param_set": param_set, "split": None, "tosses": 0, "failed": [],
            **dict.fromkeys(METRIC_KEYS, math.nan), "per_toss": [],
            "timestep_s": timestep_s, "timestep_source": source,
            "substeps": scenario.substeps, "box": _box_of(scenario), "wall_s": math.nan}


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


def result_ids(out: Mapping[str, Any]) -> list[int]:
    """The toss ids a replay's result covers."""
    return [int(r["toss"]) for r in out.get("per_toss", [])]


def _message(out: Mapping[str, Any]) -> str:
    failed = [r for r in out.get("per_toss", []) if r.get("status") != "ok"]
    if not failed:
        return ""
    ids = ", ".join(str(r["toss"]) for r in failed[:5]) + (" …" if len(failed) > 5 else "")
    return f"{len(failed)} of {out['tosses']} tosses failed ({ids}): {failed[0].get('error')}"


def run(engine: str, scenario: Any, mode: str = "default", *, param_set: str | None = None,
        params: Mapping[str, Any] | None = None, timestep_s: float | None = None,
        store: Any = None, fresh: bool = False, check_only: bool = False,
        tuned_file: str | Path | None = None,
        progress: Callable[[int, int], None] | None = None) -> dict[str, Any] | str:
    """Replay ``scenario``'s tosses in ``engine`` (the spec's ``replay`` hook; module doc).

    Returns :func:`~impactbench.cube_tosses.replay.replay`'s dict plus ``message``,
    ``engine_version``, ``timestep_s`` (the engine step), ``timestep_source``, ``substeps``,
    ``box`` and ``wall_s`` (and in ``tuned`` mode ``tuned_file`` and ``params``); an
    ``unsupported`` or ``unavailable`` run object (NaN metrics, the reason in ``message``)
    for what cannot run here. ``check_only``: validate (one-line ValueError) and return why
    the run would be unsupported ("" when it can run), running nothing.
    """
    params = dict(params or {})
    scenario, source = with_timestep(scenario, timestep_s)
    if tuned_file is not None and mode != "tuned":
        raise ValueError(f"tuned = {str(tuned_file)!r}: --tuned needs --mode tuned "
                         f"(got {mode})")
    why = check(engine, mode, param_set, params)
    tuned = ("", "")
    key_params = params
    if mode == "tuned" and not why:
        params, *tuned, why = tuned_binding(engine, scenario, tuned_file)
        key_params = params
    if check_only:
        return why
    if mode in ("native", "injected") and not why:
        from impactbench.cube_tosses import reference_model
        from impactbench.cube_tosses.model_modes import native_parameters

        tuned = (str(reference_model.FITTED_PATH),
                 hashlib.sha256(reference_model.FITTED_PATH.read_bytes()).hexdigest())
        key_params = (native_parameters(engine, None, box_of(scenario)) if mode == "native"
                      else {"reference_model": reference_model.load_fitted().describe()})
    step = scenario.sample_dt_s / scenario.substeps if scenario.sample_dt_s else None
    if why:
        return _empty(engine, mode, param_set, "unsupported", why, scenario, step, source)
    from impactbench.engines.registry import DISABLE_ENV

    if engine in {x.strip() for x in os.environ.get(DISABLE_ENV, "").split(",")}:
        return _empty(engine, mode, param_set, "unavailable",
                      f"engine {engine!r} is disabled by {DISABLE_ENV}", scenario, step, source)
    key = inputs = None
    path = data_path(scenario)
    if store is not None:
        from impactbench.store import run_inputs, run_key

        settings = ReplaySettings(param_set, key_params, data_sha256(path), tuned[1])
        inputs = run_inputs(engine, type(scenario).name, scenario, mode, settings)
        key = run_key(inputs)
        if (stored := _stored(store, key, fresh)) is not None:
            return stored
    t0 = time.perf_counter()
    try:
        out = replay(engine, mode, tosses=scenario.selection, param_set=param_set,
                     data=str(path) if scenario.data else None, params=params or None,
                     protocol=protocol_of(scenario), progress=progress, box=box_of(scenario))
    except ImportError:
        from impactbench.engines.base import EngineUnavailable

        return _empty(engine, mode, param_set, "unavailable", str(EngineUnavailable(engine)),
                      scenario, step, source)
    except (RuntimeError, OSError) as exc:
        return _empty(engine, mode, param_set, "failed",
                      f"{type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''}",
                      scenario, step, source)
    setup = out.get("engine_setup") or {}
    if out["status"] == "unsupported":  # the replay's own refusal
        return _empty(engine, mode, param_set, "unsupported",
                      str(out.get("reason") or "unsupported"), scenario, step, source)
    _check_box(scenario, engine, params, param_set, setup)
    result = {"status": out["status"], "message": _message(out), "engine": engine,
              "engine_version": str(setup.get("version", "")), **out,
              "timestep_s": setup.get("step_s", step), "timestep_source": source,
              "substeps": scenario.substeps, "box": _box_of(scenario),
              "wall_s": time.perf_counter() - t0}
    if mode in ("native", "injected"):
        result |= {"model_file": tuned[0], "params": key_params if mode == "native" else {}}
    if mode == "tuned":
        result |= {"tuned_file": tuned[0], "params": params}
    if mode in ("tuned", "native", "injected") and not scenario.data \
            and scenario.selection != "test":
        seen = len(data_mod.split(result_ids(out), "train"))
        what = ("the parameters were fitted on" if mode == "tuned" else
                "the reference model's fit drew on")
        if seen:
            result["message"] = "; ".join(x for x in (
                result["message"], f"{seen} of the {out['tosses']} tosses are training "
                f"tosses {what} (not held out)") if x)
    _keep(store, key, inputs, engine, mode, scenario, result)
    return result


def _check_box(scenario: Any, engine: str, params: Mapping[str, Any],
               param_set: str | None, setup: Mapping[str, Any]) -> None:
    """A box of the user's must have reached the engine (its inertia read back)."""
    if _dair_box(scenario):
        return
    eparams = dict(engines_mod.PARAM_SETS.get(engine, {}).get(param_set, {})) | dict(params)
    got = setup.get("cube_inertia_kg_m2")
    if "cube.inertia" in eparams or not isinstance(got, int | float):
        return
    if not math.isclose(float(got), scenario.inertia_kg_m2, rel_tol=1e-5):
        raise RuntimeError(f"{engine}: built the cube with I = {got:g} kg·m², not the given "
                           f"{scenario.inertia_kg_m2:g}: its replay ignores the box")


# ------------------------------------------------------------------------------ the model


MODEL_LABEL = "reference model"
"""How the report names the reference model's row (:mod:`~impactbench.cube_tosses.
reference_model`: a rigid box with compliant corners, fitted on training tosses)."""


def model_run(scenario: Any, *, store: Any = None, fresh: bool = False) -> dict[str, Any]:
    """The reference model's replay of ``scenario``'s tosses with its packaged fit (the model
    floor of the comparison: what a converged continuous contact model reaches, no time
    step in the way): :func:`~impactbench.cube_tosses.reference_model.replay_reference`'s
    dict plus ``message``, ``engine_version`` (scipy's), ``timestep_s`` (none: adaptive),
    ``box`` and ``wall_s``; kept in ``store`` keyed by the box, data, selection, protocol,
    the fitted file's SHA-256 and impactbench's version."""
    from importlib import metadata

    from impactbench.cube_tosses import reference_model as model
    from impactbench.store import _canonical, impactbench_version, run_key

    path = data_path(scenario)
    version = f"scipy {metadata.version('scipy')}"
    key = inputs = None
    if store is not None:
        inputs = _canonical({"engine": model.ENGINE, "engine_version": version,
                             "impactbench_version": impactbench_version(),
                             "scenario": type(scenario).name, "physics": scenario.to_dict(),
                             "mode": "fitted", "data_sha256": data_sha256(path),
                             "fitted_sha256": hashlib.sha256(
                                 model.FITTED_PATH.read_bytes()).hexdigest()})
        key = run_key(inputs)
        if (stored := _stored(store, key, fresh)) is not None:
            return stored
    t0 = time.perf_counter()
    out = model.replay_reference(scenario.selection, None, str(path) if scenario.data else None,
                                 protocol_of(scenario), box=box_of(scenario))
    result = {**out, "message": _message(out), "engine_version": version,
              "timestep_s": None, "timestep_source": "adaptive (scipy LSODA)",
              "substeps": None, "box": _box_of(scenario), "wall_s": time.perf_counter() - t0}
    _keep(store, key, inputs, model.ENGINE, "fitted", scenario, result)
    return result


# ------------------------------------------------------------------------------ measurement


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
                 param_set: str | None = None, params: Mapping[str, Any] | None = None
                 ) -> list[dict[str, Any]]:
    """Measured and simulated trajectories of ``toss_ids`` (for plots): per toss ``toss``,
    ``t_s`` (from the replay's start), ``z_ref_m``/``z_sim_m`` (the centre's height) and
    ``angle_ref_deg``/``angle_sim_deg`` (the rotation from the start orientation)."""
    protocol = protocol_of(scenario)
    box = box_of(scenario)
    eparams = engine_parameters(engine, mode, param_set, params, box=box)
    df = data_mod.load(data_path(scenario))
    starts = [prepare(t, protocol) for t in data_mod.tosses(df, toss_ids)]
    if not starts:
        return []
    out = []
    law = None
    if mode == "injected":
        from impactbench.cube_tosses.reference_model import load_fitted

        law = load_fitted()
    sim = engines_mod.make(engine, eparams, starts[0].step_s, protocol.board_z_m, box,
                           law=law)
    try:
        for s in starts:
            p, q = sim.run(s)
            out.append({"toss": s.toss, "t_s": s.t_ref - s.t_ref[0],
                        "z_ref_m": s.p_ref[:, 2], "z_sim_m": p[:, 2],
                        "angle_ref_deg": np.degrees(rotation_angle(s.q_ref[0], s.q_ref)),
                        "angle_sim_deg": np.degrees(rotation_angle(q[0], q))})
    finally:
        sim.close()
    return out
