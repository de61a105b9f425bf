"""Newton adapter (pip ``newton``, on NVIDIA warp, CPU device): both scenarios, every mode.

Solver: ``SolverFeatherstone`` (reduced coordinates, semi-implicit Euler: the forces at the
step's start state, then v_{k+1} = v_k + h·a_k, q_{k+1} = q_k + h·v_{k+1}). Its penalty contact
(the same kernel as ``SolverSemiImplicit``'s) is, per contact with penetration x > 0 and
approach rate ẋ (material ``ke``, ``kd`` averaged over the two shapes, N/m and N·s/m)

    F = ke·x + kd·max(ẋ, 0)

— damping acts only while the bodies approach, so the force never turns negative and the
contact never lets go while overlapping. Its restitution is therefore not the two-sided
spring–damper's: the approach is a damped oscillation from (0, V0) to the deepest point
x_max = (V0/ωn)·exp(−ζφ/√(1−ζ²)), φ = atan2(√(1−ζ²), ζ), the rebound an undamped quarter
period, so exactly

    e = exp(−ζφ/√(1−ζ²)),   T = (φ/√(1−ζ²) + π/2)/ωn,   ωn = √(ke/m), ζ = kd/(2√(ke·m))

(:func:`approach_damped_matching` inverts it). e ≥ 1/e ≈ 0.37 for any underdamped ζ.

Models (SI, friction 0): ball — a ground plane at z = 0 and a sphere on a vertical prismatic
joint whose coordinate is the height of the sphere's lowest point (the body origin; the sphere's
centre and the centre of mass sit R above it), so the penetration is x = −q. Rigid–flexible —
two spheres of radius :func:`~impactbench.engines.mujoco_adapter.face_radius_m` on prismatic
joints along x, body origins at the touching faces (q1 = x1, q2 = x2, both 0 at first touch);
body 2's joint ``stiffness`` is k2 and the softening term +β·x2³ goes in ``control.joint_f``.

float32: warp computes in single precision. The joint coordinates are kept near zero (body
origins at the contact point), where float32 resolves 1e-12 m against a 20–115 µm penetration;
the contact kernel forms the contact point as (body position + local offset), whose rounding is
one ulp of the sphere radius (9e-10 m for R = 14.5 mm, 5e-5 of the smallest penetration, not
accumulated). Velocities carry 6e-8 relative rounding per step. Measured at dt = 1e-7 s with
ke = 1e8 N/m, kd = 316 N·s/m: e = 0.92668 against the law's exact 0.92673 (5e-5). Below
dt ≈ 1e-8 s the per-step position increment v·dt reaches the rounding of q itself.

Force output: Featherstone reports no contact force, so the record's normal force is the
engine's own momentum change of body 1, F_k = m1·(Δu1/h + g) (ball: upward velocity change plus
gravity; rigid–flexible: −m1·Δu1/h, body 1 has no other force), taken where the contact is
active (x_k > 0, as the kernel's test) and 0 elsewhere. That is the force Newton applied over
step k exactly (semi-implicit Euler applies one constant force per step), to float32 velocity
rounding (m·ulp(v)/h: 0.01 N at 1 m/s and h = 1e-6 s).

Modes:

- ``native``: ball — ``ke``, ``kd`` from :func:`approach_damped_matching` so Newton's own law has
  the Hunt–Crossley reference's restitution and duration at V_ref (default 1 m/s,
  ``options["reference_velocity_m_s"]``); rigid–flexible — ke = k1, kd = 0 (linear local law).
- ``injected``: the reference law through Newton's own contact: at each step's start state the
  material ``ke`` of every shape is set to the law's secant F(x, ẋ)/x (the scenario's contact
  law, or the local law F1(Δx)/Δx with its memory updated after each step) and ``kd`` = 0, so
  the contact kernel applies exactly the law's force over the step.
- ``tuned``: ``settings.tuned`` keys ``ke``, ``kd``; ``custom``: ``settings.params`` keys ``ke``,
  ``kd``, ``kf``, ``mu`` (Newton's ShapeConfig names; the rest keep Newton's defaults);
  ``default``: Newton's ``ShapeConfig`` defaults (ke = 2.5e3 N/m, kd = 100 N·s/m, kf = 1e3,
  mu = 1), recorded in ``meta["engine_defaults"]``.

Oblique impact (:func:`run_oblique`, gravity off): the ball on a D6 joint (z of the centre − R,
x, rotation about +y = n × t) with its own moment of inertia. Newton's friction in the same
kernel: F_t = −kf·v_slip capped at μ·F_n (F_n with its damping term), the shapes' mu and kf
averaged (both get the same). ``native``: the ball's native ke, kd, mu = μ and kf = m_s/dt
(:func:`deadbeat_kf`: the regularisation stops a slip within one step, ideal Coulomb for the
step); ``injected``: the law's secant ke and the same friction — the law and Coulomb both
through Newton's own contact; ``default``: ShapeConfig defaults (kf 1e3) with mu = μ;
``custom``: that plus ``settings.params``; ``tuned``: ``native`` with a tuned file's ``mu`` and
``kf`` (both shapes; :data:`impactbench.engines.oblique_tuned.SPACES`), read back from the
finalized model (``shape_material_mu``, ``shape_material_kf``); no file: ``unsupported`` with
the reason. Forces: m·Δv/dt, normal and tangential.

Bounce to rest (:func:`run_bounce`): the ball's model and contact for each mode (its first
impact's, :meth:`~impactbench.reference.bounce_scenario.Bounce.ball`), the ball released at rest
``height_m`` above the plane under gravity, stepped at :data:`BOUNCE_TIMESTEP_S` (Newton's own
Featherstone contact example) in the same captured graphs and recorded every step until the
shared end rule (:class:`~impactbench.engines.bounce.BounceEnd`). Featherstone's penalty contact
has no restitution velocity threshold.

Stepping (:class:`NewtonSim`) stays on warp's CPU device: one step (a record kernel, then
``clear_forces``, ``collide``, ``SolverFeatherstone.step``) is captured once per direction of
the two-state swap as a warp CPU graph (warp ≥ 1.19 records CPU launches and replays them in
C++) and replayed by one ``wp.capture_launch`` per step; the record kernel writes each step's
start state into preallocated warp arrays, copied to numpy once per chunk, and the m·Δv/dt
force is formed from those arrays afterwards (the same float64 operations as per step). The
softening term β·q2³ is written into ``control.joint_f`` by the record kernel (float64 libm
``pow``, as Python's ``**``). Injected mode reads the start state from zero-copy views of the
CPU state arrays (one ``tolist`` per step), evaluates the law in Python (its memory too) and
writes ke into the shapes' ``shape_material_ke`` view before the step's graph launch. Each
record equals the step-by-step path's (``graphs=False``: the same kernels launched eagerly)
and the former Python-loop adapter's bit for bit (measured on the default report's runs).
Warp compiles each kernel module on first use into its kernel cache
(``warp.config.kernel_cache_dir``, by default under the user's cache directory; forward
passes only, :data:`FORWARD_ONLY`): eleven modules, the Featherstone solver's the largest,
≈ 25–40 s for the first run on a 2-core machine (≈ 65 s with the backward passes), whichever
scenario it is (they share every module); later processes load them in well under a
second. Newton's collision pipeline still generates its kernels per model (about 0.1 s).

Batches (``Adapter.run_many``: each scenario's ``Builder.batch``, :func:`run_ball_batch`,
:func:`run_rigid_flexible_batch`, :func:`run_oblique_batch`, :func:`run_bounce_batch`): the
runs at one step and gravity become the worlds of one model (:func:`worlds_model`: each
world its lone model's plane, bodies and shapes; worlds do not collide), stepped together in
one :class:`NewtonSim`, one graph launch a step for them all; each world is driven by its
lone run's plan and end rule (:func:`~impactbench.engines.mujoco_adapter.drive_many`, the
bounce's recording) and given exactly its lone run's steps, its force formed from its own
columns; an injected world's law is evaluated in Python between the steps on its own start
state and written into its own shapes' ke until its run ends (:class:`Injection`). Each
record equals the lone run's bit for bit (tested, and measured on every Newton run of the
default report). Most of a lone run's wall time is its set-up (the model, Newton's collision
pipeline generating its narrow-phase kernels, the graph capture: 0.2–0.4 s), which a batch
pays once.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Generator
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
from impactbench.engines import oblique_common, oblique_tuned
from impactbench.engines.base import (
    Adapter,
    Builder,
    EngineUnavailable,
    RunSettings,
    ball_gap_m,
    ball_phase,
    scenario_builders,
)
from impactbench.engines.bounce import BounceEnd
from impactbench.engines.common import (
    NATIVE_REFERENCE_VELOCITY_M_S,
    Recorder,
    SpringDamper,
    stderr_without,
)
from impactbench.engines.mujoco_adapter import (
    GAP_STEPS,
    ball_end_finder,
    ball_outcome_record,
    drive,
    drive_many,
    drive_pair,
    drive_plan,
    driving,
    face_radius_m,
    hertz_duration_s,
    pair_plan,
    rigid_flexible_end_finder,
    rigid_flexible_record,
)
from impactbench.reference import validation as check
from impactbench.reference.bounce_scenario import Bounce
from impactbench.reference.oblique_scenario import Oblique
from impactbench.reference.record import ImpactRecord
from impactbench.reference.scenarios import BallOnPlate, RigidFlexible
from scipy import optimize

if TYPE_CHECKING:
    from impactbench.engines.mujoco_adapter import EndFinder, _Outcome

BALL_TIMESTEP_S = 1e-6
RIGID_FLEXIBLE_TIMESTEP_S = 1e-5
PARAMETER_KEYS: tuple[str, ...] = ("ke", "kd", "kf", "mu")
"""Newton's ShapeConfig contact parameters accepted in ``custom`` mode."""
SOLVER = "featherstone"
FORWARD_ONLY = True
"""Compile warp's kernels without their backward (adjoint) passes (``warp.config.
enable_backward = False``, set before newton is imported, for the process: no run here takes
a gradient). The forward code is the same, so every record is too (measured: the default
report's Newton runs and the cube tosses, bit for bit); a cold first run compiles in about
half the time (the Featherstone and articulation modules' backward passes were most of it)."""


