"""MJX (MuJoCo XLA, pip ``mujoco-mjx`` with jax on CPU): MuJoCo's physics in JAX.

The models are MuJoCo's own (:func:`~impactbench.engines.mujoco_adapter.ball_mjcf`,
:func:`~impactbench.engines.mujoco_adapter.rigid_flexible_mjcf`), moved to the device with
``mjx.put_model``/``put_data``, and the contact physics is MuJoCo's soft constraint (see
:mod:`impactbench.engines.mujoco_adapter`): a direct solref (−S, −D) with constant impedance is
the physical linear spring–damper K = S/A, D_phys = D/A, A = efc_diagA. MJX computes in 64-bit
floats here (``jax_enable_x64`` is switched on when the engine is first used, for the whole
process), so it is MuJoCo's arithmetic on another compiler: the test suite checks that both give
the same record. It serves as MuJoCo's batched twin: many ball runs — a tuner's generation of
contact parameters, at any velocities — step as one ``vmap`` over worlds
(:func:`run_ball_batch`, :attr:`Builder.batch`; each world driven by the lone run's plan and
end rule, its record the lone run's bit for bit); :func:`ball_batch` is the raw fixed-length
form (the benchmarks').

Modes — the MuJoCo adapter's, with its helpers (solref/solimp conversions, the custom keys
``solref``, ``solimp``, ``integrator``, ``meta["engine_defaults"]`` read back from the compiled
model, the end-of-impact rules):

- ``native``, ``tuned``: as MuJoCo's (ball: the clipped spring–damper matching the
  Hunt–Crossley reference's restitution and duration at V_ref; rigid–flexible: solref
  (−k1·A, 0)).
- ``default``, ``custom``: ball-on-plate only, as MuJoCo's.
- ``injected``, ball only: the scenario's contact law through MuJoCo's contact pipeline, its
  per-step secant stiffness c·x^(n−1) and damping c·b·xⁿ (Hunt–Crossley family) or k, d
  (clipped Kelvin–Voigt), times A, written into ``geom_solref`` inside the compiled step (MJX
  has no ``mjENBL_OVERRIDE``). The rigid–flexible local laws with memory (elastoplastic,
  mutation) need a Python update between steps, which a compiled scan has not: that case
  returns ``unsupported``.

Stepping: a whole chunk of steps is one ``jax.lax.scan`` over ``mjx.step`` (a Python loop over a
jitted step manages ~170 steps/s; the scan ~70k). Chunks have a fixed length per scenario
(:data:`BALL_CHUNK`, :data:`RIGID_FLEXIBLE_CHUNK`), so each scenario kind and per-step control
compiles once per process (2–5 s) and later runs reuse it; a chunk may step past the end, which
is cut off. The softening structure's cubic term β·x2³ is written into ``qfrc_applied`` inside the
scan. Sample k is the state at the start of step k and MuJoCo's ``contact`` sensor (the normal
force acting over step k), exactly as in the MuJoCo adapter, whose end-of-impact rules
(:func:`~impactbench.engines.mujoco_adapter.drive`) are reused. MJX raises no instability
warning: a blow-up shows as non-finite state, hence ``diverged``.

Oblique impact (:func:`run_oblique`): MuJoCo's model, modes and friction settings
(:func:`~impactbench.engines.mujoco_adapter.prepare_oblique`: pyramidal or elliptic cone,
``impratio``, ``solreffriction`` on a contact pair — MJX implements them all), the whole
contact sensor recorded inside the scan; injected writes the law's secant into the pair's
solref inside the scan. MJX has no noslip solver (it would ignore ``noslip_iterations``, so
that key is not offered). The records equal C MuJoCo's (tests). ``tuned``: MuJoCo's (native
with a tuned file's ``cone``, ``impratio`` and sliding ``friction``; its own packaged file).

Bounce to rest (:func:`run_bounce`): MuJoCo's (model, modes, end rule and record, from
:mod:`impactbench.engines.mujoco_adapter`), stepped by MJX in the ball's compiled scans: the
7500 steps of the 15 s cap at 2 ms take ~0.3 s once compiled. Its records equal C MuJoCo's
to round-off (tests), which grows from bounce to bounce in a long bouncing run (the step a
contact starts at amplifies it).
"""

from __future__ import annotations

import functools
import math
import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, ClassVar

