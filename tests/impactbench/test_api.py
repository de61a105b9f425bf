"""The Python API (``impactbench.run``, ``reference_solution``, ``tune``, ``build_report``):
the same objects as the commands' ``--json``, light to import, one-line errors, and docstring
examples that run."""

from __future__ import annotations

import dataclasses
import doctest
import json
import subprocess
import sys
import tomllib
import types

import pytest
from conftest import require_engine

import impactbench
from impactbench import scenarios
from impactbench.cli import main

HEAVY = ("numpy", "scipy", "pandas", "matplotlib", "numba", "pyarrow", "duckdb", "dask",
         "distributed", "tqdm", "tabulate", "jinja2", "mujoco", "pybullet", "pymunk", "pydrake")
"""What ``import impactbench`` must not import (``test_cli_startup``'s list)."""


def fresh_python(code: str) -> str:
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          check=True, timeout=120).stdout


def cli_json(capsys: pytest.CaptureFixture[str], *argv: str) -> dict:
    main([*argv, "--json"])  # exits 1 on a non-ok status: the object is printed all the same
    return json.loads(capsys.readouterr().out)


# ------------------------------------------------------------------------------ light import


def test_import_impactbench_imports_no_heavy_library() -> None:
    """``import impactbench`` (and reaching the API's names, not calling them) stays light."""
    out = fresh_python(
        "import json, sys, impactbench\n"
        "names = [impactbench.__version__, impactbench.run, impactbench.tune,\n"
        "         impactbench.RunResult, impactbench.TuneFit]\n"
        f"heavy = sorted({{m.split('.')[0] for m in sys.modules}} & set({HEAVY!r}))\n"
        "print(json.dumps({'heavy': heavy, 'all': impactbench.__all__,\n"
        "                  'dir': [n for n in impactbench.__all__ if n in dir(impactbench)]}))")
    seen = json.loads(out)
    assert seen["heavy"] == []
    assert {"run", "reference_solution", "tune", "build_report", "RunResult",
            "TuneFit"} <= set(seen["all"])
    assert seen["dir"] == seen["all"]


def test_import_impactbench_alone_does_not_import_numpy() -> None:
    out = fresh_python("import sys, impactbench; print('numpy' in sys.modules)")
    assert out.strip() == "False"


def test_report_module_call_delegates_to_report_build(monkeypatch, tmp_path) -> None:
    """``impactbench.build_report(...)`` parses the config, checks engines, and hands
    :func:`impactbench.report.build` the execution options (workers 0 allowed)."""
    import impactbench.report as report_mod

    seen = {}

    def fake_build(cfg, out, **kwargs):
        seen.update(cfg=cfg, out=out, **kwargs)
        return "the report"

    monkeypatch.setattr(report_mod, "build", fake_build)
    small = {"report": {"engines": ["pymunk", "mujoco"], "modes": ["native"]},
             "ball_on_plate": {"velocities_m_s": [1.0]}}
    got = impactbench.build_report(config=small, out=tmp_path / "rep", engines="pymunk", workers=0,
                             store=tmp_path / "s.duckdb", progress=False)
    assert got == "the report"
    assert seen["out"] == tmp_path / "rep" and seen["engines"] == ["pymunk"]
    assert seen["workers"] == 0 and seen["store"].path == tmp_path / "s.duckdb"
    assert seen["cfg"].engines == ("pymunk", "mujoco") and seen["show_progress"] is False
    impactbench.build_report(config=small, out=tmp_path / "rep", store=False)
    assert seen["store"] is None and seen["workers"] is None
    with pytest.raises(ValueError, match=r"engines = 'pymnk'.*did you mean 'pymunk'"):
        impactbench.build_report(config=small, out=tmp_path / "rep", engines=["pymnk"])
    with pytest.raises(ValueError, match="config = 3"):
        impactbench.build_report(config=3, out=tmp_path / "rep")


# ------------------------------------------------------------------------------ the same as the CLI


