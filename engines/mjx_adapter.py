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
end rule, its record the lone run's bit for bit), and so do rigid–flexible runs
(:func:`run_rigid_flexible_batch`); :func:`ball_batch` is the raw fixed-length form (the
benchmarks').

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

Stepping: a run steps exactly the steps its plan asks for, in calls of one compiled loop over
``mjx.step`` (:func:`_stepper`: a ``fori_loop`` whose step count is a run-time argument, at
most :data:`BALL_CHUNK`, :data:`RIGID_FLEXIBLE_CHUNK` or :data:`OBLIQUE_CHUNK` steps a call;
a Python loop over a jitted step manages ~170 steps/s, the loop ~30k). One loop serves every
run of a model tree — the ball's modes, steps and velocities share one, the pair's structures
share one (a per-step control that leaves the model's values untouched where it is off: the
injected secant solref, the softening structure's cubic term β·x2³ in ``qfrc_applied``) — so
each is traced once per process and compiled once per machine (jax's persistent cache). The
model and data go in as flat leaves (the model's rebuilt from the MjModel, one
``put_model`` per MJCF: :class:`_Template`), the first step from ``put_data``'s state (its own
forward computes the rest). A run's cap is its plan's, rounded up to whole 512-step (2048:
rigid–flexible) scans (:func:`step_cap`), as MJX's fixed-length scans once made it, so its
records are the ones those scans gave, bit for bit (tested). Sample k is the state at the
start of step k and MuJoCo's ``contact`` sensor (the normal force acting over step k), exactly
as in the MuJoCo adapter, whose end-of-impact rules and drive
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
:mod:`impactbench.engines.mujoco_adapter`), stepped by MJX in the ball's compiled loop: the
7500 steps of the 15 s cap at 2 ms take ~0.25 s once compiled. Its records equal C MuJoCo's
to round-off (tests), which grows from bounce to bounce in a long bouncing run (the step a
contact starts at amplifies it).
"""

from __future__ import annotations

import contextlib
import functools
import io
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
from impactbench.engines.compile_caches import impactbench_jax_dir
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
    oblique_mjcf,
    oblique_outcome_record,
    oblique_start,
    pair_plan,
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
"""The most steps one compiled call takes for the ball (and the bounce), and the whole scans
its cap is rounded up to (:func:`step_cap`: MJX once stepped 512-step scans only)."""
RIGID_FLEXIBLE_CHUNK = 2048
""":data:`BALL_CHUNK` of the rigid–flexible model."""
BATCH_WORLDS = 128
"""Worlds of one ``vmap`` (:class:`_BatchWorlds`), spare places filled: one world count, so
one compiled batch loop (each count is its own compile, and its own trace in every
process). On this CPU a 128-world step costs about 12 lone ball steps (~2.9 µs a world for
~31 µs alone)."""
BATCH_MIN_WORLDS = 16
"""The fewest worlds :func:`run_ball_batch` steps as one ``vmap``: a smaller group runs one
by one (a :data:`BATCH_WORLDS`-wide step costs about 12 lone steps)."""
MIN_CHUNK = 64
"""The fewest steps a run asks for after its first look for the end (the plan's chunk is at
least this): a compiled call costs about as much as 20–30 ball steps besides its steps."""
COMPILE_CACHE_DIR = impactbench_jax_dir()
"""jax's persistent compilation cache, unless ``JAX_COMPILATION_CACHE_DIR`` sets another: the
compile of each loop (5–20 s on this machine) happens once per machine, not once per process
(a process still traces each loop it uses, ~1 s). XLA's own flags were measured for a shorter
first compile and left at their defaults: ``--xla_cpu_use_fusion_emitters=false`` makes the
cube tosses' first default-mode replay, compile included, ×0.80 as long (medians of 3
alternated, empty caches: 14.3 s against 17.8 s) with their poses bit for bit, but moves
MJX's ball and oblique records by one unit in the last place (175 of the default report's
8037 rows); ``--xla_llvm_disable_expensive_passes`` gives the same bits and no gain;
``--xla_backend_optimization_level=0`` makes the cube tosses' first replay, compile included,
2.6× as long (168 s against 64 s)."""


WARP_BACKEND = "mujoco.mjx.third_party.mujoco_warp"
"""MJX's bundled MuJoCo Warp (its ``impl="warp"`` backend, for NVIDIA GPUs): importing
``mujoco.mjx`` imports it where ``warp`` is installed (Newton's), defining its Warp kernels,
~4 s of every process's first MJX use; this adapter runs MJX's JAX backend on the CPU, which
never calls it, so :func:`_mjx` imports MJX without it (unless it is already imported)."""


@functools.lru_cache(maxsize=1)
def _mjx() -> tuple[Any, Any, Any]:
    """(mujoco, jax, mujoco.mjx) with 64-bit floats on; EngineUnavailable if missing."""
    try:
        import jax
        import mujoco
        _import_mjx_without_warp()
        from mujoco import mjx
    except ImportError as exc:
        raise EngineUnavailable("mjx", str(exc)) from exc
    jax.config.update("jax_enable_x64", True)
    if not jax.config.jax_compilation_cache_dir:  # keep compiled scans across processes
        jax.config.update("jax_compilation_cache_dir", str(COMPILE_CACHE_DIR))
    return mujoco, jax, mjx


def _import_mjx_without_warp() -> None:
    """Import ``mujoco.mjx`` with :data:`WARP_BACKEND` held off: MJX catches the ImportError
    (it prints one line, kept from stdout here) and leaves its Warp backend unset. Nothing
    is held off where MJX or that module is already imported."""
    import sys

    if "mujoco.mjx" in sys.modules or WARP_BACKEND in sys.modules:
        return
    sys.modules[WARP_BACKEND] = None  # type: ignore[assignment]  # import raises ImportError
    try:
        with contextlib.redirect_stdout(io.StringIO()):
            import mujoco.mjx  # noqa: F401
    finally:
        if sys.modules.get(WARP_BACKEND, 0) is None:
            del sys.modules[WARP_BACKEND]


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


def _ball_control(mx: Any, dx: Any, p: Any) -> tuple[Any, Any]:
    """The ball's per-step control, p = (on, c, n, b, d0, A): with ``on`` (injected), the
    law's direct solref (:func:`_secant_solref`) at the step's start on every geom (slide
    joint: the penetration is −q); without, the model's own solref, untouched (a select
    of its very values: the other modes' step, bit for bit). One control for every mode,
    so that one compiled loop serves them all."""
    jnp = _mjx()[1].numpy
    secant = jnp.broadcast_to(_secant_solref(p[1:], -dx.qpos[0]), mx.geom_solref.shape)
    return mx.replace(geom_solref=jnp.where(p[0] > 0.0, secant, mx.geom_solref)), dx


def ball_parameters(injected: np.ndarray | None = None) -> np.ndarray:
    """:func:`_ball_control`'s p: (1, the law's (c, n, b, d0, A)) for injected's
    (:func:`injected_parameters`), else off (zeros)."""
    return np.zeros(6) if injected is None else np.append(1.0, injected)


def _pair_control(mx: Any, dx: Any, p: Any) -> tuple[Any, Any]:
    """The rigid–flexible per-step control, p = (β,): the softening structure's cubic term
    +β·x2³ on joint 2; with β = 0 (a linear structure) the applied force untouched (a
    select of its very value), so that one compiled loop serves both structures."""
    jnp = _mjx()[1].numpy
    cubic = jnp.where(p[0] != 0.0, p[0] * dx.qpos[1] ** 3, dx.qfrc_applied[1])
    return mx, dx.replace(qfrc_applied=dx.qfrc_applied.at[1].set(cubic))


CONTROLS = {"none": _no_control, "ball": _ball_control, "pair": _pair_control}
"""Per-step changes applied inside the scan before each ``mjx.step``."""


@functools.lru_cache(maxsize=2)
def _compiled_scan(sensor_width: int) -> Any:
    """``scan(mx, dx, p, length, control) → (dx, (qpos, qvel, force))``, jitted, for the raw
    batch (:func:`ball_batch`); the force per step is the contact sensor's first value (the
    normal force), or with ``sensor_width`` its first that many. The adapter's runs step in
    :func:`_stepper`'s calls (the same step, bit for bit: tested)."""
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
    """``mjx.forward``, jitted (on the pytrees)."""
    _, jax, mjx = _mjx()
    return jax.jit(mjx.forward)


