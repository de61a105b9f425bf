"""The practical study at users' steps: every run measured at 8 phases of the step and merged
(median and range, judged at the worst phase), and the packaged advice for the step run
beside the engine's defaults, shown first with its snippet (real engines)."""

from __future__ import annotations

import pytest
from conftest import require_engine

from impactbench import config, phases, report
from impactbench.advice_files import advice_path, load
from impactbench.matrix import plan

DT = 1 / 240
SMALL = {
    "report": {"engines": ["pybullet"], "modes": ["native"]},
    "ball_on_plate": {"velocities_m_s": [1.0], "timestep_s": {"pybullet": 1e-5}},
    "practical": {"velocities_m_s": [1.0, 3.0], "modes": ["default"],
                  "timesteps_s": {"pybullet": [DT]}},
}


def test_practical_jobs_are_phased_and_carry_the_advice() -> None:
    jobs = [j for j in plan(config.parse(SMALL)) if j.study == "practical"]
    assert {j.phases for j in jobs} == {phases.PHASES}
    advised = [j for j in jobs if j.advice]
    assert {j.velocity_m_s for j in advised} == {1.0, 3.0}
    assert {j.mode for j in advised} == {"custom"}
    assert advised[0].advice == advice_path("pybullet", DT).name
    # the headline matrix at 1e-5 s is not phased (the step resolves the 0.1 ms contact)
    assert {j.phases for j in plan(config.parse(SMALL)) if j.study == "matrix"} == {1}
    off = {**SMALL, "practical": {**SMALL["practical"], "advice": False}}
    assert not any(j.advice for j in plan(config.parse(off)))
    with pytest.raises(ValueError, match=r"practical\.advice = 'yes': must be true or false"):
        config.parse({**SMALL, "practical": {**SMALL["practical"], "advice": "yes"}})


@pytest.fixture(scope="module")
def phased_report(tmp_path_factory: pytest.TempPathFactory) -> report.Report:
    require_engine("pybullet")
    out = tmp_path_factory.mktemp("phased")
    return report.build(config.parse(SMALL), out, show_progress=False, workers=0)


def test_rows_give_the_median_and_range_over_the_phases(phased_report) -> None:
    df = phased_report.results
    rows = df[(df.study == "practical") & (df.metric == "restitution")]
    assert set(rows.phases) == {phases.PHASES}
    measured = rows[rows.status.isin(["ok", "implausible"])]
    assert len(measured)
    assert (measured.value_min <= measured.value + 1e-12).all()
    assert (measured.value <= measured.value_max + 1e-12).all()


def test_the_advice_is_plausible_at_every_phase_and_shown_first(phased_report) -> None:
    """The packaged PyBullet advice at 1/240 s (rigid restitution without ERP push-out):
    ok at 1 and 3 m/s at every phase, within the error its file claims (measured: the same
    runs, so equal), and the first section pastes its snippet."""
    df = phased_report.results
    adv = df[(df.study == "practical") & (df.metric == "restitution") & (df.advice != "")]
    assert set(adv.status) == {"ok"}
    claim = {r["velocity_m_s"]: r for r in load(advice_path("pybullet", DT))["per_speed"]}
    for _, row in adv.iterrows():
        c = claim[row.velocity_m_s]
        assert row.value_min == pytest.approx(c["restitution_min"], rel=1e-9)
        assert row.value_max == pytest.approx(c["restitution_max"], rel=1e-9)
    text = (phased_report.out_dir / "README.md").read_text()
    first = text.index("## At your timestep")
    assert text.index("p.changeDynamics(ball, -1, restitution=", first) \
        < text.index("## Scoreboard")
    assert "advised @ 1/240 s" in text
