"""A third-party engine through the entry points: ``examples/plugin-engine-euler``.

The plug-in is made visible without pip, as ``test_scenario_plugin.py`` does for a scenario
(``plugin_install.py``: a ``*.dist-info`` folder and the example's source folder on
``sys.path`` and ``PYTHONPATH``). Then ``run``, ``report`` and ``gate`` run it end to end, as a
user who installed it would, with nothing in impactbench naming it.
"""

from __future__ import annotations

import csv
import json
import sys
from pathlib import Path

import pytest
from impactbench.engines import registry
from impactbench.engines.base import RunSettings, get_adapter, run_safely
from impactbench.reference import hunt_crossley, metrics
from impactbench.reference.record import Status
from impactbench.reference.scenarios import BallOnPlate, RigidFlexible
from plugin_install import cli, gate_passes_and_fails, installed

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "examples" / "plugin-engine-euler"
NAME = "euler"
METRICS = ("restitution", "duration_s", "peak_force_n", "max_penetration_m",
           "energy_loss_fraction")

# euler 0.1.0 (this example), injected, the paper's ball, dt = 1e-6 s (its default step):
# signed relative errors against the closed form. V0 = 2 m/s: restitution −3.48e-5,
# duration −1.35e-3, peak force +2.29e-3, max penetration −9.05e-4, energy loss fraction
# +2.11e-6. Tolerances ≈ 3× those.
RUN_TOLERANCE = {"restitution": 1.1e-4, "duration_s": 4e-3, "peak_force_n": 7e-3,
                 "max_penetration_m": 2.7e-3, "energy_loss_fraction": 6.5e-6}
# V0 = 1 and 5 m/s (the gate's velocities): restitution −2.57e-5 / −2.72e-5, duration
# −6.29e-4 / −3.61e-3, peak force +1.12e-3 / +6.26e-3, max penetration −4.42e-4 / −2.67e-3,
# energy loss fraction +2.26e-5 / +1.52e-5. Tolerances ≈ 3× the worse of the two.
GATE_TOLERANCE = {"restitution": 8.5e-5, "duration_s": 1.1e-2, "peak_force_n": 1.9e-2,
                  "max_penetration_m": 8e-3, "energy_loss_fraction": 7e-5}


def _forget_plugin() -> None:
    registry.forget_plugins()
    for module in [m for m in sys.modules if m.split(".")[0] == "impactbench_euler"]:
        del sys.modules[module]


