"""The cube tosses replayed in impactbench's own contact model, and its fit to the data.

The model (:mod:`impactbench.reference.box_contact`): a rigid box with a compliant normal law
at each corner (Hunt–Crossley by default) and regularised Coulomb friction, integrated with
scipy to convergence. It is the *model floor* of the cube-toss comparison: how close a
continuous contact model gets to the measured tosses, with no time stepping in the way.

- :func:`simulate`: one toss from its :class:`~impactbench.cube_tosses.protocol.Start` — the
  engines' start (sample i0, DAIR's refitted initial velocity) — to the pose at every reference
  sample time t_ref − t_ref[0] (the true sample times; the engines round them to their step);
- :func:`replay_reference`: a split or ids replayed and scored as
  ``replay()`` (:mod:`~impactbench.cube_tosses.replays`) does (the same keys, ``engine =
  "reference"``), so the reference sits in the engines' table;
- :func:`fit`: nevergrad (``CMA`` by default, as :mod:`~impactbench.cube_tosses.tune`) over
  the normal law's stiffness, exponent and damping, μ and v_s (:data:`KNOBS`) on
  :data:`OBJECTIVE`, over training tosses only — by default the deterministic subset
  ``train[::3]`` (every third training toss by id, 123 of 367: a full-train fit takes ~3× as
  long, ~30 min on two cores). Its effect, measured with the packaged fit: on the 244 training
  tosses the fit did not see, the mean position error is 0.123 widths (median 0.098), on the
  123 it saw 0.128 (0.113), on the test split 0.134 (0.101) — the subset is no worse a sample
  than the rest; the file records the subset's and the whole training split's errors;
  :func:`write_fitted` writes ``impactbench/data/tuned/cube_toss/reference.toml`` with a
  ``[provenance]`` table (optimiser, budget, seed, train-ids hash, loss, scipy version,
  tolerances, the command that reproduces it); :func:`load_fitted` reads its parameters.

Command line::

    python -m impactbench.cube_tosses.reference_model --fit --budget 200 --out FILE
    python -m impactbench.cube_tosses.reference_model --replay [--tosses test] [--params FILE]

Knobs (the fit's search space, log-scaled but the exponent): ``stiffness`` is the corner's
secant stiffness at 1 mm, c·(1 mm)^(n−1) in N/m, so that it does not move with the exponent;
``damping`` is Hunt–Crossley's b (s/m; for ``kelvin-voigt-clipped``, d in N·s/m). The start
is the middle of each box (the geometric mean of a log knob).

Workers: ``workers`` > 1 replays the tosses of each evaluation in that many processes; the
results do not depend on it (each toss is integrated alone).
"""

from __future__ import annotations

import argparse
import math
import os
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from concurrent.futures import Executor, ProcessPoolExecutor
from dataclasses import dataclass, field
from importlib import metadata
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

import impactbench.cube_tosses.data as data_mod
from impactbench.cube_tosses.protocol import Protocol, Start, prepare, summarize, toss_errors
from impactbench.cube_tosses.selection import RESULT_KEYS, frame_of, outcome, prepared
from impactbench.cube_tosses.tune import (
    FAILED_TOSS_ERROR,
    TUNED_DIR,
    Knob,
    data_hash,
    ids_hash,
    search,
    toml_ready,
    training_ids,
)
from impactbench.reference import box_contact as bc
from impactbench.reference.box_contact import DAIR_CUBE, Box, BoxContactParams

FITTED_PATH = TUNED_DIR / "reference.toml"
"""The packaged fit (:func:`load_fitted`)."""
ENGINE = "reference"
OBJECTIVE = ("mean over the fitting tosses of the time-mean position error "
             "|p_sim - p_real| / (2h) (DAIR's protocol; a failed toss counts 10)")
X_REF_M = 1e-3
"""The penetration (m) at which the ``stiffness`` knob is the corner's secant stiffness."""
STRIDE = 3
"""The fit's default subset: every ``STRIDE``-th training toss by id."""
SEED = 0
OPTIMIZER = "CMA"

