"""The cube tosses' fast paths give the old paths' floats, bit for bit.

The injected replays' per-step Python (the engine's state as plain floats, the reference
model's corner wrench, the force pushed back), the pose reads (DART's quaternion from its
rotation matrix without scipy's per-call overhead) and MJX's world slots (a finished toss's
slot taking the next toss) were rewritten for speed; each test here runs the new path beside
a copy of the old one (numpy 3-vectors, ``scipy.spatial.transform.Rotation``, the old
batches) and asserts the same bits. The old code's BLAS calls (the quaternion's norm, R·ω)
are kept as calls, so the equality holds whatever the BLAS kernel's summation order.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from conftest import require_engine
from impactbench.reference import box_contact as bc

from impactbench import scenarios

# ------------------------------------------------------------------------------ the old code


def old_quat_matrix(q: np.ndarray) -> np.ndarray:
    """box_contact.quat_matrix before the fast path (numpy scalars)."""
    w, x, y, z = np.asarray(q, dtype=float) / math.sqrt(float(np.dot(q, q)))
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


class OldCornerWrench:
    """box_contact.CornerWrench.__call__ before the fast path (numpy 3-vectors)."""

    def __init__(self, params: bc.BoxContactParams, box: bc.Box, board_z_m: float) -> None:
        self.model = bc.BoxOnBoard(params, box, board_z_m=board_z_m)
        self.model.max_evaluations = math.inf
        self.board_z, self.g = board_z_m, bc.GRAVITY_M_S2
        self.reach = box.half_width_m * math.sqrt(3.0)
        self.m = box.mass_kg
        self.inertia = box.inertia
        self.zero = (np.zeros(3), np.zeros(3))

    def __call__(self, p, q, v, w_world):
        if p[2] - self.reach >= self.board_z:
            return self.zero
        q = np.asarray(q, dtype=float)
        q = q / math.sqrt(float(q @ q))
        rot = old_quat_matrix(q)
        w_body = rot.T @ np.asarray(w_world, dtype=float)
        d = self.model.rhs(0.0, np.concatenate([p, q, v, w_body]))
        force = self.m * d[7:10]
        force[2] += self.m * self.g
        iw = self.inertia * w_body
        torque_body = self.inertia * d[10:13] + np.cross(w_body, iw)
        return force, rot @ torque_body


def old_quat_from_matrix(r: np.ndarray) -> np.ndarray:
    """cube_toss_more._quat_from_matrix before the fast path (scipy)."""
    from scipy.spatial.transform import Rotation

    x, y, z, w = Rotation.from_matrix(np.asarray(r, dtype=float)).as_quat()
    return np.array([w, x, y, z])


def bits(*arrays) -> list[bytes]:
    return [np.asarray(a, dtype=float).tobytes() for a in arrays]


# ------------------------------------------------------------------------------ the model's law


def test_quat_matrix_is_the_old_one() -> None:
    rng = np.random.default_rng(1)
    for n in range(3000):
        q = rng.normal(size=4) * rng.uniform(0.2, 5.0)
        arg = q.astype(np.float32) if n % 3 == 0 else (q.tolist() if n % 3 == 1 else q)
        assert bits(bc.quat_matrix(arg)) == bits(old_quat_matrix(arg))
    assert bc.quat_matrix(q).flags.c_contiguous


LAWS = [bc.BoxContactParams(),
        bc.BoxContactParams(law="kelvin-voigt-clipped", stiffness=3e3, exponent=1.0,
                            damping=8.0, friction=0.6),
        bc.BoxContactParams(exponent=1.0, damping=0.4)]
BOXES = [bc.Box(), bc.Box(half_width_m=0.05, mass_kg=0.5, inertia_kg_m2=(7e-4, 8e-4, 1e-3))]


@pytest.mark.parametrize("box", BOXES, ids=["dair", "anisotropic"])
@pytest.mark.parametrize("law", LAWS, ids=["hunt-crossley", "kelvin-voigt", "hc-linear"])
def test_corner_wrench_is_the_old_wrench(law: bc.BoxContactParams, box: bc.Box) -> None:
    """Random states around the board (a corner below it or not, |q| ≠ 1): values() and
    __call__ give the old __call__'s force and torque to the last bit."""
    rng = np.random.default_rng(2)
    board = 0.013
    new, old = bc.CornerWrench(law, box, board), OldCornerWrench(law, box, board)
    pushed = 0
    for _ in range(4000):
        p = np.array([rng.normal(), rng.normal(), board + rng.uniform(-0.03, 0.12)])
        q = rng.normal(size=4) * rng.uniform(0.5, 2.0)
        v, w = rng.normal(size=3), rng.normal(size=3) * 10.0
        f0, t0 = old(p, q, v, w)
        values = new.values(*p.tolist(), *q.tolist(), *v.tolist(), *w.tolist())
        f1, t1 = new(p, q, v, w)
        assert bits(values[:3], values[3:]) == bits(f0, t0) == bits(f1, t1)
        pushed += bool(np.any(f0))
    assert pushed > 1000      # the contact branch ran, not only the free flight