RUNS = [
    # engine, scenario, keyword arguments, the same as run flags
    ("mujoco", "ball-on-plate", {"mode": "default", "velocity_m_s": 2.0, "timestep_s": 2e-3},
     ["--mode", "default", "--velocity", "2", "--timestep", "2e-3"]),
    ("pymunk", "ball-on-plate", {"params": {"elasticity": 0.8}, "velocity_m_s": 2.0,
                                 "timestep_s": 1e-3, "mass_kg": 0.2},
     ["--mode", "custom", "--param", "elasticity=0.8", "--velocity", "2", "--timestep", "1e-3",
      "--mass", "0.2"]),
    ("mujoco", "ball-on-plate", {"mode": "tuned", "velocity_m_s": 1.0, "timestep_s": 1e-3},
     ["--mode", "tuned", "--velocity", "1", "--timestep", "1e-3"]),
    # no step in default mode: the engine's own (pymunk 1/60 s), as `run` picks it
    ("pymunk", "ball-on-plate", {"mode": "default", "velocity_m_s": 2.0},
     ["--mode", "default", "--velocity", "2"]),
    ("mujoco", "rigid-flexible", {"velocity_m_s": 2.0, "local": "elastoplastic",
                                  "timestep_s": 1e-4},
     ["--velocity", "2", "--local", "elastoplastic", "--timestep", "1e-4"]),
]


@pytest.mark.parametrize("engine,scenario,kwargs,flags", RUNS,
                         ids=[f"{r[0]}-{r[1]}-{i}" for i, r in enumerate(RUNS)])
def test_run_to_dict_is_the_run_json(capsys, engine, scenario, kwargs, flags) -> None:
    require_engine(engine)
    result = impactbench.run(engine=engine, scenario=scenario, **kwargs)
    cli = cli_json(capsys, "run", scenario, "--engine", engine, *flags)
    got = result.to_dict()
    assert got.pop("wall_s") > 0 and cli.pop("wall_s") > 0
    assert got == cli
    assert list(got) == list(cli)  # the same order, too
    assert isinstance(result, impactbench.RunResult)
    assert list(result.metrics) == list(scenarios.get(scenario).metrics)
    assert set(result.metrics) == set(result.reference) - {"status"} == set(result.rel_error)
    assert result.scenario.velocity_m_s == kwargs["velocity_m_s"]
    assert result.record is not None


def test_run_result_is_frozen_and_its_fields_are_the_runs() -> None:
    require_engine("pymunk")
    r = impactbench.run(engine="pymunk", scenario="ball-on-plate", velocity_m_s=1.0,
                        timestep_s=1e-3)
    with pytest.raises(dataclasses.FrozenInstanceError):
        r.status = "ok"  # type: ignore[misc]
    names = {f.name for f in dataclasses.fields(r)}
    assert {"status", "message", "engine", "engine_version", "mode", "timestep_s", "wall_s",
            "metrics", "reference", "rel_error", "resolved", "params"} <= names
    assert r.ok and r.mode == "native" and r.timestep_s == 1e-3


def test_reference_is_the_reference_json(capsys) -> None:
    got = impactbench.reference_solution(scenario="ball-on-plate", velocity_m_s=2.0)
    assert got == cli_json(capsys, "reference", "ball-on-plate", "--velocity", "2")
    assert list(got) == list(cli_json(capsys, "reference", "ball-on-plate", "--velocity", "2"))
    # a material, a contact model: the same further options as the flags
    mine = impactbench.reference_solution(velocity_m_s=2.0, material="rubber", radius_m=0.03,
                                 mass_kg=0.05)
    assert mine == cli_json(capsys, "reference", "ball-on-plate", "--velocity", "2",
                            "--material", "rubber", "--radius", "0.03", "--mass", "0.05")
    flores = impactbench.reference_solution(velocity_m_s=2.0, model="flores",
                                            nominal_restitution=0.8)
    assert flores == cli_json(capsys, "reference", "ball-on-plate", "--velocity", "2",
                              "--model", "flores", "--nominal-restitution", "0.8")
    # beyond the ball's radius: unsupported, as the command says
    deep = impactbench.reference_solution(velocity_m_s=2.0, stiffness=1e3)
    assert deep == cli_json(capsys, "reference", "ball-on-plate", "--velocity", "2",
                            "--stiffness", "1e3")
    assert deep["status"] == "unsupported" and "radius" in deep["message"]


