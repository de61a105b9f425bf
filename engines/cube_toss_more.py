"""The cube on the board in SAPIEN (PhysX), DART, Newton and MJX; pymunk and Box2D refused.

The same physical set-up as :mod:`impactbench.engines.cube_toss` (a free box, h = 0.0524 m,
0.37 kg, 0.00081 kg·m² about each axis; the board's surface at ``board_z_m``, z up; gravity
9.81 m/s²; a fixed step), the same interface (:class:`~impactbench.engines.cube_toss.CubeEngine`)
and the same key convention: ``board.`` / ``cube.`` + the engine's own name, plus engine-wide
keys; ``default`` mode sets none, ``custom`` mode the caller's. The engines are imported when a
model is built, never at import. ``injected`` mode (the reference model's corner forces,
:mod:`impactbench.cube_tosses.model_modes`): SAPIEN builds no board and zeroes the cube's
damping, DART leaves the board out of the world; MJX and Newton step in compiled batches and
have none.

SAPIEN 3 (PhysX 5, CPU)
    The board is a static PhysX plane (a half-space) at ``board_z_m``, the cube a rigid
    dynamic box. Keys: ``board.`` / ``cube.`` + ``static_friction``, ``dynamic_friction``,
    ``restitution`` (the material; a negative restitution −K makes a compliant, undamped
    contact of stiffness K N/m; PhysX combines a pair's friction and restitution by their
    average); ``contact_offset``, ``rest_offset`` (both shapes, m); ``cube.`` +
    ``linear_damping``, ``angular_damping``, ``solver_position_iterations``,
    ``solver_velocity_iterations``, ``sleep_threshold``; scene: ``bounce_threshold`` (m/s;
    restitution acts only above it), ``enable_tgs``, ``enable_pcm``. Defaults: SAPIEN's
    material (friction 0.3, restitution 0.1), bounce threshold 2 m/s, TGS; read back in
    :meth:`SapienCube.describe`. A fresh scene per toss: PhysX keeps contact caches and sleep
    state across a teleport (see :data:`SapienCube.fresh_scene_per_toss`).
DART 6
    The board is a welded 10 × 10 × 1 m box (its top at ``board_z_m``), the cube a box on a
    free joint. Contacts are rigid (boxed LCP, Dantzig), velocity-level restitution. Keys:
    ``board.`` / ``cube.`` + ``friction_coeff``, ``restitution_coeff`` (DART's
    ``DynamicsAspect``; the pair's friction is the smaller of the two, its restitution their
    product, as DART's ``ContactConstraint``); ``collision_detector`` (fcl, dart, bullet, ode),
    ``split_impulse``. Defaults: friction 1, restitution 0, FCL, no split impulse.
Newton 1.x (warp, CPU device)
    ``SolverSemiImplicit`` (maximal coordinates, semi-implicit Euler) with its penalty contact:
    per contact point normal force ke·x + kd·max(ẋ, 0), regularised Coulomb friction
    min(kf·|v_t|, μ·f_n) (ke, kd, kf, μ averaged over the two shapes). The board is Newton's
    ground plane, the cube a box shape on a free body. Keys: ``board.`` / ``cube.`` + ``ke``
    (N/m), ``kd`` (N·s/m), ``kf`` (N·s/m), ``mu``, ``ka`` (adhesion distance, m). Defaults:
    ``ShapeConfig``'s (ke 2500, kd 100, kf 1000, μ 1, ka 0). float32. **Batched**: every toss is
    a world of one model (:meth:`NewtonCube.run_many`), stepped together; one step is a warp
    CPU graph.
MJX (MuJoCo XLA, jax CPU, float64)
    MuJoCo's physics on the cube on a **plane** (MJX collides box–plane in 4 fixed contact
    slots; box–box would be far more costly), so it is compared with C MuJoCo on the same
    plane model (:class:`MujocoPlaneCube`), not with the box board of
    :class:`~impactbench.engines.cube_toss.MujocoCube`. The two agree to rounding until a
    second corner touches: MJX's ``plane_convex`` keeps only the vertices within 1 mm of the
    deepest one (``support > max(0, support.max() − 1e-3)``, mujoco-mjx 3.17), C MuJoCo's
    box–plane every penetrating vertex, so with a soft contact (the default solref 0.02 s
    lets a corner sink ~7 mm) MJX misses a shallower corner that C MuJoCo has and the
    trajectories part (measured: toss 155, step 57; out of the box the 64 first test tosses'
    errors differ by 0.004 widths at the median, 0.7 at worst). Keys: MuJoCo's (``board.`` /
    ``cube.`` + ``solref``, ``solimp``, ``friction``, ``condim``, ``priority``, ``solmix``;
    ``option.`` + an ``<option>`` attribute). **Batched**: :meth:`MjxCube.run_many` runs every
    toss in ``jax.vmap`` over the initial states, a ``lax.scan`` over the samples of a
    ``fori_loop`` over the substeps, in fixed-length chunks (one compilation per batch size
    and static model structure — MuJoCo's ``opt.cone``: default mode's pyramidal cone
    compiles apart from tuned and native modes' elliptic one, which share theirs; jax's
    persistent cache keeps it across processes). Tosses are sorted by length and run in
    :data:`MJX_BATCH` world slots, a slot taking the next toss when its toss ends
    (``batch=None``: all in one call).
pymunk, Box2D
    :data:`UNSUPPORTED`: two-dimensional engines; a tumbling cube in 3D cannot be expressed.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from impactbench.engines.cube_toss import DAIR_BOX, CubeEngine, MujocoCube, Start, _version
from impactbench.reference.box_contact import GRAVITY_M_S2, Box, quat_matrix
from impactbench.reference.validation import InvalidValue

ENGINES = ("sapien", "dart", "newton", "mjx")

GRAMIAN_MARGIN = 0.5
"""How far inside scipy's orthogonality test (the Gramian R·Rᵀ ``np.isclose`` to I at
``atol=1e-12``, rtol 1e-5) a matrix must be for :func:`quat_from_matrix`'s own arithmetic:
a fraction of each tolerance, so that the few ulps by which our Gramian may differ from
numpy's (BLAS) cannot put a matrix on the other side of it."""


