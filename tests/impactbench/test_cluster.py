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
    results = run_jobs(jobs, workers=1)  # 8 runs, one worker: pymunk's batched
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


def test_results_come_back_in_small_batches_as_they_finish(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """A group's first batch is one item per worker (to measure it); later ones hold at most
    about BATCH_S of predicted work: here 0.1 s items, about 3 per batch (BATCH_S 0.4 s), so
    results arrive a few at a time, never all at the end."""
    import time

    from impactbench import cluster

    monkeypatch.syspath_prepend(str(Path(__file__).resolve().parent.parent / "engines"))
    monkeypatch.setattr(cluster, "BATCH_S", 0.4)
    from crashing_adapter import nap

    arrivals: list[float] = []
    with cluster.Runner(workers=2) as runner:
        runner.run(nap, [0.1] * 24, on_result=lambda _i, _r: arrivals.append(
            time.monotonic()), on_crash=lambda i, why: pytest.fail(why))
    assert len(arrivals) == 24
    bursts = [len(list(g)) for _, g in __import__("itertools").groupby(
        arrivals, key=lambda t: round(t, 2))]
    assert bursts[0] <= 2 and max(bursts) <= 6 and len(bursts) >= 5, bursts


def test_a_timed_out_item_in_a_batch_costs_only_itself(monkeypatch: pytest.MonkeyPatch) -> None:
    """Items of 0.05 s in batches; the one sleeping 30 s outlasts its 2 s timeout: reported
    as timed out, its worker restarted, every other item's result kept."""
    from impactbench.cluster import Runner

    monkeypatch.syspath_prepend(str(Path(__file__).resolve().parent.parent / "engines"))
    from crashing_adapter import nap

    items = [0.05] * 7 + [30.0] + [0.05] * 4  # the last of the second batch
    got, late = [], []
    with Runner(workers=1) as runner:
        runner.run(nap, items, on_result=lambda i, r: got.append(i),
                   on_crash=lambda i, why: pytest.fail(why),
                   on_timeout=lambda i, why: late.append((i, why)), timeout_s=2.0,
                   batch_size=4)
        assert runner.restarted == 1
    assert late == [(30.0, "timed out after 2 s (cancelled; its worker was restarted)")]
    assert got == [0.05] * 11


def test_a_small_report_runs_in_this_process_by_default() -> None:
    """Default placement (issue 24): runs estimated under matrix.DISPATCH_MIN_S in all run
    here, no cluster started (a 20-run report cost 1.29x the in-process time on Dask; 1.00x
    now, farm-bench, 5 alternated pairs); a given --workers N still sends them to workers."""
    import subprocess
    import sys

    code = ("import sys, tempfile, impactbench\n"
            "small = {'report': {'engines': ['pymunk'], 'modes': ['native']},\n"
            "         'ball_on_plate': {'velocities_m_s': [1.0, 2.0]}}\n"
            "impactbench.build_report(config=small, out=tempfile.mkdtemp(), store=False,\n"
            "                         progress=False, workers=WORKERS)\n"
            "print('distributed' in sys.modules)\n")
    here = subprocess.run([sys.executable, "-c", code.replace("WORKERS", "None")],
                          capture_output=True, text=True, timeout=120)
    assert here.stdout.strip() == "False", here.stderr
    there = subprocess.run([sys.executable, "-c", code.replace("WORKERS", "1")],
                           capture_output=True, text=True, timeout=120)
    assert there.stdout.strip() == "True", there.stderr


def test_work_the_priors_predict_under_a_second_runs_in_this_process(monkeypatch) -> None:
    """The default placement judges the work by its predicted time (the estimates times the
    measured priors, ``matrix.predicted_s``), not by the generic step cost alone: 18 MuJoCo
    cube tosses (a tune generation of 6 candidates on 3 tosses) are estimated at 1.76 s,
    above matrix.DISPATCH_MIN_S, but take ~0.15 s (the prior: 0.07 of the estimate); they
    started a local cluster (the whole 8-candidate tune 1.7 s against 0.2 s here)."""
    require_engine("mujoco")
    from impactbench import cluster, matrix
    from impactbench.cube_tosses.tune import replay_runs, scenario_of

    def no_cluster(*_a, **_k):
        raise AssertionError("a local cluster was started")

    monkeypatch.setattr(cluster.Runner, "client", no_cluster)
    seen: list[tuple[float, float]] = []
    predicted = matrix.predicted_s

    def spy(estimates, clock):
        seen.append((sum(estimates.values()), predicted(estimates, clock)))
        return seen[-1][1]

    monkeypatch.setattr(matrix, "predicted_s", spy)
    stiff = [{"board.solref": (-k, -10.0)} for k in (1e4, 2e4, 3e4, 4e4, 5e4, 6e4)]
    runs = replay_runs("mujoco", scenario_of(None, [1, 2, 4]), stiff)
    assert [r["status"] for r, _ in runs] == ["ok"] * 6
    ((estimate, pred),) = seen
    assert estimate > matrix.DISPATCH_MIN_S > pred  # the raw estimate would have dispatched


def test_a_killed_worker_is_no_free_slot_until_its_replacement_registers() -> None:
    """After a timed-out item's worker is killed, the free slots are counted on the
    scheduler, less the killed worker: a batch submitted before the replacement registers
    would be queued behind the other worker's batch (a hung one, in CI: its clock ran there
    and the kill of that worker was counted against it, 'marked as failed because 2 workers
    died'). Real Dask, 2 local workers."""
    import time

    from impactbench import cluster

    with cluster.Runner(workers=2) as runner:
        c = runner.client()
        c.wait_for_workers(2, timeout=60)
        run = cluster._DaskRun(runner, c, abs, [], "t", None, lambda _i: None,
                               lambda _i: None, lambda _i: None)
        before = set(c.nthreads())
        assert run.slots(time.monotonic(), 2) == 2  # no kill: the count given
        gone = sorted(before)[0]
        run.kill(gone)
        assert run.slots(time.monotonic(), 2) == 1  # at once, whatever the scheduler lists
        deadline = time.monotonic() + 60
        while run.slots(time.monotonic(), 2) < 2:
            assert time.monotonic() < deadline, "the killed worker was not replaced"
            time.sleep(0.1)
        assert gone not in c.nthreads() and len(c.nthreads()) == 2
        assert runner.restarted == 1
