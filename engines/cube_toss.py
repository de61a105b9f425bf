"""The cube on the board in PyBullet, MuJoCo and Drake, built once and reused across tosses.

Each engine builds the same physical set-up: a free box (half width h = 0.0524 m, mass
0.37 kg, moment of inertia 0.00081 kg·m² about each axis unless a parameter set says
otherwise), the board's surface at ``board_z_m`` (z up), gravity 9.81 m/s² along −z, a fixed
step. :meth:`CubeEngine.run` sets a toss's initial state and records the pose at the protocol's
sample steps. One instance serves every toss: a reset between tosses gives bit-identical
results to a fresh instance (ENGINES.md "Friction and boxes"; re-checked by the tests).

Engine parameters are the engine's own names, prefixed by the body they are set on
(``board.`` or ``cube.``), plus a few engine-wide keys; ``default`` mode sets none of them
(what a user gets out of the box), ``custom`` mode sets a named set of :data:`PARAM_SETS`
and/or the caller's keys. DAIR's published sets (``dair2022``) are applied as their code did
(DAIRLab/dairlib, branch ``contact_model_verification``): on the board, the cube keeping the
engine's defaults. Each engine reports the *effective* pair values and the rule that made them
(:meth:`CubeEngine.describe`): Bullet multiplies the two lateral frictions (an unset body has
0.5), Drake combines 2ab/(a + b) (the URDF parser gives the cube 1.0), MuJoCo takes the larger.
``native`` mode is custom mode with the reference model's contact mapped into these keys
(:mod:`impactbench.cube_tosses.model_modes`); ``injected`` mode builds the engine with
``law`` (:func:`make`): the box–board contact off and the model's corner forces applied as
an external force and torque at every step (:meth:`CubeEngine._advance_injected`).

PyBullet
    The board is a fixed 5 × 5 × 1 m box (DAIR's ``plane.urdf``), the cube a box multibody.
    Keys: ``board.`` / ``cube.`` + ``lateralFriction``, ``contactStiffness``,
    ``contactDamping`` (N/m, N·s/m: Bullet needs both; pair stiffness in series, damping summed,
    an unset body counting 1e30 N/m and 0.1 N·s/m), ``restitution``, ``rollingFriction``,
    ``spinningFriction``; ``cube.linearDamping``, ``cube.angularDamping`` (1/s; Bullet's
    default 0.04); ``cube.inertia`` (kg·m² about each axis, or ``"collision"``: Bullet's
    own value from the collision box, 6.77e-4 kg·m², which is what DAIR's URDF cube got since
    they loaded it without ``URDF_USE_INERTIA_FROM_FILE``); ``numSolverIterations``.
MuJoCo
    The board is DAIR's 10 × 10 × 0.4 m box geom (its top at ``board_z_m``), the cube a box
    geom on a free joint with an explicit inertia. Keys: ``board.`` / ``cube.`` + ``solref``,
    ``solimp``, ``friction``, ``condim``, ``priority``, ``solmix``; ``option.`` + any attribute of
    ``<option>`` (``cone``, ``integrator``, ``impratio``, ``noslip_iterations``).
    Pair rules (geoms of equal priority): friction the larger, solref the solmix-weighted mean
    when both are positive (standard), else the element-wise minimum (so a direct
    ``solref="-k -b"`` on the board wins over the cube's default 0.02 1).
Drake
    A discrete ``MultibodyPlant`` (``MultibodyPlantConfig(time_step=step)``) with the cube from
    a URDF string (as DAIR's, so the parser gives it friction 1.0 and SceneGraph its other
    defaults) and a ``HalfSpace`` at ``board_z_m``. Keys: ``board.`` / ``cube.`` +
    ``point_contact_stiffness``, ``hunt_crossley_dissipation``, ``mu`` (static = dynamic),
    ``relaxation_time``; ``discrete_contact_approximation`` (tamsi, sap, similar, lagged; the
    plant's default is lagged), ``contact_model`` (point, hydroelastic_with_fallback, …),
    ``stiction_tolerance`` (m/s, the plant's friction regularisation; used by TAMSI).
    Pair rules: stiffness in series k₁k₂/(k₁+k₂), dissipation (k₂d₁ + k₁d₂)/(k₁+k₂), friction
    2μ₁μ₂/(μ₁+μ₂); SAP ignores the dissipation and uses the relaxation time (Drake's default
    0.1 s); tamsi, similar and lagged use the Hunt–Crossley dissipation.
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from importlib import metadata
from typing import Any

import numpy as np
from impactbench.reference.box_contact import GRAVITY_M_S2, Box, quat_matrix
from impactbench.reference.record import ImpactRecord, Status
from impactbench.reference.validation import InvalidValue

DAIR_BOX = Box()
Start = Any
"""A toss's replay start (:class:`impactbench.cube_tosses.protocol.Start`: ``toss``, ``p``,
``q`` (w, x, y, z), ``v``, ``w_world``, ``step_s``, ``record_steps``), duck-typed: the scenario
prepares it from the measurement."""

ENGINES = ("pybullet", "mujoco", "drake", "sapien", "dart", "newton", "mjx")
"""The engines the tosses replay on; the last four live in
:mod:`impactbench.engines.cube_toss_more` (imported when one is built)."""

# DAIR's fitted values (learned_parameters/cube/*.json of the branch above), full precision.
_DAIR_BULLET = {"stiffness": 1783.7652890360182, "damping": 27.221707506471567,
                "mu_tangent": 0.3580420664522583}     # bullet_2022_02_22_00_36_10
_DAIR_MUJOCO = {"stiffness": 3294.162195453933, "damping": 45.1052410182306,
                "mu_tangent": 0.2180675752744882}     # mujoco_2022_02_23_15_29_10
_DAIR_DRAKE = {"mu": 0.09696370810340711, "stiffness": 10841.170522627219,
               "dissipation": 0.3999581614549148}     # drake_2022_02_21_15_19_10


def _mujoco_dair(scale: float) -> dict[str, Any]:
    mu = _DAIR_MUJOCO["mu_tangent"]
    return {"board.solref": (-scale * _DAIR_MUJOCO["stiffness"],
                             -scale * _DAIR_MUJOCO["damping"]),
            "board.friction": (mu, 0.001, 0.001), "cube.friction": (mu, 0.001, 0.001)}


PARAM_SETS: dict[str, dict[str, dict[str, Any]]] = {
    "pybullet": {
        "dair2022": {"board.lateralFriction": _DAIR_BULLET["mu_tangent"],
                     "board.contactStiffness": _DAIR_BULLET["stiffness"],
                     "board.contactDamping": _DAIR_BULLET["damping"],
                     "cube.inertia": "collision"},
    },
    "mujoco": {
        "dair2022": _mujoco_dair(1.0),
        # DAIR's evaluation script multiplied the fitted k and b by 3 before replaying
        "dair2022x3": _mujoco_dair(3.0),
    },
    "drake": {
        "dair2022": {"board.point_contact_stiffness": _DAIR_DRAKE["stiffness"],
                     "board.hunt_crossley_dissipation": _DAIR_DRAKE["dissipation"],
                     "board.mu": _DAIR_DRAKE["mu"],
                     "contact_model": "point",
                     # the only discrete solver of the Drake DAIR used (February 2022)
                     "discrete_contact_approximation": "tamsi"},
    },
}
"""engine → parameter-set name → engine parameters (``custom`` mode's ``param_set``)."""

@dataclass
class CubeEngine:
    """One engine's cube-on-board model (built by :func:`make`). Subclasses implement
    :meth:`_build`, :meth:`_reset` and :meth:`_advance`."""

    params: Mapping[str, Any] = field(default_factory=dict)
    step_s: float = 1.0 / 1480.0
    board_z_m: float = 0.0
    name: str = ""
    keys: tuple[str, ...] = ()
    box: Box = DAIR_BOX
    law: Any = None
    """``injected`` mode: the reference model's contact parameters
    (:class:`~impactbench.reference.box_contact.BoxContactParams`); the engine's box–board
    contact is then off and the model's corner forces are applied every step
    (:mod:`impactbench.cube_tosses.model_modes`)."""

    def __post_init__(self) -> None:
        self.params = dict(self.params)
        unknown = [k for k in self.params if k not in self.keys]
        if unknown:
            raise InvalidValue(f"param {unknown[0]!r}: not a {self.name} cube parameter; valid: "
                             f"{', '.join(self.keys)}")
        if not (self.step_s > 0 and math.isfinite(self.step_s)):
            raise ValueError(f"step_s = {self.step_s!r}: must be > 0")
        self._wrench = None
        self._contact_off = ""
        if self.law is not None:
            from impactbench.reference.box_contact import CornerWrench

            self._wrench = CornerWrench(self.law, self.box, self.board_z_m, GRAVITY_M_S2)
        self._build()

    # -- the interface
    def run(self, start: Start) -> tuple[np.ndarray, np.ndarray]:
        """Replay one toss from ``start``: positions (n, 3) and quaternions wxyz (n, 4) at
        ``start.record_steps`` (the first is the initial state as set)."""
        if not math.isclose(start.step_s, self.step_s, rel_tol=1e-9):
            raise ValueError(f"toss {start.toss}: step {start.step_s!r} s, engine built for "
                             f"{self.step_s!r} s")
        self._reset(start)
        advance = self._advance if self._wrench is None else self._advance_injected
        pose = self._pose
        n = len(start.record_steps)
        p = np.empty((n, 3))
        q = np.empty((n, 4))
        done = 0
        for i, k in enumerate(np.asarray(start.record_steps).tolist()):
            if k > done:
                advance(int(k) - done)
                done = int(k)
            p[i], q[i] = pose()
        return p, q

    def _advance_injected(self, steps: int) -> None:
        """``steps`` steps with the model's corner forces at each step's start state applied
        as an external force at the centre and a torque (board frame) for that step (plain
        floats from the engine's state to its force input:
        :meth:`~impactbench.reference.box_contact.CornerWrench.values`)."""
        wrench, state, push = self._wrench.values, self._state_values, self._push_values
        for _ in range(steps):
            push(wrench(*state()))

    def injected_setup(self) -> dict[str, Any]:
        """What injected mode did to the engine (empty in the other modes)."""
        if self._wrench is None:
            return {}
        return {"law": self.law.describe(), "engine_contact": self._contact_off,
                "forces": "the model's corner forces (normal law + regularised Coulomb) at "
                          "each step's start state, summed into a force at the centre and a "
                          "torque, applied for that step"}

    def describe(self) -> dict[str, Any]:
        """What was built: the engine's version, the parameters set, the effective pair values
        and their combination rules, the cube's inertia and the board's geometry."""
        raise NotImplementedError

    def close(self) -> None:
        """Release the engine's resources."""

    # -- subclass hooks
    def _build(self) -> None:
        raise NotImplementedError

    def _reset(self, start: Start) -> None:
        raise NotImplementedError

    def _advance(self, steps: int) -> None:
        raise NotImplementedError

    def _pose(self) -> tuple[Any, Any]:
        """The centre (m, 3 numbers) and the quaternion (w, x, y, z) now."""
        raise NotImplementedError

    def _state_values(self) -> tuple[float, ...]:
        """(p, q wxyz, v, ω in the board's frame) as 13 floats: injected mode's input."""
        raise NotImplementedError

    def _push_values(self, wrench: tuple[float, ...]) -> None:
        """Apply the force ``wrench[:3]`` (N) at the centre and the torque ``wrench[3:]``
        (N·m), both in the board's frame, and take one step."""
        raise NotImplementedError


def _version(dist: str) -> str:
    try:
        return metadata.version(dist)
    except metadata.PackageNotFoundError:
        return "unknown"


# ------------------------------------------------------------------------------ PyBullet

_BULLET_BODY_KEYS = ("lateralFriction", "contactStiffness", "contactDamping", "restitution",
                     "rollingFriction", "spinningFriction")
_BULLET_CUBE_KEYS = ("linearDamping", "angularDamping")
BULLET_BOARD_HALF_EXTENTS = (2.5, 2.5, 0.5)


class PyBulletCube(CubeEngine):
    """PyBullet (module doc)."""

    def __init__(self, params: Mapping[str, Any] = (), step_s: float = 1.0 / 1480.0,
                 board_z_m: float = 0.0, box: Box = DAIR_BOX, law: Any = None) -> None:
        keys = (*(f"{b}.{k}" for b in ("board", "cube") for k in _BULLET_BODY_KEYS),
                *(f"cube.{k}" for k in _BULLET_CUBE_KEYS), "cube.inertia",
                "numSolverIterations")
        super().__init__(dict(params), step_s, board_z_m, "pybullet", keys, box, law)

    def _build(self) -> None:
        from impactbench.engines.common import silenced_fds

        with silenced_fds():  # pybullet prints its build time from C on import
            import pybullet as pb

        self._pb = pb
        self._client = pb.connect(pb.DIRECT)
        c = self._client
        pb.setGravity(0.0, 0.0, -GRAVITY_M_S2, physicsClientId=c)
        pb.setTimeStep(self.step_s, physicsClientId=c)
        # Bullet keeps the contact breaking threshold in a process-wide global
        # (gContactBreakingThreshold), not per client: another run in this process (the ball
        # adapter sets it tiny) would change these replays. Set Bullet's own default, 0.02 m.
        pb.setPhysicsEngineParameter(contactBreakingThreshold=BULLET_BREAKING_THRESHOLD_M,
                                     physicsClientId=c)
        if "numSolverIterations" in self.params:
            pb.setPhysicsEngineParameter(numSolverIterations=int(
                self.params["numSolverIterations"]), physicsClientId=c)
        hz = BULLET_BOARD_HALF_EXTENTS
        board_shape = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=hz, physicsClientId=c)
        self._board = pb.createMultiBody(0.0, board_shape,
                                         basePosition=[0.0, 0.0, self.board_z_m - hz[2]],
                                         physicsClientId=c)
        cube_shape = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=[self.box.half_width_m] * 3,
                                             physicsClientId=c)
        self._cube = pb.createMultiBody(self.box.mass_kg, cube_shape, basePosition=[0.0, 0.0, 1.0],
                                        physicsClientId=c)
        inertia = self.params.get("cube.inertia", self.box.inertia_kg_m2)
        if inertia != "collision":
            pb.changeDynamics(self._cube, -1, localInertiaDiagonal=[float(inertia)] * 3,
                              physicsClientId=c)
        for body, uid in (("board", self._board), ("cube", self._cube)):
            kw = {k: float(self.params[f"{body}.{k}"]) for k in _BULLET_BODY_KEYS
                  if f"{body}.{k}" in self.params}
            if ("contactStiffness" in kw) != ("contactDamping" in kw):
                raise InvalidValue(f"param {body}.contactStiffness/{body}.contactDamping: "
                                 "Bullet needs both or neither")
            if kw:
                pb.changeDynamics(uid, -1, physicsClientId=c, **kw)
        damping = {k: float(self.params[f"cube.{k}"]) for k in _BULLET_CUBE_KEYS
                   if f"cube.{k}" in self.params}
        if self.law is not None:  # injected: no engine contact, no drag the model lacks
            pb.setCollisionFilterPair(self._board, self._cube, -1, -1, 0, physicsClientId=c)
            damping = {"linearDamping": 0.0, "angularDamping": 0.0}
            self._contact_off = ("board-cube collision filtered out (setCollisionFilterPair); "
                                 "the cube's linear and angular damping 0")
        if damping:
            pb.changeDynamics(self._cube, -1, physicsClientId=c, **damping)

    def _reset(self, start: Start) -> None:
        pb, c = self._pb, self._client
        w, x, y, z = start.q
        pb.resetBasePositionAndOrientation(self._cube, start.p.tolist(), [x, y, z, w],
                                           physicsClientId=c)
        pb.resetBaseVelocity(self._cube, start.v.tolist(), start.w_world.tolist(),
                             physicsClientId=c)

    def _advance(self, steps: int) -> None:
        step, c = self._pb.stepSimulation, self._client
        for _ in range(steps):
            step(physicsClientId=c)

    def _pose(self) -> tuple[Any, Any]:
        pos, (x, y, z, w) = self._pb.getBasePositionAndOrientation(self._cube,
                                                                   physicsClientId=self._client)
        return pos, (w, x, y, z)

    def _state_values(self) -> tuple[float, ...]:
        pb, c = self._pb, self._client
        pos, (x, y, z, w) = pb.getBasePositionAndOrientation(self._cube, physicsClientId=c)
        v, om = pb.getBaseVelocity(self._cube, physicsClientId=c)
        self._pos = pos   # the force's point in _push_values (no step in between)
        return (*pos, w, x, y, z, *v, *om)

    def _push_values(self, wrench: tuple[float, ...]) -> None:
        pb, c = self._pb, self._client
        if any(wrench):
            pb.applyExternalForce(self._cube, -1, list(wrench[:3]), self._pos, pb.WORLD_FRAME,
                                  physicsClientId=c)
            pb.applyExternalTorque(self._cube, -1, list(wrench[3:]), pb.WORLD_FRAME,
                                   physicsClientId=c)
        pb.stepSimulation(physicsClientId=c)

    def describe(self) -> dict[str, Any]:
        pb, c = self._pb, self._client
        info = {b: pb.getDynamicsInfo(u, -1, physicsClientId=c)
                for b, u in (("board", self._board), ("cube", self._cube))}
        mu = {b: float(i[1]) for b, i in info.items()}
        eff: dict[str, Any] = {
            "friction": mu["board"] * mu["cube"],
            "friction_rule": "product of the two bodies' lateralFriction "
                             f"({mu['board']:g} × {mu['cube']:g}; an unset body has 0.5)"}
        k = {b: float(i[9]) for b, i in info.items()}   # contactStiffness, −1 when unset
        d = {b: float(i[8]) for b, i in info.items()}
        if any(v > 0 for v in k.values()):
            ks = [v if v > 0 else 1e30 for v in k.values()]
            ds = [v if k[b] > 0 else 0.1 for b, v in d.items()]
            eff |= {"contact_stiffness_n_per_m": 1.0 / sum(1.0 / v for v in ks),
                    "contact_damping_n_s_per_m": sum(ds),
                    "contact_rule": "stiffness in series, damping summed; an unset body "
                                    "counts 1e30 N/m and 0.1 N·s/m"}
        else:
            eff["contact"] = "rigid (Bullet's default ERP/CFM; no stiffness set)"
        return {"engine": "pybullet", "version": _version("pybullet"),
                "params": dict(self.params), "effective": eff,
                "cube_inertia_kg_m2": float(info["cube"][2][0]),
                "board": f"fixed box {2 * BULLET_BOARD_HALF_EXTENTS[0]:g} × "
                         f"{2 * BULLET_BOARD_HALF_EXTENTS[1]:g} × "
                         f"{2 * BULLET_BOARD_HALF_EXTENTS[2]:g} m, top at z = "
                         f"{self.board_z_m:g} m",
                "step_s": self.step_s}

    def close(self) -> None:
        if getattr(self, "_client", None) is not None:
            try:
                self._pb.disconnect(physicsClientId=self._client)
            except Exception:  # already gone
                pass
            self._client = None