@functools.lru_cache(maxsize=1)
def _newton() -> tuple[Any, Any]:
    """(warp, newton), warp quiet, forward only (:data:`FORWARD_ONLY`) and initialised;
    EngineUnavailable if missing."""
    try:
        import warp as wp

        if FORWARD_ONLY:  # before newton defines its kernels: a module takes it when made
            wp.config.enable_backward = False
        import newton
    except ImportError as exc:
        raise EngineUnavailable("newton", str(exc)) from exc
    wp.config.quiet = True  # no device banner on stdout
    wp.config.log_level = max(wp.config.log_level, wp.LOG_WARNING)  # nor module load lines
    with stderr_without("Warp CUDA warning: Could not find or load the NVIDIA CUDA driver"):
        wp.init()  # on a CPU-only machine: the CPU device, and no word about CUDA
    _share_narrow_phase_kernels()
    return wp, newton


NARROW_PHASE_FACTORIES = (
    "create_narrow_phase_primitive_kernel", "create_narrow_phase_kernel_gjk_mpr",
    "create_narrow_phase_kernels_gjk_mpr_split",
    "create_narrow_phase_process_mesh_triangle_contacts_kernel",
    "create_narrow_phase_process_mesh_plane_contacts_kernel",
    "create_narrow_phase_process_mesh_mesh_contacts_kernel",
    "create_export_group_contacts_kernel", "create_export_reduced_contacts_kernel")
"""The kernel factories Newton's ``NarrowPhase.__init__`` calls (``newton._src.geometry.
narrow_phase``'s names). Each call defines its kernels anew (closures over the writer and
support functions it is given), so every ``CollisionPipeline`` — one per run here — made warp
re-register them in their modules and hash the modules' code again at the first launch (the
AST walk of every kernel and function it reaches; the compiled code itself comes from the
same cache entry, the hash being the same). :func:`_share_narrow_phase_kernels` makes each
factory return the kernels it made before for the same arguments (the writer and support
functions are Newton's module-level ones): measured in one process, a ball run's second and
later runs 0.104 s → 0.016 s, the first 2.39 s → 0.60 s, the records bit for bit."""


def _share_narrow_phase_kernels() -> None:
    """Wrap :data:`NARROW_PHASE_FACTORIES` in ``newton._src.geometry.narrow_phase`` so the
    same arguments give the same kernels (arguments that cannot be hashed: made anew, as
    Newton does). A newton without that module or a factory keeps its own."""
    try:
        from newton._src.geometry import narrow_phase
    except ImportError:
        return
    for name in NARROW_PHASE_FACTORIES:
        factory = getattr(narrow_phase, name, None)
        if callable(factory) and not hasattr(factory, "made"):
            setattr(narrow_phase, name, _made_once(factory))


def _made_once(factory: Callable[..., Any]) -> Callable[..., Any]:
    """``factory`` returning what it returned before for equal (hashable) arguments."""
    made: dict[Any, Any] = {}

    @functools.wraps(factory)
    def shared(*args: Any, **kwargs: Any) -> Any:
        key = (args, tuple(sorted(kwargs.items())))
        try:
            return made[key]
        except TypeError:  # an unhashable argument: nothing to share
            return factory(*args, **kwargs)
        except KeyError:
            made[key] = out = factory(*args, **kwargs)
            return out

    shared.made = made  # type: ignore[attr-defined]
    return shared


# --------------------------------------------------------------------------- the contact law


def approach_damped_restitution(zeta: float) -> float:
    """e(ζ) = exp(−ζφ/√(1−ζ²)), φ = atan2(√(1−ζ²), ζ): damping only while approaching."""
    s = math.sqrt(1.0 - zeta * zeta)
    return math.exp(-zeta * math.atan2(s, zeta) / s)


def approach_damped_duration_s(stiffness_n_per_m: float, damping_ns_per_m: float,
                               mass_kg: float) -> float:
    """Contact duration of F = ke·x + kd·max(ẋ, 0) (s): the time t1 to the deepest point plus
    the undamped quarter period π/(2ωn). Underdamped ωn·t1 = φ/√(1−ζ²); critically damped
    ωn·t1 = 1; overdamped ωn·t1 = ln(r₋/r₊)/(r₊ − r₋)·… with r± = −ζ ± √(ζ²−1)."""
    wn = math.sqrt(stiffness_n_per_m / mass_kg)
    zeta = damping_ns_per_m / (2.0 * math.sqrt(stiffness_n_per_m * mass_kg))
    if zeta < 1.0:
        s = math.sqrt(1.0 - zeta * zeta)
        approach = math.atan2(s, zeta) / s
    elif zeta == 1.0:
        approach = 1.0
    else:
        root = math.sqrt(zeta * zeta - 1.0)
        r_plus, r_minus = -zeta + root, -zeta - root
        approach = math.log(r_minus / r_plus) / (r_plus - r_minus)
    return (approach + 0.5 * math.pi) / wn


def approach_damped_matching(mass_kg: float, restitution: float,
                             duration_s: float) -> SpringDamper:
    """Newton's (ke, kd) with this restitution and contact duration (see the module docstring).

    Solves e(ζ) = restitution for ζ ∈ [0, 1) (e falls monotonically from 1 to 1/e), then
    ωn = (φ/√(1−ζ²) + π/2)/T, ke = m·ωn², kd = 2ζ·√(ke·m).
    """
    floor = math.exp(-1.0)
    if not floor < restitution <= 1.0:
        raise ValueError(f"restitution = {restitution!r}: must be in ({floor:.4f}, 1] for a "
                         "contact damped only while approaching")
    check.positive("duration_s", duration_s)
    zeta = 0.0 if restitution == 1.0 else optimize.brentq(
        lambda z: approach_damped_restitution(z) - restitution, 0.0, 1.0 - 1e-12,
        xtol=1e-15, rtol=1e-15)
    s = math.sqrt(1.0 - zeta * zeta)
    wn = (math.atan2(s, zeta) / s + 0.5 * math.pi) / duration_s
    ke = mass_kg * wn * wn
    return SpringDamper(ke, 2.0 * zeta * math.sqrt(ke * mass_kg))


@functools.lru_cache(maxsize=64)
def native_ball(scenario_at_v_ref: BallOnPlate) -> SpringDamper:
    """Newton's native (ke, kd): the reference's restitution and duration at its velocity."""
    from impactbench.reference import hunt_crossley

    ref = hunt_crossley.solve(scenario_at_v_ref)
    return approach_damped_matching(scenario_at_v_ref.mass_kg, ref["restitution"],
                                    ref["duration_s"])