KNOBS: dict[str, tuple[Knob, ...]] = {
    "hunt-crossley": (
        Knob("stiffness", 1e2, 1e6, unit="N/m", note="secant stiffness of one corner at 1 mm, "
             "c·(1 mm)^(n−1)"),
        Knob("exponent", 1.0, 2.0, log=False, note="n of c·xⁿ"),
        Knob("damping", 1e-2, 1e2, unit="s/m", note="Hunt–Crossley b of (1 + b·ẋ)"),
        Knob("friction", 0.02, 2.0, note="Coulomb's μ"),
        Knob("slip_velocity_m_s", 1e-4, 1e-1, unit="m/s", note="regularisation velocity v_s"),
    ),
    "kelvin-voigt-clipped": (
        Knob("stiffness", 1e2, 1e6, unit="N/m", note="k of one corner"),
        Knob("damping", 1e-1, 1e3, unit="N·s/m", note="d of one corner"),
        Knob("friction", 0.02, 2.0, note="Coulomb's μ"),
        Knob("slip_velocity_m_s", 1e-4, 1e-1, unit="m/s", note="regularisation velocity v_s"),
    ),
}
"""The fit's knobs per normal law (module doc)."""


# ------------------------------------------------------------------------------ parameters


def params_from_knobs(knobs: Mapping[str, float], law: str = "hunt-crossley"
                      ) -> BoxContactParams:
    """The model parameters of the knob values ``knobs`` (module doc)."""
    n = float(knobs.get("exponent", 1.0))
    return BoxContactParams(law=law, stiffness=float(knobs["stiffness"]) * X_REF_M ** (1.0 - n),
                            exponent=n, damping=float(knobs["damping"]),
                            friction=float(knobs["friction"]),
                            slip_velocity_m_s=float(knobs["slip_velocity_m_s"]))


def knobs_of(params: BoxContactParams) -> dict[str, float]:
    """The knob values of ``params`` (inverse of :func:`params_from_knobs`)."""
    out = {"stiffness": params.stiffness * X_REF_M ** (params.exponent - 1.0),
           "exponent": params.exponent, "damping": params.damping,
           "friction": params.friction, "slip_velocity_m_s": params.slip_velocity_m_s}
    if params.law != "hunt-crossley":
        del out["exponent"]
    return out


def start_params(law: str = "hunt-crossley") -> BoxContactParams:
    """The fit's initial guess: the middle of each knob's box."""
    if law not in KNOBS:
        raise ValueError(f"law = {law!r}: must be one of {', '.join(KNOBS)}")
    return params_from_knobs({k.name: k.start for k in KNOBS[law]}, law)


def _box_protocol(box: Box, protocol: Protocol | None) -> Protocol:
    if not isinstance(box, Box):
        raise ValueError(f"box = {box!r}: must be a box_contact.Box")
    if protocol is None:
        return Protocol(half_width_m=box.half_width_m)
    if abs(protocol.half_width_m - box.half_width_m) > 1e-12:
        raise ValueError(f"protocol.half_width_m = {protocol.half_width_m!r}: must equal "
                         f"box.half_width_m = {box.half_width_m!r}")
    return protocol


# ------------------------------------------------------------------------------ one toss


def simulate(start: Start, params: BoxContactParams | None = None, box: Box = DAIR_CUBE, *,
             protocol: Protocol | None = None, method: str = bc.METHOD, rtol: float = bc.RTOL,
             atol: float | np.ndarray = bc.ATOL, max_step: float = bc.MAX_STEP_S,
             max_evaluations: int = bc.MAX_EVALUATIONS) -> tuple[np.ndarray, np.ndarray]:
    """The reference model's positions (m, (n, 3)) and quaternions (w, x, y, z; (n, 4)) at
    the toss's reference sample times, from its start state (``start``, from
    :func:`~impactbench.cube_tosses.protocol.prepare`). ``params``: the packaged fit when
    None. The board at ``protocol.board_z_m``, gravity ``protocol.gravity_m_s2``. NaN from
    a failed integration on."""
    protocol = _box_protocol(box, protocol)
    params = load_fitted() if params is None else params
    y0 = bc.initial_state(start.p, start.q, start.v, start.w_body)
    traj = bc.integrate_box(params, y0, start.t_ref - start.t_ref[0], box=box,
                            board_z_m=protocol.board_z_m, gravity_m_s2=protocol.gravity_m_s2,
                            method=method, rtol=rtol, atol=atol, max_step=max_step,
                            max_evaluations=max_evaluations)
    return traj.p, traj.q


