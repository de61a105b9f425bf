"""The comparison report end to end on small configs (real engines, worker processes)."""

from __future__ import annotations

import json
from pathlib import Path

import pandas as pd
import pytest
from conftest import SMALL_REPORT, require_engine
from impactbench.engines.base import DISABLE_ENV, ENGINES_ENV, available_engines
from impactbench.reference import hunt_crossley
from impactbench.reference.scenarios import BallOnPlate

from impactbench import config, report
from impactbench.matrix import Job, run_jobs

V1 = (("velocity_m_s", 1.0),)
"""The point of a ball run at 1 m/s."""

COLUMNS = ["study", "scenario", "local", "structure", "engine", "mode", "velocity_m_s",
           "angle_deg", "height_m", "timestep_s", "metric", "value", "reference", "rel_error",
           "resolved", "params", "status", "message", "wall_s", "engine_version",
           "penetration_ratio", "energy_ratio", "step_overlap_ratio", "phases", "advice",
           "value_min", "value_max"]


def test_report_writes_every_file(small_report: report.Report) -> None:
    out = small_report.out_dir
    for name in ("README.md", "index.html", "results.csv", "results.parquet", "metadata.json"):
        assert (out / name).stat().st_size > 0, name
    figs = {p.name for p in (out / "figures").glob("report_*.png")}
    for needle in ("force_ball_v1", "force_rf_linear_linear_v2", "hysteresis_ball_v1",
                   "restitution_vs_velocity", "error_heatmap_ball_on_plate",
                   "error_heatmap_rigid_flexible", "work_precision"):
        assert any(needle in f for f in figs), needle
    html = (out / "index.html").read_text()
    assert html.count("<img ") == len(figs) and "<table>" in html
    meta = json.loads((out / "metadata.json").read_text())
    assert {"commit", "config_hash", "engines", "python", "platform", "runs"} <= meta.keys()
    assert all("wall_s" in r for r in meta["runs"])


def test_results_are_tidy_and_carry_the_reference(small_report: report.Report) -> None:
    df = pd.read_csv(small_report.out_dir / "results.csv", keep_default_na=False)
    assert list(df.columns) == COLUMNS
    assert df.equals(pd.read_parquet(small_report.out_dir / "results.parquet")
                     .astype(df.dtypes.to_dict()).fillna(""))
    ref = hunt_crossley.solve(BallOnPlate(velocity_m_s=1.0))
    ball = df[(df.study == "matrix") & (df.scenario == "ball-on-plate")]
    for metric, value in ref.items():
        assert (ball[ball.metric == metric].reference.astype(float) == value).all()
    assert set(ball.engine) == {"mujoco", "pybullet", "pymunk", "drake"}


def test_headline_tables_show_statuses_as_words(small_report: report.Report) -> None:
    text = (small_report.out_dir / "README.md").read_text()
    assert "## Scoreboard" in text and "| peak force (N) | pulse width (s) |" in text
    assert "## What this means" in text and "## How to read it" in text
    for engine in set(available_engines()) & set(SMALL_REPORT["report"]["engines"]):
        assert f"**{engine} " in text


def test_report_says_how_injection_reaches_each_engine(small_report: report.Report) -> None:
    """Issue 16: injection is the law through the engine's own contact integration; the report
    shows each adapter's line, and the engines that cannot do that say so."""
    from impactbench.engines.base import get_adapter

    text = (small_report.out_dir / "README.md").read_text()
    for engine in set(available_engines()) & set(SMALL_REPORT["report"]["engines"]):
        line = get_adapter(engine).injection
        assert line and f"Injection in {engine}: {line}." in text, engine
    cannot = {e for e in available_engines() if get_adapter(e).injection.startswith("cannot:")}
    assert cannot <= {"pymunk", "drake", "sapien", "dart", "box2d"}
    assert {"mujoco", "pybullet"}.isdisjoint(cannot)


