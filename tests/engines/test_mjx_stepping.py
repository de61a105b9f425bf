"""MJX's stepping (engines/mjx_adapter.py) against the fixed-length ``lax.scan`` it replaced,
bit for bit, on the real engine.

The adapter steps exactly the steps a run asks for, in calls of one compiled loop whose step
count is a run-time argument, from flat leaves of models rebuilt from the MjModel (one
``put_model`` per MJCF), with no ``mjx.forward`` before the first step, and one per-step
control for every mode of a scenario. Each of these must leave MuJoCo's arithmetic as it was:
here the samples of the loop, split into calls of several lengths, are compared with one
512-step ``lax.scan`` from ``forward(put_data(…))`` with the controls as they were written
before (the old ``secant`` and ``cubic``), to the last bit. The report's 489 MJX runs were
compared the same way against the old adapter when the change was made (all equal).
"""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
from conftest import require_engine
from impactbench.engines.base import RunSettings, get_adapter
from impactbench.reference.oblique import Oblique
from impactbench.reference.record import Status
from impactbench.reference.scenarios import BallOnPlate, RigidFlexible

SPLITS = (1, 7, 64, 440)
"""Calls of the compiled loop that make up the scan's 512 steps."""


@pytest.fixture(scope="module")
def m():
    """The MJX adapter's module (skips with the pip command when MJX is missing)."""
    require_engine("mujoco")
    require_engine("mjx")
    from impactbench.engines import mjx_adapter

    return mjx_adapter


def _old_controls(m) -> None:
    """The per-step controls as the adapter had them before one control served each
    scenario's modes (registered under test names)."""
    jnp = m._mjx()[1].numpy

    def secant(mx, dx, p):
        solref = m._secant_solref(p, -dx.qpos[0])
        return mx.replace(geom_solref=jnp.broadcast_to(solref, mx.geom_solref.shape)), dx

    def cubic(mx, dx, p):
        return mx, dx.replace(qfrc_applied=dx.qfrc_applied.at[1].set(p[0] * dx.qpos[1] ** 3))

    m.CONTROLS.setdefault("test_old_secant", secant)
    m.CONTROLS.setdefault("test_old_cubic", cubic)


def _compare(m, sim, old_control: str, old_params: np.ndarray) -> None:
    """``sim`` stepped in :data:`SPLITS` against one old 512-step scan of the same model and
    start (the old path: put_model, forward(put_data), ``_compiled_scan``)."""
    _, _, mjx = m._mjx()
    mx = mjx.put_model(sim.model)
    dx = m._compiled_forward()(mx, mjx.put_data(sim.model, sim.data))
    _, (q, v, f) = m._compiled_scan(sim.sensor_width)(mx, dx, old_params, 512, old_control)
    for n in SPLITS:
        sim.step_chunk(n)
    got = sim.arrays()
    assert sim.steps == 512 and sim.calls == len(SPLITS)
    for name, a, b in zip(("qpos", "qvel", "force"), (q, v, f), got, strict=True):
        assert np.array_equal(np.asarray(a), b), name
    assert np.any(got[2] > 0.0)  # the samples span contact


@pytest.mark.parametrize("mode", ["native", "injected"])
def test_ball_loop_is_the_old_scan(m, mode: str) -> None:
    """The ball's one control (off: native; on: injected's secant) against the old scan
    with no control and with the old secant control."""
    _old_controls(m)
    setup = m._ball_setup(BallOnPlate(velocity_m_s=0.5), mode, RunSettings(timestep_s=1e-6))
    sim = m._MjxSim(setup.model, setup.data, setup.control, setup.params, m.BALL_CHUNK,
                    setup.mjcf)
    old = ("none", np.zeros(1)) if mode == "native" else ("test_old_secant", setup.params[1:])
    _compare(m, sim, *old)