import numpy as np
from impactbench.engines.base import (
    Adapter,
    Builder,
    EngineUnavailable,
    RunSettings,
    ball_phase,
    cube_toss_builder,
)
from impactbench.engines.mujoco_adapter import (
    BALL_TIMESTEP_S,
    BOUNCE_TIMESTEP_S,
    GAP_STEPS,
    OBLIQUE_KEYS,
    OBLIQUE_SENSOR_WIDTH,
    OBLIQUE_TIMESTEP_S,
    PARAMETER_KEYS,
    RIGID_FLEXIBLE_TIMESTEP_S,
    SOLIMP,
    MujocoAdapter,
    ball_contact,
    ball_end_finder,
    ball_mjcf,
    ball_outcome_record,
    ball_start,
    bounce_record,
    bounce_start,
    custom_parameters,
    drive,
    drive_many,
    driving,
    face_radius_m,
    hertz_duration_s,
    measured_diag_a,
    native_or_tuned,
    oblique_end_finder,
    oblique_outcome_record,
    oblique_start,
    prepare_oblique,
    rigid_flexible_end_finder,
    rigid_flexible_mjcf,
    rigid_flexible_record,
    set_contact,
)
from impactbench.engines.mujoco_adapter import custom_parameters as mujoco_custom_parameters
from impactbench.reference.bounce_scenario import Bounce
from impactbench.reference.models import KelvinVoigt
from impactbench.reference.record import ImpactRecord, Status
from impactbench.reference.scenarios import BallOnPlate, RigidFlexible

BALL_CHUNK = 512
"""Steps per compiled scan for the ball (one chunk covers a 1 m/s impact at dt = 1e-6 s)."""
RIGID_FLEXIBLE_CHUNK = 2048
"""Steps per compiled scan for the rigid–flexible model."""
COMPILE_CACHE_DIR = Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache")) \
    / "impactbench" / "jax"
"""jax's persistent compilation cache, unless ``JAX_COMPILATION_CACHE_DIR`` sets another: the
2–5 s compile of each scan happens once per machine, not once per process."""


@functools.lru_cache(maxsize=1)
def _mjx() -> tuple[Any, Any, Any]:
    """(mujoco, jax, mujoco.mjx) with 64-bit floats on; EngineUnavailable if missing."""
    try:
        import jax
        import mujoco
        from mujoco import mjx
    except ImportError as exc:
        raise EngineUnavailable("mjx", str(exc)) from exc
    jax.config.update("jax_enable_x64", True)
    if not jax.config.jax_compilation_cache_dir:  # keep compiled scans across processes
        jax.config.update("jax_compilation_cache_dir", str(COMPILE_CACHE_DIR))
    return mujoco, jax, mjx


# --------------------------------------------------------------------------- compiled stepping


def _no_control(mx: Any, dx: Any, p: Any) -> tuple[Any, Any]:
    return mx, dx


def _secant_solref(p: Any, x: Any) -> Any:
    """Direct solref of the injected law at penetration x (m), p = (c, n, b, d0, A, …):
    secant stiffness c·x^(n−1) and damping c·b·xⁿ + d0 (N/m, N·s/m), each times A; (0, 0)
    out of contact."""
    jnp = _mjx()[1].numpy
    c, n, b, d0, a = p[0], p[1], p[2], p[3], p[4]
    xp = jnp.maximum(x, 0.0)
    inside = x > 0.0
    k = jnp.where(inside, c * xp ** (n - 1.0), 0.0)
    d = jnp.where(inside, k * xp * b + d0, 0.0)
    return jnp.stack([-k * a, -d * a])


def _secant_control(mx: Any, dx: Any, p: Any) -> tuple[Any, Any]:
    """The injected law's direct solref (:func:`_secant_solref`) at the step's start on
    every geom, p = (c, n, b, d0, A) (slide joint: the penetration is −q)."""
    jnp = _mjx()[1].numpy
    solref = _secant_solref(p, -dx.qpos[0])
    return mx.replace(geom_solref=jnp.broadcast_to(solref, mx.geom_solref.shape)), dx


def _cubic_control(mx: Any, dx: Any, p: Any) -> tuple[Any, Any]:
    """The softening structure's cubic term +β·x2³ on joint 2; p = (β,)."""
    return mx, dx.replace(qfrc_applied=dx.qfrc_applied.at[1].set(p[0] * dx.qpos[1] ** 3))