# ------------------------------------------------------------------------------ MuJoCo

_MUJOCO_GEOM_KEYS = ("solref", "solimp", "friction", "condim", "priority", "solmix")
MUJOCO_BOARD_HALF = (5.0, 5.0, 0.2)


def _mj_value(v: Any) -> str:
    if isinstance(v, str):
        return v
    if isinstance(v, list | tuple | np.ndarray):
        return " ".join(repr(float(x)) for x in v)
    return repr(float(v)) if isinstance(v, float) else str(v)


class MujocoCube(CubeEngine):
    """MuJoCo (module doc)."""

    def __init__(self, params: Mapping[str, Any] = (), step_s: float = 1.0 / 1480.0,
                 board_z_m: float = 0.0, box: Box = DAIR_BOX, law: Any = None) -> None:
        super().__init__(dict(params), step_s, board_z_m, "mujoco", (), box, law)

    def __post_init__(self) -> None:
        self.keys = tuple(f"{b}.{k}" for b in ("board", "cube") for k in _MUJOCO_GEOM_KEYS)
        option = [k for k in dict(self.params) if k.startswith("option.")]
        self.keys = (*self.keys, *option)
        super().__post_init__()

    def xml(self) -> str:
        """The model's MJCF."""
        opts = {"timestep": repr(self.step_s), "gravity": f"0 0 {-GRAVITY_M_S2!r}"}
        opts |= {k.removeprefix("option."): _mj_value(v) for k, v in self.params.items()
                 if k.startswith("option.")}

        def attrs(body: str) -> str:
            return "".join(f' {k}="{_mj_value(self.params[f"{body}.{k}"])}"'
                           for k in _MUJOCO_GEOM_KEYS if f"{body}.{k}" in self.params)

        h, (bx, by, bz) = self.box.half_width_m, MUJOCO_BOARD_HALF
        i = self.box.inertia_kg_m2
        option = " ".join(f'{k}="{v}"' for k, v in opts.items())
        return (
            f'<mujoco model="cube_toss"><compiler inertiafromgeom="false"/>'
            f"<option {option}/><worldbody>"
            f'<body name="board" pos="0 0 {self.board_z_m - bz!r}">'
            f'<geom name="board" type="box" size="{bx} {by} {bz}"{attrs("board")}/></body>'
            f'<body name="cube" pos="0 0 1"><freejoint name="cube"/>'
            f'<inertial pos="0 0 0" mass="{self.box.mass_kg!r}" diaginertia="{i!r} {i!r} '
            f'{i!r}"/>'
            f'<geom name="cube" type="box" size="{h!r} {h!r} {h!r}"{attrs("cube")}/>'
            f"</body></worldbody></mujoco>")

    def _build(self) -> None:
        import mujoco

        self._mj = mujoco
        try:
            self._model = mujoco.MjModel.from_xml_string(self.xml())
        except ValueError as exc:
            first = str(exc).strip().splitlines()[0] if str(exc).strip() else "invalid"
            raise ValueError(f"mujoco cube parameters {dict(self.params)!r}: {first}") from None
        self._data = mujoco.MjData(self._model)
        if self.law is not None:  # injected: MuJoCo's contacts off, the model's forces on
            self._model.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_CONTACT)
            self._cube_body = mujoco.mj_name2id(self._model, mujoco.mjtObj.mjOBJ_BODY, "cube")
            self._contact_off = "MuJoCo's contacts disabled (mjDSBL_CONTACT)"

    def _reset(self, start: Start) -> None:
        mj, m, d = self._mj, self._model, self._data
        mj.mj_resetData(m, d)
        d.qpos[:3] = start.p
        d.qpos[3:7] = start.q
        d.qvel[:3] = start.v
        d.qvel[3:6] = start.w_body   # a free joint's angular velocity is in the body frame
        mj.mj_forward(m, d)

    def _advance(self, steps: int) -> None:
        self._mj.mj_step(self._model, self._data, nstep=steps)   # mj_step ``steps`` times, in C

    def _pose(self) -> tuple[Any, Any]:
        return self._data.qpos[:3], self._data.qpos[3:7]   # copied by the caller

    def _state_values(self) -> tuple[float, ...]:
        d = self._data
        # a free joint's angular velocity is in the body frame: ω = R(q)·ω_body (BLAS gemv)
        om = quat_matrix(d.qpos[3:7]).dot(d.qvel[3:6]).tolist()
        return (*d.qpos[:7].tolist(), *d.qvel[:3].tolist(), *om)

    def _push_values(self, wrench: tuple[float, ...]) -> None:
        d = self._data
        d.xfrc_applied[self._cube_body] = wrench   # world frame, at the body's centre
        self._mj.mj_step(self._model, d)

    def describe(self) -> dict[str, Any]:
        m = self._model
        ids = {b: self._mj.mj_name2id(m, self._mj.mjtObj.mjOBJ_GEOM, b)
               for b in ("board", "cube")}
        fr = {b: m.geom_friction[i].tolist() for b, i in ids.items()}
        sr = {b: m.geom_solref[i].tolist() for b, i in ids.items()}
        mix = {b: float(m.geom_solmix[i]) for b, i in ids.items()}
        pri = {b: int(m.geom_priority[i]) for b, i in ids.items()}
        if pri["board"] != pri["cube"]:
            top = max(pri, key=pri.get)
            friction, solref = fr[top], sr[top]
            rule = f"the {top}'s values (higher priority)"
        else:
            friction = np.maximum(fr["board"], fr["cube"]).tolist()
            if sr["board"][0] > 0 and sr["cube"][0] > 0:
                w = mix["board"] / (mix["board"] + mix["cube"])
                solref = (w * np.array(sr["board"]) + (1 - w) * np.array(sr["cube"])).tolist()
                rule = "friction: the larger; solref: solmix-weighted mean (both standard)"
            else:
                solref = np.minimum(sr["board"], sr["cube"]).tolist()
                rule = "friction: the larger; solref: element-wise minimum (a direct solref)"
        return {"engine": "mujoco", "version": _version("mujoco"),
                "params": {k: list(v) if isinstance(v, tuple) else v
                           for k, v in self.params.items()},
                "effective": {"friction": float(friction[0]), "friction_all": friction,
                              "solref": solref, "friction_rule": rule,
                              "solimp": m.geom_solimp[ids["board"]].tolist(),
                              "cone": ["pyramidal", "elliptic"][int(m.opt.cone)],
                              "integrator": self._mj.mjtIntegrator(int(m.opt.integrator))
                              .name.removeprefix("mjINT_").lower()},
                "cube_inertia_kg_m2": float(m.body_inertia[
                    self._mj.mj_name2id(m, self._mj.mjtObj.mjOBJ_BODY, "cube")][0]),
                "board": f"box geom {2 * MUJOCO_BOARD_HALF[0]:g} × {2 * MUJOCO_BOARD_HALF[1]:g}"
                         f" × {2 * MUJOCO_BOARD_HALF[2]:g} m, top at z = {self.board_z_m:g} m",
                "step_s": self.step_s}


