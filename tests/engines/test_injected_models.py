"""Injected mode follows the scenario's contact model in every engine (no per-adapter code)."""

from __future__ import annotations

import pytest
from conftest import require_engine
from impactbench.engines.base import RunSettings
from impactbench.reference.scenarios import BallOnPlate

from impactbench.evaluate import compare

ENGINES = ("mujoco", "pybullet", "pymunk", "drake", "sapien", "dart", "box2d")
FLORES = BallOnPlate(velocity_m_s=2.0, model="flores", nominal_restitution=0.5)
CLIPPED = BallOnPlate(velocity_m_s=2.0, model="kelvin-voigt-clipped", nominal_restitution=0.5,
                      exponent=1.0, stiffness=1e7)


# ~3x the measured worst |rel error| of (restitution, peak force) over the two models: MuJoCo
# and pymunk (explicit stepping) 1.2e-4, 1.1e-3; PyBullet keeps Bullet's implicit contact step
# (injection's one meaning), which dissipates: 3.1e-3, 1.5e-3; Drake (RK3) 3.6e-4, 2.9e-4;
# SAPIEN, DART and Box2D step an applied force as pymunk does (semi-implicit Euler): 1.2e-4, 1.1e-3
LIMITS = {"mujoco": (3.5e-4, 3.3e-3), "pymunk": (3.5e-4, 3.3e-3),
          "pybullet": (9.2e-3, 4.5e-3), "drake": (1.1e-3, 8.7e-4),
          "sapien": (3.5e-4, 3.3e-3), "dart": (3.5e-4, 3.3e-3), "box2d": (3.5e-4, 3.3e-3)}


@pytest.mark.parametrize("engine", ENGINES)
def test_injected_mode_follows_the_model(engine):
    require_engine(engine)
    for scenario, dt in ((FLORES, 1e-7), (CLIPPED, 2e-7)):
        out, _ = compare(engine, scenario, "injected", RunSettings(timestep_s=dt))
        assert out["status"] == "ok", out["message"]
        # Flores at e = 0.5 has k = 0.4704 (not 0.5); a Hunt–Crossley b = 0.1 run would
        # give 0.87 — the engine must follow the model, to within its first-order stepping
        assert out["reference"]["restitution"] == pytest.approx(
            0.470444779 if scenario is FLORES else 0.550283170, rel=1e-8)
        restitution, peak = LIMITS[engine]
        assert abs(out["rel_error"]["restitution"]) < restitution
        assert abs(out["rel_error"]["peak_force_n"]) < peak


@pytest.mark.parametrize("engine", ENGINES)
def test_unclipped_kelvin_voigt_is_unsupported_in_engines(engine):
    require_engine(engine)
    s = CLIPPED.replace(model="kelvin-voigt")
    out, _ = compare(engine, s, "injected", RunSettings(timestep_s=1e-6))
    assert out["status"] == "unsupported"
    assert "kelvin-voigt-clipped" in out["message"]