CONTROLS = {"none": _no_control, "secant": _secant_control,
            "cubic": _cubic_control}
"""Per-step changes applied inside the scan before each ``mjx.step``."""


@functools.lru_cache(maxsize=2)
def _compiled_scan(sensor_width: int) -> Any:
    """``scan(mx, dx, p, length, control) → (dx, (qpos, qvel, force))``, jitted; the force
    per step is the contact sensor's first value (the normal force), or with
    ``sensor_width`` its first that many (the oblique impact's force and contact frame,
    :data:`~impactbench.engines.mujoco_adapter.OBLIQUE_SENSOR_WIDTH`)."""
    _, jax, mjx = _mjx()

    def scan(mx: Any, dx: Any, p: Any, length: int, control: str) -> Any:
        change = CONTROLS[control]

        def body(dx: Any, _: Any) -> Any:
            mx_k, dx = change(mx, dx, p)
            pre = (dx.qpos, dx.qvel)
            dx = mjx.step(mx_k, dx)
            # the contact sensor of the step just taken
            force = dx.sensordata[:sensor_width] if sensor_width else dx.sensordata[0]
            return dx, (*pre, force)

        return jax.lax.scan(body, dx, None, length=length)

    return jax.jit(scan, static_argnames=("length", "control"))


@functools.lru_cache(maxsize=1)
def _compiled_forward() -> Any:
    _, jax, mjx = _mjx()
    return jax.jit(mjx.forward)


@dataclass
class _MjxSim:
    """A model and data on the device, stepped in fixed-length compiled scans."""

    model: Any
    data: Any
    control: str
    params: np.ndarray
    length: int
    steps: int = 0
    chunks: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = field(default_factory=list)

    def __post_init__(self) -> None:
        _, _, mjx = _mjx()
        self.mx = mjx.put_model(self.model)
        # a jitted forward first gives the data its 64-bit layout (put_data's integer fields
        # would otherwise differ from the scan's carry)
        self.dx = _compiled_forward()(self.mx, mjx.put_data(self.model, self.data))

    sensor_width: ClassVar[int] = 0
    """How many of the contact sensor's values a step keeps (:func:`_compiled_scan`)."""

    def step_chunk(self, n: int) -> None:
        scan = _compiled_scan(self.sensor_width)
        for _ in range(max(1, math.ceil(n / self.length))):
            self.dx, (q, v, f) = scan(self.mx, self.dx, self.params, self.length, self.control)
            self.chunks.append((np.asarray(q), np.asarray(v), np.asarray(f)))
            self.steps += self.length

    def arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        qs, vs, fs = zip(*self.chunks, strict=True)
        return np.concatenate(qs), np.concatenate(vs), np.concatenate(fs)

    def unstable(self) -> bool:
        return False  # MJX has no warnings; a blow-up is non-finite state


# --------------------------------------------------------------------------- scenarios


def _ball_model(s: BallOnPlate, dt: float, integrator: str = "Euler",
                out_of_box: bool = False) -> tuple[Any, Any, float]:
    mujoco = _mjx()[0]
    model = mujoco.MjModel.from_xml_string(ball_mjcf(s, dt, integrator,
                                                     engine_defaults=out_of_box))
    data = mujoco.MjData(model)
    return model, data, measured_diag_a(model, data, (-1e-9,))


def injected_parameters(law: Any, diag_a: float) -> np.ndarray | None:
    """(c, n, b, d0, A) of the injected control — secant stiffness c·x^(n−1), damping
    c·b·xⁿ + d0 — for a power-law Hunt–Crossley-family law or a clipped Kelvin–Voigt one
    (c = k, n = 1, b = 0, d0 = d); None for a law given as an arbitrary elastic function."""
    if isinstance(law, KelvinVoigt):
        return np.array([law.stiffness, 1.0, 0.0, law.damping_ns_per_m, diag_a])
    if not law.is_power_law:
        return None
    return np.array([law.stiffness, law.exponent, law.damping, 0.0, diag_a])


def run_ball(s: BallOnPlate, mode: str, settings: RunSettings) -> ImpactRecord:
    """Ball-on-plate in MJX; the same model, modes and end rule as MuJoCo's ``run_ball``."""
    setup = _ball_setup(s, mode, settings)
    if isinstance(setup, ImpactRecord):
        return setup
    sim = _MjxSim(setup.model, setup.data, setup.control, setup.params, BALL_CHUNK)
    out = drive(sim, setup.n_max, setup.first, setup.chunk, ball_end_finder())
    setup.meta.update(steps=sim.steps, stepping="lax.scan")
    return ball_outcome_record(s, out, setup.dt, setup.gap, setup.meta)