# ------------------------------------------------------------------------------ Drake

_DRAKE_BODY_KEYS = ("point_contact_stiffness", "hunt_crossley_dissipation", "mu",
                    "relaxation_time")
DRAKE_APPROXIMATIONS = ("tamsi", "sap", "similar", "lagged")


def _cube_urdf(box: Box) -> str:
    h2 = 2 * box.half_width_m
    i = box.inertia_kg_m2
    return (f'<robot name="cube"><link name="cube"><inertial><mass value="{box.mass_kg!r}"/>'
            f'<inertia ixx="{i!r}" ixy="0" ixz="0" iyy="{i!r}" iyz="0" izz="{i!r}"/>'
            f'</inertial><collision><geometry><box size="{h2!r} {h2!r} {h2!r}"/></geometry>'
            f"</collision></link></robot>")


class DrakeCube(CubeEngine):
    """Drake (module doc)."""

    def __init__(self, params: Mapping[str, Any] = (), step_s: float = 1.0 / 1480.0,
                 board_z_m: float = 0.0, box: Box = DAIR_BOX, law: Any = None) -> None:
        keys = (*(f"{b}.{k}" for b in ("board", "cube") for k in _DRAKE_BODY_KEYS),
                "discrete_contact_approximation", "contact_model", "stiction_tolerance")
        super().__init__(dict(params), step_s, board_z_m, "drake", keys, box, law)

    def _build(self) -> None:
        from impactbench.engines.common import quiet_drake_log
        from pydrake.geometry import HalfSpace, ProximityProperties
        from pydrake.math import RigidTransform
        from pydrake.multibody.parsing import Parser
        from pydrake.multibody.plant import (
            AddMultibodyPlant,
            CoulombFriction,
            MultibodyPlantConfig,
        )
        from pydrake.systems.analysis import Simulator
        from pydrake.systems.framework import DiagramBuilder

        quiet_drake_log()
        approx = self.params.get("discrete_contact_approximation")
        if approx is not None and approx not in DRAKE_APPROXIMATIONS:
            raise InvalidValue(f"param discrete_contact_approximation = {approx!r}: must be one "
                             f"of {', '.join(DRAKE_APPROXIMATIONS)}")
        config = MultibodyPlantConfig(time_step=self.step_s)
        if approx is not None:
            config.discrete_contact_approximation = approx
        if "contact_model" in self.params:
            config.contact_model = self.params["contact_model"]
        if "stiction_tolerance" in self.params:
            config.stiction_tolerance = float(self.params["stiction_tolerance"])
        self._config = config
        builder = DiagramBuilder()
        try:
            plant, scene_graph = AddMultibodyPlant(config, builder)
        except RuntimeError as exc:
            raise ValueError(f"drake cube parameters {dict(self.params)!r}: "
                             f"{str(exc).splitlines()[0]}") from None
        plant.mutable_gravity_field().set_gravity_vector([0.0, 0.0, -GRAVITY_M_S2])
        (model,) = Parser(plant).AddModelsFromString(_cube_urdf(self.box), "urdf")
        self._body = plant.GetBodyByName("cube", model)

        def props(body: str, base: Any = None) -> Any:
            out = ProximityProperties(base) if base is not None else ProximityProperties()
            for key in ("point_contact_stiffness", "hunt_crossley_dissipation",
                        "relaxation_time"):
                if f"{body}.{key}" in self.params:
                    value = float(self.params[f"{body}.{key}"])
                    if out.HasProperty("material", key):
                        out.UpdateProperty("material", key, value)
                    else:
                        out.AddProperty("material", key, value)
            if f"{body}.mu" in self.params:
                mu = float(self.params[f"{body}.mu"])
                if out.HasProperty("material", "coulomb_friction"):
                    out.UpdateProperty("material", "coulomb_friction", CoulombFriction(mu, mu))
                else:
                    out.AddProperty("material", "coulomb_friction", CoulombFriction(mu, mu))
            return out

        if self.law is None:
            plant.RegisterCollisionGeometry(
                plant.world_body(), RigidTransform(HalfSpace.MakePose(
                    [0.0, 0.0, 1.0], [0.0, 0.0, self.board_z_m])),
                HalfSpace(), "board", props("board"))
        else:  # injected: no board to collide with; the model's forces come in per step
            self._contact_off = ("no board geometry (the cube has nothing to collide with); "
                                 "the wrench enters through the plant's applied spatial "
                                 "force input, fixed before each discrete step")
        plant.Finalize()
        inspector = scene_graph.model_inspector()
        (cube_geom,) = plant.GetCollisionGeometriesForBody(self._body)
        if any(k.startswith("cube.") for k in self.params):
            scene_graph.AssignRole(plant.get_source_id(), cube_geom,
                                   props("cube", inspector.GetProximityProperties(cube_geom)),
                                   _replace())
        self._cube_geom = cube_geom
        self._plant, self._scene_graph = plant, scene_graph
        self._diagram = builder.Build()
        self._sim = Simulator(self._diagram)
        self._context = self._sim.get_mutable_context()
        self._plant_context = plant.GetMyMutableContextFromRoot(self._context)
        self._time = 0.0
        if self.law is not None:   # injected: one applied force, its value set every step
            from pydrake.multibody.math import SpatialForce
            from pydrake.multibody.plant import ExternallyAppliedSpatialForce

            self._spatial_force = SpatialForce
            self._applied = ExternallyAppliedSpatialForce()
            self._applied.body_index = self._body.index()
            self._applied.p_BoBq_B = np.zeros(3)   # at the body origin (its centre)
            self._fixed = plant.get_applied_spatial_force_input_port().FixValue(
                self._plant_context, [self._applied])

    def _reset(self, start: Start) -> None:
        from pydrake.common.eigen_geometry import Quaternion
        from pydrake.math import RigidTransform
        from pydrake.multibody.math import SpatialVelocity

        self._context.SetTime(0.0)
        self._sim.Initialize()
        pose = RigidTransform(Quaternion(start.q / np.linalg.norm(start.q)), start.p)
        self._plant.SetFreeBodyPose(self._plant_context, self._body, pose)
        self._plant.SetFreeBodySpatialVelocity(
            self._plant_context, self._body, SpatialVelocity(start.w_world, start.v))
        self._steps = 0

    def _advance(self, steps: int) -> None:
        # Discrete updates fall at multiples of the step; aim a quarter step past the k-th
        # (DAIR's sim_step does the same) so rounding never adds or drops one.
        self._steps += steps
        self._sim.AdvanceTo((self._steps + 0.25) * self.step_s)

    def _pose(self) -> tuple[Any, Any]:
        x = self._plant.GetFreeBodyPose(self._plant_context, self._body)
        return x.translation(), x.rotation().ToQuaternion().wxyz()

    def _state_values(self) -> tuple[float, ...]:
        plant, ctx = self._plant, self._plant_context
        x = plant.GetFreeBodyPose(ctx, self._body)
        v = plant.EvalBodySpatialVelocityInWorld(ctx, self._body)
        return (*x.translation().tolist(), *x.rotation().ToQuaternion().wxyz().tolist(),
                *v.translational().tolist(), *v.rotational().tolist())

    def _push_values(self, wrench: tuple[float, ...]) -> None:
        applied = self._applied
        applied.F_Bq_W = self._spatial_force(wrench[3:], wrench[:3])   # board (world) frame
        # the port's fixed value replaced in place (GetMutableData tells its dependents)
        self._fixed.GetMutableData().set_value([applied])
        self._steps += 1
        self._sim.AdvanceTo((self._steps + 0.25) * self.step_s)

    def _material(self) -> dict[str, dict[str, float]]:
        """Each geometry's effective material (SceneGraph's defaults filled in)."""
        sg_context = self._scene_graph.GetMyContextFromRoot(self._context)
        inspector = self._scene_graph.get_query_output_port().Eval(sg_context).inspector()
        out = {}
        for gid in inspector.GetAllGeometryIds():
            props = inspector.GetProximityProperties(gid)
            if props is None:
                continue
            name = "cube" if gid == self._cube_geom else "board"
            vals: dict[str, float] = {}
            for key in ("point_contact_stiffness", "hunt_crossley_dissipation",
                        "relaxation_time"):
                if props.HasProperty("material", key):
                    vals[key] = float(props.GetProperty("material", key))
            if props.HasProperty("material", "coulomb_friction"):
                vals["mu"] = float(props.GetProperty("material", "coulomb_friction")
                                   .dynamic_friction())
            out[name] = vals
        return out

    def describe(self) -> dict[str, Any]:
        mat = self._material()
        b, c = mat.get("board", {}), mat.get("cube", {})
        eff: dict[str, Any] = {}
        if "mu" in b and "mu" in c:
            eff["friction"] = 2 * b["mu"] * c["mu"] / (b["mu"] + c["mu"])
            eff["friction_rule"] = (f"2ab/(a + b) of board {b['mu']:g} and cube {c['mu']:g}"
                                    + ("" if "cube.mu" in self.params else
                                       " (the URDF parser gives the cube 1.0)"))
        if "point_contact_stiffness" in b and "point_contact_stiffness" in c:
            k1, k2 = b["point_contact_stiffness"], c["point_contact_stiffness"]
            d1 = b.get("hunt_crossley_dissipation", math.nan)
            d2 = c.get("hunt_crossley_dissipation", math.nan)
            eff |= {"point_contact_stiffness_n_per_m": k1 * k2 / (k1 + k2),
                    "hunt_crossley_dissipation_s_per_m": (k2 * d1 + k1 * d2) / (k1 + k2),
                    "contact_rule": "stiffness in series; dissipation (k₂d₁ + k₁d₂)/(k₁ + k₂)"}
        approx = self._config.discrete_contact_approximation
        if approx == "sap":
            eff["note"] = ("sap: linear Kelvin–Voigt dissipation from the relaxation time "
                           f"(board {b.get('relaxation_time')} s, cube "
                           f"{c.get('relaxation_time')} s); Hunt–Crossley d ignored")
        else:
            eff["note"] = f"{approx}: Hunt–Crossley dissipation d"
        return {"engine": "drake", "version": _version("drake"),
                "params": dict(self.params), "effective": eff, "materials": mat,
                "discrete_contact_approximation": approx,
                "contact_model": self._config.contact_model,
                "stiction_tolerance_m_s": self._config.stiction_tolerance,
                "cube_inertia_kg_m2": float(self._body.default_rotational_inertia()
                                            .get_moments()[0]),
                "board": f"half-space, surface at z = {self.board_z_m:g} m",
                "step_s": self.step_s}