def quat_from_matrix(r: Sequence[Sequence[float]]) -> tuple[float, float, float, float]:
    """The unit quaternion (w, x, y, z) of the rotation matrix ``r`` (3 × 3, nested rows),
    equal bit for bit to ``scipy.spatial.transform.Rotation.from_matrix(r).as_quat()``
    (x, y, z, w) reordered.

    For an orthonormal matrix (well inside scipy's test: :data:`GRAMIAN_MARGIN`) scipy's
    Cython conversion operation for operation in Python floats (scipy 1.17
    ``_rotation_cy._from_matrix_orthogonal``: Shepperd's choice of the largest of the
    diagonal and the trace, then the normalisation sqrt(((a² + b²) + c²) + d²) and a division
    per component); any other matrix goes to scipy itself (it re-orthogonalises by SVD, or
    raises on a non-positive determinant)."""
    (m00, m01, m02), (m10, m11, m12), (m20, m21, m22) = r
    off = 1e-12 * GRAMIAN_MARGIN
    diag = (1e-12 + 1e-5) * GRAMIAN_MARGIN
    if not (abs(m00 * m10 + m01 * m11 + m02 * m12) <= off
            and abs(m00 * m20 + m01 * m21 + m02 * m22) <= off
            and abs(m10 * m20 + m11 * m21 + m12 * m22) <= off
            and abs(m00 * m00 + m01 * m01 + m02 * m02 - 1.0) <= diag
            and abs(m10 * m10 + m11 * m11 + m12 * m12 - 1.0) <= diag
            and abs(m20 * m20 + m21 * m21 + m22 * m22 - 1.0) <= diag
            and m00 * (m11 * m22 - m12 * m21) - m01 * (m10 * m22 - m12 * m20)
            + m02 * (m10 * m21 - m11 * m20) > 0.5):
        from scipy.spatial.transform import Rotation

        x, y, z, w = Rotation.from_matrix(np.asarray(r, dtype=float)).as_quat().tolist()
        return w, x, y, z
    trace = m00 + m11 + m22
    choice, top = 0, m00               # scipy's argmax: the first of equal maxima
    if m11 > top:
        choice, top = 1, m11
    if m22 > top:
        choice, top = 2, m22
    if trace > top:
        choice = 3
    if choice == 0:                    # i, j, k = 0, 1, 2
        a = 1 - trace + 2 * m00
        b = m10 + m01
        c = m20 + m02
        d = m21 - m12
    elif choice == 1:                  # i, j, k = 1, 2, 0
        b = 1 - trace + 2 * m11
        c = m21 + m12
        a = m01 + m10
        d = m02 - m20
    elif choice == 2:                  # i, j, k = 2, 0, 1
        c = 1 - trace + 2 * m22
        a = m02 + m20
        b = m12 + m21
        d = m10 - m01
    else:
        a = m21 - m12
        b = m02 - m20
        c = m10 - m01
        d = 1 + trace
    norm = math.sqrt(a * a + b * b + c * c + d * d)
    return d / norm, a / norm, b / norm, c / norm


# ------------------------------------------------------------------------------ SAPIEN

_SAPIEN_MATERIAL = ("static_friction", "dynamic_friction", "restitution")
_SAPIEN_SHAPE = ("contact_offset", "rest_offset")
_SAPIEN_BODY = ("linear_damping", "angular_damping", "solver_position_iterations",
                "solver_velocity_iterations", "sleep_threshold")
_SAPIEN_SCENE = ("bounce_threshold", "enable_tgs", "enable_pcm")
SAPIEN_PLANE_Q = (math.sqrt(0.5), 0.0, -math.sqrt(0.5), 0.0)
"""A PhysX plane's normal is its local +x: this rotation (−90° about y) turns it to +z."""


def _import_sapien() -> tuple[Any, Any]:
    import warnings

    with warnings.catch_warnings():  # "Failed to find system libvulkan": headless is fine
        warnings.simplefilter("ignore")
        import sapien
        import sapien.physx as physx
    return sapien, physx