@dataclass
class _BallSetup:
    """A ball run set up and planned (:func:`_ball_setup`), before its first step."""

    model: Any
    data: Any
    control: str
    params: np.ndarray
    meta: dict[str, Any]
    dt: float
    gap: float
    n_max: int
    first: int
    chunk: int
    mjcf: str


def _ball_setup(s: BallOnPlate, mode: str, settings: RunSettings) -> _BallSetup | ImpactRecord:
    """The model, start and drive plan of a ball run (its record when it cannot run)."""
    dt = float(settings.timestep_s or BALL_TIMESTEP_S)
    built = _ball_contact(s, mode, settings, dt)
    if isinstance(built, ImpactRecord):
        return built
    gap, n_max, first, chunk = ball_start(s, mode, settings, built.data, dt, built.t_est_s,
                                          BALL_CHUNK)
    built.meta["phase"] = ball_phase(settings.phase)
    return _BallSetup(built.model, built.data, built.control, built.params, built.meta, dt,
                      gap, n_max, first, chunk, built.mjcf)


@dataclass
class _BallContact:
    """The ball's model with a mode's contact (:func:`_ball_contact`), its state not yet
    set: the head-on ball's and the bounce's."""

    model: Any
    data: Any
    control: str
    """The scan's per-step control (:data:`CONTROLS`): ``secant`` injected, else ``none``."""
    params: np.ndarray
    meta: dict[str, Any]
    t_est_s: float
    """The contact duration (s) a run is planned with."""
    mjcf: str


def _ball_contact(s: BallOnPlate, mode: str, settings: RunSettings, dt: float
                  ) -> _BallContact | ImpactRecord:
    """The ball's model at step ``dt`` (s) with ``mode``'s contact: MuJoCo's
    (:func:`~impactbench.engines.mujoco_adapter.ball_contact`), or injected's law written
    into the solref inside the scan (its ``unsupported`` record for a law that cannot be)."""
    user = custom_parameters(settings.params or {}) if mode == "custom" else {}
    out_of_box = mode in ("default", "custom")
    integrator = str(user.get("integrator", settings.options.get("integrator", "Euler")))
    model, data, a = _ball_model(s, dt, integrator, out_of_box)
    meta: dict[str, Any] = {"integrator": integrator, "efc_diagA": a, "chunk_steps": BALL_CHUNK}
    control, params = "none", np.zeros(5)
    if mode == "injected":
        t_est = hertz_duration_s(s, s.velocity_m_s)
        injected = injected_parameters(s.law(), a)
        if injected is None:
            return ImpactRecord.failed(
                Status.UNSUPPORTED, "mjx: injected needs a power-law or linear contact law "
                "(an arbitrary elastic function cannot run inside the compiled step)")
        control, params = "secant", injected
        set_contact(model, (0.0, 0.0), SOLIMP)
        meta.update(law=s.model, solimp=list(SOLIMP))
    else:
        t_est = ball_contact(s, mode, settings, model, dt, a, user, meta)
    return _BallContact(model, data, control, params, meta, t_est,
                        ball_mjcf(s, dt, integrator, engine_defaults=out_of_box))


def run_ball_batch(items: Sequence[tuple[BallOnPlate, str, RunSettings]]) -> list[ImpactRecord]:
    """Many ball runs in one compiled call per model: worlds whose models differ only in the
    contact's geom solref and solimp (a tuner's candidates, at any velocities) step together,
    one ``vmap`` over worlds of the same :data:`BALL_CHUNK`-step scan that :func:`run_ball`
    takes, each world driven by its own :func:`drive` plan and end rule. Each record is the
    one :func:`run_ball` gives: the same steps bit for bit (a vmapped step is the same
    arithmetic; tested)."""
    out: list[ImpactRecord | None] = [None] * len(items)
    groups: dict[tuple, list[tuple[int, _BallSetup]]] = {}
    for i, (s, mode, settings) in enumerate(items):
        setup = _ball_setup(s, mode, settings)
        if isinstance(setup, ImpactRecord):
            out[i] = setup
        else:
            key = (setup.mjcf, setup.control, setup.params.tobytes())
            groups.setdefault(key, []).append((i, setup))
    for group in groups.values():
        sims = _BatchWorlds([setup for _, setup in group]).run()
        for (i, setup), (sim, outcome) in zip(group, sims, strict=True):
            setup.meta.update(steps=sim.steps, stepping="lax.scan")
            out[i] = ball_outcome_record(items[i][0], outcome, setup.dt, setup.gap, setup.meta)
    return [r for r in out if r is not None]