def _replace() -> Any:
    from pydrake.geometry import RoleAssign

    return RoleAssign.kReplace


_CLASSES: dict[str, type[CubeEngine]] = {"pybullet": PyBulletCube, "mujoco": MujocoCube,
                                         "drake": DrakeCube}
MORE_ENGINES = "impactbench.engines.cube_toss_more"
BULLET_BREAKING_THRESHOLD_M = 0.02
"""Bullet's default contact breaking threshold (``gContactBreakingThreshold``, m)."""
"""The module of the other engines' classes (``CLASSES``), imported when one is built."""


def make(engine: str, params: Mapping[str, Any] = (), step_s: float = 1.0 / 1480.0,
         board_z_m: float = 0.0, box: Box = DAIR_BOX, law: Any = None) -> CubeEngine:
    """The cube-on-board model of ``engine`` with engine parameters ``params`` and the cube
    ``box`` (DAIR's by default); with ``law`` (the reference model's
    :class:`~impactbench.reference.box_contact.BoxContactParams`) the injected model: the
    engine's own box–board contact off, the model's corner forces applied every step."""
    cls = _CLASSES.get(engine)
    if cls is None and engine in ENGINES:  # by name, as the engine registry loads adapters:
        import importlib  # cube_toss_more builds on this module's classes

        cls = importlib.import_module(MORE_ENGINES).CLASSES[engine]
    if cls is None:
        raise ValueError(f"engine = {engine!r}: the cube tosses run on {', '.join(ENGINES)}")
    if law is None:
        return cls(params, step_s, board_z_m, box=box)
    return cls(params, step_s, board_z_m, box=box, law=law)