@functools.lru_cache(maxsize=16)
def _stepper(mtree: Any, dtree: Any, sensor_width: int, control: str, capacity: int,
             batched: tuple[int, ...] | None = None) -> Any:
    """``step(m, d, p, n) → (d, (qpos, qvel, force))``, jitted: ``n`` ≤ ``capacity`` steps
    (``n`` a run-time count, so one compile serves every count) of ``mjx.step`` with the
    per-step ``control`` (:data:`CONTROLS`) from the model and data given as the flat leaves
    of their trees ``mtree``, ``dtree`` (passing the mjx dataclasses to a jitted call costs
    milliseconds of Python per call; their leaves do not). Sample k is the state at the
    start of step k and the contact sensor's first value (the normal force) or first
    ``sensor_width`` values after it, in rows of buffers of ``capacity`` rows (the rows from
    ``n`` on are zeros). ``batched``: ``vmap``-ed over worlds — each world's data, control
    parameters and model leaves at those indices, ``step(m, m_worlds, d_worlds, p_worlds,
    n)``."""
    _, jax, mjx = _mjx()
    jnp = jax.numpy
    tree = jax.tree_util
    change = CONTROLS[control]

    def run(m_leaves: Any, d_leaves: Any, p: Any, n: Any) -> Any:
        mx = tree.tree_unflatten(mtree, m_leaves)
        dx = tree.tree_unflatten(dtree, d_leaves)
        width = (sensor_width,) if sensor_width else ()
        bufs = (jnp.zeros((capacity, *dx.qpos.shape), dx.qpos.dtype),
                jnp.zeros((capacity, *dx.qvel.shape), dx.qvel.dtype),
                jnp.zeros((capacity, *width), dx.sensordata.dtype))

        def body(i: Any, carry: Any) -> Any:
            dx, (qs, vs, fs) = carry
            mx_k, dx = change(mx, dx, p)
            q, v = dx.qpos, dx.qvel
            dx = mjx.step(mx_k, dx)
            # the contact sensor of the step just taken
            f = dx.sensordata[:sensor_width] if sensor_width else dx.sensordata[0]
            return dx, (qs.at[i].set(q), vs.at[i].set(v), fs.at[i].set(f))

        dx, bufs = jax.lax.fori_loop(0, n, body, (dx, bufs))
        return tree.tree_leaves(dx), bufs

    key = (_tree_key(mtree), _tree_key(dtree), sensor_width, control, capacity, batched)
    if batched is None:
        return _Loop(jax.jit(run), key)

    def world(m_leaves: Any, m_world: Any, d_leaves: Any, p: Any, n: Any) -> Any:
        leaves = list(m_leaves)
        for i, leaf in zip(batched, m_world, strict=True):
            leaves[i] = leaf
        return run(leaves, d_leaves, p, n)

    return _Loop(jax.jit(jax.vmap(world, in_axes=(None, 0, 0, 0, None))), key)


