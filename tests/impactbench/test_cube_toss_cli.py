"""The cube-toss scenario wired in (issue 23): ``run cube-toss`` on the real engines,
its one-line errors, the data gates and the report's "Against real tosses" section.

A handful of tosses (0, 1, 57) keeps every engine run well under a second; the replays
themselves are tested in ``test_cube_tosses.py``.
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import pandas as pd
import pytest
from conftest import require_engine

from impactbench import config, gates, scenarios
from impactbench.cli import main
from impactbench.cube_tosses import scenario as toss_scenario
from impactbench.cube_tosses.protocol import HALF_WIDTH_M, INERTIA_KG_M2, MASS_KG, SAMPLE_DT_S
from impactbench.cube_tosses.replays import replay
from impactbench.cube_tosses.selection import RESULT_KEYS
from impactbench.cube_tosses.tune import load_tuned

NAME = "cube-toss"
IDS = [0, 1, 57]
TIMING = ("elapsed_s", "tosses_per_s")
"""replay()'s keys that differ between two runs of the same tosses (wall time)."""


def run(capsys, *argv: str) -> tuple[int, str, str]:
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def one_line(err: str, *needles: str) -> None:
    assert err.startswith("impactbench: error:") and err.count("\n") == 1, err
    for needle in needles:
        assert needle in err, err


def run_json(capsys, engine: str, *flags: str) -> tuple[int, dict]:
    code, out, _ = run(capsys, "run", NAME, "--engine", engine, *flags, "--json")
    return code, json.loads(out)


# ------------------------------------------------------------------ the spec


def test_registered_as_measured_and_the_protocol_constants() -> None:
    spec = scenarios.get(NAME)
    assert spec.measured and spec.axes == () and spec.table == "cube_toss"
    box = spec.build()
    assert (box.half_width_m, box.mass_kg, box.inertia_kg_m2) == (HALF_WIDTH_M, MASS_KG,
                                                                  INERTIA_KG_M2)
    assert box.sample_dt_s == SAMPLE_DT_S and box.tosses == "test"
    assert spec.build(parameters={"tosses": " 0, 1,57"}).tosses == "0,1,57"
    assert set(spec.metrics) == {k for k in RESULT_KEYS if k.startswith(
        ("position_error_", "rotation_error_deg_"))}
    for spec_ in scenarios.specs():  # the others are compared with a reference solution
        assert spec_.measured == (spec_.name == NAME)


# ------------------------------------------------------------------ run --json = replay()


@pytest.mark.parametrize("engine, flags, mode, param_set", [
    ("pybullet", (), "default", None),
    ("mujoco", ("--param-set", "dair2022"), "custom", "dair2022"),
    ("drake", ("--param-set", "dair2022"), "custom", "dair2022"),
])
def test_run_json_equals_replay(capsys, engine, flags, mode, param_set) -> None:
    require_engine(engine)
    code, got = run_json(capsys, engine, "--mode", mode, *flags, "--tosses", "0,1,57")
    want = replay(engine, mode, tosses=IDS, param_set=param_set)
    assert code == 0 and got["status"] == "ok" and got["message"] == ""
    for key in ("status", "tosses", "failed", "position_error_mean", "position_error_median",
                "rotation_error_deg_mean", "rotation_error_deg_median", "position_error_q1",
                "position_error_q3", "rotation_error_deg_q1", "rotation_error_deg_q3",
                "per_toss"):
        assert key in got, key
    for key in set(RESULT_KEYS) - set(TIMING):
        assert got[key] == json.loads(json.dumps(want[key])), key
    assert [r["toss"] for r in got["per_toss"]] == IDS
    assert got["tosses"] == 3 and got["failed"] == []
    assert got["engine_version"] == want["engine_setup"]["version"]
    assert got["timestep_s"] == pytest.approx(SAMPLE_DT_S / 10, rel=1e-12)
    assert got["substeps"] == 10 and "DAIR" in got["timestep_source"]


def test_test_split_is_the_default_and_data_file_means_every_toss(capsys, tmp_path) -> None:
    require_engine("pybullet")
    from impactbench.cube_tosses.data import load

    _, got = run_json(capsys, "pybullet", "--mode", "default")
    assert got["split"] == "test" and got["tosses"] == 89
    mine = tmp_path / "mine.csv"
    load()[lambda d: d.toss.isin([0, 57])].to_csv(mine, index=False)
    _, got = run_json(capsys, "pybullet", "--mode", "default", "--data", mine)
    assert got["split"] == "all" and [r["toss"] for r in got["per_toss"]] == [0, 57]
    assert got["data"] == str(mine)


