"""Dask execution: a run that kills its worker costs only itself, also inside a batch."""

from __future__ import annotations

from pathlib import Path

import pytest
from conftest import require_engine
from impactbench.engines.base import ENGINES_ENV

from impactbench.matrix import Job, run_jobs

V1 = (("velocity_m_s", 1.0),)
"""The point of a ball run at 1 m/s."""


def test_a_dying_run_in_a_batch_costs_only_itself(monkeypatch: pytest.MonkeyPatch) -> None:
    require_engine("pymunk")
    monkeypatch.setenv(ENGINES_ENV, "crasher=crashing_adapter:CrashingAdapter")
    monkeypatch.syspath_prepend(str(Path(__file__).resolve().parent.parent / "engines"))
    jobs = [Job("pymunk", "ball-on-plate", (("velocity_m_s", v),), "injected", 1e-5)
            for v in (0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5)]
    jobs.append(Job("crasher", "ball-on-plate", V1, "native", None, study="matrix"))
    results = run_jobs(jobs, workers=1)  # 8 runs, one worker: batches of two
    status = {r.job.id: r.run["status"] for r in results}
    assert [s for i, s in status.items() if "crasher" in i] == ["crashed"]
    assert all(s == "ok" for i, s in status.items() if "pymunk" in i), status


@pytest.mark.parametrize("workers", [0, 1])
def test_runner_map_keeps_input_order(workers: int) -> None:
    from impactbench.cluster import Runner

    with Runner(workers) as runner:
        assert runner.map(abs, [-5, 2, -1, 0, 7, -3], on_crash=str) == [5, 2, 1, 0, 7, 3]


def test_runner_map_a_dying_item_costs_only_itself(monkeypatch: pytest.MonkeyPatch) -> None:
    from impactbench.cluster import Runner

    monkeypatch.syspath_prepend(str(Path(__file__).resolve().parent.parent / "engines"))
    from crashing_adapter import square_or_die

    with Runner(workers=1) as runner:  # batches of 2: the batch [2, 3] is split
        out = runner.map(square_or_die, list(range(8)), batch_size=2,
                         on_crash=lambda item, why: f"crashed {item}: {why}")
        assert out[:3] == [0, 1, 4] and out[4:] == [16, 25, 36, 49]
        assert out[3] == "crashed 3: the worker process died (twice)"
        assert runner.map(square_or_die, [9], on_crash=str) == [81]  # one cluster, reused


def test_runner_rejects_negative_workers() -> None:
    from impactbench.cluster import Runner

    with pytest.raises(ValueError, match=r"^workers = -1: must be an integer >= 0$"):
        Runner(-1)


def test_runner_keeps_work_under_min_dispatch_s_here(monkeypatch: pytest.MonkeyPatch) -> None:
    import os

    from impactbench.cluster import Runner

    monkeypatch.syspath_prepend(str(Path(__file__).resolve().parent.parent / "engines"))
    from crashing_adapter import pid

    with Runner(workers=1, min_dispatch_s=0.5) as runner:
        assert runner.map(pid, [0, 1], on_crash=str, estimate_s=0.4) == [os.getpid()] * 2
        assert runner.dispatched == 0 and runner._client is None  # no cluster started
        there = runner.map(pid, [0, 1], on_crash=str, estimate_s=0.6)
        assert there[0] == there[1] != os.getpid() and runner.dispatched == 2
