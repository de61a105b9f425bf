"""The report's quick paths of issue #32: the reference model's replay started beside the runs,
the scoreboard's worst error on the column arrays, the local cluster's workers ended at close."""

from __future__ import annotations

import math
import os
import time

import numpy as np
import pandas as pd
import pytest

from impactbench import scenarios
from impactbench.report_render import FigurePool
from impactbench.report_sections import worst


def _worst_by_frames(rows: pd.DataFrame, metric: str) -> tuple[float, object]:
    """The former implementation (filtered frames, idxmax): what the fast one must equal."""
    r = rows[(rows.metric == metric) & (rows.status == "ok")]
    r = r[pd.to_numeric(r.rel_error, errors="coerce").notna()]
    if r.empty:
        return math.nan, None
    i = r.rel_error.astype(float).abs().idxmax()
    return float(r.rel_error[i]), r.loc[i]


def test_worst_is_the_filtered_frames_idxmax() -> None:
    """Ties (the first wins), NaN, text errors, failed runs and other metrics: the same
    error and the same row as the former filter-and-idxmax, over random tables."""
    rng = np.random.default_rng(7)
    for trial in range(40):
        n = int(rng.integers(0, 30))
        errors: list[object] = list(rng.choice([-0.5, 0.5, 0.1, -0.2, np.nan, np.inf], n))
        if n and trial % 3 == 0:
            errors[0] = "0.5"  # a text cell, as a CSV read back may give
        rows = pd.DataFrame({
            "metric": rng.choice(["e", "peak_force_n"], n),
            "status": rng.choice(["ok", "ok", "diverged"], n),
            "rel_error": pd.Series(errors, dtype=object),
            "velocity_m_s": rng.random(n)})
        for metric in ("e", "peak_force_n", "absent"):
            got, want = worst(rows, metric), _worst_by_frames(rows, metric)
            assert (got[0] == want[0]) or (math.isnan(got[0]) and math.isnan(want[0]))
            assert (got[1] is None) == (want[1] is None)
            if got[1] is not None:
                assert got[1].name == want[1].name


def _double(x: int) -> int:
    return 2 * x


def test_a_call_without_workers_runs_when_asked_for() -> None:
    """``FigurePool.call`` with no worker processes computes here, once, when asked for."""
    calls: list[int] = []

    def work() -> int:
        calls.append(1)
        return 42

    with FigurePool(0) as pool:
        assert not pool.start()
        later = pool.call(work)
        assert calls == []
        assert later.result() == 42 and later.result() == 42
        assert calls == [1]


def test_a_call_with_workers_runs_in_a_worker() -> None:
    """Started, the pool runs a call in its worker processes (a picklable function)."""
    import functools

    with FigurePool(2) as pool:
        if pool.workers < 2:
            pytest.skip("needs 2 cores for the figure workers")
        assert pool.start()
        assert pool.call(functools.partial(_double, 21)).result() == 42


def test_the_model_replay_is_started_unless_stored(tmp_path) -> None:
    """The cube tosses' report starts the reference model's replay beside the runs unless
    the section's store has it; the section keeps the replay handed to it in that store,
    and a second report finds it there (nothing started)."""
    from impactbench import config
    from impactbench.cube_tosses.scenario import model_key, model_run
    from impactbench.store import Store

    spec = scenarios.get("cube-toss")
    cfg = config.load(None)
    sm = next(s for s in cfg.scenarios if s.name == spec.name)
    store = Store(tmp_path / "s.duckdb")
    work = spec.report_background(cfg, sm, store)
    assert list(work) == [f"{spec.name}:model"]

    class Given:  # a replay "computed elsewhere": model_run must keep exactly it
        def result(self) -> dict:
            return {"status": "ok", "per_toss": [], "engine_version": "scipy x", "wall_s": 0.0,
                    "message": "", "position_error_median": 0.25}

    scenario = spec.build(parameters=sm.parameters)
    out = model_run(scenario, store=store, computed=Given())
    assert out["position_error_median"] == 0.25
    key, _ = model_key(scenario)
    assert key in store.get([key])
    assert spec.report_background(cfg, sm, store) == {}
    assert model_run(scenario, store=store)["position_error_median"] == 0.25  # stored


def test_closing_the_local_cluster_ends_its_workers() -> None:
    """At close the workers are ended (their nannies told not to restart them), none
    outlives the client."""
    from impactbench import cluster

    with cluster.client(2) as c:
        c.submit(sum, [1, 2]).result()
        pids = cluster._worker_pids(c.cluster)
        assert pids
    deadline = time.monotonic() + 5
    alive = set(pids)
    while alive and time.monotonic() < deadline:
        for pid in list(alive):
            try:
                os.kill(pid, 0)
                with open(f"/proc/{pid}/stat") as f:  # a zombie is ended
                    if f.read().split(") ")[1].startswith("Z"):
                        alive.discard(pid)
            except (ProcessLookupError, FileNotFoundError):
                alive.discard(pid)
        time.sleep(0.05)
    assert not alive