def test_reference_of_the_rigid_flexible_model_holds_the_commands_keys(capsys) -> None:
    got = impactbench.reference_solution(scenario="rigid-flexible", velocity_m_s=10.0,
                                local="elastoplastic", structure="softening")
    cli = cli_json(capsys, "reference", "rigid-flexible", "--velocity", "10", "--local",
                   "elastoplastic", "--structure", "softening")
    assert {k: got[k] for k in cli} == cli
    assert (got["local"], got["structure"], got["velocity_m_s"]) == \
        ("elastoplastic", "softening", 10.0)


def test_tune_is_the_tune_command(capsys, tmp_path) -> None:
    """The same fit as ``impactbench tune`` (parameters, residuals, tuned file tables)."""
    require_engine("pymunk")
    fit = impactbench.tune(engine="pymunk", timestep_s=1e-3, velocities_m_s=(1.0, 2.0),
                           targets=("restitution",), max_evals=5, out=tmp_path / "api.toml",
                           store=tmp_path / "api.duckdb", plot=tmp_path / "api.png")
    cli = cli_json(capsys, "tune", "--engine", "pymunk", "--timestep", "1e-3", "--velocities",
                   "1,2", "--targets", "restitution", "--max-evals", "5", "--workers", "0",
                   "--out", str(tmp_path / "cli.toml"), "--no-plot",
                   "--store", str(tmp_path / "cli.duckdb"))
    got = fit.to_dict()
    for key in ("wall_s", "files"):
        got.pop(key), cli.pop(key)
    assert got == cli
    assert fit.parameters == cli["parameters"] and fit.residuals == cli["residuals"]
    assert fit.files == {"tuned": str(tmp_path / "api.toml"), "plot": str(tmp_path / "api.png")}
    assert (tmp_path / "api.png").stat().st_size > 0
    # the same bytes below the header comment (tables with NaN: compare the text)
    api_text = (tmp_path / "api.toml").read_text()
    assert api_text.split("\n[", 1)[1] == (tmp_path / "cli.toml").read_text().split("\n[", 1)[1]
    assert tomllib.loads(api_text)["parameters"] == fit.parameters
    # a second identical tune is served from the store; store=False keeps none
    again = impactbench.tune(engine="pymunk", timestep_s=1e-3, velocities_m_s=(1.0, 2.0),
                             targets=("restitution",), max_evals=5,
                             store=tmp_path / "api.duckdb")
    assert again.parameters == fit.parameters and again.to_dict()["runs_stored"] == 0
    none = impactbench.tune(engine="pymunk", timestep_s=1e-3, velocities_m_s=1.0,
                            targets="restitution", max_evals=2, store=False)
    assert none.to_dict()["runs_from_store"] == 0 and none.files == {}


# ------------------------------------------------------------------------------ bad input


def one_line_error(fn, *args, **kwargs) -> str:
    with pytest.raises(ValueError) as exc:
        fn(*args, **kwargs)
    text = str(exc.value)
    assert "\n" not in text, text
    return text


def test_an_unknown_keyword_is_named_with_a_suggestion_and_the_valid_ones() -> None:
    text = one_line_error(impactbench.run, engine="pymunk", scenario="ball-on-plate",
                          velocity=2.0)
    assert "unknown keyword 'velocity'" in text and "did you mean 'velocity_m_s'?" in text
    assert "valid: engine, scenario, mode, params, param_set, tuned_file, timestep_s, yes, " \
           "timeout_s, max_penetration_ratio, max_energy_ratio, velocity_m_s, mass_kg" in text
    assert "material" in text
    text = one_line_error(impactbench.run, engine="pymunk", timestep=1e-3)
    assert "'timestep'" in text and "did you mean 'timestep_s'?" in text
    # another scenario, other fields: the ball's are not the 2-DOF model's
    text = one_line_error(impactbench.run, engine="mujoco", scenario="rigid-flexible",
                          mass_kg=1.0)
    assert "'mass_kg'" in text and "m1_kg" in text and "radius_m" not in text
    text = one_line_error(impactbench.reference_solution, velocity_m_s=1.0, radius=0.01)
    assert "impactbench.reference_solution" in text and "did you mean 'radius_m'?" in text
    text = one_line_error(impactbench.tune, engine="pymunk", velocity_m_s=1.0)
    assert "did you mean 'velocities_m_s'?" in text
    text = one_line_error(impactbench.tune, engine="pymunk", max_eval=3)
    assert "did you mean 'max_evals'?" in text
    text = one_line_error(impactbench.tune, engine="pymunk", params={"elastcity": 0.5})
    assert "not a pymunk tuned key" in text and "did you mean 'elasticity'?" in text