@functools.lru_cache(maxsize=1)
def newton_contact_defaults() -> dict[str, float]:
    """Newton's ShapeConfig defaults for the contact parameters of :data:`PARAMETER_KEYS`."""
    cfg = _newton()[1].ModelBuilder.ShapeConfig()
    return {k: float(getattr(cfg, k)) for k in PARAMETER_KEYS}


def contact_parameters(mode: str, settings: RunSettings,
                       native: tuple[float, float]) -> tuple[dict[str, float], dict[str, Any]]:
    """The shape contact parameters for a non-injected mode, and what goes into the meta."""
    meta: dict[str, Any] = {}
    values = {"ke": native[0], "kd": native[1], "kf": 0.0, "mu": 0.0}
    if mode == "tuned":
        tuned = settings.tuned or {}
        if "ke" not in tuned:
            raise ValueError(f"tuned = {tuned!r}: must contain 'ke' (and optionally 'kd')")
        values.update(ke=check.positive("tuned.ke", tuned["ke"]),
                      kd=check.non_negative("tuned.kd", tuned.get("kd", 0.0)))
    elif mode in ("default", "custom"):
        given = (settings.params or {}) if mode == "custom" else {}
        defaults = newton_contact_defaults()
        values = dict(defaults)
        for key, value in given.items():
            values[key] = check.non_negative(f"param.{key}", value)
        meta["engine_defaults"] = {k: v for k, v in defaults.items() if k not in given}
        if mode == "custom":
            meta["params"] = dict(given)
    meta.update(values)
    return values, meta


# --------------------------------------------------------------------------- models


def _shape_config(newton: Any, values: dict[str, float]) -> Any:
    cfg = newton.ModelBuilder.ShapeConfig(density=0.0)
    for key, value in values.items():
        setattr(cfg, key, float(value))
    return cfg


def ball_model(s: BallOnPlate, values: dict[str, float]) -> Any:
    """Plane at z = 0, sphere on a z prismatic joint, q = height of its lowest point."""
    _, newton = _newton()
    b = newton.ModelBuilder(gravity=(0.0, 0.0, -s.gravity_m_s2))
    _add_ball(b, s, values)
    return b.finalize(device="cpu")


def _add_ball(b: Any, s: BallOnPlate, values: dict[str, float]) -> None:
    wp, newton = _newton()
    cfg = _shape_config(newton, values)
    b.add_ground_plane(cfg=cfg)
    r, m = s.radius_m, s.mass_kg
    i = 0.4 * m * r * r
    body = b.add_link(mass=m, com=(0.0, 0.0, r), inertia=wp.mat33(i, 0, 0, 0, i, 0, 0, 0, i))
    joint = b.add_joint_prismatic(-1, body, axis=newton.Axis.Z)
    b.add_articulation([joint])
    b.add_shape_sphere(body, xform=wp.transform((0.0, 0.0, r), wp.quat_identity()),
                       radius=r, cfg=cfg)


def rigid_flexible_model(s: RigidFlexible, values: dict[str, float]) -> Any:
    """Two spheres on x prismatic joints touching at q = 0; joint 2's stiffness is k2."""
    _, newton = _newton()
    b = newton.ModelBuilder(gravity=(0.0, 0.0, 0.0))
    _add_pair(b, s, values)
    return b.finalize(device="cpu")


def _add_pair(b: Any, s: RigidFlexible, values: dict[str, float]) -> None:
    wp, newton = _newton()
    cfg = _shape_config(newton, values)
    r = face_radius_m(s)
    joints = []
    for mass, side, stiffness in ((s.m1_kg, -1.0, 0.0), (s.m2_kg, 1.0, s.k2_n_per_m)):
        body = b.add_link(mass=mass, com=(side * r, 0.0, 0.0),
                          inertia=wp.mat33(1, 0, 0, 0, 1, 0, 0, 0, 1))
        joints.append(b.add_joint_prismatic(-1, body, axis=newton.Axis.X, stiffness=stiffness,
                                            rest_q=0.0))
        b.add_shape_sphere(body, xform=wp.transform((side * r, 0.0, 0.0), wp.quat_identity()),
                           radius=r, cfg=cfg)
    b.add_articulation(joints)


def worlds_model(gravity: tuple[float, float, float], adders: list[Callable[[Any], None]]
                 ) -> tuple[Any, list[slice]]:
    """One model with a world per ``adders[k]`` (it adds run k's plane, bodies, joints and
    shapes, as its lone model has them), ``gravity`` the acceleration (m/s²); and each world's
    shapes (a slice of the model's shape indices). Worlds do not collide with each other."""
    _, newton = _newton()
    b = newton.ModelBuilder(gravity=gravity)
    shapes = []
    for add in adders:
        first = b.shape_count
        b.begin_world()
        add(b)
        b.end_world()
        shapes.append(slice(first, b.shape_count))
    return b.finalize(device="cpu"), shapes


# --------------------------------------------------------------------------- stepping

CONTACT_CAPACITY = 8
"""Rigid-contact buffer of the collision pipeline (``rigid_contact_max``). Each model has one
shape pair (sphere–plane, sphere–sphere), one contact; Newton's own estimate (1000) only makes
its per-contact kernels loop over empty slots. The pipeline's buffer check stays on (an
overflow warns)."""
NARROW_PHASE_THREADS = 1
"""Threads of the narrow phase's primitive kernel. Newton launches 256 on CPU (a GPU occupancy
floor); the kernel grid-strides over the candidate pairs, and warp runs a CPU launch's threads
one after another, so one thread does the same work in the same order, without 255 empty
invocations (5 µs a step, half the step)."""
RECORD_CAPACITY = 8192
"""Steps recorded on the device between two copies to numpy (a chunk may hold several)."""


@functools.lru_cache(maxsize=1)
def _record_kernel() -> Any:
    """The per-step kernel run before the solver: records the step's start state into row
    ``count[0]`` of the record arrays (and advances ``count``) and, with ``cubic`` set, writes
    the softening term β_j·q[j]³ into ``joint_f[j]`` of every joint coordinate j whose
    ``beta[j]`` ≠ 0 (N; float64, as Python's ``beta * q ** 3``: the same libm ``pow``, then
    rounded to float32 as a numpy assignment would)."""
    wp = _newton()[0]

    @wp.kernel
    def record_step(joint_q: wp.array(dtype=wp.float32), joint_qd: wp.array(dtype=wp.float32),
                    beta: wp.array(dtype=wp.float64), cubic: wp.int32,
                    joint_f: wp.array(dtype=wp.float32), rec_q: wp.array2d(dtype=wp.float32),
                    rec_qd: wp.array2d(dtype=wp.float32), count: wp.array(dtype=wp.int32)):
        i = count[0]
        for j in range(joint_q.shape[0]):
            rec_q[i, j] = joint_q[j]
        for j in range(joint_qd.shape[0]):
            rec_qd[i, j] = joint_qd[j]
        count[0] = i + 1
        if cubic != 0:
            for j in range(joint_q.shape[0]):
                b = beta[j]
                if b != wp.float64(0.0):
                    joint_f[j] = wp.float32(b * wp.pow(wp.float64(joint_q[j]), wp.float64(3.0)))

    return record_step


INJECTED_STEPPING = " (contact ke from the law in Python)"
"""What an injected run's ``meta["stepping"]`` adds: its contact stiffness is set in Python
before every step."""


@dataclass
class Injection:
    """One injected run's part of a :class:`NewtonSim`: before each step its shapes'
    ``shape_material_ke`` (N/m) is set to ``secant(q, qd)`` of its joint coordinates ``q``
    (the start state, Python floats) and after the step ``commit(q)`` updates the law's
    memory; ``active`` False (its run has ended) skips both."""

    q: slice
    shapes: slice
    secant: Callable[[list[float], list[float]], float]
    commit: Callable[[list[float]], None] | None = None
    active: bool = True


