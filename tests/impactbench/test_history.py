"""``impactbench history``: each metric's error per engine version and impactbench version held
in the store, without the candidate points a tuning search stored."""

from __future__ import annotations

from pathlib import Path

import pytest
from conftest import require_engine
from impactbench.reference.scenarios import BallOnPlate

from impactbench import store as store_mod
from impactbench.cli import main
from impactbench.commands.history import summarize
from impactbench.matrix import Job, execute, job_settings

V1 = (("velocity_m_s", 1.0),)
"""The point of a ball run at 1 m/s."""

JOB = Job("pymunk", "ball-on-plate", V1, "injected", 1e-5, study="matrix")


def put_as(st: store_mod.Store, version: str, result) -> None:
    """Store a real run as if an older impactbench (``version``) had made it."""
    inputs = store_mod.run_inputs(JOB.engine, JOB.scenario, JOB.build_scenario(), JOB.mode,
                                  job_settings(JOB))
    inputs = {**inputs, "impactbench_version": version}
    st.put([(store_mod.run_key(inputs), inputs, vars(JOB), result.run, {})])


@pytest.fixture
def two_versions(tmp_path: Path) -> tuple[store_mod.Store, object]:
    require_engine("pymunk")
    st = store_mod.Store(tmp_path / "r.duckdb")
    result = execute(JOB)
    assert result.run["status"] == "ok"
    put_as(st, "0.1+aaaaaaaaaa", result)
    put_as(st, "0.2+bbbbbbbbbb", result)
    return st, result


def test_one_row_per_version_and_metric(two_versions) -> None:
    st, result = two_versions
    table = summarize(st.frame())
    assert sorted(table.impactbench_version.unique()) == ["0.1+aaaaaaaaaa", "0.2+bbbbbbbbbb"]
    assert len(table) == 2 * len(result.run["rel_error"])
    restitution = table[table.metric == "restitution"]
    assert list(restitution.runs) == [1, 1]
    assert restitution.max_abs_rel_error.tolist() == [abs(result.run["rel_error"]
                                                          ["restitution"])] * 2


def test_cli_prints_the_table_and_writes_the_plot(two_versions, tmp_path: Path, capsys) -> None:
    st, _ = two_versions
    plot = tmp_path / "h.png"
    assert main(["history", "--store", str(st.path), "--plot", str(plot)]) == 0
    out = capsys.readouterr().out
    assert "0.1+aaaaaaaaaa" in out and "0.2+bbbbbbbbbb" in out and "restitution" in out
    assert plot.read_bytes().startswith(b"\x89PNG")


def test_tuning_candidates_are_left_out(tmp_path: Path, capsys) -> None:
    require_engine("pymunk")
    from impactbench.tuning import tune

    st = store_mod.Store(tmp_path / "r.duckdb")
    res = tune("pymunk", BallOnPlate(), (1.0, 4.0), max_evals=4, store=st)
    frame = st.frame("pymunk")
    assert set(frame.study) == {store_mod.CANDIDATE} and frame.run_key.nunique() > 0
    assert summarize(frame).empty
    assert main(["history", "--store", str(st.path), "--no-plot"]) == 0
    out = capsys.readouterr().out
    assert f"({res.objective.stored} runs stored by tuning searches are candidates" in out
    assert "no stored ok runs" in out


def test_missing_store_is_one_line(tmp_path: Path, capsys) -> None:
    assert main(["history", "--store", str(tmp_path / "none.duckdb")]) == 2
    err = capsys.readouterr().err.strip()
    assert err == f"impactbench: error: store = '{tmp_path / 'none.duckdb'}': no such file " \
                  "(run a report or gate first)"