def _check_box(engine: str, box: Box, params: Mapping[str, Any], setup: Mapping[str, Any]
               ) -> None:
    """A cube of the user's must reach the engine: its inertia read back from the built engine
    (``setup["cube_inertia_kg_m2"]``) must be the given one, unless the parameters set the
    cube's inertia themselves (``cube.inertia``). DAIR's cube is the engines' default."""
    got = setup.get("cube_inertia_kg_m2")
    if box == DAIR_BOX or "cube.inertia" in params or not isinstance(got, int | float):
        return
    want = box.inertia_kg_m2
    if isinstance(want, int | float) and not math.isclose(float(got), want, rel_tol=1e-5):
        raise RuntimeError(f"{engine}: built the cube with I = {got:g} kg·m², not the given "
                           f"{want:g}: its replay ignores the box")


REPLAY_ERRORS = (RuntimeError, FloatingPointError, ValueError)
"""What one toss may raise in an engine (an engine error or a non-finite state): that toss
fails, the others go on."""


def replay_tosses(engine: str, scenario: Any, mode: str, settings: Any) -> ImpactRecord:
    """The cube-toss builder of every 3D engine: replay the scenario's tosses in ``engine``.

    The scenario (:class:`impactbench.scenarios.cube_toss.CubeToss`) prepares what the
    engine needs — the tosses' starts from the measurement (:meth:`starts`), the cube
    (:meth:`box`), the engine parameters of ``mode`` (:meth:`engine_parameters`: none in
    ``default``; ``custom`` the user's keys, a published ``param_set``; ``tuned`` the fitted
    ones; ``native`` the reference model's contact mapped into the engine) and, in
    ``injected`` mode, the reference model's contact law (:meth:`injected_law`). One engine
    instance replays every toss (a batched engine, MJX or Newton, all in one call).

    The record carries no impact channels: ``meta["poses"]`` maps each replayed toss to its
    positions (n, 3, m) and quaternions (n, 4, w x y z) at the toss's reference samples, which
    the scenario scores against the measurement; ``meta["failed_tosses"]`` the tosses that
    could not start or failed in the engine (``toss``, ``error``); ``meta["engine_setup"]``
    what was built; ``meta["params"]`` the engine parameters set. Status: ``ok`` when any toss
    ran (the message names the failed ones), ``diverged`` when none did."""
    # a ValueError here (a published set the engine lacks, a key it does not take) is bad
    # input: the adapter's builder raises it as SettingsError
    params = scenario.engine_parameters(engine, mode, settings.params, settings.tuned)
    law = scenario.injected_law() if mode == "injected" else None
    starts, failed = scenario.starts()
    box = scenario.box()
    steps = {round(s.step_s, 15) for s in starts}
    if len(steps) > 1:
        raise ValueError(f"data: the tosses' sample intervals differ ({sorted(steps)[:3]} s "
                         "engine steps); set sample_dt_s")
    step_s = starts[0].step_s if starts else scenario.step_s()
    sim = make(engine, params, step_s, scenario.board_z_m, box, law=law)
    poses: dict[int, tuple[np.ndarray, np.ndarray]] = {}
    failed = list(failed)
    try:
        setup = sim.describe()
        _check_box(engine, box, params, setup)
        if law is not None:
            setup["injected"] = sim.injected_setup()
        t0 = time.perf_counter()
        batch = sim.run_many(starts) if getattr(sim, "batched", False) else None
        for n, start in enumerate(starts):
            try:
                if batch is not None and isinstance(batch[n], Exception):
                    raise batch[n]
                p, q = batch[n] if batch is not None else sim.run(start)
                if not (np.all(np.isfinite(p)) and np.all(np.isfinite(q))):
                    raise FloatingPointError("non-finite state")
                poses[int(start.toss)] = (p, q)
            except REPLAY_ERRORS as exc:
                failed.append({"toss": int(start.toss), "status": "failed",
                               "error": f"{type(exc).__name__}: {str(exc).splitlines()[0]}"})
        elapsed = time.perf_counter() - t0
    finally:
        sim.close()
    meta = {"poses": poses, "failed_tosses": failed, "engine_setup": setup,
            "params": dict(params), "replay_s": elapsed, "timestep_s": step_s,
            "param_set": (settings.params or {}).get("param_set") if mode == "custom" else None,
            "engine_version": str(setup.get("version", ""))}
    empty = np.empty(0)
    status, message = Status.OK, ""
    if failed:
        ids = ", ".join(str(r["toss"]) for r in failed[:5]) + (" …" if len(failed) > 5 else "")
        message = (f"{len(failed)} of {len(failed) + len(poses)} tosses failed ({ids}): "
                   f"{failed[0].get('error')}")
        status = Status.OK if poses else Status.DIVERGED
    return ImpactRecord(empty, empty, empty, empty, empty, empty, mass_1_kg=box.mass_kg,
                        status=status, message=message, meta=meta)