@dataclass
class NewtonSim:
    """A Featherstone simulation on warp's CPU device, one sample per step.

    Each step is one device-side sequence (record kernel, ``clear_forces``, ``collide``,
    ``SolverFeatherstone.step``) captured once per direction (state 0 → 1, 1 → 0) as a warp
    CPU graph (warp ≥ 1.19 replays CPU captures in C++) and replayed by one
    ``wp.capture_launch`` per step; ``graphs=False`` launches the same kernels eagerly (the
    step-by-step reference path, 20-odd Python launches per step). The record kernel writes
    the start state of each step into preallocated warp arrays, copied to numpy once per
    chunk (at most :data:`RECORD_CAPACITY` steps).

    ``beta`` ≠ 0 adds the cubic joint force β·q[1]³ on joint 1 (body 2's x2) on the device
    (softening); ``joint_beta``, one β per joint coordinate (a batch's), replaces it.
    ``secant(q, qd) → ke`` (injected) is called in Python at each step's start, on the start
    state read from the state arrays (zero-copy views of the CPU memory), and its value goes
    into every shape's ``shape_material_ke``; ``commit(q)`` runs after the step (a law's
    memory). ``injections`` (a batch's): one :class:`Injection` per injected world, the same
    for its coordinates and shapes only. ``force(q, qd, qd_next)`` turns a chunk's samples
    (arrays, one row per step) into the recorded contact forces.
    """

    model: Any
    dt: float
    q0: tuple[float, ...]
    qd0: tuple[float, ...]
    force: Any
    secant: Any = None
    commit: Any = None
    beta: float = 0.0
    graphs: bool = True
    injections: list[Injection] = field(default_factory=list)
    joint_beta: tuple[float, ...] = ()
    steps: int = 0
    chunks: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = field(default_factory=list)

    def __post_init__(self) -> None:
        wp, newton = _newton()
        record = _record_kernel()
        m = self.model
        states = (m.state(), m.state())
        control = m.control()
        states[0].joint_q.assign(np.asarray(self.q0, dtype=np.float32))
        states[0].joint_qd.assign(np.asarray(self.qd0, dtype=np.float32))
        newton.eval_fk(m, states[0].joint_q, states[0].joint_qd, states[0])
        solver = newton.solvers.SolverFeatherstone(m)
        worlds = max(1, int(getattr(m, "world_count", 1) or 1))  # a batch: a pair per world
        pipeline = newton.CollisionPipeline(m, rigid_contact_max=CONTACT_CAPACITY * worlds)
        narrow = getattr(pipeline, "narrow_phase", None)
        if getattr(narrow, "total_num_threads", 0) > NARROW_PHASE_THREADS:
            narrow.total_num_threads = NARROW_PHASE_THREADS
        contacts = pipeline.contacts()
        rec_q = wp.zeros((RECORD_CAPACITY, len(self.q0)), dtype=wp.float32, device="cpu")
        rec_qd = wp.zeros((RECORD_CAPACITY, len(self.qd0)), dtype=wp.float32, device="cpu")
        count = wp.zeros(1, dtype=wp.int32, device="cpu")
        betas = np.zeros(len(self.q0), dtype=np.float64)
        if self.joint_beta:
            betas[:] = self.joint_beta
        elif self.beta != 0.0:
            betas[1] = self.beta
        beta = wp.array(betas, dtype=wp.float64, device="cpu")
        cubic, dt = int(np.any(betas != 0.0)), self.dt

        def advance(a: Any, b: Any) -> None:
            """One step from state ``a`` into ``b``, all on the device."""
            wp.launch(record, dim=1, device="cpu",
                      inputs=[a.joint_q, a.joint_qd, beta, cubic, control.joint_f, rec_q,
                              rec_qd, count])
            a.clear_forces()
            pipeline.collide(a, contacts)
            solver.step(a, b, control, contacts, dt)

        self._keep = (states, control, solver, pipeline, contacts, rec_q, rec_qd, count, beta)
        # views on the CPU device's memory: reads see what the kernels wrote, writes land in
        # what they read
        self._views = tuple((s.joint_q.numpy(), s.joint_qd.numpy()) for s in states)
        self._rec = (rec_q.numpy(), rec_qd.numpy())
        self._count = count.numpy()
        self.ke = m.shape_material_ke.numpy()
        self._parity = 0  # the current state: states[parity]
        self.stepping = "python loop"
        if self.graphs:
            try:
                self._steps = (_capture(wp, lambda: advance(states[0], states[1])),
                               _capture(wp, lambda: advance(states[1], states[0])))
                self.stepping = "warp CPU graph, one launch per step"
            except RuntimeError:  # a warp without CPU graph capture: the same steps, eagerly
                self.graphs = False
                self.stepping = "python loop (no CPU graph capture in this warp)"
        if not self.graphs:
            self._steps = (lambda: advance(states[0], states[1]),
                           lambda: advance(states[1], states[0]))
        if self.secant is not None:
            self.injections = [Injection(slice(None), slice(None), self.secant, self.commit)]
            self.stepping += INJECTED_STEPPING

    def _run(self, n: int) -> None:
        """``n`` steps from the current state, recorded from row 0."""
        p = self._parity
        if self.graphs:
            launch = _newton()[0].capture_launch
            first, second = (functools.partial(launch, g) for g in
                             (self._steps[p], self._steps[1 - p]))
        else:
            first, second = self._steps[p], self._steps[1 - p]
        active = [j for j in self.injections if j.active]
        if not active:
            for _ in range(n >> 1):
                first()
                second()
            if n & 1:
                first()
        elif len(active) == 1 and active[0].q == slice(None):  # a lone injected run
            secant, commit, ke = active[0].secant, active[0].commit, self.ke
            views = (self._views[p], self._views[1 - p])
            calls = (first, second)
            for i in range(n):
                q_view, qd_view = views[i & 1]
                q = q_view.tolist()
                ke[:] = secant(q, qd_view.tolist())
                calls[i & 1]()
                if commit is not None:
                    commit(q)
        else:
            ke = self.ke
            views = (self._views[p], self._views[1 - p])
            calls = (first, second)
            sets = [(j.q, j.shapes, j.secant) for j in active]
            commits = [(j.q, j.commit) for j in active if j.commit is not None]
            for i in range(n):
                q_view, qd_view = views[i & 1]
                q, qd = q_view.tolist(), qd_view.tolist()
                for cols, shapes, secant in sets:
                    ke[shapes] = secant(q[cols], qd[cols])
                calls[i & 1]()
                for cols, commit in commits:
                    commit(q[cols])
        self._parity = p ^ (n & 1)

    def step_chunk(self, n: int) -> None:
        done = 0
        while done < n:
            k = min(n - done, RECORD_CAPACITY)
            self._count[0] = 0
            self._run(k)
            if int(self._count[0]) != k:
                raise RuntimeError(f"newton: {int(self._count[0])} steps recorded, {k} run")
            q = np.array(self._rec[0][:k], dtype=float)
            qd = np.array(self._rec[1][:k], dtype=float)
            qd_end = np.array(self._views[self._parity][1], dtype=float)
            with np.errstate(all="ignore"):  # a blow-up's inf − inf: NaN, as in Python floats
                f = self.force(q, qd, np.vstack((qd[1:], qd_end)))
            self.chunks.append((q, qd, np.asarray(f, dtype=float)))
            done += k
        self.steps += n

    def arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        qs, vs, fs = zip(*self.chunks, strict=True)
        return np.concatenate(qs), np.concatenate(vs), np.concatenate(fs)

    def state(self) -> tuple[list[float], list[float]]:
        """The current state (the end of the last step): joint coordinates and rates."""
        q, qd = self._views[self._parity]
        return [float(v) for v in q], [float(v) for v in qd]

    def unstable(self) -> bool:
        return False  # a blow-up shows as non-finite state


def _capture(wp: Any, step: Any) -> Any:
    """``step``'s warp launches as a CPU graph (recorded, not run)."""
    wp.capture_begin(device="cpu")
    try:
        step()
    finally:
        graph = wp.capture_end(device="cpu")
    return graph


# --------------------------------------------------------------------------- scenarios


@dataclass
class _Setup:
    """A run ready to step: alone, in a model of its own (:func:`_run_alone`), or as one
    world of a batch (:func:`_run_batch`).

    ``add(builder)`` adds the run's plane, bodies, joints and shapes to a ``ModelBuilder``;
    ``gravity`` (m/s², the model's); the step ``dt`` (s); the start state ``q0``, ``qd0`` (its
    joint coordinates and rates); ``force(q, qd, qd_next)`` its recorded normal force from a
    chunk of its samples; ``plan`` (the step cap, the first step the end is looked for at, the
    chunk) and ``find_end`` for :func:`~impactbench.engines.mujoco_adapter.driving`;
    ``finish(outcome, steps, stepping, model, shapes)`` the record from the driven outcome
    (``shapes``: the run's shapes in ``model``); ``secant``/``commit`` an injected law
    (:class:`Injection`); ``beta`` the cubic force on its joint 1 (N/m³, the pair's
    softening); ``lone_drive(sim)`` how a lone run is driven where not by ``plan`` (the
    pair's :func:`~impactbench.engines.mujoco_adapter.drive_pair`)."""

    add: Callable[[Any], None]
    gravity: tuple[float, float, float]
    dt: float
    q0: tuple[float, ...]
    qd0: tuple[float, ...]
    force: Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray]
    plan: tuple[int, int, int]
    find_end: EndFinder
    finish: Callable[[_Outcome, int, str, Any, slice], ImpactRecord]
    secant: Callable[[list[float], list[float]], float] | None = None
    commit: Callable[[list[float]], None] | None = None
    beta: float = 0.0
    lone_drive: Callable[[NewtonSim], _Outcome] | None = None


