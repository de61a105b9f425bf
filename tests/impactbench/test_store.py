"""The results store: what is stored is served back unchanged, and the key sees every input."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pandas as pd
import pytest
from conftest import require_engine
from impactbench.engines.base import RunSettings
from impactbench.reference.scenarios import BallOnPlate

from impactbench import store as store_mod
from impactbench.matrix import Job, run_jobs, tidy

V1 = (("velocity_m_s", 1.0),)
"""The point of a ball run at 1 m/s."""

JOBS = [Job("pymunk", "ball-on-plate", V1, "injected", 1e-5, study="matrix", keep_history=True),
        Job("pymunk", "rigid-flexible",
            (("local", "linear"), ("structure", "linear"), ("velocity_m_s", 2.0)), "injected",
            1e-4, study="matrix", keep_history=True),
        Job("pymunk", "ball-on-plate", V1, "native", 1e-5, study="work_precision")]


@pytest.fixture(scope="module")
def stored(tmp_path_factory: pytest.TempPathFactory):
    require_engine("pymunk")
    st = store_mod.Store(tmp_path_factory.mktemp("store") / "r.duckdb")
    first = run_jobs(JOBS, workers=0, store=st)
    return st, first, run_jobs(JOBS, workers=0, store=st)


def test_a_rerun_is_served_from_the_store_unchanged(stored) -> None:
    _, first, again = stored
    assert not any(r.cached for r in first) and all(r.cached for r in again)
    pd.testing.assert_frame_equal(pd.DataFrame(tidy(first)), pd.DataFrame(tidy(again)))
    for a, b in zip(first, again, strict=True):
        assert a.history.keys() == b.history.keys()
        for k in a.history:
            assert (a.history[k] == b.history[k]).all()
        assert a.run.keys() == b.run.keys()


def test_one_row_per_run_and_metric(stored) -> None:
    st, first, _ = stored
    frame = st.frame()
    assert len(frame) == sum(len(r.run["rel_error"]) for r in first)
    assert frame.run_key.nunique() == len(JOBS)
    assert set(st.frame("pymunk").engine) == {"pymunk"} and st.frame("mujoco").empty


def test_fresh_runs_again(stored) -> None:
    st, *_ = stored
    assert not any(r.cached for r in run_jobs(JOBS[:1], workers=0, store=st, fresh=True))


def test_a_history_is_required_where_plots_need_it(stored) -> None:
    st, *_ = stored  # the work-precision run has no history stored: a plotting job reruns
    job = Job("pymunk", "ball-on-plate", V1, "native", 1e-5, study="matrix", keep_history=True)
    assert not run_jobs([job], workers=0, store=st)[0].cached


def test_a_plotting_run_that_recorded_nothing_is_served(tmp_path: Path) -> None:
    """An unsupported run has no history; it is stored as such, not rerun by every report."""
    require_engine("pymunk")
    job = Job("pymunk", "ball-on-plate", V1, "injected", 1e-5, study="matrix",
              parameters=(("exponent", 1.0), ("model", "kelvin-voigt"),
                          ("nominal_restitution", 0.5), ("stiffness", 1e7)), keep_history=True)
    st = store_mod.Store(tmp_path / "r.duckdb")
    first = run_jobs([job], workers=0, store=st)[0]
    assert first.run["status"] == "unsupported" and first.history == {}
    again = run_jobs([job], workers=0, store=st)[0]
    assert again.cached and again.history == {}
    assert json.dumps(again.run, sort_keys=True) == json.dumps(first.run, sort_keys=True)


def test_the_key_sees_every_input() -> None:
    ball = BallOnPlate(velocity_m_s=1.0)

    def key(scenario=ball, mode="native", **settings) -> str:
        return store_mod.run_key(store_mod.run_inputs("pymunk", "ball-on-plate", scenario, mode,
                                                      RunSettings(**settings)))

    base = key(timestep_s=1e-6)
    assert base == key(timestep_s=1e-6)
    variants = [key(timestep_s=2e-6), key(mode="injected", timestep_s=1e-6),
                key(scenario=ball.replace(damping_s_per_m=0.2), timestep_s=1e-6),
                key(timestep_s=1e-6, params={"elasticity": 0.5}),
                key(timestep_s=1e-6, tuned={"elasticity": 0.5}),
                key(timestep_s=1e-6, options={"integrator": "x"})]
    assert len({base, *variants}) == 1 + len(variants)
    inputs = store_mod.run_inputs("pymunk", "ball-on-plate", ball, "native", RunSettings())
    assert inputs["impactbench_version"] == store_mod.impactbench_version()
    assert "+" in inputs["impactbench_version"]


def test_crashed_runs_are_not_stored(tmp_path: Path) -> None:
    st = store_mod.Store(tmp_path / "r.duckdb")
    run = {"status": "crashed", "message": "died", "rel_error": {"restitution": math.nan}}
    job = {"engine": "x", "mode": "native", "scenario": "ball-on-plate", "velocity_m_s": 1.0}
    assert st.put([("k", {"impactbench_version": "v"}, job, run, {})]) == 0
    assert st.get(["k"]) == {}


def test_a_file_that_is_no_store_is_one_line(tmp_path: Path) -> None:
    bad = tmp_path / "bad.duckdb"
    bad.write_text("not a database")
    with pytest.raises(ValueError, match=r"^store = .*bad\.duckdb"):
        store_mod.Store(bad).get(["k"])


def test_twin_jobs_run_once_and_share_the_run(tmp_path: Path) -> None:
    require_engine("pymunk")
    st = store_mod.Store(tmp_path / "r.duckdb")
    twins = [Job("pymunk", "ball-on-plate", V1, "native", 1e-5, study="matrix", keep_history=True),
             Job("pymunk", "ball-on-plate", V1, "native", 1e-5, study="work_precision")]
    first = {r.job.study: r for r in run_jobs(twins, workers=0, store=st)}
    assert first["matrix"].run == first["work_precision"].run  # one run, not two
    assert first["matrix"].history and not first["work_precision"].history
    again = run_jobs(twins, workers=0, store=st)
    pd.testing.assert_frame_equal(pd.DataFrame(tidy(first.values())), pd.DataFrame(tidy(again)))


def test_every_registered_engine_has_its_distribution() -> None:
    """``engine_version`` reads package metadata for every built-in engine: its spec's
    distribution, the one installed here."""
    from importlib import metadata

    from impactbench.engines.registry import SPECS

    from impactbench import store

    for name, spec in SPECS.items():
        require_engine(name)
        assert store.engine_version(name) == metadata.version(spec.distribution), name
    for engine in SPECS:
        assert store.engine_version(engine)


def test_a_store_written_before_points_is_migrated_once(tmp_path: Path) -> None:
    """A store made by impactbench before scenario specs (its ``local``, ``structure`` and
    ``velocity_m_s`` columns; rebuilt from ``data/store_before_points.json``, dumped from a
    real store of that version) opens: its rows keep their values and get a JSON ``point``,
    the old columns go, and new runs are stored beside them."""
    import duckdb

    old = json.loads((Path(__file__).parent / "data" / "store_before_points.json").read_text())
    path = tmp_path / "old.duckdb"
    con = duckdb.connect(str(path))
    con.execute(old["schema"])
    for table in ("results", "runs"):
        cols = old[table]["columns"]
        marks = ", ".join("?" for _ in cols)
        con.executemany(f"INSERT INTO {table} ({', '.join(cols)}) VALUES ({marks})",
                        old[table]["rows"])
    con.close()
    before = {(r[0], r[1]): r for r in old["results"]["rows"]}
    col = {c: i for i, c in enumerate(old["results"]["columns"])}

    st = store_mod.Store(path)
    require_engine("pymunk")
    job = Job("pymunk", "ball-on-plate", (("velocity_m_s", 3.0),), "injected", 1e-5)
    assert run_jobs([job], workers=0, store=st)[0].run["status"] == "ok"  # a write migrates
    frame = st.frame()
    assert {"local", "structure", "velocity_m_s"}.isdisjoint(frame.columns)
    migrated = frame[frame.run_key.isin({k for k, _ in before})]
    assert len(migrated) == len(before) == 10
    for r in migrated.itertuples():
        row = before[(r.run_key, r.metric)]
        assert r.value == pytest.approx(row[col["value"]], rel=0, abs=0)
        point = json.loads(r.point)
        assert point["velocity_m_s"] == row[col["velocity_m_s"]]
        if row[col["scenario"]] == "rigid-flexible":
            assert (point["local"], point["structure"]) == (row[col["local"]],
                                                            row[col["structure"]])
        else:
            assert set(point) == {"velocity_m_s"}
    new = frame[~frame.run_key.isin({k for k, _ in before})]
    assert {json.loads(p)["velocity_m_s"] for p in new.point} == {3.0}
    st._connect().close()  # a second open for writing finds nothing to migrate
    assert len(st.frame()) == len(frame)
