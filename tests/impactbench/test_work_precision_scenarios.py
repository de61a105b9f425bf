"""Work–precision of another scenario than the ball's (``[work_precision.<table>]``, issue
22: the oblique impact at 45°): the config's sub-table, the jobs it plans, and its figure."""

from __future__ import annotations

from pathlib import Path

import pytest
from conftest import require_engine

from impactbench import config, report
from impactbench.matrix import plan

SMALL = {
    "report": {"engines": ["pymunk"], "modes": ["native", "injected"]},
    "ball_on_plate": {"velocities_m_s": [1.0]},
    "oblique": {"angles_deg": [45.0], "velocities_m_s": [2.0]},
    "work_precision": {"velocities_m_s": [1.0], "timesteps_s": [1e-5, 1e-6],
                       "oblique": {"angles_deg": [20.0, 45.0], "modes": ["injected"]}},
}


def test_the_sub_table_studies_the_scenario_at_its_points() -> None:
    cfg = config.parse(SMALL)
    (wp,) = cfg.work_precision_more
    assert wp.scenario == "oblique" and wp.modes == ("injected",)
    assert wp.timesteps_s == (1e-5, 1e-6)  # the parent's
    assert wp.points == ((("angle_deg", 20.0), ("velocity_m_s", 2.0)),
                         (("angle_deg", 45.0), ("velocity_m_s", 2.0)))  # V from [oblique]
    jobs = [j for j in plan(cfg) if j.study == "work_precision" and j.scenario == "oblique"]
    assert sorted((dict(j.point)["angle_deg"], j.timestep_s) for j in jobs) == [
        (20.0, 1e-6), (20.0, 1e-5), (45.0, 1e-6), (45.0, 1e-5)]
    assert {j.mode for j in jobs} == {"injected"}


def test_the_packaged_default_studies_the_oblique_impact_at_45_degrees() -> None:
    (wp,) = config.load().work_precision_more
    assert wp.scenario == "oblique" and [dict(p)["angle_deg"] for p in wp.points] == [45.0]


@pytest.mark.parametrize(("sub", "needle"), [
    ({"angle_deg": [45.0]}, "work_precision.oblique.angle_deg"),
    ({"angles_deg": [-5.0]}, "work_precision.oblique.angles_deg"),
    ({"angles_deg": [45.0], "modes": ["tuned"]}, "work_precision.oblique.modes"),
])
def test_bad_sub_tables_are_one_line_errors(sub: dict, needle: str) -> None:
    bad = {**SMALL, "work_precision": {**SMALL["work_precision"], "oblique": sub}}
    with pytest.raises(ValueError, match=needle.replace(".", r"\.")) as info:
        config.parse(bad)
    assert "\n" not in str(info.value)


def test_an_unknown_scenario_table_is_named() -> None:
    bad = {**SMALL, "work_precision": {**SMALL["work_precision"], "obliqe": {}}}
    with pytest.raises(ValueError, match=r"work_precision\.obliqe"):
        config.parse(bad)


def test_the_report_draws_one_figure_per_scenario(tmp_path: Path) -> None:
    require_engine("pymunk")
    rep = report.build(config.parse(SMALL), tmp_path / "r", workers=0, store=None,
                       show_progress=False)
    names = sorted(p.name for p in (tmp_path / "r" / "figures").glob("report_work_pr*.png"))
    assert names == ["report_work_precision.png", "report_work_precision_oblique.png"]
    wp = rep.results[(rep.results.study == "work_precision")
                     & (rep.results.scenario == "oblique")]
    assert sorted(wp.angle_deg.unique()) == [20.0, 45.0] and set(wp["mode"]) == {"injected"}
    text = (tmp_path / "r" / "README.md").read_text()
    assert "Work–precision, oblique impact; θ = 20, 45 °; V = 2 m/s" in text