def _run_alone(st: _Setup, graphs: bool = True) -> ImpactRecord:
    """A set-up run in a model of its own (its plane, bodies and shapes only)."""
    _, newton = _newton()
    b = newton.ModelBuilder(gravity=st.gravity)
    st.add(b)
    model = b.finalize(device="cpu")
    sim = NewtonSim(model, st.dt, st.q0, st.qd0, st.force, secant=st.secant,
                    commit=st.commit, beta=st.beta, graphs=graphs)
    out = (st.lone_drive(sim) if st.lone_drive is not None
           else drive(sim, *st.plan, st.find_end))
    return st.finish(out, sim.steps, sim.stepping, model, slice(None))


def _run_batch(setups: list[_Setup]) -> list[ImpactRecord]:
    """Set-up runs, those at one step and gravity as the worlds of one model
    (:func:`_run_worlds`), each record its lone run's (:func:`_run_alone`) bit for bit; a
    run with no other at its step and gravity runs alone."""
    out: list[ImpactRecord | None] = [None] * len(setups)
    groups: dict[tuple[float, tuple[float, float, float]], list[int]] = {}
    for i, st in enumerate(setups):
        groups.setdefault((st.dt, st.gravity), []).append(i)
    for group in groups.values():
        recs = ([_run_alone(setups[group[0]])] if len(group) == 1
                else _run_worlds([setups[i] for i in group]))
        for i, rec in zip(group, recs, strict=True):
            out[i] = rec
    return [r for r in out if r is not None]


def _run_worlds(setups: list[_Setup]) -> list[ImpactRecord]:
    """Runs at one step and gravity as the worlds of one model (:func:`worlds_model`),
    stepped together in one :class:`NewtonSim` (one graph launch a step for them all), each
    world driven by its lone run's plan and end rule (:func:`drive_many`: every world is
    given exactly the steps its lone drive takes) and its force formed by its lone run's
    ``force`` on its own columns; an injected world's law is evaluated in Python between
    the steps on its own start state and written into its own shapes' ke
    (:class:`Injection`), until its run ends. Worlds do not interact (Featherstone steps
    each articulation alone, the contact pairs are each world's own), so each record is the
    lone run's bit for bit (tested)."""
    model, shapes = worlds_model(setups[0].gravity, [st.add for st in setups])
    cols, at = [], 0
    for st in setups:
        cols.append(slice(at, at + len(st.q0)))
        at += len(st.q0)
    injections = {k: Injection(cols[k], shapes[k], st.secant, st.commit)
                  for k, st in enumerate(setups) if st.secant is not None}
    joint_beta = tuple(b for st in setups
                       for b in ((0.0, st.beta) + (0.0,) * (len(st.q0) - 2) if st.beta
                                 else (0.0,) * len(st.q0)))

    def force(q: np.ndarray, qd: np.ndarray, qd_next: np.ndarray) -> np.ndarray:
        return np.column_stack([st.force(q[:, c], qd[:, c], qd_next[:, c])
                                for st, c in zip(setups, cols, strict=True)])

    sim = NewtonSim(model, setups[0].dt, tuple(v for st in setups for v in st.q0),
                    tuple(v for st in setups for v in st.qd0), force,
                    injections=list(injections.values()), joint_beta=joint_beta)

    def step(n: int) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
        sim.chunks.clear()
        sim.step_chunk(n)
        q, qd, f = sim.arrays()
        return [(q[:, c], qd[:, c], f[:, k]) for k, c in enumerate(cols)]

    def plan(k: int) -> Callable[[Any], Generator[int, None, _Outcome]]:
        def drive_world(world: Any) -> Generator[int, None, _Outcome]:
            try:
                return (yield from driving(world, *setups[k].plan, setups[k].find_end))
            finally:  # its run has ended: its law is no longer evaluated
                if k in injections:
                    injections[k].active = False

        return drive_world

    recs = []
    for k, (world, outcome) in enumerate(drive_many([plan(k) for k in range(len(setups))],
                                                    step)):
        stepping = sim.stepping + (INJECTED_STEPPING if k in injections else "")
        recs.append(setups[k].finish(outcome, world.steps, stepping, model, shapes[k]))
    return recs


def _ball_secant(law: Any) -> Callable[[list[float], list[float]], float]:
    """The injected contact's ke at the step's start state (q[0] = the gap, so x = −q[0]):
    the law's secant F(x, ẋ)/x (N/m), kd = 0; 0 out of contact."""
    def secant(q: list[float], qd: list[float]) -> float:
        x = -q[0]
        return law.force(x, -qd[0]) / x if x > 0.0 else 0.0

    return secant


def run_ball(s: BallOnPlate, mode: str, settings: RunSettings, *,
             graphs: bool = True) -> ImpactRecord:
    """Ball-on-plate in Newton; see the module docstring. ``graphs=False``: the step-by-step
    reference path (eager launches, see :class:`NewtonSim`)."""
    return _run_alone(_ball_setup(s, mode, settings), graphs)


def run_ball_batch(items: list[tuple[BallOnPlate, str, RunSettings]]) -> list[ImpactRecord]:
    """Many ball runs in one Newton model, one world per run (a tuner's generation of
    contact parameters, a report's runs at any velocities, phases and modes): runs at one
    step and gravity step together, each world driven by its lone run's plan and end rule
    (:func:`_run_batch`), so each record is the one :func:`run_ball` gives, bit for bit
    (tested); an ``injected`` world's contact stiffness is set in Python every step."""
    return _run_batch([_ball_setup(*item) for item in items])


def _ball_setup(s: BallOnPlate, mode: str, settings: RunSettings) -> _Setup:
    """A ball run set up (:class:`_Setup`): the contact values and meta of ``mode``, the
    start gap (m: :func:`~impactbench.engines.base.ball_gap_m` at ``settings.phase``) at
    −V0, the drive plan and end rule, the force recorder and the record."""
    dt = float(settings.timestep_s or BALL_TIMESTEP_S)
    v0 = s.velocity_m_s
    contact = _ball_contact(s, mode, settings)
    gap = ball_gap_m(v0, dt, settings.phase)
    meta = contact.meta
    meta["phase"] = ball_phase(settings.phase)

    def finish(out: _Outcome, steps: int, stepping: str, model: Any, shapes: slice
               ) -> ImpactRecord:
        meta.update(steps=steps, stepping=stepping)
        return ball_outcome_record(s, out, dt, gap, meta)

    return _Setup(functools.partial(_add_ball, s=s, values=contact.values),
                  (0.0, 0.0, -s.gravity_m_s2), dt, (gap,), (-v0,), _ball_force(s, dt),
                  drive_plan(settings, dt, gap / v0, contact.t_est, 8), ball_end_finder(),
                  finish, secant=contact.secant)


@dataclass
class _BallContact:
    """A ball's contact for a mode (:func:`_ball_contact`): the shapes' contact values, the
    run's meta, the injected secant (None: Newton's own law) and a contact duration estimate
    (s)."""

    values: dict[str, float]
    meta: dict[str, Any]
    secant: Callable[[list[float], list[float]], float] | None
    t_est: float