def test_timestep_maps_to_substeps(capsys) -> None:
    require_engine("mujoco")
    _, got = run_json(capsys, "mujoco", "--mode", "default", "--tosses", "0",
                      "--timestep", "1e-3")
    assert got["substeps"] == 7  # round((1/148) / 1e-3) = round(6.76)
    assert got["timestep_s"] == pytest.approx(SAMPLE_DT_S / 7, rel=1e-12)
    assert got["protocol"]["substeps"] == 7 and "rounded to 1/7" in got["timestep_source"]
    _, exact = run_json(capsys, "mujoco", "--mode", "default", "--tosses", "0",
                        "--timestep", repr(SAMPLE_DT_S / 20))
    assert exact["substeps"] == 20 and exact["timestep_source"] == "given"


@pytest.mark.parametrize("engine", ["mujoco", "pybullet", "drake", "sapien", "dart",
                                    "newton"])
def test_the_users_box_reaches_the_engine_and_the_errors(capsys, engine: str) -> None:
    """A box of the user's is built by the engine (its inertia read back from the engine's
    model) and scales the position error; DAIR's cube is untouched for the next run."""
    require_engine(engine)
    _, got = run_json(capsys, engine, "--mode", "default", "--tosses", "0",
                      "--half-width", "0.06", "--mass", "0.5", "--inertia", "0.001")
    assert math.isclose(got["engine_setup"]["cube_inertia_kg_m2"], 0.001, rel_tol=1e-6)
    assert got["protocol"]["half_width_m"] == 0.06
    assert got["box"] == {"half_width_m": 0.06, "mass_kg": 0.5, "inertia_kg_m2": 0.001}
    _, dair = run_json(capsys, engine, "--mode", "default", "--tosses", "0")
    assert math.isclose(dair["engine_setup"]["cube_inertia_kg_m2"], INERTIA_KG_M2,
                        rel_tol=1e-6)


@pytest.mark.parametrize("engine, flags, words", [
    ("pymunk", ("--mode", "default"), "2D engine"),
    ("box2d", ("--mode", "default"), "2D engine"),
    ("newton", ("--mode", "injected"), "no Python between steps"),
    ("mjx", ("--mode", "injected"), "mode injected in mjx"),
    ("newton", ("--mode", "injected"), "captured warp CPU graphs"),
])
def test_unsupported_engines_and_modes_say_why(capsys, engine, flags, words) -> None:
    code, out, err = run(capsys, "run", NAME, "--engine", engine, *flags, "--json")
    got = json.loads(out)
    assert code == 1 and got["status"] == "unsupported" and words in got["message"]
    assert math.isnan(got["position_error_median"] if got["position_error_median"] is not None
                      else math.nan)
    assert "exit 1 (--allow-status" in err
    code, _, _ = run(capsys, "run", NAME, "--engine", engine, *flags,
                     "--allow-status", "unsupported")
    assert code == 0


# ------------------------------------------------------------------ bad input