EXPORT_LOOPS = True
"""Keep each compiled loop's traced program on disk (:class:`_Loop`), so that a process
loads it (~0.3 s) instead of tracing and lowering ``mjx.step`` again (~1–1.5 s a loop)."""
LOOPS_DIR = COMPILE_CACHE_DIR / "mjx-loops"
"""Where :class:`_Loop` keeps the traced programs (``jax.export``'s serialized form), one file per
loop, named by a hash of everything that shapes the program."""


class _Loop:
    """A compiled loop (:func:`_stepper`'s), its program traced once per machine: on the
    first call, the ``jax.export`` of the jitted loop for these argument shapes is loaded
    from :data:`LOOPS_DIR` or made and kept there, and every call runs it (``jax.jit`` of
    its ``call``: the same StableHLO, compiled through jax's persistent cache; the records
    are the plain jitted loop's, bit for bit, tested). The file's name hashes the loop's
    key (the model and data trees, static parts and all, the control, the capacity, the
    batched leaves), the arguments' shapes and dtypes, the versions of jax, jaxlib, mujoco
    and mujoco-mjx and this module's source. Should anything of that fail, the plain
    jitted loop runs (traced in this process)."""

    def __init__(self, jitted: Any, key: tuple[Any, ...] | None) -> None:
        self.jitted = jitted
        self.key = key
        self.run: Any = None

    def __call__(self, *args: Any) -> Any:
        if self.run is None:
            self.run = (_exported(self.jitted, self.key, args) if EXPORT_LOOPS else None) \
                or self.jitted
        return self.run(*args)


def _exported(jitted: Any, key: tuple[Any, ...] | None, args: tuple[Any, ...]) -> Any:
    """``jax.jit`` of the exported ``jitted`` for ``args``' shapes, kept in
    :data:`LOOPS_DIR` in ``jax.export``'s own serialized form (:class:`_Loop`); None where
    it cannot be."""
    import hashlib
    import tempfile

    _, jax, _ = _mjx()
    if key is None:
        return None
    try:
        from jax import export

        specs = jax.tree_util.tree_map(
            lambda x: jax.ShapeDtypeStruct(np.shape(x), np.asarray(x).dtype), args)
        name = hashlib.sha256(repr((_versions(), key, [
            (s.shape, str(s.dtype)) for s in jax.tree_util.tree_leaves(specs)])).encode())
        path = LOOPS_DIR / f"{name.hexdigest()}.jaxexport"
        try:
            exp = export.deserialize(bytearray(path.read_bytes()))
        except Exception:  # not there yet (or unreadable): trace it and keep it
            exp = export.export(jitted)(*specs)
            LOOPS_DIR.mkdir(parents=True, exist_ok=True)
            with tempfile.NamedTemporaryFile(dir=LOOPS_DIR, delete=False) as f:
                f.write(exp.serialize(vjp_order=0))
            os.replace(f.name, path)
        return jax.jit(exp.call)
    except Exception:  # no export here (another jax): the plain jitted loop
        return None


@functools.lru_cache(maxsize=1)
def _versions() -> tuple[str, ...]:
    """What a kept loop's program depends on besides its key: the versions of jax, jaxlib,
    mujoco and mujoco-mjx, and this module's source."""
    import hashlib
    from importlib.metadata import version

    mujoco, jax, _ = _mjx()
    return (jax.__version__, version("jaxlib"), mujoco.__version__, version("mujoco-mjx"),
            hashlib.sha256(Path(__file__).read_bytes()).hexdigest())


def _tree_key(tree: Any) -> str | None:
    """A stable description of a pytree's structure, static parts and all (the mjx
    dataclasses' static fields, their arrays by content); None where some static part has
    no stable description (then the loop is not kept)."""
    def norm(x: Any) -> Any:
        array = getattr(x, "array", x)  # mjx wraps static arrays for hashing
        if isinstance(array, np.ndarray):
            return ("array", array.dtype.str, array.shape, array.tobytes().hex())
        if isinstance(x, tuple | list):
            return tuple(norm(v) for v in x)
        if isinstance(x, dict):
            return tuple(sorted((repr(k), norm(v)) for k, v in x.items()))
        text = repr(x)
        if " at 0x" in text:
            raise ValueError(text)
        return f"{type(x).__qualname__}:{text}"

    def walk(t: Any) -> Any:
        data = t.node_data()
        head = None if data is None else (f"{data[0].__module__}.{data[0].__qualname__}",
                                          norm(data[1]))
        return (head, tuple(walk(c) for c in t.children()))

    try:
        return repr(walk(tree))
    except Exception:
        return None