# ------------------------------------------------------------------------------ DART's quaternion


def _rotation(axis: np.ndarray, angle: float) -> np.ndarray:
    from scipy.spatial.transform import Rotation

    return Rotation.from_rotvec(axis / np.linalg.norm(axis) * angle).as_matrix()


def test_quat_from_matrix_is_scipys() -> None:
    """Random rotations, rotations near π about each axis (each branch of Shepperd's choice),
    rounding noise inside scipy's orthogonality test and beyond it (scipy's SVD path)."""
    from impactbench.engines.cube_toss_more import quat_from_matrix

    rng = np.random.default_rng(3)
    mats = [_rotation(rng.normal(size=3), rng.uniform(0, math.pi)) for _ in range(6000)]
    for axis in np.eye(3):
        mats += [_rotation(axis + rng.normal(size=3) * 1e-3, math.pi - 1e-3 * k)
                 for k in range(20)]
    mats += [np.eye(3), np.diag([1.0, -1.0, -1.0]), np.diag([-1.0, 1.0, -1.0]),
             np.diag([-1.0, -1.0, 1.0])]
    noisy = [m + rng.normal(size=(3, 3)) * s for m in mats[:1500] for s in (1e-16, 1e-13)]
    beyond = [m + rng.normal(size=(3, 3)) * 1e-9 for m in mats[:200]]
    choices = set()
    for m in mats + noisy + beyond:
        got = quat_from_matrix(m.tolist())
        assert bits(got) == bits(old_quat_from_matrix(m))
        choices.add(int(np.argmax([m[0, 0], m[1, 1], m[2, 2], np.trace(m)])))
    assert choices == {0, 1, 2, 3}
    with pytest.raises(ValueError, match="determinant"):
        quat_from_matrix(np.diag([1.0, 1.0, -1.0]).tolist())


# ------------------------------------------------------------------------------ the engines


@pytest.fixture(scope="module")
def starts() -> list:
    """Three test tosses of the packaged data, as the report replays them."""
    scenario = scenarios.get("cube-toss").build()
    got, _ = scenario.starts()
    return got[:3]


def _old_state(engine: str, sim) -> tuple[np.ndarray, ...]:
    """The engine's state as the old _state read it (arrays)."""
    if engine == "pybullet":
        pb, c = sim._pb, sim._client
        pos, (x, y, z, w) = pb.getBasePositionAndOrientation(sim._cube, physicsClientId=c)
        v, om = pb.getBaseVelocity(sim._cube, physicsClientId=c)
        return np.array(pos), np.array([w, x, y, z]), np.array(v), np.array(om)
    if engine == "mujoco":
        d = sim._data
        q = d.qpos[3:7].copy()
        return d.qpos[:3].copy(), q, d.qvel[:3].copy(), old_quat_matrix(q) @ d.qvel[3:6]
    if engine == "drake":
        x = sim._plant.GetFreeBodyPose(sim._plant_context, sim._body)
        v = sim._plant.EvalBodySpatialVelocityInWorld(sim._plant_context, sim._body)
        return (np.array(x.translation()), np.array(x.rotation().ToQuaternion().wxyz()),
                np.array(v.translational()), np.array(v.rotational()))
    if engine == "sapien":
        pose, b = sim._body.entity_pose, sim._body
        return (np.asarray(pose.p, dtype=float), np.asarray(pose.q, dtype=float),
                np.asarray(b.linear_velocity, dtype=float),
                np.asarray(b.angular_velocity, dtype=float))
    tf, n = sim._node.getWorldTransform(), sim._node
    return (np.array(tf.translation(), dtype=float), old_quat_from_matrix(tf.rotation()),
            np.asarray(n.getLinearVelocity(), dtype=float),
            np.asarray(n.getAngularVelocity(), dtype=float))