@pytest.mark.parametrize("argv, needles", [
    ([NAME, "--engine", "mujoco", "--velocity", "2"],
     ["velocity = 2", NAME, "no impact velocity"]),
    (["ball-on-plate", "--engine", "mujoco"], ["--velocity", "ball-on-plate"]),
    ([NAME, "--engine", "mujoco", "--mode", "custom", "--param-set", "dair22"],
     ["param-set = 'dair22'", "dair2022, dair2022x3", "did you mean 'dair2022'"]),
    ([NAME, "--engine", "drake", "--mode", "default", "--param-set", "dair2022"],
     ["default mode sets no engine parameters"]),
    ([NAME, "--engine", "drake", "--mode", "custom"], ["--param-set (dair2022)"]),
    ([NAME, "--engine", "mujoco", "--tosses", "0,x"], ["tosses = '0,x'"]),
    ([NAME, "--engine", "mujoco", "--tosses", "3"], ["toss 3 not in the data"]),
    ([NAME, "--engine", "mujoco", "--data", "/nonexistent.csv"],
     ["data = '/nonexistent.csv'", "no such file"]),
    ([NAME, "--engine", "mujoco", "--mass", "-1"], ["mass_kg = -1"]),
    ([NAME, "--engine", "pybullet", "--mode", "custom", "--param", "board.stiffness=1"],
     ["board.stiffness", "not a pybullet cube parameter"]),
    ([NAME, "--engine", "mujoco", "--mode", "default", "--param", "board.solref=1,1"],
     ["--param needs --mode custom (got default)"]),
    ([NAME, "--engine", "mujoco", "--allow-status", "partal"],
     ["allow-status = 'partal'"]),
    (["ball-on-plate", "--engine", "mujoco", "--velocity", "1", "--param-set",
      "dair2022"], ["ball-on-plate has no parameter sets"]),
    ([NAME, "--engine", "mujoco", "--max-energy-ratio", "1.1"],
     ["judged against its measurements"]),
])
def test_bad_input_is_one_line_exit_2(capsys, argv, needles) -> None:
    code, _, err = run(capsys, "run", *argv)
    assert code == 2
    one_line(err, *needles)


def test_reference_cube_toss_describes_the_measurement(capsys) -> None:
    code, out, _ = run(capsys, "reference", NAME, "--tosses", "0,1,57", "--json")
    got = json.loads(out)
    assert code == 0 and got["ids"] == IDS and got["tosses"] == 3
    assert (got["tosses_in_file"], got["train_in_file"], got["test_in_file"]) == (456, 367, 89)
    assert got["sample_dt_s_median"] == pytest.approx(SAMPLE_DT_S, rel=1e-6)
    code, _, err = run(capsys, "reference", NAME, "--tosses", "train,test")
    assert code == 2
    one_line(err, "tosses = 'train,test'")


# ------------------------------------------------------------------ gates


GATE = """
[[gate]]
engine = "pybullet"
mode = ["default", "custom"]
scenario = "cube-toss"
param_set = "dair2022"
baseline_margin = 0.05
[gate.tolerance]
position_error_median = {tol}
"""


def test_data_gate_ids_and_bad_gates() -> None:
    checks = gates.parse_gates(GATE.format(tol=0.6).replace('mode = ["default", "custom"]',
                                                            'mode = "custom"'), "g.toml").checks
    assert [c.id for c in checks] == [
        "pybullet-custom-cube-toss-dtdefault-param_set=dair2022-position_error_median"]
    with pytest.raises(ValueError, match=r"g.toml:\d+: gate 1: .*default mode sets no engine"):
        gates.parse_gates(GATE.format(tol=0.6), "g.toml")  # default mode with a param set
    with pytest.raises(ValueError, match=r"velocities_m_s.*unknown for a data scenario"):
        gates.parse_gates(GATE.format(tol=0.6).replace("baseline_margin", "velocities_m_s = "
                                                       "[1.0]\nbaseline_margin"), "g.toml")
    custom = GATE.format(tol=0.6).replace('mode = ["default", "custom"]', 'mode = "custom"')
    with pytest.raises(ValueError, match=r"tolerance key = 'restitution'"):
        gates.parse_gates(custom.replace("position_error_median", "restitution"), "g.toml")
    with pytest.raises(ValueError, match=r"param-set = 'dair22'.*did you mean 'dair2022'"):
        gates.parse_gates(custom.replace('"dair2022"', '"dair22"'), "g.toml")


def test_data_gate_is_absolute_and_fails_a_partial_run(tmp_path) -> None:
    require_engine("pybullet")
    from impactbench.store import Store

    text = GATE.replace('mode = ["default", "custom"]', 'mode = "custom"')
    (check,) = gates.parse_gates(text.format(tol=0.6), "g.toml").checks
    store = Store(tmp_path / "s.duckdb")
    result = gates.execute([check.run], jobs=0, store=store)[check.run]
    assert result["tosses"] == 89 and result["reference"][check.metric] == 0.0
    assert result["rel_error"][check.metric] == result[check.metric] > 0
    assert gates.judge(check, result).mark == gates.PASS
    (tight,) = gates.parse_gates(text.format(tol=0.01), "g.toml").checks
    assert gates.judge(tight, result).mark == gates.FAIL
    baseline = {check.id: {"rel_error": 1.2 * result[check.metric]}}
    assert gates.judge(check, result, baseline).mark == gates.BETTER
    spec = scenarios.get(NAME)  # a toss that failed: no value (the errors are over all tosses)
    partial = {**result, "rel_error": spec.run_errors({**result, "failed": [0]}, {
        check.metric: result[check.metric]}, {}, {})}
    assert gates.judge(check, partial).mark == gates.FAIL
    again = gates.execute([check.run], jobs=0, store=store)[check.run]  # from the store
    assert again["per_toss"] == json.loads(json.dumps(result["per_toss"]))