def _ball_contact(s: BallOnPlate, mode: str, settings: RunSettings) -> _BallContact:
    """The ball's contact in ``mode`` — native's matched ke, kd at the reference velocity,
    the tuned file's, ``default``'s ShapeConfig defaults, ``custom``'s params, or the
    injected law's secant (ke set each step, kd = 0) — with its meta (shared by the head-on
    ball and the bounce to rest)."""
    meta: dict[str, Any] = {"solver": SOLVER, "float": "float32"}
    t_est = hertz_duration_s(s, s.velocity_m_s)
    secant = None
    if mode == "injected":
        values = {"ke": 0.0, "kd": 0.0, "kf": 0.0, "mu": 0.0}
        secant = _ball_secant(s.law())
        meta.update(law=s.model)
    else:
        native = (0.0, 0.0)
        if mode == "native":
            v_ref = float(settings.options.get("reference_velocity_m_s",
                                               NATIVE_REFERENCE_VELOCITY_M_S))
            sd = native_ball(s.replace(velocity_m_s=v_ref))
            native = (sd.stiffness_n_per_m, sd.damping_ns_per_m)
            meta.update(reference_velocity_m_s=v_ref)
        values, more = contact_parameters(mode, settings, native)
        meta.update(more, stiffness_n_per_m=values["ke"], damping_ns_per_m=values["kd"])
        if values["ke"] > 0.0:
            t_est = approach_damped_duration_s(values["ke"], values["kd"], s.mass_kg)
    meta.update(force_output="m·Δv/dt of the ball where in contact (no contact output)")
    return _BallContact(values, meta, secant, t_est)


def _ball_force(s: BallOnPlate, dt: float
                ) -> Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray]:
    """The ball's recorded normal force (N) from a chunk's samples (q = the gap, one row
    per step): F_k = m·(Δu/dt + g), the upward momentum change Newton applied over step k
    plus gravity's share, where the contact kernel's test holds (q_k < 0), else 0."""
    m, g = s.mass_kg, s.gravity_m_s2

    def force(q: np.ndarray, qd: np.ndarray, qd_next: np.ndarray) -> np.ndarray:
        return np.where(q[:, 0] < 0.0, m * ((qd_next[:, 0] - qd[:, 0]) / dt + g), 0.0)

    return force


def run_rigid_flexible(s: RigidFlexible, mode: str, settings: RunSettings, *,
                       graphs: bool = True) -> ImpactRecord:
    """Rigid–flexible 2-DOF impact in Newton; see the module docstring. ``graphs=False``: the
    step-by-step reference path (eager launches, see :class:`NewtonSim`)."""
    return _run_alone(_pair_setup(s, mode, settings), graphs)


def run_rigid_flexible_batch(items: list[tuple[RigidFlexible, str, RunSettings]]
                             ) -> list[ImpactRecord]:
    """Many rigid–flexible runs, those at one step as the worlds of one model (a pair per
    world, :func:`_run_batch`), each world driven by its lone run's plan and end rule, so
    each record is the one :func:`run_rigid_flexible` gives, bit for bit (tested); an
    ``injected`` world's local law (and its memory) is evaluated in Python every step."""
    return _run_batch([_pair_setup(*item) for item in items])


def _pair_setup(s: RigidFlexible, mode: str, settings: RunSettings) -> _Setup:
    """A rigid–flexible run set up (:class:`_Setup`): the contact values and meta of
    ``mode`` (injected: the local law's secant and memory), the start (body 1 GAP_STEPS
    steps of flight from body 2 at rest), the drive plan and end rule, the force recorder
    (−m1·Δu1/dt where in contact) and the record (with the collapse marks)."""
    dt = float(settings.timestep_s or RIGID_FLEXIBLE_TIMESTEP_S)
    structure = s.structural_law()
    beta = s.beta_n_per_m3 if s.structure == "softening" else 0.0
    meta: dict[str, Any] = {"solver": SOLVER, "float": "float32",
                            "face_radius_m": face_radius_m(s)}
    m1 = s.m1_kg
    secant = commit = None
    if mode == "injected":
        law = s.local_law()
        values = {"ke": 0.0, "kd": 0.0, "kf": 0.0, "mu": 0.0}

        def secant(q: list[float], qd: list[float]) -> float:
            dx = q[0] - q[1]  # ke·Δx = F1(Δx), the secant
            return law.force(dx) / dx if dx > 0.0 else 0.0

        def commit(q: list[float]) -> None:
            law.update(q[0] - q[1])

        meta.update(law=s.local)
    else:
        values, more = contact_parameters(mode, settings, (s.k1_n_per_m, 0.0))
        meta.update(more)
        if mode == "native":
            meta.update(stiffness_n_per_m=s.k1_n_per_m, damping_ns_per_m=0.0)

    meta.update(force_output="m1·Δu1/dt of body 1 where in contact (no contact output)")

    def force(q: np.ndarray, qd: np.ndarray, qd_next: np.ndarray) -> np.ndarray:
        return np.where(q[:, 0] > q[:, 1], -m1 * (qd_next[:, 0] - qd[:, 0]) / dt, 0.0)

    v1 = s.velocity_m_s
    gap = GAP_STEPS * v1 * dt
    collapsed: list[int] = []

    def lone_drive(sim: NewtonSim) -> _Outcome:
        out, marks = drive_pair(sim, s, structure, dt, settings.max_time_s, bool(beta))
        collapsed.extend(marks)
        return out

    def finish(out: _Outcome, steps: int, stepping: str, model: Any, shapes: slice
               ) -> ImpactRecord:
        meta.update(steps=steps, stepping=stepping)
        return rigid_flexible_record(s, structure, out, dt, gap, meta, collapsed)

    # the softening term β·q2³ goes into control.joint_f on the device (the record kernel)
    return _Setup(functools.partial(_add_pair, s=s, values=values), (0.0, 0.0, 0.0), dt,
                  (-gap, 0.0), (v1, 0.0), force,
                  pair_plan(s, dt, settings.max_time_s, bool(beta)),
                  rigid_flexible_end_finder(s, structure, collapsed), finish,
                  secant=secant, commit=commit, beta=beta, lone_drive=lone_drive)


# --------------------------------------------------------------------------- oblique impact

OBLIQUE_FRICTION_MODEL = ("regularised Coulomb in Newton's penalty contact: F_t = −kf·v_slip "
                          "capped at μ·F_n (F_n with its damping)")
OBLIQUE_FRICTION_COMBINATION = "average"
"""Newton averages the two shapes' mu and kf (and ke, kd): both shapes get the same values."""


def deadbeat_kf(scenario: Oblique, dt: float) -> float:
    """kf = m_s/dt (N·s/m, m_s the ball's effective mass at the contact point along the
    plate): the explicit step then stops a slip within one step, F_t = −s·m_s/dt capped at
    μ·F_n — ideal Coulomb friction for this step (a smaller kf lets the ball slip on, a
    larger one overshoots and, beyond 2·m_s/dt, diverges)."""
    from impactbench.engines.stepping import slip_mass_kg

    return slip_mass_kg(scenario) / dt


def oblique_model(s: Oblique, values: dict[str, float]) -> Any:
    """Plane at z = 0 and the ball on a D6 joint whose frame sits at the ball's centre at
    first touch: q = (z of the centre − R, x, rotation about +y = n × t), so the
    penetration is −q[0] and q[2]'s rate is the spin."""
    _, newton = _newton()
    b = newton.ModelBuilder(gravity=(0.0, 0.0, 0.0))
    _add_oblique(b, s, values)
    return b.finalize(device="cpu")


def _add_oblique(b: Any, s: Oblique, values: dict[str, float]) -> None:
    wp, newton = _newton()
    cfg = _shape_config(newton, values)
    b.add_ground_plane(cfg=cfg)
    r, m = s.radius_m, s.mass_kg
    i = s.moment_of_inertia_kg_m2
    body = b.add_link(mass=m, com=(0.0, 0.0, 0.0), inertia=wp.mat33(i, 0, 0, 0, i, 0, 0, 0, i))
    dof = newton.ModelBuilder.JointDofConfig
    joint = b.add_joint_d6(-1, body, linear_axes=[dof(axis=newton.Axis.Z),
                                                  dof(axis=newton.Axis.X)],
                           angular_axes=[dof(axis=newton.Axis.Y)],
                           parent_xform=wp.transform((0.0, 0.0, r), wp.quat_identity()))
    b.add_articulation([joint])
    b.add_shape_sphere(body, radius=r, cfg=cfg)