class SapienCube(CubeEngine):
    """SAPIEN 3 / PhysX 5 (module doc)."""

    fresh_scene_per_toss = True
    """PhysX keeps per-pair contact caches, friction anchors and the sleep state of a body;
    a teleported body does not clear them, so each toss gets its own scene (0.3 ms)."""

    def __init__(self, params: Mapping[str, Any] = (), step_s: float = 1.0 / 1480.0,
                 board_z_m: float = 0.0, box: Box = DAIR_BOX, law: Any = None) -> None:
        keys = (*(f"{b}.{k}" for b in ("board", "cube") for k in _SAPIEN_MATERIAL),
                *_SAPIEN_SHAPE, *(f"cube.{k}" for k in _SAPIEN_BODY), *_SAPIEN_SCENE)
        super().__init__(dict(params), step_s, board_z_m, "sapien", keys, box, law)

    def _build(self) -> None:
        sapien, px = _import_sapien()
        self._sapien, self._px = sapien, px
        p = self.params
        scene_cfg = px.PhysxSceneConfig()
        for k in _SAPIEN_SCENE:
            if k in p:
                setattr(scene_cfg, k, type(getattr(scene_cfg, k))(p[k]))
        scene_cfg.gravity = np.array([0.0, 0.0, -GRAVITY_M_S2], dtype=np.float32)
        self._scene_cfg = scene_cfg
        default = px.get_default_material()
        self._defaults = {"static_friction": float(default.static_friction),
                          "dynamic_friction": float(default.dynamic_friction),
                          "restitution": float(default.restitution)}
        self._materials = {}
        for body in ("board", "cube"):
            vals = {k: float(p.get(f"{body}.{k}", self._defaults[k])) for k in _SAPIEN_MATERIAL}
            self._materials[body] = vals
        self._scene = None
        self._new_scene()

    def _new_scene(self) -> None:
        sapien, px = self._sapien, self._px
        previous = px.get_scene_config()
        px.set_scene_config(self._scene_cfg)
        try:
            scene = sapien.Scene([px.PhysxCpuSystem()])
        finally:
            px.set_scene_config(previous)
        scene.set_timestep(self.step_s)

        def material(body: str) -> Any:
            m = self._materials[body]
            return px.PhysxMaterial(m["static_friction"], m["dynamic_friction"],
                                    m["restitution"])

        def shape(s: Any) -> Any:
            if "contact_offset" in self.params:
                s.set_contact_offset(float(self.params["contact_offset"]))
            if "rest_offset" in self.params:
                s.set_rest_offset(float(self.params["rest_offset"]))
            return s

        if self.law is None:
            board = sapien.Entity()
            static = px.PhysxRigidStaticComponent()
            static.attach(shape(px.PhysxCollisionShapePlane(material("board"))))
            board.add_component(static)
            board.set_pose(sapien.Pose([0.0, 0.0, self.board_z_m], list(SAPIEN_PLANE_Q)))
            scene.add_entity(board)
        else:  # injected: no board; the model's forces come in per step
            self._contact_off = ("no board in the scene; the cube's linear and angular "
                                 "damping 0 (PhysX's default angular damping 0.05 /s)")

        cube = sapien.Entity()
        body = px.PhysxRigidDynamicComponent()
        body.attach(shape(px.PhysxCollisionShapeBox(
            np.full(3, self.box.half_width_m, dtype=np.float32), material("cube"))))
        cube.add_component(body)
        cube.set_pose(sapien.Pose([0.0, 0.0, 1.0]))
        scene.add_entity(cube)
        body.set_mass(self.box.mass_kg)
        body.set_inertia(np.full(3, self.box.inertia_kg_m2, dtype=np.float32))
        body.set_cmass_local_pose(sapien.Pose())
        for k in _SAPIEN_BODY:
            if f"cube.{k}" in self.params:
                v = self.params[f"cube.{k}"]
                getattr(body, f"set_{k}")(int(v) if "iterations" in k else float(v))
        if self.law is not None:
            body.set_linear_damping(0.0)
            body.set_angular_damping(0.0)
        self._scene, self._cube_entity, self._body = scene, cube, body

    def _reset(self, start: Start) -> None:
        if self.fresh_scene_per_toss:
            self._new_scene()
        sapien = self._sapien
        self._cube_entity.set_pose(sapien.Pose(start.p.astype(np.float32),
                                               start.q.astype(np.float32)))
        self._body.set_linear_velocity(start.v.astype(np.float32))
        self._body.set_angular_velocity(start.w_world.astype(np.float32))  # world frame
        self._body.wake_up()

    def _advance(self, steps: int) -> None:
        step = self._scene.step
        for _ in range(steps):
            step()

    def _pose(self) -> tuple[Any, Any]:
        pose = self._body.entity_pose
        return pose.p, pose.q   # float32, widened exactly where the caller stores them

    def _state_values(self) -> tuple[float, ...]:
        b = self._body
        pose = b.entity_pose
        return (*pose.p.tolist(), *pose.q.tolist(), *b.linear_velocity.tolist(),
                *b.angular_velocity.tolist())   # world frame

    def _push_values(self, wrench: tuple[float, ...]) -> None:
        # a force for one step at the centre of mass (PhysX clears it after the step)
        w = np.array(wrench, dtype=np.float32)
        self._body.add_force_torque(w[:3], w[3:])
        self._scene.step()

    def describe(self) -> dict[str, Any]:
        sapien, px = self._sapien, self._px
        b, c = self._materials["board"], self._materials["cube"]
        cfg, body = self._scene_cfg, self._body
        (shape,) = body.collision_shapes
        eff = {"friction": 0.5 * (b["dynamic_friction"] + c["dynamic_friction"]),
               "static_friction": 0.5 * (b["static_friction"] + c["static_friction"]),
               "restitution": 0.5 * (b["restitution"] + c["restitution"]),
               "friction_rule": "average of the two materials (PhysX eAVERAGE combine mode); "
                                "restitution likewise",
               "contact": ("compliant, undamped: stiffness −restitution (N/m)"
                           if b["restitution"] + c["restitution"] < 0 else
                           f"rigid, restitution only above the bounce threshold "
                           f"{float(cfg.bounce_threshold):g} m/s"),
               "bounce_threshold_m_s": float(cfg.bounce_threshold),
               "solver": "TGS" if cfg.enable_tgs else "PGS",
               "contact_offset_m": float(shape.contact_offset),
               "rest_offset_m": float(shape.rest_offset),
               "linear_damping": float(body.linear_damping),
               "angular_damping": float(body.angular_damping),
               "solver_iterations": [int(body.solver_position_iterations),
                                     int(body.solver_velocity_iterations)]}
        return {"engine": "sapien",
                "version": f"{sapien.__version__} (PhysX {px.version()})",
                "params": dict(self.params), "effective": eff,
                "materials": {"board": b, "cube": c, "engine_default": self._defaults},
                "cube_inertia_kg_m2": float(np.asarray(body.inertia)[0]),
                "board": f"static plane (half-space), surface at z = {self.board_z_m:g} m",
                "step_s": self.step_s}


