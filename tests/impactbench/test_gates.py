"""Accuracy gates: gate-file validation, marks, exit codes, JUnit, baseline, missing engines.

Real engines only. The checks run the rigid–flexible linear/linear case at 2 m/s in injected
mode (a few thousand steps) with the first engine that runs it, and judge the same real
measurements against edited baselines and tolerances.
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest
from impactbench.engines.base import ENGINES, run_safely
from impactbench.reference.scenarios import RigidFlexible

from impactbench import gates
from impactbench.cli import main

RF = RigidFlexible(velocity_m_s=2.0)
ENGINE_MODULES = {"mujoco": "mujoco", "pybullet": "pybullet", "pymunk": "pymunk",
                  "drake": "pydrake"}


@pytest.fixture(scope="module")
def engine() -> str:
    """The first registered engine that runs the rigid–flexible case here."""
    for name in ENGINES:
        if run_safely(name, RF, "injected").ok:
            return name
    pytest.skip("no engine runs the rigid-flexible case in injected mode here")


def gate_text(engine: str, tolerance: str = "peak_force_n = 0.01\nimpulse_ns = 0.01",
              extra: str = "") -> str:
    return (f'[[gate]]\nengine = "{engine}"\nmode = "injected"\nscenario = "rigid-flexible"\n'
            f"velocities_m_s = [2.0]\n{extra}[gate.tolerance]\n{tolerance}\n")


def write(tmp_path: Path, text: str, name: str = "gates.toml") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


# ------------------------------------------------------------------ bad gate files: exit 2


@pytest.mark.parametrize(("body", "line", "words"), [
    ('[[gate]]\nengine = "mujoco"\nmode = "injected"\nscenario = "ball-on-plate"\n'
     "[gate.tolerance]\nrestitution = 0.01\nrestitutoin = 0.01\n", 7,
     ("restitutoin", "did you mean 'restitution'")),
    ('[[gate]]\nengine = "mujoco"\nmode = "injected"\nscenario = "ball-on-plate"\n'
     "[gate.tolerance]\nrestitution = 0.01\n\n[[gate]]\nengine = \"pymunk\"\n"
     'mode = "injected"\nscenario = "rigid-flexible"\ntolerance = { impulse_ns = -0.1 }\n',
     12, ("tolerance.impulse_ns = -0.1", ">= 0", "gate 2")),
    ('[[gate]]\nengine = "mujoco"\nmode = "injected"\nscenario = "ball-on-plate"\n'
     "[gate.tolerance]\nrestitution = 0.01,\n", 6, ("malformed TOML",)),
    ('[defaults]\nbaseline_margin = 0.5\n[[gate]]\nengine = "mujoco"\nmode = "fast"\n'
     'scenario = "ball-on-plate"\n[gate.tolerance]\nrestitution = 0.01\n', 5, ("mode = 'fast'",)),
    ('[[gate]]\nengine = "mujoco"\nmode = "injected"\nscenario = "ball-on-plate"\n'
     'local = "linear"\n[gate.tolerance]\nrestitution = 0.01\n', 5,
     ("local", "not an axis of ball-on-plate")),
])
def test_bad_gate_file_exits_2_naming_the_line(tmp_path, capsys, body, line, words) -> None:
    path = write(tmp_path, body)
    assert main(["gate", "--config", str(path)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    assert f"line {line}" in err or f"{path}:{line}" in err, err
    for w in words:
        assert w in err, err


def test_repeated_check_is_rejected(tmp_path) -> None:
    text = gate_text("pymunk") + gate_text("pymunk", "impulse_ns = 0.02")
    with pytest.raises(ValueError, match=r"gates.toml:\d+: gate 2: check .*impulse_ns repeats"):
        gates.parse_gates(text, tmp_path / "gates.toml")


def test_runs_are_deduplicated_across_metrics_and_gates() -> None:
    text = (gate_text("pymunk", "peak_force_n = 0.01\nimpulse_ns = 0.01")
            + gate_text("pymunk", "pulse_width_s = 0.01", 'timesteps_s = [1e-5, 2e-5]\n'))
    parsed = gates.parse_gates(text)
    assert len(parsed.checks) == 4
    # pymunk's default rigid-flexible step is one of the explicit ones or a third
    default_dt = parsed.checks[0].run.timestep_s
    assert len(gates.plan(parsed.checks)) == len({default_dt, 1e-5, 2e-5})


def test_parameters_reach_the_scenario_and_the_check_id(tmp_path) -> None:
    extra = "local = \"elastoplastic\"\nparameters = { m2_kg = 0.3, k2_n_per_m = 1e3 }\n"
    (c, _) = gates.parse_gates(gate_text("pymunk", extra=extra)).checks
    scenario = c.run.build_scenario()
    assert (scenario.m2_kg, scenario.k2_n_per_m, scenario.local) == (0.3, 1e3, "elastoplastic")
    assert "-elastoplastic-linear-k2_n_per_m1000-m2_kg0.3-v2-" in c.id
    for bad, words in (("parameters = { m2 = 0.3 }\n", ("parameters key = 'm2'", "m2_kg")),
                       ("parameters = { m2_kg = -1 }\n", ("m2_kg = -1",)),
                       ("parameters = { velocity_m_s = 3 }\n", ("velocity_m_s",))):
        with pytest.raises(ValueError) as info:
            gates.parse_gates(gate_text("pymunk", extra=bad), tmp_path / "gates.toml")
        assert "gates.toml:6: gate 1:" in str(info.value), info.value
        for w in words:
            assert w in str(info.value), info.value


def shipped_gates() -> tuple[gates.GateFile, dict]:
    root = Path(__file__).resolve().parents[2]
    return gates.load_gates(root / "gates.toml"), gates.load_baseline(root / "gates_baseline.json")


def synthetic_result(check: gates.Check, rel_error: float) -> dict:
    return {"status": "ok", check.metric: 1.0 + rel_error, "reference": {check.metric: 1.0},
            "rel_error": {check.metric: rel_error}}


def test_four_fold_regression_of_an_accurate_shipped_check_fails() -> None:
    """Issue 16: the old 1e-4 absolute allowance let the most accurate checks worsen 4–100×
    unseen. With the shipped gates and baseline, every check whose error is measurably
    non-zero fails as ``worse`` at 4× its baseline error, and at the same size with the other
    sign; the baseline itself passes."""
    parsed, baseline = shipped_gates()
    accurate = [c for c in parsed.checks
                if c.id in baseline and abs(baseline[c.id]["rel_error"]) > 1e-6]
    assert len(accurate) >= 20
    assert min(abs(baseline[c.id]["rel_error"]) for c in accurate) < 1e-4  # the old floor
    for c in accurate:
        base = baseline[c.id]["rel_error"]
        assert gates.judge(c, synthetic_result(c, base), baseline).mark == gates.PASS, c.id
        if 4 * abs(base) <= c.tolerance:
            got = gates.judge(c, synthetic_result(c, 4 * base), baseline)
            assert got.mark == gates.WORSE, (c.id, got.message)
        if abs(base) <= c.tolerance:
            got = gates.judge(c, synthetic_result(c, -base), baseline)
            assert got.mark == gates.WORSE, (c.id, got.message)


# ------------------------------------------------------------------ real runs


@pytest.fixture(scope="module")
def measured(engine) -> list[gates.Outcome]:
    parsed = gates.parse_gates(gate_text(engine))
    return gates.evaluate(parsed.checks, jobs=0)


def test_injected_gate_passes_and_tolerance_zero_fails(engine, measured) -> None:
    assert [o.mark for o in measured] == [gates.PASS, gates.PASS], gates.format_table(measured)
    assert gates.exit_code(measured) == 0
    strict = gates.parse_gates(gate_text(engine, "peak_force_n = 0\nimpulse_ns = 0")).checks
    # the same measurements against tolerance 0: nonzero error must fail (a real error is
    # never exactly zero in floating point)
    judged = [gates.judge(c, o.result) for c, o in zip(strict, measured, strict=True)]
    assert all(o.rel_error != 0 for o in measured)
    assert [o.mark for o in judged] == [gates.FAIL, gates.FAIL]
    assert gates.exit_code(judged) == 1


def test_baseline_marks_worse_better_new_failure(engine, measured) -> None:
    peak = measured[0]
    signed = peak.rel_error
    err = abs(signed)
    c = gates.Check(peak.check.run, peak.check.metric, peak.check.tolerance, 0.5, 0.0)
    # a baseline with a much smaller error: within tolerance but grown -> worse
    assert err > 0
    assert gates.judge(c, peak.result, {c.id: {"rel_error": signed / 10}}).mark == gates.WORSE
    assert gates.judge(c, peak.result, {c.id: {"rel_error": signed}}).mark == gates.PASS
    # the same size with the other sign: the error moved by 2·|e| -> worse
    assert gates.judge(c, peak.result, {c.id: {"rel_error": -signed}}).mark == gates.WORSE
    # a baseline with a larger error, of either sign -> better (passes)
    for large in (2 * signed * (1 + c.margin), -2 * signed * (1 + c.margin)):
        assert gates.judge(c, peak.result, {c.id: {"rel_error": large}}).mark == gates.BETTER
    # fails now (tolerance below the error) but passed in the baseline -> new-failure
    tight = gates.Check(c.run, c.metric, err / 2, c.margin, c.floor)
    assert gates.judge(tight, peak.result, {tight.id: {"rel_error": 0.0}}).mark == \
        gates.NEW_FAILURE
    assert gates.judge(tight, peak.result, {tight.id: {"rel_error": err}}).mark == gates.FAIL
    assert gates.judge(tight, peak.result, {}).mark == gates.FAIL


def test_must_fail_gate_exits_1_with_junit_failure(engine, tmp_path, capsys,
                                                    monkeypatch) -> None:
    path = write(tmp_path, gate_text(engine, "peak_force_n = 0.01\nimpulse_ns = 0"))
    junit = tmp_path / "junit.xml"
    summary = tmp_path / "summary.md"
    monkeypatch.setenv("GITHUB_STEP_SUMMARY", str(summary))
    rc = main(["gate", "--config", str(path), "--junit", str(junit), "--workers", "1"])
    out = capsys.readouterr().out
    assert rc == 1, out
    suite = ET.parse(junit).getroot().find("testsuite")
    assert suite.get("tests") == "2" and suite.get("failures") == "1"
    failed = [tc.get("name") for tc in suite.iter("testcase") if tc.find("failure") is not None]
    assert failed == [f"{engine}-injected-rigid-flexible-linear-linear-v2-dt"
                      f"{gates.parse_gates(path.read_text()).checks[0].run.timestep_s:g}"
                      "-impulse_ns"]
    assert "gates FAILED" in out and "fail" in out
    md = summary.read_text()
    assert "impactbench accuracy gates" in md and "| fail" in md


def test_update_baseline_then_worse_is_caught(engine, tmp_path, capsys) -> None:
    # the default floor (1e-8) is far below the errors here (~1e-5)
    path = write(tmp_path, gate_text(engine))
    base = tmp_path / "gates_baseline.json"
    assert main(["gate", "--config", str(path), "--update-baseline", "--workers", "0"]) == 0
    stored = json.loads(base.read_text())["checks"]
    assert len(stored) == 2 and all(math.isfinite(v["rel_error"]) for v in stored.values())
    assert all(v["rel_error"] != 0 for v in stored.values())
    # the default baseline beside the gate file is read: same measurements -> pass
    assert main(["gate", "--config", str(path), "--workers", "0"]) == 0
    capsys.readouterr()
    # a baseline that was far better: the same run is now "worse", which fails
    for v in stored.values():
        v["rel_error"] /= 10
    gates.save_baseline(base, stored)
    assert main(["gate", "--config", str(path), "--workers", "0"]) == 1
    out = capsys.readouterr().out
    assert out.count("\nworse ") == 2 and "gates FAILED" in out


def test_missing_engine_is_not_comparable(engine, tmp_path) -> None:
    """Block the engine's package import in a child process: `unavailable` → not-comparable,
    exit 0; --strict makes it fail."""
    shim = tmp_path / "shim"
    shim.mkdir()
    (shim / f"{ENGINE_MODULES[engine]}.py").write_text(
        "raise ImportError('blocked by the impactbench gate test')\n")
    path = write(tmp_path, gate_text(engine))
    junit = tmp_path / "junit.xml"
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(
        [str(shim), *filter(None, [os.environ.get("PYTHONPATH")])])}
    env.pop("GITHUB_STEP_SUMMARY", None)
    cmd = [sys.executable, "-m", "impactbench.cli", "gate", "--config", str(path),
           "--junit", str(junit), "--jobs", "1"]  # the old name still works
    done = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=300)
    assert done.returncode == 0, done.stdout + done.stderr
    marks = [line.split()[0] for line in done.stdout.splitlines() if "-injected-" in line]
    assert marks == ["not-comparable", "not-comparable"], done.stdout
    assert "unavailable" in done.stdout
    suite = ET.parse(junit).getroot().find("testsuite")
    assert suite.get("skipped") == "2" and suite.get("failures") == "0"
    strict = subprocess.run([*cmd, "--strict"], capture_output=True, text=True, env=env,
                            timeout=300)
    assert strict.returncode == 1, strict.stdout + strict.stderr


def test_update_baseline_keeps_entries_it_could_not_measure(engine, measured) -> None:
    c = measured[0].check
    point = (("local", "linear"), ("structure", "linear"), ("velocity_m_s", 2.0))
    other = gates.Check(gates.RunKey("drake", "rigid-flexible", point, "tuned", 1e-5),
                        "impulse_ns", 0.01)
    nc = gates.judge(other, {"status": "unavailable", "message": "not installed"})
    assert nc.mark == gates.NOT_COMPARABLE
    previous = {other.id: {"rel_error": 0.001}}
    new = gates.updated_baseline([*measured, nc], previous)
    assert new[other.id] == {"rel_error": 0.001}
    assert new[c.id]["rel_error"] == measured[0].rel_error


def test_shipped_gates_cover_native_modes_and_rigid_flexible_beyond_the_base() -> None:
    """Issue 16: native-mode gates for every engine, and rigid–flexible gates with parameters
    other than the papers' base set."""
    parsed, baseline = shipped_gates()
    runs = {c.run for c in parsed.checks}
    for engine in ENGINES:
        for scenario in ("ball-on-plate", "rigid-flexible"):
            assert any(r.engine == engine and r.mode == "native" and r.scenario == scenario
                       for r in runs), (engine, scenario)
    beyond = {dict(r.parameters).get("m2_kg") for r in runs if r.scenario == "rigid-flexible"}
    assert len(beyond - {None}) >= 1
    assert {r.get("local") for r in runs if r.scenario == "rigid-flexible"} == {
        "linear", "elastoplastic", "mutation"}
    # issue 16 part 1: the light, soft body 2 with its short separations and re-contacts
    light = {r.velocity_m_s for r in runs if r.get("local") == "elastoplastic"
             and dict(r.parameters) == {"m2_kg": 0.3, "k2_n_per_m": 1e3}}
    assert light == {100.0, 300.0}
    assert all(c.id in baseline for c in parsed.checks)  # the baseline is regenerated