def oblique_parameters(s: Oblique, mode: str, settings: RunSettings, dt: float
                       ) -> tuple[dict[str, float], dict[str, Any]]:
    """The shape contact parameters of a non-injected oblique run and its meta: ``native``
    the ball's native ke, kd (at the reference velocity), mu = μ and the deadbeat kf;
    ``default`` Newton's ShapeConfig defaults with mu = μ; ``custom`` that plus
    ``settings.params``."""
    mu = s.friction
    if mode in ("native", "tuned"):
        v_ref = float(settings.options.get("reference_velocity_m_s",
                                           NATIVE_REFERENCE_VELOCITY_M_S))
        sd = native_ball(s.normal_scenario(v_ref))
        values = {"ke": sd.stiffness_n_per_m, "kd": sd.damping_ns_per_m,
                  "kf": deadbeat_kf(s, dt), "mu": mu}
        meta = {"reference_velocity_m_s": v_ref,
                "kf_rule": "m_s/dt (deadbeat: the slip stops within one step)"}
        if mode == "tuned":  # native plus the fitted friction knobs
            applied = oblique_tuned.friction("newton", settings, s, dt)
            values.update(mu=float(applied["mu"]), kf=float(applied["kf"]))
            meta = {"reference_velocity_m_s": v_ref, **oblique_tuned.meta(applied, settings)}
        return values, {**values, **meta}
    defaults = newton_contact_defaults()
    given = (settings.params or {}) if mode == "custom" else {}
    values = {**defaults, "mu": mu}
    for key, value in given.items():
        values[key] = check.non_negative(f"param.{key}", value)
    meta: dict[str, Any] = {**values, "engine_defaults": dict(defaults)}
    if mode == "custom":
        meta["params"] = dict(given)
    return values, meta


def run_oblique(s: Oblique, mode: str, settings: RunSettings, *,
                graphs: bool = True) -> ImpactRecord:
    """The oblique impact in Newton (Featherstone, the ball on a D6 joint, one warp CPU graph
    launch per step as the ball's): ``native``, ``default``, ``custom`` with Newton's own
    contact and friction (:func:`oblique_parameters`); ``injected`` the normal law through
    the contact's ke (the secant, as the ball's) and Coulomb friction through Newton's own
    friction with mu = μ and the deadbeat kf (:func:`deadbeat_kf`), which is ideal Coulomb
    for the step. Forces: m·Δv/dt of the ball where in contact, normal and tangential (Newton
    reports no contact force)."""
    return _run_alone(_oblique_setup(s, mode, settings), graphs)


def run_oblique_batch(items: list[tuple[Oblique, str, RunSettings]]) -> list[ImpactRecord]:
    """Many oblique runs, those at one step as the worlds of one model (a plane and a ball
    per world, :func:`_run_batch`), each world driven by its lone run's plan and end rule, so
    each record is the one :func:`run_oblique` gives, bit for bit (tested); an ``injected``
    world's normal law is evaluated in Python every step."""
    return _run_batch([_oblique_setup(*item) for item in items])


def _oblique_setup(s: Oblique, mode: str, settings: RunSettings) -> _Setup:
    """An oblique run set up (:class:`_Setup`): the contact and friction values and meta of
    ``mode``, the start (the ball GAP_STEPS steps of flight above the plane at (−V_n, V_t)
    and its spin), the drive plan and end rule, the normal force recorder and the record
    (tangential force m·Δv_t/dt where in contact; ``tuned``: the shapes' mu and kf read back
    from the finalized model)."""
    dt = float(settings.timestep_s or BALL_TIMESTEP_S)
    v0, v_t, m = s.normal_velocity_m_s, s.tangential_velocity_m_s, s.mass_kg
    meta: dict[str, Any] = {"solver": SOLVER, "float": "float32",
                            "moment_of_inertia_kg_m2": s.moment_of_inertia_kg_m2}
    normal = s.normal_scenario()
    t_est = hertz_duration_s(normal, v0)
    secant = None
    if mode == "injected":
        values = {"ke": 0.0, "kd": 0.0, "kf": deadbeat_kf(s, dt), "mu": s.friction}
        secant = _ball_secant(normal.law())
        meta.update(law=s.model, kf=values["kf"], mu=values["mu"],
                    kf_rule="m_s/dt (deadbeat: ideal Coulomb for the step)")
    else:
        values, more = oblique_parameters(s, mode, settings, dt)
        meta.update(more)
        if values["ke"] > 0.0:
            t_est = approach_damped_duration_s(values["ke"], values["kd"], m)
    mu = values["mu"]
    facts = oblique_common.friction_facts(
        OBLIQUE_FRICTION_MODEL, OBLIQUE_FRICTION_COMBINATION, mu, mu, mu, kf=values["kf"],
        kd=values["kd"], moment_of_inertia_kg_m2=s.moment_of_inertia_kg_m2)
    meta["engine_defaults"] = {**meta.get("engine_defaults", {}), **facts}
    meta.update(force_output="m·Δv/dt of the ball where in contact, normal and tangential "
                             "(no contact output)")

    def force(q: np.ndarray, qd: np.ndarray, qd_next: np.ndarray) -> np.ndarray:
        return np.where(q[:, 0] < 0.0, m * (qd_next[:, 0] - qd[:, 0]) / dt, 0.0)

    gap = GAP_STEPS * v0 * dt

    def finish(out: _Outcome, steps: int, stepping: str, model: Any, shapes: slice
               ) -> ImpactRecord:
        if mode == "tuned":  # what the finalized model holds (both shapes)
            meta["engine_defaults"].update(
                shape_material_mu=[float(v) for v in model.shape_material_mu.numpy()[shapes]],
                shape_material_kf=[float(v) for v in model.shape_material_kf.numpy()[shapes]])
        x, rate = -out.qpos[:, 0], -out.qvel[:, 0]
        vt, spin = out.qvel[:, 1], out.qvel[:, 2]
        ft = np.zeros_like(x)
        if x.size > 1:
            ft[:-1] = np.where(x[:-1] > 0.0, m * np.diff(vt) / dt, 0.0)
        t = np.arange(x.size) * dt - gap / v0
        meta.update(steps=steps, stepping=stepping)
        rec = oblique_common.record(s, t, x, rate, out.force_n, vt, spin, ft, meta)
        return oblique_common.finish(rec, s, tunneled=bool(x.size and x[-1] > s.radius_m
                                                           and rate[-1] >= 0.0),
                                     timed_out=out.timed_out)

    return _Setup(functools.partial(_add_oblique, s=s, values=values), (0.0, 0.0, 0.0), dt,
                  (gap, 0.0, 0.0), (-v0, v_t, s.spin_rad_s), force,
                  drive_plan(settings, dt, gap / v0, t_est, 8), ball_end_finder(), finish,
                  secant=secant)


# --------------------------------------------------------------------------- bounce to rest

BOUNCE_TIMESTEP_S = 1.0 / 1200.0  # newton 1.8, examples/contacts/example_newton_cradle.py
"""The bounce's customary step (s): Newton's own example of spheres in Featherstone's penalty
contact, ``newton/examples/contacts/example_newton_cradle.py`` (newton 1.8), steps at
``fps = 60`` with ``SUBSTEPS["featherstone"] = 20``, 1/1200 s (its other Featherstone contact
examples step finer: ``example_balance_bird.py`` 1/3000 s, ``example_domino_spiral.py``
1/6000 s)."""
BOUNCE_CHUNK_S = 0.1
"""Simulated time (s) stepped per chunk of a bounce run (at most :data:`RECORD_CAPACITY`
steps): the end rule is checked after every step of a chunk, and the steps a chunk takes past
the end (less than a chunk, ≈ 1 ms of wall time at 1/1200 s) are dropped."""


def run_bounce(scenario: Bounce, mode: str, settings: RunSettings, *,
               graphs: bool = True) -> ImpactRecord:
    """The bounce to rest in Newton: :func:`ball_model` (the ground plane, a half-space, and
    the ball on its z prismatic joint) with the head-on ball's contact for ``mode``
    (:meth:`Bounce.ball`, :func:`_ball_contact`), the ball released at rest with its lowest
    point ``height_m`` above the plane, gravity g along −z throughout, stepped at
    ``settings.timestep_s`` in warp CPU graphs (:class:`NewtonSim`) and recorded every step:
    x = −q (m), ẋ = −q̇ (m/s), F = m·(Δu/dt + g) where in contact (N, :func:`_ball_force`,
    Newton reports no contact force), until :class:`~impactbench.engines.bounce.BounceEnd`
    (tunnelled: the centre R below the surface, as the ball's). Featherstone's penalty
    contact has no restitution velocity threshold (the material ``restitution`` is read by
    XPBD only), so no ``bounce_threshold_m_s``."""
    run = _BounceRun(scenario, mode, settings)
    sim = NewtonSim(ball_model(run.ball, run.contact.values), run.dt, (scenario.height_m,),
                    (0.0,), _ball_force(run.ball, run.dt), secant=run.contact.secant,
                    graphs=graphs)
    record = run.recording(*sim.state())
    try:
        n = next(record)
        while True:
            sim.chunks.clear()
            sim.step_chunk(n)
            n = record.send((*sim.arrays(), *sim.state()))
    except StopIteration as done:
        return run.finish(*done.value, sim.stepping)