# ------------------------------------------------------------------------------ DART

_DART_SHAPE_KEYS = ("friction_coeff", "restitution_coeff")
DART_DETECTORS = {"fcl": "FCL", "dart": "DART", "bullet": "Bullet", "ode": "Ode"}
DART_BOARD_HALF = (5.0, 5.0, 0.5)


class DartCube(CubeEngine):
    """DART 6 (module doc)."""

    def __init__(self, params: Mapping[str, Any] = (), step_s: float = 1.0 / 1480.0,
                 board_z_m: float = 0.0, box: Box = DAIR_BOX, law: Any = None) -> None:
        keys = (*(f"{b}.{k}" for b in ("board", "cube") for k in _DART_SHAPE_KEYS),
                "collision_detector", "split_impulse")
        super().__init__(dict(params), step_s, board_z_m, "dart", keys, box, law)

    def _build(self) -> None:
        import dartpy as dart

        self._dart = dart
        p = self.params
        world = dart.simulation.World()
        world.setGravity([0.0, 0.0, -GRAVITY_M_S2])
        world.setTimeStep(self.step_s)
        solver = world.getConstraintSolver()
        if "collision_detector" in p:
            name = DART_DETECTORS.get(str(p["collision_detector"]))
            if name is None:
                raise InvalidValue(f"param collision_detector = {p['collision_detector']!r}: "
                                 f"must be one of {', '.join(DART_DETECTORS)}")
            solver.setCollisionDetector(getattr(dart.collision, f"{name}CollisionDetector")())
        if "split_impulse" in p:
            solver.setSplitImpulseEnabled(bool(p["split_impulse"]))

        def aspects(node: Any, body: str) -> Any:
            node.createCollisionAspect()
            aspect = node.createDynamicsAspect()
            if f"{body}.friction_coeff" in p:
                aspect.setFrictionCoeff(float(p[f"{body}.friction_coeff"]))
            if f"{body}.restitution_coeff" in p:
                aspect.setRestitutionCoeff(float(p[f"{body}.restitution_coeff"]))
            return aspect

        board = dart.dynamics.Skeleton("board")
        joint, body = board.createWeldJointAndBodyNodePair()
        tf = dart.math.Isometry3()
        tf.set_translation([0.0, 0.0, self.board_z_m - DART_BOARD_HALF[2]])
        joint.setTransformFromParentBodyNode(tf)
        self._board_aspect = aspects(body.createShapeNode(
            dart.dynamics.BoxShape([2.0 * v for v in DART_BOARD_HALF])), "board")
        if self.law is None:
            world.addSkeleton(board)
        else:  # injected: the board is not in the world; the model's forces come in per step
            self._contact_off = "the board is not in the world (no collision)"

        cube = dart.dynamics.Skeleton("cube")
        self._joint, self._node = cube.createFreeJointAndBodyNodePair()
        self._cube_aspect = aspects(self._node.createShapeNode(
            dart.dynamics.BoxShape([2.0 * self.box.half_width_m] * 3)), "cube")
        inertia = dart.dynamics.Inertia()
        inertia.setMass(self.box.mass_kg)
        inertia.setMoment(np.eye(3) * self.box.inertia_kg_m2)
        self._node.setInertia(inertia)
        world.addSkeleton(cube)
        self._world, self._cube = world, cube
        self._origin = np.zeros(3)

    def _reset(self, start: Start) -> None:

        dart = self._dart
        self._world.reset()
        tf = dart.math.Isometry3()
        tf.set_translation(start.p.tolist())
        tf.set_rotation(quat_matrix(start.q))
        self._cube.setPositions(dart.dynamics.FreeJoint.convertToPositions(tf))
        self._cube.setVelocities(np.zeros(6))
        world = dart.dynamics.Frame.World()
        self._joint.setLinearVelocity(start.v, world, world)
        self._joint.setAngularVelocity(start.w_world, world, world)

    def _advance(self, steps: int) -> None:
        step = self._world.step
        for _ in range(steps):
            step()

    def _pose(self) -> tuple[Any, Any]:
        tf = self._node.getWorldTransform()
        return tf.translation(), quat_from_matrix(tf.rotation().tolist())

    def _state_values(self) -> tuple[float, ...]:
        n = self._node
        tf = n.getWorldTransform()
        return (*tf.translation().tolist(), *quat_from_matrix(tf.rotation().tolist()),
                *n.getLinearVelocity().tolist(), *n.getAngularVelocity().tolist())  # world

    def _push_values(self, wrench: tuple[float, ...]) -> None:
        n = self._node
        n.setExtForce(wrench[:3], self._origin, False, True)   # world force at the origin
        n.setExtTorque(wrench[3:], False)                       # world frame
        self._world.step()

    def describe(self) -> dict[str, Any]:
        b, c = self._board_aspect, self._cube_aspect
        mu = {"board": float(b.getFrictionCoeff()), "cube": float(c.getFrictionCoeff())}
        e = {"board": float(b.getRestitutionCoeff()), "cube": float(c.getRestitutionCoeff())}
        solver = self._world.getConstraintSolver()
        return {"engine": "dart", "version": _version("dartpy"), "params": dict(self.params),
                "effective": {"friction": min(mu.values()),
                              "friction_rule": f"the smaller of board {mu['board']:g} and "
                                               f"cube {mu['cube']:g} (DART ContactConstraint)",
                              "restitution": e["board"] * e["cube"],
                              "restitution_rule": f"product of board {e['board']:g} and cube "
                                                  f"{e['cube']:g}",
                              "contact": "rigid (boxed LCP, one impulse per step)",
                              "collision_detector": str(solver.getCollisionDetector()
                                                        .getType()),
                              "split_impulse": bool(solver.isSplitImpulseEnabled())},
                "cube_inertia_kg_m2": self.box.inertia_kg_m2,
                "board": f"welded box {2 * DART_BOARD_HALF[0]:g} × {2 * DART_BOARD_HALF[1]:g}"
                         f" × {2 * DART_BOARD_HALF[2]:g} m, top at z = {self.board_z_m:g} m",
                "step_s": self.step_s}