def test_bad_names_and_values_are_one_line_errors() -> None:
    assert "did you mean 'mujoco'" in one_line_error(impactbench.run, engine="mujoko",
                                                     velocity_m_s=1.0)
    assert "did you mean 'ball-on-plate'" in one_line_error(impactbench.run, engine="pymunk",
                                                            scenario="ball-on-plat")
    assert "did you mean 'default'" in one_line_error(impactbench.run, engine="pymunk",
                                                      mode="defualt")
    text = one_line_error(impactbench.run, engine="pymunk", params={"elastcity": 0.8})
    assert "not a pymunk parameter" in text and "did you mean 'elasticity'" in text
    assert "params needs mode='custom' (got 'native')" in one_line_error(
        impactbench.run, engine="pymunk", mode="native", params={"elasticity": 0.8})
    assert "needs mode='tuned'" in one_line_error(impactbench.run, engine="pymunk",
                                                  mode="native", tuned_file="x.toml")
    assert one_line_error(impactbench.run, engine="pymunk", mass_kg=-1.0).startswith(
        "mass_kg = -1.0")
    assert one_line_error(impactbench.run, engine="pymunk", timestep_s=0.0).startswith(
        "timestep_s = 0.0")
    assert "no such file" in one_line_error(impactbench.run, engine="pymunk",
                                            tuned_file="/nonexistent/tuned.toml")


def test_a_run_beyond_the_step_limit_needs_yes() -> None:
    text = one_line_error(impactbench.run, engine="mujoco", velocity_m_s=1.0,
                          timestep_s=1e-12)
    assert "yes=True" in text and "--yes" not in text


def test_a_failed_run_is_a_status_not_an_exception() -> None:
    require_engine("mujoco")
    r = impactbench.run(engine="mujoco", scenario="ball-on-plate", mode="tuned",
                        velocity_m_s=1.0, timestep_s=3e-3)  # no tuned file fits 3 ms
    assert r.status == "unsupported" and "fitted for" in r.message and not r.ok
    assert r.to_dict()["rel_error"]["restitution"] is None  # NaN is null, as in the JSON


# ------------------------------------------------------------------------------ docstrings


def test_the_docstring_examples_run(monkeypatch, tmp_path) -> None:
    """Every ``>>>`` example of :mod:`impactbench.api` (fast engines at coarse steps)."""
    require_engine("mujoco")
    require_engine("pymunk")
    monkeypatch.setenv("IMPACTBENCH_STORE", str(tmp_path / "store.duckdb"))
    import impactbench.api

    result = doctest.testmod(impactbench.api, optionflags=doctest.ELLIPSIS
                             | doctest.NORMALIZE_WHITESPACE, report=True)
    assert result.failed == 0
    assert result.attempted >= 40
    names = ["run", "reference_solution", "tune", "build_report"]
    documented = [f for f in names if ">>>" in (getattr(impactbench.api, f).__doc__ or "")]
    assert documented == names


def test_the_package_docstring_names_the_api() -> None:
    assert isinstance(impactbench, types.ModuleType)
    for name in ("impactbench.run", "impactbench.reference_solution", "impactbench.tune",
                 "impactbench.build_report"):
        assert name in impactbench.__doc__


def test_tune_refuses_an_evaluation_over_the_cost_limit_in_the_callers_words() -> None:
    """The per-evaluation cost check lives in the API (the command calls it): with the
    default velocities too, before any run; the advice names ``yes=True`` from Python."""
    import impactbench

    with pytest.raises(ValueError, match=r"timestep_s = 1e-11: about 1\.1\de\+08 "
                       r"\(integration steps per evaluation\).*pass yes=True"):
        impactbench.tune(engine="pymunk", timestep_s=1e-11, max_evals=1, store=False)