def test_report_survives_an_unavailable_engine(tmp_path: Path,
                                               monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(DISABLE_ENV, "pymunk")
    cfg = config.parse({"report": {"engines": ["pymunk", "mujoco"], "modes": ["injected"]},
                        "ball_on_plate": {"velocities_m_s": [1.0]}})
    rep = report.build(cfg, tmp_path, show_progress=False)
    status = rep.results.groupby("engine").status.first()
    assert status["pymunk"] == "unavailable"
    assert status["mujoco"] in ("ok", "unavailable")
    assert "unavailable" in (tmp_path / "README.md").read_text()


def test_same_config_gives_identical_results(tmp_path: Path) -> None:
    cfg = config.parse({"report": {"engines": ["mujoco", "pymunk"],
                                   "modes": ["native", "injected"]},
                        "ball_on_plate": {"velocities_m_s": [2.0]}})
    a = report.build(cfg, tmp_path / "a", show_progress=False, workers=2).results
    b = report.build(cfg, tmp_path / "b", show_progress=False, workers=1).results
    pd.testing.assert_frame_equal(a.drop(columns="wall_s"), b.drop(columns="wall_s"))


def test_a_dying_worker_becomes_a_crashed_row(monkeypatch: pytest.MonkeyPatch) -> None:
    plugin_dir = str(Path(__file__).resolve().parent.parent / "engines")
    monkeypatch.setenv(ENGINES_ENV, "crasher=crashing_adapter:CrashingAdapter")
    monkeypatch.syspath_prepend(plugin_dir)  # spawned workers inherit the parent's sys.path
    jobs = [Job("crasher", "ball-on-plate", V1, "native", None, study="matrix"),
            Job("pymunk", "ball-on-plate", V1, "injected", None, study="matrix")]
    results = {r.job.engine: r.run for r in run_jobs(jobs, workers=2)}
    assert results["crasher"]["status"] == "crashed"
    assert "died" in results["crasher"]["message"]
    assert results["pymunk"]["status"] in ("ok", "unavailable")


def test_what_this_means_names_each_engines_own_contact(small_report: report.Report) -> None:
    """pymunk's rigid–flexible native contact is rigid (e = 1), not a linear k1 spring."""
    text = (small_report.out_dir / "README.md").read_text()
    paragraphs = {p.split("**")[1].split()[0]: p for p in text.splitlines()
                  if p.startswith("**") and "**. " in p}
    for engine in set(available_engines()) & set(SMALL_REPORT["report"]["engines"]):
        rf = paragraphs[engine].split("Rigid–flexible, injected")[-1]
        if engine == "pymunk":
            assert "a rigid, perfectly elastic contact with e = 1" in rf
            assert "k1 contact" not in rf
        else:
            assert "a linear, undamped k1 contact" in rf


def test_render_key_sees_values_not_the_sign_of_zero(tmp_path: Path) -> None:
    """A served run's history comes back from the store with 0.0 for −0.0; the rendering
    (and so its key) is the same, so a cached rerun keeps the rendered files."""
    import numpy as np

    from impactbench.matrix import JobResult

    cfg = config.parse({"report": {"engines": ["pymunk"], "modes": ["injected"]}})
    job = Job("pymunk", "ball-on-plate", V1, "injected", 1e-5, study="matrix", keep_history=True)

    def key(force: list[float]) -> str:
        history = {"time_s": np.array([0.0, 1e-5]), "normal_force_n": np.array(force),
                   "penetration_m": np.array([0.0, 1e-6])}
        return report.render_key(pd.DataFrame({"a": [1.0]}), [JobResult(job, {}, history)],
                                 {}, cfg, tmp_path)

    assert key([-0.0, 5.0]) == key([0.0, 5.0])
    assert key([0.0, 5.0]) != key([0.0, 5.000000001])


def test_keep_unchanged_leaves_a_report_with_the_same_results_as_it_was(tmp_path: Path) -> None:
    """``make report`` on a fresh machine runs everything again (new wall times); with
    ``keep_unchanged`` a folder whose results differ only in wall times stays byte for byte,
    metadata.json included, so a newcomer's checkout is not left dirty."""
    from impactbench.store import Store

    require_engine("pymunk")
    cfg = config.parse({"report": {"engines": ["pymunk"], "modes": ["injected"]},
                        "ball_on_plate": {"velocities_m_s": [1.0]}})
    out = tmp_path / "rep"
    first = report.build(cfg, out, show_progress=False, workers=0,
                         store=Store(tmp_path / "a.duckdb"))
    before = {p.relative_to(out): p.read_bytes() for p in out.rglob("*") if p.is_file()}
    again = report.build(cfg, out, show_progress=False, workers=0,
                         store=Store(tmp_path / "b.duckdb"), keep_unchanged=True)
    assert again.kept and not first.kept
    after = {p.relative_to(out): p.read_bytes() for p in out.rglob("*") if p.is_file()}
    assert after == before
    changed = config.parse({"report": {"engines": ["pymunk"], "modes": ["injected"]},
                            "ball_on_plate": {"velocities_m_s": [2.0]}})
    third = report.build(changed, out, show_progress=False, workers=0,
                         store=Store(tmp_path / "b.duckdb"), keep_unchanged=True)
    assert not third.kept and set(third.results.velocity_m_s) == {2.0}