@pytest.mark.parametrize("structure", ["linear", "softening"])
def test_rigid_flexible_loop_is_the_old_scan(m, structure: str) -> None:
    """The pair's one control (β = 0: no applied force; softening: +β·x2³) against the old
    scan with no control and with the old cubic control, at 1e-6 s (512 steps in contact)."""
    import mujoco
    from impactbench.engines.mujoco_adapter import measured_diag_a, rigid_flexible_mjcf

    _old_controls(m)
    s, dt = RigidFlexible(structure=structure, velocity_m_s=10.0), 1e-6
    mjcf = rigid_flexible_mjcf(s, dt)
    model = mujoco.MjModel.from_xml_string(mjcf)
    data = mujoco.MjData(model)
    a = measured_diag_a(model, data, (1e-9, 0.0))
    model.geom_solref[:] = (-s.k1_n_per_m * a, 0.0)
    data.qpos[:] = (-2.5 * s.velocity_m_s * dt, 0.0)
    data.qvel[:] = (s.velocity_m_s, 0.0)
    beta = s.beta_n_per_m3 if structure == "softening" else 0.0
    sim = m._MjxSim(model, data, "pair", np.array([beta]), m.RIGID_FLEXIBLE_CHUNK, mjcf)
    _compare(m, sim, "test_old_cubic" if beta else "none", np.array([beta]))


def test_oblique_injected_loop_is_the_old_scan(m) -> None:
    """The oblique ball (free joint, a contact pair, the whole contact sensor) with the
    injected law's pair solref scheduled each step."""
    from impactbench.engines.mujoco_adapter import oblique_mjcf, oblique_start, prepare_oblique

    s, settings = Oblique(angle_deg=45.0), RunSettings(timestep_s=3e-7)
    model, data, meta, contact = prepare_oblique(s, "injected", settings, engine="mjx")
    params = np.append(m.injected_parameters(s.normal_scenario().law(),
                                             meta["normal_compliance"]), s.radius_m)
    oblique_start(s, "injected", settings, meta, data, 3e-7, m.MIN_CHUNK)
    sim = m._MjxObliqueSim(model, data, "pair_secant", params, m.OBLIQUE_CHUNK,
                           oblique_mjcf(s, 3e-7, meta["integrator"], contact))
    _compare(m, sim, "pair_secant", params)


def test_model_leaves_are_put_models(m) -> None:
    """A model compiled from a template's MJCF and changed since in its contact (another
    solref and solimp) has exactly put_model's leaves and tree (the template's own check
    passed: ``exact``); another step is another MJCF, with the same tree (one compiled loop
    for both)."""
    mujoco = m._mjx()[0]
    scenario = BallOnPlate(velocity_m_s=1.0)
    first = m._ball_setup(scenario, "native", RunSettings(timestep_s=1e-6))
    other = m._ball_setup(scenario, "tuned", RunSettings(timestep_s=1e-6, tuned={
        "solref": [-3e7, -10.0], "solimp": [0.9, 0.95, 0.001, 0.5, 2.0]}))
    assert first.mjcf == other.mjcf
    template = m._template(first.model, first.data, first.mjcf)
    assert template.exact
    tree, leaves, _ = m._put_model(other.model)
    assert tree == template.mtree
    assert m._same_leaves(template.model_leaves(other.model), m._host(leaves))
    assert not m._same_leaves(template.model_leaves(other.model),
                              template.model_leaves(first.model))  # the solref differs
    coarse = m._ball_setup(scenario, "native", RunSettings(timestep_s=1e-3))
    assert coarse.mjcf != first.mjcf
    assert m._template(coarse.model, coarse.data, coarse.mjcf).mtree == template.mtree
    # the pair's sphere radii differ with its velocity: one tree all the same
    r2, r10 = (m._put_model(mujoco.MjModel.from_xml_string(
        m.rigid_flexible_mjcf(RigidFlexible(velocity_m_s=v), 1e-5)))[0] for v in (2.0, 10.0))
    assert r2 == r10


def test_timed_out_record_runs_to_the_old_scans_end(m) -> None:
    """A run that reaches its cap keeps the samples it always had: the plan's cap rounded up
    to whole 512-step scans (``step_cap``), every one of them stepped."""
    rec = get_adapter("mjx").run(BallOnPlate(velocity_m_s=0.5), "tuned", RunSettings(
        timestep_s=1e-4, max_time_s=0.03, tuned={"solref": [0.02, 1.0]}))
    assert rec.status is Status.MAX_TIME, rec.message
    assert len(rec) == m.step_cap(300, m.BALL_CHUNK) == 512 == rec.meta["steps"]
    assert m.step_cap(512, 512) == 512 and m.step_cap(513, 512) == 1024


