"""Work items (impactbench/matrix.py: work_items): which runs go to one process together.

A batching builder's runs (one engine call) and a compiling engine's runs of a scenario (its
compiles once, not once per worker: cold caches, the default report's MJX cube tosses took
115 s of engine time over two workers and 86 s in one) share an item; the rest go alone."""

from __future__ import annotations

from conftest import require_engine

from impactbench import config
from impactbench.matrix import plan, work_items


def _items(engines: list[str]) -> list[list]:
    jobs = plan(config.load(None), engines)
    refs = {j.reference_key: {} for j in jobs}
    return work_items(jobs, {j.id: None for j in jobs}, refs)


def test_a_compiling_engines_runs_of_a_scenario_share_an_item_and_others_go_alone() -> None:
    require_engine("mujoco")
    require_engine("mjx")
    items = _items(["mujoco", "mjx"])
    by = {}
    for item in items:
        engines = {it[0].engine for it in item}
        scenarios = {it[0].scenario for it in item}
        assert len(engines) == 1 and len(scenarios) == 1  # never mixed
        by.setdefault((engines.pop(), scenarios.pop()), []).append(len(item))
    # MJX: every scenario's runs in one item (oblique and the tosses have no batch method)
    for scenario in ("oblique", "cube-toss", "ball-on-plate", "rigid-flexible"):
        assert by[("mjx", scenario)] == [sum(by[("mjx", scenario)])], scenario
        assert by[("mjx", scenario)][0] > 1
    # C MuJoCo neither batches nor compiles: each run its own item
    assert set(by[("mujoco", "oblique")]) == {1} and len(by[("mujoco", "oblique")]) > 1
    assert set(by[("mujoco", "cube-toss")]) == {1}
