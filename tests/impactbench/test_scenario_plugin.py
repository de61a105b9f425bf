"""A third-party scenario through the entry points: ``examples/plugin-sphere-on-sphere``.

The plug-in is made visible without pip by ``plugin_install.py``: a ``*.dist-info`` folder
(what pip would write) and the example's source folder on ``sys.path`` and ``PYTHONPATH``.
Then ``run``, ``report`` and ``gate`` run it end to end with real engines, as a user who
installed it would.
"""

from __future__ import annotations

import csv
import json
import sys
from pathlib import Path

import pytest
from conftest import require_engine
from plugin_install import cli, gate_passes_and_fails, installed

from impactbench import scenarios

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "examples" / "plugin-sphere-on-sphere"
NAME = "sphere-on-sphere"

# mujoco 4.0.0, injected, dt = 1e-6 s: signed relative errors against the closed form.
# V0 = 2 m/s: restitution −2.50e-5, duration −1.28e-3, peak force +2.12e-3,
# max penetration −9.38e-4, energy loss fraction +3.20e-5. Tolerances ≈ 3× those.
RUN_TOLERANCE = {"restitution": 7.5e-5, "duration_s": 4e-3, "peak_force_n": 6.5e-3,
                 "max_penetration_m": 3e-3, "energy_loss_fraction": 1e-4}
# V0 = 1 and 5 m/s (the gate's velocities): restitution −1.61e-5 / −1.85e-5, duration
# −5.96e-4 / −3.43e-3, peak force +9.63e-4 / +5.64e-3, max penetration −3.72e-4 / −2.45e-3,
# energy loss fraction +2.30e-5 / +1.90e-5. Tolerances ≈ 3× the worse of the two.
GATE_TOLERANCE = {"restitution": 6e-5, "duration_s": 1.1e-2, "peak_force_n": 1.7e-2,
                  "max_penetration_m": 7.5e-3, "energy_loss_fraction": 7e-5}


def _forget_plugin() -> None:
    scenarios._plugins.cache_clear()
    scenarios.get.cache_clear()
    for module in [m for m in sys.modules if m.split(".")[0] == "impactbench_sphere"]:
        del sys.modules[module]