def _replay_one(job: tuple[Start, BoxContactParams, Box, Protocol, dict[str, Any]]
                ) -> dict[str, Any]:
    start, params, box, protocol, options = job
    try:
        p, q = simulate(start, params, box, protocol=protocol, **options)
        if not (np.all(np.isfinite(p)) and np.all(np.isfinite(q))):
            raise FloatingPointError("the integration failed (non-finite state)")
        return {"status": "ok", **toss_errors(start, p, q, protocol)}
    except (FloatingPointError, ValueError, RuntimeError) as exc:
        return {"toss": start.toss, "status": "failed",
                "error": f"{type(exc).__name__}: {str(exc).splitlines()[0]}"}


def _run(starts: Sequence[Start], params: BoxContactParams, box: Box, protocol: Protocol,
         options: Mapping[str, Any], pool: Executor | None) -> list[dict[str, Any]]:
    jobs = [(s, params, box, protocol, dict(options)) for s in starts]
    if pool is None:
        return [_replay_one(j) for j in jobs]
    return list(pool.map(_replay_one, jobs, chunksize=max(1, len(jobs) // 32)))


def _pool(workers: int) -> ProcessPoolExecutor | None:
    if not (isinstance(workers, int) and workers >= 1):
        raise ValueError(f"workers = {workers!r}: must be an integer >= 1")
    return ProcessPoolExecutor(workers) if workers > 1 else None


def integrator_setup(options: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """The integrator's settings (method, tolerances, max step) and scipy's version."""
    o = dict(options or {})
    atol = np.broadcast_to(np.asarray(o.get("atol", bc.ATOL), float), (13,))
    return {"method": o.get("method", bc.METHOD), "rtol": float(o.get("rtol", bc.RTOL)),
            "atol_p_m": float(atol[0]), "atol_q": float(atol[3]),
            "atol_v_m_s": float(atol[7]), "atol_w_rad_s": float(atol[10]),
            "max_step_s": float(o.get("max_step", bc.MAX_STEP_S)),
            "scipy": metadata.version("scipy"), "numpy": metadata.version("numpy")}


# ------------------------------------------------------------------------------ replay


def replay_reference(tosses: str | int | Iterable[int] = "test",
                     params: BoxContactParams | None = None,
                     df: pd.DataFrame | str | Path | None = None,
                     protocol: Protocol | None = None, *, box: Box = DAIR_CUBE, workers: int = 1,
                     progress: Callable[[int, int], None] | None = None,
                     **integrator: Any) -> dict[str, Any]:
    """Replay ``tosses`` (a split name, an id or ids) of ``df`` (a DataFrame, a CSV path, None:
    the packaged tosses) in the reference model with ``params`` (None: the packaged fit,
    :func:`load_fitted`), under ``protocol`` (DAIR's by default, with ``box``'s half width).

    Returns the dict ``replay()`` (:mod:`~impactbench.cube_tosses.replays`) returns (same keys:
    status, summary statistics, per_toss, protocol, ...) with ``engine = "reference"``,
    ``mode`` "fitted" (the packaged parameters) or "custom", and ``engine_setup`` describing
    the model, the box and the integrator. ``integrator``: ``method``, ``rtol``, ``atol``,
    ``max_step``, ``max_evaluations`` for :func:`simulate`."""
    protocol = _box_protocol(box, protocol)
    mode = "fitted" if params is None else "custom"
    params = load_fitted() if params is None else params
    if not isinstance(params, BoxContactParams):
        raise ValueError(f"params = {params!r}: must be a BoxContactParams")
    frame, source = frame_of(df)
    ids, split_name, starts, per_toss = prepared(frame, tosses, protocol)
    t0 = time.perf_counter()
    pool = _pool(workers)
    try:
        if pool is None and progress is not None:
            rows = []
            for n, s in enumerate(starts):
                rows.append(_replay_one((s, params, box, protocol, dict(integrator))))
                progress(n + 1, len(starts))
        else:
            rows = _run(starts, params, box, protocol, integrator, pool)
    finally:
        if pool is not None:
            pool.shutdown()
    elapsed = time.perf_counter() - t0
    per_toss += rows
    status, failed = outcome(per_toss, ids)
    setup = {"model": "rigid box, compliant corner contacts (impactbench.reference."
                      "box_contact)",
             "params": params.describe(),
             "box": {"half_width_m": box.half_width_m, "mass_kg": box.mass_kg,
                     "inertia_kg_m2": box.inertia.tolist()},
             "board": f"plane z = {protocol.board_z_m:g} m", "gravity_m_s2":
                 protocol.gravity_m_s2,
             "friction": "regularised Coulomb F_t = -mu F_n u_t / sqrt(|u_t|^2 + v_s^2)",
             "integrator": integrator_setup(integrator), "workers": workers,
             "parameters_file": str(FITTED_PATH) if mode == "fitted" else None}
    out = {"status": status, "engine": ENGINE, "mode": mode,
           "param_set": "reference.toml" if mode == "fitted" else None,
           "split": split_name, "tosses": len(per_toss), "failed": failed,
           **summarize(per_toss), "per_toss": per_toss, "protocol": protocol.describe(),
           "engine_setup": setup, "elapsed_s": elapsed,
           "tosses_per_s": len(starts) / elapsed if elapsed > 0 else math.nan,
           "data": source}
    return {k: out[k] for k in RESULT_KEYS}


# ------------------------------------------------------------------------------ the fit


def fit_ids(df: pd.DataFrame, tosses: str | Iterable[int] = "train", stride: int = STRIDE
            ) -> list[int]:
    """The tosses a fit uses: the training split (or given training ids), every
    ``stride``-th by id (``train[::stride]``)."""
    if not (isinstance(stride, int) and stride >= 1):
        raise ValueError(f"stride = {stride!r}: must be an integer >= 1")
    return training_ids(df, tosses)[::stride]


def objective_of(rows: Sequence[Mapping[str, Any]]) -> float:
    """:data:`OBJECTIVE` of per-toss rows (a failed toss counts :data:`FAILED_TOSS_ERROR`)."""
    return float(np.mean([r["position_error"] if r["status"] == "ok" else FAILED_TOSS_ERROR
                          for r in rows]))


def _summary(rows: Sequence[Mapping[str, Any]]) -> dict[str, Any]:
    return {**summarize(rows), "objective": objective_of(rows), "tosses": len(rows),
            "failed": [r["toss"] for r in rows if r["status"] != "ok"]}


@dataclass
class ReferenceFit:
    """What :func:`fit` found (write it with :func:`write_fitted`).

    Attributes:
        params, knobs (the best candidate), start_knobs, law; objective_start, objective
        (:data:`OBJECTIVE` on the fitting tosses); fit_summary, start_summary (their errors
        there); scored: "fitted"/"start" → "train"/"test" → summary on the whole splits (empty
        when ``score=False``); budget, evaluations, seed, optimizer, optimizer_version; stride,
        fit_ids (the fitting tosses), data_hash (of their rows); protocol, box, integrator
        (method, tolerances, versions); wall_time_s (the search, scoring excluded), workers;
        history ((knobs, objective) per evaluation).
    """

    params: BoxContactParams
    knobs: dict[str, float]
    start_knobs: dict[str, float]
    law: str
    objective_start: float
    objective: float
    fit_summary: dict[str, Any]
    start_summary: dict[str, Any]
    scored: dict[str, dict[str, dict[str, Any]]]
    budget: int
    evaluations: int
    seed: int
    optimizer: str
    optimizer_version: str
    stride: int
    fit_ids: list[int]
    data_hash: str
    protocol: dict[str, Any]
    box: Box
    integrator: dict[str, Any]
    wall_time_s: float
    workers: int
    history: list[tuple[dict[str, float], float]] = field(default_factory=list)


def fit(budget: int = 200, tosses: str | Iterable[int] = "train", seed: int = SEED,
        workers: int = 1, *, stride: int = STRIDE, law: str = "hunt-crossley",
        optimizer: str = OPTIMIZER, df: pd.DataFrame | str | Path | None = None,
        protocol: Protocol | None = None, box: Box = DAIR_CUBE, score: bool = True,
        progress: Callable[[int, int, float, float], None] | None = None) -> ReferenceFit:
    """Fit the model's knobs (:data:`KNOBS`) to training tosses with nevergrad (module doc).

    Args:
        budget: candidate evaluations, the start included (≥ 2).
        tosses: "train" or training-toss ids (a test toss is refused); ``stride`` thins them.
        seed: the optimiser's seed. workers: processes per evaluation (results unchanged).
        law: the normal law (a key of :data:`KNOBS`). optimizer: a nevergrad name.
        score: after the fit, score the best and the start on the whole training split and on
            the test split (never seen by the optimiser).
        progress: called after each evaluation with (done, budget, objective, best).
    """
    import nevergrad as ng

    if not (isinstance(budget, int) and budget >= 2):
        raise ValueError(f"budget = {budget!r}: must be an integer >= 2")
    if law not in KNOBS:
        raise ValueError(f"law = {law!r}: must be one of {', '.join(KNOBS)}")
    if optimizer not in ng.optimizers.registry:
        raise ValueError(f"optimizer = {optimizer!r}: not a nevergrad optimiser (e.g. CMA, "
                         "NGOpt)")
    protocol = _box_protocol(box, protocol)
    frame, _ = frame_of(df)
    ids = fit_ids(frame, tosses, stride)
    starts = [prepare(t, protocol) for t in data_mod.tosses(frame, ids)]
    knobs = KNOBS[law]
    history: list[tuple[dict[str, float], float]] = []
    best: tuple[float, dict[str, float], list[dict[str, Any]]] | None = None
    first: list[dict[str, Any]] = []
    t0 = time.perf_counter()
    pool = _pool(workers)
    try:
        def run(values: Mapping[str, Any]) -> float:
            nonlocal best
            values = {k: float(v) for k, v in values.items()}
            rows = _run(starts, params_from_knobs(values, law), box, protocol, {}, pool)
            obj = objective_of(rows)
            history.append((values, obj))
            if not first:
                first.extend(rows)
            if best is None or obj < best[0]:
                best = (obj, values, rows)
            if progress is not None:
                progress(len(history), budget, obj, best[0])
            return obj

        start_knobs = {k.name: float(k.start) for k in knobs}
        objective_start = search(knobs, run, budget, seed, optimizer)
        assert best is not None
        objective, best_knobs, best_rows = best
        wall = time.perf_counter() - t0
        params = params_from_knobs(best_knobs, law)
        scored: dict[str, dict[str, dict[str, Any]]] = {}
        if score:
            split_starts = {split: [prepare(t, protocol) for t in data_mod.tosses(
                frame, data_mod.split(data_mod.toss_ids(frame), split))]
                for split in ("train", "test")}
            for name, prm in (("fitted", params), ("start", params_from_knobs(start_knobs, law))):
                scored[name] = {split: _summary(_run(ss, prm, box, protocol, {}, pool))
                                for split, ss in split_starts.items()}
    finally:
        if pool is not None:
            pool.shutdown()
    return ReferenceFit(
        params=params, knobs=best_knobs, start_knobs=start_knobs, law=law,
        objective_start=objective_start, objective=objective,
        fit_summary=_summary(best_rows), start_summary=_summary(first), scored=scored,
        budget=budget, evaluations=len(history), seed=seed, optimizer=optimizer,
        optimizer_version=f"nevergrad {metadata.version('nevergrad')}", stride=stride,
        fit_ids=ids, data_hash=data_hash(frame, ids), protocol=protocol.describe(), box=box,
        integrator=integrator_setup(), wall_time_s=wall, workers=workers, history=history)


# ------------------------------------------------------------------------------ files


_SUMMARY_KEYS = ("tosses", "objective", "position_error_mean", "position_error_median",
                 "position_error_q1", "position_error_q3", "rotation_error_deg_mean",
                 "rotation_error_deg_median", "rotation_error_deg_q1", "rotation_error_deg_q3",
                 "failed")


def _short(summary: Mapping[str, Any]) -> dict[str, Any]:
    return {k: summary[k] for k in _SUMMARY_KEYS if k in summary}


def fit_command(fit_result: ReferenceFit, out: str | Path) -> str:
    """The command that reproduces ``fit_result`` (recorded in the file)."""
    return (f"python -m impactbench.cube_tosses.reference_model --fit --budget "
            f"{fit_result.budget} --seed {fit_result.seed} --stride {fit_result.stride} "
            f"--law {fit_result.law} --optimizer {fit_result.optimizer} --out {out}")


def write_fitted(fit_result: ReferenceFit, path: str | Path | None = None) -> Path:
    """Write ``fit_result`` as TOML (``[parameters]``, ``[knobs]``, ``[start]``, ``[box]``,
    ``[provenance]``, ``[fit]``/``[start_fit]``: the errors on the fitting tosses, and
    ``[scored.<fitted|start>.<train|test>]``: on the whole splits); returns the path."""
    import tomli_w

    out = Path(path) if path is not None else FITTED_PATH
    f = fit_result
    try:
        shown = out.resolve().relative_to(Path.cwd().resolve())
    except ValueError:
        shown = out
    doc = {
        "parameters": toml_ready(f.params.describe()),
        "knobs": toml_ready(f.knobs),
        "start": toml_ready(f.start_knobs),
        "box": toml_ready({"half_width_m": f.box.half_width_m, "mass_kg": f.box.mass_kg,
                      "inertia_kg_m2": f.box.inertia.tolist()}),
        "provenance": toml_ready({
            "model": "impactbench.reference.box_contact", "scenario": "cube-toss",
            "objective": OBJECTIVE, "loss": f.objective, "loss_start": f.objective_start,
            "optimizer": f.optimizer, "optimizer_version": f.optimizer_version,
            "budget": f.budget, "evaluations": f.evaluations, "seed": f.seed,
            "fit_tosses": len(f.fit_ids), "stride": f.stride,
            "subset": f"train[::{f.stride}] (the training tosses by id, one in {f.stride}; "
                      "data.split: SHA-256 of the id ≢ 0 mod 5)",
            "train_ids_hash": ids_hash(f.fit_ids), "data_hash": f.data_hash,
            "scipy_version": f.integrator["scipy"], "numpy_version": f.integrator["numpy"],
            "integrator": {k: v for k, v in f.integrator.items()
                           if k not in ("scipy", "numpy")},
            "wall_time_s": round(f.wall_time_s, 1), "workers": f.workers,
            "command": fit_command(f, shown),
            "protocol": {k: v for k, v in f.protocol.items() if v is not None}}),
        "fit": toml_ready(_short(f.fit_summary)),
        "start_fit": toml_ready(_short(f.start_summary)),
        "scored": {name: {split: toml_ready(_short(s)) for split, s in splits.items()}
                   for name, splits in f.scored.items()},
        "space": {k.name: toml_ready({x: y for x, y in k.describe().items() if x != "name"})
                  for k in KNOBS[f.law]},
    }
    header = ("# impactbench's reference box model (compliant corners, regularised Coulomb)\n"
              "# fitted to the cube tosses' training split; load with\n"
              "# impactbench.cube_tosses.reference_model.load_fitted().\n\n")
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(header + tomli_w.dumps(doc))
    return out


def load_fitted(path: str | Path | None = None) -> BoxContactParams:
    """The ``[parameters]`` of the fitted file (the packaged one unless ``path``) as
    :class:`~impactbench.reference.box_contact.BoxContactParams` (ValueError, one line, when
    it is missing or malformed)."""
    import tomllib

    src = Path(path) if path is not None else FITTED_PATH
    if not src.is_file():
        raise ValueError(f"path = {str(src)!r}: no fitted reference-model file")
    try:
        doc = tomllib.loads(src.read_text())
    except tomllib.TOMLDecodeError as exc:
        raise ValueError(f"path = {str(src)!r}: not TOML ({exc})") from None
    params = doc.get("parameters")
    if not isinstance(params, dict):
        raise ValueError(f"path = {str(src)!r}: [parameters] table is missing")
    fields = ("law", "stiffness", "exponent", "damping", "friction", "slip_velocity_m_s")
    unknown = [k for k in params if k not in fields]
    if unknown:
        raise ValueError(f"path = {str(src)!r}: [parameters] {unknown[0]!r} is not one of "
                         f"{', '.join(fields)}")
    return BoxContactParams(**params)


# ------------------------------------------------------------------------------ command line


def _print_summary(name: str, s: Mapping[str, Any]) -> None:
    print(f"{name}: {s.get('tosses')} tosses, position error median "
          f"{s['position_error_median']:.4f} (q1 {s['position_error_q1']:.4f}, q3 "
          f"{s['position_error_q3']:.4f}, mean {s['position_error_mean']:.4f}) widths; "
          f"rotation median {s['rotation_error_deg_median']:.2f}° (q1 "
          f"{s['rotation_error_deg_q1']:.2f}, q3 {s['rotation_error_deg_q3']:.2f}, mean "
          f"{s['rotation_error_deg_mean']:.2f})")


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m impactbench.cube_tosses.reference_model",
                                 description="Fit or replay impactbench's reference box model "
                                             "on the cube tosses.")
    what = ap.add_mutually_exclusive_group(required=True)
    what.add_argument("--fit", action="store_true", help="fit on the training split")
    what.add_argument("--replay", action="store_true", help="replay and score tosses")
    ap.add_argument("--budget", type=int, default=200)
    ap.add_argument("--seed", type=int, default=SEED)
    ap.add_argument("--stride", type=int, default=STRIDE)
    ap.add_argument("--law", default="hunt-crossley", choices=tuple(KNOBS))
    ap.add_argument("--optimizer", default=OPTIMIZER)
    ap.add_argument("--workers", type=int, default=min(2, os.cpu_count() or 1))
    ap.add_argument("--out", default=None, help="the fitted file (default: the packaged one)")
    ap.add_argument("--tosses", default="test", help="replay: test, train, all or ID,ID,…")
    ap.add_argument("--params", default=None, help="replay: a fitted file (default packaged)")
    a = ap.parse_args(argv)
    try:
        if a.fit:
            def progress(done: int, total: int, obj: float, best: float) -> None:
                print(f"  {done}/{total}: {obj:.5f} (best {best:.5f})", flush=True)

            res = fit(a.budget, seed=a.seed, workers=a.workers, stride=a.stride, law=a.law,
                      optimizer=a.optimizer, progress=progress)
            path = write_fitted(res, a.out)
            print(f"wrote {path} ({res.evaluations} evaluations, {res.wall_time_s:.0f} s); "
                  f"{res.params}")
            for name, splits in res.scored.items():
                for split, s in splits.items():
                    _print_summary(f"{name} on {split}", s)
            return 0
        sel: str | list[int] = a.tosses
        if a.tosses not in data_mod.SPLITS:
            sel = [int(x) for x in a.tosses.split(",")]
        params = load_fitted(a.params) if a.params else None
        out = replay_reference(sel, params, workers=a.workers)
        _print_summary(f"{out['mode']} on {out['split']}", out)
        print(f"{out['elapsed_s']:.1f} s ({out['tosses_per_s']:.2f} tosses/s, {a.workers} "
              f"workers); failed: {out['failed']}")
        return 0
    except ValueError as exc:
        print(f"error: {exc}")
        return 2


if __name__ == "__main__":
    raise SystemExit(main())


__all__ = ["FITTED_PATH", "KNOBS", "OBJECTIVE", "ReferenceFit", "fit", "fit_ids",
           "knobs_of", "load_fitted", "params_from_knobs", "replay_reference", "simulate",
           "start_params", "write_fitted"]