@dataclass
class _Template:
    """One MJCF's compiled model in MJX's form, flat (:func:`_template`): the tree of
    ``mjx.put_model`` (its hfield-only static bound zeroed where the model has no height
    field, so that models differing only in sizes share one compiled step) and of
    ``mjx.put_data``, where each model leaf comes from in the MjModel, and the data leaves
    of a fresh MjData. ``exact`` when rebuilding the leaves from the filling model and its
    run's data reproduced ``put_model``'s and ``put_data``'s exactly (checked once, when the
    template is made); otherwise every run goes through ``put_model``/``put_data``."""

    mtree: Any
    dtree: Any
    sources: list[tuple[str, ...] | None]
    """Per model leaf, its attribute path in the MjModel (None: a constant of the MJCF,
    taken from ``m_leaves``)."""
    m_leaves: list[Any]
    d_leaves: list[Any]
    qpos: int
    qvel: int
    widened: list[int] = field(default_factory=list)
    """The data leaves of :data:`WIDENED`."""
    exact: bool = True

    def model_leaves(self, model: Any) -> list[Any]:
        """``model``'s leaves (a model compiled from this template's MJCF, changed since in
        its leaf fields only: the contact parameters)."""
        if not self.exact:
            return _host(_put_model(model)[1])
        out = []
        for src, ref in zip(self.sources, self.m_leaves, strict=True):
            if src is None:
                out.append(ref)
                continue
            obj = model
            for name in src:
                obj = getattr(obj, name)
            out.append(np.array(obj, dtype=ref.dtype).reshape(ref.shape))
        return out

    def leaf(self, model: Any, i: int) -> np.ndarray:
        """``model``'s leaf ``i`` (:meth:`model_leaves`' ``i``-th)."""
        src, ref = self.sources[i], self.m_leaves[i]
        if src is None or not self.exact:
            return self.model_leaves(model)[i]
        obj = model
        for name in src:
            obj = getattr(obj, name)
        return np.array(obj, dtype=ref.dtype).reshape(ref.shape)

    def data_leaves(self, model: Any, data: Any) -> list[Any]:
        """``mjx.put_data(model, data)``'s leaves for a ``data`` reset but for its qpos and
        qvel (every run's start): the fresh data's with those two."""
        if not self.exact:
            return _host(_mjx()[1].tree_util.tree_leaves(_mjx()[2].put_data(model, data)))
        out = list(self.d_leaves)
        out[self.qpos] = np.array(data.qpos)
        out[self.qvel] = np.array(data.qvel)
        return out

    def initial(self, model: Any, data: Any) -> list[Any]:
        """The data leaves the first step starts from: ``put_data``'s (:meth:`data_leaves`),
        the leaves of :data:`WIDENED` 64-bit. No ``mjx.forward`` first: a step's own forward
        recomputes every derived field from the state before it reads it (the same records
        bit for bit, tested), and a separate forward would be traced anew in every process
        (2–3 s each model structure)."""
        out = self.data_leaves(model, data)
        for i in self.widened:
            out[i] = np.asarray(out[i]).astype(np.int64)
        return out

    def index(self, *path: str) -> int:
        """The model leaf at attribute ``path``."""
        return self.sources.index(path)


def _put_model(model: Any) -> tuple[Any, list[Any], list[tuple[str, ...] | None]]:
    """``mjx.put_model(model)`` flat: (tree, leaves, each leaf's attribute path in the
    MjModel or None), the hfield-only static bound ``geom_rbound_hfield`` zeroed when the
    model has no height field (MJX reads it for height-field collisions only, at trace
    time: it is part of the tree, so sphere radii would otherwise each compile anew)."""
    _, jax, mjx = _mjx()
    mx = mjx.put_model(model)
    if model.nhfield == 0:
        bound = mx._impl.geom_rbound_hfield
        mx = mx.replace(_impl=mx._impl.replace(geom_rbound_hfield=np.zeros_like(bound)))
    with_paths, mtree = jax.tree_util.tree_flatten_with_path(mx)
    sources: list[tuple[str, ...] | None] = []
    for path, _ in with_paths:
        names = tuple(getattr(k, "name", None) for k in path)
        if None in names or names[0] in ("_impl", "_sizes"):
            sources.append(None)  # derived by put_model: a constant of the MJCF
        elif names[:2] == ("opt", "_impl"):
            sources.append(("opt", *names[2:]))  # MjOption's o_margin, o_solref, …
        else:
            sources.append(names)
    return mtree, [leaf for _, leaf in with_paths], sources


