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

Stepping is a Python loop (collide, step, read the joint state) on warp's CPU device. Warp
compiles each kernel module on first use (18–40 s per solver on this machine kind) into its
kernel cache (``warp.config.kernel_cache_dir``, by default under the user's cache directory), so
later processes load them in well under a second.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np
from impactbench.engines.base import Adapter, Builder, EngineUnavailable, RunSettings
from impactbench.engines.common import (
    NATIVE_REFERENCE_VELOCITY_M_S,
    SpringDamper,
    classify,
)
from impactbench.engines.mujoco_adapter import (
    GAP_STEPS,
    ball_end_finder,
    drive,
    face_radius_m,
    hertz_duration_s,
    rigid_flexible_end_finder,
    rigid_flexible_record,
)
from impactbench.reference import validation as check
from impactbench.reference.record import ImpactRecord, Status
from impactbench.reference.scenarios import BallOnPlate, RigidFlexible
from scipy import optimize

BALL_TIMESTEP_S = 1e-6
RIGID_FLEXIBLE_TIMESTEP_S = 1e-5
PARAMETER_KEYS: tuple[str, ...] = ("ke", "kd", "kf", "mu")
"""Newton's ShapeConfig contact parameters accepted in ``custom`` mode."""
SOLVER = "featherstone"


@functools.lru_cache(maxsize=1)
def _newton() -> tuple[Any, Any]:
    """(warp, newton), warp quiet and initialised; EngineUnavailable if missing."""
    try:
        import newton
        import warp as wp
    except ImportError as exc:
        raise EngineUnavailable("newton", str(exc)) from exc
    wp.config.quiet = True  # no device banner on stdout
    wp.config.log_level = max(wp.config.log_level, wp.LOG_WARNING)  # nor module load lines
    wp.init()
    return wp, newton


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
    wp, newton = _newton()
    b = newton.ModelBuilder(gravity=(0.0, 0.0, -s.gravity_m_s2))
    cfg = _shape_config(newton, values)
    b.add_ground_plane(cfg=cfg)
    r, m = s.radius_m, s.mass_kg
    i = 0.4 * m * r * r
    body = b.add_link(mass=m, com=(0.0, 0.0, r), inertia=wp.mat33(i, 0, 0, 0, i, 0, 0, 0, i))
    joint = b.add_joint_prismatic(-1, body, axis=newton.Axis.Z)
    b.add_articulation([joint])
    b.add_shape_sphere(body, xform=wp.transform((0.0, 0.0, r), wp.quat_identity()),
                       radius=r, cfg=cfg)
    return b.finalize(device="cpu")


def rigid_flexible_model(s: RigidFlexible, values: dict[str, float]) -> Any:
    """Two spheres on x prismatic joints touching at q = 0; joint 2's stiffness is k2."""
    wp, newton = _newton()
    b = newton.ModelBuilder(gravity=(0.0, 0.0, 0.0))
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
    return b.finalize(device="cpu")


# --------------------------------------------------------------------------- stepping


@dataclass
class NewtonSim:
    """A Featherstone simulation stepped in a Python loop, one sample per step.

    ``hook(q, qd) → (joint forces or None, contact ke or None)`` is called at each step's start
    (injected and softening runs): the joint forces go into ``control.joint_f``, the ke into
    every shape's ``shape_material_ke``; ``commit(q)`` runs after the step (a law's memory).
    ``force(q, qd, qd_next)`` turns the step into the recorded contact force.
    """

    model: Any
    dt: float
    q0: tuple[float, ...]
    qd0: tuple[float, ...]
    force: Any
    hook: Any = None
    commit: Any = None
    steps: int = 0
    chunks: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = field(default_factory=list)

    def __post_init__(self) -> None:
        newton = _newton()[1]
        m = self.model
        self.s0, self.s1, self.control = m.state(), m.state(), m.control()
        self.s0.joint_q.assign(np.asarray(self.q0, dtype=np.float32))
        self.s0.joint_qd.assign(np.asarray(self.qd0, dtype=np.float32))
        newton.eval_fk(m, self.s0.joint_q, self.s0.joint_qd, self.s0)
        self.solver = newton.solvers.SolverFeatherstone(m)
        self.pipeline = newton.CollisionPipeline(m)
        self.contacts = self.pipeline.contacts()
        # views on the CPU device's memory: writes land in what the kernels read
        self.joint_f = self.control.joint_f.numpy()
        self.ke = m.shape_material_ke.numpy()

    def step_chunk(self, n: int) -> None:
        s0, s1, control, contacts = self.s0, self.s1, self.control, self.contacts
        solver, pipeline, dt = self.solver, self.pipeline, self.dt
        hook, commit, joint_f, ke = self.hook, self.commit, self.joint_f, self.ke
        qs, vs, fs = [], [], []
        for _ in range(n):
            q, qd = s0.joint_q.numpy().tolist(), s0.joint_qd.numpy().tolist()
            if hook is not None:
                forces, stiffness = hook(q, qd)
                if forces is not None:
                    joint_f[:] = forces
                if stiffness is not None:
                    ke[:] = stiffness
            s0.clear_forces()
            pipeline.collide(s0, contacts)
            solver.step(s0, s1, control, contacts, dt)
            s0, s1 = s1, s0
            if commit is not None:
                commit(q)
            qs.append(q)
            vs.append(qd)
            fs.append(self.force(q, qd, s0.joint_qd.numpy().tolist()))
        self.s0, self.s1 = s0, s1
        self.steps += n
        self.chunks.append((np.array(qs, dtype=float), np.array(vs, dtype=float),
                            np.array(fs, dtype=float)))

    def arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        qs, vs, fs = zip(*self.chunks, strict=True)
        return np.concatenate(qs), np.concatenate(vs), np.concatenate(fs)

    def unstable(self) -> bool:
        return False  # a blow-up shows as non-finite state


# --------------------------------------------------------------------------- scenarios


def run_ball(s: BallOnPlate, mode: str, settings: RunSettings) -> ImpactRecord:
    """Ball-on-plate in Newton; see the module docstring."""
    dt = float(settings.timestep_s or BALL_TIMESTEP_S)
    v0, m, g = s.velocity_m_s, s.mass_kg, s.gravity_m_s2
    meta: dict[str, Any] = {"solver": SOLVER, "float": "float32"}
    t_est = hertz_duration_s(s, v0)
    hook = None
    if mode == "injected":
        law = s.law()
        values = {"ke": 0.0, "kd": 0.0, "kf": 0.0, "mu": 0.0}

        def hook(q: list[float], qd: list[float]) -> tuple[None, float]:
            x = -q[0]  # ke·x = F(x, ẋ) at the start state; kd = 0
            return None, (law.force(x, -qd[0]) / x if x > 0.0 else 0.0)

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
            t_est = approach_damped_duration_s(values["ke"], values["kd"], m)

    def force(q: list[float], qd: list[float], qd_next: list[float]) -> float:
        return m * ((qd_next[0] - qd[0]) / dt + g) if q[0] < 0.0 else 0.0

    meta.update(force_output="m·Δv/dt of the ball where in contact (no contact output)")
    gap = GAP_STEPS * v0 * dt
    sim = NewtonSim(ball_model(s, values), dt, (gap,), (-v0,), force, hook=hook)
    max_time = settings.max_time_s or gap / v0 + 20.0 * t_est
    n_max = max(math.ceil(max_time / dt), math.ceil(GAP_STEPS) + 16)
    first = math.ceil(GAP_STEPS) + math.ceil(t_est / dt) + 2
    chunk = max(8, math.ceil(0.05 * t_est / dt))
    out = drive(sim, n_max, first, chunk, ball_end_finder())
    x, rate = -out.qpos[:, 0], -out.qvel[:, 0]
    t = np.arange(x.size) * dt - gap / v0
    meta.update(steps=sim.steps, stepping="python loop")
    rec = ImpactRecord(t, x, rate, out.force_n, rate, np.zeros_like(x), mass_1_kg=m,
                       mass_2_kg=math.inf, meta=meta)
    final = 0.5 * m * rate[-1] ** 2 if x.size else math.nan
    return classify(rec, initial_kinetic_j=0.5 * m * v0 * v0, final_kinetic_j=final,
                    tunneled=bool(x.size and x[-1] > s.radius_m and rate[-1] >= 0.0),
                    timed_out=out.timed_out)


def run_rigid_flexible(s: RigidFlexible, mode: str, settings: RunSettings) -> ImpactRecord:
    """Rigid–flexible 2-DOF impact in Newton; see the module docstring."""
    dt = float(settings.timestep_s or RIGID_FLEXIBLE_TIMESTEP_S)
    structure = s.structural_law()
    beta = s.beta_n_per_m3 if s.structure == "softening" else 0.0
    meta: dict[str, Any] = {"solver": SOLVER, "float": "float32",
                            "face_radius_m": face_radius_m(s)}
    m1 = s.m1_kg
    commit = None
    cubic = [0.0, 0.0]
    if mode == "injected":
        law = s.local_law()
        values = {"ke": 0.0, "kd": 0.0, "kf": 0.0, "mu": 0.0}

        def hook(q: list[float], qd: list[float]) -> tuple[list[float], float]:
            dx = q[0] - q[1]  # ke·Δx = F1(Δx), the secant
            cubic[1] = beta * q[1] ** 3
            return cubic, (law.force(dx) / dx if dx > 0.0 else 0.0)

        def commit(q: list[float]) -> None:
            law.update(q[0] - q[1])

        meta.update(law=s.local)
    else:
        values, more = contact_parameters(mode, settings, (s.k1_n_per_m, 0.0))
        meta.update(more)
        if mode == "native":
            meta.update(stiffness_n_per_m=s.k1_n_per_m, damping_ns_per_m=0.0)

        def hook(q: list[float], qd: list[float]) -> tuple[list[float], None]:
            cubic[1] = beta * q[1] ** 3
            return cubic, None

    meta.update(force_output="m1·Δu1/dt of body 1 where in contact (no contact output)")

    def force(q: list[float], qd: list[float], qd_next: list[float]) -> float:
        return -m1 * (qd_next[0] - qd[0]) / dt if q[0] > q[1] else 0.0

    v1 = s.velocity_m_s
    gap = GAP_STEPS * v1 * dt
    sim = NewtonSim(rigid_flexible_model(s, values), dt, (-gap, 0.0), (v1, 0.0), force,
                    hook=hook if beta or mode == "injected" else None, commit=commit)
    m_eff = s.m1_kg * s.m2_kg / (s.m1_kg + s.m2_kg)
    t_contact = math.pi * math.sqrt(m_eff / min(s.k1_n_per_m, s.k2_n_per_m))
    n_max = math.ceil((settings.max_time_s or s.max_time_s) / dt)
    chunk = max(64, math.ceil(0.1 * t_contact / dt))
    first = chunk if beta else math.ceil(GAP_STEPS) + math.ceil(2.0 * t_contact / dt)
    collapsed: list[int] = []
    out = drive(sim, n_max, first, chunk, rigid_flexible_end_finder(s, structure, collapsed))
    meta.update(steps=sim.steps, stepping="python loop")
    return rigid_flexible_record(s, structure, out, dt, gap, meta, collapsed)


# --------------------------------------------------------------------------- the adapter


class NewtonAdapter(Adapter):
    """Newton (pip ``newton``): Featherstone with penalty contact, both scenarios, float32."""

    name = "newton"
    pip = "pip install newton"
    injection = ("the law through Newton's penalty contact: each shape's ke set every step to "
                 "the law's secant F(x, ẋ)/x at the start state (kd = 0), stepped by "
                 "Featherstone's semi-implicit Euler")
    modes = ("native", "injected", "tuned", "default", "custom")
    parameter_keys = PARAMETER_KEYS
    builders: ClassVar[dict[str, Builder]] = {
        "ball-on-plate": Builder("run_ball", BALL_TIMESTEP_S),
        "rigid-flexible": Builder("run_rigid_flexible", RIGID_FLEXIBLE_TIMESTEP_S),
    }

    def version(self) -> str:
        wp, newton = _newton()
        return f"{newton.__version__} (warp {wp.__version__})"

    def run_ball(self, scenario: BallOnPlate, mode: str, settings: RunSettings) -> ImpactRecord:
        if mode == "tuned" and settings.tuned is None:
            return _no_tuned_file()
        return run_ball(scenario, mode, settings)

    def run_rigid_flexible(self, scenario: RigidFlexible, mode: str, settings: RunSettings
                           ) -> ImpactRecord:
        if mode == "tuned" and settings.tuned is None:
            return _no_tuned_file()
        return run_rigid_flexible(scenario, mode, settings)


def _no_tuned_file() -> ImpactRecord:
    return ImpactRecord.failed(
        Status.UNSUPPORTED, "tuned mode needs a tuned-parameter file (none given)")