def test_shipped_data_gates_have_baselines() -> None:
    root = Path(__file__).resolve().parents[2]
    parsed = gates.load_gates(root / "gates.toml")
    baseline = gates.load_baseline(root / "gates_baseline.json")
    data = [c for c in parsed.checks if c.run.scenario == NAME]
    # every engine and mode the default report's real-tosses section shows has a gate
    from impactbench.engines.base import get_adapter
    from impactbench.engines.cube_toss import ENGINES

    from impactbench.config import REPLAY_MODES

    shown = set()
    cube = scenarios.get(NAME).build()
    for engine in ENGINES:
        builder = get_adapter(engine).builder(cube)
        for mode in REPLAY_MODES:
            if builder.modes is not None and mode not in builder.modes:
                continue  # the builder says why (injected in MJX and Newton)
            if mode == "tuned" and toss_scenario.tuned_settings(engine, cube)[1]["mismatch"]:
                continue  # no packaged fit of this engine
            if mode == "custom":
                try:
                    cube.engine_parameters(engine, mode, {"param_set": "dair2022"}, None)
                except ValueError:  # no such parameter set for this engine
                    continue
            shown.add((engine, mode))
    assert {(c.run.engine, c.run.mode) for c in data} == shown
    for c in data:
        assert c.id in baseline and baseline[c.id]["reference"] == 0.0
        assert baseline[c.id]["value"] == baseline[c.id]["rel_error"] < c.tolerance


# ------------------------------------------------------------------ config and report


def tiny_config(tmp_path: Path, **table) -> config.ReportConfig:
    return config.parse({"report": {"engines": ["pybullet"]},
                         "cube_toss": {"engines": ["pybullet", "pymunk"],
                                       "param_sets": ["dair2022"], "tosses": "0,1,57",
                                       **table},
                         "execution": {"store": str(tmp_path / "s.duckdb")}})


def test_config_table_plans_no_matrix_jobs_and_checks_its_keys(tmp_path) -> None:
    from impactbench.matrix import plan

    cfg = tiny_config(tmp_path)
    (sm,) = cfg.scenarios
    assert sm.name == NAME and sm.points() == [] and sm.parameters == {"tosses": "0,1,57"}
    # no matrix points: its jobs are the replays (per engine and mode, dair2022 where the
    # engine has it), planned beside the matrix and keeping their trajectories
    jobs = plan(cfg)
    assert {j.study for j in jobs} == {"real_tosses"} and all(j.keep_history for j in jobs)
    assert all(j.scenario == NAME and j.point == () for j in jobs)
    for table, words in (({"param_sets": ["dair22"]}, "cube_toss.param_sets: param-set = "
                                                      "'dair22'"),
                         ({"modes": ["sometimes"]}, "cube_toss.modes"),
                         ({"mass_kg": 0}, "cube_toss.mass_kg = 0"),
                         ({"velocities_m_s": [1.0]}, "cube_toss.velocities_m_s: unknown key")):
        with pytest.raises(ValueError, match=words.replace("(", r"\(").replace(")", r"\)")):
            tiny_config(tmp_path, **table)
    # the packaged default replays the test split beside DAIR's sets (Against real tosses)
    (cube,) = [s for s in config.load().scenarios if s.name == NAME]
    assert cube.points() == [] and cube.parameters == {"tosses": "test"}
    assert config.load().raw["cube_toss"]["param_sets"] == ["dair2022"]