def _old_push(engine: str, sim, force: np.ndarray, torque: np.ndarray) -> None:
    """One step with the force and torque as the old _push_step applied them."""
    if engine == "pybullet":
        pb, c = sim._pb, sim._client
        if force[0] or force[1] or force[2] or torque[0] or torque[1] or torque[2]:
            pos, _ = pb.getBasePositionAndOrientation(sim._cube, physicsClientId=c)
            pb.applyExternalForce(sim._cube, -1, force.tolist(), pos, pb.WORLD_FRAME,
                                  physicsClientId=c)
            pb.applyExternalTorque(sim._cube, -1, torque.tolist(), pb.WORLD_FRAME,
                                   physicsClientId=c)
        pb.stepSimulation(physicsClientId=c)
    elif engine == "mujoco":
        d = sim._data
        d.xfrc_applied[sim._cube_body, :3] = force
        d.xfrc_applied[sim._cube_body, 3:] = torque
        sim._mj.mj_step(sim._model, d)
    elif engine == "drake":
        from pydrake.multibody.math import SpatialForce
        from pydrake.multibody.plant import ExternallyAppliedSpatialForce

        applied = ExternallyAppliedSpatialForce()
        applied.body_index = sim._body.index()
        applied.p_BoBq_B = np.zeros(3)
        applied.F_Bq_W = SpatialForce(torque, force)
        # FixValue replaces the port's value object, freeing the one the adapter holds and
        # sets in place (sim._fixed): hand it the new one, or the next new-path step writes
        # into freed memory (a segfault seen once in a full run of the suite)
        sim._fixed = sim._plant.get_applied_spatial_force_input_port().FixValue(
            sim._plant_context, [applied])
        sim._steps += 1
        sim._sim.AdvanceTo((sim._steps + 0.25) * sim.step_s)
    elif engine == "sapien":
        sim._body.add_force_torque(force.astype(np.float32), torque.astype(np.float32))
        sim._scene.step()
    else:
        sim._node.setExtForce(force, np.zeros(3), False, True)
        sim._node.setExtTorque(torque, False)
        sim._world.step()


ENGINES = ["pybullet", "mujoco", "drake", "sapien", "dart"]
STEPS = 700
"""Steps per toss compared: the flight, the first impacts and some sliding."""


@pytest.mark.parametrize("engine", ENGINES)
def test_injected_steps_are_the_old_path(engine: str, starts: list) -> None:
    """Injected mode, step by step: the new loop (plain floats, CornerWrench.values, the
    engine's new push) and the old one (arrays, the old wrench, the old push) from the same
    start reach the same state after every step."""
    require_engine(engine)
    from impactbench.engines.cube_toss import make

    from impactbench.cube_tosses.model_modes import load_model

    law = load_model()
    sim = make(engine, {}, starts[0].step_s, 0.0, law=law)
    old_wrench = OldCornerWrench(law, sim.box, 0.0)
    try:
        for start in starts:
            sim._reset(start)
            new = []
            for _ in range(STEPS):
                sim._advance_injected(1)
                new.append(bits(*_old_state(engine, sim)))
            sim._reset(start)
            old = []
            for _ in range(STEPS):
                _old_push(engine, sim, *old_wrench(*_old_state(engine, sim)))
                old.append(bits(*_old_state(engine, sim)))
            assert new == old
            assert sim._wrench.model.evaluations > 0    # the corners touched the board
    finally:
        sim.close()


