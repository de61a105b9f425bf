"""The time left a run of work prints: each run's estimated cost, learnt per group as runs
finish (#32: an estimate from the first minute on, not only once a count-based rate exists)."""

from __future__ import annotations

import re

import pytest

from impactbench import cliutil
from impactbench.matrix import TimeLeft


def test_the_estimate_learns_each_groups_ratio_and_shares_the_rest_over_the_workers() -> None:
    clock = TimeLeft(2)
    slow, fast = ("drake", "cube-toss", False), ("mujoco", "ball-on-plate", False)
    clock.add(slow, 10.0)   # two runs estimated 5 s each
    clock.add(fast, 30.0)   # three runs estimated 10 s each
    assert clock.seconds() == pytest.approx(40.0 / 2)  # the prior: the estimates as they are
    clock.finished(slow, 5.0, 15.0)  # took 3 × its estimate
    # slow: 5 s left × 3; fast: none of its scenario or engine finished, the median of all (3)
    assert clock.seconds() == pytest.approx((5.0 * 3 + 30.0 * 3) / 2)
    clock.finished(fast, 10.0, 1.0)  # 0.1 × its estimate
    assert clock.seconds() == pytest.approx((5.0 * 3 + 20.0 * 0.1) / 2)
    clock.finished(fast, 10.0, float("nan"))  # a crashed run: gone, nothing learnt
    assert clock.seconds() == pytest.approx((5.0 * 3 + 10.0 * 0.1) / 2)
    # a new group takes the ratio of its scenario's others before its engine's
    other = ("pybullet", "ball-on-plate", False)
    clock.add(other, 4.0)
    assert clock.seconds() == pytest.approx((5.0 * 3 + 10.0 * 0.1 + 4.0 * 0.1) / 2)
    clock.add(("drake", "oblique", False), 2.0)  # no oblique finished: drake's (3)
    assert clock.seconds() == pytest.approx((5.0 * 3 + 10.0 * 0.1 + 4.0 * 0.1 + 2.0 * 3) / 2)


def test_a_progress_line_says_the_callers_estimate_from_the_first_line(capsys,
                                                                       monkeypatch) -> None:
    monkeypatch.setattr(cliutil, "PROGRESS_EVERY_S", 0.0)
    update, close = cliutil.progress_bar(4)
    update.left(150.0)
    update(0)  # a heartbeat before anything finished: the estimate is there already
    update.left(30.0)
    update(1)
    update(3)
    close()
    err = capsys.readouterr().err.splitlines()
    assert re.fullmatch(r"impactbench: 0 of 4 runs done \(0 s, about (2|3) min left\)", err[0])
    assert re.fullmatch(r"impactbench: 1 of 4 runs done \(0 s, about (29|30) s left\)", err[1])
    assert err[2] == "impactbench: 4 of 4 runs done (0 s)"  # nothing left: no estimate


def test_a_run_matrix_gives_its_progress_an_estimate_before_any_run_finished() -> None:
    """run_jobs hands its estimate to the progress as soon as it has planned the work."""
    from impactbench.matrix import Job, run_jobs

    heard: list[float] = []

    def progress(n: int) -> None:
        pass

    progress.left = heard.append  # type: ignore[attr-defined]
    jobs = [Job("pymunk", "ball-on-plate", (("velocity_m_s", v),), "native", 1e-4)
            for v in (1.0, 2.0)]
    run_jobs(jobs, 0, progress=progress)
    assert len(heard) == 3 and heard[0] > 0.0 and heard[-1] == 0.0