def test_mjx_imports_without_its_warp_backend() -> None:
    """A fresh process: MJX's bundled MuJoCo Warp is not imported, nothing is printed, and
    MJX runs."""
    require_engine("mjx")
    code = ("import sys\n"
            "from impactbench.engines.mjx_adapter import WARP_BACKEND, _mjx, ball_batch\n"
            "from impactbench.reference.scenarios import BallOnPlate\n"
            "_mjx()\n"
            "assert WARP_BACKEND not in sys.modules, 'warp backend imported'\n"
            "x, _, f = ball_batch(BallOnPlate(), [(-1e6, -10.0)], 1e-5, 8)\n"
            "assert x.shape == (1, 8)\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=600, check=False)
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout == ""


def _same_records(a, b) -> None:
    """Two records equal bit for bit in every channel, status, message and meta (wall_s
    aside)."""
    assert (a.status, a.message) == (b.status, b.message)
    for name in ("time_s", "penetration_m", "penetration_rate_m_s", "normal_force_n",
                 "velocity_1_m_s", "velocity_2_m_s", "displacement_2_m"):
        x, y = getattr(a, name), getattr(b, name)
        assert (x is None) == (y is None), name
        assert x is None or np.array_equal(x, y, equal_nan=True), name
    strip = ("wall_s",)
    assert repr({k: v for k, v in a.meta.items() if k not in strip}) == \
        repr({k: v for k, v in b.meta.items() if k not in strip})


def test_rigid_flexible_run_many_is_run_bit_for_bit(m) -> None:
    """Rigid–flexible runs in one vmap over every model leaf (run_rigid_flexible_batch):
    both structures (a collapse among them), three local laws, two velocities, a tuned
    solref and another step — one model tree, one batch — each record the lone run's to the
    last bit; an injected run between them is refused as alone."""
    mjx = get_adapter("mjx")
    items = [(RigidFlexible(local=local, structure=structure, velocity_m_s=v), "native",
              RunSettings()) for local, structure, v in (
                  ("linear", "linear", 2.0), ("elastoplastic", "softening", 10.0),
                  ("mutation", "linear", 10.0), ("linear", "softening", 2.0),
                  ("linear", "softening", 40.0))]
    items.append((RigidFlexible(), "tuned", RunSettings(tuned={"solref": [-2e7, -5.0]})))
    items.append((RigidFlexible(velocity_m_s=3.0), "native", RunSettings(timestep_s=2e-5)))
    items.insert(2, (RigidFlexible(), "injected", RunSettings()))
    trees = {m._template(st.model, st.data, st.mjcf).mtree
             for st in (m._pair_setup(*it) for it in items if it[1] != "injected")}
    assert len(trees) == 1 and len(items) - 1 >= m.PAIR_BATCH_MIN_WORLDS  # one batch
    many = mjx.run_many(items)
    alone = [mjx.run(*item) for item in items]
    assert str(alone[2].status) == "unsupported"
    assert {str(r.status) for r in alone if r is not alone[2]} == {"ok", "structure_collapsed"}
    for a, b in zip(alone, many, strict=True):
        _same_records(a, b)


def test_a_kept_loop_steps_as_the_traced_one_bit_for_bit(m, tmp_path, monkeypatch) -> None:
    """A loop loaded from its kept program (jax.export's serialized form, LOOPS_DIR) gives
    the records of the loop traced in this process, to the last bit: a ball run and a
    rigid–flexible run, first traced here with nothing kept, then kept, then loaded from
    the files written (one per loop)."""
    mjx = get_adapter("mjx")
    items = [(BallOnPlate(), "native", RunSettings()), (RigidFlexible(), "native", RunSettings())]
    monkeypatch.setattr(m, "LOOPS_DIR", tmp_path)

    def fresh(keep: bool):
        monkeypatch.setattr(m, "EXPORT_LOOPS", keep)
        m._stepper.cache_clear()
        return [mjx.run(*item) for item in items]

    traced = fresh(False)
    assert not list(tmp_path.iterdir())
    kept = fresh(True)
    files = sorted(tmp_path.glob("*.jaxexport"))
    assert len(files) == 2
    loaded = fresh(True)
    assert sorted(tmp_path.glob("*.jaxexport")) == files  # read, not written again
    for a, b, c in zip(traced, kept, loaded, strict=True):
        assert str(a.status) == "ok"
        _same_records(a, b)
        _same_records(a, c)
    m._stepper.cache_clear()
