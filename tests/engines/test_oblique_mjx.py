"""MJX's oblique impact (issue 22): C MuJoCo's model and friction settings in JAX, so the main
check is that both give the same record; plus injected against the rigid Coulomb reference on
both sides of the stick/slide threshold, through :func:`impactbench.evaluate.compare`.

Tolerances: ~3× the errors measured here (mujoco-mjx 3.17.0, jax 0.10.2 CPU, dt 1e-6 s); they
are C MuJoCo's to 1e-12. Each scan kind compiles once per process (~15 s on first use, then
jax's persistent cache).
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import require_engine

require_engine("mjx")
require_engine("mujoco")

from impactbench.engines.base import RunSettings, get_adapter  # noqa: E402
from impactbench.engines.mjx_adapter import _mjx  # noqa: E402
from impactbench.engines.mujoco_adapter import prepare_oblique  # noqa: E402
from impactbench.reference.oblique import Oblique  # noqa: E402

from impactbench.evaluate import compare  # noqa: E402

# injected vs rigid, measured worst |rel err| over 20°, 45°, 60° (stick) and 80° (slide) —
# C MuJoCo's: restitution 3.2e-4, tangential restitution 4.2e-4, spin 5.6e-4, rebound angle
# 3.4e-4
INJECTED_TOLERANCE = {"restitution": 1e-3, "tangential_restitution": 1.3e-3,
                      "spin_out_rad_s": 1.7e-3, "rebound_angle_deg": 1e-3}


@pytest.mark.parametrize(("angle", "regime"), [(20.0, 0.0), (45.0, 0.0), (60.0, 0.0),
                                               (80.0, 1.0)])
def test_injected_reproduces_the_rigid_reference(angle, regime):
    out, rec = compare("mjx", Oblique(angle_deg=angle), "injected", RunSettings())
    assert out["status"] == "ok", out["message"]
    for key, tol in INJECTED_TOLERANCE.items():
        assert abs(out["rel_error"][key]) <= tol, (angle, key, out["rel_error"][key])
    assert out["regime"] == regime
    assert rec.meta["engine_defaults"]["cone"] == "elliptic"


@pytest.mark.parametrize("mode", ["native", "injected"])
def test_the_record_is_c_mujocos(mode):
    s = Oblique(angle_deg=20.0)
    _, mjx_rec = compare("mjx", s, mode, RunSettings())
    _, c_rec = compare("mujoco", s, mode, RunSettings())
    assert len(mjx_rec) == len(c_rec)
    for name in ("penetration_m", "normal_force_n", "tangential_velocity_m_s", "spin_rad_s",
                 "tangential_force_n"):
        got, ref = getattr(mjx_rec, name), getattr(c_rec, name)
        scale = np.max(np.abs(ref))
        assert np.max(np.abs(got - ref)) <= 1e-9 * scale, name
    assert mjx_rec.meta["engine_defaults"] == c_rec.meta["engine_defaults"]


def test_default_at_a_customary_step_records_the_friction_model():
    out, _ = compare("mjx", Oblique(angle_deg=60.0), "default", RunSettings(timestep_s=2e-3))
    assert out["status"] in ("ok", "implausible"), out["message"]
    facts = out["engine_defaults"]
    assert facts["cone"] == "pyramidal" and facts["friction_effective"] == 0.3
    assert facts["friction_combination"] == "max" and facts["friction_model"]


def test_custom_keys_reach_mjxs_model():
    mjx = _mjx()[2]
    params = {"cone": "elliptic", "impratio": 10, "friction": 0.5,
              "solreffriction": [0.02, 1.0]}
    model, *_ = prepare_oblique(Oblique(), "custom", RunSettings(params=params))
    mx = mjx.put_model(model)
    assert int(mx.opt.cone) == 1 and float(mx.opt.impratio) == 10.0  # mjCONE_ELLIPTIC
    assert np.allclose(np.asarray(mx.geom_friction)[:, 0], 0.5)
    assert np.allclose(np.asarray(mx.pair_solreffriction)[0], [0.02, 1.0])
    # MJX has no noslip solver: the key is not offered
    with pytest.raises(ValueError, match="valid keys"):
        get_adapter("mjx").run(Oblique(), "custom",
                               RunSettings(params={"noslip_iterations": 5}))


def test_tuned_with_the_balls_parameters_is_unsupported_with_a_reason():
    # oblique tuned reads friction knobs (impactbench.engines.oblique_tuned); a ball's
    # parameters are refused, and none at all too (tests/impactbench/test_oblique_tuned.py)
    out, _ = compare("mjx", Oblique(), "tuned", RunSettings(tuned={"solref": [-1, -1]}))
    assert out["status"] == "unsupported"
    assert "not mjx's oblique friction" in out["message"]