WIDENED = ("._impl.contact.geom1", "._impl.contact.geom2", "._impl.contact.geom")
"""The data leaves ``mjx.put_data`` gives as int32 and a step returns as int64 (64-bit
mode): widened before the first step, so that the loop's carry keeps one type (a step
overwrites them: the contact's geoms)."""
_TEMPLATES: dict[str, _Template] = {}
TEMPLATES_KEPT = 64
"""How many MJCFs' templates (:func:`_template`) a process keeps."""


def _template(model: Any, data: Any, mjcf: str) -> _Template:
    """The flat MJX form of the models compiled from ``mjcf`` (:class:`_Template`), made from
    ``model`` and checked against ``put_model``/``put_data`` of it and of ``data`` on first
    use."""
    found = _TEMPLATES.get(mjcf)
    if found is not None:
        return found
    mujoco, jax, mjx = _mjx()
    mtree, m_leaves, sources = _put_model(model)
    d_paths, dtree = jax.tree_util.tree_flatten_with_path(
        mjx.put_data(model, mujoco.MjData(model)))
    names = [jax.tree_util.keystr(p) for p, _ in d_paths]
    made = _Template(mtree, dtree, sources, _host(m_leaves), _host(leaf for _, leaf in d_paths),
                     names.index(".qpos"), names.index(".qvel"),
                     [names.index(n) for n in WIDENED if n in names])
    want = jax.tree_util.tree_leaves(mjx.put_data(model, data))
    made.exact = _same_leaves(made.model_leaves(model), m_leaves) and \
        _same_leaves(made.data_leaves(model, data), want)
    if len(_TEMPLATES) >= TEMPLATES_KEPT:
        _TEMPLATES.pop(next(iter(_TEMPLATES)))
    _TEMPLATES[mjcf] = made
    return made


def _host(leaves: Any) -> list[np.ndarray]:
    """Leaves as host (numpy) arrays. Every compiled call takes numpy arrays only: jax
    compiles a call anew for another mix of device and host arguments (their placement is
    part of the executable's key), so device outputs are brought back before they go in
    again (on the CPU, no copy of substance)."""
    return [np.asarray(leaf) for leaf in leaves]


def _same_leaves(a: Sequence[Any], b: Sequence[Any]) -> bool:
    """Leaf lists equal in dtype, shape and every value (NaN equal to NaN)."""
    return len(a) == len(b) and all(
        np.asarray(x).dtype == np.asarray(y).dtype and np.asarray(x).shape == np.asarray(y).shape
        and np.array_equal(np.asarray(x), np.asarray(y), equal_nan=np.asarray(x).dtype.kind
                           in "fc") for x, y in zip(a, b, strict=True))