@pytest.fixture
def plugin(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> dict[str, str]:
    """The example registered as if pip-installed; returns the subprocesses' environment
    (PYTHONPATH, a private results store). The registry forgets it afterwards."""
    yield from installed(tmp_path, monkeypatch, EXAMPLE, "impactbench-sphere-on-sphere",
                         scenarios.ENTRY_POINT_GROUP, f"{NAME} = impactbench_sphere:SPEC",
                         _forget_plugin)


def closed_form(**fields: float) -> dict[str, float]:
    """The reference the plug-in must give: the ball's closed form on the equivalent ball."""
    from impactbench.reference import hunt_crossley
    from impactbench_sphere import SphereOnSphere

    return dict(hunt_crossley.solve(SphereOnSphere(**fields).equivalent_ball()))


# ------------------------------------------------------------------ in process


def test_registry_lists_the_plugin_after_the_builtins(plugin) -> None:
    names = scenarios.names()
    assert names[:len(scenarios.BUILTIN)] == tuple(scenarios.BUILTIN)
    assert NAME in names[len(scenarios.BUILTIN):]
    spec = scenarios.get(NAME)
    assert spec.title == "Sphere on sphere" and spec.table == "sphere_on_sphere"
    assert not spec.studies and not spec.measured and not spec.owns_timestep
    # its behaviour is methods of its spec class; the defaults where it brings none
    assert type(spec).register_commands is scenarios.ScenarioSpec.register_commands
    assert spec.reference_metrics(spec.build())["restitution"] > 0
    assert scenarios.by_table("sphere_on_sphere") is spec


def test_bad_field_is_one_line_naming_it(plugin) -> None:
    from impactbench_sphere import SphereOnSphere

    with pytest.raises(ValueError) as err:
        SphereOnSphere(target_radius_m=-1)
    text = str(err.value)
    assert "\n" not in text
    assert text.startswith("target_radius_m = -1") and "> 0" in text
    with pytest.raises(ValueError, match=r"^target_radius_m = -1"):
        scenarios.get(NAME).build(parameters={"target_radius_m": -1})


def test_equivalent_ball_is_the_hertz_problem(plugin) -> None:
    from impactbench.reference.scenarios import hertz_stiffness
    from impactbench_sphere import SphereOnSphere

    s = SphereOnSphere()
    ball = s.equivalent_ball()
    r_star = 1.0 / (1.0 / s.radius_m + 1.0 / s.target_radius_m)
    assert ball.radius_m == pytest.approx(r_star, rel=1e-15)
    assert ball.stiffness == pytest.approx(
        hertz_stiffness(s.radius_m, 2e11, 0.25, s.target_radius_m, 2e11, 0.25), rel=1e-15)
    assert (ball.velocity_m_s, ball.mass_kg, ball.exponent, ball.damping_s_per_m) == (
        s.velocity_m_s, s.mass_kg, 1.5, s.damping_s_per_m)
    # a target sphere far larger than the ball is a plate: the ball's Hertz c on steel
    flat = SphereOnSphere(target_radius_m=1e12).equivalent_ball()
    assert flat.stiffness == pytest.approx(hertz_stiffness(s.radius_m, 2e11, 0.25), rel=1e-9)
    assert scenarios.get(NAME).reference_metrics(s) == closed_form()


# ------------------------------------------------------------------ through the CLI


def test_run_against_the_closed_form(plugin) -> None:
    require_engine("mujoco")
    args = ("run", "--engine", "mujoco", "--scenario", NAME, "--mode", "injected",
            "--velocity", "2", "--timestep", "1e-6", "--json")
    done = cli(plugin, *args)
    assert done.returncode == 0, done.stdout + done.stderr
    out = json.loads(done.stdout)
    assert out["status"] == "ok", out["message"]
    assert out["reference"] == closed_form(velocity_m_s=2.0)
    for metric, tol in RUN_TOLERANCE.items():
        assert abs(out["rel_error"][metric]) <= tol, (metric, out["rel_error"][metric])

    small = cli(plugin, *args, "--target-radius", "0.02")
    assert small.returncode == 0, small.stdout + small.stderr
    ref = json.loads(small.stdout)["reference"]
    assert ref == closed_form(velocity_m_s=2.0, target_radius_m=0.02)
    # a smaller target sphere: smaller R*, smaller c ∝ √R*, a softer contact, a lower peak
    assert ref["peak_force_n"] < out["reference"]["peak_force_n"]
    assert ref["duration_s"] > out["reference"]["duration_s"]


def test_report_has_the_plugin_section(plugin, tmp_path: Path) -> None:
    require_engine("mujoco")
    require_engine("pymunk")
    config = tmp_path / "report.toml"
    config.write_text('[report]\nengines = ["mujoco", "pymunk"]\n'
                      'modes = ["injected", "native"]\n\n'
                      "[sphere_on_sphere]\nvelocities_m_s = [1.0, 2.0]\n"
                      # layered over the default report: drop its own sections
                      "[ball_on_plate]\nvelocities_m_s = []\n"
                      "[rigid_flexible]\nvelocities_m_s = []\n"
                      "[oblique]\nvelocities_m_s = []\n[bounce]\nheights_m = []\n"
                      "[work_precision]\ntimesteps_s = []\n[practical]\nvelocities_m_s = []\n"
                      "[cube_toss]\nengines = []\n")
    out = tmp_path / "report"
    done = cli(plugin, "report", "--config", str(config), "--out", str(out))
    assert done.returncode == 0, done.stdout + done.stderr
    with (out / "results.csv").open() as fh:
        rows = [r for r in csv.DictReader(fh) if r["scenario"] == NAME]
    assert {r["engine"] for r in rows} == {"mujoco", "pymunk"}
    assert {(r["engine"], r["mode"], float(r["velocity_m_s"])) for r in rows} == {
        (e, m, v) for e in ("mujoco", "pymunk") for m in ("injected", "native")
        for v in (1.0, 2.0)}
    assert {r["status"] for r in rows} == {"ok"}
    ref = closed_form(velocity_m_s=1.0)
    for r in rows:
        if float(r["velocity_m_s"]) == 1.0:
            assert float(r["reference"]) == pytest.approx(ref[r["metric"]], rel=1e-12)
    readme = (out / "README.md").read_text()
    assert "\n## Sphere on sphere\n" in readme


def test_gate_passes_and_fails(plugin, tmp_path: Path) -> None:
    require_engine("mujoco")
    checks = gate_passes_and_fails(
        plugin, tmp_path, f'[[gate]]\nengine = "mujoco"\nmode = "injected"\n'
        f'scenario = "{NAME}"\nvelocities_m_s = [1.0, 5.0]\n', GATE_TOLERANCE)
    assert all(f"-{NAME}-" in c for c in checks)