class _BatchWorlds:
    """Worlds of one model but their contact's solref and solimp, stepped together one scan
    chunk (:data:`BALL_CHUNK` steps) at a time."""

    def __init__(self, setups: Sequence[_BallSetup]) -> None:
        _, jax, mjx = _mjx()
        jnp = jax.numpy
        self.setups = list(setups)
        first = self.setups[0]
        self.mx = mjx.put_model(first.model)
        forward = _compiled_forward()
        datas = [forward(self.mx, mjx.put_data(st.model, st.data)) for st in self.setups]
        self.dx = jax.tree_util.tree_map(lambda *xs: jnp.stack(xs), *datas)
        self.solref = jnp.asarray(np.stack([st.model.geom_solref for st in self.setups]))
        self.solimp = jnp.asarray(np.stack([st.model.geom_solimp for st in self.setups]))
        self.params = first.params
        self.scan = _batched_chunk(BALL_CHUNK, first.control)

    def step(self, n: int) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
        """``n`` steps (a multiple of :data:`BALL_CHUNK`) of every world: its samples."""
        parts = []
        for _ in range(n // BALL_CHUNK):
            self.dx, (q, v, f) = self.scan(self.mx, self.dx, self.solref, self.solimp,
                                           self.params)
            parts.append((np.asarray(q), np.asarray(v), np.asarray(f)))
        qs, vs, fs = (np.concatenate(a, axis=1) for a in zip(*parts, strict=True))
        return [(qs[k], vs[k], fs[k]) for k in range(len(self.setups))]

    def run(self) -> list[tuple[Any, Any]]:
        return drive_many([functools.partial(_plan, st) for st in self.setups], self.step,
                          BALL_CHUNK)


def _plan(setup: _BallSetup, world: Any) -> Any:
    return driving(world, setup.n_max, setup.first, setup.chunk, ball_end_finder())


@functools.lru_cache(maxsize=4)
def _batched_chunk(length: int, control: str) -> Any:
    """:func:`_compiled_scan`'s chunk of ``length`` steps, ``vmap``-ed over worlds: each
    world's data and its contact's geom solref and solimp (the model otherwise shared)."""
    _, jax, _ = _mjx()
    scan = _compiled_scan(0)

    def one(mx: Any, dx: Any, solref: Any, solimp: Any, p: Any) -> Any:
        return scan(mx.replace(geom_solref=solref, geom_solimp=solimp), dx, p, length, control)

    return jax.jit(jax.vmap(one, in_axes=(None, 0, 0, 0, None)))


def run_rigid_flexible(s: RigidFlexible, mode: str, settings: RunSettings) -> ImpactRecord:
    """Rigid–flexible 2-DOF impact in MJX (native and tuned); see the module docstring."""
    mujoco = _mjx()[0]
    dt = float(settings.timestep_s or RIGID_FLEXIBLE_TIMESTEP_S)
    model = mujoco.MjModel.from_xml_string(rigid_flexible_mjcf(s, dt))
    data = mujoco.MjData(model)
    a = measured_diag_a(model, data, (1e-9, 0.0))
    structure = s.structural_law()
    beta = s.beta_n_per_m3 if s.structure == "softening" else 0.0
    meta: dict[str, Any] = {"efc_diagA": a, "face_radius_m": face_radius_m(s),
                            "chunk_steps": RIGID_FLEXIBLE_CHUNK}
    meta.update(native_or_tuned(model, mode, settings, (-s.k1_n_per_m * a, 0.0)))
    if mode == "native":
        meta.update(stiffness_n_per_m=s.k1_n_per_m, damping_ns_per_m=0.0)
    v1 = s.velocity_m_s
    gap = GAP_STEPS * v1 * dt
    data.qpos[:] = (-gap, 0.0)
    data.qvel[:] = (v1, 0.0)
    n_max = math.ceil((settings.max_time_s or s.max_time_s) / dt)
    collapsed: list[int] = []
    sim = _MjxSim(model, data, "cubic" if beta else "none", np.array([beta]),
                  RIGID_FLEXIBLE_CHUNK)
    out = drive(sim, n_max, RIGID_FLEXIBLE_CHUNK, RIGID_FLEXIBLE_CHUNK,
                rigid_flexible_end_finder(s, structure, collapsed))
    meta.update(steps=sim.steps, stepping="lax.scan")
    return rigid_flexible_record(s, structure, out, dt, gap, meta, collapsed)


def run_bounce(scenario: Bounce, mode: str, settings: RunSettings) -> ImpactRecord:
    """The bounce to rest in MJX: MuJoCo's bounce (:func:`~impactbench.engines.
    mujoco_adapter.run_bounce`: the head-on ball's model and contact for ``mode`` at the
    first impact, released from rest ``height_m`` above the plane, the same end rule and
    record), stepped by MJX in the ball's compiled :data:`BALL_CHUNK`-step scans (compiled
    once per process, shared with the ball; the steps past the end are cut off)."""
    dt = float(settings.timestep_s or BOUNCE_TIMESTEP_S)
    built = _ball_contact(scenario.ball(), mode, settings, dt)
    if isinstance(built, ImpactRecord):
        return built
    end, find_end, n_max, first, chunk = bounce_start(scenario, built.data, dt, settings,
                                                      BALL_CHUNK)
    sim = _MjxSim(built.model, built.data, built.control, built.params, BALL_CHUNK)
    out = drive(sim, n_max, first, chunk, find_end)
    built.meta["stepping"] = "lax.scan"
    return bounce_record(scenario, out, end, find_end, dt, built.meta)


# --------------------------------------------------------------------------- batches


def ball_batch(s: BallOnPlate, solrefs: Sequence[Sequence[float]], timestep_s: float,
               steps: int, solimp: Sequence[float] = SOLIMP
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Many contact parameter sets for one ball impact in one compiled call (``vmap``).

    Every world starts 2.5 steps above the plate at −V0 and runs ``steps`` steps with its own
    geom solref (MuJoCo's convention, e.g. direct (−K·A, −D·A)). Returns (gap (m), gap rate (m/s),
    contact force (N)), each shaped (worlds, steps): the pre-step state and the force over each
    step. Build :class:`ImpactRecord`s from them as :func:`run_ball` does, or read the final
    velocity for a restitution.
    """
    _, jax, mjx = _mjx()
    jnp = jax.numpy
    model, data, _ = _ball_model(s, timestep_s)
    model.geom_solimp[:] = solimp
    data.qpos[0], data.qvel[0] = GAP_STEPS * s.velocity_m_s * timestep_s, -s.velocity_m_s
    mx = mjx.put_model(model)
    dx = _compiled_forward()(mx, mjx.put_data(model, data))
    refs = jnp.asarray(np.asarray(solrefs, dtype=float).reshape(-1, 2))
    return tuple(np.asarray(a) for a in _batched_scan()(mx, dx, refs, steps))


@functools.lru_cache(maxsize=1)
def _batched_scan() -> Any:
    _, jax, _ = _mjx()
    jnp = jax.numpy
    scan = _compiled_scan(0)

    def one(mx: Any, dx: Any, solref: Any, steps: int) -> Any:
        mx = mx.replace(geom_solref=jnp.broadcast_to(solref, mx.geom_solref.shape))
        _, (q, v, f) = scan(mx, dx, jnp.zeros(1), steps, "none")
        return q[:, 0], v[:, 0], f

    return jax.jit(jax.vmap(one, in_axes=(None, None, 0, None)), static_argnames=("steps",))


# --------------------------------------------------------------------------- oblique impact


OBLIQUE_CHUNK = 512
"""Steps per compiled scan for the oblique impact (one chunk covers the paper's ball)."""
MJX_OBLIQUE_KEYS: tuple[str, ...] = tuple(k for k in OBLIQUE_KEYS if k != "noslip_iterations")
"""The oblique ``custom`` keys MJX applies: MuJoCo's but ``noslip_iterations`` (MJX has no
noslip solver; it would ignore the setting)."""


def _pair_secant_control(mx: Any, dx: Any, p: Any) -> tuple[Any, Any]:
    """The oblique injected law at the step's start (:func:`_secant_solref`), written into
    the contact pair's solref; p = (c, n, b, d0, A, R) (free joint: the penetration is
    R − z)."""
    solref = _secant_solref(p, p[5] - dx.qpos[2])
    return mx.replace(pair_solref=mx.pair_solref.at[0].set(solref)), dx


CONTROLS["pair_secant"] = _pair_secant_control


@dataclass
class _MjxObliqueSim(_MjxSim):
    """:class:`_MjxSim` keeping the whole contact sensor (a 2-D force array)."""

    sensor_width: ClassVar[int] = OBLIQUE_SENSOR_WIDTH


def run_oblique(s: Any, mode: str, settings: RunSettings) -> ImpactRecord:
    """The oblique impact in MJX: MuJoCo's model and modes (:func:`~impactbench.engines.
    mujoco_adapter.prepare_oblique`), stepped in compiled scans; injected writes the law's
    secant into the contact pair's solref inside the scan."""
    dt = float(settings.timestep_s or OBLIQUE_TIMESTEP_S)
    model, data, meta, _ = prepare_oblique(s, mode, settings, engine="mjx")
    control, params = "none", np.zeros(6)
    if mode == "injected":
        injected = injected_parameters(s.normal_scenario().law(), meta["normal_compliance"])
        if injected is None:
            return ImpactRecord.failed(
                Status.UNSUPPORTED, "mjx: injected needs a power-law or linear contact law "
                "(an arbitrary elastic function cannot run inside the compiled step)")
        control, params = "pair_secant", np.append(injected, s.radius_m)
    meta["chunk_steps"] = OBLIQUE_CHUNK
    n_max, first, chunk = oblique_start(s, mode, settings, meta, data, dt, OBLIQUE_CHUNK)
    sim = _MjxObliqueSim(model, data, control, params, OBLIQUE_CHUNK)
    out = drive(sim, n_max, first, chunk, oblique_end_finder(s.radius_m))
    meta.update(steps=sim.steps, stepping="lax.scan")
    return oblique_outcome_record(s, out, dt, meta)


# --------------------------------------------------------------------------- the adapter


class MjxAdapter(Adapter):
    """MJX (pip ``mujoco-mjx`` and ``jax``): MuJoCo's contact in JAX, both scenarios."""

    name = "mjx"
    value_check = staticmethod(mujoco_custom_parameters)
    pip = "pip install mujoco-mjx jax"
    injection = ("the law through MuJoCo's soft-contact solver in MJX: a direct solref written "
                 "into geom_solref inside the compiled step, the law's secant stiffness and "
                 "damping at the start state (Euler); oblique: into the contact pair's solref, "
                 "with Coulomb friction through the elliptic cone as MuJoCo's (impratio 1e4, "
                 "direct solreffriction)")
    modes = ("native", "injected", "tuned", "default", "custom")
    parameter_keys = PARAMETER_KEYS + MJX_OBLIQUE_KEYS
    tuned_parameters = MujocoAdapter.tuned_parameters
    builders: ClassVar[dict[str, Builder]] = {
        **MujocoAdapter.builders,
        "ball-on-plate": Builder("run_ball", BALL_TIMESTEP_S, parameter_keys=PARAMETER_KEYS,
                                 batch="run_ball_batch"),  # MuJoCo's, batched
        "rigid-flexible": Builder(
            "run_rigid_flexible", RIGID_FLEXIBLE_TIMESTEP_S, modes=("native", "tuned"),
            why_not={"injected": "rigid–flexible needs the local law's memory updated "
                                 "between steps, which a compiled scan cannot call"}),
        "cube-toss": cube_toss_builder("mjx"),
        "bounce": Builder("run_bounce", BOUNCE_TIMESTEP_S, parameter_keys=PARAMETER_KEYS),
    }
    # builders only build (Adapter.run has checked the mode, the keys and the tuned file)
    run_ball = staticmethod(run_ball)
    run_ball_batch = staticmethod(run_ball_batch)
    run_rigid_flexible = staticmethod(run_rigid_flexible)
    run_oblique = staticmethod(run_oblique)
    run_bounce = staticmethod(run_bounce)

    def version(self) -> str:
        from importlib.metadata import version

        mujoco, jax, _ = _mjx()
        return f"{version('mujoco-mjx')} (mujoco {mujoco.__version__}, jax {jax.__version__})"