@pytest.mark.parametrize("engine", ENGINES)
def test_recorded_poses_are_the_old_reads(engine: str, starts: list) -> None:
    """Default mode's recorded poses (run: MuJoCo's steps in one mj_step call, the poses
    read as views or floats) are the old per-step loop's with the old pose reads."""
    require_engine(engine)
    from impactbench.engines.cube_toss import make

    sim = make(engine, {}, starts[0].step_s, 0.0)
    try:
        for start in starts[:2]:
            p, q = sim.run(start)
            sim._reset(start)
            done, want_p, want_q = 0, [], []
            for k in start.record_steps.tolist():
                for _ in range(k - done):
                    sim._advance(1)
                done = k
                pos, quat = _old_state(engine, sim)[:2]
                want_p.append(pos)
                want_q.append(quat)
            assert bits(p, q) == bits(want_p, want_q)
    finally:
        sim.close()


# ------------------------------------------------------------------------------ MJX


def test_mjx_slots_are_the_old_batches(starts: list) -> None:
    """MJX's world slots (2 slots for 5 tosses of different lengths: a finished toss's slot
    takes the next), each toss started from put_data's leaves (no forward first), give each
    toss the poses the old fixed batches gave (sorted by length, 2 at a time, the last
    padded with a copy, each batch's data from a vmapped ``mjx.forward`` of the model's
    forward data at the tosses' states): bit for bit, so that neither the slots nor
    starting without a forward (MJX's forward writes the normalized quaternion back into
    qpos: the start is normalized once on the host to match) changes a pose."""
    require_engine("mjx")
    from impactbench.engines import cube_toss_more as more

    scenario = scenarios.get("cube-toss").build()
    every, _ = scenario.starts()
    # toss 567: its start's quaternion is one whose second normalization changes a bit, and
    # the poses from sample 21 on (default mode) differ where the start is not normalized
    picked = [*every[:3], next(s for s in every if int(s.toss) == 567), every[3]]
    short = [dataclasses.replace(s, record_steps=s.record_steps[:n])
             for s, n in zip(picked, (40, 7, 23, 33, 12), strict=True)]
    sim = more.MjxCube({}, short[0].step_s, 0.0, batch=2)
    got = sim.run_many(short)
    # the old run_many: fixed batches of 2, each to its longest toss
    _, jax, mjx = more._mjx()
    jnp = jax.numpy
    mx = mjx.put_model(sim._model)
    dx0 = jax.jit(mjx.forward)(mx, mjx.put_data(sim._model, sim._data))
    init = jax.jit(jax.vmap(lambda m, d, q, v: mjx.forward(m, d.replace(qpos=q, qvel=v)),
                            in_axes=(None, None, 0, 0)))
    stride = sim._check(short)
    lengths = np.array([int(s.record_steps[-1] // stride) for s in short])
    order = np.argsort(-lengths, kind="stable")
    chunk = more._mjx_chunk(stride, more.MJX_CHUNK_RECORDS)
    want: list = [None] * len(short)
    for first in range(0, len(short), 2):
        group = [int(i) for i in order[first:first + 2]]
        members = group + [group[0]] * (2 - len(group))
        qpos = np.stack([np.concatenate([short[i].p, short[i].q]) for i in members])
        qvel = np.stack([np.concatenate([short[i].v, short[i].w_body]) for i in members])
        dx = init(mx, dx0, jnp.asarray(qpos), jnp.asarray(qvel))
        rows, done = [qpos[:, None, :7]], 0
        while done < int(lengths[group].max()):
            dx, r = chunk(mx, dx)
            rows.append(np.asarray(r))
            done += more.MJX_CHUNK_RECORDS
        rows = np.concatenate(rows, axis=1)
        for j, i in enumerate(group):
            want[i] = more._gather(short[i], rows[j], stride)
    for (p, q), (wp, wq) in zip(got, want, strict=True):
        assert bits(p, q) == bits(wp, wq)
    assert len({len(p) for p, _ in got}) == 5