def test_report_section_renders_with_a_tiny_config(tmp_path) -> None:
    require_engine("pybullet")
    from impactbench.report_render import ReportContext, render_documents
    from impactbench.report_sections import real_tosses, sections

    cfg = tiny_config(tmp_path, trajectories="all")
    (tmp_path / "rep" / "figures").mkdir(parents=True)
    ctx = ReportContext(cfg, pd.DataFrame(), {}, tmp_path / "rep")
    docs = render_documents(ctx, [s for s in sections() if s.template == "real_tosses"],
                            "t", "")
    md = docs["md"]
    assert "## Against real tosses" in md and "tosses 0,1,57" in md
    want = replay("pybullet", "custom", tosses=IDS, param_set="dair2022")
    assert f"| {want['position_error_median']:.3f} [" in md
    # the reason is a numbered note under the table (no note column)
    mark = re.search(r"\| pymunk \| all \| — \| unsupported (\S+) \| — \| — \| — \|\n", md)
    assert mark and f"\n> {mark.group(1)} pymunk is a 2D engine" in md
    names = sorted(p.name for p in (tmp_path / "rep" / "figures").glob("*.png"))
    # trajectories: every run's here ("all"); by default only each engine's best run's
    assert names == ["report_cube_toss_error_cdf.png",
                     "report_cube_toss_pybullet_custom_dair2022_trajectories.png",
                     "report_cube_toss_pybullet_default_trajectories.png",
                     "report_cube_toss_pybullet_injected_trajectories.png",
                     "report_cube_toss_pybullet_native_trajectories.png",
                     "report_cube_toss_pybullet_tuned_trajectories.png"]
    assert md.count("![") == 6 and "<img" in docs["html"]
    # the reference model's row first (the model floor), its numbers the model's replay
    from impactbench.cube_tosses.reference_model import replay_reference

    model = replay_reference(IDS)
    assert "| reference model (scipy " in md and "| fitted | reference.toml | 3/3 | " in md
    assert f"| {model['position_error_median']:.3f} [" in md
    assert md.index("| reference model") < md.index("| pybullet ")
    # toss 1 is a training toss (data.split): the tuned row says it is not held out
    assert "1 of the 3 tosses are training tosses the parameters were fitted on" in md
    empty = ReportContext(config.parse({"report": {"engines": ["pybullet"]}}), pd.DataFrame(),
                          {}, tmp_path / "rep")
    assert real_tosses(empty) is None  # no [cube_toss] table, no section


def test_by_default_only_each_engines_best_run_gets_trajectories(tmp_path) -> None:
    require_engine("pybullet")
    from impactbench.report_render import ReportContext
    from impactbench.report_sections import real_tosses

    (tmp_path / "rep" / "figures").mkdir(parents=True)
    ctx = ReportContext(tiny_config(tmp_path, modes=["default", "tuned"]), pd.DataFrame(), {},
                        tmp_path / "rep")
    (part,) = real_tosses(ctx)["parts"]
    assert len(part["trajectories"]) == 1
    names = sorted(p.name for p in (tmp_path / "rep" / "figures").glob("*trajectories.png"))
    default = replay("pybullet", "default", tosses=IDS)["position_error_median"]
    tuned = replay("pybullet", "custom", tosses=IDS, params=load_tuned("pybullet"))
    best = "default" if default < tuned["position_error_median"] else "tuned"
    assert names == [f"report_cube_toss_pybullet_{best}_trajectories.png"]
    with pytest.raises(ValueError, match=r"cube_toss\.trajectories = 'some': must be best"):
        tiny_config(tmp_path, trajectories="some")


def test_the_section_counts_its_replays_on_stderr(tmp_path, capsys) -> None:
    """The replays run after the matrix: never silent (the model, then 5 modes in pybullet,
    and pymunk's 4 — it has no dair2022 set — refused as unsupported)."""
    require_engine("pybullet")
    from impactbench.report_render import ReportContext
    from impactbench.report_sections import real_tosses

    (tmp_path / "rep" / "figures").mkdir(parents=True)
    ctx = ReportContext(tiny_config(tmp_path), pd.DataFrame(), {}, tmp_path / "rep",
                        show_progress=True)
    real_tosses(ctx)
    err = capsys.readouterr().err
    lines = [x for x in err.splitlines() if "replays done" in x]
    assert lines[0].startswith("impactbench: 1 of 10 cube-toss replays done")
    assert lines[-1] == "impactbench: 10 of 10 cube-toss replays done"


def test_the_model_row_can_be_left_out_and_its_key_is_checked(tmp_path) -> None:
    assert config.parse({"cube_toss": {"model": False}}).raw["cube_toss"]["model"] is False
    with pytest.raises(ValueError, match=r"cube_toss\.model = 'yes': must be true or false"):
        config.parse({"cube_toss": {"model": "yes"}})


