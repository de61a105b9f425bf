"""The reference model's corner contact in the engines: the cube tosses' ``native`` and
``injected`` modes.

The reference model (:mod:`impactbench.reference.box_contact`, fitted on the training tosses:
:func:`impactbench.cube_tosses.reference_model.load_fitted`) gives each corner of the box a
Hunt–Crossley normal law F_n = c·xⁿ·(1 + b·ẋ) (c = 8.82e5 N/mⁿ, n = 1.619, b = 3.20 s/m) and
regularised Coulomb friction F_t = −μ·F_n·u_t/√(|u_t|² + v_s²) (μ = 0.178, v_s = 5.2 mm/s).

``native``: the law mapped into each engine's own contact parameters
=====================================================================

As for the ball (:func:`impactbench.engines.common.native_ball_spring_damper`), a contact law
of another form matches the reference at one operating point: **one corner's impact** on the
board at the reference normal speed V_ref with the reference effective mass m_ref
(:class:`OperatingPoint`), where the Hunt–Crossley corner has restitution e_ref and contact
duration T_ref (:func:`corner_impact`, the zoo's :func:`~impactbench.reference.hunt_crossley.
solve_law`).

The operating point is measured on the training tosses (:func:`measure_operating_point`): each
toss's replay start, flown ballistically (the model's own free flight) to the instant its first
corner touches the board; there the corner's normal speed and its effective mass along the
normal, 1/m_eff = 1/m + |r × n|²/I (r the corner's lever arm, n the board's normal). The medians
over the 367 training tosses are V_ref = :data:`REFERENCE_SPEED_M_S` (1.10 m/s; quartiles 0.98
and 1.20) and a lever term λ = |r × n|²/h² = :data:`REFERENCE_LEVER` (0.519; quartiles 0.25 and
0.87), so m_ref = 1/(1/m + λ·h²/I) = 0.224 kg for DAIR's cube (a corner straight down has
λ = 0 and m_eff = m; a face flat λ = 2 and m_eff = 0.105 kg). Why the first touch: it is the
fastest impact of a toss, the one that decides where the cube goes; later bounces are slower
and a Hunt–Crossley law's restitution rises as the speed falls. The lever term (not the mass)
is the stored quantity, so a user's box gets its own m_ref. At that point the fitted law gives
e_ref = 0.269, T_ref = 13.0 ms (peak force 102 N, penetration 2.35 mm).

Friction is μ for every engine: each body gets the value its engine's combination rule needs
for the *pair* to have μ (the rules are :mod:`~impactbench.engines.cube_toss`' and
:mod:`~impactbench.engines.cube_toss_more`'s). The regularisation v_s maps where the engine
has a parameter of that role (Drake's stiction tolerance, Newton's friction slope).

Per engine (:func:`native_mapping`; the numbers are DAIR's cube with the packaged fit; each
engine's own contact law with the mapped values, integrated as an ODE, has e_ref and T_ref at
the operating point: ``tests/impactbench/test_cube_toss_modes.py``):

- **PyBullet**: the clipped linear spring–damper with the corner's e_ref and T_ref at m_ref
  (:func:`impactbench.engines.common.spring_damper_matching`): k = 7.36e3 N/m, d = 45.1 N·s/m
  (ζ = 0.555, ωn = 181 rad/s) at every contact point (Bullet's soft contact is k·x + d·ẋ per
  manifold point, checked against ``getContactPoints``); Bullet puts the two bodies'
  stiffnesses in series and sums their dampings, so board and cube each get 2k and d/2.
  Friction: Bullet multiplies the two lateral frictions: board μ, cube 1; Bullet's friction is
  velocity-level Coulomb (no regularisation to map). The cube's linear and angular damping
  (Bullet's default 0.04 /s; the model has no drag) are set to 0.
- **MuJoCo** and **MJX**: the same spring–damper through a *direct* solref with a constant
  impedance d = 1e-4 (solimp (1e-4, 1e-4, 1 mm, 0.5, 2), MuJoCo's smallest, as the ball's
  native mode): a contact row's force is then (S·x + D·ẋ)/A − d·M·a₀, where A is MuJoCo's
  *approximate* diagonal of the row's inverse inertia, which against the fixed board is the
  cube's translational inverse weight 1/M whatever the orientation (measured: efc_diagA =
  1/0.37 kg at the operating point's corner, whose exact value is 1/m_ref = 1/0.224 kg). So
  solref = (−k/M, −d/M) = (−1.99e4, −122) gives every contact point exactly k and d (checked
  against ``mj_contactForce``; the leak d·M·g is 3.6e-4 N). Friction (μ, 0.005, 0.0001) on both
  geoms (MuJoCo takes the larger: the pair has μ), condim 3 and the **elliptic** cone: the
  model's friction is isotropic Coulomb (a circular cone), which MuJoCo's default pyramidal cone
  approximates by four edges. MuJoCo's friction regularisation (its soft friction rows) is its
  own: no parameter of the model's v_s role.
- **Drake**: its point contact IS Hunt–Crossley with n = 1, f = k·x·(1 + d·ẋ). A
  Hunt–Crossley law's restitution depends on b·V alone, whatever n and c (the energy integral;
  the zoo's :func:`~impactbench.reference.hunt_crossley.restitution`), so d = b = 3.20 s/m keeps
  the model's restitution at **every** speed; k is chosen so that the linear law's duration is
  T_ref at (V_ref, m_ref): the problem is self-similar in √(m/k), so k = m_ref·(τ₁/T_ref)²
  with τ₁ the duration at k = m_ref (the ball's rule): k = 1.79e4 N/m (pair values; Drake puts
  the geometries' stiffnesses in series and weights their dissipations by them, so both get 2k
  and d). The exponent itself cannot be expressed: the linear law is stiffer than the model's
  below 1.84 mm of penetration (where the two secant stiffnesses are equal) and softer beyond;
  at the operating point it peaks at 88 N and 2.22 mm against the model's 102 N and 2.35 mm.
  Friction μ on both (Drake's 2ab/(a+b)), ``stiction_tolerance`` = v_s, the point contact
  model and the **TAMSI** approximation, the one discrete approximation that uses both the
  Hunt–Crossley dissipation and the stiction tolerance (SAP, similar and lagged regularise
  friction their own way, and SAP also ignores d). Drake's point contact between a box and a
  half-space is one point (the deepest corner), not one per corner.
- **Newton** (``SolverSemiImplicit``): its penalty law is f = ke·x + kd·max(ẋ, 0), damped in
  compression only; (ke, kd) solve that law's restitution and duration
  (:func:`compression_damped`) for e_ref and T_ref at m_ref: ke = 7.75e3 N/m, kd = 128 N·s/m
  (ζ = 1.54: the compression must be overdamped for a restitution below 1/e); both shapes get
  them (Newton averages). Friction min(kf·|v_t|, μ·f_n): μ, and kf = μ·F_rest/v_s =
  31.3 N·s/m, the model's slope at zero slip under a corner's share of the weight at rest,
  F_rest = M·g/4 (where the slip is slow enough for the regularisation to matter).
- **SAPIEN** (PhysX): a compliant PhysX contact has no settable damping (SAPIEN exposes no
  material damping), and an undamped spring would return the 93 % of the corner's energy the
  fitted law dissipates at V_ref; so the rigid contact with restitution e_ref = 0.269 (both
  materials: PhysX averages) and ``bounce_threshold`` 0 (as the ball's rigid variant), friction
  μ static and dynamic on both, and the cube's damping 0 (PhysX's default angular damping
  0.05 /s).
- **DART**: rigid (boxed LCP) with restitution e_ref (DART multiplies the two: board 1, cube
  e_ref) and friction μ on both (DART takes the smaller).

Where the match holds: at the operating point, one corner, in one dimension. In the tumbling
cube the corner's lever arm turns during the contact, and the laws respond differently (the
operating point's corner with the cube free to rotate, no friction or gravity: restitution of
the corner's normal speed 0.341 under the model's law, 0.374 under the matched spring–damper
in MuJoCo and PyBullet, 0.298 under Drake's linear Hunt–Crossley).

Measured on the 89 test tosses (median position error / width and rotation error; the
reference model 0.101 and 9.3°): native PyBullet 0.106 / 7.0°, MuJoCo 0.103 / 7.9°, MJX
0.106 / 8.1°, Drake 0.102 / 8.9°, SAPIEN 0.102 / 14.1°, DART 0.215 / 13.0°, Newton
0.113 / 7.6°.

``injected``: the model's corner law through the engine
========================================================

The engine's own box–board contact is switched off (PyBullet: a collision filter on the pair;
MuJoCo: ``mjDSBL_CONTACT``; DART, SAPIEN, Drake: no board in the world) and at every step the
model's corner forces at the step's start state — penetration and velocity of each corner from
the engine's pose and velocities, the normal law and the regularised friction, summed into a
force at the centre and a torque (:class:`CornerWrench`, which calls the model's own
right-hand side :meth:`~impactbench.reference.box_contact.BoxOnBoard.rhs`) — are applied as an
external force and torque for that step (PyBullet ``applyExternalForce``/``Torque``, MuJoCo
``xfrc_applied``, DART ``setExtForce``/``setExtTorque``, SAPIEN ``add_force_torque``, Drake the
plant's applied-spatial-force input port, fixed to the wrench before each discrete step).
Body damping the engine adds by default is set to 0 (PyBullet, SAPIEN). What differs from the
reference model is then the engine's integrator and its step (the model is integrated to
convergence): PyBullet, MuJoCo (Euler), DART and SAPIEN step semi-implicit Euler alike and
agree to 1e-8 widths (SAPIEN's float32 to 1e-5), Drake's discrete plant differs slightly.
Measured on the 89 test tosses at DAIR's step 1/1480 s: the injected trajectory is within
0.0085 widths / 1.2° of the model's (medians over tosses of the time-mean gap; Drake 0.0095 /
1.2°; a few chaotic tosses part by up to 0.13 widths), and the errors against the data have
the model's medians (0.100 / 9.5° against 0.101 / 9.3°). The gap is the stepping: it shrinks
with the step (five test tosses in MuJoCo and Drake: a 10× finer step makes the position gaps
5× to 280× smaller, 30× finer 16× to 750×; the engines' integrators are first order).
MJX and Newton are ``unsupported`` (their cube-toss builders say why,
:data:`impactbench.engines.base.CUBE_TOSS_NOT_INJECTED`): they step inside compiled,
batched calls with no Python between steps.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Iterable, Mapping
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np
from scipy import integrate, optimize

from impactbench.cube_tosses.protocol import DAIR_BOX, GRAVITY_M_S2, Box
from impactbench.reference.box_contact import (
    BoxContactParams,
    BoxOnBoard,
    CornerWrench,
    quat_matrix,
)

MODES = ("native", "injected")

FITTED_PATH = Path(__file__).resolve().parents[1] / "data" / "tuned" / "cube_toss" / \
    "reference.toml"
"""The packaged fit of the reference model (the file
:func:`impactbench.cube_tosses.reference_model.load_fitted` reads; read here by
:func:`load_model`, since that module imports the replay that imports this one)."""

REFERENCE_SPEED_M_S = 1.0995
"""V_ref: the median normal speed (m/s) of a toss's first touching corner over the training
tosses (:func:`measure_operating_point`; quartiles 0.98 and 1.20 m/s)."""
REFERENCE_LEVER = 0.5192
"""λ_ref: the median of |r × n|²/h² of that corner (dimensionless; 0 for a corner straight
down, 2 for a face flat; quartiles 0.25 and 0.87)."""
RESTING_SHARE = 0.25
"""The share of the weight one corner carries at rest (four corners): Newton's friction slope
is matched there."""

NATIVE_ENGINES = ("pybullet", "mujoco", "mjx", "drake", "sapien", "dart", "newton")
# ------------------------------------------------------------------------------ operating point


@dataclass(frozen=True)
class OperatingPoint:
    """Where the native mappings match the corner law: a corner hitting the board at normal
    speed ``speed_m_s`` with lever term ``lever`` = |r × n|²/h² (module doc)."""

    speed_m_s: float = REFERENCE_SPEED_M_S
    lever: float = REFERENCE_LEVER

    def mass_kg(self, box: Box = DAIR_BOX) -> float:
        """The corner's effective mass along the normal, 1/(1/m + λ·h²/I) (kg); a box with
        three moments uses the mean of 1/I."""
        inv_i = float(np.mean(1.0 / box.inertia))
        return 1.0 / (1.0 / box.mass_kg + self.lever * box.half_width_m ** 2 * inv_i)


def first_touch(p: np.ndarray, q: np.ndarray, v: np.ndarray, w_body: np.ndarray,
                box: Box = DAIR_BOX, board_z_m: float = 0.0,
                gravity_m_s2: float = GRAVITY_M_S2) -> dict[str, float]:
    """The first corner to touch the board from the state (p, q wxyz, v, ω body frame) in free
    flight (the model's own torque-free flight, integrated tightly): the time (s), its normal
    speed (m/s, > 0 approaching) and tangential speed, its lever term |r × n|²/h² and effective
    mass (kg). NaN when no corner reaches the board within 2 s."""
    model = BoxOnBoard(BoxContactParams(), box, board_z_m=board_z_m,
                       gravity_m_s2=gravity_m_s2)
    corners = box.corners

    def lowest(_t: float, y: np.ndarray) -> float:
        return float(y[2] + (corners @ quat_matrix(y[3:7]).T)[:, 2].min() - board_z_m)

    lowest.terminal = True   # type: ignore[attr-defined]
    lowest.direction = -1    # type: ignore[attr-defined]
    y0 = np.concatenate([p, np.asarray(q, float) / np.linalg.norm(q), v, w_body])
    nan = dict.fromkeys(("time_s", "normal_speed_m_s", "tangential_speed_m_s", "lever",
                         "mass_kg"), math.nan)
    if lowest(0.0, y0) <= 0.0:
        return nan
    sol = integrate.solve_ivp(model.rhs, (0.0, 2.0), y0, method="DOP853", rtol=1e-10,
                              atol=1e-12, events=lowest)
    if not sol.t_events[0].size:
        return nan
    y = sol.y_events[0][0]
    rot = quat_matrix(y[3:7])
    r = corners @ rot.T
    i = int(np.argmin(r[:, 2]))
    u = y[7:10] + np.cross(rot @ y[10:13], r[i])
    lever = float(r[i, 0] ** 2 + r[i, 1] ** 2) / box.half_width_m ** 2
    return {"time_s": float(sol.t_events[0][0]), "normal_speed_m_s": float(-u[2]),
            "tangential_speed_m_s": float(math.hypot(u[0], u[1])), "lever": lever,
            "mass_kg": OperatingPoint(1.0, lever).mass_kg(box)}


def measure_operating_point(tosses: str | Iterable[int] = "train", df: Any = None,
                            protocol: Any = None, box: Box = DAIR_BOX) -> dict[str, Any]:
    """The first touch (:func:`first_touch`) of every selected toss from its replay start
    (:func:`~impactbench.cube_tosses.protocol.prepare`): the medians and quartiles of the
    normal speed and of the lever term, and the :class:`OperatingPoint` of the medians."""
    import impactbench.cube_tosses.data as data_mod
    from impactbench.cube_tosses.protocol import Protocol, prepare

    protocol = protocol or Protocol(half_width_m=box.half_width_m)
    frame = data_mod.load(df) if not hasattr(df, "columns") else data_mod.validate(df)
    ids = (data_mod.split(data_mod.toss_ids(frame), tosses) if isinstance(tosses, str)
           else [int(i) for i in tosses])
    rows = []
    for toss in data_mod.tosses(frame, ids):
        s = prepare(toss, protocol)
        rows.append(first_touch(s.p, s.q, s.v, s.w_body, box, protocol.board_z_m,
                                protocol.gravity_m_s2))
    speed = np.array([r["normal_speed_m_s"] for r in rows])
    lever = np.array([r["lever"] for r in rows])
    ok = np.isfinite(speed) & np.isfinite(lever)
    q_speed = np.percentile(speed[ok], [25, 50, 75])
    q_lever = np.percentile(lever[ok], [25, 50, 75])
    return {"tosses": int(ok.sum()), "missed": int((~ok).sum()),
            "speed_m_s_quartiles": q_speed.tolist(), "lever_quartiles": q_lever.tolist(),
            "point": OperatingPoint(float(q_speed[1]), float(q_lever[1]))}


# ------------------------------------------------------------------------------ corner impact


@dataclass(frozen=True)
class CornerImpact:
    """One corner's impact under the reference law at the operating point (SI)."""

    mass_kg: float
    speed_m_s: float
    restitution: float
    duration_s: float
    peak_force_n: float
    max_penetration_m: float


def corner_impact(params: BoxContactParams | None = None, box: Box = DAIR_BOX,
                  point: OperatingPoint | None = None) -> CornerImpact:
    """The reference corner law's impact at ``point`` (default :class:`OperatingPoint`):
    restitution, duration, peak force and penetration from the zoo's Hunt–Crossley solution."""
    from impactbench.reference import hunt_crossley

    params = _fitted() if params is None else params
    point = point or OperatingPoint()
    m = point.mass_kg(box)
    law = params.corner_law()
    if params.law != "hunt-crossley":
        from impactbench.reference import kelvin_voigt

        r = kelvin_voigt.solve(m, law.stiffness, law.damping_ns_per_m, point.speed_m_s, True)
    else:
        r = hunt_crossley.solve_law(law, m, point.speed_m_s)
    return CornerImpact(m, point.speed_m_s, float(r["restitution"]), float(r["duration_s"]),
                        float(r["peak_force_n"]), float(r["max_penetration_m"]))


def load_model(path: str | Path | None = None) -> BoxContactParams:
    """The reference model's fitted parameters (``[parameters]`` of the fitted file: the
    packaged one, :data:`FITTED_PATH`, unless ``path``; one-line ValueError when it is missing
    or malformed)."""
    import tomllib

    src = Path(path) if path is not None else FITTED_PATH
    try:
        table = tomllib.loads(src.read_text())["parameters"]
        return BoxContactParams(**table)
    except (OSError, KeyError, TypeError, tomllib.TOMLDecodeError) as exc:
        raise ValueError(f"path = {str(src)!r}: not a fitted reference-model file "
                         f"({type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''})"
                         ) from None


def _fitted() -> BoxContactParams:
    return load_model()


def compression_phase(zeta: float) -> float:
    """φ(ζ) = ωn·t₁: the compression time of m·ẍ + d·ẋ + k·x = 0 from x = 0, ẋ = V (to
    ẋ = 0) in units of 1/ωn: atan2(s, ζ)/s with s = √(1−ζ²) (ζ < 1), 1 (ζ = 1),
    atanh(s/ζ)/s with s = √(ζ²−1) (ζ > 1)."""
    if zeta < 1.0:
        s = math.sqrt(1.0 - zeta * zeta)
        return math.atan2(s, zeta) / s
    if zeta == 1.0:
        return 1.0
    s = math.sqrt(zeta * zeta - 1.0)
    return math.atanh(s / zeta) / s


def compression_damped(mass_kg: float, restitution: float, duration_s: float
                       ) -> tuple[float, float]:
    """(k N/m, d N·s/m) of the law f = k·x + d·max(ẋ, 0) (damped in compression only: Newton's
    penalty contact) whose impact of ``mass_kg`` has this restitution and duration.

    Compression ends at ẋ = 0 after t₁ = φ(ζ)/ωn at x_max = (V/ωn)·e^(−ζφ); the undamped
    spring then returns the mass in a quarter period, so e = ωn·x_max/V = exp(−ζ·φ(ζ)) (a
    function of ζ alone, falling from 1 to 0) and T = (φ(ζ) + π/2)/ωn."""
    if not 0.0 < restitution < 1.0:
        raise ValueError(f"restitution = {restitution!r}: must be in (0, 1)")
    zeta = optimize.brentq(lambda z: math.exp(-z * compression_phase(z)) - restitution,
                           0.0, 1e3, xtol=1e-14, rtol=1e-14)
    wn = (compression_phase(zeta) + 0.5 * math.pi) / duration_s
    k = mass_kg * wn * wn
    return k, 2.0 * zeta * math.sqrt(k * mass_kg)


# ------------------------------------------------------------------------------ native


@dataclass(frozen=True)
class NativeMapping:
    """An engine's native parameters (``params``: the engine's own keys, as custom mode takes
    them), what they were mapped from (``inputs``) and the rule (``rule``)."""

    engine: str
    params: dict[str, Any]
    inputs: dict[str, Any]
    rule: str

    def describe(self) -> dict[str, Any]:
        return {"engine": self.engine, "params": _jsonable(self.params),
                "inputs": _jsonable(self.inputs), "rule": self.rule}


def _jsonable(v: Any) -> Any:
    if isinstance(v, Mapping):
        return {str(k): _jsonable(x) for k, x in v.items()}
    if isinstance(v, tuple | list):
        return [_jsonable(x) for x in v]
    return v


MUJOCO_IMPEDANCE = 1e-4
"""The native MuJoCo contact's constant impedance d (``mjMINIMP``; module doc)."""
MUJOCO_SOLIMP = (MUJOCO_IMPEDANCE, MUJOCO_IMPEDANCE, 0.001, 0.5, 2.0)


def native_mapping(engine: str, params: BoxContactParams | None = None, box: Box = DAIR_BOX,
                   point: OperatingPoint | None = None) -> NativeMapping:
    """The reference model's fitted contact (``params``: the packaged fit when None) mapped
    into ``engine``'s own parameters at ``point`` (module doc; ValueError for an engine without
    a mapping)."""
    if engine not in NATIVE_ENGINES:
        raise ValueError(f"engine = {engine!r}: native mode maps the model into "
                         f"{', '.join(NATIVE_ENGINES)}")
    params = _fitted() if params is None else params
    point = point or OperatingPoint()
    return _native(engine, params, box, point)


@functools.lru_cache(maxsize=64)
def _native(engine: str, params: BoxContactParams, box: Box, point: OperatingPoint
            ) -> NativeMapping:
    from impactbench.engines.common import spring_damper_matching

    imp = corner_impact(params, box, point)
    mu, vs = params.friction, params.slip_velocity_m_s
    inputs: dict[str, Any] = {
        "model": params.describe(),
        "operating_point": {"speed_m_s": point.speed_m_s, "lever": point.lever,
                            "mass_kg": imp.mass_kg},
        "corner_impact": asdict(imp),
        "box": {"half_width_m": box.half_width_m, "mass_kg": box.mass_kg,
                "inertia_kg_m2": box.inertia.tolist()},
    }
    m = imp.mass_kg
    if engine in ("pybullet", "mujoco", "mjx"):
        sd = spring_damper_matching(m, imp.restitution, imp.duration_s)
        k, d = sd.stiffness_n_per_m, sd.damping_ns_per_m
        inputs["spring_damper"] = {"stiffness_n_per_m": k, "damping_n_s_per_m": d,
                                   "zeta": sd.zeta(m), "omega_n_rad_s": math.sqrt(k / m)}
        if engine == "pybullet":
            out = {"board.contactStiffness": 2 * k, "cube.contactStiffness": 2 * k,
                   "board.contactDamping": d / 2, "cube.contactDamping": d / 2,
                   "board.lateralFriction": mu, "cube.lateralFriction": 1.0,
                   "cube.linearDamping": 0.0, "cube.angularDamping": 0.0}
            rule = ("the clipped linear spring-damper with the corner law's restitution and "
                    "duration at the operating point (pair: stiffness in series, damping "
                    "summed, so each body 2k and d/2); friction: product, board mu, cube 1; "
                    "the cube's body damping 0")
        else:
            # MuJoCo divides a direct solref by its approximate diagonal of the contact row's
            # inverse inertia, the cube's translational inverse weight 1/M (module doc)
            a = 1.0 / box.mass_kg
            solref = (-k * a, -d * a)
            inputs["mujoco"] = {"diag_approx_1_per_kg": a, "impedance": MUJOCO_IMPEDANCE}
            out = {"board.solref": solref, "cube.solref": solref,
                   "board.solimp": MUJOCO_SOLIMP, "cube.solimp": MUJOCO_SOLIMP,
                   "board.friction": (mu, 0.005, 0.0001), "cube.friction": (mu, 0.005, 0.0001),
                   "option.cone": "elliptic"}
            rule = ("the clipped linear spring-damper with the corner law's restitution and "
                    "duration at the operating point as a direct solref (-k/M, -d/M) with the "
                    "constant impedance 1e-4 on both geoms (each contact point gets k and d); "
                    "friction mu on both (the larger); the elliptic cone")
    elif engine == "drake":
        from impactbench.reference import hunt_crossley
        from impactbench.reference.laws import HuntCrossley

        if params.law != "hunt-crossley":
            raise ValueError(f"law = {params.law!r}: Drake's native mapping needs the "
                             "Hunt-Crossley law")
        b = params.damping
        unit = hunt_crossley.solve_law(HuntCrossley(m, 1.0, b), m, point.speed_m_s)
        k = m * (unit["duration_s"] / imp.duration_s) ** 2
        inputs["point_contact"] = {"stiffness_n_per_m": k, "dissipation_s_per_m": b,
                                   "duration_at_k_eq_m_s": unit["duration_s"]}
        out = {"board.point_contact_stiffness": 2 * k, "cube.point_contact_stiffness": 2 * k,
               "board.hunt_crossley_dissipation": b, "cube.hunt_crossley_dissipation": b,
               "board.mu": mu, "cube.mu": mu, "contact_model": "point",
               "discrete_contact_approximation": "tamsi", "stiction_tolerance": vs}
        rule = ("Hunt-Crossley with n = 1: d = b (the restitution at every speed), k so that "
                "the duration is the corner law's at the operating point (each geometry 2k, "
                "d); mu on both (2ab/(a+b)); stiction tolerance v_s; point contact, TAMSI")
    elif engine == "newton":
        k, d = compression_damped(m, imp.restitution, imp.duration_s)
        f_rest = RESTING_SHARE * box.mass_kg * GRAVITY_M_S2
        kf = mu * f_rest / vs
        inputs["penalty"] = {"ke_n_per_m": k, "kd_n_s_per_m": d, "kf_n_s_per_m": kf,
                             "zeta": d / (2.0 * math.sqrt(k * m)),
                             "resting_corner_force_n": f_rest}
        out = {f"{b}.{key}": val for b in ("board", "cube")
               for key, val in (("ke", k), ("kd", d), ("kf", kf), ("mu", mu))}
        rule = ("f = ke x + kd max(xdot, 0) with the corner law's restitution and duration at "
                "the operating point; mu; kf = mu m g/4 / v_s (the model's slope at zero slip "
                "under a resting corner); both shapes (averaged)")
    elif engine == "sapien":
        out = {f"{b}.{key}": val for b in ("board", "cube")
               for key, val in (("static_friction", mu), ("dynamic_friction", mu),
                                ("restitution", imp.restitution))}
        out |= {"bounce_threshold": 0.0, "cube.linear_damping": 0.0,
                "cube.angular_damping": 0.0}
        rule = ("rigid contact with the corner law's restitution at the operating point "
                "(both materials, averaged), bounce threshold 0; mu static and dynamic on "
                "both; the cube's damping 0 (PhysX has no settable contact damping)")
    else:  # dart
        out = {"board.friction_coeff": mu, "cube.friction_coeff": mu,
               "board.restitution_coeff": 1.0, "cube.restitution_coeff": imp.restitution}
        rule = ("rigid contact with the corner law's restitution at the operating point "
                "(product: board 1, cube e); mu on both (the smaller)")
    return NativeMapping(engine, out, inputs, rule)


def native_parameters(engine: str, params: BoxContactParams | None = None,
                      box: Box = DAIR_BOX, point: OperatingPoint | None = None
                      ) -> dict[str, Any]:
    """``engine``'s own parameter keys of :func:`native_mapping` (custom mode's keys)."""
    return dict(native_mapping(engine, params, box, point).params)


# ------------------------------------------------------------------------------ injected


__all__ = ["FITTED_PATH", "MODES", "NATIVE_ENGINES",
           "REFERENCE_LEVER", "REFERENCE_SPEED_M_S", "CornerImpact", "CornerWrench",
           "NativeMapping", "OperatingPoint", "compression_damped", "compression_phase",
           "corner_impact", "first_touch", "load_model",
           "measure_operating_point", "native_mapping", "native_parameters"]
