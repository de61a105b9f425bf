"""The time left a run of work prints: each run's estimated cost, learnt per group as runs
finish (#32: an estimate from the first minute on, not only once a count-based rate exists)."""

from __future__ import annotations

import math
import re

import pytest

from impactbench import cliutil
from impactbench.matrix import PACE_PRIOR_S, TimeLeft


def test_the_estimate_learns_each_groups_ratio_and_shares_the_rest_over_the_workers() -> None:
    clock = TimeLeft(2, priors={})  # no measured priors: the estimates, then what is learnt
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


def test_a_group_without_finished_items_takes_its_prior_at_this_machines_pace() -> None:
    """A measured prior (a fresh report's ratio) stands for a group until one of its own
    items finishes, scaled by how the finished groups' items kept to their priors —
    PACE_PRIOR_S of predicted work counted in at pace 1."""
    slow, fast = ("mjx", "cube-toss", False), ("mujoco", "ball-on-plate", False)
    clock = TimeLeft(1, priors={slow: 4.0, fast: 0.5})
    clock.add(slow, 10.0)
    clock.add(fast, 20.0)
    clock.add(("pymunk", "oblique", False), 6.0)  # no prior and nothing finished: 1
    assert clock.pace() == 1.0
    assert clock.seconds() == pytest.approx(10.0 * 4.0 + 20.0 * 0.5 + 6.0)
    clock.finished(fast, 10.0, 10.0)  # took twice its prior's 5 s: a busy machine
    pace = (10.0 + PACE_PRIOR_S) / (5.0 + PACE_PRIOR_S)
    assert clock.pace() == pytest.approx(pace) and pace > 1.0
    # fast: its own ratio (1); slow: its prior at the pace; pymunk: the median of all
    assert clock.seconds() == pytest.approx(10.0 * 1.0 + 10.0 * 4.0 * pace + 6.0 * 1.0)
    assert clock.measured() == [["mujoco", "ball-on-plate", False, 1.0]]
    for _ in range(40):  # much more work at twice its prior: the pace nears 2
        clock.finished(fast, 10.0, 10.0)
    assert clock.pace() == pytest.approx((41 * 10.0 + PACE_PRIOR_S) / (41 * 5.0 + PACE_PRIOR_S))
    assert 1.8 < clock.pace() < 2.0


def test_one_early_item_does_not_swing_the_pace() -> None:
    """The first item to finish took 10 × its prior's 1 s (a worker's imports, say): the
    other groups' priors are scaled by (10 + 30)/(1 + 30), not by 10."""
    clock = TimeLeft(1, priors={("dart", "cube-toss", False): 0.1,
                                ("mjx", "oblique", True): 5.0})
    clock.add(("dart", "cube-toss", False), 20.0)
    clock.add(("mjx", "oblique", True), 10.0)
    clock.finished(("dart", "cube-toss", False), 10.0, 10.0)
    assert clock.pace() == pytest.approx(40.0 / 31.0)
    assert clock.seconds() == pytest.approx(10.0 * 1.0 + 10.0 * 5.0 * 40.0 / 31.0)


def test_an_engine_with_an_empty_compile_cache_takes_the_cold_priors(tmp_path,
                                                                     monkeypatch) -> None:
    """The packaged priors were measured twice, compile caches empty and warm: a JIT engine
    whose cache folder is empty here is estimated with its compiles (the cold column), every
    other engine with the warm column."""
    from impactbench import matrix

    columns = matrix._packaged_priors()
    assert set(columns) == {"cold", "warm"}
    group = ("mjx", "cube-toss", True)
    cold, warm = columns["cold"][group], columns["warm"][group]
    assert cold > 1.3 * warm  # its compiles: measured 74 s of engine time against 39 s
    assert matrix.time_priors(["mjx"])[group] == cold
    assert matrix.time_priors([])[group] == warm
    plain = ("drake", "cube-toss", False)  # not a cold engine: the warm column
    assert matrix.time_priors(["mjx"])[plain] == columns["warm"][plain]
    # by default, as the caches are: empty ones here
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    for name in ("WARP_CACHE_PATH", "JAX_COMPILATION_CACHE_DIR"):
        monkeypatch.delenv(name, raising=False)
    assert matrix.cold_engines() == {"mjx", "newton"}
    assert TimeLeft(2).priors[group] == cold
    (tmp_path / "impactbench" / "jax").mkdir(parents=True)
    (tmp_path / "impactbench" / "jax" / "jit_call-0-cache").write_bytes(b"x")
    assert matrix.cold_engines() == {"newton"}
    assert TimeLeft(2).priors[group] == warm


def test_the_packaged_priors_cover_the_default_reports_groups() -> None:
    """Every group of work items of the default report has a measured prior in both
    columns (a new engine or scenario needs `python -m benchmarks report --priors` again,
    cold and warm), each a ratio ≥ 0 (a group of refused runs takes next to nothing)."""
    from impactbench import config
    from impactbench.matrix import _packaged_priors, plan, work_items

    jobs = plan(config.load(None))
    refs = {j.reference_key: {} for j in jobs}
    groups = {(it[0][0].engine, it[0][0].scenario, len(it) > 1)
              for it in work_items(jobs, {j.id: None for j in jobs}, refs)}
    for column, priors in _packaged_priors().items():
        assert priors and all(0.0 <= r < math.inf for r in priors.values()), column
        missing = {g for g in groups if g not in priors}
        # a group of one run in the default report may be a batch of one: alike either way
        missing = {g for g in missing if (g[0], g[1], not g[2]) not in priors}
        assert missing == set(), column
