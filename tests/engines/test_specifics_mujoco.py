"""MuJoCo's and MJX's own checks (real engines, no mocks); the shapes every adapter shares are
in test_conformance.py.

MJX is C MuJoCo's physics in JAX (64-bit), so its main check is that both give the same record
for the same model, to round-off (XLA orders some sums differently). Each MJX scan kind
compiles once per process (2–5 s, ~15 s for the oblique kinds on first use, then jax's
persistent cache); the tests reuse a few kinds only. Tolerances are about 3× the errors
measured on this machine (mujoco 4.0.0; mujoco-mjx 3.17.0, jax 0.10.2 CPU), written beside
them.
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import require_engine
from impactbench.engines.base import RunSettings, get_adapter
from impactbench.engines.oblique_common import native_normal
from impactbench.reference import hunt_crossley
from impactbench.reference.metrics import compute
from impactbench.reference.oblique import Oblique
from impactbench.reference.record import Status
from impactbench.reference.scenarios import BallOnPlate

from impactbench.evaluate import compare


@pytest.fixture(scope="module")
def mujoco():
    """The mujoco module (skips with its pip command when it is missing)."""
    return require_engine("mujoco")


@pytest.fixture(scope="module")
def mjx(mujoco):
    """The MJX adapter, beside C MuJoCo (both skip with their pip commands)."""
    require_engine("mjx")
    return get_adapter("mjx")


# --------------------------------------------------------------------------------- C MuJoCo


@pytest.mark.parametrize("v_ref", [1.0, 5.0])
def test_native_linear_contact_restitution_does_not_follow_hunt_crossley(mujoco, v_ref):
    """A linear contact's restitution does not follow Hunt–Crossley's fall with velocity:
    measured equal to 1.3e-15 at three times the velocity."""
    settings = RunSettings(timestep_s=1e-7, options={"reference_velocity_m_s": v_ref})
    mj = get_adapter("mujoco")
    rec = mj.run(BallOnPlate(velocity_m_s=v_ref), "native", settings)
    other = mj.run(BallOnPlate(velocity_m_s=v_ref * 3.0), "native", settings)
    assert rec.status is Status.OK and other.status is Status.OK, (rec.message, other.message)
    assert compute(other)["restitution"] == pytest.approx(compute(rec)["restitution"], rel=1e-14)


def test_contact_sensor_is_mj_contact_force_and_direct_solref_is_physical(mujoco) -> None:
    """The recorded force (contact sensor) equals mj_contactForce's normal force, and a direct
    solref (−K·A, −D·A) with constant impedance gives F = K·x + D·ẋ."""
    from impactbench.engines.mujoco_adapter import SOLIMP, ball_mjcf, measured_diag_a

    scenario = BallOnPlate()
    model = mujoco.MjModel.from_xml_string(ball_mjcf(scenario, 1e-6))
    data = mujoco.MjData(model)
    a = measured_diag_a(model, data, (-1e-9,))
    assert a == pytest.approx(1.0 / scenario.mass_kg, rel=1e-9)
    k, d = 3.0e8, 250.0
    model.geom_solref[:] = (-k * a, -d * a)
    model.geom_solimp[:] = SOLIMP
    x, rate = 2.0e-5, 0.7
    data.qpos[0], data.qvel[0] = -x, -rate
    mujoco.mj_step(model, data)
    f6 = np.zeros(6)
    mujoco.mj_contactForce(model, data, 0, f6)
    assert data.sensordata[0] == pytest.approx(f6[0], rel=1e-12)
    assert f6[0] == pytest.approx(k * x + d * rate, rel=1e-6)


def test_gravity_option_is_applied(mujoco) -> None:
    """With gravity on, the ball leaves slower (gravity acts through the whole contact)."""
    mj = get_adapter("mujoco")
    off = compute(mj.run(BallOnPlate(velocity_m_s=0.5), "injected"))
    on = compute(mj.run(BallOnPlate(velocity_m_s=0.5, gravity_m_s2=9.81), "injected"))
    assert on["restitution"] < off["restitution"]
    # measured −4.6e-5: gravity's work over the contact against the impact energy
    assert on["restitution"] == pytest.approx(off["restitution"], rel=1.4e-4)


def test_oblique_native_is_pyramidal_and_its_soft_friction_barely_acts(mujoco):
    s = Oblique(angle_deg=20.0)
    pyramidal, rec = compare("mujoco", s, "native", RunSettings())
    elliptic, rec_e = compare("mujoco", s, "native", RunSettings(options={"cone": "elliptic"}))
    assert pyramidal["status"] == elliptic["status"] == "ok"
    facts = rec.meta["engine_defaults"]
    assert facts["cone"] == "pyramidal" and rec_e.meta["engine_defaults"]["cone"] == "elliptic"
    assert facts["condim"] == 3 and facts["impratio"] == 1.0
    assert facts["friction_combination"] == "max" and facts["friction_effective"] == 0.3
    assert "pyramidal" in facts["friction_model"]
    # the normal part is the ball's native contact: the clipped spring–damper matched at 1 m/s
    # (e 0.93748 at every speed; measured 0.93731 — the sliding pyramid adds 2e-4)
    native_e = native_normal(s, 1.0).restitution(s.mass_kg)
    assert pyramidal["restitution"] == pytest.approx(native_e, rel=1e-3)
    # measured: spin 0.68 rad/s (pyramidal), 12.2 (elliptic) for the rigid theory's 33.65
    ref = pyramidal["reference"]["spin_out_rad_s"]
    assert pyramidal["spin_out_rad_s"] < 0.1 * ref < elliptic["spin_out_rad_s"] < 0.6 * ref


OBLIQUE_CUSTOM = {"cone": "elliptic", "impratio": 10, "condim": 4, "friction": [0.5],
                  "noslip_iterations": 5, "solreffriction": [0.02, 1.0]}
"""The oblique custom keys, read back from the MjModel here and from the record in
test_conformance.py (``mujoco-custom``)."""


def test_oblique_custom_keys_reach_the_model(mujoco):
    from impactbench.engines.mujoco_adapter import prepare_oblique

    settings = RunSettings(timestep_s=2e-3, params=OBLIQUE_CUSTOM)
    model, *_ = prepare_oblique(Oblique(angle_deg=30.0), "custom", settings)
    assert model.opt.cone == mujoco.mjtCone.mjCONE_ELLIPTIC
    assert model.opt.impratio == 10.0 and model.opt.noslip_iterations == 5
    assert np.allclose(model.geom_friction[:, 0], 0.5)
    assert list(model.pair_solreffriction[0]) == [0.02, 1.0] and model.pair_dim[0] == 4


# -------------------------------------------------------------------------------------- MJX


@pytest.mark.parametrize("mode", ["native", "injected"])
def test_mjx_ball_record_is_c_mujocos(mjx, mode: str) -> None:
    """Same MJCF, same parameters: MJX (64-bit) and C MuJoCo give the same samples."""
    scenario = BallOnPlate(velocity_m_s=2.0)
    ours = mjx.run(scenario, mode)
    theirs = get_adapter("mujoco").run(scenario, mode)
    assert ours.status is Status.OK and theirs.status is Status.OK, (ours.message, theirs.message)
    assert len(ours) == len(theirs)
    # measured largest relative differences (native / injected): penetration 1.6e-15 /
    # 2.3e-14, force 1.5e-16 / 5.0e-15, velocity 1.2e-14 / 6.8e-15, zeros equal: a
    # round-off floor of 1e-12 (XLA's operation order follows the host CPU's vector units)
    for name in ("penetration_m", "normal_force_n", "velocity_1_m_s"):
        np.testing.assert_allclose(getattr(ours, name), getattr(theirs, name), rtol=1e-12,
                                   atol=0.0, err_msg=name)
    assert ours.meta["stepping"] == "lax.scan" and ours.meta["efc_diagA"] == theirs.meta[
        "efc_diagA"]


def test_mjx_long_run_spans_several_scans(mjx) -> None:
    """The injected ball at 1e-7 s (776 contact steps) runs in chunks of one compiled scan;
    its errors are in test_conformance.py."""
    rec = mjx.run(BallOnPlate(velocity_m_s=5.0), "injected", RunSettings(timestep_s=1e-7))
    assert rec.status is Status.OK, rec.message
    assert rec.meta["steps"] > rec.meta["chunk_steps"]


def test_mjx_default_is_soft_and_custom_native_solref_is_native(mjx) -> None:
    """default: MuJoCo's own solref (0.02, 1) — a soft, heavily damped contact (recorded:
    test_conformance.py); custom with the native solref/solimp is the native run."""
    scenario = BallOnPlate(velocity_m_s=1.0)
    rec = mjx.run(scenario, "default", RunSettings(timestep_s=1e-5))
    assert rec.status is Status.OK, rec.message
    assert compute(rec)["duration_s"] > 100 * hunt_crossley.solve(scenario)["duration_s"]
    native = mjx.run(scenario, "native")
    params = {"solref": native.meta["solref"], "solimp": native.meta["solimp"]}
    custom = mjx.run(scenario, "custom", RunSettings(params=params))
    assert custom.meta["solref"] == native.meta["solref"]
    np.testing.assert_array_equal(custom.normal_force_n, native.normal_force_n)


def test_mjx_batch_over_stiffness(mjx) -> None:
    """One vmapped call over three stiffnesses: restitution grows with stiffness at fixed
    damping (ζ ∝ 1/√K), and the middle world is the single run with that solref."""
    from impactbench.engines.mjx_adapter import ball_batch

    scenario = BallOnPlate(velocity_m_s=1.0)
    single = mjx.run(scenario, "native")
    s, d = single.meta["solref"]
    n = 2 * len(single)  # the softest world (duration × √3) separates within it too
    x, rate, force = ball_batch(scenario, [(s / 3, d), (s, d), (3 * s, d)], 1e-6, n)
    assert x.shape == (3, n)
    restitution = rate[:, -1] / scenario.velocity_m_s  # gap rate: upward after the bounce
    assert restitution[0] < restitution[1] < restitution[2]
    # measured bit-identical; the round-off floor of test_mjx_ball_record_is_c_mujocos
    np.testing.assert_allclose(force[1, :len(single)], single.normal_force_n, rtol=1e-12,
                               atol=0.0)


@pytest.mark.parametrize("mode", ["native", "injected"])
def test_mjx_oblique_record_is_c_mujocos(mjx, mode):
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


def test_mjx_oblique_custom_keys_reach_mjxs_model(mjx):
    from impactbench.engines.mjx_adapter import _mjx
    from impactbench.engines.mujoco_adapter import prepare_oblique

    mjx_module = _mjx()[2]
    params = {"cone": "elliptic", "impratio": 10, "friction": 0.5,
              "solreffriction": [0.02, 1.0]}
    model, *_ = prepare_oblique(Oblique(), "custom", RunSettings(params=params))
    mx = mjx_module.put_model(model)
    assert int(mx.opt.cone) == 1 and float(mx.opt.impratio) == 10.0  # mjCONE_ELLIPTIC
    assert np.allclose(np.asarray(mx.geom_friction)[:, 0], 0.5)
    assert np.allclose(np.asarray(mx.pair_solreffriction)[0], [0.02, 1.0])


# --------------------------------------------------------------------------- MJX batches


def _same_records(a, b) -> None:
    """Two records equal bit for bit (``wall_s`` aside)."""
    assert (a.status, a.message) == (b.status, b.message)
    for name in ("time_s", "penetration_m", "penetration_rate_m_s", "normal_force_n",
                 "velocity_1_m_s"):
        assert np.array_equal(getattr(a, name), getattr(b, name), equal_nan=True), name
    strip = ("wall_s",)
    assert repr({k: v for k, v in a.meta.items() if k not in strip}) == \
        repr({k: v for k, v in b.meta.items() if k not in strip})


def test_mjx_run_many_is_run_bit_for_bit(mjx) -> None:
    """A tuner's generation in one vmapped call (Adapter.run_many → run_ball_batch): every
    world's record is the one a lone run gives, to the last bit — a soft candidate that runs
    to the time cap, stiff ones at two velocities and three phases, a native run among them
    (its model is theirs: 19 worlds of one vmap), and an injected run (a group of one: it
    runs alone). Measured: the report's 438 ball runs through run_many equal the old lone
    adapter's, 0.31 of the time of one by one once compiled."""
    from impactbench.engines.mjx_adapter import BATCH_MIN_WORLDS

    items = []
    for v in (0.5, 3.0):
        scenario = BallOnPlate(velocity_m_s=v)
        items += [(scenario, "tuned", RunSettings(tuned={"solref": solref}, phase=phase))
                  for solref in ([0.02, 1.0], [-1e6, -30.0], [-3e7, -10.0])
                  for phase in (0.0, 0.25, 0.5)]
    items.insert(2, (BallOnPlate(velocity_m_s=1.0), "native", RunSettings()))
    items.insert(5, (BallOnPlate(velocity_m_s=1.0), "injected", RunSettings()))
    assert len(items) - 1 >= BATCH_MIN_WORLDS  # the batch really is one
    many = mjx.run_many(items)
    alone = [mjx.run(*item) for item in items]
    assert {str(r.status) for r in alone} == {"ok", "max_time"}
    for a, b in zip(alone, many, strict=True):
        _same_records(a, b)


def test_compare_many_is_compare(mjx) -> None:
    """compare_many's objects (what the tuner reads) are compare's, wall_s aside."""
    from impactbench.evaluate import compare_many

    items = [(BallOnPlate(velocity_m_s=v), "tuned", RunSettings(tuned={"solref": [-1e6, -30.0]}),
              None) for v in (0.5, 3.0)]
    got = compare_many("mjx", items)
    for item, run in zip(items, got, strict=True):
        want = compare("mjx", *item)[0]
        assert {k: v for k, v in run.items() if k != "wall_s"} == \
            {k: v for k, v in want.items() if k != "wall_s"}