# ------------------------------------------------------------------------------ batched


class BatchedCube(CubeEngine):
    """An engine that replays many tosses in one call: :meth:`run_many` is the engine's
    path; :meth:`run` is ``run_many([start])[0]``."""

    batched = True

    def run(self, start: Start) -> tuple[np.ndarray, np.ndarray]:
        (out,) = self.run_many([start])
        if isinstance(out, Exception):
            raise out
        return out

    def run_many(self, starts: Sequence[Start]
                 ) -> list[tuple[np.ndarray, np.ndarray] | Exception]:
        raise NotImplementedError

    def _check(self, starts: Sequence[Start]) -> int:
        """The record stride: the gcd of every start's record steps (10 under DAIR's
        protocol), so that a recorded sample falls every ``stride`` steps."""
        for s in starts:
            if not math.isclose(s.step_s, self.step_s, rel_tol=1e-9):
                raise ValueError(f"toss {s.toss}: step {s.step_s!r} s, engine built for "
                                 f"{self.step_s!r} s")
        steps = np.concatenate([s.record_steps for s in starts])
        return max(1, int(np.gcd.reduce(steps[steps > 0])) if np.any(steps > 0) else 1)


def _gather(start: Start, rows: np.ndarray, stride: int) -> tuple[np.ndarray, np.ndarray]:
    """The records of ``start`` from rows of (p xyz, q wxyz) recorded every ``stride`` steps
    (row 0 the initial state)."""
    idx = start.record_steps // stride
    return rows[idx, :3].astype(float), rows[idx, 3:7].astype(float)


# ------------------------------------------------------------------------------ Newton

_NEWTON_SHAPE_KEYS = ("ke", "kd", "kf", "mu", "ka")
NEWTON_CONTACTS_PER_WORLD = 8


def _newton() -> tuple[Any, Any]:
    from impactbench.engines.newton_adapter import _newton as load

    return load()