def run_bounce_batch(items: list[tuple[Bounce, str, RunSettings]]) -> list[ImpactRecord]:
    """Many bounce runs, those at one step and gravity as the worlds of one model (a plane
    and a ball per world), stepped together chunk by chunk: each world's samples go through
    its lone run's recording and end rule (:meth:`_BounceRun.recording`, every step in
    order) until it ends, each round as many steps as the unfinished world that wants the
    fewest asks for, so each record is the one :func:`run_bounce` gives, bit for bit
    (tested); an ``injected`` world's law is evaluated in Python every step."""
    runs = [_BounceRun(*item) for item in items]
    out: list[ImpactRecord | None] = [None] * len(runs)
    groups: dict[tuple[float, float], list[int]] = {}
    for i, run in enumerate(runs):
        groups.setdefault((run.dt, run.ball.gravity_m_s2), []).append(i)
    for group in groups.values():
        if len(group) == 1:
            out[group[0]] = run_bounce(*items[group[0]])
            continue
        for i, rec in zip(group, _bounce_worlds([runs[i] for i in group]), strict=True):
            out[i] = rec
    return [r for r in out if r is not None]


def _bounce_worlds(runs: list[_BounceRun]) -> list[ImpactRecord]:
    """Bounce runs at one step and gravity as the worlds of one model (see
    :func:`run_bounce_batch`)."""
    model, shapes = worlds_model(
        (0.0, 0.0, -runs[0].ball.gravity_m_s2),
        [functools.partial(_add_ball, s=r.ball, values=r.contact.values) for r in runs])
    injections = {k: Injection(slice(k, k + 1), shapes[k], r.contact.secant)
                  for k, r in enumerate(runs) if r.contact.secant is not None}
    forces = [_ball_force(r.ball, r.dt) for r in runs]

    def force(q: np.ndarray, qd: np.ndarray, qd_next: np.ndarray) -> np.ndarray:
        return np.column_stack([f(q[:, [k]], qd[:, [k]], qd_next[:, [k]])
                                for k, f in enumerate(forces)])

    sim = NewtonSim(model, runs[0].dt, tuple(r.scenario.height_m for r in runs),
                    (0.0,) * len(runs), force, injections=list(injections.values()))
    q_end, qd_end = sim.state()
    records = [r.recording([q_end[k]], [qd_end[k]]) for k, r in enumerate(runs)]
    wants: list[int | None] = [next(record) for record in records]
    done: list[tuple[Recorder, int, float] | None] = [None] * len(runs)
    while any(w is not None for w in wants):
        n = min(w for w in wants if w is not None)
        sim.chunks.clear()
        sim.step_chunk(n)
        q, qd, f = sim.arrays()
        q_end, qd_end = sim.state()
        for k, record in enumerate(records):
            if wants[k] is None:
                continue
            try:
                wants[k] = record.send((q[:, [k]], qd[:, [k]], f[:, k], [q_end[k]],
                                        [qd_end[k]]))
            except StopIteration as end:
                done[k], wants[k] = end.value, None
                if k in injections:
                    injections[k].active = False
    return [r.finish(*d, sim.stepping + (INJECTED_STEPPING if k in injections else ""))
            for k, (r, d) in enumerate(zip(runs, done, strict=True)) if d is not None]


class _BounceRun:
    """A bounce run's ball, contact for ``mode`` (:func:`_ball_contact`), step (s) and end
    rule; its recording (:meth:`recording`) and record (:meth:`finish`)."""

    def __init__(self, scenario: Bounce, mode: str, settings: RunSettings) -> None:
        self.scenario = scenario
        self.ball = scenario.ball()
        self.dt = float(settings.timestep_s or BOUNCE_TIMESTEP_S)
        self.contact = _ball_contact(self.ball, mode, settings)
        self.end = BounceEnd(scenario, self.dt, settings.max_time_s, self.ball.radius_m)

    def recording(self, q0: list[float], qd0: list[float]
                  ) -> Generator[int, tuple[Any, ...], tuple[Recorder, int, float]]:
        """Record each step — its start state (x, ẋ) and force — until the end rule says so
        after a step or its step cap; then the state the last step ended in (force 0). A
        generator from the start state (``q0``, ``qd0``: the ball's joint coordinate and
        rate): it yields the steps it wants next (a chunk, at most :data:`RECORD_CAPACITY`),
        is sent ``(q, qd, f, q_end, qd_end)`` — the samples of the steps taken (as many or
        fewer), one row each, and the state after the last — and returns the recorder, the
        steps recorded and the final ẋ (m/s)."""
        dt, end = self.dt, self.end
        rec = Recorder()
        append, ended = rec.append, end.ended
        chunk = max(1, min(RECORD_CAPACITY, math.ceil(BOUNCE_CHUNK_S / dt)))
        x, v = -q0[0], -qd0[0]
        k, done = 0, False
        while not done and k < end.n_max:
            q, qd, f, q_end, qd_end = yield min(chunk, end.n_max - k)
            xs = (-q[1:, 0]).tolist()
            xs.append(-q_end[0])
            vs = (-qd[1:, 0]).tolist()
            vs.append(-qd_end[0])
            for f_k, x_next, v_next in zip(f.tolist(), xs, vs, strict=True):
                append(k * dt, x, v, f_k, v)
                x, v = x_next, v_next
                k += 1
                if ended(x, v, f_k):
                    done = True
                    break
        append(k * dt, x, v, 0.0, v)
        return rec, k, v

    def finish(self, rec: Recorder, steps: int, v_end: float, stepping: str) -> ImpactRecord:
        self.contact.meta.update(steps=steps, stepping=stepping)
        return self.end.finish(rec, self.scenario, v_end, **self.contact.meta)


# --------------------------------------------------------------------------- the adapter

def newton_builders() -> dict[str, Builder]:
    """Newton's :attr:`~impactbench.engines.base.Adapter.builders`: the suite's scenarios at
    its customary steps, each head-on, 2-DOF, oblique and bounce builder with its batch
    (many runs as the worlds of one model)."""
    return scenario_builders(
        ball_s=BALL_TIMESTEP_S, pair_s=RIGID_FLEXIBLE_TIMESTEP_S, oblique_s=BALL_TIMESTEP_S,
        oblique_tuned_check=oblique_tuned.refused, engine_3d="newton",
        ball_batch="run_ball_batch", pair_batch="run_rigid_flexible_batch",
        oblique_batch="run_oblique_batch", bounce_s=BOUNCE_TIMESTEP_S,
        bounce_batch="run_bounce_batch")


class NewtonAdapter(Adapter):
    """Newton (pip ``newton``): Featherstone with penalty contact, both scenarios, float32."""

    name = "newton"
    pip = "pip install newton"
    injection = ("the law through Newton's penalty contact: each shape's ke set every step to "
                 "the law's secant F(x, ẋ)/x at the start state (kd = 0), stepped by "
                 "Featherstone's semi-implicit Euler; oblique: Coulomb friction through "
                 "Newton's own friction, mu = μ and kf = m_s/dt (capped −kf·v_slip: ideal "
                 "Coulomb for the step)")
    modes = ("native", "injected", "tuned", "default", "custom")
    parameter_keys = PARAMETER_KEYS
    tuned_parameters = "ke, optional kd"
    builders = newton_builders()
    # builders only build (Adapter.run has checked the mode, the keys and the tuned file)
    run_ball = staticmethod(run_ball)
    run_ball_batch = staticmethod(run_ball_batch)
    run_rigid_flexible = staticmethod(run_rigid_flexible)
    run_rigid_flexible_batch = staticmethod(run_rigid_flexible_batch)
    run_oblique = staticmethod(run_oblique)
    run_oblique_batch = staticmethod(run_oblique_batch)
    run_bounce = staticmethod(run_bounce)
    run_bounce_batch = staticmethod(run_bounce_batch)

    def version(self) -> str:
        wp, newton = _newton()
        return f"{newton.__version__} (warp {wp.__version__})"