@pytest.fixture
def plugin(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> dict[str, str]:
    """The example registered as if pip-installed; returns the subprocesses' environment
    (PYTHONPATH, a private results store). The registry forgets it afterwards."""
    monkeypatch.delenv(registry.WARNED_ENV, raising=False)
    yield from installed(tmp_path, monkeypatch, EXAMPLE, "impactbench-euler",
                         registry.ENTRY_POINT_GROUP, f"{NAME} = impactbench_euler:SPEC",
                         _forget_plugin)


def rel_errors(velocity_m_s: float, timestep_s: float, mode: str = "injected"
               ) -> dict[str, float]:
    scenario = BallOnPlate(velocity_m_s=velocity_m_s)
    rec = run_safely(NAME, scenario, mode, RunSettings(timestep_s=timestep_s))
    assert rec.status == Status.OK, rec.message
    got, ref = metrics.compute(rec), hunt_crossley.solve(scenario)
    return {m: (got[m] - ref[m]) / ref[m] for m in METRICS}


# ------------------------------------------------------------------ in process


def test_registry_lists_the_plugin_with_its_facts(plugin) -> None:
    from impactbench.plots import ENGINE_COLORS, engine_color

    names = registry.engine_names()
    assert names[:len(registry.BUILTIN)] == tuple(s.name for s in registry.BUILTIN)
    assert names[len(registry.BUILTIN):] == (NAME,)
    spec = registry.spec(NAME)
    assert spec.adapter == "impactbench_euler.adapter:EulerAdapter"
    assert spec.distribution == "impactbench-euler" and not spec.variants
    assert registry.ENGINES[NAME] == f"{registry.PLUGIN_ADAPTERS}:{NAME}"
    assert registry.PIP[NAME] == spec.pip
    assert not registry.is_builtin(NAME) and registry.plugin_error(NAME) == ""
    assert engine_color(NAME) == ENGINE_COLORS[NAME] == "teal"
    assert list(ENGINE_COLORS)[-1] == NAME
    adapter = get_adapter(NAME)
    assert type(adapter).__name__ == "EulerAdapter" and adapter.version() == "0.1.0"


def test_injected_converges_at_first_order(plugin) -> None:
    """Semi-implicit Euler's damping term lags half a step: peak force high, duration and
    penetration short, each ∝ dt (a tenth of the step, a tenth of the error), while the
    restitution's error cancels between compression and restitution."""
    coarse, fine = rel_errors(5.0, 1e-6), rel_errors(5.0, 1e-7)
    assert coarse["peak_force_n"] > 0 and coarse["duration_s"] < 0
    for metric in ("duration_s", "peak_force_n", "max_penetration_m"):
        assert 8.0 < coarse[metric] / fine[metric] < 12.0, (metric, coarse, fine)
    # measured (5 m/s): −2.72e-5 at 1e-6 s, −1.10e-7 at 1e-7 s
    assert abs(fine["restitution"]) < 3.3e-7 < abs(coarse["restitution"]) / 10


def test_native_is_right_at_its_reference_velocity_only(plugin) -> None:
    """Native: a linear spring–damper matched at 1 m/s. There its restitution and duration
    are the reference's (to the stepping error); at 5 m/s a linear spring keeps its
    restitution while Hunt–Crossley's falls (measured at 1e-7 s: +2.53e-1)."""
    at_ref, fast = rel_errors(1.0, 1e-7, "native"), rel_errors(5.0, 1e-7, "native")
    # measured at 1 m/s, 1e-7 s: restitution −4.14e-6, duration −3.19e-5
    assert abs(at_ref["restitution"]) < 1.3e-5 and abs(at_ref["duration_s"]) < 1e-4
    assert fast["restitution"] > 0.2


def test_what_it_does_not_run_is_unsupported(plugin) -> None:
    rec = run_safely(NAME, RigidFlexible(), "injected")
    assert rec.status == Status.UNSUPPORTED and "no builder" in rec.message
    rec = run_safely(NAME, BallOnPlate(), "default")
    assert rec.status == Status.UNSUPPORTED and "native, injected" in rec.message


# ------------------------------------------------------------------ through the CLI


def test_run_against_the_closed_form(plugin) -> None:
    done = cli(plugin, "run", "--engine", NAME, "--scenario", "ball-on-plate", "--mode",
               "injected", "--velocity", "2", "--json")
    assert done.returncode == 0, done.stdout + done.stderr
    out = json.loads(done.stdout)
    assert out["status"] == "ok", out["message"]
    assert out["timestep_s"] == 1e-6  # the adapter's step for the ball
    assert out["reference"] == pytest.approx(dict(hunt_crossley.solve(
        BallOnPlate(velocity_m_s=2.0))), rel=1e-12)
    for metric, tol in RUN_TOLERANCE.items():
        assert abs(out["rel_error"][metric]) <= tol, (metric, out["rel_error"][metric])


def test_report_has_the_plugin_engine(plugin, tmp_path: Path) -> None:
    config = tmp_path / "report.toml"
    config.write_text(f'[report]\nengines = ["{NAME}"]\nmodes = ["injected", "native"]\n\n'
                      "[ball_on_plate]\nvelocities_m_s = [1.0, 2.0]\n"
                      # layered over the default report: drop its other sections
                      "[rigid_flexible]\nvelocities_m_s = []\n"
                      "[oblique]\nvelocities_m_s = []\n[bounce]\nheights_m = []\n"
                      "[work_precision]\ntimesteps_s = []\n[practical]\nvelocities_m_s = []\n"
                      "[cube_toss]\nengines = []\n")
    out = tmp_path / "report"
    done = cli(plugin, "report", "--config", str(config), "--out", str(out), "--workers", "1")
    assert done.returncode == 0, done.stdout + done.stderr
    with (out / "results.csv").open() as fh:
        rows = list(csv.DictReader(fh))
    assert {r["engine"] for r in rows} == {NAME}
    assert {(r["mode"], float(r["velocity_m_s"])) for r in rows} == {
        (m, v) for m in ("injected", "native") for v in (1.0, 2.0)}
    assert {r["status"] for r in rows} == {"ok"}
    assert {r["engine_version"] for r in rows} == {"0.1.0"}
    ref = hunt_crossley.solve(BallOnPlate(velocity_m_s=2.0))
    for r in rows:
        if float(r["velocity_m_s"]) == 2.0:
            assert float(r["reference"]) == pytest.approx(ref[r["metric"]], rel=1e-12)
            if r["mode"] == "injected" and r["metric"] in RUN_TOLERANCE:
                assert abs(float(r["rel_error"])) <= RUN_TOLERANCE[r["metric"]], r
    assert NAME in (out / "README.md").read_text()


def test_gate_passes_and_fails(plugin, tmp_path: Path) -> None:
    checks = gate_passes_and_fails(
        plugin, tmp_path, f'[[gate]]\nengine = "{NAME}"\nmode = "injected"\n'
        'scenario = "ball-on-plate"\nvelocities_m_s = [1.0, 5.0]\n', GATE_TOLERANCE,
        "--workers", "0")
    assert all(c.startswith(f"{NAME}-") for c in checks), checks