class NewtonCube(BatchedCube):
    """Newton with ``SolverSemiImplicit`` (module doc); every toss a world of one model."""

    def __init__(self, params: Mapping[str, Any] = (), step_s: float = 1.0 / 1480.0,
                 board_z_m: float = 0.0, box: Box = DAIR_BOX) -> None:
        keys = tuple(f"{b}.{k}" for b in ("board", "cube") for k in _NEWTON_SHAPE_KEYS)
        super().__init__(dict(params), step_s, board_z_m, "newton", keys, box)

    def _build(self) -> None:
        wp, newton = _newton()
        self._wp, self._newton = wp, newton
        defaults = newton.ModelBuilder.ShapeConfig()
        self._defaults = {k: float(getattr(defaults, k)) for k in _NEWTON_SHAPE_KEYS}
        self._shape = {b: {k: float(self.params.get(f"{b}.{k}", self._defaults[k]))
                           for k in _NEWTON_SHAPE_KEYS} for b in ("board", "cube")}

    def _config(self, body: str, **extra: Any) -> Any:
        cfg = self._newton.ModelBuilder.ShapeConfig(**extra)
        for k, v in self._shape[body].items():
            setattr(cfg, k, v)
        return cfg

    def _model(self, worlds: int) -> Any:
        wp, newton = self._wp, self._newton
        cube = newton.ModelBuilder(gravity=(0.0, 0.0, -GRAVITY_M_S2))
        i = self.box.inertia_kg_m2
        body = cube.add_body(xform=wp.transform((0.0, 0.0, 1.0), wp.quat_identity()),
                             mass=self.box.mass_kg, inertia=wp.mat33(i, 0, 0, 0, i, 0, 0, 0, i),
                             lock_inertia=True)
        h = self.box.half_width_m
        cube.add_shape_box(body, hx=h, hy=h, hz=h,
                           cfg=self._config("cube", density=0.0))
        scene = newton.ModelBuilder(gravity=(0.0, 0.0, -GRAVITY_M_S2))
        scene.replicate(cube, worlds)
        scene.add_ground_plane(height=self.board_z_m, cfg=self._config("board"))
        return scene.finalize(device="cpu")

    def run_many(self, starts: Sequence[Start]
                 ) -> list[tuple[np.ndarray, np.ndarray] | Exception]:
        if not starts:
            return []
        wp, newton = self._wp, self._newton
        stride = self._check(starts)
        n = len(starts)
        model = self._model(n)
        states = (model.state(), model.state())
        control = model.control()
        q0 = np.empty((n, 7), dtype=np.float32)
        qd0 = np.empty((n, 6), dtype=np.float32)
        for k, s in enumerate(starts):
            w, x, y, z = s.q / np.linalg.norm(s.q)
            q0[k] = (*s.p, x, y, z, w)
            qd0[k] = (*s.v, *s.w_world)  # body_qd: linear then angular velocity, world frame
        states[0].body_q.assign(q0)
        states[0].body_qd.assign(qd0)
        solver = newton.solvers.SolverSemiImplicit(model)
        pipeline = newton.CollisionPipeline(
            model, rigid_contact_max=NEWTON_CONTACTS_PER_WORLD * n)
        contacts = pipeline.contacts()
        dt = self.step_s

        def steps(a: int) -> None:
            for j in range(stride):
                s0, s1 = states[(a + j) & 1], states[(a + j + 1) & 1]
                s0.clear_forces()
                pipeline.collide(s0, contacts)
                solver.step(s0, s1, control, contacts, dt)

        graphs = []
        for a in range(2 if stride & 1 else 1):
            with wp.ScopedCapture(device="cpu") as cap:
                steps(a)
            graphs.append(cap.graph)
        # capturing records the launches without running them: the state is still q0
        records = int(max(s.record_steps[-1] for s in starts) // stride) + 1
        rows = np.empty((records, n, 7), dtype=np.float32)
        views = tuple(s.body_q.numpy() for s in states)
        parity = 0
        rows[0] = views[0]
        for r in range(1, records):
            wp.capture_launch(graphs[parity if stride & 1 else 0])
            parity ^= stride & 1
            rows[r] = views[parity]
        out: list[tuple[np.ndarray, np.ndarray] | Exception] = []
        for k, s in enumerate(starts):
            block = rows[:, k, :].astype(float)
            pose = np.column_stack([block[:, :3], block[:, 6], block[:, 3:6]])  # xyzw → wxyz
            p, q = _gather(s, pose, stride)
            if not (np.all(np.isfinite(p)) and np.all(np.isfinite(q))):
                out.append(FloatingPointError("non-finite state"))
            else:
                out.append((p, q))
        return out

    def describe(self) -> dict[str, Any]:
        b, c = self._shape["board"], self._shape["cube"]
        eff = {k: 0.5 * (b[k] + c[k]) for k in _NEWTON_SHAPE_KEYS}
        return {"engine": "newton",
                "version": f"{_version('newton')} (warp {_version('warp-lang')})",
                "params": dict(self.params),
                "effective": {"contact_stiffness_n_per_m": eff["ke"],
                              "contact_damping_n_s_per_m": eff["kd"],
                              "friction_damping_n_s_per_m": eff["kf"],
                              "friction": eff["mu"], "adhesion_distance_m": eff["ka"],
                              "rule": "each value the average of board and cube "
                                      "(SolverSemiImplicit's contact kernel); per contact "
                                      "point f_n = ke·x + kd·max(ẋ, 0), f_t = "
                                      "min(kf·|v_t|, μ·f_n)",
                              "solver": "SolverSemiImplicit", "precision": "float32"},
                "shapes": {"board": b, "cube": c, "engine_default": self._defaults},
                "cube_inertia_kg_m2": self.box.inertia_kg_m2,
                "board": f"ground plane (half-space) at z = {self.board_z_m:g} m",
                "step_s": self.step_s, "batched": "one world per toss, one model"}


# ------------------------------------------------------------------------------ MuJoCo / MJX


class MujocoPlaneCube(MujocoCube):
    """C MuJoCo with the board as a plane geom (MJX's model), for comparing the two on one
    model; keys as :class:`~impactbench.engines.cube_toss.MujocoCube`'s."""

    def xml(self) -> str:
        xml = super().xml()
        head, rest = xml.split('<geom name="board" type="box" size="', 1)
        size, tail = rest.split('"', 1)
        bz = size.split()[2]
        return (f'{head}<geom name="board" type="plane" size="{size.split()[0]} '
                f'{size.split()[1]} 0.1" pos="0 0 {bz}"{tail}')

    def describe(self) -> dict[str, Any]:
        out = super().describe()
        out["board"] = f"plane geom at z = {self.board_z_m:g} m"
        return out


MJX_BATCH = 32
"""World slots of :meth:`MjxCube.run_many`: the tosses stepped together in one vmapped call.
Each slot replays one toss after another (the longest first), a finished toss's slot taking
the next at a chunk's end, so that the long tail (5 of the 89 test tosses need 217–373
samples, the rest 74–113) does not keep every world stepping for nothing. A step's cost grows
less than in proportion to its worlds (the vmapped constraint solver iterates as long as its
slowest world), and beyond ~40 worlds more than in proportion. Measured on 2 CPU cores (the
89 test tosses, compiled, medians of 3 alternating rounds): default mode 4.4 s in 32 slots,
5.2 s in 24, 4.9 s in 40, 7.3 s in the former two padded batches of 64, 17 s in one call of
89; native mode 4.4, 4.7, 4.8 and 7.8 s."""
MJX_CHUNK_RECORDS = 16
"""Recorded samples per compiled chunk (a scan over samples of ``stride`` substeps each): a
toss's slot is freed at the first chunk end past its last sample."""


def _mjx() -> tuple[Any, Any, Any]:
    from impactbench.engines.mjx_adapter import _mjx as load

    return load()


_MJX_CHUNKS: dict[tuple[int, int], Any] = {}


def _mjx_chunk(stride: int, records: int) -> Any:
    """``chunk(mx, dx) → (dx, rows)`` for a batch of data ``dx`` (vmapped): ``records``
    samples of ``stride`` steps, each row the pose (qpos[:7]) after the sample's steps. One
    jitted function per (stride, records) in a process, so that models of equal static
    structure (the same ``opt.cone``, …) share its compilation."""
    key = (stride, records)
    if key not in _MJX_CHUNKS:
        _, jax, mjx = _mjx()

        def one(mx: Any, dx: Any) -> Any:
            def sample(d: Any, _: Any) -> Any:
                d = jax.lax.fori_loop(0, stride, lambda _, x: mjx.step(mx, x), d)
                return d, d.qpos[:7]

            return jax.lax.scan(sample, dx, None, length=records)

        _MJX_CHUNKS[key] = jax.jit(jax.vmap(one, in_axes=(None, 0)))
    return _MJX_CHUNKS[key]


@functools.lru_cache(maxsize=8)
def _mjx_loop(mtree: Any, dtree: Any, stride: int, records: int) -> Any:
    """:func:`_mjx_chunk`'s chunk on the flat leaves of the model and the data (trees
    ``mtree``, ``dtree``), ``loop(m_leaves, d_leaves) → (d_leaves, rows)``, its traced
    program kept on disk (MJX's kept loops, :class:`impactbench.engines.mjx_adapter._Loop`):
    a process loads it (~0.45 s with XLA's cached compile) instead of tracing ``mjx.step``
    again. The model's values are arguments, not constants of the program: the modes whose
    models differ only in values (native's and tuned's elliptic cones) share one program and
    one XLA compile. Bit for bit the plain chunk's (tested)."""
    from impactbench.engines.mjx_adapter import _Loop, _tree_key

    _, jax, mjx = _mjx()
    tree = jax.tree_util

    def one(m_leaves: Any, d_leaves: Any) -> Any:
        mx = tree.tree_unflatten(mtree, m_leaves)

        def sample(d: Any, _: Any) -> Any:
            d = jax.lax.fori_loop(0, stride, lambda _, x: mjx.step(mx, x), d)
            return d, d.qpos[:7]

        d, rows = jax.lax.scan(sample, tree.tree_unflatten(dtree, d_leaves), None,
                               length=records)
        return tree.tree_leaves(d), rows

    key = ("cube_toss_more", _source_hash(), _tree_key(mtree), _tree_key(dtree), stride,
           records)
    return _Loop(jax.jit(jax.vmap(one, in_axes=(None, 0))), None if None in key else key)


@functools.lru_cache(maxsize=1)
def _source_hash() -> str:
    """This module's source (what :func:`_mjx_loop`'s kept programs depend on besides MJX's
    own key)."""
    import hashlib

    return hashlib.sha256(Path(__file__).read_bytes()).hexdigest()


@functools.lru_cache(maxsize=1)
def _normalize() -> Any:
    from mujoco.mjx._src import math as mjx_math

    _, jax, _ = _mjx()
    return jax.jit(jax.vmap(mjx_math.normalize))


def _mjx_normalize(quats: np.ndarray) -> np.ndarray:
    """The quaternions (rows w x y z) normalized as MJX's kinematics normalizes a free joint's
    (``math.normalize``, written back into qpos by every forward): a toss's start as it was
    after the ``mjx.forward`` that once came before its first step, so that the first step's
    own forward normalizes it a second time, as then (a second normalization changes the
    last bit of 10 of the 89 test tosses' starts: the same poses bit for bit, tested)."""
    return np.asarray(_normalize()(quats))


class MjxCube(BatchedCube, MujocoPlaneCube):
    """MJX on the plane model (module doc)."""

    batch: int | None = MJX_BATCH

    def __init__(self, params: Mapping[str, Any] = (), step_s: float = 1.0 / 1480.0,
                 board_z_m: float = 0.0, batch: int | None = MJX_BATCH,
                 box: Box = DAIR_BOX) -> None:
        self.batch = batch
        MujocoPlaneCube.__init__(self, params, step_s, board_z_m, box)
        self.name = "mjx"

    def _build(self) -> None:
        super()._build()
        _, jax, mjx = _mjx()
        self._jax = jax
        try:
            self._mx = mjx.put_model(self._model)
        except NotImplementedError as exc:
            raise ValueError(f"mjx cube parameters {dict(self.params)!r}: {exc}") from None
        from impactbench.engines.mjx_adapter import WIDENED

        # the data every toss starts from: put_data's of a fresh MjData, its qpos and qvel
        # set per toss (:meth:`_initial`), the leaves of WIDENED 64-bit (a step returns them
        # so). No mjx.forward first: a step's own forward recomputes every derived field from
        # the state before it reads it (the same poses bit for bit as a forward first,
        # tested), and a separate forward and its vmapped twin would each be traced in every
        # process and compiled on every machine (~2 s and ~12 s each model structure).
        paths, self._dtree = jax.tree_util.tree_flatten_with_path(
            mjx.put_data(self._model, self._mj.MjData(self._model)))
        names = [jax.tree_util.keystr(p) for p, _ in paths]
        self._d_leaves = [np.array(leaf) for _, leaf in paths]
        for name in WIDENED:
            if name in names:
                i = names.index(name)
                self._d_leaves[i] = self._d_leaves[i].astype(np.int64)
        self._qpos, self._qvel = names.index(".qpos"), names.index(".qvel")

    def _initial(self, starts: Sequence[Start]) -> list[np.ndarray]:
        """The data leaves of ``starts``' tosses, one row each (:meth:`_build`): qpos the
        toss's centre and its quaternion normalized as MJX's forward normalizes it
        (:func:`_mjx_normalize`), qvel its velocity and body-frame angular velocity."""
        n = len(starts)
        out = [np.repeat(leaf[None], n, axis=0) for leaf in self._d_leaves]
        out[self._qpos] = np.concatenate(
            [np.stack([s.p for s in starts]), _mjx_normalize(np.stack([s.q for s in starts]))],
            axis=1)
        out[self._qvel] = np.stack([np.concatenate([s.v, s.w_body]) for s in starts])
        return out

    def run_many(self, starts: Sequence[Start]
                 ) -> list[tuple[np.ndarray, np.ndarray] | Exception]:
        """Every toss of ``starts`` in :attr:`batch` world slots (module doc): each toss's
        initial data (:meth:`_initial`), then chunks of
        :data:`MJX_CHUNK_RECORDS` samples over all slots; between chunks a slot whose toss
        has all its samples takes the next toss's initial data (copied, every field). A
        world's floats depend on its own data only (vmap; checked bit for bit against
        separate batches by the tests), so each toss replays as it would alone."""
        if not starts:
            return []
        stride = self._check(starts)
        jax, jnp = self._jax, self._jax.numpy
        n = len(starts)
        need = [int(s.record_steps[-1] // stride) for s in starts]
        order = [int(i) for i in np.argsort(-np.array(need), kind="stable")]
        size = n if self.batch is None else min(self.batch, n)
        rows: dict[int, list[np.ndarray]] = {
            i: [np.concatenate([starts[i].p, starts[i].q])[None, :7]] for i in range(n)}
        got = dict.fromkeys(range(n), 0)
        slots: list[int | None] = list(order[:size])
        queue = order[size:][::-1]                 # popped from the end: longest first
        carry = self._initial([starts[i] for i in slots])
        m_leaves, mtree = jax.tree_util.tree_flatten(self._mx)
        chunk = _mjx_loop(mtree, self._dtree, stride, MJX_CHUNK_RECORDS)
        while any(i is not None for i in slots):
            leaves, r = chunk(m_leaves, [jnp.array(a) for a in carry])
            r = np.asarray(r)
            carry = [np.array(leaf) for leaf in leaves]
            for k, i in enumerate(slots):
                if i is None:
                    continue
                rows[i].append(r[k])
                got[i] += MJX_CHUNK_RECORDS
                if got[i] < need[i]:
                    continue
                slots[k] = None
                if queue:                          # the next toss takes the slot
                    nxt = queue.pop()
                    for a, b in zip(carry, self._initial([starts[nxt]]), strict=True):
                        a[k] = b[0]
                    slots[k] = nxt
        out: list[Any] = []
        for i, s in enumerate(starts):
            p, q = _gather(s, np.concatenate(rows[i], axis=0), stride)
            out.append((p, q) if np.all(np.isfinite(p)) and np.all(np.isfinite(q))
                       else FloatingPointError("non-finite state"))
        return out

    def describe(self) -> dict[str, Any]:
        out = super().describe()
        out["engine"] = "mjx"
        out["version"] = (f"{_version('mujoco-mjx')} (mujoco {_version('mujoco')}, "
                          f"jax {_version('jax')})")
        out["batched"] = (f"jax.vmap over tosses in {self.batch or 'all'} world slots (a "
                          "slot takes the next toss when its toss ends), lax.scan chunks of "
                          f"{MJX_CHUNK_RECORDS} samples")
        return out


CLASSES: dict[str, type[CubeEngine]] = {"sapien": SapienCube, "dart": DartCube,
                                        "newton": NewtonCube, "mjx": MjxCube}

__all__ = ["CLASSES", "ENGINES", "DartCube", "MjxCube", "MujocoPlaneCube",
           "NewtonCube", "SapienCube"]