def test_trajectories_start_at_the_measured_pose() -> None:
    require_engine("mujoco")
    spec = scenarios.get(NAME)
    (tr,) = toss_scenario.trajectories("mujoco", spec.build(), "custom", [57],
                                       params={"param_set": "dair2022"})
    assert tr["toss"] == 57 and tr["t_s"][0] == 0.0
    assert tr["z_sim_m"][0] == pytest.approx(tr["z_ref_m"][0], abs=1e-12)
    assert tr["angle_sim_deg"][0] == 0.0 and len(tr["z_sim_m"]) == len(tr["z_ref_m"])


def test_a_report_replays_beside_the_matrix_and_draws_what_the_replays_kept(
        tmp_path, monkeypatch) -> None:
    """The report plans the replays with the matrix (one run on its workers and store); each
    keeps its best, median and worst toss's trajectories, which the figures draw: a rerun
    served from the store draws them again without replaying anything, and the kept
    trajectories are the ones a replay of those tosses gives."""
    require_engine("pybullet")
    import numpy as np

    from impactbench import report
    from impactbench.matrix import job_inputs, job_settings, plan
    from impactbench.store import Store, run_key

    cfg = tiny_config(tmp_path, modes=["custom"])
    store = Store(tmp_path / "s.duckdb")
    first = report.build(cfg, tmp_path / "a", store=store, workers=0, show_progress=False)
    runs = [r for r in first.results.itertuples() if r.study == "real_tosses"]
    assert {r.engine for r in runs} == {"pybullet"}  # (pymunk has no dair2022 set)
    figure = (tmp_path / "a" / "figures"
              / "report_cube_toss_pybullet_custom_dair2022_trajectories.png")
    assert figure.is_file()
    (job,) = [j for j in plan(cfg) if j.engine == "pybullet"]
    key = run_key(job_inputs(job, job_settings(job)))
    ((run, history),) = store.get([key], with_history=[key]).values()
    kept = toss_scenario.trajectories_of_history(history)
    chosen = [t for _, t in toss_scenario.picks(run["per_toss"])]
    assert [k["toss"] for k in kept] == chosen and len(chosen) == 3
    again = toss_scenario.trajectories("pybullet", job.build_scenario(), "custom", chosen,
                                       params={"param_set": "dair2022"})
    for k, a in zip(kept, again, strict=True):
        for name in toss_scenario.TRAJECTORY_SERIES:
            assert np.array_equal(k[name], a[name]), name

    def no_replays(*args, **kwargs):
        raise AssertionError("replayed again")

    monkeypatch.setattr(toss_scenario, "trajectories", no_replays)
    monkeypatch.setattr("impactbench.engines.base.Adapter.replay_tosses", no_replays)
    second = report.build(cfg, tmp_path / "b", store=store, workers=0, show_progress=False)
    assert (tmp_path / "b" / "figures" / figure.name).is_file()
    same = ["position_error_median", "rotation_error_deg_median"]
    a = first.results[first.results.metric.isin(same)].value.tolist()
    b = second.results[second.results.metric.isin(same)].value.tolist()
    assert a == b


def test_a_replays_estimate_counts_its_samples_and_its_timeout_allows_them() -> None:
    """A replay's steps are every sample of its tosses, ``substeps`` each (the measurement's
    count: 10,071 samples in the 89 test tosses), weighted by the spec's step cost in its
    time estimate: its timeout is then 20 × that, above the 60 s floor a replay of the slow
    engines could pass on a busy machine (DART injected: 16 s here alone, 48 s loaded)."""
    from impactbench import cluster
    from impactbench.evaluate import reference_metrics
    from impactbench.matrix import estimated_steps, plan

    (job, *_) = [j for j in plan(config.load()) if j.study == "real_tosses"]
    ref = reference_metrics(job.build_scenario())
    steps = estimated_steps(job, ref)
    assert steps == ref["samples"] * job.build_scenario().substeps
    assert ref["samples"] == 10071 and ref["tosses"] == 89
    estimate = cluster.run_estimate_s(steps * job.spec.step_cost)
    assert cluster.default_timeout(estimate) > 3 * 60.0