def step_cap(n_max: int, chunk: int) -> int:
    """MJX's step cap: ``n_max`` rounded up to whole ``chunk``s. MJX once stepped only whole
    fixed-length scans (:data:`BALL_CHUNK`, …), looking for the end in every step taken, so
    its records at the cap ran to the end of the last scan; its runs step exactly the
    steps asked now, up to this cap, so the records stay what they were."""
    return -(-n_max // chunk) * chunk


@dataclass
class _MjxSim:
    """A model and data on the device, stepped exactly the steps asked, in calls of at most
    ``length`` steps of one compiled loop (:func:`_stepper`)."""

    model: Any
    data: Any
    control: str
    params: np.ndarray
    length: int
    mjcf: str
    steps: int = 0
    chunks: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = field(default_factory=list)
    calls: int = 0
    """Compiled calls made (each at most ``length`` steps)."""

    sensor_width: ClassVar[int] = 0
    """How many of the contact sensor's values a step keeps (:func:`_stepper`)."""

    def __post_init__(self) -> None:
        t = _template(self.model, self.data, self.mjcf)
        self.m = t.model_leaves(self.model)
        self.d = t.initial(self.model, self.data)
        self.step = _stepper(t.mtree, t.dtree, self.sensor_width, self.control, self.length)

    def step_chunk(self, n: int) -> None:
        while n > 0:
            k = min(n, self.length)
            d, (q, v, f) = self.step(self.m, self.d, self.params, np.int64(k))
            self.d = _host(d)
            self.chunks.append((np.asarray(q)[:k], np.asarray(v)[:k], np.asarray(f)[:k]))
            self.steps += k
            self.calls += 1
            n -= k

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
    return _run_ball_setup(s, setup)


def _run_ball_setup(s: BallOnPlate, setup: _BallSetup) -> ImpactRecord:
    """A ball run set up (:func:`_ball_setup`), stepped alone: its record."""
    sim = _MjxSim(setup.model, setup.data, setup.control, setup.params, BALL_CHUNK,
                  setup.mjcf)
    out = drive(sim, setup.n_max, setup.first, setup.chunk, setup.end_finder())
    setup.meta.update(steps=sim.steps, stepping="lax.scan")
    return ball_outcome_record(s, out, setup.dt, setup.gap, setup.meta)


@dataclass
class _Setup:
    """A run set up and planned, before its first step: the model with the mode's contact,
    the start, the per-step control's parameters, the record's facts, the step (s), the
    start's gap (m), the drive plan (cap, first look for the end, chunk; steps) and the
    MJCF it was compiled from."""

    model: Any
    data: Any
    params: np.ndarray
    meta: dict[str, Any]
    dt: float
    gap: float
    n_max: int
    first: int
    chunk: int
    mjcf: str


@dataclass
class _BallSetup(_Setup):
    """A ball run set up and planned (:func:`_ball_setup`), with its per-step control."""

    control: str = ""

    def end_finder(self) -> Any:
        """A fresh end rule (:func:`~impactbench.engines.mujoco_adapter.ball_end_finder`)."""
        return ball_end_finder()


def _ball_setup(s: BallOnPlate, mode: str, settings: RunSettings) -> _BallSetup | ImpactRecord:
    """The model, start and drive plan of a ball run (its record when it cannot run)."""
    dt = float(settings.timestep_s or BALL_TIMESTEP_S)
    built = _ball_contact(s, mode, settings, dt)
    if isinstance(built, ImpactRecord):
        return built
    gap, n_max, first, chunk = ball_start(s, mode, settings, built.data, dt, built.t_est_s,
                                          MIN_CHUNK)
    built.meta["phase"] = ball_phase(settings.phase)
    return _BallSetup(built.model, built.data, built.params, built.meta, dt, gap,
                      step_cap(n_max, BALL_CHUNK), first, chunk, built.mjcf,
                      control=built.control)


@dataclass
class _BallContact:
    """The ball's model with a mode's contact (:func:`_ball_contact`), its state not yet
    set: the head-on ball's and the bounce's."""

    model: Any
    data: Any
    control: str
    """The loop's per-step control (:data:`CONTROLS`): ``ball`` (on for injected)."""
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
    params = ball_parameters()
    if mode == "injected":
        t_est = hertz_duration_s(s, s.velocity_m_s)
        injected = injected_parameters(s.law(), a)
        if injected is None:
            return ImpactRecord.failed(
                Status.UNSUPPORTED, "mjx: injected needs a power-law or linear contact law "
                "(an arbitrary elastic function cannot run inside the compiled step)")
        params = ball_parameters(injected)
        set_contact(model, (0.0, 0.0), SOLIMP)
        meta.update(law=s.model, solimp=list(SOLIMP))
    else:
        t_est = ball_contact(s, mode, settings, model, dt, a, user, meta)
    return _BallContact(model, data, "ball", params, meta, t_est,
                        ball_mjcf(s, dt, integrator, engine_defaults=out_of_box))


def run_ball_batch(items: Sequence[tuple[BallOnPlate, str, RunSettings]]) -> list[ImpactRecord]:
    """Many ball runs in one compiled call per model: worlds whose models differ only in the
    contact's geom solref and solimp (a tuner's candidates, at any velocities and phases)
    step together, :data:`BATCH_WORLDS` at a time, in the loop :func:`run_ball` takes
    ``vmap``-ed, each world driven by its own :func:`drive` plan and end rule; fewer than
    :data:`BATCH_MIN_WORLDS` of a model run one by one. Each record is the one
    :func:`run_ball` gives: the same steps bit for bit (a vmapped step is the same
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
    batches, alone = _batches(groups, BATCH_WORLDS, BATCH_MIN_WORLDS)
    for i, setup in alone:
        out[i] = _run_ball_setup(items[i][0], setup)
    for batch in batches:
        sims = _BatchWorlds([setup for _, setup in batch], BATCH_WORLDS, BALL_CHUNK,
                            ("geom_solref", "geom_solimp")).run()
        for (i, setup), (sim, outcome) in zip(batch, sims, strict=True):
            setup.meta.update(steps=sim.steps, stepping="lax.scan")
            out[i] = ball_outcome_record(items[i][0], outcome, setup.dt, setup.gap, setup.meta)
    return [r for r in out if r is not None]


class _BatchWorlds:
    """Worlds of one model tree (:class:`_Template`) and per-step control, stepped together
    in calls of at most ``capacity`` steps of one compiled loop (:func:`_stepper`,
    ``vmap``-ed over the worlds' data, control parameters and model leaves ``at``: all that
    carry values, or the given few), always ``width`` wide (the first world repeated in the
    spare places, its copies' samples dropped: each world steps on its own, so one compile
    serves every batch of a kind). Each world is driven by its lone run's plan
    (:func:`~impactbench.engines.mujoco_adapter.drive_many`)."""

    def __init__(self, setups: Sequence[Any], width: int, capacity: int,
                 at: tuple[str, ...] | None = None) -> None:
        self.setups = list(setups)
        first = self.setups[0]
        t = _template(first.model, first.data, first.mjcf)
        self.m = t.model_leaves(first.model)
        index = tuple(i for i, src in enumerate(t.sources) if src is not None) if at is None \
            else tuple(t.index(name) for name in at)
        spare = width - len(self.setups)
        own = [_template(st.model, st.data, st.mjcf) for st in self.setups]  # one tree
        self.m_worlds = [np.stack([tk.leaf(st.model, i) for tk, st in zip(own, self.setups,
                                                                           strict=True)]
                                  + [self.m[i]] * spare) for i in index]
        datas = [tk.initial(st.model, st.data) for tk, st in zip(own, self.setups, strict=True)]
        self.d = [np.stack(leaves) for leaves in zip(*datas, *[datas[0]] * spare, strict=True)]
        self.state = (t.qpos, t.qvel)
        self.parked = [leaf.copy() for leaf in self.d]  # each world at rest at its start
        self.parked[t.qvel][:] = 0.0
        self.done = np.zeros(width, dtype=bool)
        self.done[len(self.setups):] = True  # the spare places
        self.p = np.stack([st.params for st in self.setups] + [first.params] * spare)
        self.capacity = capacity
        self.step_fn = _stepper(t.mtree, t.dtree, 0, first.control, capacity, index)

    def step(self, n: int) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
        """``n`` steps of every world: its samples."""
        parts = []
        while n > 0:
            k = min(n, self.capacity)
            d, (q, v, f) = self.step_fn(self.m, self.m_worlds, self._park(self.d), self.p,
                                        np.int64(k))
            self.d = self._park(_host(d))
            parts.append((np.asarray(q)[:, :k], np.asarray(v)[:, :k], np.asarray(f)[:, :k]))
            n -= k
        qs, vs, fs = (np.concatenate(a, axis=1) for a in zip(*parts, strict=True))
        return [(qs[k], vs[k], fs[k]) for k in range(len(self.setups))]

    def _park(self, d: list[np.ndarray]) -> list[np.ndarray]:
        """``d`` with every world that has ended (its plan returned: its samples from now on
        are dropped) or whose state is no longer finite (its run ends at its first
        non-finite sample, taken already) put at rest at its start: stepped on, a world
        that has run away (a collapsed structure) or blown up holds the batch's solver to
        its iteration limit every step."""
        q, v = (d[i].reshape(len(d[i]), -1) for i in self.state)
        park = self.done | ~(np.all(np.isfinite(q), axis=1) & np.all(np.isfinite(v), axis=1))
        if park.any():
            d = [leaf.copy() for leaf in d]
            for leaf, rest in zip(d, self.parked, strict=True):
                leaf[park] = rest[park]
        return d

    def _tracked(self, k: int, world: Any) -> Any:
        """World ``k``'s plan (:func:`_plan`), marking it done when it returns."""
        out = yield from _plan(self.setups[k], world)
        self.done[k] = True
        return out

    def run(self) -> list[tuple[Any, Any]]:
        return drive_many([functools.partial(self._tracked, k) for k in range(len(self.setups))],
                          self.step)


def _plan(setup: Any, world: Any) -> Any:
    return driving(world, setup.n_max, setup.first, setup.chunk, setup.end_finder())


def _batches(groups: dict[Any, list[tuple[int, Any]]], width: int, fewest: int
             ) -> tuple[list[list[tuple[int, Any]]], list[tuple[int, Any]]]:
    """Groups of (item index, setup) cut into batches of at most ``width`` worlds: (the
    batches of at least ``fewest`` worlds, the setups of the others: they run alone)."""
    cut = [group[k:k + width] for group in groups.values() for k in range(0, len(group), width)]
    return [b for b in cut if len(b) >= fewest], [x for b in cut if len(b) < fewest for x in b]


@dataclass
class _PairSetup(_Setup):
    """A rigid–flexible run set up and planned (:func:`_pair_setup`): its scenario and
    structural law besides (the control's parameter: β of the softening structure's cubic
    term, 0 for a linear one)."""

    s: RigidFlexible | None = None
    structure: Any = None
    collapsed: list[int] = field(default_factory=list)
    control: ClassVar[str] = "pair"

    def end_finder(self) -> Any:
        """The run's end rule (:func:`~impactbench.engines.mujoco_adapter.
        rigid_flexible_end_finder`), marking a collapse in :attr:`collapsed`."""
        return rigid_flexible_end_finder(self.s, self.structure, self.collapsed)

    def record(self, out: Any, steps: int) -> ImpactRecord:
        self.meta.update(steps=steps, stepping="lax.scan")
        return rigid_flexible_record(self.s, self.structure, out, self.dt, self.gap,
                                     self.meta, self.collapsed)


def _pair_setup(s: RigidFlexible, mode: str, settings: RunSettings) -> _PairSetup:
    """The model, start and drive plan of a rigid–flexible run (native or tuned): MuJoCo's
    model and contact (solref (−k1·A, 0), or the tuned one), body 1 :data:`GAP_STEPS` steps
    of flight from body 2 at rest, MuJoCo's plan (:func:`~impactbench.engines.
    mujoco_adapter.pair_plan`) with MJX's cap (:func:`step_cap`)."""
    mujoco = _mjx()[0]
    dt = float(settings.timestep_s or RIGID_FLEXIBLE_TIMESTEP_S)
    mjcf = rigid_flexible_mjcf(s, dt)
    model = mujoco.MjModel.from_xml_string(mjcf)
    data = mujoco.MjData(model)
    a = measured_diag_a(model, data, (1e-9, 0.0))
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
    n_max, first, chunk = pair_plan(s, dt, settings.max_time_s, bool(beta))
    return _PairSetup(model, data, np.array([beta]), meta, dt, gap,
                      step_cap(n_max, RIGID_FLEXIBLE_CHUNK), first, chunk, mjcf,
                      s=s, structure=s.structural_law())


def run_rigid_flexible(s: RigidFlexible, mode: str, settings: RunSettings) -> ImpactRecord:
    """Rigid–flexible 2-DOF impact in MJX (native and tuned); see the module docstring."""
    return _run_pair_setup(_pair_setup(s, mode, settings))


def _run_pair_setup(setup: _PairSetup) -> ImpactRecord:
    """A rigid–flexible run set up (:func:`_pair_setup`), stepped alone: its record."""
    sim = _MjxSim(setup.model, setup.data, setup.control, setup.params,
                  RIGID_FLEXIBLE_CHUNK, setup.mjcf)
    out = drive(sim, setup.n_max, setup.first, setup.chunk, setup.end_finder())
    return setup.record(out, sim.steps)


PAIR_BATCH_WORLDS = 16
"""Worlds of one rigid–flexible ``vmap`` (:func:`run_rigid_flexible_batch`), spare places
filled: 12 worlds step in ~170 µs where one alone takes ~45 µs on this CPU."""
PAIR_BATCH_MIN_WORLDS = 4
"""The fewest rigid–flexible worlds stepped as one ``vmap``; fewer run one by one."""


def run_rigid_flexible_batch(items: Sequence[tuple[RigidFlexible, str, RunSettings]]
                             ) -> list[ImpactRecord]:
    """Many rigid–flexible runs (native, tuned) in one compiled call: every run whose model
    has the same tree (any velocity, masses, stiffnesses, step and structure — the sphere
    radii's only static trace is zeroed, :func:`_put_model`) steps as a world of one
    ``vmap`` over all model leaves, the data and the control's β, each world driven by its
    lone run's plan and end rule. Each record is the one :func:`run_rigid_flexible` gives,
    bit for bit (tested)."""
    setups = [_pair_setup(*item) for item in items]
    groups: dict[Any, list[tuple[int, _PairSetup]]] = {}
    for i, setup in enumerate(setups):
        t = _template(setup.model, setup.data, setup.mjcf)
        key = (t.mtree, t.dtree, t.exact, tuple(
            leaf.tobytes() for leaf, src in zip(t.m_leaves, t.sources, strict=True)
            if src is None))
        groups.setdefault(key if t.exact else (key, i), []).append((i, setup))
    out: list[ImpactRecord | None] = [None] * len(items)
    batches, alone = _batches(groups, PAIR_BATCH_WORLDS, PAIR_BATCH_MIN_WORLDS)
    for i, setup in alone:
        out[i] = _run_pair_setup(setup)
    for batch in batches:
        worlds = _BatchWorlds([setup for _, setup in batch], PAIR_BATCH_WORLDS,
                              RIGID_FLEXIBLE_CHUNK).run()
        for (i, setup), (world, outcome) in zip(batch, worlds, strict=True):
            out[i] = setup.record(outcome, world.steps)
    return [r for r in out if r is not None]


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
                                                      MIN_CHUNK)
    sim = _MjxSim(built.model, built.data, built.control, built.params, BALL_CHUNK,
                  built.mjcf)
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
    model, data, meta, contact = prepare_oblique(s, mode, settings, engine="mjx")
    control, params = "none", np.zeros(6)
    if mode == "injected":
        injected = injected_parameters(s.normal_scenario().law(), meta["normal_compliance"])
        if injected is None:
            return ImpactRecord.failed(
                Status.UNSUPPORTED, "mjx: injected needs a power-law or linear contact law "
                "(an arbitrary elastic function cannot run inside the compiled step)")
        control, params = "pair_secant", np.append(injected, s.radius_m)
    meta["chunk_steps"] = OBLIQUE_CHUNK
    n_max, first, chunk = oblique_start(s, mode, settings, meta, data, dt, MIN_CHUNK)
    sim = _MjxObliqueSim(model, data, control, params, OBLIQUE_CHUNK,
                         oblique_mjcf(s, dt, meta["integrator"], contact))
    out = drive(sim, step_cap(n_max, OBLIQUE_CHUNK), first, chunk,
                oblique_end_finder(s.radius_m))
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
            batch="run_rigid_flexible_batch",
            why_not={"injected": "rigid–flexible needs the local law's memory updated "
                                 "between steps, which a compiled scan cannot call"}),
        "cube-toss": cube_toss_builder("mjx"),
        "bounce": Builder("run_bounce", BOUNCE_TIMESTEP_S, parameter_keys=PARAMETER_KEYS),
    }
    # builders only build (Adapter.run has checked the mode, the keys and the tuned file)
    run_ball = staticmethod(run_ball)
    run_ball_batch = staticmethod(run_ball_batch)
    run_rigid_flexible = staticmethod(run_rigid_flexible)
    run_rigid_flexible_batch = staticmethod(run_rigid_flexible_batch)
    run_oblique = staticmethod(run_oblique)
    run_bounce = staticmethod(run_bounce)

    def version(self) -> str:
        return _version()


@functools.lru_cache(maxsize=1)
def _version() -> str:
    """mujoco-mjx's version with mujoco's and jax's (read once: every record carries it)."""
    from importlib.metadata import version

    mujoco, jax, _ = _mjx()
    return f"{version('mujoco-mjx')} (mujoco {mujoco.__version__}, jax {jax.__version__})"
